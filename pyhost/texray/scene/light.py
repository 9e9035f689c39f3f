"""Point lights."""
from __future__ import annotations

from dataclasses import dataclass

from .. import validate as V


@dataclass
class PointLight:
    """Point light; irradiance falls off as intensity / d^2 (the lecture's I_i / d_i^2)."""
    position: tuple
    intensity: tuple = (10.0, 10.0, 10.0)

    def __post_init__(self):
        self.validate()

    def validate(self, where="light."):
        return V.point(self.position, "position", where), V.rgb(self.intensity, "intensity", where)
