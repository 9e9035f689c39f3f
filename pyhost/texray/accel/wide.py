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
from ..device.layout import BVH4_NODE

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
    first = nodes["first"].astype(np.int64)
    leaf = nodes["count_kind"] != 0
    area = node_area(nodes)
    level = np.zeros(1, np.int64)                 # binary indices of this level's wide nodes
    if leaf[0]:
        lanes = np.full((1, WIDTH), -1, np.int64)
        lanes[0, 0] = 0                           # a single-leaf tree: one leaf lane
        levels, starts = [lanes], [0]
    else:
        levels, starts = [], []
        start = 0
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
            starts.append(start)
            start += k
            inner = lanes[(lanes >= 0) & ~leaf[np.where(lanes >= 0, lanes, 0)]]
            level = inner                         # row-major: the next level's order
    total = sum(len(x) for x in levels)
    out = np.zeros(total, BVH4_NODE)
    next_start = starts[1:] + [total]
    for lanes, s, ns in zip(levels, starts, next_start):
        k = len(lanes)
        valid = lanes >= 0
        b = np.where(valid, lanes, 0)
        lo = np.where(valid[..., None], nodes["bmin"][b], np.float32(np.inf))
        hi = np.where(valid[..., None], nodes["bmax"][b], np.float32(-np.inf))
        rec = out[s:s + k]
        for axis, name in enumerate("xyz"):
            rec[f"lo_{name}"] = lo[..., axis]
            rec[f"hi_{name}"] = hi[..., axis]
        is_leaf = valid & leaf[b]
        inner = valid & ~is_leaf
        child = np.zeros((k, WIDTH), np.int64)
        child[is_leaf] = first[b[is_leaf]]
        child[inner] = ns + np.arange(int(inner.sum()))
        rec["child"] = child.astype(np.uint32)
        rec["count_kind"] = np.where(is_leaf, nodes["count_kind"][b], 0).astype(np.uint32)
    return out, len(levels)
