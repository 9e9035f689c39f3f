"""The kernels build as strict OpenCL C 1.2 on every device, warning-free: with every
feature compiled in (the generic program) and with none (the leanest variant), with the
stage kernels and without them (a fused render's program: kernels/texray.cl TX_STAGES). PoCL
accepts OpenCL C 3.0 too; building as 1.2 with -Werror keeps what only a newer or
laxer compiler accepts (the generic address space, implicit conversions it warns
about) out of the code that must also build on NVIDIA, AMD and Intel drivers."""
import dataclasses
import os

import pyopencl as cl
import pytest

from texray.device.features import Features, compile_options, cpu_avx512


@pytest.mark.parametrize("which", ["generic", "lean", "packet8", "packet16", "packet16-avx512", "surface8",
                                   "surface16", "lean-fused", "packet16-fused", "surface16-fused"])
def test_kernels_build_as_opencl_1_2_without_warnings(any_rt, which):
    fused_only = which.endswith("-fused")          # the fused pipeline's program: no stage kernels
    which = which.removesuffix("-fused")
    slow = {"generic": "over a minute", "packet8": "48 s", "surface8": "about a minute",
            "surface16": "about a minute"}     # cold, this Xeon
    if which in slow and "Intel" in any_rt.device.platform.name and not os.environ.get("TEXRAY_TEST_SLOW_BUILDS"):
        # The generic program: 64-77 s on Intel's runtime (the README's "Default device"), a twentieth
        # of the CI budget; its specialized programs are built by the other portability tests. The
        # packets with quads and spheres: 48 s; test_intel_runtime builds them for the brick wall and
        # the globe (its forced packets). TEXRAY_TEST_SLOW_BUILDS=1 runs both here.
        pytest.skip(f"the {which} program on Intel's runtime takes {slow[which]} to build; "
                    "TEXRAY_TEST_SLOW_BUILDS=1 builds it")
    if which.endswith("avx512") and (any_rt.kind != "pocl" or not cpu_avx512()):
        pytest.skip("AVX-512 programs (kernels/texray.cl TX_AVX512) are PoCL's on a CPU with AVX-512")
    f = dataclasses.replace(Features.generic(), one_light=True, adaptive=True) if which == "generic" else dataclasses.replace(
        Features(), shadows=False, max_lights=1, stack_size=32)
    options = compile_options(f)
    if which.startswith("packet"):     # shadow-ray packets (accel/packet.h), on any device
        f = Features(textures=True, vertex_normals=True, specular=True, filter_bilinear=True, max_lights=2,
                     stack_size=32, quads=True, spheres=True)      # quads: geometry/quad_packet.h
        if which.startswith("packet16"):  # triangles only, one light per sample (stages/fused.cl TX_ONE_LIGHT)
            f = dataclasses.replace(f, quads=False, spheres=False, one_light=True)
        options = {**compile_options(f), "TX_PACKET": int(which.removeprefix("packet")[:2]),
                   "TX_AVX512": int(which.endswith("avx512"))}
    if which.startswith("surface"):    # the packet surface (shading/surface_packet.h): every kind, bump
        f = Features(textures=True, specular=True, bump=True, filter_bilinear=True, max_lights=2, stack_size=32,
                     quads=True, spheres=True, triangles=True, cylinders=True, vertex_normals=which == "surface16")
        options = {**compile_options(f), "TX_PACKET": int(which.removeprefix("surface"))}
    if fused_only:     # cylinders in surface16: the packet leaves' kinds lane by lane (geometry/dispatch.h)
        options = {**options, "TX_STAGES": 0}
    prg = any_rt.program(options, extra_options=("-Werror",))
    names = set(prg.get_info(cl.program_info.KERNEL_NAMES).split(";"))
    if fused_only:
        assert names == {"render_fused"}
        return
    assert {"raygen", "intersect", "surface", "shadow", "shade", "render_fused", "occluded"} <= names
    assert ("occluded_packet" in names) == which.startswith(("packet", "surface"))
    assert ({"adaptive_mark", "adaptive_count", "adaptive_scan", "adaptive_list"} <= names) == (which == "generic")


def test_the_bvh_build_kernel_builds_and_gives_a_valid_tree(any_rt, monkeypatch):
    """texray.accel.cells' kernel (kernels/accel/build.cl) on every device: strict 1.2
    without warnings, and a well-formed tree with many cells (Oclgrind checks its memory
    accesses; the device-agreement tests fail on any diagnostic it logs)."""
    import warnings
    import numpy as np
    from texray.accel import cells
    from bvh_checks import check_tree, clustered_soup
    from conftest import OCLGRIND_LOG
    log0 = OCLGRIND_LOG.stat().st_size if OCLGRIND_LOG.exists() else 0
    any_rt.build('#include "accel/build.cl"\n', ("-Werror",))
    monkeypatch.setattr(cells, "CELL_PRIMS", 128)
    lo, hi = clustered_soup(np.random.default_rng(1), 3000)
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message="BVH build")     # no fallback to the numpy builder
        tree = cells.build(lo, hi, device=any_rt)
    check_tree(tree, lo, hi, any_rt.device.name)
    log1 = OCLGRIND_LOG.stat().st_size if OCLGRIND_LOG.exists() else 0
    assert log1 == log0, OCLGRIND_LOG.read_text()[log0:][:2000]
