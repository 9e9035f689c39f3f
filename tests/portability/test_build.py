"""The kernels build as strict OpenCL C 1.2 on every device, warning-free: with every
feature compiled in (the generic program) and with none (the leanest variant). PoCL
accepts OpenCL C 3.0 too; building as 1.2 with -Werror keeps what only a newer or
laxer compiler accepts (the generic address space, implicit conversions it warns
about) out of the code that must also build on NVIDIA, AMD and Intel drivers."""
import dataclasses

import pyopencl as cl
import pytest

from texray.device.features import Features, compile_options


@pytest.mark.parametrize("which", ["generic", "lean"])
def test_kernels_build_as_opencl_1_2_without_warnings(any_rt, which):
    f = Features.generic() if which == "generic" else dataclasses.replace(
        Features(), shadows=False, max_lights=1, stack_size=32)
    prg = any_rt.program(compile_options(f), extra_options=("-Werror",))
    names = set(prg.get_info(cl.program_info.KERNEL_NAMES).split(";"))
    assert {"raygen", "intersect", "surface", "shadow", "shade", "render_fused", "occluded"} <= names
