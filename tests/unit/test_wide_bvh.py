"""texray.wide.collapse: the 4-wide tree the kernels traverse holds exactly the
binary tree's leaves, with exact bounds, every wide node reached once, empty
lanes that no ray enters, and the depth the traversal stack is sized from.
(Traversal of the wide tree on the device is tested against float64 brute force
in test_traversal.py and test_extremes.py.)"""
import numpy as np
import pytest

from texray.accel.scene_bvh import build_scene_bvh
from texray.accel.bvh import build
from texray.device.layout import BVH4_NODE, PRIM_QUAD, PRIM_SPHERE, PRIM_TRIANGLE
from texray.accel.wide import collapse

from bvh_checks import clustered_soup, flat_grid, node_depths, random_soup


def _lanes(wide, i):
    w = wide[i]
    lo = np.stack([w["lo_x"], w["lo_y"], w["lo_z"]], axis=1)
    hi = np.stack([w["hi_x"], w["hi_y"], w["hi_z"]], axis=1)
    return lo, hi, w["child"], w["count_kind"]


def _check(nodes, wide, depth, ctx):
    assert wide.dtype == BVH4_NODE and wide.dtype.itemsize == 128, ctx
    leaves = nodes[(nodes["count_kind"] != 0) & (node_depths(nodes) > 0)]      # the reachable leaves
    want = sorted(zip(leaves["first"].tolist(), leaves["count_kind"].tolist(),
                      map(tuple, leaves["bmin"].tolist()), map(tuple, leaves["bmax"].tolist())))
    got, seen = [], np.zeros(len(wide), np.int64)
    seen[0] = 1
    frontier, levels = [0], 0
    while frontier:
        levels += 1
        nxt = []
        for i in frontier:
            lo, hi, child, ck = _lanes(wide, i)
            empty = lo[:, 0] == np.inf
            assert np.all(hi[empty] == -np.inf) and np.all(lo[empty] == np.inf) and np.all(ck[empty] == 0), ctx
            assert (~empty).sum() >= (1 if len(nodes) == 1 else 2), f"{ctx}: node {i} has one child"
            for lane in np.flatnonzero(~empty):
                assert np.all(lo[lane] <= hi[lane]), ctx
                if ck[lane]:
                    got.append((int(child[lane]), int(ck[lane]), tuple(lo[lane].tolist()), tuple(hi[lane].tolist())))
                else:
                    c = int(child[lane])
                    assert 0 < c < len(wide), ctx
                    seen[c] += 1
                    clo, chi, _, _ = _lanes(wide, c)
                    full = clo[:, 0] != np.inf
                    # the lane's box is exactly the union of its node's children
                    np.testing.assert_array_equal(lo[lane], clo[full].min(axis=0), err_msg=ctx)
                    np.testing.assert_array_equal(hi[lane], chi[full].max(axis=0), err_msg=ctx)
                    nxt.append(c)
        frontier = nxt
    assert sorted(got) == want, f"{ctx}: leaves differ"
    assert np.all(seen == 1), f"{ctx}: wide nodes reached {sorted(set(seen.tolist()))} times"
    assert depth == levels, ctx
    # Each wide level stands for at least one binary level: the stack bound 3 x depth holds.
    assert depth <= max(1, (np.log2(len(nodes) + 1) * 4)), ctx


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 7, 64, 1000])
@pytest.mark.parametrize("soup", ["random", "clustered"])
def test_collapse_keeps_every_leaf_with_exact_bounds(n, soup):
    rng = np.random.default_rng(n)
    lo, hi = (random_soup if soup == "random" else clustered_soup)(rng, n)
    tree = build(lo, hi, max_leaf=1 if n < 8 else 4)
    wide, depth = collapse(tree.nodes)
    _check(tree.nodes, wide, depth, f"{soup} n={n}")
    if n >= 64:     # the greedy collapse fills most lanes
        full = np.isfinite(wide["lo_x"]).sum(axis=1)
        assert full.mean() > 2.8, full.mean()


def test_collapse_of_a_flat_grid_and_of_a_mixed_kind_scene():
    rng = np.random.default_rng(3)
    lo, hi = flat_grid(rng, 20)
    tree = build(lo, hi)
    _check(tree.nodes, *collapse(tree.nodes), "flat grid")
    boxes = {PRIM_TRIANGLE: random_soup(rng, 50), PRIM_SPHERE: random_soup(rng, 3), PRIM_QUAD: random_soup(rng, 1)}
    scene = build_scene_bvh(boxes)
    wide, depth = collapse(scene.nodes)
    kinds = {int(k) >> 24 for k in wide["count_kind"].ravel() if k}
    assert kinds == {PRIM_TRIANGLE, PRIM_SPHERE, PRIM_QUAD}
    # The joined tree keeps the subtrees' original roots in the array, unreferenced:
    # the wide tree holds only what is reachable.
    _check(scene.nodes, wide, depth, "mixed kinds")


def test_collapse_of_an_empty_tree():
    wide, depth = collapse(build(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32)).nodes)
    assert len(wide) == 0 and depth == 0
