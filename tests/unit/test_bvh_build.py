"""texray.bvh.build: the tree is well formed, bounds are exact, the SAH helps,
degenerate input terminates and bad input is refused.

Every random scene comes from ``np.random.default_rng(seed)``; the seed is part
of each failure message.
"""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from texray.accel.bvh import build, sah_cost
from bvh_checks import check_tree, clustered_soup, flat_grid, leaf_slots, random_soup, triangle_boxes
from texray.device.layout import BVH_NODE, decode_leaf, encode_leaf


# --- scenes -----------------------------------------------------------------

# --- well-formed trees --------------------------------------------------------

SCENES = {
    "soup": lambda rng: random_soup(rng, 5000),
    "clustered": lambda rng: clustered_soup(rng, 5000),
    "uniform-boxes": lambda rng: (lambda c, h: (c - h, c + h))(
        rng.uniform(-1, 1, (3000, 3)).astype(np.float32), rng.uniform(0, 0.01, (3000, 3)).astype(np.float32)),
    "flat-grid": lambda rng: flat_grid(rng, 40),
    "huge": lambda rng: random_soup(rng, 2000, extent=1e30, size=1e28),
    "tiny": lambda rng: random_soup(rng, 2000, extent=1e-30, size=1e-32),
    "near-float32-max": lambda rng: triangle_boxes(rng.uniform(-3e38, 3e38, (500, 3, 3))),
    "mixed-scales": lambda rng: tuple(np.concatenate(p) for p in zip(
        random_soup(rng, 500, extent=1e-20, size=1e-22), random_soup(rng, 500, extent=1e20, size=1e18))),
}


@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("scene", sorted(SCENES))
def test_tree_is_well_formed(scene, seed):
    lo, hi = SCENES[scene](np.random.default_rng(seed))
    check_tree(build(lo, hi), lo, hi, f"{scene} seed={seed}")


@pytest.mark.parametrize("n", [0, 1, 2, 3, 4, 5, 6, 17, 100])
def test_small_inputs(n):
    seed = 100 + n
    lo, hi = random_soup(np.random.default_rng(seed), n)
    bvh = build(lo, hi)
    check_tree(bvh, lo, hi, f"n={n} seed={seed}")
    if n == 1:
        assert len(bvh.nodes) == 1 and bvh.depth == 1
        assert decode_leaf(bvh.nodes["count_kind"])[0][0] == 1 and bvh.nodes["first"][0] == 0


@pytest.mark.parametrize("max_leaf,bins,sah_leaf_max", [(1, 2, None), (1, 16, 16), (2, 8, 2), (8, 32, 16),
                                                         (4, 16, None), (32, 16, 8)])
def test_settings(max_leaf, bins, sah_leaf_max):
    seed = 7
    lo, hi = clustered_soup(np.random.default_rng(seed), 3000)
    bvh = build(lo, hi, max_leaf=max_leaf, bins=bins, kind=5, sah_leaf_max=sah_leaf_max)
    check_tree(bvh, lo, hi, f"max_leaf={max_leaf} bins={bins} sah_leaf_max={sah_leaf_max} seed={seed}",
               max_leaf=max_leaf, sah_leaf_max=sah_leaf_max, kind=5)


def test_max_leaf_is_a_hard_limit_by_default():
    """E.g. a top-level tree over a few overlapping sub-tree roots, one per leaf."""
    lo = np.array([[0, 0, 0], [0.2, 0.2, 0.2], [0.1, 0, 0]], np.float32)
    hi = np.array([[1, 1, 1], [0.9, 0.9, 0.9], [1, 1, 0.8]], np.float32)
    for n in (2, 3):
        count, _ = decode_leaf(build(lo[:n], hi[:n], max_leaf=1).nodes["count_kind"])
        assert count.max() == 1 and (count == 1).sum() == n, f"n={n}: leaf sizes {count[count > 0]}"


def test_sah_termination_keeps_overlapping_boxes_together():
    seed = 15
    c = np.random.default_rng(seed).uniform(0, 1e-3, (12, 3)).astype(np.float32)
    lo, hi = c - 1, c + 1                                 # twelve nearly identical boxes
    assert len(build(lo, hi, max_leaf=1, sah_leaf_max=16).nodes) == 1, f"seed={seed}"
    assert len(build(lo, hi, max_leaf=1).nodes) == 2 * 12 - 1, f"seed={seed}"


def test_identical_boxes_terminate():
    seed = 11
    tri = np.random.default_rng(seed).normal(size=(1, 3, 3))
    lo, hi = triangle_boxes(np.repeat(tri, 10_000, axis=0))
    bvh = build(lo, hi)
    check_tree(bvh, lo, hi, f"identical seed={seed}")
    assert bvh.depth <= 16, f"seed={seed}: identical boxes should be split by count, depth {bvh.depth}"


def test_many_duplicates_and_points():
    seed = 12
    rng = np.random.default_rng(seed)
    pts = rng.integers(0, 4, (4000, 3)).astype(np.float32)   # 64 distinct point boxes
    check_tree(build(pts, pts), pts, pts, f"points seed={seed}")


def test_float64_input_is_rounded_outward():
    seed = 13
    rng = np.random.default_rng(seed)
    lo64 = rng.uniform(-1, 1, (2000, 3)) * np.float64(1 + 2 ** -30)
    hi64 = lo64 + rng.uniform(0, 0.01, (2000, 3))
    bvh = build(lo64, hi64)
    lo32, hi32 = bvh.nodes["bmin"][0], bvh.nodes["bmax"][0]
    assert np.all(lo32 <= lo64.min(axis=0)) and np.all(hi32 >= hi64.max(axis=0)), f"seed={seed}"
    owner = leaf_slots(bvh.nodes)[2]
    assert np.all(bvh.nodes["bmin"][owner] <= lo64[bvh.order]) and \
        np.all(bvh.nodes["bmax"][owner] >= hi64[bvh.order]), \
        f"seed={seed}: a float32 leaf box does not contain its float64 primitive"


def test_build_is_deterministic():
    seed = 14
    lo, hi = clustered_soup(np.random.default_rng(seed), 4000)
    a, b = build(lo, hi), build(lo, hi)
    assert np.array_equal(a.nodes, b.nodes) and np.array_equal(a.order, b.order), f"seed={seed}"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(0, 150), seed=st.integers(0, 2 ** 32 - 1), grid=st.sampled_from([2, 5, 1000]),
       max_leaf=st.integers(1, 6))
def test_random_small_scenes(n, seed, grid, max_leaf):
    """Coordinates on a coarse grid give many ties and zero extents."""
    rng = np.random.default_rng(seed)
    a = rng.integers(0, grid, (n, 3)).astype(np.float32)
    b = a + rng.integers(0, 2, (n, 3)).astype(np.float32)
    check_tree(build(a, b, max_leaf=max_leaf), a, b, f"n={n} grid={grid} seed={seed}", max_leaf=max_leaf)


# --- quality ------------------------------------------------------------------

def naive_median_tree(lo, hi, max_leaf=4):
    """Reference tree: split the *input order* in the middle until <= max_leaf."""
    ranges, nodes = [(0, len(lo))], []
    for a, b in ranges:                                  # grows while iterating
        rec = np.zeros((), BVH_NODE)
        rec["bmin"], rec["bmax"] = lo[a:b].min(axis=0), hi[a:b].max(axis=0)
        if b - a <= max_leaf:
            rec["first"], rec["count_kind"] = a, encode_leaf(b - a)
        else:
            rec["first"] = len(ranges)
            ranges += [(a, (a + b) // 2), ((a + b) // 2, b)]
        nodes.append(rec)
    return np.array(nodes, BVH_NODE)


def object_median_tree(lo, hi, max_leaf=4):
    """Stronger reference: sort by centroid along the widest centroid axis, split in the middle."""
    cent, perm = (lo.astype(np.float64) + hi) / 2, np.arange(len(lo))
    ranges, nodes = [(0, len(lo))], []
    for a, b in ranges:
        idx = perm[a:b]
        rec = np.zeros((), BVH_NODE)
        rec["bmin"], rec["bmax"] = lo[idx].min(axis=0), hi[idx].max(axis=0)
        if b - a <= max_leaf:
            rec["first"], rec["count_kind"] = a, encode_leaf(b - a)
        else:
            axis = np.argmax(np.ptp(cent[idx], axis=0))
            perm[a:b] = idx[np.argsort(cent[idx, axis], kind="stable")]
            rec["first"] = len(ranges)
            ranges += [(a, (a + b) // 2), ((a + b) // 2, b)]
        nodes.append(rec)
    return np.array(nodes, BVH_NODE)


@pytest.mark.parametrize("seed", [21, 22])
@pytest.mark.parametrize("scene", ["clustered", "soup"])
def test_sah_beats_object_median_split(scene, seed):
    lo, hi = SCENES[scene](np.random.default_rng(seed))
    built, median = build(lo, hi).sah_cost, sah_cost(object_median_tree(lo, hi))
    assert built < 0.9 * median, f"{scene} seed={seed}: SAH cost {built:.2f} vs object median {median:.2f}"


@pytest.mark.parametrize("seed", [21, 22, 23])
def test_sah_beats_naive_median_split(seed):
    lo, hi = clustered_soup(np.random.default_rng(seed), 4000)
    built, naive = build(lo, hi).sah_cost, sah_cost(naive_median_tree(lo, hi))
    assert built < 0.5 * naive, f"seed={seed}: SAH cost {built:.2f} vs naive {naive:.2f}"


def test_sah_cost_of_known_trees():
    one = np.zeros(1, BVH_NODE)
    one["bmax"], one["count_kind"] = 1, encode_leaf(3)
    assert sah_cost(one) == 3.0
    assert sah_cost(one, t_isect=2.0) == 6.0
    assert sah_cost(np.zeros(0, BVH_NODE)) == 0.0
    tree = np.zeros(3, BVH_NODE)                        # unit cube over two half cubes
    tree["bmax"] = [[1, 1, 1], [0.5, 1, 1], [1, 1, 1]]
    tree["bmin"][2] = [0.5, 0, 0]
    tree["first"] = [1, 0, 1]
    tree["count_kind"] = [0, encode_leaf(1), encode_leaf(1)]
    # A(root) = 3, A(half) = 0.5 + 1 + 0.5 = 2 -> 1 + 2 * (1 * 2 / 3)
    assert sah_cost(tree) == pytest.approx(1 + 4 / 3)


# --- bad input ------------------------------------------------------------------

def _good(n=10):
    lo = np.zeros((n, 3), np.float32)
    return lo, lo + 1


@pytest.mark.parametrize("case,message", [
    ("nan", "NaN"), ("inf", "infinite"), ("neg-inf", "infinite"), ("float64-overflow", "float32"),
    ("inverted", "bmin > bmax"), ("shape-2d", "shape"), ("shape-1d", "shape"),
    ("shape-mismatch", "shape"), ("strings", "dtype"),
])
def test_bad_boxes_are_refused(case, message):
    lo, hi = _good()
    if case == "nan":
        lo[3, 1] = np.nan
    elif case == "inf":
        hi[4, 2] = np.inf
    elif case == "neg-inf":
        lo[0, 0] = -np.inf
    elif case == "float64-overflow":
        lo, hi = lo.astype(np.float64), hi.astype(np.float64)
        hi[5, 0] = 1e300
    elif case == "inverted":
        lo[7, 2] = 2.0
    elif case == "shape-2d":
        lo, hi = lo[:, :2], hi[:, :2]
    elif case == "shape-1d":
        lo, hi = lo[0], hi[0]
    elif case == "shape-mismatch":
        hi = hi[:5]
    elif case == "strings":
        lo = lo.astype(str)
    with pytest.raises(ValueError, match=message):
        build(lo, hi)


@pytest.mark.parametrize("kwargs", [{"max_leaf": 0}, {"bins": 1}, {"kind": 256}, {"t_isect": 0.0},
                                    {"t_trav": float("nan")}, {"sah_leaf_max": 0}])
def test_bad_settings_are_refused(kwargs):
    lo, hi = _good()
    with pytest.raises(ValueError):
        build(lo, hi, **kwargs)


def test_top_levels_bin_finer():
    """top_bins: the levels of at most TOP_LEVEL_NODES nodes bin finer. Where two large flat
    boxes (a ground plane's triangles) stretch the root's centroid range, 16 bins leave the
    small objects in a few of them; finer top bins give a valid tree of lower SAH cost. A
    top_bins below bins is bins; None, the same tree as without it."""
    rng = np.random.default_rng(5)
    c = rng.normal(size=(3000, 3)).astype(np.float32) * np.float32(0.3)
    lo = np.concatenate([c - np.float32(0.01), np.float32([[-50, -0.01, -50], [-50, -0.01, -50]])])
    hi = np.concatenate([c + np.float32(0.01), np.float32([[50, 0.0, 50], [50, 0.0, 50]])])
    lo, hi = lo.astype(np.float32), hi.astype(np.float32)
    plain, fine = build(lo, hi), build(lo, hi, top_bins=64)
    check_tree(fine, lo, hi, "top_bins=64")
    assert fine.sah_cost < 0.95 * plain.sah_cost
    assert np.array_equal(build(lo, hi, top_bins=None).nodes, plain.nodes)
    assert np.array_equal(build(lo, hi, top_bins=4).nodes, plain.nodes)
