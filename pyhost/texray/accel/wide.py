"""Collapse a binary BVH into a 4-wide one (layout.BVH4_NODE), the tree the kernels traverse.

A wide node holds the boxes of up to four children as one float4 per bound and
axis, so the device tests all four with vector arithmetic: PoCL's CPU driver
compiles float4 operations to SIMD instructions (a binary node's two scalar
box tests do not vectorize), and a GPU reads the 128-byte node in one
transaction. The traversal also takes half the steps and stack operations.

Collapse (the classic greedy one, e.g. Wald et al. 2008, "Getting rid of
packets"): a wide node starts from its binary node's two children and, twice,
replaces its interior child of largest surface area by that child's two
children. Interior children become wide nodes of the next level; leaf children
keep their ``first`` and ``count_kind``. Empty lanes get the empty box
(lo = +inf, hi = -inf), which the device's slab test always misses. Wide nodes
are numbered breadth first, the root at 0. The loop is over tree levels; every
level is vectorized.
"""
from __future__ import annotations

import numpy as np

from .bvh import node_area
from ..device.layout import BVH4_NODE, BVH_NODE, word

WIDTH = 4


def stack_depth(depth: int) -> int:
    """Stack entries the device traversal (kernels/accel/bvh.h) holds at most in a wide tree of
    ``depth`` levels: WIDTH - 1 lanes pushed per level (any-hit pushes up to WIDTH and
    pops one at once: give ``features.stack_size_for`` this, which adds that one)."""
    return (WIDTH - 1) * depth


def collapse(nodes: np.ndarray) -> tuple[np.ndarray, int]:
    """(BVH4_NODE array, depth in wide levels) for the binary ``layout.BVH_NODE`` tree
    ``nodes`` (root at 0). Traversal pushes at most three lanes per level."""
    if len(nodes) == 0:
        return np.zeros(0, BVH4_NODE), 0
    # plain columns of the records (structured field gathers copy element by element)
    words = np.ascontiguousarray(nodes).view(np.uint32).reshape(len(nodes), BVH_NODE.itemsize // 4)
    first = words[:, word(BVH_NODE, "first")].astype(np.int64)
    count_kind = words[:, word(BVH_NODE, "count_kind")]
    leaf = count_kind != 0
    area = node_area(nodes)
    level = np.zeros(1, np.int64)                 # binary indices of this level's wide nodes
    if leaf[0]:
        lanes = np.full((1, WIDTH), -1, np.int64)
        lanes[0, 0] = 0                           # a single-leaf tree: one leaf lane
        levels = [lanes]
    else:
        levels = []
        while len(level):
            k = len(level)
            lanes = np.full((k, WIDTH), -1, np.int64)
            lanes[:, 0], lanes[:, 1] = first[level], first[level] + 1
            count = np.full(k, 2)
            for _ in range(WIDTH - 2):
                cand = np.where(lanes >= 0, lanes, 0)
                a = np.where((lanes >= 0) & ~leaf[cand], area[cand], -1.0)
                j = np.argmax(a, axis=1)
                rows = np.flatnonzero(a[np.arange(k), j] >= 0)
                if not len(rows):
                    break
                c = lanes[rows, j[rows]]
                lanes[rows, j[rows]] = first[c]
                lanes[rows, count[rows]] = first[c] + 1
                count[rows] += 1
            levels.append(lanes)
            inner = lanes[(lanes >= 0) & ~leaf[np.where(lanes >= 0, lanes, 0)]]
            level = inner                         # row-major: the next level's order
    lanes = np.concatenate(levels)
    total = len(lanes)
    # Wide nodes are numbered breadth first and each level's wide nodes are the previous
    # level's interior lanes in row-major order, so the interior lanes of all levels, in
    # order, are wide nodes 1, 2, ...: the child index of each is its running count.
    valid = lanes >= 0
    b = np.where(valid, lanes, 0)
    ck = count_kind[b]
    is_leaf = valid & (ck != 0)
    inner = valid & ~is_leaf
    child = np.where(is_leaf, first[b], np.cumsum(inner.reshape(-1)).reshape(total, WIDTH))
    # BVH4_NODE as runs of WIDTH words (lo_x, hi_x, ..., child, count_kind), filled as plain arrays
    out = np.empty((total, BVH4_NODE.itemsize // (4 * WIDTH), WIDTH), np.uint32)
    out_f = out.view(np.float32)
    rows = np.take(words.view(np.float32), b.reshape(-1), axis=0).reshape(total, WIDTH, -1)
    lo0, hi0 = word(BVH_NODE, "bmin"), word(BVH_NODE, "bmax")
    for axis, name in enumerate("xyz"):
        out_f[:, word(BVH4_NODE, f"lo_{name}") // WIDTH] = np.where(valid, rows[..., lo0 + axis], np.float32(np.inf))
        out_f[:, word(BVH4_NODE, f"hi_{name}") // WIDTH] = np.where(valid, rows[..., hi0 + axis], np.float32(-np.inf))
    out[:, word(BVH4_NODE, "child") // WIDTH] = np.where(valid, child, 0)
    out[:, word(BVH4_NODE, "count_kind") // WIDTH] = np.where(is_leaf, ck, 0)
    return out.reshape(total, -1).view(BVH4_NODE).reshape(total), len(levels)
