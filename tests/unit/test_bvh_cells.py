"""The cell builder (texray.accel.cells: Morton cells built by an OpenCL kernel on PoCL's
CPU device, joined by a numpy top tree): every invariant of the numpy builder's trees,
an SAH cost within a few percent of it, the same closest hits, and its fallbacks."""
import numpy as np
import pytest

from texray.accel import bvh, cells
from texray.accel import scene_bvh
from texray.accel.scene_bvh import build_scene_bvh
from texray.compile import compile_scene
from texray.device import devices
from texray.procedural import bench_mesh
from bvh_checks import check_tree, clustered_soup, random_soup, triangle_boxes
from test_bvh_build import SCENES

pytestmark = [pytest.mark.skipif(not any("portable computing language" in d.platform.lower() for d in devices()),
                                 reason="the cell builder runs on PoCL's CPU device"),
              # a fallback to the numpy builder would pass every tree check: it fails here
              # (the fallback tests expect it with pytest.warns)
              pytest.mark.filterwarnings("error:BVH build:UserWarning")]


@pytest.fixture
def small_cells(monkeypatch):
    """Cells of at most 64 primitives: many cells, many joins, on small inputs."""
    monkeypatch.setattr(cells, "CELL_PRIMS", 64)


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_trees_are_well_formed(scene, small_cells):
    lo, hi = SCENES[scene](np.random.default_rng(3))
    tree = cells.build(lo, hi)
    check_tree(tree, lo, hi, scene)


@pytest.mark.parametrize("n", [1, 2, 5, 8, 9, 65, 200])
def test_small_inputs_and_kinds(n, small_cells):
    lo, hi = random_soup(np.random.default_rng(n), n)
    tree = cells.build(lo, hi, kind=2)
    check_tree(tree, lo, hi, f"n={n}", kind=2)


def test_identical_boxes_split_by_count(small_cells):
    lo = np.zeros((1000, 3), np.float32)
    tree = cells.build(lo, lo + 1)
    check_tree(tree, lo, lo + 1, "identical")
    assert tree.depth <= 12          # halves: log2(1000 / 4) + the top tree over one cell


@pytest.mark.parametrize("make", [lambda r: random_soup(r, 60_000), lambda r: clustered_soup(r, 60_000)],
                         ids=["soup", "clustered"])
def test_sah_cost_within_five_percent_of_the_numpy_builder(make):
    lo, hi = make(np.random.default_rng(7))
    ref, tree = bvh.build(lo, hi), cells.build(lo, hi)
    check_tree(tree, lo, hi, "cells")
    assert tree.sah_cost <= 1.05 * ref.sah_cost, (tree.sah_cost, ref.sah_cost)


def test_a_displaced_mesh_of_200k_triangles():
    m = bench_mesh(200_000)
    lo, hi = triangle_boxes(m.positions[m.faces])
    ref, tree = bvh.build(lo, hi), cells.build(lo, hi)
    check_tree(tree, lo, hi, "bench mesh")
    assert tree.sah_cost <= 1.05 * ref.sah_cost, (tree.sah_cost, ref.sah_cost)
    assert tree.build_seconds < ref.build_seconds       # the point of it (several times over, not timed here)


def test_deterministic(small_cells):
    lo, hi = clustered_soup(np.random.default_rng(5), 5000)
    a, b = cells.build(lo, hi), cells.build(lo, hi)
    assert np.array_equal(a.nodes, b.nodes) and np.array_equal(a.order, b.order)


def test_the_same_closest_hits_as_the_numpy_tree(device):
    """Rays through both trees: the same hit distances everywhere (the triangle test does not
    depend on the tree; only ties between triangles at one distance may pick another)."""
    from texray.renderer.trace import Tracer
    import texray as tx
    m = bench_mesh(120_000)
    scene = tx.Scene()
    scene.add(tx.Mesh(m.positions, m.faces))
    rng = np.random.default_rng(2)
    org = rng.uniform(-2, 2, (20_000, 3)) + [0, 0, 4]
    dirs = rng.normal(size=(20_000, 3)) * [0.3, 0.3, 1] - [0, 0, 1]
    hits = {}
    for b in ("numpy", "cells"):
        cs = compile_scene(scene, bvh_builder=b)
        hits[b] = Tracer(cs, device=device).closest(org, dirs)
    t0, t1 = hits["numpy"].t, hits["cells"].t
    assert np.isfinite(t0).sum() > 2000
    np.testing.assert_array_equal(t0, t1)


def test_scene_bvh_builder_choice():
    lo, hi = random_soup(np.random.default_rng(1), 3000)
    a = build_scene_bvh({0: (lo, hi)}, "numpy")
    b = build_scene_bvh({0: (lo, hi)}, "cells")
    assert np.array_equal(a.nodes, bvh.build(lo, hi, top_bins=scene_bvh.TOP_BINS).nodes)
    assert len(b.nodes) != len(a.nodes) or not np.array_equal(a.nodes, b.nodes)
    with pytest.raises(ValueError, match="BVH builder: expected one of auto, numpy, cells"):
        build_scene_bvh({0: (lo, hi)}, "fast")


def test_falls_back_to_numpy_with_a_warning(monkeypatch):
    lo, hi = random_soup(np.random.default_rng(4), 3000)

    def broken(*args):
        raise RuntimeError("no device")
    monkeypatch.setattr(cells, "_run_cells", broken)
    with pytest.warns(UserWarning, match=r"cell builder is unavailable \(RuntimeError: no device\); building with numpy"):
        tree = cells.build(lo, hi)
    assert np.array_equal(tree.nodes, bvh.build(lo, hi).nodes)


def test_a_failed_cell_falls_back(monkeypatch):
    lo, hi = random_soup(np.random.default_rng(4), 3000)
    real = cells._run_cells

    def one_failed(*args):
        run = real(*args)
        run.counts[len(run.counts) // 2] = 0
        return run
    monkeypatch.setattr(cells, "_run_cells", one_failed)
    with pytest.warns(UserWarning, match="a cell failed its checks; building with numpy"):
        tree = cells.build(lo, hi)
    check_tree(tree, lo, hi, "fallback")


def test_morton_cells_partition_the_order(small_cells):
    lo, hi = clustered_soup(np.random.default_rng(8), 20_000)
    order, starts = cells.morton_cells(lo, hi)
    assert np.array_equal(np.sort(order), np.arange(len(lo)))
    assert starts[0] == 0 and starts[-1] == len(lo) and np.all(np.diff(starts.astype(np.int64)) > 0)
    assert np.diff(starts.astype(np.int64)).max() <= 64          # ten bits per axis split every cluster
