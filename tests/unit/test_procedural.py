"""Fast checks of texray.procedural: mesh topology, orientation, normals, UVs,
benchmark-mesh size, and texture shapes / ranges / determinism / tiling."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import trimesh

from texray import procedural as proc

REPO = Path(__file__).resolve().parents[2]

CLOSED = {
    "sphere": lambda: proc.uv_sphere(24, 12, radius=1.5),
    "torus": lambda: proc.torus(32, 12, R=1.0, r=0.3),
    "vase": lambda: proc.vase(),
    "bench": lambda: proc.bench_mesh(50_000),
}
ALL = {**CLOSED, "grid": lambda: proc.grid(5, 3, size=(2.0, 1.0))}
# minimum cos(angle) between a vertex normal and the faces around it
NORMAL_TOL = {"sphere": 0.95, "torus": 0.95, "vase": 0.75, "bench": 0.97,
              "grid": 0.999999}


def _tri(m):
    """Plain trimesh (no visuals, so copies do not need Pillow)."""
    return trimesh.Trimesh(m.positions, m.faces, process=False)


@pytest.fixture(scope="module", params=sorted(ALL))
def named_mesh(request):
    return request.param, ALL[request.param]()


def test_mesh_arrays(named_mesh):
    _, m = named_mesh
    V = len(m.positions)
    assert m.positions.shape == (V, 3) and m.positions.dtype == np.float64
    assert m.faces.ndim == 2 and m.faces.shape[1] == 3 and m.faces.dtype == np.int64
    assert m.uvs.shape == (V, 2) and m.uvs.dtype == np.float64
    assert m.normals.shape == (V, 3) and m.normals.dtype == np.float64
    assert m.faces.min() == 0 and m.faces.max() == V - 1
    assert len(np.unique(m.faces)) == V, "unreferenced vertices"
    assert _tri(m).area_faces.min() > 1e-12, "degenerate triangle"


@pytest.mark.parametrize("name", sorted(CLOSED))
def test_closed_after_seam_merge_and_outward(name):
    m = CLOSED[name]()
    t = _tri(m)
    assert t.volume > 0, "faces must be counter-clockwise seen from outside"
    merged = t.copy()
    merged.merge_vertices()
    assert merged.is_watertight
    assert len(merged.vertices) < len(t.vertices)      # seams were duplicated


def test_volumes_match_analytic():
    assert np.isclose(_tri(proc.uv_sphere(64, 32, 1.5)).volume,
                      4 / 3 * np.pi * 1.5 ** 3, rtol=0.01)
    assert np.isclose(_tri(proc.torus(64, 32, 1.0, 0.3)).volume,
                      2 * np.pi ** 2 * 1.0 * 0.3 ** 2, rtol=0.01)


def test_normals_unit_and_close_to_face_normals(named_mesh):
    name, m = named_mesh
    assert np.allclose(np.linalg.norm(m.normals, axis=1), 1.0)
    fn = _tri(m).face_normals
    cos = np.einsum("fkj,fj->fk", m.normals[m.faces], fn)
    assert cos.min() > NORMAL_TOL[name]


def test_uvs_in_range_and_not_mirrored(named_mesh):
    _, m = named_mesh
    assert m.uvs.min() >= 0.0 and m.uvs.max() <= 1.0
    uv = m.uvs[m.faces]
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    # counter-clockwise in UV space too: textures read left-to-right seen from outside
    assert (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).min() > 0


def test_grid_layout():
    g = proc.grid(4, 2, size=(2.0, 1.0), uv_scale=(3.0, 2.0))
    assert g.n_triangles == 16 and g.n_vertices == 15
    assert np.allclose(_tri(g).face_normals, [0, 1, 0])
    assert np.allclose(g.positions[:, 1], 0)
    assert np.allclose(g.positions.min(0), [-1, 0, -0.5])
    # v grows towards -z: upright seen from above with +x to the right
    top = g.uvs[:, 1] == g.uvs[:, 1].max()
    assert np.allclose(g.positions[top, 2], -0.5)
    assert np.allclose(g.uvs.max(0), [3.0, 2.0])


def test_sphere_poles_and_seam():
    s = proc.uv_sphere(16, 8, radius=2.0)
    assert s.n_triangles == 2 * 16 * 7
    assert np.allclose(np.linalg.norm(s.positions, axis=1), 2.0)
    assert np.allclose(s.normals, s.positions / 2.0)
    south = s.uvs[:, 1] == 0
    assert south.sum() == 16 and np.allclose(s.positions[south], [0, -2, 0])
    assert np.any(s.uvs[:, 0] == 0) and np.any(s.uvs[:, 0] == 1)


def test_torus_counts():
    t = proc.torus(20, 10, R=1.0, r=0.25)
    assert t.n_triangles == 2 * 20 * 10 and t.n_vertices == 21 * 11
    rho = np.hypot(t.positions[:, 0], t.positions[:, 2])
    assert np.allclose(np.hypot(rho - 1.0, t.positions[:, 1]), 0.25)


def test_vase_shape():
    v = proc.vase()
    lo, hi = v.positions.min(0), v.positions.max(0)
    assert np.isclose(lo[1], 0.0) and 0.95 < hi[1] < 1.1
    assert 0.2 < hi[0] < 0.5
    assert v.n_triangles <= 20_000


@pytest.mark.parametrize("target", [5_000, 123_457, 1_000_000])
def test_bench_mesh_count(target):
    m = proc.bench_mesh(target)
    assert abs(m.n_triangles - target) <= 0.01 * target
    r = np.linalg.norm(m.positions, axis=1)
    assert 0.7 < r.min() < 1.0 < r.max() < 1.3


# --- textures ---------------------------------------------------------------

TEXTURES = {
    "value_noise": (lambda s, seed: proc.value_noise(s, seed=seed), 1),
    "checker": (lambda s, seed: proc.checker(s), 3),
    "wood": (lambda s, seed: proc.wood(s, seed=seed), 3),
    "marble": (lambda s, seed: proc.marble(s, seed=seed), 3),
    "bricks": (lambda s, seed: proc.bricks(s, seed=seed), 3),
    "bricks_height": (lambda s, seed: proc.bricks_height(s, seed=seed), 1),
    "tiles": (lambda s, seed: proc.tiles(s, seed=seed), 3),
}


@pytest.mark.parametrize("name", sorted(TEXTURES))
def test_texture_shape_range_determinism(name):
    make, channels = TEXTURES[name]
    img = make((48, 80), 1)
    assert img.shape == (48, 80, channels) and img.dtype == np.float32
    assert img.min() >= 0.0 and img.max() <= 1.0 and img.std() > 0.02
    assert make(32, 1).shape == (32, 32, channels)
    assert np.array_equal(img, make((48, 80), 1))
    if name != "checker":
        assert not np.array_equal(img, make((48, 80), 2))


def _wrap_vs_adjacent(img, axis):
    """(mean |first - last| slice, mean |difference| of neighbouring slices)."""
    d = np.abs(np.diff(img, axis=axis)).mean()
    wrap = np.abs(np.take(img, 0, axis) - np.take(img, -1, axis)).mean()
    return wrap, d


@pytest.mark.parametrize("name", ["value_noise", "wood", "marble", "bricks"])
def test_textures_tile(name):
    img = TEXTURES[name][0]((96, 128), 3)
    for axis in (0, 1):
        wrap, adjacent = _wrap_vs_adjacent(img, axis)
        assert wrap < 3 * adjacent + 1e-3, (axis, wrap, adjacent)


def test_value_noise_continues_across_edges():
    n = proc.value_noise(128, octaves=3, seed=5)[..., 0]
    rolled = np.roll(n, 64, axis=1)           # seam now in the middle
    assert np.abs(np.diff(rolled, axis=1)).max() <= np.abs(np.diff(n, axis=1)).max() + 1e-6


def test_checker_origin_and_colours():
    c0, c1 = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    img = proc.checker(64, n_checks=4, c0=c0, c1=c1)
    assert np.allclose(img[-1, 0], c0)       # uv (0, 0) = bottom-left pixel
    assert np.allclose(img[-1, 16], c1) and np.allclose(img[-17, 0], c1)


def test_bricks_height_levels():
    h = proc.bricks_height(128)[..., 0]
    assert h.min() == 0.0 and h.max() > 0.9
    assert 0.05 < np.mean(h < 0.01) < 0.4     # some, not most, is mortar


# --- OBJ writer of tools/make_assets.py ----------------------------------------

def _make_assets():
    spec = importlib.util.spec_from_file_location(
        "make_assets", REPO / "tools" / "make_assets.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_obj_round_trip_through_trimesh(tmp_path):
    m = proc.torus(16, 8)
    path = tmp_path / "t.obj"
    _make_assets().write_obj(path, m, "test")
    # no force="mesh": trimesh 5.2 without Pillow fails to copy the default material
    t = trimesh.load(path, process=False)
    assert len(t.vertices) == m.n_vertices
    assert np.array_equal(t.faces, m.faces)
    assert np.allclose(t.vertices, m.positions, atol=1e-5)
    assert np.allclose(t.visual.uv, m.uvs, atol=1e-5)
    assert np.allclose(t.vertex_normals, m.normals, atol=1e-5)
