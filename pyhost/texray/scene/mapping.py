"""Projection mappings, UV transforms and wrap modes: the host side of
``kernels/texture/mapping.h`` and ``kernels/texture/wrap.h``.

* :class:`Projection` -- planar, cylindrical or spherical texture coordinates
  computed from a point's position in an object-space frame (the lecture's
  three "common texture coordinate mappings").
* :class:`UVTransform` -- scale, rotation and offset of texture coordinates,
  as the 2x3 affine matrix the device applies (``uv_transform``).
* :data:`WRAP_MODES` -- what coordinates outside [0, 1] sample.
* :func:`project_numpy` -- the float64 reference of the device mappings.

Conventions (the same on the device):

* planar: ``u = scale * (p - origin) . x``, ``v = scale * (p - origin) . y``:
  ``scale`` is texture repeats per world unit.
* cylindrical: ``u = phi / 2pi`` with ``phi = atan2(y_l, x_l)`` in [0, 2pi),
  ``v = scale * z_l`` (height along the frame's z axis).
* spherical: ``u = phi / 2pi``, ``v = 1 - theta / pi`` with
  ``theta = atan2(sqrt(x_l^2 + y_l^2), z_l)``: the +z pole is v = 1, the top
  row of the image (the sphere primitive's convention); ``scale`` is unused.
* the frame: ``z`` = normalized ``z_axis``, ``x`` = ``x_axis`` made orthogonal
  to it (Gram-Schmidt) and normalized, ``y = z cross x`` (right-handed; phi
  grows from x towards y).
* UV transform: ``uv' = R(rotation) (S uv - c) + c + offset`` with
  ``S = diag(scale)``, ``R`` the counter-clockwise rotation by ``rotation``
  degrees in (u, v) and the pivot ``c = (0.5, 0.5)``, the texture's centre.
  With rotation 0 this is ``S uv + offset``; with scale 1 and offset 0 the
  unit square turns about its centre. Since these are *coordinates*, the image
  as seen on the surface shrinks by ``scale`` (scale 2 = twice as many
  repeats), moves by ``-offset`` and turns by ``-rotation``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..device import layout
from ..errors import SceneError
from .. import validate as V

WRAP_MODES = layout.WRAP_MODES                # name -> the device's TX_WRAP_* code
PROJECTION_KINDS = layout.PROJECTION_KINDS    # name -> the device's TX_MAP_* code
ROTATION_PIVOT = (0.5, 0.5)

_PARALLEL_TOL = 1e-6     # |x - (x.z) z| / |x| below this: x_axis is parallel to z_axis


def _vector(value, n, field, *, nonzero=False, limit=V.FLT_MAX):
    """``value`` as a tuple of ``n`` finite floats, or SceneError naming ``field`` (texray.validate)."""
    return tuple(float(x) for x in V.vector(value, n, field, nonzero=nonzero, limit=limit))


def _scalar(value, field, **kw):
    return V.number(value, field, **kw)


def _cos_sin_degrees(deg):
    """cos and sin of ``deg`` degrees, exact at multiples of 90."""
    r = math.fmod(deg, 360.0)
    r = r + 360.0 if r < 0 else r
    exact = {0.0: (1.0, 0.0), 90.0: (0.0, 1.0), 180.0: (-1.0, 0.0), 270.0: (0.0, -1.0)}
    if r in exact:
        return exact[r]
    t = math.radians(r)
    return math.cos(t), math.sin(t)


@dataclass
class UVTransform:
    """Scale, then rotate (degrees, counter-clockwise, about (0.5, 0.5)), then offset
    texture coordinates: ``uv' = R (S uv - c) + c + offset`` (see the module docstring)."""
    scale: tuple = (1.0, 1.0)
    offset: tuple = (0.0, 0.0)
    rotation: float = 0.0

    def __post_init__(self):
        self.validate()

    def validate(self):
        """Normalize the fields to floats; SceneError naming the field if one is bad."""
        self.scale = _vector(self.scale, 2, "uv_transform.scale", nonzero=True)
        self.offset = _vector(self.offset, 2, "uv_transform.offset")
        self.rotation = _scalar(self.rotation, "uv_transform.rotation")

    def matrix(self) -> np.ndarray:
        """(2, 3) float64 ``[[a, b, e], [c, d, f]]``: ``u' = a u + b v + e``, ``v' = c u + d v + f``."""
        self.validate()
        su, sv = self.scale
        cs, sn = _cos_sin_degrees(self.rotation)
        lin = np.array([[cs * su, -sn * sv], [sn * su, cs * sv]])
        c = np.array(ROTATION_PIVOT)
        rc = np.array([[cs, -sn], [sn, cs]]) @ c
        t = c - rc + np.array(self.offset)
        return np.column_stack([lin, t])

    def device_args(self) -> tuple[np.ndarray, np.ndarray]:
        """``(m0, m1)`` as float32 arrays for ``uv_transform(uv, m0, m1)``:
        m0 = (a, b, c, d), m1 = (e, f)."""
        m = self.matrix()
        return (np.array([m[0, 0], m[0, 1], m[1, 0], m[1, 1]], np.float32),
                np.array([m[0, 2], m[1, 2]], np.float32))

    def apply(self, uv) -> np.ndarray:
        """The transform of (..., 2) texture coordinates, float64."""
        uv = np.asarray(uv, dtype=np.float64)
        m = self.matrix()
        return uv @ m[:, :2].T + m[:, 2]


@dataclass
class Projection:
    """Texture coordinates from a point's position in a frame (see the module docstring).

    ``kind``: "planar", "cylindrical" or "spherical"; ``origin``, ``x_axis``,
    ``z_axis``: the frame in object space (``x_axis`` need not be orthogonal to
    ``z_axis``, only not parallel to it); ``scale`` (> 0): repeats per unit of
    planar u and v and of cylindrical v."""
    kind: str = "planar"
    origin: tuple = (0.0, 0.0, 0.0)
    x_axis: tuple = (1.0, 0.0, 0.0)
    z_axis: tuple = (0.0, 0.0, 1.0)
    scale: float = 1.0

    def __post_init__(self):
        self.validate()

    def validate(self):
        """Normalize the fields; SceneError naming the field if one is bad."""
        V.one_of(self.kind, tuple(PROJECTION_KINDS), "projection.kind")
        self.origin = _vector(self.origin, 3, "projection.origin", limit=V.COORD_LIMIT)
        self.x_axis = _vector(self.x_axis, 3, "projection.x_axis")
        self.z_axis = _vector(self.z_axis, 3, "projection.z_axis")
        self.scale = _scalar(self.scale, "projection.scale", lo=0.0, lo_open=True, limit=V.COORD_LIMIT)
        self._axes()

    def _axes(self):
        z = np.array(self.z_axis)
        z = z / max(np.abs(z).max(), 1e-300)          # scaled first: tiny vectors' norms underflow
        nz = np.linalg.norm(z)
        if not nz > 0 or not np.isfinite(nz):
            raise SceneError(f"projection.z_axis: must be a non-zero vector, got {self.z_axis}")
        z = z / nz
        x = np.array(self.x_axis)
        x = x / max(np.abs(x).max(), 1e-300)
        nx = np.linalg.norm(x)
        if not nx > 0 or not np.isfinite(nx):
            raise SceneError(f"projection.x_axis: must be a non-zero vector, got {self.x_axis}")
        x = x / nx
        x = x - (x @ z) * z
        nxo = np.linalg.norm(x)
        if not nxo > _PARALLEL_TOL:
            raise SceneError(f"projection.x_axis: {self.x_axis} is parallel to projection.z_axis {self.z_axis}")
        x = x / nxo
        y = np.cross(z, x)
        return x, y / np.linalg.norm(y), z

    @property
    def kind_id(self) -> int:
        """The device's TX_MAP_* number of ``kind``."""
        return PROJECTION_KINDS[self.kind]

    def frame(self) -> np.ndarray:
        """(4, 3) float64 rows ``origin, x, y, z``, the axes orthonormal and right-handed."""
        self.validate()
        x, y, z = self._axes()
        return np.array([self.origin, x, y, z], dtype=np.float64)

    def device_frame(self) -> np.ndarray:
        """(4, 3) float64 ``origin, k x, k y, k z`` with ``k = scale``: the ``Frame`` to pass to
        ``kernels/texture/mapping.h``, which folds the scale into equal-length axes (it multiplies
        planar u, v and cylindrical v and leaves phi and theta unchanged)."""
        f = self.frame()
        f[1:] *= self.scale
        return f


def project_numpy(projection: Projection, points) -> np.ndarray:
    """(N, 2) float64 texture coordinates of (N, 3) ``points`` (object space): the
    reference of ``map_planar`` / ``map_cylindrical`` / ``map_spherical``
    applied to ``projection.device_frame()``. Any (..., 3) shape gives (..., 2)."""
    if not isinstance(projection, Projection):
        raise TypeError(f"project_numpy: expected a Projection, got {type(projection).__name__}")
    p = np.asarray(points, dtype=np.float64)
    if p.ndim < 1 or p.shape[-1] != 3:
        raise ValueError(f"project_numpy: points must have shape (..., 3), got {p.shape}")
    o, x, y, z = projection.frame()
    d = p - o
    xl, yl, zl = d @ x, d @ y, d @ z
    k = projection.scale
    if projection.kind == "planar":
        return np.stack([k * xl, k * yl], axis=-1)
    u = np.arctan2(yl, xl) / (2 * np.pi)
    u = np.where(u < 0, u + 1.0, u)
    u = np.where(u < 1.0, u, np.nextafter(1.0, 0.0))
    if projection.kind == "cylindrical":
        return np.stack([u, k * zl], axis=-1)
    theta = np.arctan2(np.hypot(xl, yl), zl)
    return np.stack([u, 1.0 - theta / np.pi], axis=-1)
