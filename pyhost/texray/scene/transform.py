"""Object transforms: translate, rotate (Euler angles in degrees) and scale."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..validate import COORD_LIMIT, FLT_MAX, show, vector


def _vec3(value, field, where="", positive=False, limit=FLT_MAX):
    """A number or 3 numbers as a float64 (3,) array (texray.validate.vector); ``positive``:
    none may be zero (a scale)."""
    v = vector(value, 3, field, where, broadcast=True, limit=limit)
    if positive and np.any(v == 0):
        raise SceneError(f"{where}{field}: a scale of zero flattens the object, got {show(value)}")
    return v


@dataclass
class Transform:
    """Scale, then rotate about x, y, z (degrees, in that order), then translate."""
    translate: tuple = (0.0, 0.0, 0.0)
    rotate: tuple = (0.0, 0.0, 0.0)
    scale: object = 1.0

    def __post_init__(self):
        self.matrix()

    def matrix(self, where="") -> np.ndarray:
        """The 4x4 float64 matrix acting on column vectors."""
        t = _vec3(self.translate, "translate", where, limit=COORD_LIMIT)
        r = np.radians(_vec3(self.rotate, "rotate", where))
        s = _vec3(self.scale, "scale", where, positive=True, limit=COORD_LIMIT)
        cx, cy, cz = np.cos(r)
        sx, sy, sz = np.sin(r)
        rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        m = np.eye(4)
        m[:3, :3] = rz @ ry @ rx @ np.diag(s)
        m[:3, 3] = t
        return m
