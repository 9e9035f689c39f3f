"""The pinhole camera."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from .. import validate as V


# Smallest sine of the angle between the viewing direction and `up` that still gives a
# well-defined image orientation (the camera's right axis is their cross product).
_MIN_UP_SINE = 1e-9


@dataclass
class Camera:
    """Pinhole camera at ``eye`` looking at ``look_at``; ``fov_y`` is the vertical field of view in degrees."""
    eye: tuple = (0.0, 0.0, 5.0)
    look_at: tuple = (0.0, 0.0, 0.0)
    up: tuple = (0.0, 1.0, 0.0)
    fov_y: float = 40.0

    def __post_init__(self):
        self.basis(1.0)

    def basis(self, aspect: float, where="camera."):
        """(eye, forward, right, up) with right/up scaled so that NDC (+-1, +-1) hits the image corners."""
        eye = V.point(self.eye, "eye", where)
        look = V.point(self.look_at, "look_at", where)
        up = V.vector(self.up, 3, "up", where)
        fov = V.number(self.fov_y, "fov_y", where, 0.0, 179.0, lo_open=True)
        fwd = look - eye
        if np.linalg.norm(fwd) == 0:
            raise SceneError(f"{where}look_at: equals eye {V.show(eye)}; the camera has no direction")
        fwd /= np.linalg.norm(fwd)
        if not np.any(up != 0):
            raise SceneError(f"{where}up: expected a non-zero vector, got {V.show(self.up)}")
        up = up / np.abs(up).max()          # scaled first: the norm of (0, 1e-300, 0) underflows
        right = np.cross(fwd, up / np.linalg.norm(up))
        if np.linalg.norm(right) < _MIN_UP_SINE:
            raise SceneError(f"{where}up: {V.show(self.up)} is parallel to the viewing direction "
                             f"{V.show(fwd)}")
        right /= np.linalg.norm(right)
        true_up = np.cross(right, fwd)
        h = np.tan(np.radians(fov) / 2)
        return eye, fwd, right * h * aspect, true_up * h
