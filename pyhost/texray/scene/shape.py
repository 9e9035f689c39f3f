"""What every shape shares: validation of frames, transforms, materials and mappings;
the world-space extent check; float32 boxes that contain the float64 shape."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import validate as V
from ..errors import SceneError
from ..linalg import apply_points
from .mapping import Projection
from .material import Material
from .transform import Transform


class DeviceRecords(NamedTuple):
    """A shape's device records, keyed by the CompiledScene array they join (one row
    each, or a mesh's triangles), and the float64 (lo, hi) box of each row (rounded
    outward to float32 by the compiler)."""
    arrays: dict
    lo: np.ndarray
    hi: np.ndarray


def frame(z_axis, x_axis, where):
    """Orthonormal (x, y, z) from a z axis and an x direction (Gram-Schmidt)."""
    z = V.vector(z_axis, 3, "axis_z", where)
    x = V.vector(x_axis, 3, "axis_x", where)
    if np.linalg.norm(z) == 0:
        raise SceneError(f"{where}axis_z: expected a non-zero vector, got {V.show(z_axis)}")
    if np.linalg.norm(x) == 0:
        raise SceneError(f"{where}axis_x: expected a non-zero vector, got {V.show(x_axis)}")
    z = z / np.linalg.norm(z)
    x = x / np.linalg.norm(x)
    x = x - z * (x @ z)
    if np.linalg.norm(x) <= 1e-9:
        raise SceneError(f"{where}axis_x: {V.show(x_axis)} is parallel to axis_z {V.show(z_axis)}")
    x = x / np.linalg.norm(x)
    return x, np.cross(z, x), z


def similarity(transform, where):
    """(matrix, uniform scale) of a transform; analytic shapes need a uniform scale."""
    if transform is None:
        return np.eye(4), 1.0
    V.instance(transform, Transform, "transform", where)
    m = transform.matrix(where + "transform.")
    s = np.linalg.svd(m[:3, :3], compute_uv=False)
    if not np.allclose(s, s[0], rtol=1e-9):
        raise SceneError(f"{where}transform.scale: {V.show(transform.scale)}: spheres and cylinders take a "
                         "uniform scale only")
    return m, float(s[0])


def check_mapping(mapping, where):
    if mapping is not None:
        if not isinstance(mapping, Projection):
            raise SceneError(f"{where}mapping: expected a texray.Projection, got {mapping!r}")
        try:
            mapping.validate()
        except SceneError as e:
            raise SceneError(f"{where}mapping: {e}") from None


def placed(shape, point, where):
    """(point, uniform scale, axis_x, axis_z) of an analytic shape in world space, after
    checking its frame, transform, material and mapping."""
    m, k = similarity(shape.transform, where)
    x, _, z = frame(shape.axis_z, shape.axis_x, where)
    check_material(shape.material, where)
    check_mapping(shape.mapping, where)
    rot = m[:3, :3] / k
    return apply_points(m, point[None])[0], k, rot @ x, rot @ z


def materials_of(shape) -> tuple:
    """Every material of a shape: a mesh's list (texray.Mesh.materials), else its one."""
    m = shape.material
    return tuple(m) if isinstance(m, (list, tuple)) else (m,)


def check_material(m, where):
    V.instance(m, Material, "material", where)
    m.validate(f"{where}material.")


def check_curved_displacement(shape, radius, what, where):
    """The rules of a displaced sphere or cylinder (searched or maxmip on the device): no
    height below the centre or axis (the shell would turn inside out)."""
    d = shape.material.displacement
    if d is None or d.method == "tessellate":
        return
    hmin = d.bounds()[0]
    if radius + hmin < 0:
        raise SceneError(f"{where}material.displacement.offset: the lowest height {hmin:g} is below the {what} "
                         f"of radius {radius:g}")


def check_extent(points, where, field):
    """SceneError unless every coordinate of the world-space ``points`` lies within
    +-validate.COORD_LIMIT (the device computes in float32)."""
    big = np.abs(points).max(initial=0.0)
    if not big <= V.COORD_LIMIT:
        raise SceneError(f"{where}{field}: coordinates up to {big:.3g} after the transform; the device "
                         f"computes in float32 and takes |coordinates| <= {V.COORD_LIMIT:.0e}")


def outward(lo, hi):
    """float64 bounds rounded outward to float32, so the float32 box contains the shape."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    lo32, hi32 = lo.astype(np.float32), hi.astype(np.float32)
    lo32 = np.where(lo32.astype(np.float64) > lo, np.nextafter(lo32, np.float32(-np.inf)), lo32)
    hi32 = np.where(hi32.astype(np.float64) < hi, np.nextafter(hi32, np.float32(np.inf)), hi32)
    if not (np.all(np.isfinite(lo32)) and np.all(np.isfinite(hi32))):
        raise SceneError("scene: a primitive's bounds overflow float32 (coordinates beyond 3.4e38)")
    return lo32, hi32


def circle_extent(radius, axis):
    """Half-extent along x, y, z of a circle of ``radius`` about the unit ``axis``:
    radius sqrt(1 - axis_k^2) along axis k."""
    return radius * np.sqrt(np.maximum(0.0, 1.0 - axis * axis))
