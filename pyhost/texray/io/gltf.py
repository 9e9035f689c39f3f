"""glTF 2.0 files (.gltf with external or data-URI buffers and images, .glb): meshes in
world space, perspective cameras and KHR_lights_punctual lights, as plain data and
texray scene objects (nothing here renders).

    f = read_gltf("scene.glb")
    for m in f.meshes:        # one per node with a mesh, its primitives merged
        m.positions, m.faces, m.uvs, m.normals, m.materials, m.material_ids

Layers: :mod:`.gltf_data` (the JSON, buffers, accessors, checked fields),
:mod:`.gltf_materials` (the material rule, textures, bakes), this module (the node
hierarchy, primitives, cameras, lights).

Conventions (texray's):

* texture coordinates: texray's v = 0 is the image's bottom row (texray.Texture keeps
  row 0 = the top row, as read), glTF's (0, 0) is the image's top-left corner: texray
  uv = (u, 1 - v) of glTF's TEXCOORD_0, with the image as read.
* node transforms: ``matrix`` (column-major) or T R S, world = parent * child. Normals
  take the inverse transpose; a node whose matrix mirrors (negative determinant) has its
  triangles' vertex order reversed, which keeps their front side (the glTF spec's rule).
* cameras: eye = the node's origin, forward = its -Z axis, up = its +Y axis; yfov
  radians -> fov_y degrees. Orthographic cameras are skipped (texray is perspective).
* lights: point -> PointLight(position, color * intensity) (candela: texray's I / d^2
  is in the same units); spot -> the same, its cone ignored; directional -> a point
  light along -direction at 1000 x the scene's bounding radius from its centre,
  intensity = lux * d^2.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..linalg import apply_normals, apply_points
from ..scene.camera import Camera
from ..scene.light import PointLight
from ..scene.material import Material
from .gltf_data import ACCESSOR_TYPES, INDEX_COMPONENT_TYPES, GltfDocument, Notes
from .gltf_materials import MaterialBuilder

SUPPORTED_EXTENSIONS = ("KHR_texture_transform", "KHR_lights_punctual", "KHR_mesh_quantization")
# Required extensions that only refine shading texray does not have: read, ignored with a warning.
IGNORED_EXTENSION_PREFIX = "KHR_materials_"
DIRECTIONAL_DISTANCE = 1000.0      # x the scene's bounding radius: where a directional light is put
MODES = {0: "POINTS", 1: "LINES", 2: "LINE_LOOP", 3: "LINE_STRIP", 4: "TRIANGLES", 5: "TRIANGLE_STRIP",
         6: "TRIANGLE_FAN"}
_SINGULAR = 1e-300                 # |det| of a node's 3x3 below this: it flattens its mesh


@dataclass
class GltfMesh:
    """The merged primitives of one node's mesh, in world space.

    name: "FILE: nodes[i] 'name'" (the node's name, else the mesh's). positions (V, 3)
    float64; faces (F, 3) int64; uvs (V, 2) float64 in texray's convention (u, 1 - v) or
    None if no primitive has TEXCOORD_0 (zeros for the vertices of those without, when
    others have it); normals (V, 3) float64 unit (zeros likewise) or None; materials: the
    texray Materials of the mesh's glTF materials, one per glTF material index (shared
    between meshes of the file); material_ids (F,) int64 into materials."""
    name: str
    positions: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None
    normals: np.ndarray | None
    materials: list
    material_ids: np.ndarray
    mesh_index: int = -1                  # the glTF mesh (nodes sharing one can be instances of it)
    world: np.ndarray | None = None       # the node's 4x4 world matrix (positions = world x local)
    local: object = None                  # the mesh in its own space (positions, faces, uvs, normals, ...)


@dataclass
class GltfFile:
    """What :func:`read_gltf` found in a file's default scene (the file's ``scene``, else
    scenes[0], else every root node). cameras: [(name, Camera, aspectRatio or None)];
    lights: [(name, PointLight)]."""
    path: str
    meshes: list
    cameras: list
    lights: list


def read_gltf(path, materials=True) -> GltfFile:
    """Read a .gltf or .glb file (see the module docstring). ``materials=False`` reads no
    image and makes each glTF material a default ``texray.Material()`` (faces keep their
    material ids). Raises SceneError naming the file, the JSON path and the value; warns
    once per topic about what texray ignores or approximates."""
    doc = GltfDocument(path)
    notes = Notes(doc.label)
    _check_extensions(doc, notes)
    builder = MaterialBuilder(doc, notes) if materials else None
    local_meshes, plain = {}, {}
    meshes, cameras, light_nodes = [], [], []
    for ni, world in _scene_nodes(doc):
        node = doc.item("nodes", ni)
        where = f"nodes[{ni}]"
        if "skin" in node:
            notes.add("skins ignored (meshes drawn as stored, under their node transforms)", where)
        if "mesh" in node:
            mi = doc.ref(node, "mesh", where, "meshes")
            if mi not in local_meshes:
                local_meshes[mi] = _local_mesh(doc, mi, notes, builder, plain)
            m = _place(doc, ni, node, mi, world, local_meshes[mi], notes)
            if m is not None:
                meshes.append(m)
        if "camera" in node:
            c = _camera(doc, ni, node, world, notes)
            if c is not None:
                cameras.append(c)
        ext = doc.get(node, "extensions", where, "dict", {})
        if "KHR_lights_punctual" in ext:
            light_nodes.append((ni, world, doc.get(ext, "KHR_lights_punctual", f"{where}.extensions", "dict")))
    lights = _lights(doc, light_nodes, meshes, notes)
    notes.emit(stacklevel=3)      # at read_gltf's caller
    return GltfFile(str(path), meshes, cameras, lights)


# --- extensions -------------------------------------------------------------------------
def _check_extensions(doc, notes):
    def names(key):
        items = doc.get(doc.json, key, "(top level)", "list", [])
        for i, n in enumerate(items):
            if not isinstance(n, str):
                raise doc.error(f"{key}[{i}]", f"expected an extension name, got {n!r}")
        return items

    for name in names("extensionsRequired"):
        if name not in SUPPORTED_EXTENSIONS and not name.startswith(IGNORED_EXTENSION_PREFIX):
            raise doc.error("extensionsRequired", f"{name!r} is not supported by texray (it reads "
                            f"{', '.join(SUPPORTED_EXTENSIONS)}; {IGNORED_EXTENSION_PREFIX}* are ignored)")
    for name in names("extensionsUsed"):
        if name not in SUPPORTED_EXTENSIONS and not name.startswith(IGNORED_EXTENSION_PREFIX):
            notes.add("extensions not read by texray (their core fallbacks are used)", name)


# --- the node hierarchy -------------------------------------------------------------------
def quaternion_matrix(q):
    """3x3 rotation of a unit quaternion (x, y, z, w), glTF's order."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def node_matrix(doc, node, where):
    """The 4x4 local matrix of a node: ``matrix`` (column-major) or T R S."""
    if "matrix" in node:
        m = doc.numbers(node, "matrix", where, 16).reshape(4, 4).T
        if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
            raise doc.error(f"{where}.matrix", f"not an affine transform (its last row is {m[3].tolist()}, "
                            "expected [0, 0, 0, 1])")
        return m
    t = doc.numbers(node, "translation", where, 3, np.zeros(3))
    q = doc.numbers(node, "rotation", where, 4, np.array([0.0, 0.0, 0.0, 1.0]))
    s = doc.numbers(node, "scale", where, 3, np.ones(3))
    norm = np.linalg.norm(q)
    if not norm > 0:
        raise doc.error(f"{where}.rotation", f"{q.tolist()} is not a rotation (a zero quaternion)")
    m = np.eye(4)
    m[:3, :3] = quaternion_matrix(q / norm) * s
    m[:3, 3] = t
    return m


def _scene_nodes(doc):
    """[(node index, world matrix)] of the default scene, depth first, children in order."""
    top = doc.json
    if "scene" in top:
        si = doc.ref(top, "scene", "(top level)", "scenes")
    elif doc.array("scenes"):
        si = 0
    else:
        si = None
    nodes = doc.array("nodes")
    if si is None:
        children = set()
        for i in range(len(nodes)):
            children.update(c for c in doc.get(doc.item("nodes", i), "children", f"nodes[{i}]", "list", [])
                            if isinstance(c, int))
        roots, rw = [i for i in range(len(nodes)) if i not in children], None
    else:
        roots = doc.get(doc.item("scenes", si), "nodes", f"scenes[{si}]", "list", [])
        rw = f"scenes[{si}].nodes"
    out, seen = [], set()
    stack = [(r, np.eye(4), f"{rw}[{k}]" if rw else None) for k, r in enumerate(roots)][::-1]
    while stack:
        ni, parent, ref = stack.pop()
        node = doc.item("nodes", ni, ref)
        if ni in seen:
            raise doc.error(ref or f"nodes[{ni}]", f"nodes[{ni}] appears twice in the scene's hierarchy (a cycle, "
                            "or a node with two parents)")
        seen.add(ni)
        where = f"nodes[{ni}]"
        world = parent @ node_matrix(doc, node, where)
        out.append((ni, world))
        kids = doc.get(node, "children", where, "list", [])
        stack.extend((c, world, f"{where}.children[{k}]") for k, c in reversed(list(enumerate(kids))))
    return out


# --- meshes ---------------------------------------------------------------------------
class _LocalMesh:
    """A glTF mesh's primitives merged, in the mesh's own space (shared by its nodes)."""

    def __init__(self, positions, faces, uvs, normals, material_ids, materials):
        self.positions, self.faces, self.uvs, self.normals = positions, faces, uvs, normals
        self.material_ids, self.materials = material_ids, materials


def _attribute(doc, attrs, key, jpath, width, count):
    ai = doc.ref(attrs, key, f"{jpath}.attributes", "accessors")
    _, t, _ = doc.accessor_info(ai, f"{jpath}.attributes.{key}")
    if ACCESSOR_TYPES[t] != (1, width):
        raise doc.error(f"{jpath}.attributes.{key}", f"accessors[{ai}] is {t}; {key} is VEC{width}")
    a = doc.accessor(ai, f"{jpath}.attributes.{key}").astype(np.float64)
    if count is not None and len(a) != count:
        raise doc.error(f"{jpath}.attributes.{key}", f"accessors[{ai}] has {len(a)} elements, POSITION has {count}")
    return a, ai


def _triangles(doc, prim, jpath, mode, n_vertices):
    """(F, 3) vertex indices of a triangles / strip / fan primitive."""
    if "indices" in prim:
        ii = doc.ref(prim, "indices", jpath, "accessors")
        ct, t, normalized = doc.accessor_info(ii, f"{jpath}.indices")
        if t != "SCALAR" or ct not in INDEX_COMPONENT_TYPES or normalized:
            raise doc.error(f"{jpath}.indices", f"accessors[{ii}] is {'normalized ' if normalized else ''}{t} of "
                            f"componentType {ct}; indices are SCALAR of {', '.join(map(str, INDEX_COMPONENT_TYPES))}, "
                            "not normalized")
        idx = doc.accessor(ii, f"{jpath}.indices")[:, 0]
        if idx.size and idx.max() >= n_vertices:
            k = int(np.argmax(idx >= n_vertices))
            raise doc.error(f"{jpath}.indices", f"accessors[{ii}][{k}] = {int(idx[k])} indexes past the "
                            f"{n_vertices} vertices of the primitive")
        shown = f"accessors[{ii}] holds {len(idx)} indices"
    else:
        idx = np.arange(n_vertices, dtype=np.int64)
        shown = f"POSITION has {n_vertices} vertices (no indices)"
    if mode == 4:
        if len(idx) % 3:
            raise doc.error(jpath, f"{shown}, not a multiple of 3 (mode 4, TRIANGLES)")
        return idx.reshape(-1, 3)
    n = max(len(idx) - 2, 0)
    i = np.arange(n)
    if mode == 5:        # strip: (i, i+1, i+2), every other one reversed to keep the winding
        odd = i % 2
        return np.stack([idx[i], idx[i + 1 + odd], idx[i + 2 - odd]], axis=1)
    return np.stack([idx[i + 1], idx[i + 2], np.full(n, idx[0] if len(idx) else 0)], axis=1)   # fan


def _local_mesh(doc, mi, notes, builder, plain):
    mesh = doc.item("meshes", mi)
    mw = f"meshes[{mi}]"
    prims = doc.get(mesh, "primitives", mw, "list")
    vertex_sets = {}     # attribute accessors -> vertex offset (primitives sharing vertices share them)
    pos, uvs, nrm, faces, fmat, has_uv, keys = [], [], [], [], [], [], []
    total = 0
    for pi, prim in enumerate(prims):
        pw = f"{mw}.primitives[{pi}]"
        if not isinstance(prim, dict):
            raise doc.error(pw, f"expected an object, got {prim!r}")
        mode = doc.get(prim, "mode", pw, "int", 4)
        if mode not in MODES:
            raise doc.error(f"{pw}.mode", f"{mode} is not a glTF primitive mode (0..6)")
        if mode < 4:
            notes.add("points and lines skipped (texray renders triangles)", MODES[mode], pw)
            continue
        attrs = doc.get(prim, "attributes", pw, "dict")
        if "POSITION" not in attrs:
            notes.add("primitives without POSITION skipped", pw)
            continue
        if prim.get("targets"):
            notes.add("morph targets ignored (the base shape is drawn)", pw)
        p, pa = _attribute(doc, attrs, "POSITION", pw, 3, None)
        uv = _attribute(doc, attrs, "TEXCOORD_0", pw, 2, len(p)) if "TEXCOORD_0" in attrs else (None, None)
        n = _attribute(doc, attrs, "NORMAL", pw, 3, len(p)) if "NORMAL" in attrs else (None, None)
        tri = _triangles(doc, prim, pw, mode, len(p))
        key = (pa, uv[1], n[1])
        if key not in vertex_sets:
            vertex_sets[key] = total
            total += len(p)
            pos.append(p)
            uvs.append(None if uv[0] is None else np.column_stack([uv[0][:, 0], 1.0 - uv[0][:, 1]]))
            nrm.append(n[0])
        mat = doc.ref(prim, "material", pw, "materials", None)
        if mat not in keys:
            keys.append(mat)
        faces.append(tri + vertex_sets[key])
        fmat.append(np.full(len(tri), keys.index(mat), dtype=np.int64))
        has_uv.append((uv[0] is not None, mat, pw))
    if not pos or sum(len(f) for f in faces) == 0:
        return None
    if builder is not None:
        materials = [builder.material(k) for k in keys]
        for with_uv, mat, pw in has_uv:
            m = materials[keys.index(mat)]
            if not with_uv and m.textures:
                who = "the default material" if mat is None else doc.name_of("materials", mat)
                raise doc.error(pw, f"{who} has a texture ({m.textures[0].name}) but the primitive has no "
                                "TEXCOORD_0")
    else:
        materials = [plain.setdefault(k, Material()) for k in keys]
    any_uv = any(u is not None for u in uvs)
    any_n = any(x is not None for x in nrm)
    sizes = [len(p) for p in pos]
    return _LocalMesh(np.concatenate(pos), np.concatenate(faces),
                      np.concatenate([u if u is not None else np.zeros((k, 2)) for u, k in zip(uvs, sizes)])
                      if any_uv else None,
                      np.concatenate([x if x is not None else np.zeros((k, 3)) for x, k in zip(nrm, sizes)])
                      if any_n else None,
                      np.concatenate(fmat), materials)


def _node_name(doc, ni, node, mi):
    own = node.get("name") if isinstance(node.get("name"), str) and node.get("name") else None
    if own is None and mi is not None:
        m = doc.item("meshes", mi).get("name")
        own = m if isinstance(m, str) and m else None
    return f"nodes[{ni}]" + (f" {own!r}" if own else "")


def _place(doc, ni, node, mi, world, local, notes):
    name = f"{doc.label}: {_node_name(doc, ni, node, mi)}"
    if local is None:
        notes.add("meshes without triangles skipped", f"meshes[{mi}]", f"nodes[{ni}]")
        return None
    det = np.linalg.det(world[:3, :3])
    if not abs(det) > _SINGULAR:
        notes.add("nodes with a singular transform (scale 0) skipped", f"nodes[{ni}]")
        return None
    faces = local.faces if det > 0 else local.faces[:, [0, 2, 1]]
    normals = None if local.normals is None else apply_normals(world, local.normals)
    # an identity node keeps the positions as stored: a bad value is reported as the file has it
    positions = local.positions if np.array_equal(world, np.eye(4)) else apply_points(world, local.positions)
    return GltfMesh(name, positions, np.ascontiguousarray(faces),
                    None if local.uvs is None else local.uvs.copy(), normals, list(local.materials),
                    local.material_ids.copy(), mi, world, local)


# --- cameras and lights ------------------------------------------------------------------
def _unit(v):
    n = np.linalg.norm(v)
    return v / n if n > 0 else v


def _camera(doc, ni, node, world, notes):
    ci = doc.ref(node, "camera", f"nodes[{ni}]", "cameras")
    cam = doc.item("cameras", ci)
    cw = f"cameras[{ci}]"
    kind = doc.get(cam, "type", cw, "str")
    if kind == "orthographic":
        notes.add("orthographic cameras skipped (texray's camera is perspective)", cw)
        return None
    if kind != "perspective":
        raise doc.error(f"{cw}.type", f"{kind!r} (expected perspective or orthographic)")
    p = doc.get(cam, "perspective", cw, "dict")
    yfov = doc.number(p, "yfov", f"{cw}.perspective", lo=0.0)
    aspect = doc.number(p, "aspectRatio", f"{cw}.perspective", None, lo=0.0)
    if yfov == 0 or aspect == 0:
        raise doc.error(f"{cw}.perspective.{'yfov' if yfov == 0 else 'aspectRatio'}", "0 (expected > 0)")
    eye = world[:3, 3].copy()
    forward, up = _unit(-world[:3, 2]), _unit(world[:3, 1])
    name = _plain_name(node, cam, cw)
    try:
        camera = Camera(eye=tuple(eye), look_at=tuple(eye + forward), up=tuple(up), fov_y=math.degrees(yfov))
    except SceneError as e:
        raise SceneError(f"{doc.label}: nodes[{ni}] ({cw}): {e}") from None
    return name, camera, aspect


def _plain_name(node, obj, fallback):
    for o in (node, obj):
        n = o.get("name")
        if isinstance(n, str) and n:
            return n
    return fallback


def _bounds(meshes):
    """(centre, radius) of the meshes' bounding box; radius 1 for no or a point-sized scene."""
    if not meshes:
        return np.zeros(3), 1.0
    lo = np.min([m.positions.min(axis=0) for m in meshes], axis=0)
    hi = np.max([m.positions.max(axis=0) for m in meshes], axis=0)
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    return 0.5 * (lo + hi), (radius if radius > 0 else 1.0)


def _lights(doc, light_nodes, meshes, notes):
    if not light_nodes:
        return []
    ext = doc.get(doc.json, "extensions", "(top level)", "dict", {})
    root = doc.get(ext, "KHR_lights_punctual", "extensions", "dict", {})
    defs = doc.get(root, "lights", "extensions.KHR_lights_punctual", "list", [])
    centre, radius = None, None
    out = []
    for ni, world, node_ext in light_nodes:
        nw = f"nodes[{ni}].extensions.KHR_lights_punctual"
        li = doc.get(node_ext, "light", nw, "int")
        if not 0 <= li < len(defs) or not isinstance(defs[li], dict):
            raise doc.error(f"{nw}.light", f"{li} is not an index of extensions.KHR_lights_punctual.lights "
                            f"({len(defs)} defined)")
        light = defs[li]
        lw = f"extensions.KHR_lights_punctual.lights[{li}]"
        kind = doc.get(light, "type", lw, "str")
        color = doc.numbers(light, "color", lw, 3, np.ones(3))
        intensity = doc.number(light, "intensity", lw, 1.0, lo=0.0)
        if np.any(color < 0):
            raise doc.error(f"{lw}.color", f"{color.tolist()} (expected values >= 0)")
        if "range" in light:
            doc.number(light, "range", lw, lo=0.0)
            notes.add("KHR_lights_punctual: range ignored (texray's lights fall off as 1/d^2 everywhere)", lw)
        if kind in ("point", "spot"):
            if kind == "spot":
                notes.add("spot lights rendered as point lights (cone ignored)", lw)
            position, rgb = world[:3, 3], color * intensity
        elif kind == "directional":
            if centre is None:
                centre, radius = _bounds(meshes)
            d = DIRECTIONAL_DISTANCE * radius
            towards = _unit(world[:3, 2])          # the light shines along its node's -Z
            position, rgb = centre + towards * d, color * intensity * d * d
            notes.add(f"directional lights approximated by point lights at {DIRECTIONAL_DISTANCE:g} x the scene's "
                      f"bounding radius ({d:.6g})", lw)
        else:
            raise doc.error(f"{lw}.type", f"{kind!r} (expected point, spot or directional)")
        try:
            out.append((_plain_name(doc.item("nodes", ni), light, f"lights[{li}]"),
                        PointLight(position=tuple(position), intensity=tuple(rgb))))
        except SceneError as e:
            raise SceneError(f"{doc.label}: nodes[{ni}] ({lw}): {e}") from None
    return out
