"""Whole renders on the device against the float64 reference renderer (tests/reference.py)."""
import numpy as np

import texray as tx
from reference import render_reference
from scenes_for_tests import box, quad, textured_box_scene

W, H = 96, 72


def _interior(ids, vis):
    """Pixels whose 3x3 neighbourhood sees one primitive... of one object and one light visibility:
    away from silhouettes and shadow boundaries, where a float32 hit may land on the other side."""
    keep = np.ones(ids.shape, bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            sid = np.roll(np.roll(ids, dy, 0), dx, 1)
            svis = np.roll(np.roll(vis, dy, 0), dx, 1)
            keep &= (sid >= 0) == (ids >= 0)
            keep &= np.all(svis == vis, axis=-1)
    keep[[0, -1], :] = keep[:, [0, -1]] = False
    return keep


def test_kernels_match_float64_reference(device):
    scene = textured_box_scene()
    img = tx.render(scene, W, H, spp=1, device=device, jitter=False)
    ref, ids, vis = render_reference(scene, W, H)
    assert img.rgb.shape == (H, W, 3) and img.rgb.dtype == np.float32
    assert np.all(np.isfinite(img.rgb))
    keep = _interior(ids, vis)
    assert keep.mean() > 0.6
    # Tolerance: float32 interpolation, rsqrt and powr (a few ulp each) against float64.
    err = np.abs(img.rgb - ref)[keep]
    tol = 1e-4 + 2e-4 * np.abs(ref[keep])
    bad = err > tol
    assert not bad.any(), f"{bad.sum()} interior pixels off; worst {err.max():.3g}"
    # At silhouettes and shadow edges a pixel may legitimately flip; few do.
    assert np.mean(np.abs(img.rgb - ref).max(-1) > 1e-3) < 0.03


def test_shadowed_point_is_dark_and_lit_point_is_not(device):
    kd = np.array([0.5, 0.5, 0.5])
    p, f, _ = quad(0.0, 4.0)
    scene = tx.Scene(camera=tx.Camera(eye=(0, 6, 0.001), look_at=(0, 0, 0), fov_y=60),
                     lights=[tx.PointLight((0.0, 4.0, 0.0), (20, 20, 20))], ambient=(0.1, 0.1, 0.1))
    scene.add(tx.Mesh(p, f, material=tx.Material(diffuse=kd), name="floor"))
    bp, bf = box((0.0, 2.0, 0.0), (0.5, 0.05, 0.5))           # a floating slab under the light
    scene.add(tx.Mesh(bp, bf, material=tx.Material(diffuse=kd), name="slab"))
    img = tx.render(scene, 101, 101, spp=1, device=device, jitter=False)
    # Pixel rays from the camera: find floor pixels straight below the slab (in its shadow,
    # but seen past its edge) and far from it.
    ref, ids, vis = render_reference(scene, 101, 101)
    floor = np.isin(ids, np.flatnonzero(np.isin(_objects(scene), [0])))
    shadowed = floor & ~vis[..., 0]
    lit = floor & vis[..., 0]
    assert shadowed.sum() > 20 and lit.sum() > 20
    keep = _interior(ids, vis)
    np.testing.assert_allclose(img.rgb[shadowed & keep], 0.1 * 0.5, rtol=1e-5)   # ambient only
    assert np.all(img.rgb[lit & keep] > 0.1 * 0.5 + 0.05)


def _objects(scene):
    from texray.compile import compile_scene
    return compile_scene(scene).tri_shade["object"]


def test_no_light_leaks_into_a_closed_box(device):
    """A light inside a closed box lights nothing outside; a light outside lights nothing inside."""
    p, f, _ = quad(0.0, 3.0)
    inside = tx.PointLight((0.0, 0.5, 0.0), (50, 50, 50))
    scene = tx.Scene(camera=tx.Camera(eye=(0, 3, 3), look_at=(0, 0, 0)), lights=[inside])
    scene.add(tx.Mesh(p, f, name="floor"))
    bp, bf = box((0.0, 0.5, 0.0), (0.5, 0.499, 0.5))
    scene.add(tx.Mesh(bp, bf, name="box"))
    img = tx.render(scene, 64, 64, spp=4, device=device)
    assert img.rgb.max() == 0.0


def test_stats_time_each_compile_step(device, scenes_dir):
    scene = tx.Scene.load(scenes_dir / "showcase.toml")
    s = tx.render(scene, 16, 12, 1, device=device, cache=False).stats
    steps = s["compile_steps_s"]
    assert set(steps) == {"validate", "tessellate", "records", "heights", "instances", "bvh", "wide", "leaf_order",
                          "textures", "tables"}
    assert all(v >= 0 for v in steps.values())
    assert sum(steps.values()) <= s["scene_compile_s"] and steps["bvh"] >= s["bvh_build_s"] * 0.9
