"""The scene compiler: a :class:`~texray.scene.Scene` becomes flat arrays laid out by
:mod:`texray.device.layout`, one BVH over every primitive (each kind's array in leaf
order) and a feature set. Each shape makes its own device records
(``device_records``, ``displaced_record``); this module orders them, builds the BVH
and the material, texture and object tables. Everything is vectorized numpy over
primitives (the only Python loops are over scene objects); only what the scene uses
is produced."""
from __future__ import annotations

import copy
import time
import warnings
from dataclasses import dataclass

import numpy as np

from ..accel import wide
from ..accel.scene_bvh import BUILDERS, SceneBVH, build_scene_bvh
from ..device import buffers, layout
from ..device.features import Features, max_lights_for, stack_size_for
from ..errors import SceneError
from ..scene import Camera, Cylinder, Instance, Mesh, Quad, Scene, Sphere
from ..scene.shape import check_extent, materials_of, outward
from ..scene.texture import FILTERS
from . import instances as inst_blas
from . import units
from . import shells as mesh_shells
from .heights import METHOD_ADAPTIVE, METHOD_IDS, height_key, pack_heights
from .materials import MaterialTable
from .objects import object_table
from .tessellate import tessellate
from .tessellate_mesh import tessellate_mesh
from .textures import pack as pack_textures


@dataclass
class CompiledScene:
    """Everything a render needs, without the Scene: the device arrays (named as in
    texray.device.buffers' manifest), the feature set, the BVH's statistics, the camera
    and the names errors quote."""
    tri_verts: np.ndarray          # layout.TRI_VERTS, BVH leaf order
    tri_shade: np.ndarray          # layout.TRI_SHADE, same order
    spheres: np.ndarray            # layout.SPHERE, leaf order
    cylinders: np.ndarray          # layout.CYLINDER, leaf order
    quad_verts: np.ndarray         # layout.QUAD_VERTS, leaf order
    quad_shade: np.ndarray         # layout.QUAD_SHADE, same order
    nodes: np.ndarray              # layout.BVH4_NODE (texray.accel.wide), what the kernels traverse
    normals: np.ndarray | None     # float32 (V*3,), indexed by TriShade.v
    uvs: np.ndarray | None         # float32 (V*2,)
    materials: np.ndarray          # layout.MATERIAL
    textures: np.ndarray | None    # layout.TEXTURE
    texels: np.ndarray | None      # float16 (T*4,) RGBA, linear
    objects: np.ndarray | None     # layout.OBJECT, when some object has a projection mapping
    lights: np.ndarray             # layout.POINT_LIGHT
    ambient: np.ndarray            # float32 (4,)
    background: np.ndarray         # float32 (4,)
    features: Features
    bvh: SceneBVH
    displaced: np.ndarray | None = None   # layout.DISPLACED, leaf order (kernels: geometry/displace.h)
    heights: np.ndarray | None = None     # uint16 (unorm over [hmin, hmax]) height fields and their min-max pyramids
    wide_depth: int = 0                   # levels of the 4-wide tree in ``nodes``
    camera: Camera | None = None          # the scene's camera when compiled
    objects_generic: np.ndarray | None = None   # layout.OBJECT for every object: what the generic program reads
    texture_names: tuple = ()             # the textures' names, for error messages
    instances: np.ndarray | None = None   # layout.INSTANCE, top-level leaf order (kernels/accel/instance.h)
    steps_s: dict | None = None           # seconds of each step of compile_scene (image.stats["compile_steps_s"])
    blas_reused: int = 0                  # instanced meshes whose BLAS came from an earlier compile (instances.py)
    source_key: str | None = None         # the scene cache's key of the scene and options it was compiled from
    scale: float = 1.0                    # device units per world unit, a power of two (texray.compile.units)

    def device_bytes(self) -> dict[str, int]:
        """Bytes each uploaded array takes on the device (absent or empty arrays are not uploaded)."""
        return buffers.device_bytes(self)


# The kinds of records in the BVH, in the order their materials are numbered, with the
# CompiledScene arrays each fills (the first is the one the BVH's leaves index).
_KINDS = ((Mesh, ("tri_verts", "tri_shade")), (Sphere, ("spheres",)), (Cylinder, ("cylinders",)),
          (Quad, ("quad_verts", "quad_shade")))
_DTYPES = {"tri_verts": layout.TRI_VERTS, "tri_shade": layout.TRI_SHADE, "spheres": layout.SPHERE,
           "cylinders": layout.CYLINDER, "quad_verts": layout.QUAD_VERTS, "quad_shade": layout.QUAD_SHADE}


def _records(cls, items, mats, any_normals, any_uvs):
    """({array name: records}, (lo, hi) float32 boxes) of the (obj_id, shape) ``items`` of one kind."""
    names = dict(_KINDS)[cls]
    parts = {n: [] for n in names + (("normals", "uvs") if cls is Mesh else ())}
    los, his, voff = [], [], 0
    for obj_id, obj in items:
        if cls is Mesh:
            material = np.array([mats.index(m) for m in obj.materials], np.int64)
            rec = obj.device_records(material, obj_id, voff, any_normals, any_uvs)
            voff += len(obj.positions)
        else:
            rec = obj.device_records(mats.index(obj.material), obj_id)
        for k, a in rec.arrays.items():
            parts[k].append(a)
        los.append(np.atleast_2d(rec.lo))
        his.append(np.atleast_2d(rec.hi))
    out = {n: _joined(parts[n]) if parts[n] else np.zeros(0, _DTYPES[n]) for n in names}
    for n in ("normals", "uvs"):
        if parts.get(n):
            out[n] = _joined(parts[n]).astype(np.float32).ravel()
    if not los:
        return out, (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
    lo, hi = _joined(los), _joined(his)
    return out, ((lo, hi) if lo.dtype == np.float32 else outward(lo, hi))   # float32 boxes are exact


def _joined(arrays):
    """np.concatenate, without the copy of a single array (one mesh: 100 MiB saved per
    million triangles)."""
    return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)


def _displaced(items, shells, mats):
    """layout.DISPLACED records, the shared height buffer and the float32 (lo, hi) boxes of
    the displaced volumes, for (obj_id, shape) pairs whose displacement is searched on the
    device (each shape fills its own fields and gives its volume's box), then the prism
    shells of (obj_id, texray.compile.shells.Shells) meshes."""
    rec = np.zeros(len(items), layout.DISPLACED)
    if not items and not shells:
        return rec, None, (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
    heights, index = pack_heights([o.material.displacement for _, o in items]
                                  + [m.displacement for _, s in shells for m in s.mesh.materials
                                     if m.displacement is not None
                                     and m.displacement.method in mesh_shells.SHELL_METHODS])
    lo, hi = np.zeros((len(items), 3)), np.zeros((len(items), 3))
    for i, (obj_id, o) in enumerate(items):
        d, r = o.material.displacement, rec[i]
        hmin, hmax = d.bounds()
        r["hoff"], r["moff"], r["levels"] = index[height_key(d)]
        r["hh"], r["hw"] = d.texture.shape
        r["wrap"] = layout.WRAP_MODES[d.wrap]
        r["hmin"], r["hmax"] = hmin, hmax
        r["method"] = METHOD_IDS[d.method] | (METHOD_ADAPTIVE if d.adaptive else 0)
        r["steps"], r["refine"] = d.steps, d.refine
        r["material"], r["object"] = mats.index(o.material), obj_id
        lo[i], hi[i] = o.displaced_record(r, hmin, hmax)
    for (_, o), a, b in zip(items, lo, hi):
        check_extent(np.stack([a, b]), f"{o.name}: material.displacement.", "scale, offset")
    if shells:
        parts = [mesh_shells.records(s, obj_id, mats, index) for obj_id, s in shells]
        for (_, s), (_, a, b) in zip(shells, parts):
            check_extent(np.concatenate([a, b]), f"{s.mesh.name}: material.displacement.", "scale, offset")
        rec = np.concatenate([rec] + [r for r, _, _ in parts])
        lo = np.concatenate([lo] + [a for _, a, _ in parts])
        hi = np.concatenate([hi] + [b for _, _, b in parts])
    # The kernel pads the volume by a rounding bound of the ray's height (displace.h);
    # 2^-16 of the box's size keeps that pad inside the box for rays from within it.
    pad = 2.0 ** -16 * (np.abs(lo).max(axis=1) + np.abs(hi).max(axis=1) + (hi - lo).max(axis=1))[:, None]
    return rec, heights, outward(lo - pad, hi + pad)


def _method_on(disp, method, *shapes) -> bool:
    """Some record of ``disp`` (layout.DISPLACED) with one of ``shapes`` is displaced by ``method``
    (layout.DISP_SEARCH or DISP_MAXMIP)."""
    return bool(len(disp)) and bool(np.any(((disp["method"] & 3) == method) & np.isin(disp["shape"], shapes)))


def _sorted_objects(scene):
    """{shape class: [(obj_id, shape)]} of what the BVH holds directly (tessellated shapes
    as meshes), the [(obj_id, shape)] displaced on the device and the [(obj_id,
    texray.compile.shells.Shells)] of meshes displaced per pixel (search or maxmip)."""
    by_kind = {cls: [] for cls, _ in _KINDS}
    by_kind[Instance] = []
    displaced, shells = [], []
    for obj_id, obj in enumerate(scene.objects):
        d = getattr(obj.material, "displacement", None)
        if isinstance(obj, Instance):
            if any(m.displacement is not None for m in obj.materials):
                raise SceneError(f"{obj.name}: material.displacement: an instanced mesh is not displaced; "
                                 "tessellate it (texray.compile.tessellate_mesh) and instance the result")
            by_kind[Instance].append((obj_id, obj))
        elif isinstance(obj, Mesh):
            methods = {m.displacement.method for m in obj.materials if m.displacement is not None}
            if methods and methods <= set(mesh_shells.SHELL_METHODS):
                try:
                    s = mesh_shells.prepare(obj)
                except mesh_shells.NotABound as e:
                    method = "' or '".join(sorted(methods))
                    warnings.warn(f"{e}: method='{method}' would miss parts of the surface; tessellated instead",
                                  stacklevel=4)
                    by_kind[Mesh].append((obj_id, tessellate_mesh(obj, methods=tuple(methods))))
                    continue
                shells.append((obj_id, s))
                plain = _plain_faces(obj)
                if plain is not None:
                    by_kind[Mesh].append((obj_id, plain))
                continue
            if methods - {"tessellate"}:        # Mesh validation refuses these; changed since
                raise SceneError(f"{obj.name}: material.displacement: a triangle mesh is displaced by "
                                 f"method='search', 'maxmip' or 'tessellate', one of them for all its materials; got "
                                 f"{', '.join(sorted(methods))}")
            by_kind[Mesh].append((obj_id, tessellate_mesh(obj) if methods else obj))
        elif d is None:
            by_kind[type(obj)].append((obj_id, obj))
        elif d.method == "tessellate":
            by_kind[Mesh].append((obj_id, tessellate(obj)))
        else:
            displaced.append((obj_id, obj))
    return by_kind, displaced, shells


def _plain_faces(mesh):
    """The faces of ``mesh`` that the search does not displace (their material has no
    displacement) as a Mesh in world space, or None when there are none."""
    plain = ~mesh_shells.searched_faces(mesh)
    if not plain.any():
        return None
    p, n = mesh.world()
    ids = None if mesh.material_ids is None else mesh.material_ids[plain]
    return Mesh(p, mesh.faces[plain], uvs=mesh.uvs, normals=n, material=mesh.material, material_ids=ids,
                name=mesh.name, mapping=mesh.mapping)


def compile_scene(scene: Scene, shadows: bool = True, texture_filter=None, bvh_builder="auto") -> CompiledScene:
    """Flatten ``scene``; raises SceneError for anything that cannot be rendered.
    ``texture_filter``: None, or a filter name that replaces every texture's own.
    ``bvh_builder``: "auto" (the cell builder for kinds of at least
    texray.accel.cells.MIN_PRIMS primitives, else numpy), "numpy" or "cells"
    (texray.accel.scene_bvh.build_kind)."""
    if not isinstance(scene, Scene):
        raise SceneError(f"render: expected a texray.Scene, got {type(scene).__name__}")
    steps, t_last = {}, [time.perf_counter()]

    def step(name):
        now = time.perf_counter()
        steps[name] = steps.get(name, 0.0) + now - t_last[0]
        t_last[0] = now

    ambient, background = scene.validate()
    if not scene.lights and scene.objects and not np.any(ambient > 0):
        warnings.warn("scene: no lights and no ambient light: every object renders black", stacklevel=3)
    if texture_filter is not None and (not isinstance(texture_filter, str) or texture_filter not in FILTERS):
        raise SceneError(f"render: texture_filter: expected None or one of {', '.join(FILTERS)}, "
                         f"got {texture_filter!r}")
    meshes_checked = set()
    for obj in scene.objects:              # fields may have changed since the objects were made
        if isinstance(obj, Instance):      # a shared mesh once
            obj.validate(check_mesh=id(obj.mesh) not in meshes_checked)
            meshes_checked.add(id(obj.mesh))
        else:
            obj.validate()
    step("validate")
    by_kind, displaced, shells = _sorted_objects(scene)
    step("tessellate")
    mats = MaterialTable(texture_filter)
    meshes = by_kind[Mesh] + [(i, o.mesh) for i, o in by_kind[Instance]]
    any_normals = any(m.normals is not None for _, m in meshes)
    any_uvs = any(m.uvs is not None and any(mt.textures for mt in m.materials) for _, m in meshes)
    arrays, boxes = {}, {}
    for cls, _ in _KINDS:
        recs, boxes[cls.PRIM] = _records(cls, by_kind[cls], mats, any_normals, any_uvs)
        arrays.update(recs)
    step("records")
    disp, heights, boxes[layout.PRIM_DISPLACED] = _displaced(displaced, shells, mats)
    step("heights")
    blases = None
    if by_kind[Instance]:
        blases = inst_blas.build(by_kind[Instance], mats, any_normals, any_uvs,
                                 sum(len(m.positions) for _, m in by_kind[Mesh]), bvh_builder)
        boxes[layout.PRIM_INSTANCE] = inst_blas.boxes(blases)
    step("instances")

    if bvh_builder not in BUILDERS:
        raise SceneError(f"compile_scene: bvh_builder: expected one of {', '.join(BUILDERS)}, got {bvh_builder!r}")
    tree = build_scene_bvh(boxes, bvh_builder)
    step("bvh")
    order = tree.orders
    wide_nodes, wide_depth = wide.collapse(tree.nodes)
    step("wide")
    for cls, names in _KINDS:
        if cls.PRIM in order:
            for n in names:
                arrays[n] = layout.take_records(arrays[n], order[cls.PRIM])
    if layout.PRIM_DISPLACED in order:
        disp = layout.take_records(disp, order[layout.PRIM_DISPLACED])
    instances, top_tris, top_nodes = None, None, None
    if blases is not None:
        top_tris, top_nodes = len(arrays["tri_verts"]), len(wide_nodes)
        wide_nodes, instances = inst_blas.place(blases, arrays, wide_nodes, order[layout.PRIM_INSTANCE])
        wide_depth = max(wide_depth, blases.depth)   # the BLAS traversal has its own stack
    step("leaf_order")

    materials, any_specular = mats.table()
    tex_table, texels = pack_textures(mats.entries) if mats.entries else (None, None)
    step("textures")
    filters = {t.filter for t, _ in mats.entries}
    slots = {slot for m in mats.materials for slot, _, _ in m.texture_roles()}
    lights = np.zeros(len(scene.lights), layout.POINT_LIGHT)
    intensities = np.zeros((len(scene.lights), 3))      # float64: units.rescale scales them before rounding
    for i, light in enumerate(scene.lights):
        lights[i]["position"], intensities[i] = light.validate(f"lights[{i}].")
        lights[i]["intensity"] = intensities[i]
    features = Features(textures=bool(mats.textures), vertex_normals=any_normals, specular=any_specular,
                        shadows=shadows and bool(scene.lights),
                        triangles=len(arrays["tri_verts"]) > 0,
                        spheres=len(arrays["spheres"]) > 0, cylinders=len(arrays["cylinders"]) > 0,
                        quads=len(arrays["quad_verts"]) > 0,
                        projections=any(o.mapping is not None for o in scene.objects),
                        filter_nearest="nearest" in filters, filter_bilinear="bilinear" in filters,
                        filter_trilinear="trilinear" in filters,
                        filter_anisotropic="anisotropic" in filters, specular_maps="specular_tex" in slots,
                        shininess_maps="shininess_tex" in slots, labels="label_tex" in slots,
                        bump=any(m.bump is not None for m in mats.materials),
                        normal_maps=any(m.normal_map is not None for m in mats.materials),
                        displacement=len(disp) > 0, displaced_meshes=bool(shells),
                        displaced_curved_maxmip=_method_on(disp, layout.DISP_MAXMIP, layout.DISP_SPHERE,
                                                           layout.DISP_CYLINDER),
                        displaced_trapezoid_maxmip=_method_on(disp, layout.DISP_MAXMIP, layout.DISP_TRAPEZOID),
                        displaced_mesh_maxmip=_method_on(disp, layout.DISP_MAXMIP, layout.DISP_TRIANGLE),
                        displaced_curved_search=_method_on(disp, layout.DISP_SEARCH, layout.DISP_SPHERE,
                                                           layout.DISP_CYLINDER, layout.DISP_TRIANGLE),
                        instances=instances is not None,
                        stack_size=stack_size_for(wide.stack_depth(wide_depth)),
                        max_lights=max_lights_for(len(scene.lights)))
    objects, objects_generic = object_table(scene.objects), object_table(scene.objects, always=True)
    step("tables")
    cs = CompiledScene(
        **{n: arrays[n] for n in _DTYPES}, nodes=wide_nodes, normals=arrays.get("normals"), uvs=arrays.get("uvs"),
        materials=materials, textures=tex_table, texels=texels, objects=objects,
        lights=lights, ambient=np.append(ambient, 0).astype(np.float32),
        background=np.append(background, 0).astype(np.float32),
        features=features, bvh=tree, displaced=disp if len(disp) else None, heights=heights,
        wide_depth=wide_depth, camera=copy.deepcopy(scene.camera),
        objects_generic=objects_generic, instances=instances,
        texture_names=tuple(sorted({t.name for o in scene.objects for m in materials_of(o) for t in m.textures})),
        steps_s=steps, blas_reused=blases.reused if blases is not None else 0)
    # in device units where the geometry's coordinates are far from 1 (texray.compile.units)
    return units.rescale(cs, units.choose_scale(units.extent(tree.nodes)), top_tris, top_nodes, intensities)
