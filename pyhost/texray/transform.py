"""Object transforms: translate, rotate (Euler angles in degrees) and scale."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SceneError


def _vec3(value, field, where="", positive=False):
    try:
        v = np.asarray(value, dtype=np.float64)
        if v.ndim == 0:
            v = np.full(3, float(v))
    except (TypeError, ValueError):
        raise SceneError(f"{where}{field}: expected a number or 3 numbers, got {value!r}") from None
    if v.shape != (3,):
        raise SceneError(f"{where}{field}: expected 3 numbers, got {value!r}")
    if not np.all(np.isfinite(v)):
        raise SceneError(f"{where}{field}: values must be finite, got {value!r}")
    if positive and np.any(v == 0):
        raise SceneError(f"{where}{field}: a scale of zero flattens the object, got {value!r}")
    return v


@dataclass
class Transform:
    """Scale, then rotate about x, y, z (degrees, in that order), then translate."""
    translate: tuple = (0.0, 0.0, 0.0)
    rotate: tuple = (0.0, 0.0, 0.0)
    scale: object = 1.0

    def matrix(self, where="") -> np.ndarray:
        """The 4x4 float64 matrix acting on column vectors."""
        t = _vec3(self.translate, "translate", where)
        r = np.radians(_vec3(self.rotate, "rotate", where))
        s = _vec3(self.scale, "scale", where, positive=True)
        cx, cy, cz = np.cos(r)
        sx, sy, sz = np.sin(r)
        rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        m = np.eye(4)
        m[:3, :3] = rz @ ry @ rx @ np.diag(s)
        m[:3, 3] = t
        return m


def apply_points(m, p):
    """Transform (N, 3) points by the 4x4 matrix m."""
    return p @ m[:3, :3].T + m[:3, 3]


def apply_normals(m, n):
    """Transform (N, 3) normals by the inverse transpose of m and renormalize (zero stays zero)."""
    out = n @ np.linalg.inv(m[:3, :3])
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, length, out=np.zeros_like(out), where=length > 0)
