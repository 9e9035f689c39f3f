"""Scene compiler: a :class:`~texray.scene.Scene` becomes flat arrays laid out by
:mod:`texray.layout`, a BVH over the triangles (in leaf order) and a feature set.
Everything is vectorized numpy; only what the scene uses is produced."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bvh as bvh_mod
from . import layout
from .errors import SceneError
from .features import Features, stack_size_for
from .scene import Scene, degenerate_faces, warn_degenerate


@dataclass
class CompiledScene:
    tri_verts: np.ndarray          # layout.TRI_VERTS, BVH leaf order
    tri_shade: np.ndarray          # layout.TRI_SHADE, same order
    nodes: np.ndarray              # layout.BVH_NODE
    normals: np.ndarray | None     # float32 (V*3,), indexed by Triangle.v
    uvs: np.ndarray | None         # float32 (V*2,)
    materials: np.ndarray          # layout.MATERIAL
    textures: np.ndarray | None    # layout.TEXTURE
    texels: np.ndarray | None      # float16 (T*4,) RGBA, linear
    lights: np.ndarray             # layout.POINT_LIGHT
    ambient: np.ndarray            # float32 (4,)
    background: np.ndarray         # float32 (4,)
    features: Features
    bvh: bvh_mod.BVH

    def device_bytes(self) -> dict[str, int]:
        """Bytes each uploaded array takes on the device (absent arrays are not uploaded)."""
        arrays = {"tri_verts": self.tri_verts, "tri_shade": self.tri_shade, "nodes": self.nodes, "normals": self.normals, "uvs": self.uvs,
                  "materials": self.materials, "textures": self.textures, "texels": self.texels,
                  "lights": self.lights}
        return {k: int(v.nbytes) for k, v in arrays.items() if v is not None}


def compile_scene(scene: Scene, shadows: bool = True, jitter: bool = True) -> CompiledScene:
    """Flatten ``scene``; raises SceneError for anything that cannot be rendered."""
    if not isinstance(scene, Scene):
        raise SceneError(f"render: expected a texray.Scene, got {type(scene).__name__}")
    materials, textures, mat_index, tex_index = [], [], {}, {}
    nrm, uvs, verts, tris = [], [], [], []
    any_normals = any(o.normals is not None for o in scene.objects)
    any_uvs = any(o.uvs is not None and o.material.textures for o in scene.objects)
    voff = 0
    for obj_id, mesh in enumerate(scene.objects):
        m = mesh.material
        if id(m) not in mat_index:
            mat_index[id(m)] = len(materials)
            materials.append(m)
        for t in m.textures:
            tex_index.setdefault(id(t), len(textures))
            if len(textures) < len(tex_index):
                textures.append(t)
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
        verts.append(tv)
        t = np.zeros(len(keep), layout.TRI_SHADE)
        t["material"] = mat_index[id(m)]
        t["object"] = obj_id
        t["prim"] = keep
        t["v"] = fk + voff
        flags = 0
        if any_normals:
            flags |= layout.TRI_HAS_NORMALS if n is not None else 0
            nrm.append(n if n is not None else np.zeros_like(p))
        if any_uvs:
            has = mesh.uvs is not None
            flags |= layout.TRI_HAS_UVS if has else 0
            uvs.append(mesh.uvs if has else np.zeros((len(p), 2)))
        t["flags"] = flags
        tris.append(t)
        voff += len(p)
    tri_verts = np.concatenate(verts) if verts else np.zeros(0, layout.TRI_VERTS)
    tri_shade = np.concatenate(tris) if tris else np.zeros(0, layout.TRI_SHADE)
    lo, hi = triangle_bounds(tri_verts)
    tree = bvh_mod.build(lo, hi)
    tri_verts, tri_shade = tri_verts[tree.order], tri_shade[tree.order]

    mats = np.zeros(max(len(materials), 1), layout.MATERIAL)
    mats["diffuse_tex"] = mats["bump_tex"] = mats["normal_tex"] = mats["specular_tex"] = -1
    any_specular = False
    for i, m in enumerate(materials):
        kd, ks, n = m.validate(f"material {i}: ")
        mats[i]["diffuse"], mats[i]["specular"], mats[i]["shininess"] = kd, ks, n
        any_specular |= bool(np.any(ks > 0))
        if m.textures:
            mats[i]["diffuse_tex"] = tex_index[id(m.diffuse)]
    tex_table, texels = _pack_textures(textures)

    lights = np.zeros(max(len(scene.lights), 1), layout.POINT_LIGHT)
    for i, light in enumerate(scene.lights):
        lights[i]["position"], lights[i]["intensity"] = light.validate(f"lights[{i}].")
    lights = lights[:len(scene.lights)] if scene.lights else lights[:0]

    from .scene import _rgb
    features = Features(textures=bool(textures), vertex_normals=any_normals, specular=any_specular,
                        shadows=shadows and bool(scene.lights), jitter=jitter,
                        stack_size=stack_size_for(tree.depth))
    return CompiledScene(
        tri_verts=tri_verts, tri_shade=tri_shade, nodes=tree.nodes,
        normals=np.concatenate(nrm).astype(np.float32).ravel() if any_normals else None,
        uvs=np.concatenate(uvs).astype(np.float32).ravel() if any_uvs else None,
        materials=mats, textures=tex_table, texels=texels, lights=lights,
        ambient=np.append(_rgb(scene.ambient, "ambient", "scene."), 0).astype(np.float32),
        background=np.append(_rgb(scene.background, "background", "scene."), 0).astype(np.float32),
        features=features, bvh=tree)


def triangle_bounds(tri_verts):
    """(lo, hi) float32 (n, 3) boxes of TRI_VERTS triangles (exact: min/max of float32)."""
    p0, p1, p2 = tri_verts["p0"], tri_verts["p1"], tri_verts["p2"]
    return np.minimum(np.minimum(p0, p1), p2), np.maximum(np.maximum(p0, p1), p2)


def _pack_textures(textures):
    """One texture table and one shared half-float RGBA texel buffer, or (None, None)."""
    if not textures:
        return None, None
    table = np.zeros(len(textures), layout.TEXTURE)
    sizes = np.array([t.rgba.shape[0] * t.rgba.shape[1] for t in textures], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    if sizes.sum() >= 2**32:
        raise SceneError(f"textures: {sizes.sum()} texels in all exceeds the 2^32 texel limit")
    table["offset"] = offsets
    table["height"] = [t.rgba.shape[0] for t in textures]
    table["width"] = [t.rgba.shape[1] for t in textures]
    # Half floats top out at 65504: clamp so that bright HDR texels stay finite.
    texels = np.clip(np.concatenate([t.rgba.reshape(-1, 4) for t in textures]), -65504, 65504)
    texels = texels.astype(np.float16).ravel()
    return table, texels
