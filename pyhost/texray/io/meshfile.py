"""Mesh files: OBJ (with its MTL materials: texray.io.mtl), PLY, OFF and STL through
trimesh, read unprocessed (nothing silently merged or dropped), glTF through
texray.io.gltf; every file reported by name when unreadable."""
from __future__ import annotations

import re
import warnings
from typing import NamedTuple

import numpy as np

from ..errors import SceneError
from ..linalg import apply_normals, apply_points
from ..scene.material import Material
from .. import validate as V
from .gltf import read_gltf
from .mtl import read_mtl, to_materials


class MeshData(NamedTuple):
    """A mesh file's triangles (scene-graph transforms applied) and materials."""
    positions: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None
    normals: np.ndarray | None
    name: str
    materials: list            # [texray.Material]: the file's own (one default grey for formats without)
    material_ids: np.ndarray   # (F,) index into materials


def read_mesh(path, materials=True) -> MeshData:
    """Every triangle geometry in the file at ``path``, scene-graph transforms applied, with
    the file's materials when ``materials`` (OBJ/MTL, glTF; else one default Material)."""
    path = V.file_path(path, "mesh")
    kind = path.suffix.lower().lstrip(".")
    if kind in ("gltf", "glb"):
        g = read_gltf(path, materials=materials)
        if not g.meshes:
            raise SceneError(f"mesh: {path} contains no triangles")
        return merge_meshes(g.meshes, str(path), materials)
    # the OBJ's text, read once for its mtllib and usemtl statements (undecodable: refused later)
    text = path.read_bytes().decode("utf-8", "replace") if kind == "obj" and materials else ""
    libs = _mtllibs(path, text)
    entries = {}
    for lib in libs:
        entries.update(read_mtl(lib, path))
    names = _usemtl_names(text) if libs else None
    parts = _read_trimesh(path, kind, names)
    offsets = np.cumsum([0] + [len(p.positions) for p in parts])
    positions = np.concatenate([p.positions for p in parts])
    faces = np.concatenate([p.faces + o for p, o in zip(parts, offsets)])
    uvs, normals = _parts_field(parts, "uvs", 2), _parts_field(parts, "normals", 3)
    if not libs:
        return MeshData(positions, faces, uvs, normals, str(path), [Material()], np.zeros(len(faces), np.int64))
    used = {p.material for p in parts}
    order = [n for n in names if n in used] + [n for n in dict.fromkeys(p.material for p in parts) if n not in names]
    mats = to_materials(entries, order, path)       # in the order of first use in the file
    for p in parts:
        m = mats[order.index(p.material)]
        if p.uvs is None and m.textures:
            raise SceneError(f"{path}: material {p.material!r} has a texture ({m.textures[0].name}) but the "
                             "file gives its faces no texture coordinates (vt)")
    ids = np.repeat(np.array([order.index(p.material) for p in parts], np.int64), [len(p.faces) for p in parts])
    return MeshData(positions, faces, uvs, normals, str(path), mats, ids)


def merge_meshes(meshes, name, materials=True) -> MeshData:
    """One MeshData of several (each with positions, faces, uvs, normals, materials,
    material_ids): vertices concatenated, materials deduplicated by identity."""
    offsets = np.cumsum([0] + [len(m.positions) for m in meshes])
    positions = np.concatenate([m.positions for m in meshes])
    faces = np.concatenate([m.faces + o for m, o in zip(meshes, offsets)])
    uvs, normals = _parts_field(meshes, "uvs", 2), _parts_field(meshes, "normals", 3)
    if not materials:
        return MeshData(positions, faces, uvs, normals, name, [Material()], np.zeros(len(faces), np.int64))
    mats, ids = [], []
    for m in meshes:
        local = []
        for mt in m.materials:
            if not any(mt is x for x in mats):
                mats.append(mt)
            local.append(next(i for i, x in enumerate(mats) if x is mt))
        ids.append(np.asarray(local, np.int64)[m.material_ids])
    return MeshData(positions, faces, uvs, normals, name, mats, np.concatenate(ids))


def _mtllibs(path, text):
    """The material libraries the OBJ at ``path`` (its ``text``) names (``mtllib a.mtl b.mtl``),
    relative to the OBJ."""
    libs = []
    for line in text.splitlines():
        if line.startswith("mtllib"):
            rest = line[len("mtllib"):].split("#", 1)[0].strip()
            names = [rest] if (path.parent / rest).exists() else rest.split()
            libs += [path.parent / n for n in names if n]
    return libs


class _Part(NamedTuple):
    """One triangle geometry of a trimesh load result (OBJ: one per usemtl material)."""
    positions: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None
    normals: np.ndarray | None
    material: str | None          # the material's name (OBJ: its usemtl)


def _usemtl_names(text):
    """Every material name an OBJ's usemtl statements give, in order of first use."""
    names = re.findall(r"^[ \t]*usemtl[ \t]+(.+?)[ \t]*$", text, re.M)
    return list(dict.fromkeys(names))


def _resolver(path, mtl_names):
    """A trimesh resolver that gives an OBJ's mtllib as one plain material per usemtl name:
    trimesh then groups the faces by usemtl and keeps the names (texray.io.mtl reads the
    libraries themselves; trimesh's reader keeps little of them and wants Pillow for maps)."""
    from trimesh.resolvers import FilePathResolver

    class MtlNames(FilePathResolver):
        def get(self, name):
            if str(name).lower().endswith(".mtl"):
                return "".join(f"newmtl {n}\nKd 1 1 1\n" for n in mtl_names).encode()
            return super().get(name)
    return MtlNames(str(path))


def _read_trimesh(path, kind, mtl_names=None) -> list[_Part]:
    """Every triangle geometry trimesh reads from ``path`` (a non-empty list); an OBJ's
    faces grouped by the ``mtl_names`` of its usemtl statements when given."""
    import trimesh           # 0.2 s to import: only when a mesh file is read
    data = path.read_bytes()
    kind = path.suffix.lower().lstrip(".")
    if kind in _TEXT_MESH_FORMATS:
        try:
            data.decode("utf-8")
        except UnicodeDecodeError as e:
            raise SceneError(f"mesh: cannot read {path}: not UTF-8 text ({kind.upper()} is a text format; "
                             f"byte {data[e.start]:#04x} at offset {e.start})") from None
    try:
        extra = {"resolver": _resolver(path, mtl_names)} if mtl_names else {}
        loaded = trimesh.load(str(path), process=False, **extra)
    except IndexError as e:  # trimesh's parsers index vertex arrays with the file's face indices
        raise SceneError(f"mesh: cannot read {path}: a face refers to a vertex (or uv, normal) the file does "
                         f"not define ({e})") from None
    except ModuleNotFoundError:   # trimesh guesses the encoding of undecodable text with an extra module
        raise SceneError(f"mesh: cannot read {path}: neither UTF-8 text nor a binary {kind.upper()} file "
                         "trimesh recognizes") from None
    except Exception as e:   # trimesh raises many kinds of errors for unreadable files
        raise SceneError(f"mesh: cannot read {path}: {type(e).__name__}: {e}") from None
    try:
        parts = _flatten(loaded)
    except Exception as e:   # malformed files can leave trimesh objects inconsistent
        raise SceneError(f"mesh: cannot read {path}: {type(e).__name__}: {e}") from None
    if not parts or sum(len(p.faces) for p in parts) == 0:
        raise SceneError(f"mesh: {path} contains no triangles")
    if kind == "obj":
        _warn_dropped_faces(path, data, sum(len(p.faces) for p in parts))
    return parts


def _parts_field(parts, field, width):
    """The parts' ``field`` (uvs, normals) concatenated: None if no part has it, zeros for
    parts without when some have it (a textured material on such a part is refused)."""
    if all(getattr(p, field) is None for p in parts):
        return None
    return np.concatenate([getattr(p, field) if getattr(p, field) is not None else np.zeros((len(p.positions), width))
                           for p in parts])


# Mesh formats that are text: bytes that are not UTF-8 make trimesh guess an encoding
# (and need a module it does not install), so they are refused first with a clear message.
_TEXT_MESH_FORMATS = ("obj", "off")


def _warn_dropped_faces(path, data, n_loaded):
    """Warn when an OBJ's face lines give fewer triangles than there are face lines
    (each gives at least one): a truncated or malformed file that trimesh read in part."""
    n_lines = len(re.findall(rb"^[ \t]*f[ \t]", data, re.M))
    if n_loaded < n_lines:
        warnings.warn(f"{path}: {n_lines} face lines but {n_loaded} triangles loaded: "
                      f"{n_lines - n_loaded} or more faces are malformed or truncated and were skipped",
                      stacklevel=4)


def _flatten(loaded):
    """[(positions, faces, uvs | None, normals | None, material name | None)] of every triangle
    geometry in a trimesh load result, with scene-graph transforms applied; nothing is merged
    or dropped.
    Normals are the file's own (trimesh keeps them in its cache when the file has them)."""
    import trimesh
    if isinstance(loaded, trimesh.Trimesh):
        items = [(np.eye(4), loaded)]
    elif isinstance(loaded, trimesh.Scene):
        items = []
        for node in loaded.graph.nodes_geometry:
            m, gname = loaded.graph[node]
            g = loaded.geometry.get(gname)
            if isinstance(g, trimesh.Trimesh):
                items.append((np.asarray(m, dtype=np.float64), g))
    else:
        return []
    out = []
    for m, g in items:
        identity = np.array_equal(m, np.eye(4))
        p = np.asarray(g.vertices, dtype=np.float64)
        p = p if identity else apply_points(m, p)
        uv = getattr(g.visual, "uv", None)
        n = g._cache.cache.get("vertex_normals") if hasattr(g, "_cache") else None
        if n is not None and len(n) == len(p):
            n = np.asarray(n, dtype=np.float64)
            n = n if identity else apply_normals(m, n)
        else:
            n = None
        out.append(_Part(p, np.asarray(g.faces, dtype=np.int64),
                         None if uv is None or len(uv) != len(p) else np.asarray(uv, dtype=np.float64), n,
                         getattr(getattr(g.visual, "material", None), "name", None)))
    return out
