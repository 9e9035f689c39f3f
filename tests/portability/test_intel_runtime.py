"""Intel's OpenCL CPU runtime (``pip install 'texray[intel]'``): its registration with the
ICD loader (texray.device.icd) and the images it renders.

Registration, unit-level with fake libraries and vendor directories in a temporary
directory: the vendor directory texray writes lists every ICD the loader read before
plus Intel's (and NVIDIA's driver library where it is mounted without its ICD file); a
user's OCL_ICD_VENDORS directory keeps all it lists, a file is left alone, TEXRAY_NO_ICD=1
and a driver the loader finds already change nothing; a driver library that cannot load
(an empty file) hides no device.

Rendering, where the Intel device is present (the wheel installed): its compiler
vectorizes kernels across work-items (16 wide with AVX-512, 8 with AVX2) and gave
functions it does not inline a vector variant whose float3 arguments every lane but the
first read from the wrong place (kernels/core/common.h): rays, hits and shading mixed
between work-items at local sizes of the vector width and above, while local sizes below
it (run as scalar code) were right. So each scene is rendered at 8, 16 and 64, through
both pipelines, and held to PoCL's image within the device-agreement tolerance
(test_devices_agree.py: at most 0.1% of pixels differ by more than 0.02, the rest by
less than 1e-4 on average).
"""
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

import texray as tx
from texray.compile import compile_scene
from texray.device import icd, opencl, runtime
from texray.device.features import compile_options
from texray.renderer import render

from conftest import PORTABILITY_DEVICES


def _icd(directory, name, library):
    directory.mkdir(parents=True, exist_ok=True)
    (directory / name).write_text(f"{library}\n")


def _listed(vendors):
    """The libraries a vendor directory names, sorted."""
    return sorted((Path(vendors) / n).read_text().strip() for n in os.listdir(vendors) if n.endswith(".icd"))


@pytest.fixture
def fake(tmp_path):
    """A fake libintelocl.so, system vendor directory (PoCL by soname, Oclgrind by an
    existing path) and environment vendor directory (the wheel's placeholder ICD naming a
    conda build path that does not exist)."""
    lib = tmp_path / "venv" / "lib" / "libintelocl.so"
    lib.parent.mkdir(parents=True)
    lib.write_bytes(b"")
    grind = tmp_path / "oclgrind" / "liboclgrind-rt-icd.so"
    grind.parent.mkdir()
    grind.write_bytes(b"")
    system = tmp_path / "etc" / "OpenCL" / "vendors"
    _icd(system, "pocl.icd", "libpocl.so.2")
    _icd(system, "oclgrind.icd", grind)
    prefix = tmp_path / "venv" / "etc" / "OpenCL" / "vendors"
    _icd(prefix, "intel-cpu.icd", "/opt/anaconda1anaconda2anaconda3/lib/libintelocl.so")
    return dict(lib=lib, grind=grind, system=system, prefix=prefix, cache=tmp_path / "cache", tmp=tmp_path)


def _register(fake, environ, nvidia_dirs=()):
    return icd.register(environ, library=fake["lib"], cache_dir=fake["cache"], prefix_vendors=fake["prefix"],
                        nvidia_dirs=nvidia_dirs)


def test_the_vendor_directory_lists_the_icds_visible_before_and_intels(fake):
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}       # the loader's directory (else /etc/OpenCL/vendors)
    vendors = _register(fake, env)
    assert vendors is not None and env["OCL_ICD_VENDORS"] == str(vendors)
    assert vendors.parent == fake["cache"]
    # PoCL and Oclgrind stay; the placeholder (a path that does not exist) is not copied
    assert _listed(vendors) == sorted(["libpocl.so.2", str(fake["grind"]), str(fake["lib"])])
    # a child process inherits OCL_ICD_VENDORS, which lists Intel already: nothing changes
    before = dict(env)
    assert _register(fake, env) is None and env == before
    # the same list in another process: the same directory, not a new one
    assert _register(fake, {"OPENCL_VENDOR_PATH": str(fake["system"])}) == vendors


def test_a_users_vendor_directory_keeps_everything_it_lists(fake):
    mine = fake["tmp"] / "mine"
    _icd(mine, "oclgrind.icd", fake["grind"])
    env = {"OCL_ICD_VENDORS": str(mine), "OPENCL_VENDOR_PATH": str(fake["system"])}
    vendors = _register(fake, env)
    # the loader read only the user's directory: that and Intel's, not the system's PoCL
    assert _listed(vendors) == sorted([str(fake["grind"]), str(fake["lib"])])
    assert env["OCL_ICD_VENDORS"] == str(vendors)
    assert _listed(mine) == [str(fake["grind"])]           # the user's directory is not touched


def test_an_explicit_choice_is_left_alone(fake):
    one = fake["system"] / "oclgrind.icd"
    env = {"OCL_ICD_VENDORS": str(one)}                     # a file: the loader loads that ICD only
    assert _register(fake, env) is None and env == {"OCL_ICD_VENDORS": str(one)}
    for value in ("1", "yes"):
        env = {"TEXRAY_NO_ICD": value, "OPENCL_VENDOR_PATH": str(fake["system"])}
        assert _register(fake, env) is None and "OCL_ICD_VENDORS" not in env
    env = {"TEXRAY_NO_ICD": "0", "OPENCL_VENDOR_PATH": str(fake["system"])}
    assert _register(fake, env) is not None


def test_a_child_with_texray_no_icd_undoes_an_inherited_registration(fake):
    """A child process inherits the parent's OCL_ICD_VENDORS (which lists Intel, so the child
    registers nothing): TEXRAY_NO_ICD in the child, or without_registration() in the parent,
    gives back the user's own OCL_ICD_VENDORS (pytest-xdist's workers, the fuzz worker)."""
    mine = fake["tmp"] / "mine"
    _icd(mine, "oclgrind.icd", fake["grind"])
    for user in ({"OCL_ICD_VENDORS": str(mine)}, {}):
        env = dict(user, OPENCL_VENDOR_PATH=str(fake["system"]))
        vendors = _register(fake, env)
        assert env["OCL_ICD_VENDORS"] == str(vendors)
        child = dict(env)
        assert _register(fake, child) is None and child == env           # inherited: left as it is
        assert icd.without_registration(child) == dict(user, OPENCL_VENDOR_PATH=str(fake["system"]))
        assert _register(fake, dict(child, TEXRAY_NO_ICD="1")) is None
        child["TEXRAY_NO_ICD"] = "1"
        _register(fake, child)
        assert child == dict(user, OPENCL_VENDOR_PATH=str(fake["system"]), TEXRAY_NO_ICD="1")
    # a user's OCL_ICD_VENDORS set after the registration stands
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}
    _register(fake, env)
    env["OCL_ICD_VENDORS"] = str(mine)
    assert icd.without_registration(env) == {"OPENCL_VENDOR_PATH": str(fake["system"]), "OCL_ICD_VENDORS": str(mine)}


def test_an_intel_runtime_the_loader_finds_already_is_not_registered_twice(fake):
    _icd(fake["system"], "intel.icd", fake["lib"])
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}
    assert _register(fake, env) is None and "OCL_ICD_VENDORS" not in env


def test_without_the_wheel_nothing_changes(fake, monkeypatch):
    monkeypatch.setattr(icd, "DISTRIBUTION", "no-such-distribution-texray")
    assert icd.find_runtime() is None
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}
    assert icd.register(env, cache_dir=fake["cache"], prefix_vendors=fake["prefix"], nvidia_dirs=()) is None
    assert env == {"OPENCL_VENDOR_PATH": str(fake["system"])}


def test_an_unwritable_cache_registers_nothing(fake):
    blocked = fake["tmp"] / "blocked"
    blocked.write_text("a file where the cache directory would go")
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}
    assert icd.register(env, library=fake["lib"], cache_dir=blocked / "icd", prefix_vendors=fake["prefix"],
                        nvidia_dirs=()) is None
    assert "OCL_ICD_VENDORS" not in env


def _nvidia(tmp_path, where="nvidia/lib64"):
    lib = tmp_path / where / icd.NVIDIA_LIBRARY
    lib.parent.mkdir(parents=True)
    lib.write_bytes(b"")
    return lib


def test_nvidias_driver_mounted_without_its_icd_is_listed(fake, monkeypatch):
    """A container's driver mount (/usr/local/nvidia/lib64 on the lent H200): the library,
    no nvidia.icd. Listed with the ICDs visible before; with Intel's where both are found."""
    nv = _nvidia(fake["tmp"])
    monkeypatch.setattr(icd, "DISTRIBUTION", "no-such-distribution-texray")     # NVIDIA alone
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}
    vendors = icd.register(env, cache_dir=fake["cache"], prefix_vendors=fake["prefix"], nvidia_dirs=[str(nv.parent)])
    assert env["OCL_ICD_VENDORS"] == str(vendors)
    assert _listed(vendors) == sorted(["libpocl.so.2", str(fake["grind"]), str(nv)])
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}
    assert _listed(_register(fake, env, [str(nv.parent)])) == sorted(["libpocl.so.2", str(fake["grind"]),
                                                                     str(fake["lib"]), str(nv)])


def test_an_nvidia_icd_the_loader_reads_already_is_left_alone(fake):
    nv = _nvidia(fake["tmp"])
    _icd(fake["system"], "nvidia.icd", "libnvidia-opencl.so.1")         # the driver package's own, by soname
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}
    vendors = _register(fake, env, [str(nv.parent)])                   # Intel's still added, NVIDIA's not twice
    assert _listed(vendors) == sorted(["libpocl.so.2", str(fake["grind"]), "libnvidia-opencl.so.1", str(fake["lib"])])
    _icd(fake["system"], "intel.icd", fake["lib"])
    env = {"OPENCL_VENDOR_PATH": str(fake["system"])}
    assert _register(fake, env, [str(nv.parent)]) is None and "OCL_ICD_VENDORS" not in env


def test_nvidias_library_is_looked_for_in_ld_library_path_then_the_driver_directories(tmp_path):
    first, second = _nvidia(tmp_path, "a"), _nvidia(tmp_path, "b")
    assert icd.find_nvidia({"LD_LIBRARY_PATH": f"relative/dir:{tmp_path / 'none'}:{second.parent}:{first.parent}"}) \
        == second
    assert icd.find_nvidia({}, dirs=[str(tmp_path / "none")]) is None
    assert icd.find_nvidia({}, dirs=["a", str(first.parent)]) == first       # a relative directory is skipped
    assert "/usr/local/nvidia/lib64" in icd.NVIDIA_DIRS


def test_a_driver_library_that_cannot_load_hides_no_device(tmp_path):
    """An NVIDIA library that is no driver (here an empty file: a machine without the GPU or
    its kernel module) is registered, and the loader skips it: every device seen before is
    still there."""
    lib = _nvidia(tmp_path, "driver")
    code = ("import json, texray.device.icd as i, texray.device as d; "
            "print(json.dumps([i.registered is not None, sorted(x.name for x in d.devices())]))")
    runs = []
    for extra in ({"TEXRAY_NO_ICD": "1"}, {"LD_LIBRARY_PATH": str(lib.parent)}):
        env = {k: v for k, v in os.environ.items() if k not in ("OCL_ICD_VENDORS", "LD_LIBRARY_PATH", "TEXRAY_NO_ICD")}
        env.update(extra, XDG_CACHE_HOME=str(tmp_path / "cache"))
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stderr[-2000:]
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    assert runs[1][0], "nothing registered"
    assert set(runs[0][1]) <= set(runs[1][1]) and runs[0][1]
    listed = [p.read_text().strip() for p in (tmp_path / "cache" / "texray" / "icd").rglob("*.icd")]
    assert str(lib) in listed


def test_the_cache_root_follows_xdg(tmp_path):
    assert icd.cache_root({"XDG_CACHE_HOME": str(tmp_path)}) == tmp_path / "texray" / "icd"


INTEL = [d for d in PORTABILITY_DEVICES if d.platform.startswith("Intel(R) OpenCL") and d.type == "cpu"]
POCL = [d for d in PORTABILITY_DEVICES if "Portable Computing Language" in d.platform]
needs_intel = pytest.mark.skipif(not (INTEL and POCL), reason="needs Intel's OpenCL CPU runtime and PoCL")


def test_the_installed_wheel_is_found_and_listed_once():
    lib = icd.find_runtime()
    if lib is None:
        pytest.skip("intel-opencl-rt is not installed")
    assert lib.name == "libintelocl.so" and lib.is_file()
    names = [(d.platform, d.name) for d in tx.devices()]
    intel = sum(p.startswith("Intel(R) OpenCL") for p, _ in names)
    assert intel == 1 if icd.registered is not None else intel <= 1, (names, icd.registered)
    assert sum("Portable Computing Language" in p for p, _ in names) == 1, names      # PoCL not hidden, not twice


# Every primitive kind (triangles with vertex normals, spheres, cylinders, quads,
# displaced shapes), projection mappings, bump and normal maps, the texture roles.
SCENES = ["showcase.toml", "bench/globe.toml", "bench/displaced_wall.toml", "bump/normal_mesh.toml",
          "mappings/projection.toml", "bench/textured_meshes.toml"]


@needs_intel
@pytest.mark.parametrize("path", SCENES)
def test_vectorized_renders_match_pocl(scenes_dir, path):
    """With the AOVs of test_devices_agree.py (the same programs: their builds, 5-18 s each on
    Intel's compiler, are paid once per run), whose values are held to PoCL's as there."""
    scene = tx.Scene.load(scenes_dir / path)
    aovs = ("shading_normal", "uv")
    for pipeline in ("fused", "stages"):
        ref = render(scene, 64, 48, 1, device=POCL[0].index, seed=1, pipeline=pipeline, aovs=aovs)
        for local in (8, 16, 64):
            img = render(scene, 64, 48, 1, device=INTEL[0].index, seed=1, pipeline=pipeline, local_size=local,
                         aovs=aovs)
            diff = np.abs(img.rgb - ref.rgb).max(axis=2)
            where = f"{path}, {pipeline}, local size {local}"
            assert np.mean(diff > 0.02) <= 1e-3, f"{where}: {np.mean(diff > 0.02):.3%} of pixels differ by > 0.02"
            assert diff[diff <= 0.02].mean() < 1e-4, f"{where}: mean abs difference {diff[diff <= 0.02].mean():.2g}"
            for a in aovs:
                same = np.isfinite(ref.aov[a]) & np.isfinite(img.aov[a])
                assert np.mean(np.abs(img.aov[a] - ref.aov[a])[same] > 1e-3) <= 2e-3, (where, a)


@needs_intel
def test_the_default_local_size_runs_vectorized(scenes_dir):
    """LOCAL_SIZES["intel-cpu"] is a multiple of every vector width the build log reports:
    a smaller work-group (or its remainder) runs as scalar code. Built past pyopencl's
    binary cache (Runtime.program's source and options), whose reloads log no vectorization."""
    rt = runtime(INTEL[0].index)
    cs = compile_scene(tx.Scene.load(scenes_dir / "bench/globe.toml"))
    options = [f"-D{k}={int(v)}" for k, v in sorted(compile_options(cs.features).items())]
    prg = cl.Program(rt.context, opencl.opencl_prelude() + '#include "texray.cl"\n').build(
        options=options + ["-I", str(opencl.KERNEL_DIR), "-cl-std=CL1.2"], cache_dir=False)
    log = prg.get_build_info(rt.device, cl.program_build_info.LOG)
    widths = {int(w) for w in re.findall(r'Kernel "\w+" was successfully vectorized \((\d+)\)', log)}
    assert widths, log[-2000:]
    assert all(opencl.LOCAL_SIZES["intel-cpu"] % w == 0 for w in widths), (widths, opencl.LOCAL_SIZES)
    assert rt.local_size() == opencl.LOCAL_SIZES["intel-cpu"]


@needs_intel
@pytest.mark.parametrize("path", ["bench/globe.toml", "bench/brick_wall.toml"])
def test_forced_packets_use_work_groups_of_one_and_match_pocl(scenes_dir, path, monkeypatch):
    """Packets on Intel's runtime are the user's choice (TEXRAY_PACKET=8: its packet programs
    build 2-3x slower); then they run in work-groups of one (opencl.PACKET_LOCAL_SIZES), at 2
    spp with four pixels per work-item; by default none, at the vectorized local size. Every
    image agrees with PoCL's within the device-agreement tolerance."""
    monkeypatch.delenv("TEXRAY_LOCAL_SIZE", raising=False)
    scene = tx.Scene.load(scenes_dir / path)
    one, vec = opencl.PACKET_LOCAL_SIZES["intel-cpu"], opencl.LOCAL_SIZES["intel-cpu"]
    for spp, packet, local in ((16, 8, one), (2, 8, one), (2, 0, vec)):
        monkeypatch.setenv("TEXRAY_PACKET", "8") if packet else monkeypatch.delenv("TEXRAY_PACKET", raising=False)
        ref = render(scene, 48, 32, spp, device=POCL[0].index, seed=1).rgb
        got = render(scene, 48, 32, spp, device=INTEL[0].index, seed=1)
        assert (got.stats["packet"], got.stats["local_size"]) == (packet, local), got.stats
        diff = np.abs(got.rgb - ref).max(axis=2)
        assert np.mean(diff > 0.02) <= 1e-3, f"{path} at {spp} spp: {np.mean(diff > 0.02):.3%} of pixels differ"
        assert diff[diff <= 0.02].mean() < 1e-4, f"{path} at {spp} spp: mean abs difference {diff[diff <= 0.02].mean():.2g}"
    rt = runtime(INTEL[0].index)
    assert rt.local_size(None, 8) == 1 and rt.local_size(None, 0) == opencl.LOCAL_SIZES["intel-cpu"]
    assert rt.local_size(4, 8) == 4                    # an explicit size wins


# What the kernels' workaround relies on, on every device: a large helper with several
# callers (left out of line, given a vector variant by a vectorizing compiler) receives its
# float4 arguments intact in every work-item. (Intel's compiler 2026.2 fails this with
# float3 arguments: lane k reads floats 4k..4k+2 of the 3-float-strided array its caller
# packed, so lane 1 of (x_i, 2, 3) reads (2, 3, x_2).)
_OUT_OF_LINE = r"""
__attribute__((noinline)) float pick(float4 o, __global const float* tab, uint gid)
{
    float s = tab[gid % 7u];
    return o.x + 10.0f * o.y + 100.0f * o.z + s;
}
__kernel void first(__global const float* in, __global const float* tab, __global float* out, uint n)
{
    uint gid = get_global_id(0);
    if (gid < n) out[gid] = pick((float4)(in[gid], 2.0f, 3.0f, 0.0f), tab, gid);
}
__kernel void second(__global const float* in, __global const float* tab, __global float* out, uint n)
{
    uint gid = get_global_id(0);
    if (gid < n) out[gid] = pick((float4)(0.0f), tab, gid) + in[gid];
}
"""


def test_float4_arguments_of_out_of_line_helpers_reach_every_work_item(any_rt):
    n = 256
    x = np.arange(n, dtype=np.float32) * 1000
    tab = np.zeros(7, np.float32)
    prg = any_rt.build(_OUT_OF_LINE)
    mf = cl.mem_flags
    bx = cl.Buffer(any_rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
    bt = cl.Buffer(any_rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tab)
    bo = cl.Buffer(any_rt.context, mf.WRITE_ONLY, x.nbytes)
    out = np.empty_like(x)
    local = min(64, any_rt.device.max_work_group_size)
    cl.Kernel(prg, "first")(any_rt.queue, (n,), (local,), bx, bt, bo, np.uint32(n))
    cl.enqueue_copy(any_rt.queue, out, bo)
    bad = np.nonzero(out != x + 320)[0]
    assert len(bad) == 0, f"work-items {bad[:8]} got {out[bad[:8]] - x[bad[:8]]} + x, want 320 + x"
