"""Device units: the compiled scene rescaled by a power of two so that its geometry's
largest coordinate is between 1 and 2, where it is not already within :data:`SAFE`.

The kernels compute in float32, and the intersection tests multiply coordinates: the
watertight triangle test's distance is a product of three (relative to the ray's origin),
the bilinear patch's of up to four, and some tests compare squared lengths with fixed
thresholds. Far beyond a unit-sized scene those products overflow or underflow: measured
on 2026-12-08 (PoCL, a ball on a floor, the camera and the light scaled with them), quads
lost their shadows from a scale of 1e7 on and vanished from 1e11, triangles from 1e13,
meshes lost their shadows below 1e-5 and quads went dark below 1e-9, all within the
coordinates the scene validation accepts (texray.validate.COORD_LIMIT, 1e18). Scaling by a
power of two is exact in floating point (every float32 keeps its significand), so the
device sees a scene of the same shape, bit for bit, at the scale the kernels are tested
at; the renderer scales the camera's eye the same way, the Tracer its rays, and the AOVs
in world units (position, depth, dpdu, dpdv) back. A scene within :data:`SAFE` is left as
it is: its images keep their bits.

What is in world units on the device, and what scaling by ``s`` does to it:

* positions and lengths (vertices, centres, radii, cylinder heights, displaced patches'
  corners and edges, displacement heights and shells, the BVH's boxes, light positions, bump
  heights): times ``s``;
* the projection frames' axes (texture repeats per world unit, layout.OBJECT x, y, z): over
  ``s``, so that dot(p - origin, axis) stays the same; the normal matrices (object-space
  normal maps' nm rows, instances' nrm) over ``s`` too, as the inverse transpose of the
  rescaled matrix (their normals are normalized: the same directions);
* instances: the meshes they share keep units of their own (a BLAS far from 1 in its own
  coordinates gets a power of two ``k`` of its own: texray.compile.instances.place), their
  matrices map those to device units: o2w = S M K^-1, w2o = K M^-1 S^-1;
* light intensities: times ``s^2``, so that I / d^2 stays the same;
* directions (vertex normals, sphere and cylinder axes), texture coordinates, colours and the
  camera's image-plane vectors (dimensionless): unchanged.
"""
from __future__ import annotations

import math

import numpy as np

from ..device import layout
from ..errors import SceneError
from ..validate import show

# The range of the geometry's largest coordinate magnitude (world units) left as it is: on
# the measurements above every kind renders its unit-scale image from 1e-4 to 1e6.
SAFE = (2.0 ** -10, 2.0 ** 20)

NODE_BOUNDS = ("lo_x", "hi_x", "lo_y", "hi_y", "lo_z", "hi_z")
LENGTHS = {
    "tri_verts": ("p0", "p1", "p2"),
    "spheres": ("center", "radius"),
    "cylinders": ("origin", "radius", "z_min", "z_max"),
    "quad_verts": ("p0", "p1", "p2", "p3"),
}
# DISPLACED fields in world units for every shape; e0, e1 are edges (world units) on the
# flat shapes and unit axes on the sphere and the cylinder
_DISPLACED_LENGTHS = ("p", "radius", "z_min", "z_max", "hmin", "hmax", "g", "slo", "shi")
_DISPLACED_EDGES = (layout.DISP_QUAD, layout.DISP_TRAPEZOID, layout.DISP_TRIANGLE)


def box_extent(lo, hi) -> float:
    """The largest coordinate magnitude of the box (lo, hi); 0 for an empty one."""
    box = np.concatenate([np.ravel(lo), np.ravel(hi)]).astype(np.float64)
    box = box[np.isfinite(box)]
    return float(np.abs(box).max()) if box.size else 0.0


def extent(nodes: np.ndarray) -> float:
    """The largest coordinate magnitude of the scene's geometry: its BVH root's box
    (layout.BVH_NODE, root at 0); 0 for an empty scene."""
    return box_extent(nodes[0]["bmin"], nodes[0]["bmax"]) if len(nodes) else 0.0


def choose_scale(e: float) -> float:
    """Device units per world unit for a scene whose geometry reaches ``e`` (:func:`extent`):
    1 within :data:`SAFE` (or for an empty scene), else the power of two that brings ``e``
    into [1, 2)."""
    if not (e > 0.0) or not math.isfinite(e) or SAFE[0] <= e <= SAFE[1]:
        return 1.0
    return 2.0 ** -math.floor(math.log2(e))


def scale_fields(arr, fields, s):
    """``arr`` (a structured array) with ``fields`` times ``s``, as a copy (float32; ``s`` a
    power of two: exact); ``arr`` itself where ``s`` is 1 or it is empty."""
    if arr is None or len(arr) == 0 or s == 1.0:
        return arr
    out = arr.copy()
    for f in fields:
        out[f] = out[f] * np.float32(s)
    return out


def _scale_head(arr, fields, s, head=None):
    """:func:`scale_fields` of the first ``head`` rows (the scene's own tree; the instanced
    meshes' rows after them keep their units), of every row where ``head`` is None."""
    if head is None:
        return scale_fields(arr, fields, s)
    return np.concatenate([scale_fields(arr[:head], fields, s), arr[head:]])


def _scaled_or_error(values, factor, s, where):
    """``values`` (rows of world values) times ``factor`` as float32, or SceneError
    naming ``where`` (formatted with the row's index i) and that row where a product leaves
    float32's range (a scene rescaled by ``s``)."""
    v = np.asarray(values, np.float64)
    out = v * factor
    bad = ~(np.abs(out) <= np.finfo(np.float32).max)
    if bad.any():
        i = int(np.argwhere(bad.any(axis=1))[0][0])
        raise SceneError(f"{where.format(i=i)}: expected magnitudes up to {np.finfo(np.float32).max / factor:.3g} in "
                         f"a scene whose geometry reaches {1.0 / s:.3g} to {2.0 / s:.3g} (the device sees it in units "
                         f"of {1.0 / s:.3g}: texray.compile.units), got {show([float(f'{x:.7g}') for x in v[i]])}")
    return out.astype(np.float32)


def rescale(cs, s: float, top_tris=None, top_nodes=None, intensities=None):
    """The compiled scene ``cs`` in device units, ``s`` per world unit (a power of two):
    its arrays rescaled as the module's docstring lists, ``cs.scale = s``. Returns ``cs``
    itself where ``s`` is 1. With instances, ``top_tris`` and ``top_nodes`` count the
    triangles and wide nodes of the scene's own tree: those after them are the instanced
    meshes' (texray.compile.instances), each in units of its own, which the instances'
    matrices map to world units (here: to device units). ``intensities``: the lights' as the
    scene gives them (float64), rescaled before they are rounded to float32 (a light of 4e-59
    in a scene 1e-30 across is 0 as a float32, 40 rescaled); else cs.lights'."""
    if s == 1.0:
        return cs
    for name, fields in LENGTHS.items():
        setattr(cs, name, _scale_head(getattr(cs, name), fields, s, top_tris if name == "tri_verts" else None))
    cs.nodes = _scale_head(cs.nodes, NODE_BOUNDS, s, top_nodes)
    if cs.displaced is not None:
        d = scale_fields(cs.displaced, _DISPLACED_LENGTHS, s)
        flat = np.isin(d["shape"], _DISPLACED_EDGES)
        for f in ("e0", "e1"):
            d[f][flat] = d[f][flat] * np.float32(s)
        cs.displaced = d
    if cs.instances is not None:     # rows of 3x4 matrices: o2w' = S o2w, w2o' = w2o S^-1, nrm' = nrm / s
        inst = cs.instances.copy()
        inst["o2w"] = inst["o2w"] * np.float32(s)
        inst["w2o"][:, :, :3] = inst["w2o"][:, :, :3] * np.float32(1.0 / s)
        inst["nrm"] = inst["nrm"] * np.float32(1.0 / s)
        cs.instances = inst
    if len(cs.lights):
        lights = cs.lights.copy()
        lights["position"] = lights["position"] * np.float32(s)
        world = lights["intensity"] if intensities is None else intensities
        lights["intensity"] = _scaled_or_error(world, s * s, s, "lights[{i}].intensity")
        cs.lights = lights
    if len(cs.materials):
        m = cs.materials.copy()
        m["bump_height"] = _scaled_or_error(m["bump_height"][:, None], s, s, "materials[{i}].bump.height")[:, 0]
        cs.materials = m
    for name in ("objects", "objects_generic"):
        table = getattr(cs, name)
        if table is None:
            continue
        t = table.copy()
        t["origin"] = t["origin"] * np.float32(s)
        for f in ("nm0", "nm1", "nm2"):          # the normal matrix of S M: M^-T / s (normalized after)
            t[f] = t[f] * np.float32(1.0 / s)
        for f in ("x", "y", "z"):                 # k axis: k texture repeats per world unit
            t[f] = _scaled_or_error(t[f], 1.0 / s, s, "objects[{i}].mapping.scale")
        setattr(cs, name, t)
    cs.scale = s
    return cs
