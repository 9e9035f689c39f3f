"""The bilinear patch (the lecture's quad): its parameterization, validation, bounds
and device records."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .. import validate as V
from ..device import layout
from ..errors import SceneError
from ..linalg import apply_points
from .material import Material
from .shape import DeviceRecords, check_extent, check_mapping, check_material
from .transform import Transform


class QuadWorld(NamedTuple):
    """A quad in world space, float64."""
    corners: np.ndarray    # (4, 3) P0..P3
    uvs: np.ndarray        # (4, 2) their texture coordinates


@dataclass
class Quad:
    """A bilinear patch P(u,v) = (1-u)(1-v)P0 + u(1-v)P1 + uv P2 + (1-u)v P3, planar or not.
    uvs: texture coordinates of P0..P3, interpolated bilinearly (default: (u, v) itself).
    A quad of zero area is an error."""
    p0: tuple
    p1: tuple
    p2: tuple
    p3: tuple
    material: Material = field(default_factory=Material)
    uvs: tuple = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))
    transform: Transform | None = None
    name: str = "<quad>"
    mapping: object = None

    PRIM = layout.PRIM_QUAD

    def __post_init__(self):
        self.world()

    def validate(self):
        """Check every field again (they may have been changed since the shape was made)."""
        self.world()
        return self

    def world(self) -> QuadWorld:
        """The corners and their uvs in world space, float64 (validating every field)."""
        where = f"{self.name}: "
        p = np.stack([V.point(v, f"p{i}", where) for i, v in enumerate((self.p0, self.p1, self.p2, self.p3))])
        uv = V.array(self.uvs, "uvs", where, 2)
        if uv.shape != (4, 2) or not np.all(np.abs(uv) <= V.COORD_LIMIT):
            V.fail(where, "uvs", f"4 (u, v) pairs of numbers of magnitude <= {V.COORD_LIMIT:.0e} (interpolated in "
                   "float32)", self.uvs)
        if self.transform is not None:
            p = apply_points(self.transform.matrix(where + "transform."), p)
        check_extent(p, where, "p0..p3")
        area = np.linalg.norm(np.cross(p[1] - p[0], p[3] - p[0])) + np.linalg.norm(np.cross(p[2] - p[1], p[3] - p[2]))
        if area == 0:
            raise SceneError(f"{where}p0..p3: the quad has zero area: {p.tolist()}")
        check_material(self.material, where)
        check_mapping(self.mapping, where)
        d = self.material.displacement
        if d is not None and d.method != "tessellate":
            _check_displaceable(p, d.method, where)
        return QuadWorld(p, uv)

    # --- the parameterization ------------------------------------------------------
    def surface(self, u, v):
        """(P, n) of the patch at (u, v), float64: n = normalize(dP/du x dP/dv)."""
        p0, p1, p2, p3 = (np.asarray(c, np.float64) for c in self.world().corners)
        u, v = np.asarray(u)[..., None], np.asarray(v)[..., None]
        p = (1 - u) * (1 - v) * p0 + u * (1 - v) * p1 + u * v * p2 + (1 - u) * v * p3
        pu = (1 - v) * (p1 - p0) + v * (p2 - p3)
        pv = (1 - u) * (p3 - p0) + u * (p2 - p1)
        n = np.cross(pu, pv)
        return p, n / np.linalg.norm(n, axis=-1, keepdims=True)

    def texture_uv(self, u, v):
        """Texture coordinates at the patch parameters (u, v): the corners' uvs interpolated
        bilinearly, as the device does (kernels/geometry/quad.h)."""
        tuv = self.world().uvs
        a, b = np.asarray(u)[..., None], np.asarray(v)[..., None]
        return (1 - a) * (1 - b) * tuv[0] + a * (1 - b) * tuv[1] + a * b * tuv[2] + (1 - a) * b * tuv[3]

    # --- device records -------------------------------------------------------------
    def device_records(self, material, object_id) -> DeviceRecords:
        """layout.QUAD_VERTS and QUAD_SHADE, and the box of the float32 corners (a bilinear
        patch lies in the convex hull of its corners: that box is exact)."""
        p, uv = self.world()
        p32 = p.astype(np.float32)       # Quad.world checked |corners| <= validate.COORD_LIMIT
        qv = np.zeros(1, layout.QUAD_VERTS)
        qv["p0"], qv["p1"], qv["p2"], qv["p3"] = p32[0], p32[1], p32[2], p32[3]
        qs = np.zeros(1, layout.QUAD_SHADE)
        qs["uv"], qs["material"], qs["object"] = uv.ravel(), material, object_id
        return DeviceRecords({"quad_verts": qv, "quad_shade": qs}, p32.min(axis=0).astype(np.float64),
                             p32.max(axis=0).astype(np.float64))

    def displaced_record(self, rec, hmin, hmax):
        """Fill the shape's fields of the layout.DISPLACED record ``rec``; the (lo, hi) box
        of the slab [hmin, hmax] along the normal (Quad.world checked that a searched or
        maxmip quad is planar and convex: a parallelogram is a DISP_QUAD, any other a
        DISP_TRAPEZOID)."""
        p, uv = self.world()
        e0, e1 = p[1] - p[0], p[3] - p[0]
        n = np.cross(e0, e1)
        n /= np.linalg.norm(n)
        rec["shape"], rec["p"], rec["e0"], rec["e1"], rec["n"], rec["uv"] = layout.DISP_QUAD, p[0], e0, e1, n, uv.ravel()
        if not _parallelogram(p):
            rec["shape"], rec["g"] = layout.DISP_TRAPEZOID, p[0] - p[1] + p[2] - p[3]
        c = np.concatenate([p + hmin * n, p + hmax * n])
        return c.min(axis=0), c.max(axis=0)


def _tolerance(p):
    """2^-20 of the quad's size: float32 precision, what "planar" and "parallelogram" mean."""
    return 2.0 ** -20 * max(np.abs(p).max(), np.linalg.norm(p[1] - p[0]), np.linalg.norm(p[3] - p[0]))


def _parallelogram(p):
    """p0 + p2 = p1 + p3 to float32 precision: (u, v, h) are affine along a ray."""
    return np.linalg.norm(p[0] + p[2] - p[1] - p[3]) <= _tolerance(p)


def _check_displaceable(p, method, where):
    """SceneError unless the per-pixel methods ("search", "maxmip") can displace the quad with
    world corners p: a planar convex quad (a parallelogram, or a trapezoid or any other
    convex quad: kernels/geometry/displace.h inverts its bilinear patch in the plane; maxmip
    traverses a parallelogram's cells along the ray, (u, v, h) affine there, and bisects a
    trapezoid's segment in t, disp_maxmip_bisect)."""
    field = f"{where}material.displacement.method"
    e0, e1 = p[1] - p[0], p[3] - p[0]
    n = np.cross(e0, e1)
    if not np.linalg.norm(n) > 0:
        raise SceneError(f"{field}: {method!r} needs p1 - p0 and p3 - p0 to span the quad's plane; they are "
                         f"parallel for the corners {V.show(p)}: use method = \"tessellate\"")
    n = n / np.linalg.norm(n)
    off = float(np.dot(p[2] - p[0], n))
    if abs(off) > _tolerance(p):
        raise SceneError(f"{field}: {method!r} displaces planar quads only; p2 lies {abs(off):.3g} off the plane of "
                         f"p0, p1, p3 (corners {V.show(p)}): use method = \"tessellate\"")
    if _parallelogram(p):
        return
    turns = [np.dot(np.cross(p[(i + 1) % 4] - p[i], p[(i + 2) % 4] - p[(i + 1) % 4]), n) for i in range(4)]
    if not min(turns) > 0:
        raise SceneError(f"{field}: {method!r} displaces convex quads only (corners in order around the quad, "
                         f"no corner of 180 degrees or more); this quad's corners are {V.show(p)}: use "
                         f"method = \"tessellate\"")
