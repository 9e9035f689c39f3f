"""OpenCL devices: discovery, selection, contexts and the program cache.

Selection (``device=`` of :func:`texray.render`):

* ``None``: ``PYOPENCL_CTX`` if set (pyopencl's own syntax, e.g. ``"0:1"``),
  else the first device in :data:`DEFAULT_ORDER`: a GPU of any platform, else PoCL's
  CPU device (it ships with ``pyopencl[pocl]``, so there always is one), else any
  other CPU device (Intel's runtime: why it comes after PoCL is stated there).
* ``"cpu"`` / ``"gpu"``: the first device of that type in the same order.
* an ``int``: an index into :func:`devices`.
* ``"pocl"``: PoCL's first device.
* any other string: the first device whose platform name contains it
  (case-insensitive: ``"intel"`` is Intel's runtime, ``"nvidia"`` NVIDIA's platform),
  else the first whose device name does.
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import threading
import time
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

# PoCL's CPU driver runs a work-group either as plain loops over its work-items or
# vectorized across them ("loopvec", its default). BVH traversal diverges per ray, and
# the plain loops measured faster on every stage here (showcase, 4 spp: 0.53 s against
# 0.71 s; see README "Performance"). Set before PoCL initializes; a user's own
# POCL_WORK_GROUP_METHOD wins. Other OpenCL drivers ignore it.
os.environ.setdefault("POCL_WORK_GROUP_METHOD", "loops")

import numpy as np  # noqa: E402
from . import icd  # noqa: E402,F401  (registers Intel's OpenCL CPU runtime before pyopencl loads the ICDs)
import pyopencl as cl  # noqa: E402

from ..errors import BuildError, DeviceError
from . import buffers, layout



def _kernel_dir() -> Path:
    """Where the .cl sources are: the repository's ``kernels/`` when this package is
    imported from a source tree (whichever checkout it is: a git worktree beside an
    editable install must not build another tree's kernels), else the installed package
    ``texray.kernels``."""
    repo = Path(__file__).resolve().parents[3] / "kernels"
    if (repo / "texray.cl").is_file():
        return repo
    try:
        spec = importlib.util.find_spec("texray.kernels")
    except ImportError:
        spec = None
    if spec is not None and spec.submodule_search_locations:
        for loc in spec.submodule_search_locations:
            if (Path(loc) / "texray.cl").is_file():
                return Path(loc)
    raise DeviceError("texray's OpenCL sources (texray.cl) were not found: the installation is incomplete")


KERNEL_DIR = _kernel_dir()


@dataclass(frozen=True)
class DeviceInfo:
    """One OpenCL device as listed by :func:`devices`."""
    index: int
    name: str
    platform: str
    type: str            # "cpu", "gpu", "accelerator" or "other"
    compute_units: int
    global_mem: int      # bytes
    max_alloc: int       # bytes, largest single buffer
    fp64: bool

    def __str__(self):
        return (f"[{self.index}] {self.name} ({self.platform}, {self.type}, {self.compute_units} CUs, "
                f"{self.global_mem / 2**30:.1f} GiB)")


def _type_name(t):
    """The device's one type. A device reporting several (Oclgrind, the OpenCL
    simulator, reports CL_DEVICE_TYPE_ALL) is "other": it must not be taken for
    the first GPU by the default selection."""
    kinds = [name for bit, name in ((cl.device_type.GPU, "gpu"), (cl.device_type.CPU, "cpu"),
                                    (cl.device_type.ACCELERATOR, "accelerator")) if t & bit]
    return kinds[0] if len(kinds) == 1 else "other"


@lru_cache(maxsize=1)
def _all_devices():
    out = []
    try:
        platforms = cl.get_platforms()
    except cl.Error:
        platforms = []
    for p in platforms:
        try:
            out.extend(p.get_devices())
        except cl.Error:
            continue
    return tuple(out)


def devices() -> list[DeviceInfo]:
    """All OpenCL devices of all platforms, in a stable order."""
    return [DeviceInfo(i, d.name.strip(), d.platform.name.strip(), _type_name(d.type), d.max_compute_units,
                       d.global_mem_size, d.max_mem_alloc_size, "cl_khr_fp64" in d.extensions)
            for i, d in enumerate(_all_devices())]


# The default device (device=None; "cpu" or "gpu" among several of that type): the first
# of these classes, each in the ICD loader's order. Measured with `texray bench --peers`
# (README, Performance): a GPU first; among CPU drivers PoCL before Intel's runtime,
# which renders frames 1.2-1.5x faster on the bench scenes but compiles each program
# 3x slower (4-7 s cold against 1.3-1.9 s; the generic program 64 s against 2.6 s), so
# that a first render, and every new feature set, waits longer than the frame saves.
# `device="Intel(R) OpenCL"` (its platform) chooses it for long or repeated renders:
# its programs are cached, a warm start takes 0.05 s.
DEFAULT_ORDER = ("gpu", "pocl", "cpu", "accelerator", "other")


def _default_rank(d) -> int:
    typ = _type_name(d.type)
    if typ == "cpu" and _device_kind(d) == "pocl":
        return DEFAULT_ORDER.index("pocl")
    return DEFAULT_ORDER.index(typ)


def default_order(devs):
    """``devs`` in the default selection's order (:data:`DEFAULT_ORDER`; stable)."""
    return sorted(devs, key=_default_rank)


def select_device(device=None) -> cl.Device:
    """The pyopencl device that ``device`` names (see module docstring)."""
    devs = _all_devices()
    if not devs:
        raise DeviceError("no OpenCL device found: install pyopencl[pocl] for the CPU device")
    if isinstance(device, cl.Device):
        return device
    if device is None:
        ctx = os.environ.get("PYOPENCL_CTX")
        if ctx:
            try:
                return cl.create_some_context(interactive=False).devices[0]
            except Exception as e:     # pyopencl raises RuntimeError, ValueError or IndexError for a bad value
                raise DeviceError(f"PYOPENCL_CTX={ctx!r} names no device ({type(e).__name__}: {e}); pyopencl's "
                                  "syntax is PLATFORM[:DEVICE] (indices or name substrings); available: "
                                  + "; ".join(map(str, devices()))) from None
        return default_order(devs)[0]
    if isinstance(device, (bool, np.bool_)) or not isinstance(device, (int, np.integer, str)):
        raise DeviceError(f"device: expected None, an int or a str, got {type(device).__name__} {device!r}")
    if isinstance(device, str) and not device.strip():
        raise DeviceError(f"device: expected a device index, 'cpu', 'gpu' or a name, got {device!r}; "
                          "available: " + "; ".join(map(str, devices())))
    if isinstance(device, (int, np.integer)):
        device = int(device)
        if not 0 <= device < len(devs):
            raise DeviceError(f"device: index {device} out of range; {len(devs)} device(s): "
                              + "; ".join(map(str, devices())))
        return devs[device]
    key = device.strip().lower()
    if key in ("cpu", "gpu"):
        for d in default_order(devs):
            if _type_name(d.type) == key:
                return d
        raise DeviceError(f"device: no {key.upper()} device; available: " + "; ".join(map(str, devices())))
    # A platform's name first ("intel" is Intel's runtime, not PoCL's device on an Intel
    # CPU, whose name also says Intel), then a device's; "pocl" names PoCL's devices.
    for d in devs:
        if key in d.platform.name.lower() or (key == "pocl" and _device_kind(d) == "pocl"):
            return d
    for d in devs:
        if key in d.name.lower():
            return d
    raise DeviceError(f"device: no device matches {device!r}; available: " + "; ".join(map(str, devices())))


class Runtime:
    """A context and a profiling-enabled queue on one device, with its program cache."""

    def __init__(self, dev: cl.Device):
        self.device = dev
        self.context = cl.Context([dev])
        self.queue = cl.CommandQueue(self.context, properties=cl.command_queue_properties.PROFILING_ENABLE)
        self._programs = {}
        self._lock = threading.Lock()
        self._thread = threading.local()      # .kernels: (program, name) -> cl.Kernel, per thread
        self.build_log = []          # (options, seconds) per program built in this process
        # Defines naming the driver, for its workarounds (core/builtins.h: TX_POCL).
        self.kind = _device_kind(dev)
        self.device_defines = ("-DTX_POCL=1",) if self.kind == "pocl" else ()

    def local_size(self, override=None, packet=0):
        """Work-group size for the one-ray-per-work-item kernels, or None to let the driver
        choose. ``override`` (the render's ``local_size``) or ``TEXRAY_LOCAL_SIZE`` wins;
        0 means "driver's choice". Otherwise, for a program with ray packets (``packet``:
        its TX_PACKET), the value of :data:`PACKET_LOCAL_SIZES` for this device's kind if
        it has one, else that of :data:`LOCAL_SIZES` (measured with ``texray bench
        --local-sizes``), capped by the device's maximum work-group size."""
        value = override
        if value is None and os.environ.get("TEXRAY_LOCAL_SIZE"):
            try:
                value = int(os.environ["TEXRAY_LOCAL_SIZE"])
            except ValueError:
                raise DeviceError(f"TEXRAY_LOCAL_SIZE: expected an integer, got "
                                  f"{os.environ['TEXRAY_LOCAL_SIZE']!r}") from None
        if value is None and packet:
            value = PACKET_LOCAL_SIZES.get(_device_kind(self.device))
        if value is None:
            value = LOCAL_SIZES.get(_device_kind(self.device), LOCAL_SIZES["default"])
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise DeviceError(f"local_size: expected a non-negative integer, got {value!r}")
        if value == 0:
            return None
        return min(value, self.device.max_work_group_size)

    def launch_size(self, n: int, local=None):
        """(global, local) sizes covering ``n`` work-items (kernels ignore ids >= n; a
        kernel's id is ``TX_GID()``, kernels/core/common.h): one dimension rounded up to a
        multiple of the local size, or on PoCL, past :data:`GRID_WIDTH`, rows of at most that
        width (the fewest that fit, each as narrow as they allow: fewer than a row's
        work-groups left over), so that every launch of a kernel runs the one work-group
        function PoCL builds for grids narrower than 65535."""
        return _launch_size(max(int(n), 1), local, in_rows=self.kind == "pocl")

    @property
    def fp64(self):
        return "cl_khr_fp64" in self.device.extensions

    def program(self, defines: dict[str, int], extra_options=()) -> cl.Program:
        """The texray program compiled with ``-D name=value`` for each of ``defines``.

        Always as OpenCL C 1.2 (``-cl-std=CL1.2``): a driver that knows 2.0/3.0
        (PoCL does) would otherwise accept what a 1.2-only GPU rejects, such as the
        generic address space. Built once per (device, source, options) in this
        process; the driver's or pyopencl's cache on disk makes the next process's
        build cheap as well. Raises BuildError with the compiler log on failure.
        """
        return self.build('#include "texray.cl"\n', [f"-D{k}={int(v)}" for k, v in sorted(defines.items())]
                          + list(extra_options))

    def build(self, source: str, options=()) -> cl.Program:
        """``source`` after the generated prelude (:func:`opencl_prelude`), built with
        ``options`` as OpenCL C 1.2 against the kernel sources (``-I KERNEL_DIR``): the one
        build path of the renderer's program and the tests' kernels. Cached per (source,
        every kernel source file, options); BuildError with the compiler log on failure."""
        source = opencl_prelude() + source
        options = list(options) + ["-I", str(KERNEL_DIR), "-cl-std=CL1.2"] + list(self.device_defines)
        key = (hashlib.sha256((source + _kernel_sources_digest()).encode()).hexdigest(), tuple(options))
        with self._lock:
            prg = self._programs.get(key)
            if prg is None:
                t0 = time.perf_counter()
                try:
                    prg = cl.Program(self.context, source).build(options=options)
                except cl.Error as e:   # pyopencl's build failure carries the compiler log in its message
                    raise BuildError(f"OpenCL build failed on {self.device.name.strip()} with options "
                                     f"{' '.join(options)}:\n{e}") from None
                _check_kernels(prg, self.device, options)
                self.build_log.append((tuple(options), time.perf_counter() - t0))
                self._programs[key] = prg
        return prg

    def kernel(self, prg: cl.Program, name: str) -> cl.Kernel:
        """The kernel ``name`` of ``prg`` (a program of this runtime), made once per thread and
        kept: making the six of a render's program cost 1.3 ms a render on PoCL. Per thread,
        since a kernel object holds its arguments between setting them and a launch."""
        kernels = getattr(self._thread, "kernels", None)
        if kernels is None:
            kernels = self._thread.kernels = {}
        got = kernels.get((prg.int_ptr, name))
        if got is None:           # the program is kept with its kernel: its address stays its own
            got = kernels[(prg.int_ptr, name)] = (prg, cl.Kernel(prg, name))
        return got[1]


def _check_kernels(prg: cl.Program, device, options) -> None:
    """BuildError where a program that built has no kernels: a driver's cached binary that did
    not load (PoCL once cached 16-lane programs that LLVM could not read back, core/builtins.h),
    which would otherwise surface later as INVALID_KERNEL_NAME on a kernel that exists."""
    try:
        names = prg.get_info(cl.program_info.KERNEL_NAMES)
    except cl.Error:                     # a driver without the query: nothing to check
        return
    if not names.strip(";"):
        cache = os.environ.get("POCL_CACHE_DIR", "~/.cache/pocl")
        raise BuildError(f"OpenCL build on {device.name.strip()} with options {' '.join(options)} gave a "
                         f"program with no kernels; if the driver keeps a cache of built programs (PoCL: "
                         f"{cache}), it may hold one that does not load: remove it and run again")


def opencl_prelude() -> str:
    """What the host generates ahead of the kernel sources: the structs and constants of
    texray.device.layout and the parameter lists of texray.device.buffers."""
    return layout.opencl_declarations() + buffers.opencl_macros()


@lru_cache(maxsize=1)
def _kernel_sources_digest() -> str:
    """Hash of every kernel source file (kernels/ and its subfolders, by path relative to
    it), so an edited header invalidates the cache."""
    h = hashlib.sha256()
    for p in sorted(KERNEL_DIR.rglob("*")):
        if p.suffix in (".cl", ".h"):
            h.update(p.relative_to(KERNEL_DIR).as_posix().encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def _device_kind(dev) -> str:
    """'pocl', 'nvidia', 'amd', 'intel-gpu', 'intel-cpu' or 'other': the keys of LOCAL_SIZES."""
    platform = dev.platform.name.lower()
    vendor = dev.vendor.lower()
    if "portable computing language" in platform or "pocl" in platform:
        return "pocl"
    if "nvidia" in vendor:
        return "nvidia"
    if "advanced micro devices" in vendor or "amd" in vendor:
        return "amd"
    if "intel" in vendor:
        return "intel-gpu" if _type_name(dev.type) == "gpu" else "intel-cpu"
    return "other"


# The widest dimension of a launch's grid (launch_size): under PoCL's limit for its "smallgrid"
# work-group functions (USHRT_MAX, pocl_cache's kernel directory suffix), a multiple of every
# power-of-two work-group size.
GRID_WIDTH = 32768


def _launch_size(n: int, local, in_rows: bool = True):
    """Runtime.launch_size's sizes for n >= 1 work-items; ``in_rows``: past GRID_WIDTH in rows."""
    step = local or 1
    groups = -(-n // step)
    rows = -(-groups * step // GRID_WIDTH) if in_rows else 1
    if rows == 1:
        glob = (groups * step,)
    else:
        glob = (step * -(-groups // rows), rows)
    if local is None:
        return glob, None
    return glob, (local,) + (1,) * (len(glob) - 1)


# Work-group size per device kind for the per-ray kernels. 0 = the driver's choice.
# pocl: 64. `texray bench --local-sizes` measures every size within noise of the
# driver's choice in frame time (README, Performance), but PoCL compiles a
# work-group function per local size, and its own choice follows the global size:
# each new image size paid 0.6-0.7 s of compiling (globe, 1 spp: 1000x700 in 0.72 s
# against 0.15 s at 64). A fixed size compiles once. GPUs: a multiple of the SIMD
# width (NVIDIA warp 32, AMD wavefront 64, Intel SIMD 8-32) that keeps enough groups
# in flight for incoherent traversal. intel-cpu: 16, the smallest size its compiler runs
# vectorized (it packs work-items 16 wide with AVX-512, 8 with AVX2, and runs a group's
# remainder, a whole group below that width, as scalar code).
LOCAL_SIZES = {"pocl": 64, "nvidia": 64, "amd": 64, "intel-gpu": 64, "intel-cpu": 16, "other": 0, "default": 0}
# Work-group size where the program traces ray packets (texray.device.features.packet_width),
# by kind, in place of LOCAL_SIZES. intel-cpu: 1. Its compiler then runs each work-item's
# packet code as the explicit 8-wide vectors it is, instead of vectorizing it once more across
# work-items: 2026-12-03, the bench's globe, brick wall, grazing quad and textured meshes at
# their spp took 0.45-0.65 of the frame time of local size 16 without packets (README,
# Performance).
PACKET_LOCAL_SIZES = {"intel-cpu": 1}


_runtimes: dict = {}
_runtimes_lock = threading.Lock()


def runtime(device=None) -> Runtime:
    """The shared :class:`Runtime` of the selected device (created on first use)."""
    dev = select_device(device)
    with _runtimes_lock:
        rt = _runtimes.get(dev.int_ptr)
        if rt is None:
            rt = _runtimes[dev.int_ptr] = Runtime(dev)
    return rt
