"""The fused pipeline (one kernel per pixel, all stages) renders exactly the image of
the staged pipeline (five kernels with per-ray records between them): both call the
same device functions on the same samples, so the images are bit-identical (up to the
order of the per-pixel sums when a tile's samples are split over launches), whatever
the tiling, and with AOVs, bump maps, labels and mappings."""
import numpy as np
import pytest

import texray as tx
from texray.errors import SceneError
from texray.renderer import render, tiling


SCENES = ["bench/globe.toml", "bench/mixed.toml", "bench/brick_wall.toml", "roles/roles.toml",
          "bump/normal_mesh.toml", "mappings/projection.toml"]


@pytest.mark.parametrize("path", SCENES)
def test_fused_equals_staged(device, scenes_dir, path):
    scene = tx.Scene.load(scenes_dir / path)
    a = render(scene, 40, 28, 3, device=device, pipeline="stages", seed=5)
    b = render(scene, 40, 28, 3, device=device, seed=5)
    assert b.stats["pipeline"] == "fused" and set(b.stats["stage_s"]) == {"render_fused"}
    assert np.all(np.isfinite(b.rgb)) and b.rgb.max() > 0.02
    np.testing.assert_array_equal(b.rgb, a.rgb)


def test_fused_launch_splits_and_tiles(device, scenes_dir, monkeypatch):
    scene = tx.Scene.load(scenes_dir / "bench/mixed.toml")
    ref = render(scene, 32, 24, 5, device=device, pipeline="stages", aovs=("depth",))
    # a row's 5 samples over MAX_FUSED_SAMPLES: launches of 2 samples (as many as fit in one
    # row), one row each, whatever tile_pixels asks
    monkeypatch.setattr(tiling, "MAX_FUSED_SAMPLES", 32 * 2)
    assert tiling.fused_samples(32, 24, 5) == 2 and tiling.fused_rows(32, 2) == 1
    seen = []
    img = render(scene, 32, 24, 5, device=device, tile_pixels=32 * 8, aovs=("depth",), progress=seen.append)
    assert img.stats["tiles"] == 24 and img.stats["tile_rows"] == 1 and len(img.stats["stage_s"]) == 4
    # launches of 2 samples add partial sums ((s0 + s1) + (s2 + s3)) + s4 where the staged
    # pipeline adds one sample at a time: float32 rounding, a few ulp
    np.testing.assert_allclose(img.rgb, ref.rgb, rtol=4e-7, atol=1e-9)
    np.testing.assert_array_equal(img.aov["depth"], ref.aov["depth"])
    # 24 tiles x (3 fused launches + the AOV pass), progress strictly increasing to 1
    assert len(seen) == 96 and seen[-1] == 1.0 and all(b > a for a, b in zip(seen, seen[1:]))


def test_a_pixels_samples_take_one_launch_where_a_row_fits(device, scenes_dir, monkeypatch):
    """Where a row's samples fit MAX_FUSED_SAMPLES, a launch takes every sample of its pixels
    and as many rows as fit: each pixel sums its samples in order, as the staged pipeline
    does one at a time, so the images are equal bit for bit; 640x480 at 16 spp (the textured
    meshes bench) takes launches of 409 rows, all 16 samples."""
    assert tiling.fused_samples(640, 480, 16) == 16 and tiling.fused_rows(640, 16) == 409
    assert tiling.fused_samples(4096, 2160, 2048) == tiling.MAX_FUSED_SAMPLES // 4096     # a row over the limit
    scene = tx.Scene.load(scenes_dir / "bench/mixed.toml")
    ref = render(scene, 32, 24, 5, device=device, pipeline="stages")
    monkeypatch.setattr(tiling, "MAX_FUSED_SAMPLES", 32 * 24 * 2)      # 9 rows of 5 samples a launch
    assert tiling.fused_samples(32, 24, 5) == 5 and tiling.fused_rows(32, 5) == 9
    img = render(scene, 32, 24, 5, device=device)
    assert img.stats["tiles"] == 3 and img.stats["tile_rows"] == 9 and len(img.stats["stage_s"]) == 1
    np.testing.assert_array_equal(img.rgb, ref.rgb)


def test_unknown_pipeline_is_an_error(scenes_dir):
    scene = tx.Scene.load(scenes_dir / "bench/globe.toml")
    with pytest.raises(SceneError, match="pipeline"):
        render(scene, 8, 8, 1, pipeline="megakernel")


def test_a_fused_render_builds_its_program_without_the_stage_kernels(device, scenes_dir, monkeypatch):
    """On PoCL the fused pipeline's program leaves the stage kernels out, and with them every
    helper only they call (kernels/texray.cl TX_STAGES, core/common.h); the staged pipeline's,
    an AOV render's and the ray tracer's hold them, as every program on other devices does.
    Their images are the same (test_fused_equals_staged, where the scalar geometry the fused
    program leaves out, geometry/dispatch.h, is the staged pipeline's)."""
    import dataclasses
    import pyopencl as cl
    from texray.compile import compile_scene
    from texray.device import runtime
    from texray.device.features import compile_options
    rt = runtime(device)
    built = []
    program = type(rt).program

    def recording(self, defines, extra_options=()):
        prg = program(self, defines, extra_options)
        built.append((defines["TX_STAGES"], set(prg.get_info(cl.program_info.KERNEL_NAMES).split(";"))))
        return prg

    monkeypatch.setattr(type(rt), "program", recording)
    scene = tx.Scene.load(scenes_dir / "bench/mixed.toml")
    stage_kernels = {"raygen", "intersect", "surface", "shadow", "shade", "occluded"}
    fused_only = rt.kind == "pocl"
    render(scene, 8, 6, 1, device=device)
    assert built[-1][0] == (not fused_only) and bool(built[-1][1] & stage_kernels) == (not fused_only)
    assert "render_fused" in built[-1][1]
    render(scene, 8, 6, 1, device=device, adaptive=0.1)
    assert built[-1][0] == (not fused_only) and bool(built[-1][1] & stage_kernels) == (not fused_only)
    assert "adaptive_mark" in built[-1][1]
    for kw in ({"pipeline": "stages"}, {"aovs": ("depth",)}):
        render(scene, 8, 6, 1, device=device, **kw)
        assert built[-1][0] == 1 and stage_kernels <= built[-1][1]
    f = compile_scene(scene).features
    assert compile_options(f, "pocl", stages=False)["TX_STAGES"] == 0
    assert compile_options(f, "pocl", rays=True, stages=False)["TX_STAGES"] == 1
    assert compile_options(dataclasses.replace(f, aovs=True), "pocl", stages=False)["TX_STAGES"] == 1
    assert compile_options(f, "pocl")["TX_STAGES"] == 1                  # the whole program unless told
    for kind in ("nvidia", "amd", "intel-cpu", "intel-gpu", "other", None):  # one program for both pipelines
        assert compile_options(f, kind, stages=False)["TX_STAGES"] == 1


def test_a_fused_only_packet_program_compiles_no_copy_of_the_scalar_code_packets_replace(device, scenes_dir):
    """On PoCL a fused-only packet program (core/common.h TX_PRE_GEOM_ONLY) holds no copy of
    the scalar tests that the packets replace and no 8-lane sampler in a 16-lane program: static
    there, they are not compiled at all (an extern one is, called or not). Their names are looked
    for in the program's binary (PoCL's holds its bitcode), those no other name contains; the
    staged program, which traverses rays one at a time, holds them."""
    import pyopencl as cl
    from texray.compile import compile_scene
    from texray.device import runtime
    from texray.device.features import compile_options
    rt = runtime(device)
    if rt.kind != "pocl":
        pytest.skip("fused-only programs are PoCL's (compile_options: TX_STAGES)")
    f = compile_scene(tx.Scene.load(scenes_dir / "bench/mixed.toml")).features
    scalar = (b"triangle_intersect4", b"quad_intersect_corners", b"sphere_ray")

    width = compile_options(f, rt.kind)["TX_PACKET"]
    if not width:
        pytest.skip("no packets (TEXRAY_PACKET=0)")

    def binary(**kw):
        return rt.program(compile_options(f, rt.kind, **kw)).get_info(cl.program_info.BINARIES)[0]

    fused, staged = binary(stages=False), binary(stages=True)
    assert b"render_fused_body" in fused and b"light_term_packet" in fused      # the probe finds names
    assert [n for n in scalar if n in fused] == []
    assert [n for n in scalar if n in staged] == list(scalar)
    if width == 16:                              # (an 8-lane program calls both samplers)
        assert b"cmj_sample_packet8" not in fused and b"cmj_sample_packet8" not in staged
        assert b"cmj_sample_packet16" in fused
