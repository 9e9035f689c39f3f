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
from ..linalg import apply_normals, apply_points
from .material import Material
from .shape import DeviceRecords, check_extent, check_mapping, materials_of
from .transform import Transform


class MeshWorld(NamedTuple):
    """A mesh's vertices in world space, float64."""
    positions: np.ndarray
    normals: np.ndarray | None


@dataclass
class Mesh:
    """A triangle mesh in world space after its ``transform``.

    positions (V, 3), faces (F, 3) vertex indices, optional per-vertex uvs
    (V, 2) and normals (V, 3). ``material``: one Material for every face, or a list of
    Materials with ``material_ids`` (F,) choosing one per face (a mesh file's ``usemtl``
    groups or glTF primitives: still one mesh in one BVH). Validated on creation:
    non-finite coordinates, out-of-range indices and a textured material without uvs
    raise SceneError; zero-area triangles are kept out of the render with a warning
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
    material_ids: np.ndarray | None = None   # (F,) index into a list ``material``

    PRIM = layout.PRIM_TRIANGLE

    def __post_init__(self):
        self._validate()

    @classmethod
    def load(cls, path, material=None, transform=None, mapping=None):
        """Load OBJ (with its MTL), GLB/GLTF, PLY, OFF or STL (texray.io.meshfile: nothing is
        silently merged or dropped). Without ``material`` the file's own materials are used
        (OBJ/MTL and glTF; grey for formats without); ``material=`` replaces them all."""
        # Imported here, as Scene.load imports the scene-file reader: the reader makes
        # Materials, so the model cannot import it at module level.
        from ..io.meshfile import read_mesh
        m = read_mesh(path, materials=material is None)
        if material is not None:
            return cls(m.positions, m.faces, m.uvs, m.normals, material, transform, m.name, mapping)
        return cls(m.positions, m.faces, m.uvs, m.normals, m.materials, transform, m.name, mapping, m.material_ids)

    @property
    def materials(self) -> tuple:
        """Every material of the mesh (one unless ``material`` is a list)."""
        return materials_of(self)

    def face_materials(self) -> np.ndarray:
        """(F,) index into :attr:`materials` per face."""
        if self.material_ids is None:
            return np.zeros(len(self.faces), np.int64)
        return self.material_ids

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
        ids = self._check_materials(where, len(f))
        check_mapping(self.mapping, where)
        if self.uvs is None and self.mapping is None:
            for k, m in enumerate(self.materials):
                if m.textures:
                    which = "the material" if len(self.materials) == 1 else f"material[{k}]"
                    raise SceneError(f"{where}uvs: {which} has a texture ({m.textures[0].name}) "
                                     "but the mesh has no texture coordinates")
        self.positions, self.faces, self.material_ids = p, f, ids
        self.uvs, self.normals = arrays.get("uvs"), arrays.get("normals")

    def _check_materials(self, where, n_faces):
        """Validate ``material`` (one or a list) and ``material_ids``; the ids as int64 or None."""
        mats = self.materials
        if not mats:
            raise SceneError(f"{where}material: an empty list (give a Material, or a list with material_ids)")
        for k, m in enumerate(mats):
            field_ = "material" if len(mats) == 1 and not isinstance(self.material, (list, tuple)) else f"material[{k}]"
            V.instance(m, Material, field_, where)
            m.validate(f"{where}{field_}.")
        methods = {m.displacement.method for m in mats if m.displacement is not None}
        if len(methods) > 1:
            raise SceneError(f"{where}material: a triangle mesh is displaced by one method for all its "
                             f"materials, got {', '.join(sorted(methods))}")
        if self.material_ids is None:
            if len(mats) > 1:
                raise SceneError(f"{where}material_ids: required with a list of {len(mats)} materials "
                                 "(one index per face)")
            return None
        raw = self.material_ids
        if isinstance(raw, (str, bytes)) or np.ndim(raw) != 1:
            raise SceneError(f"{where}material_ids: expected ({n_faces},) integers (one per face), got "
                             f"{V.show(raw)}")
        ids = V.array(np.asarray(raw)[:, None], "material_ids", where, 1, integer_values=True)[:, 0]
        if ids.shape != (n_faces,):
            raise SceneError(f"{where}material_ids: expected shape ({n_faces},) (one per face), got {ids.shape}")
        if ids.size and (ids.min() < 0 or ids.max() >= len(mats)):
            i = int(np.flatnonzero((ids < 0) | (ids >= len(mats)))[0])
            raise SceneError(f"{where}material_ids: face {i} has {int(ids[i])}, outside 0..{len(mats) - 1}")
        return ids.astype(np.int64)

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
        """``material``: the material table index of each of :attr:`materials` (or one int).
        layout.TRI_VERTS and TRI_SHADE of the triangles that have an area (zero-area ones
        are skipped with a warning: no ray can hit them), the per-vertex ``normals`` and
        ``uvs`` arrays when the scene has them (zeros for a mesh without), and each
        triangle's box (exact: min/max of float32). ``vertex_offset``: where this mesh's
        vertices start in the scene's vertex arrays."""
        p, n = self.world()
        f = self.faces
        check_extent(p, f"{self.name}: ", "positions")
        # the corners gathered once as layout.TRI_VERTS rows (float3 + a zero pad each): plain
        # float32 arrays, no structured copies (a million triangles in a fresh process pays
        # for every new array in page faults)
        p4 = np.zeros((len(p), 4), np.float32)
        p4[:, :3] = p
        tri = np.take(p4, f, axis=0)
        degenerate = zero_area(tri[:, 0, :3], tri[:, 1, :3], tri[:, 2, :3])
        if degenerate.all():
            raise SceneError(f"{self.name}: faces: all {len(f)} triangles have zero area; nothing to render")
        warn_degenerate(self.name, degenerate)
        if degenerate.any():
            keep = np.flatnonzero(~degenerate)
            fk, tri = f[keep], tri[keep]
        else:                                     # the common case: no copies
            keep, fk = np.arange(len(f)), f
        k = len(keep)
        tv = tri.reshape(k, 12).view(layout.TRI_VERTS).reshape(k)   # layout.tri_corners' view, inverted
        material = np.asarray(material)[self.face_materials()[keep]] if np.ndim(material) else material
        flags = 0
        arrays = {"tri_verts": tv}
        if with_normals:
            flags |= layout.TRI_HAS_NORMALS if n is not None else 0
            arrays["normals"] = n if n is not None else np.zeros_like(p)
        if with_uvs:
            flags |= layout.TRI_HAS_UVS if self.uvs is not None else 0
            arrays["uvs"] = self.uvs if self.uvs is not None else np.zeros((len(p), 2))
        # layout.TRI_SHADE as plain words (the padding zero)
        ts, w = layout.TRI_SHADE, layout.word
        words = np.zeros((k, ts.itemsize // 4), np.uint32)
        words[:, w(ts, "v"):w(ts, "v") + 3] = fk + vertex_offset
        for name, value in (("material", material), ("object", object_id), ("prim", keep), ("flags", flags)):
            words[:, w(ts, name)] = value
        arrays["tri_shade"] = words.view(ts).reshape(k)
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
    return zero_area(positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]])


def zero_area(a, b, c):
    """Boolean mask of the triangles (a, b, c) ((F, 3) corners) whose cross product
    (b - a) x (c - a) is exactly zero in float64 (float32 corners: the differences and
    products are exact, so "zero" is exact collinearity); the components written out
    (np.cross's copies cost 0.4 s on a million triangles), in chunks of _CHUNK triangles
    whose float64 temporaries stay in the cache and in reused memory."""
    out = np.empty(len(a), bool)
    for s in range(0, len(a), _CHUNK):
        a_, b_, c_ = a[s:s + _CHUNK], b[s:s + _CHUNK], c[s:s + _CHUNK]
        u = b_.astype(np.float64) - a_
        v = c_.astype(np.float64) - a_
        ux, uy, uz, vx, vy, vz = u[:, 0], u[:, 1], u[:, 2], v[:, 0], v[:, 1], v[:, 2]
        out[s:s + _CHUNK] = (uy * vz == uz * vy) & (uz * vx == ux * vz) & (ux * vy == uy * vx)
    return out


_CHUNK = 1 << 15


def warn_degenerate(name, mask):
    n = int(mask.sum())
    if n:
        first = np.flatnonzero(mask)[:5].tolist()
        warnings.warn(f"{name}: {n} zero-area triangle(s) skipped (faces {first}{'...' if n > 5 else ''})",
                      stacklevel=3)
