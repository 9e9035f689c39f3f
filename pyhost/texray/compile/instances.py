"""The bottom level of the two-level BVH: each mesh that instances share is compiled once
(its triangles in the mesh's own world space, one 4-wide BLAS) and appended to the
scene's triangle and node arrays; each texray.Instance becomes one layout.INSTANCE
record and one box (its BLAS root's box through its matrix) in the top-level tree. A
BLAS whose coordinates are far from 1 is in units of its own (texray.compile.units), which
its instances' matrices undo.

Moving instances rebuilds only the top level: each BLAS's tree (its leaf order and
wide nodes) is kept in this process, keyed by a hash of exactly what its build reads
(the triangles' float32 boxes and the builder), so compiling the scene again with new
instance matrices (the frames of an animation) builds no BLAS twice."""
from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from ..accel import wide
from ..accel.scene_bvh import build_scene_bvh
from ..device import layout
from ..scene.shape import outward
from . import units

_EMPTY = (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
# The BLAS trees kept for the next compile: {key: (leaf order, wide nodes, depth)}, least
# recently used first, bounded by the bytes they hold.
_TREES: OrderedDict = OrderedDict()
TREE_CACHE_BYTES = 512 << 20


@dataclass
class Blases:
    """The instanced meshes compiled once, before their offsets into the scene's arrays."""
    meshes: list          # [(mesh, records dict, wide nodes, depth)] per unique mesh
    items: list           # [(obj_id, instance, mesh index)]
    depth: int = 0        # the deepest BLAS, in wide levels
    reused: int = 0       # BLAS trees taken from an earlier compile (not rebuilt)


def build(items, mats, any_normals, any_uvs, vertex_offset, builder) -> Blases:
    """Compile each unique mesh of the (obj_id, Instance) ``items`` once."""
    index, meshes, out = {}, [], []
    voff, reused = vertex_offset, 0
    for obj_id, inst in items:
        key = id(inst.mesh)
        if key not in index:
            mesh = inst.mesh
            material = np.array([mats.index(m) for m in mesh.materials], np.int64)
            rec = mesh.device_records(material, obj_id, voff, any_normals, any_uvs)
            voff += len(mesh.positions)
            (order, nodes, depth), hit = _tree(rec.lo, rec.hi, builder)
            reused += hit
            arrays = dict(rec.arrays)
            arrays["tri_verts"], arrays["tri_shade"] = (layout.take_records(arrays["tri_verts"], order),
                                                        layout.take_records(arrays["tri_shade"], order))
            index[key] = len(meshes)
            meshes.append((mesh, arrays, nodes, depth, (rec.lo.min(0), rec.hi.max(0))))
        out.append((obj_id, inst, index[key]))
    return Blases(meshes, out, max((m[3] for m in meshes), default=0), reused)


def _tree(lo, hi, builder):
    """((leaf order, wide nodes, depth), whether it was kept from an earlier compile) of
    the BLAS over the float32 triangle boxes (lo, hi). The arrays are shared with the
    cache: callers index and copy them, never write them."""
    h = hashlib.blake2b(digest_size=20)
    for part in (str(builder).encode(), np.ascontiguousarray(lo), np.ascontiguousarray(hi)):
        h.update(part)
    key = (h.digest(), lo.shape)
    if key in _TREES:
        _TREES.move_to_end(key)
        return _TREES[key], True
    tree = build_scene_bvh({layout.PRIM_TRIANGLE: (lo, hi)}, builder)
    nodes, depth = wide.collapse(tree.nodes)
    entry = (tree.orders[layout.PRIM_TRIANGLE], nodes, depth)
    _TREES[key] = entry
    while len(_TREES) > 1 and sum(e[0].nbytes + e[1].nbytes for e in _TREES.values()) > TREE_CACHE_BYTES:
        _TREES.popitem(last=False)
    return entry, False


def boxes(b: Blases):
    """float32 (lo, hi) world boxes of the instances: the 8 corners of the mesh's box
    through the instance matrix, rounded outward and padded by 2^-20 of their size and
    position (the device moves rays, not boxes, in float32)."""
    if not b.items:
        return _EMPTY
    lo, hi = np.zeros((len(b.items), 3)), np.zeros((len(b.items), 3))
    for i, (_, inst, k) in enumerate(b.items):
        blo, bhi = (np.asarray(x, np.float64) for x in b.meshes[k][4])
        corners = np.array([[(bhi if (c >> a) & 1 else blo)[a] for a in range(3)] for c in range(8)])
        m = inst.matrix()
        w = corners @ m[:3, :3].T + m[:3, 3]
        lo[i], hi[i] = w.min(0), w.max(0)
    pad = 2.0 ** -20 * ((hi - lo).max(axis=1) + np.abs(lo).max(axis=1) + np.abs(hi).max(axis=1))[:, None]
    return outward(lo - pad, hi + pad)


def place(b: Blases, arrays, nodes, order):
    """Append the BLASes' triangles (and vertex data) to ``arrays`` and their nodes to the
    top-level ``nodes`` (child indices offset); the INSTANCE records in the top tree's leaf
    order ``order``. Returns (nodes, instance records)."""
    parts_nodes, roots, scales = [nodes], [], []
    node_base = len(nodes)
    for mesh, rec, bn, _, box in b.meshes:
        # each BLAS in units of its own (texray.compile.units): its triangles and boxes times a
        # power of two where its coordinates are far from 1, the instance matrices below over it
        kb = units.choose_scale(units.box_extent(*box))
        scales.append(kb)
        tri_base = len(arrays["tri_verts"])
        bn = units.scale_fields(bn.copy(), units.NODE_BOUNDS, kb)      # the cache's: never written
        rec = dict(rec, tri_verts=units.scale_fields(rec["tri_verts"], units.LENGTHS["tri_verts"], kb))
        leaf = bn["count_kind"] != 0
        empty = ~np.isfinite(bn["lo_x"])
        bn["child"] = np.where(leaf, bn["child"] + np.uint32(tri_base),
                               np.where(empty, bn["child"], bn["child"] + np.uint32(node_base)))
        roots.append(node_base)
        node_base += len(bn)
        parts_nodes.append(bn)
        for n in ("tri_verts", "tri_shade"):
            arrays[n] = np.concatenate([arrays[n], rec[n]])
        for n in ("normals", "uvs"):
            if n in rec:
                arrays[n] = np.concatenate([arrays.get(n, np.zeros(0, np.float32)),
                                            np.asarray(rec[n], np.float32).ravel()])
    rec = np.zeros(len(b.items), layout.INSTANCE)
    for i, (obj_id, inst, k) in enumerate(b.items):
        m = inst.matrix()
        inv = np.linalg.inv(m)
        r = rec[i]
        # from the BLAS's units (kb per unit of the mesh's space): o2w = M Kb^-1, w2o = Kb M^-1 and
        # the normal matrix (o2w^-1)^T = kb M^-T (its normals are normalized: a direction)
        kb = scales[k]
        o2w, w2o = m[:3].copy(), inv[:3] * kb
        o2w[:, :3] /= kb
        r["o2w"], r["w2o"] = o2w, w2o
        r["nrm"][:, :3] = inv[:3, :3].T * kb
        r["root"], r["object"] = roots[k], obj_id
        r["det_sign"] = 1.0 if np.linalg.det(m[:3, :3]) > 0 else -1.0
    return np.concatenate(parts_nodes), rec[order]
