"""Specialized programs (only the features a scene uses) against the one generic
program (every feature compiled in), the feature sets the host derives, and
the program variants a session over all of scenes/ builds.

The generic program must render every scene the same as its specialized one:
the specializations only remove code that the scene's data never reaches, so
the images agree to float rounding (1e-5 absolute on values ~1 allows for a
compiler contracting differently once dead branches are gone)."""
import dataclasses

import numpy as np
import pytest

import texray as tx
from texray.compile import compile_scene
from texray.device.features import Features, compile_options, max_lights_for, stack_size_for
from texray.device.features import generic_features
from texray.renderer import render

SUITE_SMALL = ["globe", "grazing_quad", "mixed"]


@pytest.mark.parametrize("name", SUITE_SMALL)
def test_generic_program_renders_the_same_image(device, scenes_dir, name):
    scene = tx.Scene.load(scenes_dir / "bench" / f"{name}.toml")
    cs = compile_scene(scene)
    a = render(scene, 48, 32, 2, device=device, compiled=cs)
    b = render(scene, 48, 32, 2, device=device, compiled=cs, specialize=False)
    assert a.stats["features"] != b.stats["features"]
    assert b.stats["features"] == generic_features(cs.features)
    assert np.all(np.isfinite(a.rgb)) and a.rgb.max() > 0.05
    np.testing.assert_allclose(b.rgb, a.rgb, atol=1e-5, rtol=0)


def test_generic_features_cover_every_scene(scenes_dir):
    """The generic set has every capability; each scene's specialized set has exactly the
    primitive kinds and mappings that scene uses."""
    for path in sorted(scenes_dir.rglob("*.toml")):
        if path.stem == "mesh1m":
            continue              # 1M triangles: covered by the bench, too slow to compile here
        scene = tx.Scene.load(path)
        f = compile_scene(scene).features
        assert generic_features(f).covers(f), path
        # Displaced shapes searched on the device are their own primitive kind (PRIM_DISPLACED).
        on_device = [getattr(o.material, "displacement", None) is not None
                     and o.material.displacement.method != "tessellate" for o in scene.objects]
        kinds = {type(o).__name__ for o, d in zip(scene.objects, on_device) if not d}
        assert f.displacement == any(on_device), path
        assert f.spheres == ("Sphere" in kinds) and f.cylinders == ("Cylinder" in kinds), path
        assert f.quads == ("Quad" in kinds), path
        assert f.projections == any(o.mapping is not None for o in scene.objects), path
        assert f.max_lights == max_lights_for(len(scene.lights)), path


def test_generic_set_turns_on_every_flag():
    g = Features.generic()
    for fld in dataclasses.fields(Features):
        if fld.name in ("aovs", "adaptive", "one_light"):          # render settings, not capabilities
            assert getattr(g, fld.name) is False
        elif isinstance(getattr(g, fld.name), bool):
            assert getattr(g, fld.name) is True, fld.name
    assert g.max_lights == 0 and g.stack_size >= 128
    # every flag reaches the compiler
    opts = compile_options(g)
    assert all(v == 1 for k, v in opts.items()
               if k not in ("TX_STACK_SIZE", "TX_MAX_LIGHTS", "TX_AOVS", "TX_ADAPTIVE", "TX_ONE_LIGHT", "TX_PACKET",
                            "TX_MULTI_PIXEL", "TX_AVX512", "TX_LIGHT_BLOCKS"))
    # packets (and pixels per work-item and light blocks with them) and AVX-512 are the device's
    # choice (features.packet_width, pixels_per_item, light_blocks, avx512), not a capability:
    # none without one
    assert opts["TX_PACKET"] == 0 and opts["TX_MULTI_PIXEL"] == 0 and opts["TX_AVX512"] == 0
    assert opts["TX_LIGHT_BLOCKS"] == 0


def test_feature_bounds():
    assert [max_lights_for(n) for n in (0, 1, 2, 3, 4, 5, 8, 9, 100)] == [1, 1, 2, 4, 4, 8, 8, 0, 0]
    assert [stack_size_for(d) for d in (1, 31, 32, 63, 64, 100)] == [32, 32, 64, 64, 128, 128]
    small, big = Features(max_lights=2), Features(max_lights=4)
    assert big.covers(small) and not small.covers(big) and Features(max_lights=0).covers(big)
    assert not Features(max_lights=8).covers(Features(max_lights=0))


@pytest.mark.parametrize("n_lights", [1, 3, 9])
def test_light_bound_renders_like_a_runtime_loop(device, n_lights):
    """TX_MAX_LIGHTS (unrolled bound) and the runtime loop (bound 0) give the same image,
    for counts below, between and above the bounds."""
    rng = np.random.default_rng(n_lights)
    scene = tx.Scene(camera=tx.Camera(eye=(0, 1.5, 3), look_at=(0, 0, 0)))
    scene.add(tx.Sphere(center=(0, 0.5, 0), radius=0.5))
    scene.add(tx.Quad((-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)))
    for _ in range(n_lights):
        scene.lights.append(tx.PointLight(tuple(rng.uniform((-3, 1, -3), (3, 4, 3))), (4.0, 4.0, 4.0)))
    cs = compile_scene(scene)
    assert cs.features.max_lights == max_lights_for(n_lights)
    a = render(scene, 32, 24, 1, device=device, compiled=cs)
    cs0 = dataclasses.replace(cs, features=dataclasses.replace(cs.features, max_lights=0))
    b = render(scene, 32, 24, 1, device=device, compiled=cs0)
    np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-6, rtol=0)


def test_scenes_need_few_program_variants(scenes_dir):
    """Rendering every scene file compiles few distinct programs (issue 4's budget): at
    most one per scene, and fewer than there are scenes."""
    from texray.bench.suite import program_variants
    paths = [p for p in sorted(scenes_dir.rglob("*.toml")) if p.stem != "mesh1m"]
    variants = program_variants(paths)
    assert sum(len(v["scenes"]) for v in variants) == len(paths)
    assert len(variants) < len(paths)
