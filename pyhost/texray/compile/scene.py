"""Scene compiler: a :class:`~texray.scene.Scene` becomes flat arrays laid out by
:mod:`texray.layout`, one BVH over every primitive (each kind's array in leaf
order) and a feature set. Everything is vectorized numpy over primitives (the
only Python loops are over scene objects); only what the scene uses is produced."""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from . import layout, wide
from .accel import SceneBVH, build_scene_bvh
from .errors import SceneError
from .features import Features, max_lights_for, stack_size_for
from .scene import (Cylinder, Mesh, Quad, Scene, Sphere, _normal_role_textures, check_extent, degenerate_faces,
                    object_frame, warn_degenerate)
from .displace import tessellate
from .texture import FILTERS
from .texture import pack as _pack_texture_entries


@dataclass
class CompiledScene:
    tri_verts: np.ndarray          # layout.TRI_VERTS, BVH leaf order
    tri_shade: np.ndarray          # layout.TRI_SHADE, same order
    spheres: np.ndarray            # layout.SPHERE, leaf order
    cylinders: np.ndarray          # layout.CYLINDER, leaf order
    quad_verts: np.ndarray         # layout.QUAD_VERTS, leaf order
    quad_shade: np.ndarray         # layout.QUAD_SHADE, same order
    nodes: np.ndarray              # layout.BVH4_NODE (texray.wide), what the kernels traverse
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
    displaced: np.ndarray | None = None   # layout.DISPLACED, leaf order (texray.displace)
    heights: np.ndarray | None = None     # uint16 (unorm over [hmin, hmax]) height fields and their min-max pyramids
    wide_depth: int = 0                   # levels of the 4-wide tree in ``nodes``

    def device_bytes(self) -> dict[str, int]:
        """Bytes each uploaded array takes on the device (absent or empty arrays are not uploaded)."""
        arrays = {"tri_verts": self.tri_verts, "tri_shade": self.tri_shade, "spheres": self.spheres,
                  "cylinders": self.cylinders, "quad_verts": self.quad_verts, "quad_shade": self.quad_shade,
                  "nodes": self.nodes, "normals": self.normals, "uvs": self.uvs, "materials": self.materials,
                  "textures": self.textures, "texels": self.texels, "objects": self.objects,
                  "lights": self.lights, "displaced": self.displaced, "heights": self.heights}
        return {k: int(v.nbytes) for k, v in arrays.items() if v is not None and v.nbytes}


class _Materials:
    """Deduplicated materials and texture-table entries, in first-use order. An entry is a
    (Texture, kind) pair (texray.texture.KINDS): a texture used in roles of two kinds gets
    two entries. ``texture_filter`` (a texray.texture.FILTERS name) replaces every
    texture's filter."""

    def __init__(self, texture_filter=None):
        self.materials, self.entries, self._mi, self._ti, self._tk = [], [], {}, {}, {}
        self.texture_filter = texture_filter

    @property
    def textures(self):
        return [t for t, _ in self.entries]

    def _entry(self, t, kind):
        key = (id(t), kind)
        if key not in self._tk:
            self._tk[key] = len(self.entries)
            self.entries.append((t if self.texture_filter is None else t.with_options(filter=self.texture_filter),
                                 kind))
        return self._tk[key]

    def index(self, m):
        if id(m) not in self._mi:
            self._mi[id(m)] = len(self.materials)
            self.materials.append(m)
            for _, t, kind in m.texture_roles():
                self._entry(t, kind)
            for t in _normal_role_textures(m):      # bump and normal maps: data, looked up by id
                self._ti[id(t)] = self._entry(t, "data")
        return self._mi[id(m)]

    def table(self):
        mats = np.zeros(max(len(self.materials), 1), layout.MATERIAL)
        for role in ("diffuse_tex", "specular_tex", "shininess_tex", "label_tex", "bump_tex", "normal_tex"):
            mats[role] = -1
        any_specular = False
        for i, m in enumerate(self.materials):
            kd, ks, n = m.validate(f"material {i}: ")
            mats[i]["diffuse"], mats[i]["specular"], mats[i]["shininess"] = kd, ks, n
            any_specular |= bool(np.any(ks > 0))
            for slot, t, kind in m.texture_roles():
                mats[i][slot] = self._tk[(id(t), kind)]
            if m.shininess_map is not None and m.shininess_map.raw.min() < 0:
                t = m.shininess_map
                raise SceneError(f"{t.field}: {t.name}: shininess_map values must be >= 0 (n = shininess * map), "
                                 f"got {float(t.raw.min())}")
            if m.bump is not None:
                mats[i]["bump_tex"] = self._ti[id(m.bump.texture)]
                mats[i]["bump_height"], mats[i]["bump_delta"] = m.bump.height, m.bump.device_delta()
            if m.normal_map is not None:
                mats[i]["normal_tex"] = self._ti[id(m.normal_map.texture)]
                mats[i]["normal_mode"] = m.normal_map.device_mode()
        return mats, any_specular


def _outward(lo, hi):
    """float64 bounds rounded outward to float32, so the float32 box contains the shape."""
    lo32, hi32 = lo.astype(np.float32), hi.astype(np.float32)
    lo32 = np.where(lo32.astype(np.float64) > lo, np.nextafter(lo32, np.float32(-np.inf)), lo32)
    hi32 = np.where(hi32.astype(np.float64) < hi, np.nextafter(hi32, np.float32(np.inf)), hi32)
    if not (np.all(np.isfinite(lo32)) and np.all(np.isfinite(hi32))):
        raise SceneError("scene: a primitive's bounds overflow float32 (coordinates beyond 3.4e38)")
    return lo32, hi32


def _meshes(items, mats, any_normals, any_uvs):
    nrm, uvs, verts, tris, voff = [], [], [], [], 0
    for obj_id, mesh in items:
        mat = mats.index(mesh.material)
        p, n = mesh.world()
        f = mesh.faces
        check_extent(p, f"{mesh.name}: ", "positions")
        p32 = p.astype(np.float32)
        degenerate = degenerate_faces(p32.astype(np.float64), f)
        if degenerate.all():
            raise SceneError(f"{mesh.name}: faces: all {len(f)} triangles have zero area; nothing to render")
        warn_degenerate(mesh.name, degenerate)
        keep = np.flatnonzero(~degenerate)
        fk = f[keep]
        tv = np.zeros(len(keep), layout.TRI_VERTS)
        tv["p0"], tv["p1"], tv["p2"] = p32[fk[:, 0]], p32[fk[:, 1]], p32[fk[:, 2]]
        t = np.zeros(len(keep), layout.TRI_SHADE)
        t["material"], t["object"], t["prim"], t["v"] = mat, obj_id, keep, fk + voff
        flags = 0
        if any_normals:
            flags |= layout.TRI_HAS_NORMALS if n is not None else 0
            nrm.append(n if n is not None else np.zeros_like(p))
        if any_uvs:
            flags |= layout.TRI_HAS_UVS if mesh.uvs is not None else 0
            uvs.append(mesh.uvs if mesh.uvs is not None else np.zeros((len(p), 2)))
        t["flags"] = flags
        verts.append(tv)
        tris.append(t)
        voff += len(p)
    tv = np.concatenate(verts) if verts else np.zeros(0, layout.TRI_VERTS)
    ts = np.concatenate(tris) if tris else np.zeros(0, layout.TRI_SHADE)
    normals = np.concatenate(nrm).astype(np.float32).ravel() if nrm else None
    uv = np.concatenate(uvs).astype(np.float32).ravel() if uvs else None
    return tv, ts, normals, uv


def _spheres(items, mats):
    s = np.zeros(len(items), layout.SPHERE)
    for i, (obj_id, sp) in enumerate(items):
        c, r, x, z = sp.world()
        s[i]["center"], s[i]["radius"], s[i]["axis_x"], s[i]["axis_z"] = c, r, x, z
        s[i]["material"], s[i]["object"] = mats.index(sp.material), obj_id
    c, r = s["center"].astype(np.float64), s["radius"].astype(np.float64)[:, None]
    return s, _outward(c - r, c + r)


def _cylinders(items, mats):
    cy = np.zeros(len(items), layout.CYLINDER)
    lo, hi = np.zeros((len(items), 3)), np.zeros((len(items), 3))
    for i, (obj_id, c) in enumerate(items):
        o, r, x, z, (z0, z1), (t0, t1) = c.world()
        cy[i]["origin"], cy[i]["radius"], cy[i]["axis_x"], cy[i]["axis_z"] = o, r, x, z
        cy[i]["z_min"], cy[i]["z_max"], cy[i]["theta_min"], cy[i]["theta_max"] = z0, z1, t0, t1
        cy[i]["material"], cy[i]["object"] = mats.index(c.material), obj_id
        # Box of the two end circles: a circle of radius r about axis z spans r sqrt(1 - z_k^2) along axis k.
        ends = o + np.outer([z0, z1], z)
        ext = r * np.sqrt(np.maximum(0.0, 1.0 - z * z))
        lo[i], hi[i] = ends.min(axis=0) - ext, ends.max(axis=0) + ext
    return cy, _outward(lo, hi)


def _quads(items, mats):
    qv = np.zeros(len(items), layout.QUAD_VERTS)
    qs = np.zeros(len(items), layout.QUAD_SHADE)
    corners = np.zeros((len(items), 4, 3))
    for i, (obj_id, q) in enumerate(items):
        p, uv = q.world()
        corners[i] = p
        qs[i]["uv"], qs[i]["material"], qs[i]["object"] = uv.ravel(), mats.index(q.material), obj_id
    p32 = corners.astype(np.float32)      # Quad.world checked |corners| <= validate.COORD_LIMIT
    qv["p0"], qv["p1"], qv["p2"], qv["p3"] = p32[:, 0], p32[:, 1], p32[:, 2], p32[:, 3]
    # A bilinear patch lies in the convex hull of its corners: their float32 box is exact.
    return qv, qs, (p32.min(axis=1), p32.max(axis=1))


def _displaced(items, mats):
    """layout.DISPLACED records, the shared height buffer and the (lo, hi) boxes of the
    displaced volumes (slab [hmin, hmax] along a quad's normal; shell [r + hmin, r + hmax]
    around a sphere or cylinder), for (obj_id, object) pairs whose displacement is
    searched on the device."""
    from .displace import METHOD_ADAPTIVE, METHOD_IDS, pack_heights
    from .mapping import WRAP_MODES
    rec = np.zeros(len(items), layout.DISPLACED)
    if not items:
        return rec, None, (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
    heights, index = pack_heights([o.material.displacement for _, o in items])
    lo, hi = np.zeros((len(items), 3)), np.zeros((len(items), 3))
    for i, (obj_id, o) in enumerate(items):
        d, r = o.material.displacement, rec[i]
        where = f"{o.name}: material.displacement."
        hmin, hmax = d.bounds()
        r["hoff"], r["moff"], r["levels"] = index[_disp_key(d)]
        r["hh"], r["hw"] = d.texture.shape
        r["wrap"] = WRAP_MODES[d.wrap]
        r["hmin"], r["hmax"] = hmin, hmax
        r["method"] = METHOD_IDS[d.method] | (METHOD_ADAPTIVE if d.adaptive else 0)
        r["steps"], r["refine"] = d.steps, d.refine
        r["material"], r["object"] = mats.index(o.material), obj_id
        if isinstance(o, Quad):
            p, uv = o.world()
            e0, e1 = p[1] - p[0], p[3] - p[0]          # Quad.world checked it is a parallelogram
            n = np.cross(e0, e1)
            n /= np.linalg.norm(n)
            r["shape"], r["p"], r["e0"], r["e1"], r["n"], r["uv"] = layout.DISP_QUAD, p[0], e0, e1, n, uv.ravel()
            c = np.concatenate([p + hmin * n, p + hmax * n])
            lo[i], hi[i] = c.min(axis=0), c.max(axis=0)
        elif isinstance(o, Sphere):         # Sphere.world checked the method and the lowest height
            c, rad, x, z = o.world()
            r["shape"], r["p"], r["radius"], r["e0"], r["e1"], r["n"] = layout.DISP_SPHERE, c, rad, x, np.cross(z, x), z
            lo[i], hi[i] = c - (rad + hmax), c + (rad + hmax)
        else:
            o_, rad, x, z, (z0, z1), (t0, t1) = o.world()
            r["shape"], r["p"], r["radius"], r["e0"], r["e1"], r["n"] = (layout.DISP_CYLINDER, o_, rad, x,
                                                                          np.cross(z, x), z)
            r["z_min"], r["z_max"], r["theta_min"], r["theta_max"] = z0, z1, t0, t1
            ends = o_ + np.outer([z0, z1], z)
            ext = (rad + hmax) * np.sqrt(np.maximum(0.0, 1.0 - z * z))
            lo[i], hi[i] = ends.min(axis=0) - ext, ends.max(axis=0) + ext
    for (_, o), a, b in zip(items, lo, hi):
        check_extent(np.stack([a, b]), f"{o.name}: material.displacement.", "scale, offset")
    # The kernel pads the volume by a rounding bound of the ray's height (displace.h);
    # 2^-16 of the box's size keeps that pad inside the box for rays from within it.
    pad = 2.0 ** -16 * (np.abs(lo).max(axis=1) + np.abs(hi).max(axis=1) + (hi - lo).max(axis=1))[:, None]
    return rec, heights, _outward(lo - pad, hi + pad)


def _disp_key(d):
    from .displace import _key
    return _key(d)


def compile_scene(scene: Scene, shadows: bool = True, texture_filter=None) -> CompiledScene:
    """Flatten ``scene``; raises SceneError for anything that cannot be rendered.
    ``texture_filter``: None, or a filter name that replaces every texture's own."""
    if not isinstance(scene, Scene):
        raise SceneError(f"render: expected a texray.Scene, got {type(scene).__name__}")
    ambient, background = scene.validate()
    if not scene.lights and scene.objects and not np.any(ambient > 0):
        warnings.warn("scene: no lights and no ambient light: every object renders black", stacklevel=3)
    if texture_filter is not None and (not isinstance(texture_filter, str) or texture_filter not in FILTERS):
        raise SceneError(f"render: texture_filter: expected None or one of {', '.join(FILTERS)}, "
                         f"got {texture_filter!r}")
    by_kind = {Mesh: [], Sphere: [], Cylinder: [], Quad: []}
    displaced = []
    for obj in scene.objects:              # fields may have changed since the objects were made
        obj.validate()
    for obj_id, obj in enumerate(scene.objects):
        d = getattr(obj.material, "displacement", None)
        if d is None:
            by_kind[type(obj)].append((obj_id, obj))
        elif isinstance(obj, Mesh):          # Mesh validation refuses displacement; the material changed since
            raise SceneError(f"{obj.name}: material.displacement: triangle meshes are not displaced (no sound "
                             "bounding volume chosen); use a quad, sphere or cylinder")
        elif d.method == "tessellate":
            by_kind[Mesh].append((obj_id, tessellate(obj)))
        else:
            displaced.append((obj_id, obj))
    mats = _Materials(texture_filter)
    meshes = by_kind[Mesh]
    any_normals = any(m.normals is not None for _, m in meshes)
    any_uvs = any(m.uvs is not None and m.material.textures for _, m in meshes)
    tri_verts, tri_shade, normals, uvs = _meshes(meshes, mats, any_normals, any_uvs)
    spheres, sphere_box = _spheres(by_kind[Sphere], mats)
    cylinders, cyl_box = _cylinders(by_kind[Cylinder], mats)
    quad_verts, quad_shade, quad_box = _quads(by_kind[Quad], mats)
    disp, heights, disp_box = _displaced(displaced, mats)

    tree = build_scene_bvh({layout.PRIM_TRIANGLE: triangle_bounds(tri_verts), layout.PRIM_SPHERE: sphere_box,
                            layout.PRIM_CYLINDER: cyl_box, layout.PRIM_QUAD: quad_box,
                            layout.PRIM_DISPLACED: disp_box})
    order = tree.orders
    wide_nodes, wide_depth = wide.collapse(tree.nodes)
    if layout.PRIM_TRIANGLE in order:
        tri_verts, tri_shade = tri_verts[order[layout.PRIM_TRIANGLE]], tri_shade[order[layout.PRIM_TRIANGLE]]
    if layout.PRIM_SPHERE in order:
        spheres = spheres[order[layout.PRIM_SPHERE]]
    if layout.PRIM_CYLINDER in order:
        cylinders = cylinders[order[layout.PRIM_CYLINDER]]
    if layout.PRIM_QUAD in order:
        quad_verts, quad_shade = quad_verts[order[layout.PRIM_QUAD]], quad_shade[order[layout.PRIM_QUAD]]
    if layout.PRIM_DISPLACED in order:
        disp = disp[order[layout.PRIM_DISPLACED]]

    materials, any_specular = mats.table()
    tex_table, texels = _pack_textures(mats.entries)
    filters = {t.filter for t, _ in mats.entries}
    slots = {slot for m in mats.materials for slot, _, _ in m.texture_roles()}
    objects = object_table(scene.objects)
    lights = np.zeros(len(scene.lights), layout.POINT_LIGHT)
    for i, light in enumerate(scene.lights):
        lights[i]["position"], lights[i]["intensity"] = light.validate(f"lights[{i}].")
    features = Features(textures=bool(mats.textures), vertex_normals=any_normals, specular=any_specular,
                        shadows=shadows and bool(scene.lights),
                        spheres=len(spheres) > 0, cylinders=len(cylinders) > 0, quads=len(quad_verts) > 0,
                        projections=any(o.mapping is not None for o in scene.objects),
                        filter_nearest="nearest" in filters, filter_bilinear="bilinear" in filters,
                        filter_trilinear="trilinear" in filters,
                        filter_anisotropic="anisotropic" in filters, specular_maps="specular_tex" in slots,
                        shininess_maps="shininess_tex" in slots, labels="label_tex" in slots,
                        bump=any(m.bump is not None for m in mats.materials),
                        normal_maps=any(m.normal_map is not None for m in mats.materials),
                        displacement=len(disp) > 0,
                        stack_size=stack_size_for(wide.stack_depth(wide_depth)), max_lights=max_lights_for(len(scene.lights)))
    return CompiledScene(
        tri_verts=tri_verts, tri_shade=tri_shade, spheres=spheres, cylinders=cylinders,
        quad_verts=quad_verts, quad_shade=quad_shade, nodes=wide_nodes, normals=normals, uvs=uvs,
        materials=materials, textures=tex_table, texels=texels, objects=objects, lights=lights,
        ambient=np.append(ambient, 0).astype(np.float32),
        background=np.append(background, 0).astype(np.float32),
        features=features, bvh=tree, displaced=disp if len(disp) else None, heights=heights,
        wide_depth=wide_depth)


def triangle_bounds(tri_verts):
    """(lo, hi) float32 (n, 3) boxes of TRI_VERTS triangles (exact: min/max of float32)."""
    p0, p1, p2 = tri_verts["p0"], tri_verts["p1"], tri_verts["p2"]
    return np.minimum(np.minimum(p0, p1), p2), np.maximum(np.maximum(p0, p1), p2)


def object_table(objs, always=False):
    """layout.OBJECT per scene object, or None when no object has a projection mapping
    (unless ``always``: a program compiled with projections reads the table)."""
    if not always and not any(o.mapping is not None or _object_space_normals(o) for o in objs):
        return None
    table = np.zeros(max(len(objs), 1), layout.OBJECT)
    table["mapping"] = -1
    for i, o in enumerate(objs):
        if o.mapping is not None:
            f = object_frame(o)
            table[i]["mapping"] = o.mapping.kind_id
            table[i]["origin"], table[i]["x"], table[i]["y"], table[i]["z"] = f
        m = np.eye(4) if o.transform is None else o.transform.matrix()
        table[i]["nm0"], table[i]["nm1"], table[i]["nm2"] = np.linalg.inv(m[:3, :3]).T
    return table


def _object_space_normals(obj):
    nm = obj.material.normal_map
    return nm is not None and nm.space == "object"


def _pack_textures(entries):
    """One texture table and one shared half-float RGBA texel buffer, or (None, None), for
    (Texture, kind) entries (texray.texture.pack: each distinct pixels-and-kind packed once,
    with MIP levels for trilinear and anisotropic textures)."""
    if not entries:
        return None, None
    return _pack_texture_entries(entries)
