"""Shared fixtures: the OpenCL devices to test on, seeded generators, asset paths.

Every device test runs on the default CPU device (PoCL, always present with
pyopencl[pocl]) and on each GPU found; set TEXRAY_TEST_DEVICES=all|cpu|gpu
to choose. The portability tests (struct layout, strict 1.2 builds, images
agreeing across devices) also run on every other OpenCL device found: other CPU
drivers (Intel's runtime, which `.ci/run` installs) and
Oclgrind, the OpenCL 1.2 simulator that `.ci/run` installs where it can: a
second, independent compiler and runtime, whose memory checker reports any
out-of-bounds access of the kernels.
"""
import os
import zlib
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

# Where Oclgrind (if it is one of the devices) writes its diagnostics: read when a
# context is created, so set before any test creates one. One log per process: pytest-xdist's
# workers inherit the controller's environment, so a log this file chose in the controller
# (named in TEXRAY_TEST_OWN_OCLGRIND_LOG) is replaced by the worker's own.
_OWN_OCLGRIND_LOG = os.environ.get("OCLGRIND_LOG") in (None, os.environ.get("TEXRAY_TEST_OWN_OCLGRIND_LOG"))
if _OWN_OCLGRIND_LOG:
    os.environ["OCLGRIND_LOG"] = os.environ["TEXRAY_TEST_OWN_OCLGRIND_LOG"] = str(
        Path(os.environ.get("TMPDIR", "/tmp")) / f"texray-oclgrind-{os.getpid()}.log")
OCLGRIND_LOG = Path(os.environ["OCLGRIND_LOG"])


def pytest_sessionfinish(session, exitstatus):
    if _OWN_OCLGRIND_LOG and OCLGRIND_LOG.exists() and OCLGRIND_LOG.stat().st_size == 0:
        OCLGRIND_LOG.unlink()      # nothing logged: no litter; a log with diagnostics stays for reading
try:
    import texray  # noqa: F401  (installed)
except ImportError:                      # running from a source tree
    sys.path.insert(0, str(ROOT / "pyhost"))
    import texray  # noqa: F401


def _test_devices(types, every_cpu):
    """Devices of the given types; of the CPU drivers only the default one (PoCL: the
    renderer's default CPU device) unless ``every_cpu``."""
    from texray.device import devices, select_device
    want = os.environ.get("TEXRAY_TEST_DEVICES", "all")
    default_cpu = None
    if not every_cpu and any(d.type == "cpu" for d in devices()):
        c = select_device("cpu")
        default_cpu = (c.name.strip(), c.platform.name.strip())
    out = []
    for d in devices():
        if d.type == "cpu" and default_cpu is not None and (d.name, d.platform) != default_cpu:
            continue
        if want in ("all", d.type) and d.type in types:
            if not any(o.type == d.type and o.name == d.name for o in out):
                out.append(d)
    return out


DEVICES = _test_devices(("cpu", "gpu"), every_cpu=False)
# Devices of the portability tests: the above and any other OpenCL device (other CPU
# drivers, such as Intel's runtime from texray[intel], included).
PORTABILITY_DEVICES = _test_devices(("cpu", "gpu", "accelerator", "other"), every_cpu=True)


@pytest.fixture(params=[d.index for d in DEVICES], ids=[f"{d.type}:{d.name[:24]}" for d in DEVICES])
def device(request):
    """Index of an OpenCL device (see module docstring)."""
    return request.param


@pytest.fixture
def rt(device):
    from texray.device import runtime
    return runtime(device)


@pytest.fixture(params=[d.index for d in PORTABILITY_DEVICES],
                ids=[f"{d.type}:{d.name[:24]}" for d in PORTABILITY_DEVICES])
def any_rt(request):
    """A runtime on each device of PORTABILITY_DEVICES."""
    from texray.device import runtime
    return runtime(request.param)


@pytest.fixture
def rng(request):
    """A seeded generator: the seed is the CRC of the test id (TEXRAY_SEED overrides it) and is
    reported with the failure."""
    seed = int(os.environ.get("TEXRAY_SEED", zlib.crc32(request.node.nodeid.encode())))
    request.node.user_properties.append(("seed", seed))
    return np.random.default_rng(seed)


@pytest.fixture
def scenes_dir():
    return ROOT / "scenes"


# The scene cache (texray.compile.cache) is off in the tests: every render compiles its
# scene as it did before the cache, and nothing is written to the user's cache folder.
# tests/unit/test_scene_cache.py and tests/render/test_scene_cache_render.py turn it on in
# temporary folders (the cache_env fixture).
os.environ["TEXRAY_NO_CACHE"] = "1"
os.environ["TEXRAY_CACHE_DIR"] = str(Path(os.environ.get("TMPDIR", "/tmp")) / f"texray-test-cache-{os.getpid()}")


@pytest.fixture
def cache_env(tmp_path, monkeypatch):
    """The scene cache on, in an empty folder, storing every scene however fast it compiles;
    the folder."""
    folder = tmp_path / "scene-cache"
    monkeypatch.delenv("TEXRAY_NO_CACHE", raising=False)
    monkeypatch.setenv("TEXRAY_CACHE_DIR", str(folder))
    monkeypatch.setenv("TEXRAY_CACHE_MIN_S", "0")
    monkeypatch.delenv("TEXRAY_CACHE_SIZE", raising=False)
    monkeypatch.setenv("TEXRAY_CACHE_MEMORY", "0")      # the folder alone (tests that keep in memory set it)
    from texray.compile import cache
    cache.forget()
    return folder
