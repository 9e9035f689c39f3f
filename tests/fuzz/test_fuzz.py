"""Fuzz tests of texray's contract (issue 12): on any input a texray call either succeeds
with finite pixels (AOVs finite where hit, NaN / -1 where missed) or raises a texray
SceneError / DeviceError / BuildError; scene-file errors name the file.

The cases come from tests/fuzz_cases.py (the generators tools/fuzz.py runs in long
campaigns), drawn here through hypothesis so that a failure is shrunk to a small input;
the failure message holds the case as a runnable program. Every example runs in one
persistent worker process (fuzz_cases.Worker) with a time limit: a crash (the camera
segfaults of issue 12) or a hang must fail the test, not kill or stall pytest. The
worker is restarted after either.

Reproducible: seeded by the test's name (the same examples in any clone), no example
database. Environment:

* TEXRAY_FUZZ_SCALE multiplies every max_examples (default 1: about 2 minutes on two CPU
  cores when nothing fails).
* TEXRAY_FUZZ_SHRINK_S bounds each failing test's shrinking (default 30 s; hypothesis's own
  bound is 300 s).
* TEXRAY_FUZZ_REPORT_ONLY=1 prints the findings instead of failing, so every example runs
  (for timing the file, or listing what a tree still gets wrong).
"""
import os
import zlib

import pytest
from hypothesis import HealthCheck, given, seed, settings, strategies as st

import fuzz_cases as fc

SCALE = float(os.environ.get("TEXRAY_FUZZ_SCALE", "1"))
TIMEOUT = float(os.environ.get("TEXRAY_FUZZ_TIMEOUT", "60"))
REPORT_ONLY = os.environ.get("TEXRAY_FUZZ_REPORT_ONLY", "") not in ("", "0")

try:        # hypothesis's shrink budget (an internal constant: left alone if it moves)
    from hypothesis.internal.conjecture import engine as _engine
    if hasattr(_engine, "MAX_SHRINKING_SECONDS"):
        _engine.MAX_SHRINKING_SECONDS = float(os.environ.get("TEXRAY_FUZZ_SHRINK_S", "30"))
except ImportError:
    pass


def _settings(n):
    """max_examples n (times TEXRAY_FUZZ_SCALE), no deadline, no example database, and a seed from
    the test's name alone: derandomize=True would hash the test's file path too, so a clone in
    another folder (CI's) would draw other examples than the ones run here."""
    def apply(test):
        s = settings(max_examples=max(1, int(n * SCALE)), deadline=None, database=None, print_blob=False,
                     suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                            HealthCheck.filter_too_much, HealthCheck.large_base_example])
        return seed(zlib.crc32(test.__name__.encode()))(s(test))
    return apply


_WARMUP = ("scene = tx.Scene(objects=[tx.Sphere()], lights=[tx.PointLight((1, 2, 3))])\n"
           "RESULT = tx.render(scene, 8, 8, 1, specialize=False)\n")


@pytest.fixture(scope="module")
def worker():
    with fc.Worker() as w:
        w.run(fc.Case("warmup", _WARMUP), timeout=300)     # the generic program's build (cached by PoCL)
        yield w


_FAILURES = {}


def _failure(kind):
    """An AssertionError subclass per finding kind, so that hypothesis reports (and shrinks)
    distinct kinds of finding separately."""
    if kind not in _FAILURES:
        _FAILURES[kind] = type(f"Fuzz_{kind}", (AssertionError,), {})
    return _FAILURES[kind]


def check(worker, case):
    out = worker.run(case, TIMEOUT)
    if fc.is_finding(out):
        msg = (f"{out['kind']}: {out.get('exc_type', '')} {out['detail']}\n  at {out.get('where', '')}\n"
               f"--- case (run with tests/ on sys.path, `from fuzz_cases import *`) ---\n{case.source()}")
        if out.get("log"):
            msg += "\n--- worker log ---\n" + out["log"][-1500:]
        if REPORT_ONLY:
            print(f"\nFINDING {msg}\n")
            return out
        raise _failure(out["kind"])(msg)
    return out


@_settings(700)
@given(st.data())
def test_scene_files(worker, data):
    """Mutated shipped scene files through Scene.load + render and the CLI."""
    check(worker, fc.gen_scene_file(fc.HypothesisChooser(data)))


@_settings(150)
@given(st.data())
def test_gltf_files(worker, data):
    """Mutated glTF files (JSON fields, accessors, buffers, images, nodes, materials,
    cameras, lights) through Scene.load / Mesh.load + render."""
    check(worker, fc.gen_gltf_file(fc.HypothesisChooser(data)))


@_settings(1000)
@given(st.data())
def test_geometry_camera_lights(worker, data):
    """Meshes, spheres, cylinders, quads, transforms, cameras, lights and Scene() arguments."""
    check(worker, fc.gen_geometry(fc.HypothesisChooser(data)))


@_settings(1000)
@given(st.data())
def test_textures_and_roles(worker, data):
    """Texture.from_array / procedural / load and the material roles."""
    check(worker, fc.gen_texture(fc.HypothesisChooser(data)))


@_settings(500)
@given(st.data())
def test_render_arguments(worker, data):
    """render()'s own arguments, devices, PYOPENCL_CTX."""
    check(worker, fc.gen_render_args(fc.HypothesisChooser(data)))


@_settings(200)
@given(st.data())
def test_random_valid_scenes_render_finite(worker, data):
    """Valid scenes with every feature at extreme placements render with finite pixels."""
    check(worker, fc.gen_random_scene(fc.HypothesisChooser(data)))


@_settings(300)
@given(st.data())
def test_extreme_valid_values_render_finite(worker, data):
    """Valid values at float32's edge (huge colours and lights, lights on surfaces, degenerate uvs and
    normals, extreme uv transforms, bumps, displacements, cameras): finite pixels or a texray error."""
    check(worker, fc.gen_extreme_scene(fc.HypothesisChooser(data)))


@_settings(700)
@given(st.data())
def test_objects_changed_after_construction(worker, data):
    """Objects, materials, cameras, lights and scenes edited after construction: render checks them again."""
    check(worker, fc.gen_post_edit(fc.HypothesisChooser(data)))


@pytest.mark.parametrize("seed", [0, 12345, 2**32 - 1])
def test_seeds_2_32_apart_give_different_images(worker, seed):
    """render(seed=s) and render(seed=s + 2**32) must differ (as s and s + 1 do)."""
    code = (fc._BASE_SCENE + "\n"
            f"RESULT = [tx.render(scene, 16, 16, 1, seed={seed}, specialize=False),\n"
            f"          tx.render(scene, 16, 16, 1, seed={seed} + 2**32, specialize=False),\n"
            f"          tx.render(scene, 16, 16, 1, seed={seed} + 1, specialize=False)]\n")
    out = check(worker, fc.Case("render_args", code, differ=True))
    assert out["kind"] in ("ok", "scene_error"), out


def test_case_generation_is_deterministic():
    """Case k of campaign S is the same input every time (tools/fuzz.py --seed S --case k replays it)."""
    for k in range(40):
        assert fc.campaign_case(7, k).code == fc.campaign_case(7, k).code


def test_toml_writer_round_trips():
    import math
    import tomllib
    doc = {"a": 1, "b": [1.5, float("nan"), float("inf"), -float("inf"), 1e-45, 2**63], "s": "x\"\\\x00\u00e9",
           "t": {"k": {"i": [1, [2, 3], {"z": True}]}, "e": {}}, "objects": [{"p": [1, 2]}, {"q": "r"}],
           "weird key": []}
    back = tomllib.loads(fc.toml_dumps(doc))
    assert math.isnan(back["b"][1]) and back["b"][2:] == [float("inf"), -float("inf"), 1e-45, 2**63]
    back["b"][1] = doc["b"][1] = 0
    assert back == doc
