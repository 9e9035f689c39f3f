"""Procedural textures for texray (pure, vectorized numpy), and the checks of their
parameters (Texture.procedural, scene files).

Every texture is a ``float32`` array of shape ``(H, W, C)`` with values in
``[0, 1]``; row 0 is the TOP row of the image (image order, as written to a
file). Colours are display (sRGB-encoded) values; heights are plain data.
``size`` is an ``int`` (square) or an ``(height, width)`` pair. Textures are
deterministic given their arguments (including ``seed``) and, unless stated
otherwise, tile seamlessly.
"""
from __future__ import annotations

import inspect

import numpy as np

from ..errors import SceneError
from .. import validate as V

__all__ = ["value_noise", "checker", "wood", "marble", "bricks", "bricks_height", "tiles", "globe", "label"]

def _hw(size):
    """(height, width) from an int or a (height, width) pair."""
    if np.ndim(size) == 0:
        return int(size), int(size)
    h, w = size
    return int(h), int(w)


def _pixel_coords(h, w):
    """Pixel-centre image coordinates (x, y) in [0, 1), y = 0 at the top;
    shapes (1, w) and (h, 1)."""
    return (np.arange(w)[None, :] + 0.5) / w, (np.arange(h)[:, None] + 0.5) / h


def _smooth(t):
    """Quintic fade 6t^5 - 15t^4 + 10t^3 (C2 value-noise interpolation)."""
    return t * t * t * (t * (6.0 * t - 15.0) + 10.0)


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _lattice(h, w, cy, cx, rng):
    """One octave of tileable value noise: a (cy, cx) periodic lattice of
    uniform random values, quintic-interpolated to (h, w), in [0, 1]."""
    lat = rng.random((cy, cx))

    def axis(n, c):
        x = np.arange(n) * (c / n)
        i0 = np.floor(x).astype(np.int64)
        return i0 % c, (i0 + 1) % c, _smooth(x - i0)

    y0, y1, wy = axis(h, cy)
    x0, x1, wx = axis(w, cx)
    rows = lat[y0] * (1 - wy)[:, None] + lat[y1] * wy[:, None]    # (h, cx)
    return rows[:, x0] * (1 - wx) + rows[:, x1] * wx


def _fbm(h, w, cells, octaves, seed, persistence=0.5):
    """Fractal sum of tileable value noise, (h, w) float64 in [0, 1].

    cells: lattice cells (cy, cx) of the first octave over the whole image
    (different values stretch the noise); each octave doubles them.
    """
    rng = np.random.default_rng(seed)
    cy, cx = (cells, cells) if np.ndim(cells) == 0 else cells
    total, norm = np.zeros((h, w)), 0.0
    for o in range(octaves):
        amp = persistence ** o
        total += amp * _lattice(h, w, cy << o, cx << o, rng)
        norm += amp
    return total / norm


def _as_texture(*channels):
    """Stack (h, w) channels into a clipped float32 (h, w, C) texture."""
    return np.clip(np.stack(channels, -1), 0.0, 1.0).astype(np.float32)


def _mix(c0, c1, t):
    """Blend two RGB colours by t (h, w) -> (h, w, 3)."""
    c0, c1 = np.asarray(c0, np.float64), np.asarray(c1, np.float64)
    return c0 + (c1 - c0) * np.asarray(t)[..., None]


def value_noise(size, octaves=5, seed=0, cells=4, persistence=0.5):
    """Tileable fractal value noise, (H, W, 1) float32 in [0, 1].

    cells: lattice cells across the image for the first octave (int or
    (cy, cx)); octave o has cells * 2**o and weight persistence**o. The noise
    is periodic with the image size in both directions (seamless tiling).
    """
    h, w = _hw(size)
    return _as_texture(_fbm(h, w, cells, octaves, seed, persistence))


def checker(size=512, n_checks=8, c0=(0.9, 0.9, 0.85), c1=(0.15, 0.2, 0.3)):
    """Checkerboard, (H, W, 3) float32: n_checks squares (int or (ny, nx))
    across the image; the square at UV (0, 0) (bottom-left) has colour c0."""
    h, w = _hw(size)
    ny, nx = (n_checks, n_checks) if np.ndim(n_checks) == 0 else n_checks
    x, y = _pixel_coords(h, w)
    parity = (np.floor(x * nx) + np.floor((1.0 - y) * ny)) % 2
    rgb = _mix(c0, c1, np.broadcast_to(parity, (h, w)))
    return _as_texture(*np.moveaxis(rgb, -1, 0))


def wood(size=512, seed=0, n_rings=18, light=(0.80, 0.57, 0.34),
         dark=(0.42, 0.22, 0.09)):
    """Flat-sawn plank, (H, W, 3) float32; grain runs vertically (along v).

    The plank cuts a log whose axis runs along the image's columns: the
    distance to the axis, sqrt(across^2 + depth^2), with across ~
    sin(pi (x - 1/2)) (periodic) and a noisy depth, gives the growth rings
    (n_rings per unit of that distance; light early wood, dark late wood) as
    nested arches. Fine fibres and pores come from noise stretched along the
    grain. Tileable.
    """
    h, w = _hw(size)
    x, y = _pixel_coords(h, w)
    across = 0.8 * np.sin(np.pi * (x - 0.5))
    depth = (0.33 + 0.4 * (_fbm(h, w, (2, 1), 3, seed) - 0.5)
             + 0.06 * np.sin(2 * np.pi * y))
    warp = _fbm(h, w, (3, 4), 4, seed + 1) - 0.5
    phase = n_rings * np.sqrt(across ** 2 + depth ** 2) + 0.35 * warp
    t = phase - np.floor(phase)
    late = _smoothstep(0.35, 0.93, t) ** 2 * (1.0 - _smoothstep(0.93, 1.0, t))
    fibres = _fbm(h, w, (3, 128), 4, seed + 2)
    pores = _smoothstep(0.62, 0.8, _fbm(h, w, (16, 256), 2, seed + 3))
    tone = 0.8 * late + 0.35 * (fibres - 0.5) + 0.25 * pores * (0.3 + 0.7 * late)
    rgb = _mix(light, dark, np.clip(tone, 0.0, 1.0))
    rgb *= (0.88 + 0.24 * _fbm(h, w, (2, 3), 4, seed + 4))[..., None]
    return _as_texture(*np.moveaxis(rgb, -1, 0))


def marble(size=512, seed=0, n_veins=3, base=(0.93, 0.92, 0.9),
           vein=(0.3, 0.32, 0.36)):
    """White marble with dark turbulent veins, (H, W, 3) float32; tileable."""
    h, w = _hw(size)
    x, y = _pixel_coords(h, w)
    turb = _fbm(h, w, 3, 6, seed, 0.55)
    s = 1.0 - np.abs(np.sin(np.pi * (n_veins * (x + y) + 2.0 * turb)))
    veins = 0.7 * s ** 12 + 0.25 * s ** 3
    cloud = _fbm(h, w, 4, 5, seed + 1)
    rgb = _mix(base, vein, veins + 0.12 * cloud)
    return _as_texture(*np.moveaxis(rgb, -1, 0))


def _brick_layout(h, w, n_rows, n_cols, offset):
    """Per-pixel brick id (h, w) and distance to the brick's edge (h, w) in
    units of brick height. Row r of bricks is shifted by offset * (r % 2)
    brick widths; ids wrap so the layout tiles when n_rows is even."""
    x, y = _pixel_coords(h, w)
    ys = y * n_rows
    row = np.floor(ys).astype(np.int64)
    fy = ys - row
    xs = x * n_cols + offset * (row % 2)
    col = np.floor(xs).astype(np.int64)
    fx = xs - col
    aspect = (w / n_cols) / (h / n_rows)            # brick width / height
    dist = np.minimum(np.minimum(fx, 1 - fx) * aspect, np.minimum(fy, 1 - fy))
    return row * n_cols + col % n_cols, dist


def _brick_profile(dist, mortar, bevel):
    """0 in the mortar, rising smoothly to 1 over ``bevel`` (brick heights)."""
    return _smoothstep(0.5 * mortar, 0.5 * mortar + bevel, dist)


def bricks(size=512, n_rows=8, n_cols=4, mortar=0.12, bevel=0.1, seed=0,
           offset=0.5, brick=(0.55, 0.27, 0.2), mortar_color=(0.7, 0.68, 0.64),
           variation=0.25):
    """Running-bond brick wall, (H, W, 3) float32.

    n_rows x n_cols bricks across the image (n_rows even for seamless
    tiling); mortar: joint width and bevel: edge rounding, both in brick
    heights; offset: shift of odd rows in brick widths; variation: random
    per-brick brightness/hue spread.
    """
    h, w = _hw(size)
    ids, dist = _brick_layout(h, w, n_rows, n_cols, offset)
    rng = np.random.default_rng(seed)
    jitter = rng.uniform(-1, 1, (n_rows * n_cols, 3)) * [1.0, 0.6, 0.5]
    tint = 1.0 + variation * (jitter[:, :1] + 0.3 * jitter)      # per brick
    grit = _fbm(h, w, 16, 5, seed + 1, 0.65)[..., None]
    face = np.asarray(brick) * tint[ids] * (0.8 + 0.4 * grit)
    edge = _brick_profile(dist, mortar, bevel)[..., None]
    face *= 0.75 + 0.25 * edge                                    # darker bevel
    joint = np.asarray(mortar_color) * (0.85 + 0.3 * grit)
    mask = _brick_profile(dist, mortar, 0.02)[..., None]
    rgb = joint + (face - joint) * mask
    return _as_texture(*np.moveaxis(rgb, -1, 0))


def bricks_height(size=512, n_rows=8, n_cols=4, mortar=0.12, bevel=0.1,
                  seed=0, offset=0.5, roughness=0.08):
    """Height map matching :func:`bricks` (same layout arguments), (H, W, 1)
    float32: 0 in the mortar, 1 on brick faces with a smooth bevel; the
    faces carry noise of relative depth ``roughness``."""
    h, w = _hw(size)
    _, dist = _brick_layout(h, w, n_rows, n_cols, offset)
    grit = _fbm(h, w, 16, 5, seed + 1, 0.65)
    height = _brick_profile(dist, mortar, bevel) * (1.0 - roughness * grit)
    return _as_texture(height)


def tiles(size=512, n=6, grout=0.06, bevel=0.05, seed=0,
          tile=(0.25, 0.45, 0.6), grout_color=(0.85, 0.84, 0.8),
          variation=0.2):
    """Square glazed tiles, n x n across the image, (H, W, 3) float32: a
    :func:`bricks` layout without offset. Tileable."""
    return bricks(size, n, n, mortar=grout, bevel=bevel, seed=seed, offset=0.0,
                  brick=tile, mortar_color=grout_color, variation=variation)


def globe(size=(512, 1024), seed=5, sea_level=0.52):
    """An invented planet as an equirectangular map, (H, W, 3) float32: longitude
    along columns (phi = 0 at the left edge), the north pole on the top row.
    Continents from fractal noise (land above ``sea_level``), shading by height,
    polar ice, and a graticule every 30 degrees so that mapping errors show."""
    h, w = _hw(size)
    x, y = _pixel_coords(h, w)
    height = _fbm(h, w, (3, 6), 6, seed)
    lat = (0.5 - y) * np.pi                                 # +pi/2 at the top row
    land = height > sea_level
    depth = np.clip((sea_level - height) / sea_level, 0, 1)
    sea = _mix((0.05, 0.25, 0.55), (0.01, 0.06, 0.25), depth ** 0.7)
    relief = np.clip((height - sea_level) / (1 - sea_level), 0, 1)
    ground = _mix((0.20, 0.45, 0.15), (0.55, 0.42, 0.25), np.clip(relief * 2.2, 0, 1))
    rgb = np.where(land[..., None], ground, sea)
    ice = np.abs(lat) > np.radians(72) - 0.15 * (height - 0.5)
    rgb = np.where(ice[..., None], 0.92, rgb)
    lon_deg, lat_deg = x * 360.0, np.degrees(lat)
    near = lambda v, step, width: np.abs(((v + step / 2) % step) - step / 2) < width
    grid = near(lon_deg, 30.0, 0.35 * 720 / w) | near(lat_deg + 0 * lon_deg, 30.0, 0.35 * 360 / h)
    rgb = np.where(grid[..., None], rgb * 0.55 + 0.45, rgb)
    return _as_texture(rgb[..., 0], rgb[..., 1], rgb[..., 2])


def label(size=(256, 512), seed=2, color=(0.85, 0.12, 0.1), ink=(0.98, 0.95, 0.85)):
    """A can label, (H, W, 4) float32 RGBA: a coloured band with a ring emblem,
    stripes and a border; alpha is 1 inside the band's rounded rectangle and 0
    outside, for the lecture's 'texture used as a label'."""
    h, w = _hw(size)
    x, y = _pixel_coords(h, w)
    x, y = x + 0 * y, y + 0 * x
    rgb = _mix(color, np.multiply(color, 0.6), np.clip((np.abs(y - 0.5) - 0.3) * 5, 0, 1))
    cx, cy = 0.5, 0.5
    r = np.hypot((x - cx) * w / h, y - cy)
    emblem = (np.abs(r - 0.28) < 0.03) | (r < 0.12) | ((np.abs(r - 0.2) < 0.012))
    stripes = (np.abs(y - 0.15) < 0.02) | (np.abs(y - 0.85) < 0.02)
    ink_mask = emblem | stripes
    rgb = np.where(ink_mask[..., None], np.asarray(ink), rgb)
    grain = _fbm(h, w, (4, 8), 4, seed)
    rgb = rgb * (0.9 + 0.2 * grain)[..., None]
    inset = 0.04
    qx = np.maximum(np.abs(x - 0.5) - (0.5 - 2 * inset), 0) * w / h
    qy = np.maximum(np.abs(y - 0.5) - (0.5 - 2 * inset), 0)
    alpha = (np.hypot(qx, qy) < inset).astype(np.float64)
    return _as_texture(rgb[..., 0], rgb[..., 1], rgb[..., 2], alpha)


# =============================================================================
# Parameter checks of the texture generators (Texture.procedural, scene files)
# =============================================================================

MAX_TEXTURE_SIDE = 8192           # texels per side of a generated texture
MAX_TEXTURE_TEXELS = 1 << 24      # texels in all (float64 intermediates: ~1 GiB at this size)
MAX_COUNT = 1024                  # checks, bricks, tiles, noise cells... across a texture
MAX_OCTAVES = 16

# Parameters by role; a generator's other parameters are colours (3 numbers in [0, 1]).
_COUNTS = ("n_checks", "cells")             # an int or an (ny, nx) pair, >= 1
_INT_COUNTS = ("n_rows", "n_cols", "n")     # an int >= 1
_FRACTIONS = ("mortar", "grout", "variation", "roughness", "sea_level")   # in [0, 1]
_POSITIVE_FRACTIONS = ("bevel", "persistence")                    # in (0, 1]
_AMOUNTS = ("n_rings", "n_veins")                                 # numbers in [0, MAX_COUNT]


def check_texture_params(fn, params, where):
    """SceneError naming ``where``PARAM unless ``params`` suit generator ``fn`` (known names,
    sizes within MAX_TEXTURE_SIDE / MAX_TEXTURE_TEXELS, counts >= 1, fractions in range)."""
    known = inspect.signature(fn).parameters
    for key, value in params.items():
        if key not in known:
            raise SceneError(f"{where}{key}: not a parameter of {fn.__name__} (allowed: {', '.join(known)})")
        if key == "size":
            hw = V.vector(value, 2, key, where, broadcast=True, positive=True)
            if not np.all(hw == np.round(hw)) or not all(_is_int(v) for v in np.atleast_1d(value)):
                V.fail(where, key, "an integer or (height, width) integers >= 1", value)
            if hw.max() > MAX_TEXTURE_SIDE or hw.prod() > MAX_TEXTURE_TEXELS:
                V.fail(where, key, f"at most {MAX_TEXTURE_SIDE} texels a side and {MAX_TEXTURE_TEXELS} in all",
                       value)
        elif key == "seed":
            V.integer(value, key, where, 0, 2**63 - 1)
        elif key == "octaves":
            V.integer(value, key, where, 1, MAX_OCTAVES)
        elif key in _INT_COUNTS:
            V.integer(value, key, where, 1, MAX_COUNT)
        elif key in _COUNTS:
            pair = V.vector(value, 2, key, where, broadcast=True)
            if not all(_is_int(v) for v in np.atleast_1d(value)) or pair.min() < 1 or pair.max() > MAX_COUNT:
                V.fail(where, key, f"an integer or a pair of integers in [1, {MAX_COUNT}]", value)
        elif key in _FRACTIONS:
            V.number(value, key, where, 0.0, 1.0)
        elif key in _POSITIVE_FRACTIONS:
            V.number(value, key, where, 0.0, 1.0, lo_open=True)
        elif key in _AMOUNTS:
            V.number(value, key, where, 0.0, MAX_COUNT)
        elif key == "offset":
            V.number(value, key, where, -MAX_COUNT, MAX_COUNT)
        else:
            V.vector(value, 3, key, where, nonneg=True)
            if np.any(np.asarray(value, dtype=np.float64) > 1):
                V.fail(where, key, "an RGB colour, 3 numbers in [0, 1]", value)
    octaves = params.get("octaves", known["octaves"].default if "octaves" in known else 1)
    cells = params.get("cells", known["cells"].default if "cells" in known else 1)
    if "cells" in known and np.max(cells) * 2 ** (octaves - 1) > MAX_COUNT:
        raise SceneError(f"{where}cells, octaves: the finest octave has {V.show(cells)} x 2^{octaves - 1} "
                         f"lattice cells; at most {MAX_COUNT}")


def _is_int(v):
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
