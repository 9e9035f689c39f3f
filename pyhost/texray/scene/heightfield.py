"""The height field H(u, v) of a Displacement as float64 numpy: the bilinear
interpolant of its texels with the conventions of ``kernels/texture/texture.h`` (u along
columns, v = 0 the bottom row, texel centres at ((i + 0.5) / W, 1 - (j + 0.5) / H),
the wrap mode outside). The reference of the device's lookups and the tessellation's
heights."""
from __future__ import annotations

import numpy as np


def wrap_index(i, n, mode):
    """kernels/texture/wrap.h wrap_index, vectorized: any integer texel index -> [0, n - 1]."""
    i = np.asarray(i, dtype=np.int64)
    if n <= 1:
        return np.zeros_like(i)
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    if mode == "mirror":
        r = np.mod(i, 2 * n)
        return np.where(r < n, r, 2 * n - 1 - r)
    return np.mod(i, n)


def _taps(heights, u, v, wrap):
    h, w = heights.shape
    x = np.asarray(u, np.float64) * w - 0.5
    y = (1.0 - np.asarray(v, np.float64)) * h - 0.5
    fx, fy = np.floor(x), np.floor(y)
    ax, ay = x - fx, y - fy
    x0, x1 = wrap_index(fx.astype(np.int64), w, wrap), wrap_index(fx.astype(np.int64) + 1, w, wrap)
    y0, y1 = wrap_index(fy.astype(np.int64), h, wrap), wrap_index(fy.astype(np.int64) + 1, h, wrap)
    return (heights[y0, x0], heights[y0, x1], heights[y1, x0], heights[y1, x1]), ax, ay, w, h


def height(heights, u, v, wrap="repeat"):
    """H(u, v): the bilinear interpolant of ``heights`` (float64 (H, W), row 0 on top)."""
    (t00, t10, t01, t11), ax, ay, _, _ = _taps(heights, u, v, wrap)
    return (t00 * (1 - ax) + t10 * ax) * (1 - ay) + (t01 * (1 - ax) + t11 * ax) * ay


def height_gradient(heights, u, v, wrap="repeat"):
    """(dH/du, dH/dv) of the interpolant (exact; piecewise linear across texel cells)."""
    (t00, t10, t01, t11), ax, ay, w, h = _taps(heights, u, v, wrap)
    dx = (t10 - t00) * (1 - ay) + (t11 - t01) * ay
    dy = (t01 - t00) * (1 - ax) + (t11 - t10) * ax
    return dx * w, -dy * h
