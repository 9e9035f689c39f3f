"""Displacement mapping: a height field moves the surface along its normal before
visibility is decided (the lecture's "Displacement Mapping" slides).

The height field is H(u, v) = offset + scale * texture.r (world units; the texture's
stored values: a data role, never sRGB-decoded), the bilinear interpolant of the
texels with the conventions of ``kernels/texture/texture.h``: u along columns, v = 0 the
bottom row, texel centres at ((i + 0.5) / W, 1 - (j + 0.5) / H), the texture's wrap
mode outside. (u, v) are the primitive's own parameters: the bilinear (u, v) of a
quad, the uv of a sphere or cylinder (their texture coordinates); the displaced
surface is S(u, v) = P(u, v) + H(u, v) n(u, v), n the primitive's outward unit normal.

Methods (``Displacement.method``):

* ``"search"``: on the device, the lecture's search between the entry A and exit B of
  the displaced surface's bounding volume: ``steps`` linear steps to the first
  sample on the other side of the surface, then ``refine`` bisection steps
  (``kernels/geometry/displace.h``). On spheres, cylinders and planar convex quads:
  a parallelogram, or any other (a trapezoid), whose bilinear (u, v) the kernel
  inverts in its plane; and on triangle meshes, one prism shell per triangle along
  the interpolated vertex normals (texray.compile.shells), the mesh's own uvs
  addressing the height field.
* ``"maxmip"``: the exact hierarchical traversal of a min-max MIP pyramid of the
  height field (Tevs, Ihrke, Seidel, "Maximum Mipmaps for Fast, Accurate, and
  Scalable Dynamic Height Field Rendering", I3D 2008), made two-sided so that
  rays from below work too: a cell is skipped when the ray's height over it lies
  entirely above its maximum or below its minimum; in a texel cell the ray meets
  the bilinear interpolant where a quadratic vanishes. Planar parallelogram quads
  (where (u, v, h) are affine along a ray); spheres, cylinders and other planar
  convex quads (trapezoids, kites): there the ray is cut into pieces where u, v and
  h are monotone (a trapezoid's segment is one) and each piece is bisected in t
  against the pyramid (the bilinear patch's exact bound in texel cells), a root
  bracketed by a sign change polished by regula falsi; exact but for a ray that dips
  below the surface and out again within 1/64 texel (kernels/geometry/displace.h
  disp_maxmip_bisect). Triangle meshes: each triangle's prism shell (as the search's)
  is subdivided on the device into sub-prisms over sub-triangles, each bounded by the
  pyramid over its uv footprint, traversed front to back down to half-texel leaves,
  whose exact segment is searched (kernels/geometry/displace.h disp_maxmip_mesh):
  conservative, but a ray that dips below the surface and out again between two of
  a leaf's 4 samples is missed.
* ``"tessellate"``: true geometry on the host (:func:`tessellate`), rendered as a
  triangle mesh: the accuracy reference (meshes: texray.compile.tessellate_mesh).

The height field's float64 reference maths: texray.scene.heightfield; the device
packing: texray.compile.heights; tessellation: texray.compile.tessellate.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from .. import validate as V
from .bump import data_texture
from .texture import Texture

METHODS = ("search", "maxmip", "tessellate")
MAX_STEPS = 4096
MAX_REFINE = 32
MAX_RESOLUTION = 16


@dataclass
class Displacement:
    """A height field H = offset + scale * texture.r moving the surface along its
    outward normal (world units: a texel value of 1 raises it by ``scale``).

    method: "search" (linear + binary search, ``steps`` N >= 1 and ``refine`` M >= 0
    bisections; spheres, cylinders, planar convex quads, triangle meshes), "maxmip" (hierarchical
    traversal of a min-max pyramid; planar convex quads, spheres, cylinders, triangle meshes) or "tessellate" (a triangle mesh, ``resolution`` vertices per
    texel and axis). adaptive: N grows with the grazing angle, N / max(|cos|, 1/8)
    (the path through the volume grows as 1/|cos|, so the height step per sample
    stays put up to 8x N).
    """
    texture: object
    scale: float = 0.1
    offset: float = 0.0
    method: str = "search"
    steps: int = 32
    refine: int = 8
    adaptive: bool = False
    resolution: int = 1

    def __post_init__(self):
        self.texture = data_texture(self.texture, "displacement.")
        self.validate()

    def validate(self, where="displacement."):
        V.instance(self.texture, Texture, "texture", where)
        V.number(self.scale, "scale", where, limit=V.COORD_LIMIT)
        V.number(self.offset, "offset", where, limit=V.COORD_LIMIT)
        V.one_of(self.method, METHODS, "method", where)
        V.integer(self.steps, "steps", where, 1, MAX_STEPS)
        V.integer(self.refine, "refine", where, 0, MAX_REFINE)
        V.integer(self.resolution, "resolution", where, 1, MAX_RESOLUTION)
        if not isinstance(self.adaptive, (bool, np.bool_)):
            raise SceneError(f"{where}adaptive: expected true or false, got {V.show(self.adaptive)}")
        t = self.texture
        if t.uv_transform is not None and not _identity(t.uv_transform):
            raise SceneError(f"{where}texture: {t.name}: a height texture takes no uv_transform (the height "
                             "field is addressed by the primitive's own parameters)")
        h = self.heights()
        if not np.all(np.isfinite(h)):
            raise SceneError(f"{where}texture: {t.name}: heights must be finite, got "
                             f"{h[~np.isfinite(h)].flat[0]!r}")
        return self

    def heights(self) -> np.ndarray:
        """float64 (H, W) heights in world units, row 0 = the texture's top row."""
        return float(self.offset) + float(self.scale) * self.texture.raw[:, :, 0].astype(np.float64)

    @property
    def wrap(self) -> str:
        return self.texture.wrap

    def bounds(self):
        """(min, max) of H: the bilinear interpolant stays within its texels' range."""
        h = self.heights()
        return float(h.min()), float(h.max())


def _identity(tr):
    return (np.all(np.asarray(tr.scale) == 1) and np.all(np.asarray(tr.offset) == 0)
            and float(tr.rotation) % 360 == 0)
