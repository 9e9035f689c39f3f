"""The lecture's sphere: its parameterization, validation, bounds and device records."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..device import layout
from .. import validate as V
from .material import Material
from .shape import DeviceRecords, check_curved_displacement, check_extent, placed
from .transform import Transform


class SphereWorld(NamedTuple):
    """A sphere in world space, float64."""
    center: np.ndarray
    radius: float
    x: np.ndarray          # axis_x: phi = 0
    z: np.ndarray          # axis_z: the pole theta = 0


@dataclass
class Sphere:
    """A sphere with the lecture's parameterization: theta (polar, from axis_z) and
    phi (azimuth, from axis_x toward axis_z x axis_x); texture uv = (phi/2pi, 1 - theta/pi).
    A radius <= 0 is an error."""
    center: tuple = (0.0, 0.0, 0.0)
    radius: float = 1.0
    material: Material = field(default_factory=Material)
    axis_z: tuple = (0.0, 0.0, 1.0)
    axis_x: tuple = (1.0, 0.0, 0.0)
    transform: Transform | None = None
    name: str = "<sphere>"
    mapping: object = None

    PRIM = layout.PRIM_SPHERE

    def __post_init__(self):
        self.world()

    def validate(self):
        """Check every field again (they may have been changed since the shape was made)."""
        self.world()
        return self

    def world(self) -> SphereWorld:
        """The sphere in world space (validating every field)."""
        where = f"{self.name}: "
        r = V.number(self.radius, "radius", where, 0.0, lo_open=True, limit=V.COORD_LIMIT)
        c, k, x, z = placed(self, V.point(self.center, "center", where), where)
        check_extent(np.stack([c - r * k, c + r * k]), where, "center, radius")
        check_curved_displacement(self, r * k, "centre of a sphere", where)
        return SphereWorld(c, r * k, x, z)

    # --- the parameterization (kernels/geometry: the device's one copy) ---------------
    def surface(self, u, v):
        """(P, n) at uv = (phi / 2pi, 1 - theta / pi), float64 (..., 3)."""
        c, radius, ax, az = self.world()
        ay = np.cross(az, ax)
        phi, theta = 2 * np.pi * np.asarray(u)[..., None], np.pi * (1 - np.asarray(v)[..., None])
        n = np.sin(theta) * (np.cos(phi) * ax + np.sin(phi) * ay) + np.cos(theta) * az
        return np.asarray(c) + radius * n, n

    def texture_uv(self, u, v):
        """Texture coordinates at the parameters (u, v): the same."""
        return np.stack([u, v], axis=-1)

    # --- device records -------------------------------------------------------------
    def device_records(self, material, object_id) -> DeviceRecords:
        """layout.SPHERE, and the box of its float32 centre and radius."""
        c, r, x, z = self.world()
        s = np.zeros(1, layout.SPHERE)
        s["center"], s["radius"], s["axis_x"], s["axis_z"] = c, r, x, z
        s["material"], s["object"] = material, object_id
        c32, r32 = s["center"][0].astype(np.float64), np.float64(s["radius"][0])
        return DeviceRecords({"spheres": s}, c32 - r32, c32 + r32)

    def displaced_record(self, rec, hmin, hmax):
        """Fill the shape's fields of the layout.DISPLACED record ``rec``; the (lo, hi) box
        of the shell [r + hmin, r + hmax] (Sphere.world checked the method and the lowest
        height)."""
        c, rad, x, z = self.world()
        rec["shape"], rec["p"], rec["radius"], rec["e0"], rec["e1"], rec["n"] = (layout.DISP_SPHERE, c, rad, x,
                                                                                 np.cross(z, x), z)
        return c - (rad + hmax), c + (rad + hmax)
