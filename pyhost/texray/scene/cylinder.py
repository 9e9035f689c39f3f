"""The lecture's partial open cylinder: its parameterization, validation, bounds and
device records."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..device import layout
from .. import validate as V
from .material import Material
from .shape import DeviceRecords, check_curved_displacement, check_extent, circle_extent, placed
from .transform import Transform


class CylinderWorld(NamedTuple):
    """A cylinder in world space, float64; ranges scaled by the transform, theta in radians."""
    origin: np.ndarray
    radius: float
    x: np.ndarray          # axis_x: theta = 0
    z: np.ndarray          # the axis
    z_range: tuple
    theta_range: tuple


@dataclass
class Cylinder:
    """The lecture's partial open cylinder: radius r around axis_z through origin,
    z in z_range, theta in theta_range (degrees, from axis_x); texture
    uv = ((theta - theta_min) / (theta_max - theta_min), (z - z_min) / (z_max - z_min)).
    An empty z or theta range is an error."""
    radius: float = 1.0
    z_range: tuple = (0.0, 1.0)
    theta_range: tuple = (0.0, 360.0)
    origin: tuple = (0.0, 0.0, 0.0)
    axis_z: tuple = (0.0, 0.0, 1.0)
    axis_x: tuple = (1.0, 0.0, 0.0)
    material: Material = field(default_factory=Material)
    transform: Transform | None = None
    name: str = "<cylinder>"
    mapping: object = None

    PRIM = layout.PRIM_CYLINDER

    def __post_init__(self):
        self.world()

    def validate(self):
        """Check every field again (they may have been changed since the shape was made)."""
        self.world()
        return self

    def world(self) -> CylinderWorld:
        """The cylinder in world space (validating every field)."""
        where = f"{self.name}: "
        r = V.number(self.radius, "radius", where, 0.0, lo_open=True, limit=V.COORD_LIMIT)
        zr = V.vector(self.z_range, 2, "z_range", where, limit=V.COORD_LIMIT)
        if not zr[0] < zr[1]:
            V.fail(where, "z_range", "[z_min, z_max] with z_min < z_max", self.z_range)
        tr = V.vector(self.theta_range, 2, "theta_range", where, limit=V.COORD_LIMIT)
        if not tr[0] < tr[1] or tr[1] - tr[0] > 360:
            V.fail(where, "theta_range", "[min, max] degrees with min < max <= min + 360", self.theta_range)
        o, k, x, z = placed(self, V.point(self.origin, "origin", where), where)
        ends = o + np.outer(zr * k, z)
        check_extent(np.concatenate([ends - r * k, ends + r * k]), where, "origin, radius, z_range")
        check_curved_displacement(self, r * k, "axis of a cylinder", where)
        return CylinderWorld(o, r * k, x, z, tuple(zr * k), tuple(np.radians(tr)))

    # --- the parameterization ------------------------------------------------------
    def surface(self, u, v):
        """(P, n) at uv = ((theta - theta_min) / span, (z - z_min) / (z_max - z_min)), float64."""
        origin, radius, ax, az, z_range, theta_range = self.world()
        ay = np.cross(az, ax)
        th = theta_range[0] + (theta_range[1] - theta_range[0]) * np.asarray(u)[..., None]
        z = z_range[0] + (z_range[1] - z_range[0]) * np.asarray(v)[..., None]
        n = np.cos(th) * ax + np.sin(th) * ay
        return np.asarray(origin) + radius * n + z * az, n

    def texture_uv(self, u, v):
        """Texture coordinates at the parameters (u, v): the same."""
        return np.stack([u, v], axis=-1)

    # --- device records -------------------------------------------------------------
    def device_records(self, material, object_id) -> DeviceRecords:
        """layout.CYLINDER, and the box of its two end circles."""
        o, r, x, z, (z0, z1), (t0, t1) = self.world()
        cy = np.zeros(1, layout.CYLINDER)
        cy["origin"], cy["radius"], cy["axis_x"], cy["axis_z"] = o, r, x, z
        cy["z_min"], cy["z_max"], cy["theta_min"], cy["theta_max"] = z0, z1, t0, t1
        cy["material"], cy["object"] = material, object_id
        ends = o + np.outer([z0, z1], z)
        ext = circle_extent(r, z)
        return DeviceRecords({"cylinders": cy}, ends.min(axis=0) - ext, ends.max(axis=0) + ext)

    def displaced_record(self, rec, hmin, hmax):
        """Fill the shape's fields of the layout.DISPLACED record ``rec``; the (lo, hi) box
        of the shell of radius r + hmax around the axis."""
        o, rad, x, z, (z0, z1), (t0, t1) = self.world()
        rec["shape"], rec["p"], rec["radius"], rec["e0"], rec["e1"], rec["n"] = (layout.DISP_CYLINDER, o, rad, x,
                                                                                 np.cross(z, x), z)
        rec["z_min"], rec["z_max"], rec["theta_min"], rec["theta_max"] = z0, z1, t0, t1
        ends = o + np.outer([z0, z1], z)
        ext = circle_extent(rad + hmax, z)
        return ends.min(axis=0) - ext, ends.max(axis=0) + ext
