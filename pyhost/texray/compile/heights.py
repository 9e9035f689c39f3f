"""Device packing of displacement height fields: unorm16 texels and their min-max
MIP pyramids in one buffer (layout.DISPLACED records address it)."""
from __future__ import annotations

import numpy as np

from ..device import layout
from ..scene.heightfield import wrap_index

METHOD_IDS = {"search": layout.DISP_SEARCH, "maxmip": layout.DISP_MAXMIP}   # layout.DISPLACED.method
METHOD_ADAPTIVE = layout.DISP_ADAPTIVE                                     # its adaptive-steps bit


def minmax_pyramid(heights, wrap="repeat"):
    """Min-max MIP pyramid of the bilinear interpolant: [float64 (CH_l, CW_l, 2)] per level.

    Level 0 has one cell per pair of adjacent texel centres, (H + 1) x (W + 1) cells:
    cell (cy, cx) spans x = u W + 1/2 in [cx, cx + 1] and y = (1 - v) H + 1/2 in
    [cy, cy + 1], with texels (cx - 1, cx) x (cy - 1, cy) (wrapped) at its corners,
    so (min, max) of its four corners bound the interpolant exactly. Level l + 1
    halves each side (rounding up) taking min / max over 2 x 2 cells; the last
    level is one cell holding the global range.
    """
    h, w = heights.shape
    cols = wrap_index(np.arange(-1, w + 1), w, wrap)
    rows = wrap_index(np.arange(-1, h + 1), h, wrap)
    g = heights[np.ix_(rows, cols)]
    corners = np.stack([g[:-1, :-1], g[:-1, 1:], g[1:, :-1], g[1:, 1:]])
    level = np.stack([corners.min(axis=0), corners.max(axis=0)], axis=-1)
    levels = [level]
    while level.shape[0] > 1 or level.shape[1] > 1:
        ch, cw = level.shape[:2]
        ph, pw = ch + (ch & 1) * (ch > 1), cw + (cw & 1) * (cw > 1)
        lo = np.full((ph, pw), np.inf)
        hi = np.full((ph, pw), -np.inf)
        lo[:ch, :cw], hi[:ch, :cw] = level[..., 0], level[..., 1]
        sh, sw = (2 if ph > 1 else 1), (2 if pw > 1 else 1)
        lo = lo.reshape(ph // sh, sh, pw // sw, sw).min(axis=(1, 3))
        hi = hi.reshape(ph // sh, sh, pw // sw, sw).max(axis=(1, 3))
        level = np.stack([lo, hi], axis=-1)
        levels.append(level)
    return levels


UNORM = 65535        # the stored heights: unorm16 over each field's [hmin, hmax]


def quantize(h):
    """float64 heights -> uint16 q with H = hmin + q (hmax - hmin) / 65535: 2 bytes per
    texel, like a half float, but with a uniform absolute error of at most (hmax - hmin) /
    131070 where a half's grows with |H| (2^-11 H, 32x more near hmax); exact for the full
    range of 8- and 16-bit textures. A constant field stores zeros."""
    lo, hi = float(h.min()), float(h.max())
    if hi <= lo:
        return np.zeros(h.shape, np.uint16)
    return np.round((h - lo) / (hi - lo) * UNORM).astype(np.uint16)


def pack_heights(displacements):
    """One uint16 buffer for the device: per distinct height field, its H x W texels
    (:func:`quantize`d over its [hmin, hmax], which the DISPLACED record holds; row 0 on
    top) then the min-max pyramid of those stored values (interleaved min, max; level
    after level): the device dequantizes both alike, monotonically, so the pyramid bounds
    its interpolant exactly. Returns (buffer, {key: (texel offset, pyramid offset, levels)})."""
    parts, index, n = [], {}, 0
    for d in displacements:
        key = height_key(d)
        if key in index:
            continue
        q = quantize(d.heights())
        pyr = minmax_pyramid(q.astype(np.float64), d.wrap)
        flat = [q.ravel()] + [lv.reshape(-1) for lv in pyr]
        index[key] = (n, n + q.size, len(pyr))
        parts.extend(flat)
        n += sum(a.size for a in flat)
    if not parts:
        return None, index
    return np.concatenate(parts).astype(np.uint16), index


def height_key(d):
    return (id(d.texture.raw), d.wrap, float(d.scale), float(d.offset))
