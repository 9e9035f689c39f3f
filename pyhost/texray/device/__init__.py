"""The OpenCL side of the host: devices, contexts and the program cache (:mod:`.opencl`), the
structs shared with the kernels (:mod:`.layout`), the feature set that specializes
the kernels (:mod:`.features`) and the manifest of device buffers (:mod:`.buffers`)."""
from .opencl import KERNEL_DIR, DeviceInfo, Runtime, devices, runtime, select_device

__all__ = ["KERNEL_DIR", "DeviceInfo", "Runtime", "devices", "runtime", "select_device"]
