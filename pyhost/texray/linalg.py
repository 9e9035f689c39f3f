"""Affine maps applied to arrays of points and normals (float64 numpy): what the
scene's transforms, mesh files' node graphs and projection frames share."""
from __future__ import annotations

import numpy as np


def apply_points(m, p):
    """Transform (N, 3) points by the 4x4 matrix m."""
    return p @ m[:3, :3].T + m[:3, 3]


def apply_normals(m, n):
    """Transform (N, 3) normals by the inverse transpose of m and renormalize (zero stays zero)."""
    out = n @ np.linalg.inv(m[:3, :3])
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, length, out=np.zeros_like(out), where=length > 0)
