"""Device units (texray.compile.units): a scene whose coordinates are far from 1 is rescaled by
a power of two before the device sees it, so that every kind renders at any scale the scene
validation accepts (coordinates up to 1e18) the image it renders at unit scale. Before
2026-12-08 quads lost their shadows from a scale of 1e7 on and vanished from 1e11, triangles
vanished from 1e13, meshes lost their shadows below 1e-5 and quads went dark below 1e-9."""
import copy

import numpy as np
import pytest
import trimesh

import texray as tx
from cache_scenes import rich_scene, texture
from texray.compile import compile_scene, units
from texray.errors import SceneError
from texray.renderer.trace import Tracer

W, H = 64, 48


def scaled(scene, k):
    """``scene`` with every length times ``k`` (a deep copy): the objects through their
    transforms (an instance's, which maps its mesh's space), the lengths materials give in
    world units (bump and displacement heights), the lights (intensity times k^2, so that I /
    d^2 stays the same) and the camera."""
    s = copy.deepcopy(scene)
    for o in s.objects:
        t = o.transform
        o.transform = tx.Transform(scale=k) if t is None else tx.Transform(
            translate=tuple(k * np.asarray(t.translate, float)), rotate=t.rotate, scale=k * np.asarray(t.scale, float))
        for m in getattr(o, "materials", None) or [o.material]:
            if m.bump is not None:
                m.bump.height *= k
            if m.displacement is not None:
                m.displacement.scale *= k
                m.displacement.offset *= k
    for light in s.lights:
        light.position = tuple(k * np.asarray(light.position, float))
        light.intensity = tuple(k * k * np.asarray(light.intensity, float))
    s.camera.eye = tuple(k * np.asarray(s.camera.eye, float))
    s.camera.look_at = tuple(k * np.asarray(s.camera.look_at, float))
    return s


def every_feature():
    """The scene cache's rich scene (textured and multi-material meshes, a projection mapping
    under a transform, a labelled MIP-mapped sphere, a bumped quad, a normal-mapped cylinder,
    a displaced quad) with two instances of a mesh, a maxmip-displaced sphere, a searched
    cylinder and trapezoid, and a mesh displaced per pixel (prism shells): every kind of
    device record."""
    s = rich_scene()
    bumps = texture(12, channels=1)
    s.add(tx.Cylinder(0.25, (0.0, 0.6), origin=(2.6, 0, 0.9), axis_z=(0, 1, 0), name="column",
                      material=tx.Material(displacement=tx.Displacement(bumps, scale=0.05, steps=16))))
    s.add(tx.Quad((-2.9, 0.02, 1.2), (-1.6, 0.02, 1.3), (-1.8, 0.02, 2.2), (-2.7, 0.02, 2.0), name="trapezoid",
                  material=tx.Material(displacement=tx.Displacement(bumps, scale=0.1, method="maxmip"))))
    octa = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    faces = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    s.add(tx.Mesh(octa, faces, uvs=0.5 + 0.45 * octa[:, :2] + 0.05 * octa[:, 2:], name="gem",
                  transform=tx.Transform(translate=(1.9, 0.35, 1.7), scale=0.3),
                  material=tx.Material(displacement=tx.Displacement(bumps, scale=0.06, method="search", steps=16))))
    ico = trimesh.creation.icosphere(subdivisions=1)
    mesh = tx.Mesh(np.asarray(ico.vertices) * 0.25, np.asarray(ico.faces), material=tx.Material(diffuse=(0.3, 0.7, 0.4)),
                   name="pebble")
    s.add(tx.Instance(mesh, tx.Transform(translate=(-0.3, 0.25, 1.6), rotate=(0, 20, 0)), name="pebble1"))
    s.add(tx.Instance(mesh, tx.Transform(translate=(0.5, 0.25, 1.8), scale=1.3), name="pebble2"))
    s.add(tx.Sphere((-2.2, 0.5, 0.8), 0.45, name="rough", material=tx.Material(
        displacement=tx.Displacement(texture(11, channels=1), scale=0.08, method="maxmip"))))
    return s


def test_the_scale_rule():
    """1 within SAFE (and for an empty or non-finite extent), else the power of two that
    brings the extent into [1, 2)."""
    lo, hi = units.SAFE
    for e in (lo, hi, 1.0, 3.7, 1e5, 0.0, float("nan"), float("inf")):
        assert units.choose_scale(e) == 1.0, e
    for e in (hi * 1.0001, 1e7, 3e14, 1e18, lo * 0.999, 1e-6, 1e-30):
        s = units.choose_scale(e)
        assert 1.0 <= e * s < 2.0 and s == 2.0 ** round(np.log2(s)), (e, s)


def test_power_of_two_scales_give_the_unit_scale_bits(device):
    """Scaled by 2^-40 or 2^36 the scene with every feature compiles to the same device arrays
    (bit for bit: the same device units) and renders the image of the scene at unit scale
    (PoCL: the same bits; a device may round the rescaled floats' products apart only where
    they meet a fixed threshold, none here: within 1e-5), its AOVs in world units."""
    base = every_feature()
    kw = dict(seed=1, device=device, aovs=("position", "depth", "dpdu"))
    ref = tx.render(base, W, H, 2, **kw)
    got = {}
    for k in (2.0 ** -40, 2.0 ** 36):
        cs = compile_scene(scaled(base, k))
        assert cs.scale * k == 2.0 ** -np.floor(np.log2(units.extent(compile_scene(base).bvh.nodes)))
        got[k] = (cs, tx.render(scaled(base, k), W, H, 2, **kw))
    (ca, a), (cb, b) = got.values()
    for name in ("tri_verts", "spheres", "cylinders", "quad_verts", "nodes", "displaced", "instances", "lights",
                 "materials", "objects"):
        x, y = getattr(ca, name), getattr(cb, name)
        assert x.tobytes() == y.tobytes(), name
    assert np.array_equal(a.rgb, b.rgb)
    assert np.isfinite(a.rgb).all()
    np.testing.assert_allclose(a.rgb, ref.rgb, rtol=0, atol=1e-5)
    for k, (_, im) in got.items():
        for name in ("position", "depth", "dpdu"):
            np.testing.assert_allclose(im.aov[name] / k, ref.aov[name], rtol=1e-5, atol=0, equal_nan=True,
                                       err_msg=f"{name} at scale {k}")


@pytest.mark.parametrize("k", [1e-9, 3e14])
def test_other_scales_give_the_unit_scale_image(device, k):
    """At scales that are not powers of two the float64 scene rounds to other floats: the
    image within 1e-3 of the unit scale's (PoCL: 4e-5 at 1e-9, 1.6e-4 at 3e14)."""
    base = every_feature()
    ref = tx.render(base, W, H, 2, seed=1, device=device)
    im = tx.render(scaled(base, k), W, H, 2, seed=1, device=device)
    assert im.stats["scene_scale"] != 1.0
    np.testing.assert_allclose(im.rgb, ref.rgb, rtol=0, atol=1e-3)


def _ball_on_floor(kind, s, offset=0.0):
    """A ball (sphere, mesh, quad or cylinder) of size s on a floor of its own kind, at
    ``offset`` from the origin, the camera and the light moved and scaled with them."""
    c = np.array([offset, offset * 0.5, -offset * 0.25])
    sc = tx.Scene(camera=tx.Camera(eye=tuple(c + np.array([0, 1.5, 4.0]) * s), look_at=tuple(c), fov_y=45),
                  lights=[tx.PointLight(tuple(c + np.array([2, 4, 3]) * s), (40 * s ** 2,) * 3)], ambient=(0.05,) * 3)
    q = [c + np.array(p) * s for p in ([-3, -1, -3], [3, -1, -3], [3, -1, 3], [-3, -1, 3])]
    if kind == "sphere":
        sc.add(tx.Sphere(center=tuple(c + np.array([0, -101, 0]) * s), radius=100 * s, name="floor"))
        sc.add(tx.Sphere(center=tuple(c), radius=s, name="ball"))
    elif kind == "mesh":
        sc.add(tx.Mesh(np.array(q), np.array([[0, 2, 1], [0, 3, 2]]), name="floor"))
        ico = trimesh.creation.icosphere(subdivisions=2)
        sc.add(tx.Mesh(np.asarray(ico.vertices), np.asarray(ico.faces), name="ball",
                       transform=tx.Transform(translate=tuple(c), scale=s)))
    elif kind == "quad":
        sc.add(tx.Quad(*[tuple(x) for x in q], name="floor"))
        p = [c + np.array(v) * s for v in ([-1, -0.5, 0.5], [1, -0.5, 0.3], [1, 0.8, -0.5], [-1, 0.9, -0.2])]
        sc.add(tx.Quad(*[tuple(x) for x in p], name="ball"))
    else:
        sc.add(tx.Quad(*[tuple(x) for x in q], name="floor"))
        sc.add(tx.Cylinder(radius=0.7 * s, z_range=(-0.8 * s, 0.8 * s), origin=tuple(c), axis_z=(0, 1, 0), name="ball"))
    return sc


@pytest.mark.parametrize("kind", ["sphere", "mesh", "quad", "cylinder"])
def test_every_kind_at_every_scale(device, kind):
    """A ball on a floor with its shadow, from 1e-30 to 1e17 and at 5e17 from the origin (at
    1e-30 the light's intensity, 4e-59, is 0 in float32 unless rescaled first):
    no pixel more than 0.05 from the unit scale's image, none NaN; at 5e17, where float32's
    positions are 3e10 (3e-5 of the ball) apart, at most three silhouette pixels (measured: 1)."""
    ref = tx.render(_ball_on_floor(kind, 1.0), W, H, 1, device=device, jitter=False).rgb
    for s, offset in [(1e-30, 0.0), (1e-12, 0.0), (1e-6, 0.0), (1e7, 0.0), (1e11, 0.0), (1e15, 0.0), (1e17, 0.0),
                      (1e15, 5e17)]:
        if kind == "sphere" and s > 1e15:
            continue                                       # the floor sphere's radius would pass 1e18
        img = tx.render(_ball_on_floor(kind, s, offset), W, H, 1, device=device, jitter=False).rgb
        off = np.abs(img - ref).max(axis=-1) > 0.05
        assert np.isfinite(img).all() and off.sum() <= (3 if offset else 0), \
            f"scale {s:g} at {offset:g}: {off.sum()} pixels off"


def test_instanced_meshes_in_far_coordinates_of_their_own(device):
    """A mesh given at 1e15 (or 1e-12) and instanced at unit size: each BLAS is in units of its
    own, so the image is the unit mesh's."""
    ico = trimesh.creation.icosphere(subdivisions=2)

    def scene(vs):
        s = tx.Scene(camera=tx.Camera(eye=(0, 1.5, 4.0), look_at=(0, 0, 0), fov_y=45),
                     lights=[tx.PointLight((2, 4, 3), (40,) * 3)], ambient=(0.05,) * 3)
        s.add(tx.Mesh(np.array([(-3, -1, -3), (3, -1, -3), (3, -1, 3), (-3, -1, 3)], float),
                      np.array([[0, 2, 1], [0, 3, 2]]), name="floor"))
        s.add(tx.Instance(tx.Mesh(np.asarray(ico.vertices) * vs, np.asarray(ico.faces), name="ball"),
                          tx.Transform(scale=1.0 / vs), name="inst"))
        return s

    ref = tx.render(scene(1.0), W, H, 1, device=device, jitter=False).rgb
    for vs in (1e15, 1e-12):
        img = tx.render(scene(vs), W, H, 1, device=device, jitter=False).rgb
        np.testing.assert_allclose(img, ref, rtol=0, atol=1e-4, err_msg=f"mesh at {vs:g}")


def test_traced_rays_are_in_world_units(device):
    """The Tracer takes world rays: on the scene scaled by 2^40 (in device units of 2^-41 per world unit)
    rays scaled with it hit the same primitives at the same t as on the unit scene."""
    base = _ball_on_floor("mesh", 1.0)
    rng = np.random.default_rng(4)
    org = np.tile([0.0, 1.5, 4.0], (500, 1))
    d = rng.uniform(-1, 1, (500, 3)) * [1.5, 1.0, 1.5] - [0, 1.5, 4.0]
    a = Tracer(base, device).closest(org.astype(np.float32), d.astype(np.float32), 0.0, np.float32(10.0))
    k = 2.0 ** 40
    tr = Tracer(_ball_on_floor("mesh", k), device)
    assert tr.compiled.scale == 2.0 ** -41             # the floor reaches 3 k
    b = tr.closest((org * k).astype(np.float32), (d * k).astype(np.float32), 0.0, np.float32(10.0))
    assert (a.prim >= 0).sum() > 300
    np.testing.assert_array_equal(a.prim, b.prim)
    np.testing.assert_array_equal(a.t, b.t)


def test_a_light_too_bright_for_the_rescaled_scene_is_an_error():
    """A ball of 1e-12 on a floor sphere of 1e-10 is rescaled by 2^33: a light of intensity 1e30
    would be 7e49, beyond float32 (its radiance there, I / d^2 ~ 1e50, is beyond it as well):
    an error naming the light, the largest intensity this scene takes and the value."""
    scene = _ball_on_floor("sphere", 1e-12)
    scene.lights[0].intensity = (1e30, 1.0, 1.0)
    with pytest.raises(SceneError, match=r"lights\[0\]\.intensity: expected magnitudes up to 4\.61e\+18 in a scene "
                                         r"whose geometry reaches 1\.16e-10 to 2\.33e-10 .*got \[1e\+30, 1\.0, 1\.0\]"):
        compile_scene(scene)


@pytest.mark.parametrize("seed", range(8))
def test_random_valid_scenes_at_far_scales(device, seed):
    """The fuzz suite's random valid scenes (tests/fuzz_cases.py gen_random_scene: every kind,
    material role, mapping and placement it draws) scaled by 2^30 and 2^-30 compile to the same
    device units and so render the same bits; the unit scale's image within 1e-4 (measured on
    PoCL: the same bits on every scene tried). A scene whose scaling takes a value past what the
    validation accepts (the generator's displacement scale of 1e18, a transform at 1e18) is
    skipped."""
    import tempfile
    import fuzz_cases as fc
    case = fc.gen_random_scene(fc.RandomChooser(f"scene-units-{seed}"))
    ns = fc.namespace()
    fc._TMP[0] = tempfile.mkdtemp(prefix="texray-units-")     # the case's asset copies
    exec(compile(case.code.split("RESULT =")[0], "case", "exec"), ns)
    scene = ns["scene0"]
    try:
        big, small = scaled(scene, 2.0 ** 30), scaled(scene, 2.0 ** -30)
        ims = [tx.render(s, 32, 24, 1, seed=1, device=device) for s in (scene, big, small)]
    except SceneError as e:
        pytest.skip(f"scaled past the validation's range: {e}")
    assert ims[1].stats["scene_scale"] * 2.0 ** 30 == ims[2].stats["scene_scale"] * 2.0 ** -30
    assert np.isfinite(ims[1].rgb).all()
    np.testing.assert_array_equal(ims[1].rgb, ims[2].rgb)
    np.testing.assert_allclose(ims[1].rgb, ims[0].rgb, rtol=0, atol=1e-4)
