"""Triangle meshes: validation, world-space vertices and device records."""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .. import validate as V
from ..accel.scene_bvh import triangle_bounds
from ..device import layout
from ..errors import SceneError
from ..io.meshfile import read_mesh
from ..linalg import apply_normals, apply_points
from .material import Material
from .shape import DeviceRecords, check_extent, check_mapping
from .transform import Transform


class MeshWorld(NamedTuple):
    """A mesh's vertices in world space, float64."""
    positions: np.ndarray
    normals: np.ndarray | None


@dataclass
class Mesh:
    """A triangle mesh in world space after its ``transform``.

    positions (V, 3), faces (F, 3) vertex indices, optional per-vertex uvs
    (V, 2) and normals (V, 3). Validated on creation: non-finite coordinates,
    out-of-range indices and a textured material without uvs raise
    SceneError; zero-area triangles are kept out of the render with a warning
    (they can never be hit, so no pixel depends on them).
    """
    positions: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None = None
    normals: np.ndarray | None = None
    material: Material = field(default_factory=Material)
    transform: Transform | None = None
    name: str = "<mesh>"
    mapping: object = None        # a texray.Projection generating uvs, or None for the mesh's own

    PRIM = layout.PRIM_TRIANGLE

    def __post_init__(self):
        self._validate()

    @classmethod
    def load(cls, path, material=None, transform=None, mapping=None):
        """Load OBJ, PLY, GLB/GLTF, OFF or STL through trimesh (unprocessed: nothing is
        silently merged or dropped; texray.io.meshfile)."""
        positions, faces, uvs, normals, name = read_mesh(path)
        return cls(positions, faces, uvs, normals, material if material is not None else Material(), transform,
                   name, mapping)

    def _validate(self):
        if not isinstance(self.name, str):
            raise SceneError(f"mesh: name: expected a string, got {V.show(self.name)}")
        where = f"{self.name}: "
        p = V.array(self.positions, "positions", where, 3)
        f = V.array(self.faces, "faces", where, 3, integer_values=True)
        bad = ~np.all(np.abs(p) <= V.COORD_LIMIT, axis=1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            what = "non-finite" if not np.all(np.isfinite(p[i])) else f"beyond +-{V.COORD_LIMIT:.0e}"
            raise SceneError(f"{where}positions: vertex {i} is {V.show(p[i])} ({int(bad.sum())} {what} vertices)")
        if f.size and (f.min() < 0 or f.max() >= len(p)):
            i = int(np.flatnonzero((f < 0).any(1) | (f >= len(p)).any(1))[0])
            raise SceneError(f"{where}faces: face {i} = {V.show(f[i])} indexes outside 0..{len(p) - 1}")
        arrays = {}
        for name, arr, width in (("uvs", self.uvs, 2), ("normals", self.normals, 3)):
            if arr is None:
                continue
            a = V.array(arr, name, where, width)
            if a.shape != (len(p), width):
                raise SceneError(f"{where}{name}: expected shape ({len(p)}, {width}), got {a.shape}")
            limit = V.COORD_LIMIT if name == "uvs" else V.FLT_MAX     # uvs are interpolated: sums must not overflow
            bad = ~np.all(np.abs(a) <= limit, axis=1)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise SceneError(f"{where}{name}: vertex {i} is {V.show(a[i])} (expected finite values of magnitude "
                                 f"<= {limit:.3g})")
            arrays[name] = a
        if "normals" in arrays:
            arrays["normals"] = _tame_normals(arrays["normals"])
        if self.transform is not None:
            V.instance(self.transform, Transform, "transform", where)
            self.transform.matrix(where + "transform.")
        V.instance(self.material, Material, "material", where)
        self.material.validate(f"{where}material.")
        d = self.material.displacement
        if d is not None and d.method != "tessellate":    # tessellated shapes are meshes with the shape's material
            raise SceneError(f"{where}material.displacement: triangle meshes are not displaced (no sound "
                             "bounding volume chosen); use a quad, sphere or cylinder")
        check_mapping(self.mapping, where)
        if self.material.textures and self.uvs is None and self.mapping is None:
            raise SceneError(f"{where}uvs: the material has a texture ({self.material.textures[0].name}) "
                             "but the mesh has no texture coordinates")
        self.positions, self.faces = p, f
        self.uvs, self.normals = arrays.get("uvs"), arrays.get("normals")

    def validate(self):
        """Check every field again (they may have been changed since the mesh was made)."""
        self._validate()
        return self

    def world(self) -> MeshWorld:
        """Positions and vertex normals (or None) in world space, float64."""
        if self.transform is None:
            return MeshWorld(self.positions, None if self.normals is None else np.asarray(self.normals, np.float64))
        m = self.transform.matrix(f"{self.name}: transform.")
        n = None if self.normals is None else apply_normals(m, np.asarray(self.normals, np.float64))
        return MeshWorld(apply_points(m, self.positions), n)

    # --- device records -------------------------------------------------------------
    def device_records(self, material, object_id, vertex_offset, with_normals, with_uvs) -> DeviceRecords:
        """layout.TRI_VERTS and TRI_SHADE of the triangles that have an area (zero-area ones
        are skipped with a warning: no ray can hit them), the per-vertex ``normals`` and
        ``uvs`` arrays when the scene has them (zeros for a mesh without), and each
        triangle's box (exact: min/max of float32). ``vertex_offset``: where this mesh's
        vertices start in the scene's vertex arrays."""
        p, n = self.world()
        f = self.faces
        check_extent(p, f"{self.name}: ", "positions")
        p32 = p.astype(np.float32)
        degenerate = degenerate_faces(p32.astype(np.float64), f)
        if degenerate.all():
            raise SceneError(f"{self.name}: faces: all {len(f)} triangles have zero area; nothing to render")
        warn_degenerate(self.name, degenerate)
        keep = np.flatnonzero(~degenerate)
        fk = f[keep]
        tv = np.zeros(len(keep), layout.TRI_VERTS)
        tv["p0"], tv["p1"], tv["p2"] = p32[fk[:, 0]], p32[fk[:, 1]], p32[fk[:, 2]]
        t = np.zeros(len(keep), layout.TRI_SHADE)
        t["material"], t["object"], t["prim"], t["v"] = material, object_id, keep, fk + vertex_offset
        arrays, flags = {"tri_verts": tv, "tri_shade": t}, 0
        if with_normals:
            flags |= layout.TRI_HAS_NORMALS if n is not None else 0
            arrays["normals"] = n if n is not None else np.zeros_like(p)
        if with_uvs:
            flags |= layout.TRI_HAS_UVS if self.uvs is not None else 0
            arrays["uvs"] = self.uvs if self.uvs is not None else np.zeros((len(p), 2))
        t["flags"] = flags
        return DeviceRecords(arrays, *triangle_bounds(tv))


def _tame_normals(n):
    """Vertex normals are directions: rows whose length is far from 1 (outside [2^-20, 2^20])
    are scaled to unit length, so that the device's float32 dot products of them stay
    finite; zero rows stay zero. Normals of ordinary meshes are left bit for bit."""
    length = np.linalg.norm(n, axis=1)
    odd = (length > 0) & ((length > 2.0 ** 20) | (length < 2.0 ** -20))
    if odd.any():
        n = n.copy()
        n[odd] /= length[odd, None]
    return n


def degenerate_faces(positions, faces):
    """Boolean mask of zero-area triangles (exactly collinear in float64)."""
    a, b, c = positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]]
    return ~np.any(np.cross(b - a, c - a) != 0, axis=1)


def warn_degenerate(name, mask):
    n = int(mask.sum())
    if n:
        first = np.flatnonzero(mask)[:5].tolist()
        warnings.warn(f"{name}: {n} zero-area triangle(s) skipped (faces {first}{'...' if n > 5 else ''})",
                      stacklevel=3)
