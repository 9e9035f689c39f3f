"""Mesh files through trimesh: OBJ, PLY, GLB/GLTF, OFF and STL, read unprocessed
(nothing silently merged or dropped) and reported by name when unreadable."""
from __future__ import annotations

import re
import warnings

import numpy as np

from ..errors import SceneError
from ..linalg import apply_normals, apply_points
from .. import validate as V


def read_mesh(path):
    """(positions, faces, uvs | None, normals | None, name) of every triangle geometry in
    the file at ``path``, scene-graph transforms applied."""
    import trimesh           # 0.2 s to import: only when a mesh file is read
    path = V.file_path(path, "mesh")
    data = path.read_bytes()
    kind = path.suffix.lower().lstrip(".")
    if kind in _TEXT_MESH_FORMATS:
        try:
            data.decode("utf-8")
        except UnicodeDecodeError as e:
            raise SceneError(f"mesh: cannot read {path}: not UTF-8 text ({kind.upper()} is a text format; "
                             f"byte {data[e.start]:#04x} at offset {e.start})") from None
    try:
        loaded = trimesh.load(str(path), process=False)
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
    if not parts or sum(len(f) for _, f, _, _ in parts) == 0:
        raise SceneError(f"mesh: {path} contains no triangles")
    offsets = np.cumsum([0] + [len(p) for p, _, _, _ in parts])
    positions = np.concatenate([p for p, _, _, _ in parts])
    faces = np.concatenate([f + o for (_, f, _, _), o in zip(parts, offsets)])
    if kind == "obj":
        _warn_dropped_faces(path, data, len(faces))
    uvs = None if any(u is None for _, _, u, _ in parts) else np.concatenate([u for _, _, u, _ in parts])
    normals = None if any(n is None for _, _, _, n in parts) else np.concatenate([n for _, _, _, n in parts])
    return positions, faces, uvs, normals, str(path)


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
    """[(positions, faces, uvs | None, normals | None)] of every triangle geometry in a
    trimesh load result, with scene-graph transforms applied; nothing is merged or dropped.
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
        out.append((p, np.asarray(g.faces, dtype=np.int64),
                    None if uv is None or len(uv) != len(p) else np.asarray(uv, dtype=np.float64), n))
    return out
