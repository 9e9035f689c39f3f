"""Tessellation of a displaced triangle mesh (``Displacement(method="tessellate")`` on a
Mesh's material): every triangle subdivided to its height texture's rate, displaced
along the interpolated vertex normal, without cracks between triangles.

Each edge gets a level from the edge alone: ``resolution`` x its length in texels of
the height texture (its uv length scaled by the texture's size), the largest over the
triangles beside it, at least 1. A triangle is cut into the regular lattice of its
largest edge level n (n^2 triangles); the lattice points on an edge of a lower level m
are moved to the nearest of that edge's m + 1 points, so the edge's vertices are the
edge's own, computed once for the edge (from its end with the lower vertex index) and
shared by the two triangles beside it: the surface is closed wherever the mesh is. The
triangles the moves make degenerate are dropped.

A vertex's displaced position is P + H(uv) n, with P, n and uv interpolated linearly
from the triangle's (or the edge's) corners and n normalized: H from the displacement of
the first displaced triangle that uses the vertex. The result's shading normals are the
area-weighted normals of the displaced triangles (the height field's slope).
"""
from __future__ import annotations

import numpy as np

from ..errors import SceneError
from ..scene.displacement import MAX_RESOLUTION
from ..scene.heightfield import height
from ..scene.mesh import Mesh
from .. import validate as V

MAX_LEVEL = 256                    # lattice cuts per edge at most (256^2 = 65536 triangles per triangle)
MAX_TRIANGLES = 1 << 24            # the tessellation's size at most: a clear error instead of an exhausted host


def check_displaceable(mesh):
    """SceneError unless the displaced mesh has what displacing it reads, by tessellation or
    by search (texray.compile.shells): its own uvs (the height texture is read there), no
    projection mapping."""
    where = f"{mesh.name}: "
    if mesh.mapping is not None:
        raise SceneError(f"{where}mapping: a displaced mesh reads its height texture at its own uvs; a projection "
                         "mapping with displacement is not supported")
    if mesh.uvs is None:
        raise SceneError(f"{where}uvs: displacement reads the height texture at the mesh's texture coordinates, "
                         "and the mesh has none")


def tessellate_mesh(mesh, resolution=None, methods=("tessellate",)) -> Mesh:
    """The displaced surface of ``mesh`` as a new Mesh in world space (see the module
    docstring); faces whose material is not displaced (by one of ``methods``) are kept as
    they are (level 1 unless a displaced neighbour refines their shared edge).
    ``resolution``: the cuts per texel, instead of each Displacement's own. ``methods``:
    ("search",) or ("maxmip",) tessellates a mesh whose shells would not bound its surface
    (texray.compile.shells)."""
    where = f"{mesh.name}: "
    check_displaceable(mesh)
    res_override = None if resolution is None else V.integer(resolution, "resolution", "tessellate: ", 1,
                                                             MAX_RESOLUTION)
    p, n = mesh.world()
    p = np.asarray(p, np.float64)
    f = np.asarray(mesh.faces, np.int64)
    uv = np.asarray(mesh.uvs, np.float64)
    mats = mesh.materials
    fmat = mesh.face_materials()
    disp = [m.displacement if m.displacement is not None and m.displacement.method in methods else None
            for m in mats]
    if n is None:
        n = vertex_normals(p, f)
    n = unit_rows(np.asarray(n, np.float64))

    # --- levels: per face-edge from its texels, per unique edge the largest -----------------
    edges = np.stack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]], axis=1)          # (F, 3, 2), edge k: v_k -> v_k+1
    lo_v, hi_v = edges.min(axis=2), edges.max(axis=2)
    key = lo_v * (len(p) + 1) + hi_v
    uniq, edge_id = np.unique(key.ravel(), return_inverse=True)
    edge_id = edge_id.reshape(-1, 3)
    want = np.ones((len(f), 3), np.int64)
    for k, d in enumerate(disp):
        if d is None:
            continue
        rate = (d.resolution if res_override is None else res_override)
        th, tw = d.texture.shape[:2]
        sel = np.flatnonzero(fmat == k)
        duv = uv[edges[sel, :, 1]] - uv[edges[sel, :, 0]]
        texels = np.nan_to_num(np.hypot(duv[..., 0] * tw, duv[..., 1] * th), nan=MAX_LEVEL, posinf=MAX_LEVEL)
        want[sel] = np.clip(np.ceil(rate * texels), 1, MAX_LEVEL).astype(np.int64)
    edge_level = np.ones(len(uniq), np.int64)
    np.maximum.at(edge_level, edge_id.ravel(), want.ravel())
    face_level = edge_level[edge_id].max(axis=1)
    total = int(np.sum(face_level ** 2))
    if total > MAX_TRIANGLES:
        raise SceneError(f"{where}material.displacement: tessellating to the height textures' rate gives {total} "
                         f"triangles, more than {MAX_TRIANGLES}; lower the displacement's resolution or the "
                         "height texture's size")

    # --- vertices: the mesh's, then each edge's inner points, then each face's inner points -----
    e_lo, e_hi = uniq // (len(p) + 1), uniq % (len(p) + 1)
    e_inner = edge_level - 1
    e_first = len(p) + np.concatenate([[0], np.cumsum(e_inner)[:-1]])
    n_edge_pts = int(e_inner.sum())
    ek = np.repeat(np.arange(len(uniq)), e_inner)
    et = (np.arange(n_edge_pts) - np.repeat(e_first - len(p), e_inner) + 1) / np.repeat(edge_level, e_inner)
    # the displacement each vertex takes: from the first displaced face using it
    vert_disp = np.full(len(p), -1, np.int64)
    edge_disp = np.full(len(uniq), -1, np.int64)
    disp_face = np.array([disp[m] is not None for m in range(len(mats))])[fmat]
    faces_d = np.flatnonzero(disp_face)
    if len(faces_d):
        order = faces_d[::-1]                                 # reversed: the first face's write is the last
        vert_disp[f[order].ravel()] = np.repeat(fmat[order], 3)
        edge_disp[edge_id[order].ravel()] = np.repeat(fmat[order], 3)
    positions = [p + _heights(disp, vert_disp, uv)[:, None] * n]
    uvs = [uv]
    if n_edge_pts:
        t = et[:, None]
        pe = (1 - t) * p[e_lo[ek]] + t * p[e_hi[ek]]
        ne = unit_rows((1 - t) * n[e_lo[ek]] + t * n[e_hi[ek]])
        uve = (1 - t) * uv[e_lo[ek]] + t * uv[e_hi[ek]]
        positions.append(pe + _heights(disp, edge_disp[ek], uve)[:, None] * ne)
        uvs.append(uve)
    next_id = len(p) + n_edge_pts
    out_faces, out_mats = [], []
    for level in np.unique(face_level):
        sel = np.flatnonzero(face_level == level)
        ids, inner_p, inner_uv, tris = _lattice(int(level), sel, f, fmat, p, n, uv, disp, edge_id, edge_level,
                                                e_lo, e_first, next_id)
        next_id += len(inner_p)
        if len(inner_p):
            positions.append(inner_p)
            uvs.append(inner_uv)
        tri = ids[:, tris]                                          # (F_l, T, 3) global vertex ids
        ok = (tri[..., 0] != tri[..., 1]) & (tri[..., 1] != tri[..., 2]) & (tri[..., 2] != tri[..., 0])
        out_faces.append(tri[ok])
        out_mats.append(np.broadcast_to(fmat[sel][:, None], ok.shape)[ok])
    pos = np.concatenate(positions)
    faces = np.concatenate(out_faces)
    mat_ids = np.concatenate(out_mats)
    normals = vertex_normals(pos, faces)
    material = mesh.material if len(mats) == 1 else list(mats)
    return Mesh(pos, faces, uvs=np.concatenate(uvs), normals=normals, material=material,
                material_ids=None if len(mats) == 1 else mat_ids, name=f"{mesh.name} (tessellated)")


def _lattice(level, sel, f, fmat, p, n, uv, disp, edge_id, edge_level, e_lo, e_first, next_id):
    """For the faces ``sel`` cut at ``level``: (global vertex id of every lattice point
    (F_l, P), the inner points' displaced positions and uvs, the lattice's triangles (T, 3)
    as point indices)."""
    a, b = [x.ravel() for x in np.meshgrid(np.arange(level + 1), np.arange(level + 1), indexing="ij")]
    keep = a + b <= level
    a, b = a[keep], b[keep]                           # point: v0 + a/n (v1 - v0) + b/n (v2 - v0)
    c = level - a - b                                 # the weight of v0, times n
    index = -np.ones((level + 1, level + 1), np.int64)
    index[a, b] = np.arange(len(a))
    ua, ub = np.meshgrid(np.arange(level), np.arange(level), indexing="ij")
    up = (ua + ub) <= level - 1
    tris = [np.stack([index[ua, ub], index[ua + 1, ub], index[ua, ub + 1]], -1)[up]]
    dn = (ua + ub) <= level - 2
    if dn.any():
        tris.append(np.stack([index[ua + 1, ub], index[ua + 1, ub + 1], index[ua, ub + 1]], -1)[dn])
    tris = np.concatenate(tris)
    fs = f[sel]
    ids = np.empty((len(sel), len(a)), np.int64)
    corner = {0: c == level, 1: a == level, 2: b == level}
    for k, m in corner.items():
        ids[:, m] = fs[:, k][:, None]
    # edge points: edge 0 is v0 -> v1 (b = 0), edge 1 v1 -> v2 (c = 0), edge 2 v2 -> v0 (a = 0)
    on_edge = {0: (b == 0) & (a > 0) & (c > 0), 1: (c == 0) & (a > 0) & (b > 0), 2: (a == 0) & (b > 0) & (c > 0)}
    toward = {0: a, 1: b, 2: c}                       # the lattice steps from the edge's start vertex v_k
    for k, m in on_edge.items():
        if not m.any():
            continue
        start, end = fs[:, k], fs[:, (k + 1) % 3]
        eid = edge_id[sel, k]
        lev = edge_level[eid][:, None]
        s = toward[k][m][None, :]                    # steps from v_k, of ``level``
        from_lo = np.where((e_lo[eid] == start)[:, None], s, level - s)    # steps from the edge's lower vertex
        q = (2 * from_lo * lev + level) // (2 * level)                       # the nearest of the edge's points
        lo_vertex = np.where((e_lo[eid] == start), start, end)[:, None]
        hi_vertex = np.where((e_lo[eid] == start), end, start)[:, None]
        inner = e_first[eid][:, None] + q - 1
        ids[:, m] = np.where(q == 0, lo_vertex, np.where(q == lev, hi_vertex, inner))
    interior = (a > 0) & (b > 0) & (c > 0)
    ni = int(interior.sum())
    ids[:, interior] = next_id + np.arange(len(sel) * ni).reshape(len(sel), ni)
    if ni == 0:
        return ids, np.zeros((0, 3)), np.zeros((0, 2)), tris
    w0, w1, w2 = (x[interior][None, :, None] / level for x in (c, a, b))
    pi = w0 * p[fs[:, 0]][:, None] + w1 * p[fs[:, 1]][:, None] + w2 * p[fs[:, 2]][:, None]
    nni = unit_rows(w0 * n[fs[:, 0]][:, None] + w1 * n[fs[:, 1]][:, None] + w2 * n[fs[:, 2]][:, None])
    uvi = w0 * uv[fs[:, 0]][:, None] + w1 * uv[fs[:, 1]][:, None] + w2 * uv[fs[:, 2]][:, None]
    which = np.broadcast_to(fmat[sel][:, None], (len(sel), ni))
    which = np.where(np.array([d is not None for d in disp])[which], which, -1)
    hi_ = _heights(disp, which.reshape(-1), uvi.reshape(-1, 2))
    return ids, (pi + hi_.reshape(len(sel), ni, 1) * nni).reshape(-1, 3), uvi.reshape(-1, 2), tris


def _heights(disp, which, uv):
    """H at ``uv`` from displacement ``disp[which]`` per point (0 where which is -1)."""
    out = np.zeros(len(uv))
    for k, d in enumerate(disp):
        if d is None:
            continue
        m = which == k
        if m.any():
            u, v = _periodic(uv[m, 0], d.wrap), _periodic(uv[m, 1], d.wrap)
            out[m] = height(d.heights(), u, v, d.wrap)
    return out


def _periodic(x, wrap):
    """``x`` moved by whole periods of the wrap mode (1 for repeat, 2 for mirror; clamp:
    into [-1, 2]): the same height, and texel indices that fit an int64 whatever the uvs."""
    if wrap == "repeat":
        return x - np.floor(x)
    if wrap == "mirror":
        return x - 2.0 * np.floor(x / 2.0)
    return np.clip(x, -1.0, 2.0)


def unit_rows(v):
    """Rows of v scaled to unit length; zero rows stay zero."""
    ln = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(ln > 0, v / np.where(ln > 0, ln, 1), 0.0)


def vertex_normals(p, f):
    """Area-weighted vertex normals of the triangles ``f`` over the points ``p``."""
    fn = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
    acc = np.zeros((len(p), 3))
    for k in range(3):
        for j in range(3):
            acc[:, j] += np.bincount(f[:, k], weights=fn[:, j], minlength=len(p))
    return unit_rows(acc)
