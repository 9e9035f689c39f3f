"""Scene compiler: a :class:`~texray.scene.Scene` becomes flat arrays laid out by
:mod:`texray.layout`, one BVH over every primitive (each kind's array in leaf
order) and a feature set. Everything is vectorized numpy over primitives (the
only Python loops are over scene objects); only what the scene uses is produced."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import layout
from .accel import SceneBVH, build_scene_bvh
from .errors import SceneError
from .features import Features, max_lights_for, stack_size_for
from .scene import (Cylinder, Mesh, Quad, Scene, Sphere, _rgb, degenerate_faces, object_frame,
                    warn_degenerate)


@dataclass
class CompiledScene:
    tri_verts: np.ndarray          # layout.TRI_VERTS, BVH leaf order
    tri_shade: np.ndarray          # layout.TRI_SHADE, same order
    spheres: np.ndarray            # layout.SPHERE, leaf order
    cylinders: np.ndarray          # layout.CYLINDER, leaf order
    quad_verts: np.ndarray         # layout.QUAD_VERTS, leaf order
    quad_shade: np.ndarray         # layout.QUAD_SHADE, same order
    nodes: np.ndarray              # layout.BVH_NODE
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

    def device_bytes(self) -> dict[str, int]:
        """Bytes each uploaded array takes on the device (absent or empty arrays are not uploaded)."""
        arrays = {"tri_verts": self.tri_verts, "tri_shade": self.tri_shade, "spheres": self.spheres,
                  "cylinders": self.cylinders, "quad_verts": self.quad_verts, "quad_shade": self.quad_shade,
                  "nodes": self.nodes, "normals": self.normals, "uvs": self.uvs, "materials": self.materials,
                  "textures": self.textures, "texels": self.texels, "objects": self.objects,
                  "lights": self.lights}
        return {k: int(v.nbytes) for k, v in arrays.items() if v is not None and v.nbytes}


class _Materials:
    """Deduplicated materials and textures, in first-use order."""

    def __init__(self):
        self.materials, self.textures, self._mi, self._ti = [], [], {}, {}

    def index(self, m):
        if id(m) not in self._mi:
            self._mi[id(m)] = len(self.materials)
            self.materials.append(m)
            for t in m.textures:
                if id(t) not in self._ti:
                    self._ti[id(t)] = len(self.textures)
                    self.textures.append(t)
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
            if m.textures:
                mats[i]["diffuse_tex"] = self._ti[id(m.diffuse)]
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
        p32 = p.astype(np.float32)
        if not np.all(np.isfinite(p32)):
            raise SceneError(f"{mesh.name}: positions overflow float32 after the transform "
                             f"(largest magnitude {np.abs(p).max():.3g})")
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
    p32 = corners.astype(np.float32)
    if not np.all(np.isfinite(p32)):
        raise SceneError("quad: corners overflow float32")
    qv["p0"], qv["p1"], qv["p2"], qv["p3"] = p32[:, 0], p32[:, 1], p32[:, 2], p32[:, 3]
    # A bilinear patch lies in the convex hull of its corners: their float32 box is exact.
    return qv, qs, (p32.min(axis=1), p32.max(axis=1))


def compile_scene(scene: Scene, shadows: bool = True) -> CompiledScene:
    """Flatten ``scene``; raises SceneError for anything that cannot be rendered."""
    if not isinstance(scene, Scene):
        raise SceneError(f"render: expected a texray.Scene, got {type(scene).__name__}")
    by_kind = {Mesh: [], Sphere: [], Cylinder: [], Quad: []}
    for obj_id, obj in enumerate(scene.objects):
        by_kind[type(obj)].append((obj_id, obj))
    mats = _Materials()
    meshes = by_kind[Mesh]
    any_normals = any(m.normals is not None for _, m in meshes)
    any_uvs = any(m.uvs is not None and m.material.textures for _, m in meshes)
    tri_verts, tri_shade, normals, uvs = _meshes(meshes, mats, any_normals, any_uvs)
    spheres, sphere_box = _spheres(by_kind[Sphere], mats)
    cylinders, cyl_box = _cylinders(by_kind[Cylinder], mats)
    quad_verts, quad_shade, quad_box = _quads(by_kind[Quad], mats)

    tree = build_scene_bvh({layout.PRIM_TRIANGLE: triangle_bounds(tri_verts), layout.PRIM_SPHERE: sphere_box,
                            layout.PRIM_CYLINDER: cyl_box, layout.PRIM_QUAD: quad_box})
    order = tree.orders
    if layout.PRIM_TRIANGLE in order:
        tri_verts, tri_shade = tri_verts[order[layout.PRIM_TRIANGLE]], tri_shade[order[layout.PRIM_TRIANGLE]]
    if layout.PRIM_SPHERE in order:
        spheres = spheres[order[layout.PRIM_SPHERE]]
    if layout.PRIM_CYLINDER in order:
        cylinders = cylinders[order[layout.PRIM_CYLINDER]]
    if layout.PRIM_QUAD in order:
        quad_verts, quad_shade = quad_verts[order[layout.PRIM_QUAD]], quad_shade[order[layout.PRIM_QUAD]]

    materials, any_specular = mats.table()
    tex_table, texels = _pack_textures(mats.textures)
    objects = _object_table(scene.objects)
    lights = np.zeros(len(scene.lights), layout.POINT_LIGHT)
    for i, light in enumerate(scene.lights):
        lights[i]["position"], lights[i]["intensity"] = light.validate(f"lights[{i}].")
    features = Features(textures=bool(mats.textures), vertex_normals=any_normals, specular=any_specular,
                        shadows=shadows and bool(scene.lights),
                        spheres=len(spheres) > 0, cylinders=len(cylinders) > 0, quads=len(quad_verts) > 0,
                        projections=objects is not None,
                        stack_size=stack_size_for(tree.depth), max_lights=max_lights_for(len(scene.lights)))
    return CompiledScene(
        tri_verts=tri_verts, tri_shade=tri_shade, spheres=spheres, cylinders=cylinders,
        quad_verts=quad_verts, quad_shade=quad_shade, nodes=tree.nodes, normals=normals, uvs=uvs,
        materials=materials, textures=tex_table, texels=texels, objects=objects, lights=lights,
        ambient=np.append(_rgb(scene.ambient, "ambient", "scene."), 0).astype(np.float32),
        background=np.append(_rgb(scene.background, "background", "scene."), 0).astype(np.float32),
        features=features, bvh=tree)


def triangle_bounds(tri_verts):
    """(lo, hi) float32 (n, 3) boxes of TRI_VERTS triangles (exact: min/max of float32)."""
    p0, p1, p2 = tri_verts["p0"], tri_verts["p1"], tri_verts["p2"]
    return np.minimum(np.minimum(p0, p1), p2), np.maximum(np.maximum(p0, p1), p2)


def _object_table(objs):
    """layout.OBJECT per scene object, or None when no object has a projection mapping."""
    if not any(o.mapping is not None for o in objs):
        return None
    table = np.zeros(len(objs), layout.OBJECT)
    table["mapping"] = -1
    for i, o in enumerate(objs):
        if o.mapping is not None:
            f = object_frame(o)
            table[i]["mapping"] = o.mapping.kind_id
            table[i]["origin"], table[i]["x"], table[i]["y"], table[i]["z"] = f
    return table


def _pack_textures(textures):
    """One texture table and one shared half-float RGBA texel buffer, or (None, None).
    Textures sharing pixels (Texture.with_options) share texels."""
    if not textures:
        return None, None
    from .mapping import WRAP_MODES, UVTransform
    images, image_index = [], {}
    for t in textures:
        if id(t.rgba) not in image_index:
            image_index[id(t.rgba)] = len(images)
            images.append(t.rgba)
    sizes = np.array([im.shape[0] * im.shape[1] for im in images], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    if sizes.sum() >= 2**32:
        raise SceneError(f"textures: {sizes.sum()} texels in all exceeds the 2^32 texel limit")
    table = np.zeros(len(textures), layout.TEXTURE)
    for i, t in enumerate(textures):
        table[i]["offset"] = offsets[image_index[id(t.rgba)]]
        table[i]["height"], table[i]["width"] = t.rgba.shape[:2]
        table[i]["wrap"] = WRAP_MODES[t.wrap]
        table[i]["m0"], table[i]["m1"] = (t.uv_transform or UVTransform()).device_args()
    # Half floats top out at 65504: clamp so that bright HDR texels stay finite.
    texels = np.clip(np.concatenate([im.reshape(-1, 4) for im in images]), -65504, 65504)
    return table, texels.astype(np.float16).ravel()
