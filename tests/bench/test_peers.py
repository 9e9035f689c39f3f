"""texray.bench.peers: the scene -> Mitsuba conversion (pure Python, no peer needed), and, when the
peers are installed, Embree's hits and Mitsuba's images against texray's on the same work."""
import math
import sys
from types import SimpleNamespace

import numpy as np
import pytest

import texray as tx
from texray import procedural
from texray.bench import peers


def _texture(seed=1, shape=(4, 6), cell=8):
    rng = np.random.default_rng(seed)
    return tx.Texture.from_array(np.kron(rng.random((*shape, 3)), np.ones((cell, cell, 1))), colorspace="linear")


def _bump_class():
    """texray's Bump (tx.Bump, or texray.bump.Bump while it is not exported yet), or None."""
    if hasattr(tx, "Bump"):
        return tx.Bump
    try:
        from texray.scene.bump import Bump
    except ImportError:
        return None
    return Bump


def _quad_scene(material, lights=None):
    sc = tx.Scene(camera=tx.Camera(eye=(0.3, 0.5, 3.0), look_at=(0, 0, 0), fov_y=45),
                  lights=lights or [tx.PointLight((1.0, 2.0, 2.0), (8.0, 8.0, 8.0))],
                  ambient=(0.05, 0.05, 0.05), background=(0.1, 0.2, 0.3))
    sc.add(tx.Quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0), material=material, name="quad"))
    return sc


# ----------------------------------------------------------------------------- pure conversion

def test_camera_to_world_maps_mitsuba_camera_rays_onto_texray_rays():
    cam = tx.Camera(eye=(2.6, 2.4, 4.6), look_at=(0.1, 0.5, 0.0), fov_y=38)
    aspect = 640 / 480
    m = peers.camera_to_world(cam, aspect)
    eye, fwd, right, up = cam.basis(aspect)
    np.testing.assert_allclose(m[:3, 3], eye)
    np.testing.assert_allclose(m[:3, :3].T @ m[:3, :3], np.eye(3), atol=1e-12)    # rigid
    h = math.tan(math.radians(38) / 2)
    for x, y in [(0, 0), (1, 1), (-1, 1), (0.3, -0.7)]:
        # Mitsuba's camera space: +x left, +y up, +z forward; NDC x to the right
        d_cam = np.array([-x * h * aspect, y * h, 1.0])
        np.testing.assert_allclose(m[:3, :3] @ d_cam, fwd + x * right + y * up, atol=1e-12)
    spec = peers.mitsuba_spec(tx.Scene(camera=cam), 640, 480)
    assert spec["sensor"]["fov"] == 38 and spec["sensor"]["fov_axis"] == "y"
    assert (spec["sensor"]["width"], spec["sensor"]["height"]) == (640, 480)


def test_bitmap_rows_flipped_and_tint_applied():
    tex = _texture()
    h = tex.shape[0]
    t = peers.texture_spec(tex, scale=(0.5, 1.0, 2.0))
    # texray: texel row j's centre is at v = 1 - (j + 0.5) / H; Mitsuba: bitmap row k at v = (k + 0.5) / H
    for j in (0, 5, h - 1):
        k = int(np.floor((1 - (j + 0.5) / h) * h))
        np.testing.assert_allclose(t["bitmap"][k], tex.rgba[j, :, :3] * [0.5, 1.0, 2.0], rtol=1e-6)
    assert t["raw"] and t["filter_type"] == "bilinear" and t["wrap_mode"] == "repeat"
    np.testing.assert_array_equal(t["to_uv"], np.eye(3))


def test_uv_transform_and_sphere_v_flip():
    uvt = tx.UVTransform(scale=(2, 3), offset=(0.1, 0.2), rotation=20)
    tex = _texture().with_options(wrap="mirror", uv_transform=uvt)
    mesh_t = peers.texture_spec(tex)
    uv = np.array([0.3, 0.8])
    np.testing.assert_allclose((mesh_t["to_uv"] @ [*uv, 1])[:2], uvt.apply(uv))
    assert mesh_t["wrap_mode"] == "mirror"
    # a sphere point at polar angle theta (from axis_z), azimuth phi (from axis_x toward z x x)
    sph = tx.Sphere((1, 2, 3), 0.5, material=tx.Material(diffuse=tex), axis_z=(0, 1, 0), axis_x=(0, 0, 1))
    s = peers.shape_spec(sph)
    np.testing.assert_allclose(s["to_world"][:3, 0], [0, 0, 0.5])     # x = axis_x * r
    np.testing.assert_allclose(s["to_world"][:3, 1], [0.5, 0, 0])     # y = z x x
    np.testing.assert_allclose(s["to_world"][:3, 2], [0, 0.5, 0])     # z = axis_z
    np.testing.assert_allclose(s["to_world"][:3, 3], [1, 2, 3])
    theta, phi = 0.6, 4.0
    mitsuba_uv = np.array([phi / (2 * np.pi), theta / np.pi, 1.0])
    texray_uv = np.array([phi / (2 * np.pi), 1 - theta / np.pi])
    np.testing.assert_allclose((s["material"]["reflectance"]["to_uv"] @ mitsuba_uv)[:2], uvt.apply(texray_uv))


def test_lights_carry_pi_and_integrator_is_direct_hard_shadows():
    sc = _quad_scene(tx.Material(diffuse=(0.5, 0.5, 0.5)),
                     lights=[tx.PointLight((1, 2, 3), (8, 4, 2)), tx.PointLight((0, 5, 0), (1, 1, 1))])
    spec = peers.mitsuba_spec(sc, 64, 48, spp=16, seed=3)
    np.testing.assert_allclose(spec["lights"][0]["intensity"], np.array([8, 4, 2]) * np.pi)
    np.testing.assert_allclose(spec["lights"][1]["position"], [0, 5, 0])
    assert spec["integrator"] == {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}
    assert spec["sampler"] == {"type": "multijitter", "sample_count": 16, "seed": 3}
    np.testing.assert_allclose(spec["background"], [0.1, 0.2, 0.3])
    assert any("pi" in n for n in spec["notes"]) and any("ambient" in n for n in spec["notes"])
    assert spec["shapes"][0]["kind"] == "mesh" and spec["shapes"][0].get("note") is None   # a parallelogram
    np.testing.assert_array_equal(spec["shapes"][0]["faces"], [[0, 1, 2], [0, 2, 3]])


def test_comparable_scene_drops_ambient_and_specular_only_in_the_copy():
    m = tx.Material(diffuse=(0.5, 0.6, 0.7), specular=0.3, shininess=20)
    sc = _quad_scene(m)
    cmp, notes = peers.comparable_scene(sc)
    assert tuple(cmp.ambient) == (0.0, 0.0, 0.0) and len(notes) == 2
    assert cmp.objects[0].material.specular == 0.0 and cmp.objects[0].material.diffuse == (0.5, 0.6, 0.7)
    assert sc.objects[0].material.specular == 0.3 and sc.ambient == (0.05, 0.05, 0.05)


def test_comparable_scene_differentiates_bump_maps_exactly_as_mitsuba_does():
    Bump = _bump_class()
    height = _texture(seed=4)
    bumped = tx.Material(diffuse=(0.5, 0.5, 0.5), bump=Bump(height, height=0.02))
    sc = _quad_scene(bumped)
    cmp, notes = peers.comparable_scene(sc)
    b = cmp.objects[0].material.bump
    assert b.delta == "analytic" and b.height == 0.02 and b.texture is height
    assert sc.objects[0].material.bump.delta is None                       # the original keeps its step
    assert any("bump delta set to 'analytic' in 1 material" in n for n in notes)
    spec = peers.mitsuba_spec(cmp, 16, 12, 1)
    assert not any("not converted" in n for n in spec["notes"])            # nothing left unconverted
    # already exact: the material is shared, no note
    exact = tx.Material(bump=Bump(height, height=0.02, delta="analytic"))
    cmp2, notes2 = peers.comparable_scene(_quad_scene(exact))
    assert cmp2.objects[0].material is exact and not any("bump" in n for n in notes2)


def test_cylinder_full_turn_frame_and_partial_unsupported():
    cyl = tx.Cylinder(0.8, (-0.5, 0.7), (90, 450), axis_z=(0, 1, 0), axis_x=(1, 0, 0))
    s = peers.shape_spec(cyl)
    m = s["to_world"]
    np.testing.assert_allclose(m[:3, 3], [0, -0.5, 0], atol=1e-12)          # z_min along the axis
    np.testing.assert_allclose(m[:3, 2], [0, 1.2, 0], atol=1e-12)           # length z_max - z_min
    # Mitsuba's phi = 0 lies at texray's theta_min = 90 degrees: axis_x rotated toward y = z x x = (0, 0, -1)
    np.testing.assert_allclose(m[:3, 0], [0, 0, -0.8], atol=1e-12)
    with pytest.raises(peers.Unsupported, match="theta_range"):
        peers.shape_spec(tx.Cylinder(0.8, (0, 1), (-60, 240), name="partial"))
    with pytest.raises(peers.Unsupported, match="mapping"):
        peers.shape_spec(tx.Sphere(mapping=tx.Projection("planar"), name="proj"))
    trap = tx.Quad((-1, -1, 0), (1, -1, 0), (0.5, 1, 0), (-1, 1, 0), name="trap")
    assert "trap" in peers.shape_spec(trap)["note"]


def test_bump_conversion():
    height = _texture(seed=2)
    # tx.Bump (duck-typed: texture, height, delta) -> Mitsuba bumpmap
    mat = SimpleNamespace(bump=SimpleNamespace(texture=height, height=0.02, delta=1e-3))
    b = peers.bump_spec(mat)
    assert b["scale"] == 0.02 and b["use_shadowing_function"] is False and b["flip_invalid_normals"] is False
    assert b["texture"]["bitmap"].shape == (*height.shape, 1)
    np.testing.assert_array_equal(b["texture"]["bitmap"][0, :, 0], height.rgba[-1, :, 0])   # rows flipped
    assert peers.bump_spec(tx.Material()) is None
    if _bump_class() is not None:
        srgb = tx.Texture.from_array(height.rgba[..., :1] * 0 + 0.5, colorspace="srgb")
        b = peers.bump_spec(tx.Material(bump=_bump_class()(srgb, height=0.03)))
        assert b["scale"] == 0.03
        np.testing.assert_allclose(b["texture"]["bitmap"], 0.5, rtol=1e-5)     # data role: stored values


def test_compare_images_values():
    a = np.full((4, 5, 3), 0.5, np.float32)
    b = a.copy()
    b[0, 0] = [0.6, 0.5, 0.5]          # one pixel off by 0.1 in one channel
    c = peers.compare_images(a, b)
    n = a.size
    assert c["rmse"] == pytest.approx(math.sqrt(0.01 / n), rel=1e-5)
    assert c["mean_abs"] == pytest.approx(0.1 / n, rel=1e-5)
    assert c["rel_mean_diff"] == pytest.approx(0.1 / n / 0.5, rel=1e-5)
    assert c["frac_pixels_over"] == pytest.approx(1 / 20)
    with pytest.raises(ValueError, match="shapes differ"):
        peers.compare_images(a, b[:2])


def test_missing_peers_are_named(monkeypatch):
    monkeypatch.setitem(sys.modules, "embreex", None)
    monkeypatch.setitem(sys.modules, "mitsuba", None)
    with pytest.raises(peers.PeerMissing, match="embreex"):
        peers.embree_rays(np.zeros((3, 3)), np.array([[0, 1, 2]]), np.zeros((1, 3)), np.ones((1, 3)))
    with pytest.raises(peers.PeerMissing, match="mitsuba"):
        peers.mitsuba_render(_quad_scene(tx.Material()), 8, 8, 1)
    av = peers.available()
    assert av["embree"]["ok"] is False and "embreex" in av["embree"]["error"]
    assert av["mitsuba"]["ok"] is False


# ----------------------------------------------------------------------------- with the peers

def test_embree_hits_the_same_triangles_as_texray():
    pytest.importorskip("embreex")
    from texray.renderer.trace import Tracer
    m = procedural.bench_mesh(20_000)
    scene = tx.Scene(camera=tx.Camera(eye=(0.0, 0.4, 3.2), look_at=(0, 0, 0), fov_y=40),
                     lights=[tx.PointLight((3.0, 4.0, 5.0), (40, 40, 40))])
    scene.add(tx.Mesh(m.positions, m.faces))
    org, dirs = peers.primary_rays(scene.camera, 96)
    tracer = Tracer(scene)
    hits = tracer.closest(org, dirs)
    face = peers.texray_face_ids(tracer.compiled, hits)
    so, sd = peers.shadow_rays(org, dirs, hits.t, face >= 0, scene.lights[0].position)
    occ, _ = tracer.occluded(so, sd, 0.0, 1.0)
    r = peers.embree_rays(m.positions, m.faces, org, dirs, so, sd, repeat=1, threads=2,
                          texray_hits=(hits.t, face), texray_occluded=occ)
    assert 0.3 < r["hit_fraction"] < 0.9
    assert r["agreement"]["hit_face_agree"] >= 0.999
    assert r["agreement"]["t_rel_diff_max"] < 1e-4
    assert r["agreement"]["shadow_agree"] >= 0.999
    assert r["primary_mrays_s"]["median"] > 0 and r["shadow_mrays_s"]["median"] > 0


@pytest.mark.parametrize("shape", ["quad", "sphere"])
def test_mitsuba_matches_texray_at_pixel_centres(shape):
    """Pins the conventions: pixel-centre samples in both, so only float precision (texray keeps
    texels as halves) separates the images: mean |difference| below 0.1 % of the mean, every
    pixel within 0.005."""
    pytest.importorskip("mitsuba")
    mat = tx.Material(diffuse=_texture(), tint=(0.9, 1.0, 0.8), specular=0.4)
    sc = _quad_scene(mat)
    if shape == "sphere":
        sc.objects = []
        sc.add(tx.Sphere((0, 0, 0), 1.0, material=mat, axis_z=(0, 1, 0), axis_x=(0, 0, 1), name="sphere"))
    cmp, _ = peers.comparable_scene(sc)
    ours = tx.render(cmp, 64, 48, 1, jitter=False).rgb
    theirs, stats = peers.mitsuba_render(sc, 64, 48, 1, sampler="centre")
    d = peers.compare_images(ours, theirs)
    assert d["rel_mean_abs"] < 1e-3, d
    assert np.abs(ours - theirs).max() < 5e-3
    assert stats["render_s"]["median"] > 0 and stats["notes"]


def test_mitsuba_bumpmap_matches_texray_analytic_bump():
    """Mitsuba's bumpmap (exact bilinear gradient, no shadowing term, no normal flipping) against
    texray's Bump(delta="analytic") at pixel centres: mean |difference| below 0.2 % of the mean.
    Without texray's Bump class yet, only checks that a duck-typed bump loads and changes the image."""
    pytest.importorskip("mitsuba")
    mat = tx.Material(diffuse=(0.7, 0.6, 0.5))
    sc = tx.Scene(camera=tx.Camera(eye=(0.3, 1.0, 2.5), look_at=(0, 0, 0), fov_y=45),
                  lights=[tx.PointLight((1, 2, 1), (8, 8, 8))])
    sc.add(tx.Quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0), material=mat, name="wall"))
    flat, _ = peers.mitsuba_render(sc, 64, 48, 1, sampler="centre")
    height = tx.Texture.from_array(procedural.bricks_height(128))
    bump = _bump_class()
    mat.bump = (bump(height, height=0.02, delta="analytic") if bump is not None
                else SimpleNamespace(texture=height, height=0.02, delta="analytic"))
    bumped, stats = peers.mitsuba_render(sc, 64, 48, 1, sampler="centre")
    assert np.all(np.isfinite(bumped)) and np.abs(bumped - flat).max() > 0.05
    assert any("bumpmap" in n for n in stats["notes"])
    if bump is not None:
        ours = tx.render(sc, 64, 48, 1, jitter=False).rgb
        assert np.abs(ours - flat).max() > 0.05                        # texray bumps too
        assert peers.compare_images(ours, bumped)["rel_mean_abs"] < 2e-3


def test_one_light_per_sample_is_mitsubas_estimator_and_the_bench_times_it(tmp_path):
    """Two lights and a shadowing sphere: texray's light_sampling="one" and Mitsuba's direct
    integrator (one emitter sample per camera sample) converge to the same image, and
    compare_peers.frames times texray both ways."""
    pytest.importorskip("mitsuba")
    from texray.bench import compare_peers
    lights = [tx.PointLight((1.5, 2.0, 2.0), (8.0, 8.0, 8.0)), tx.PointLight((-2.0, 1.0, 1.5), (3.0, 4.0, 6.0))]
    sc = _quad_scene(tx.Material(diffuse=(0.7, 0.6, 0.5)), lights=lights)
    sc.add(tx.Sphere((0, 0, 0.4), 0.35, material=tx.Material(diffuse=(0.4, 0.6, 0.8)), name="ball"))
    cmp, _ = peers.comparable_scene(sc)
    theirs, _ = peers.mitsuba_render(sc, 48, 36, 256)
    ours = tx.render(cmp, 48, 36, 256, light_sampling="one").rgb
    d = peers.compare_images(ours, theirs)
    assert abs(d["rel_mean_diff"]) < 3e-3 and d["rel_mean_abs"] < 0.01, d
    path = tmp_path / "two_lights.toml"
    path.write_text('[render]\nwidth = 32\nheight = 24\nspp = 4\n'
                    '[camera]\neye = [0.3, 0.5, 3.0]\nlook_at = [0, 0, 0]\n'
                    '[[lights]]\nposition = [1.5, 2.0, 2.0]\n[[lights]]\nposition = [-2.0, 1.0, 1.5]\n'
                    '[[objects]]\ntype = "sphere"\nradius = 0.5\n')
    f = compare_peers.frames(path, None, repeat=1, tte=False)
    one = f["texray_one_light"]
    assert one["render_s"]["median"] > 0 and one["diff"]["rmse"] < 0.2


def test_time_to_error_times_each_setting_by_its_median(monkeypatch):
    """time_to_error's settings are timed as the median of `repeat` renders after a warm-up (one
    render of a 20 ms frame caught a 45% hiccup and picked a slower setting), and the fastest
    setting whose RMSE reaches Mitsuba's wins. Renders faked: noise falls as 1 / spp, times
    are spp ms with one slow outlier per setting."""
    from texray.bench import compare_peers as cp
    ref = np.full((2, 2, 3), 0.5)
    calls = []

    def fake_render(scene, w, h, spp=1, device=None, seed=0, adaptive=None, light_sampling=None):
        calls.append((spp, seed, adaptive))
        k = sum(1 for c in calls if c == (spp, seed, adaptive))
        t = spp * 1e-3 * (3.0 if k == 1 else 1.0)           # the first timed run of each setting: slow
        return SimpleNamespace(rgb=ref + (0.0 if spp >= 256 else 0.1 / spp),
                               stats={"render_s": t, "samples": spp * w * h})

    monkeypatch.setattr(cp.tx, "render", fake_render)
    monkeypatch.setattr(cp.peers, "mitsuba_render", lambda *a, **k: (ref, {}))     # its converged image
    scene = SimpleNamespace(lights=[None])
    out = cp.time_to_error(scene, 2, 2, 4, "cpu", ref + 0.1 / 3.5, 0.004, repeat=3)
    fixed = [t for t in out["tried"] if "adaptive" not in t]
    for t in fixed:                                          # median of (3x, 1x, 1x) = 1x
        assert t["render_s"] == pytest.approx(t["spp"] * 1e-3)
    assert out["target_rmse"] == pytest.approx(0.1 / 3.5)
    assert out["texray"]["spp"] == 4                         # rmse 0.025 <= 0.0286; 3 spp's 0.033 is not
    timed = [c for c in calls if c[1] == 1]
    assert len(timed) == 3 * len(out["tried"])


def test_frames_alternate_texray_and_mitsuba_round_by_round(monkeypatch, tmp_path):
    """compare_peers.frames times the renderers in alternating rounds (texray, Mitsuba, texray
    with one light per sample; each an untimed frame, then the timed one), after a warm-up of
    each, and its ratios are Mitsuba's time over
    texray's, per round and of the medians: a machine whose load doubles halfway through the
    run (every frame of the later rounds twice as slow) leaves every round's ratio alone, where
    blocks timed one after the other (texray's frames, then Mitsuba's) would halve it. Renderers
    faked; the time-to-error setting found is timed in rounds against Mitsuba's frames too."""
    from texray.bench import compare_peers as cp
    log = []
    load = lambda: 2.0 if len(log) > 20 else 1.0                # the load doubles after round 3

    def fake_render(scene, w, h, spp=1, device=None, seed=0, adaptive=None, light_sampling=None):
        log.append("one" if light_sampling == "one" else "texray")
        t = (0.010 if light_sampling == "one" else 0.020) * spp / 16 * load()
        return SimpleNamespace(rgb=np.full((h, w, 3), 0.5) + (0.0 if spp >= 256 else 0.1 / spp),
                               stats={"render_s": t, "total_s": t + 1e-3, "samples": spp * w * h})

    class FakeMitsuba:
        def __init__(self, scene, w, h, spp, seed=0, **kw):
            self.rgb = np.full((h, w, 3), 0.5)
            self.load_s, self.first_render_s, self.notes = 0.1, 0.2, []

        def frame(self):
            log.append("mitsuba")
            return 0.030 * load()

        def stats(self, times):
            return {"render_s": cp.median_spread(times), "load_s": self.load_s,
                    "first_render_s": self.first_render_s, "notes": []}

    monkeypatch.setattr(cp.tx, "render", fake_render)
    monkeypatch.setattr(cp.peers, "MitsubaFrames", FakeMitsuba)
    monkeypatch.setattr(cp.peers, "mitsuba_render", lambda *a, **k: (np.full((4, 4, 3), 0.5), {}))
    path = tmp_path / "two.toml"
    path.write_text('[render]\nwidth = 4\nheight = 4\nspp = 16\n[camera]\neye = [0, 0, 3]\nlook_at = [0, 0, 0]\n'
                    '[[lights]]\nposition = [1, 2, 2]\n[[lights]]\nposition = [-2, 1, 1]\n'
                    '[[objects]]\ntype = "sphere"\nradius = 0.5\n')
    f = cp.frames(path, None, repeat=6, tte=False)
    assert log[:2] == ["texray", "one"]                            # the warm-ups (Mitsuba's in its constructor)
    assert log[2:] == ["texray", "texray", "mitsuba", "mitsuba", "one", "one"] * 6   # then the rounds
    assert f["round_ratios"]["min"] == f["round_ratios"]["max"] == pytest.approx(1.5)
    assert f["texray_one_light"]["round_ratios"]["median"] == pytest.approx(3.0)
    assert f["mitsuba"]["render_s"]["median"] / f["texray"]["render_s"]["median"] == pytest.approx(1.5)
    assert f["texray"]["prep_s"]["n"] == 6                          # host time of the default frames only

    log.clear()
    out = cp.time_to_error(cp.peers.comparable_scene(tx.Scene.load(path))[0], 4, 4, 16, None,
                           np.full((4, 4, 3), 0.5) + 0.1 / 16, 0.030, repeat=3, mitsuba=FakeMitsuba(None, 4, 4, 16))
    best = out["texray"]
    assert best["spp"] == 16 and best.get("light_sampling") == "one"   # the fastest setting at the error
    # the settings within TTE_RETIME of the fastest (one light at 16 and 24 spp) timed again, in
    # rounds with Mitsuba's
    assert [(c["spp"], c.get("light_sampling")) for c in out["retimed"]] == [(16, "one"), (24, "one")]
    assert log[-18:] == ["one", "one", "one", "one", "mitsuba", "mitsuba"] * 3
    assert best["render_s"] == pytest.approx(0.020) and out["mitsuba_s"] == pytest.approx(0.060)
    assert out["round_ratios"]["median"] == pytest.approx(3.0)
    assert best["scan_render_s"] == pytest.approx(0.020)           # its time in the search

    # a setting slower in the search than in the rounds (the load moved) is chosen by the rounds
    rounds = []
    slow_in_search = lambda spp, one: one and spp == 16 and not rounds

    def fake_render2(scene, w, h, spp=1, device=None, seed=0, adaptive=None, light_sampling=None):
        t = (0.010 if light_sampling == "one" else 0.020) * spp / 16 * (1.6 if slow_in_search(spp, light_sampling) else 1)
        return SimpleNamespace(rgb=np.full((h, w, 3), 0.5) + (0.0 if spp >= 256 else 0.1 / spp),
                               stats={"render_s": t, "total_s": t + 1e-3, "samples": spp * w * h})

    class FakeMitsuba2(FakeMitsuba):
        def frame(self):
            rounds.append(1)
            return 0.030

    monkeypatch.setattr(cp.tx, "render", fake_render2)
    out = cp.time_to_error(cp.peers.comparable_scene(tx.Scene.load(path))[0], 4, 4, 16, None,
                           np.full((4, 4, 3), 0.5) + 0.1 / 16, 0.030, repeat=3, mitsuba=FakeMitsuba2(None, 4, 4, 16))
    # the search: 24 spp one light 0.015, 16 spp one light 0.016 (slow), 16 spp every light 0.020
    # (within 1.5x); in the rounds 16 spp one light takes 0.010 and is chosen over the search's pick
    assert [(c["spp"], c.get("light_sampling")) for c in out["retimed"]] == [(24, "one"), (16, "one"), (16, None)]
    assert (out["texray"]["spp"], out["texray"].get("light_sampling")) == (16, "one")
    assert out["texray"]["render_s"] == pytest.approx(0.010) and out["texray"]["scan_render_s"] == pytest.approx(0.016)
    assert [c["rounds_render_s"] for c in out["retimed"]] == pytest.approx([0.015, 0.010, 0.020])
