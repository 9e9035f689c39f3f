"""The scene's one BVH over primitives of several kinds.

Each kind (triangles, spheres, cylinders, quads) gets its own binned-SAH tree
(:func:`texray.accel.bvh.build`, leaves homogeneous in kind); when there are several,
a small top tree over their root boxes joins them into one node array. A top
leaf is replaced by the root it stands for, so traversal sees an ordinary
binary tree whose leaves carry their kind in ``count_kind``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bvh, cells
from ..device import layout
from ..device.layout import BVH_NODE

BUILDERS = ("auto", "numpy", "cells")
# Leaf sizes by kind: triangles four to a leaf (the leaf test runs them as float4 lanes,
# kernels/geometry/triangle.h); every other kind one to a leaf, so that a node's box test,
# cheaper than a quad's, sphere's, cylinder's, displaced patch's or instance's own test,
# culls it alone (leaves of 4 quads: a bumped brick wall's frame 1.23x slower, tools/ab.py).
MAX_LEAF = {layout.PRIM_TRIANGLE: 4}
# SAH bins on the trees' top levels (texray.accel.bvh build's top_bins; 16 below them): on
# the textured meshes bench scene (the ground's two large triangles stretch the top nodes'
# centroid range) the tree's SAH cost fell from 7.04 to 6.22 and the frame to 0.943 of its
# time (PoCL, the AMD EPYC, 9 interleaved renders, 2026-12-07); its build took 25 against
# 16 ms, a random 99k-box build 177 against 171 ms.
TOP_BINS = 64


@dataclass
class SceneBVH:
    nodes: np.ndarray             # BVH_NODE, root at 0
    orders: dict                  # kind -> uint32 leaf order of that kind's primitives
    sah_cost: float
    depth: int
    build_seconds: float


def triangle_bounds(tri_verts):
    """(lo, hi) float32 (n, 3) boxes of layout.TRI_VERTS triangles (exact: min/max of float32)."""
    c = layout.tri_corners(tri_verts)[:, :, :3]      # plain columns: no structured field copies
    return (np.minimum(np.minimum(c[:, 0], c[:, 1]), c[:, 2]),
            np.maximum(np.maximum(c[:, 0], c[:, 1]), c[:, 2]))


def build_kind(lo, hi, kind, builder="auto") -> bvh.BVH:
    """One kind's tree: the numpy builder (texray.accel.bvh), or the cell builder
    (texray.accel.cells: Morton cells built on PoCL's CPU device, 6-8x faster on a
    million triangles, SAH cost within a few percent); "auto" takes the cells from
    cells.MIN_PRIMS primitives on. Leaves hold up to MAX_LEAF[kind] primitives (1 unless
    listed)."""
    max_leaf = MAX_LEAF.get(kind, 1)
    if builder == "cells" or (builder == "auto" and len(lo) >= cells.MIN_PRIMS):
        return cells.build(lo, hi, kind=kind, max_leaf=max_leaf)
    return bvh.build(lo, hi, kind=kind, max_leaf=max_leaf, top_bins=TOP_BINS)


def build_scene_bvh(boxes: dict, builder="auto") -> SceneBVH:
    """boxes: kind -> (lo, hi) float32 (n, 3) primitive bounds; kinds with n == 0 are left out.
    builder: one of BUILDERS (:func:`build_kind`)."""
    if builder not in BUILDERS:
        raise ValueError(f"BVH builder: expected one of {', '.join(BUILDERS)}, got {builder!r}")
    subs = {k: build_kind(lo, hi, k, builder) for k, (lo, hi) in boxes.items() if len(lo)}
    seconds = sum(s.build_seconds for s in subs.values())
    if not subs:
        return SceneBVH(np.zeros(0, BVH_NODE), {}, 0.0, 0, seconds)
    orders = {k: s.order for k, s in subs.items()}
    if len(subs) == 1:
        (s,) = subs.values()
        return SceneBVH(s.nodes, orders, s.sah_cost, s.depth, seconds)
    kinds = list(subs)
    roots = np.stack([subs[k].nodes[0] for k in kinds])
    top = bvh.build(roots["bmin"], roots["bmax"], max_leaf=1, sah_leaf_max=1)   # one subtree per top leaf
    parts, offset, offsets = [top.nodes.copy()], len(top.nodes), {}
    for k in kinds:
        n = subs[k].nodes.copy()
        interior = n["count_kind"] == 0
        n["first"][interior] += offset
        offsets[k] = offset
        parts.append(n)
        offset += len(n)
    nodes = np.concatenate(parts)
    top_leaves = np.flatnonzero(top.nodes["count_kind"] != 0)
    for j in top_leaves:                      # one per kind: a handful of iterations
        k = kinds[top.order[top.nodes["first"][j]]]
        nodes[j] = nodes[offsets[k]]
    depth = top.depth - 1 + max(s.depth for s in subs.values())
    # SAH of the joined tree: the top's interior nodes plus each subtree's cost, rescaled
    # from its root's area to the joined root's (the subtrees' original root records stay
    # in the array, unreferenced, so the cost is not summed over the array).
    area = bvh.node_area(top.nodes)
    cost = float(area[top.nodes["count_kind"] == 0].sum())
    cost += sum(subs[k].sah_cost * bvh.node_area(subs[k].nodes[:1])[0] for k in kinds)
    return SceneBVH(nodes, orders, cost / area[0] if area[0] > 0 else cost, depth, seconds)
