"""BVH test helpers shared by tests/unit and tests/portability: box soups and the
checker of every structural invariant of a texray.accel.bvh.BVH."""
import numpy as np

from texray.accel.bvh import leaf_size_limit, sah_cost
from texray.device.layout import BVH_NODE, PRIM_TRIANGLE, decode_leaf


def triangle_boxes(tris):
    """(n, 3, 3) triangle corners -> float32 (bmin, bmax)."""
    tris = np.asarray(tris, np.float32)
    return tris.min(axis=1), tris.max(axis=1)


def random_soup(rng, n, extent=100.0, size=1.0):
    centres = rng.uniform(0, extent, (n, 1, 3))
    return triangle_boxes(centres + rng.normal(0, size, (n, 3, 3)))


def clustered_soup(rng, n, clusters=20):
    centres = rng.uniform(0, 100, (clusters, 3))[rng.integers(0, clusters, n)]
    return triangle_boxes(centres[:, None, :] + rng.normal(0, 0.5, (n, 3, 3)))


def flat_grid(rng, cells):
    """Triangulated z = 0 grid, in random order: every box has zero z extent."""
    x, y = np.meshgrid(np.arange(cells), np.arange(cells), indexing="ij")
    p = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    dx, dy = np.array([1, 0, 0]), np.array([0, 1, 0])
    tris = np.concatenate([np.stack([p, p + dx, p + dx + dy], 1), np.stack([p, p + dx + dy, p + dy], 1)])
    return triangle_boxes(tris[rng.permutation(len(tris))])


# --- the checker ------------------------------------------------------------

def node_depths(nodes):
    """Depth (root = 1) of every node reachable from the root; 0 = unreachable."""
    count, _ = decode_leaf(nodes["count_kind"])
    depth = np.zeros(len(nodes), np.int64)
    frontier, d = np.array([0]), 1
    while len(frontier):
        depth[frontier] = d
        inner = frontier[count[frontier] == 0]
        first = nodes["first"][inner].astype(np.int64)
        frontier, d = np.concatenate([first, first + 1]), d + 1
    return depth


def leaf_slots(nodes):
    """Leaves sorted by first slot, their sizes, and the leaf owning each slot."""
    count, _ = decode_leaf(nodes["count_kind"])
    leaf = np.flatnonzero(count > 0)
    by_first = leaf[np.argsort(nodes["first"][leaf])]
    sizes = count[by_first].astype(np.int64)
    return by_first, sizes, np.repeat(by_first, sizes)


def check_tree(bvh, lo, hi, ctx, *, max_leaf=4, sah_leaf_max=None, kind=PRIM_TRIANGLE):
    """Assert every structural invariant of ``bvh`` built over boxes (lo, hi)."""
    n, nodes, order = len(lo), bvh.nodes, bvh.order
    assert nodes.dtype == BVH_NODE, ctx
    assert order.dtype == np.uint32 and order.shape == (n,), ctx
    assert np.array_equal(np.sort(order), np.arange(n)), f"{ctx}: order is not a permutation"
    if n == 0:
        assert len(nodes) == 0 and bvh.depth == 0 and bvh.sah_cost == 0.0, ctx
        return
    count, kinds = decode_leaf(nodes["count_kind"])
    first = nodes["first"].astype(np.int64)
    leaf, inner = np.flatnonzero(count > 0), np.flatnonzero(count == 0)

    # Interior nodes: children adjacent, after the parent, each node reached once.
    assert np.all(first[inner] > inner) and np.all(first[inner] + 1 < len(nodes)), \
        f"{ctx}: child index out of range"
    children = np.concatenate([first[inner], first[inner] + 1])
    assert np.array_equal(np.sort(children), np.arange(1, len(nodes))), \
        f"{ctx}: every node but the root must be the child of exactly one interior node"
    depth = node_depths(nodes)
    assert depth.min() >= 1 and bvh.depth == depth.max(), f"{ctx}: depth {bvh.depth} != {depth.max()}"

    # Leaves tile the slots [0, n) without overlap.
    by_first, sizes, leaf_of_slot = leaf_slots(nodes)
    starts = first[by_first]
    assert starts[0] == 0 and np.array_equal(starts[1:], (starts + sizes)[:-1]) \
        and starts[-1] + sizes[-1] == n, f"{ctx}: leaves do not tile [0, {n})"
    assert sizes.max() <= leaf_size_limit(max_leaf, sah_leaf_max), \
        f"{ctx}: leaf of {sizes.max()} > limit {leaf_size_limit(max_leaf, sah_leaf_max)}"
    assert np.all(kinds[leaf] == kind), f"{ctx}: wrong primitive kind in a leaf"

    # Bounds are exact: leaves = union of their boxes, parents = union of children.
    lo_leaf = np.full((len(nodes), 3), np.inf, np.float32)
    hi_leaf = np.full((len(nodes), 3), -np.inf, np.float32)
    np.minimum.at(lo_leaf, leaf_of_slot, lo[order])
    np.maximum.at(hi_leaf, leaf_of_slot, hi[order])
    assert np.array_equal(nodes["bmin"][leaf], lo_leaf[leaf]) and \
        np.array_equal(nodes["bmax"][leaf], hi_leaf[leaf]), f"{ctx}: leaf bounds != union of its boxes"
    c0, c1 = first[inner], first[inner] + 1
    assert np.array_equal(nodes["bmin"][inner], np.minimum(nodes["bmin"][c0], nodes["bmin"][c1])) and \
        np.array_equal(nodes["bmax"][inner], np.maximum(nodes["bmax"][c0], nodes["bmax"][c1])), \
        f"{ctx}: interior bounds != union of its children"
    assert np.array_equal(nodes["bmin"][0], lo.min(axis=0)) and \
        np.array_equal(nodes["bmax"][0], hi.max(axis=0)), f"{ctx}: root bounds != union of all boxes"
    assert bvh.sah_cost == sah_cost(nodes), ctx
