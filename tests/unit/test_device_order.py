"""The default device rule (texray.device.opencl.DEFAULT_ORDER): a GPU, else PoCL's CPU
device, else another CPU driver (Intel's runtime), else anything else; stable within a
class. And names: a platform's name before a device's, "pocl" for PoCL."""
from types import SimpleNamespace

import pyopencl as cl

from texray.device import opencl


def _dev(name, platform, vendor, typ):
    return SimpleNamespace(name=name, platform=SimpleNamespace(name=platform), vendor=vendor, type=typ)


INTEL_CPU = _dev("Intel(R) Xeon(R) Processor", "Intel(R) OpenCL", "Intel(R) Corporation", cl.device_type.CPU)
POCL_CPU = _dev("pthread-Intel(R) Xeon(R) Processor", "Portable Computing Language", "GenuineIntel",
                cl.device_type.CPU)
OCLGRIND = _dev("Oclgrind Simulator", "Oclgrind", "University of Bristol", cl.device_type.ALL)
NVIDIA = _dev("NVIDIA H200", "NVIDIA CUDA", "NVIDIA Corporation", cl.device_type.GPU)
AMD_GPU = _dev("gfx90a", "AMD Accelerated Parallel Processing", "Advanced Micro Devices, Inc.",
               cl.device_type.GPU)


def test_gpu_then_pocl_then_other_cpus_then_the_rest():
    assert opencl.default_order([OCLGRIND, INTEL_CPU, POCL_CPU]) == [POCL_CPU, INTEL_CPU, OCLGRIND]
    assert opencl.default_order([INTEL_CPU, POCL_CPU, AMD_GPU, NVIDIA]) == [AMD_GPU, NVIDIA, POCL_CPU, INTEL_CPU]
    assert opencl.default_order([INTEL_CPU, OCLGRIND]) == [INTEL_CPU, OCLGRIND]


def test_names_choose_platforms_first(monkeypatch):
    monkeypatch.setattr(opencl, "_all_devices", lambda: (POCL_CPU, INTEL_CPU, OCLGRIND))
    monkeypatch.setattr(opencl.cl, "Device", SimpleNamespace)       # no real device passes isinstance
    monkeypatch.delenv("PYOPENCL_CTX", raising=False)
    assert opencl.select_device("intel") is INTEL_CPU                # platform, though PoCL's name says Intel
    assert opencl.select_device("pocl") is POCL_CPU
    assert opencl.select_device("pthread") is POCL_CPU
    assert opencl.select_device("cpu") is POCL_CPU
    assert opencl.select_device(None) is POCL_CPU
    assert opencl.select_device("oclgrind") is OCLGRIND
