"""Kernel build times, cold and warm, measured in a fresh process.

``python -m texray.bench.buildtime SCENE [--device D] [--generic]`` loads a scene,
then times building the program a render at the scene file's spp uses (OpenCL
``clBuildProgram``) plus the code generation that drivers defer to a kernel's first launch (PoCL compiles each
kernel for its work-group size when it is first enqueued), and prints JSON.
:func:`measure` runs it twice in subprocesses that share a fresh, empty cache
directory: the first run is cold (nothing cached: PoCL's kernel cache, the
NVIDIA driver's cache and pyopencl's binary cache all point into it), the
second is warm (what every later run of the same scene pays).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

from ..compile import compile_scene
from ..device import runtime
from ..device.features import compile_options, generic_features
from ..renderer import render
from ..renderer.frame import launch_samples
from ..scene import Scene


def _time_build(scene_path, device, specialize):
    scene = Scene.load(scene_path)
    cs = compile_scene(scene)
    features = cs.features if specialize else generic_features(cs.features)
    rt = runtime(device)
    # The program the scene renders with: its file's spp (the samples per launch choose the
    # packets' pixels, TX_MULTI_PIXEL), which the 16x16 probe below takes too, so that it
    # launches that program. (Until 2026-12-08 every scene's probe was at 1 spp, with the
    # program of 4 samples a launch: the scenes at 16 spp render with another, 3% fewer
    # instructions to build for the globe and the textured meshes.)
    spp = int((getattr(scene, "render_settings", None) or {}).get("spp", 1))
    t0 = time.perf_counter()
    rt.program(compile_options(features, rt.kind, launch_samples(16, 16, spp), stages=False))   # render's fused one
    t_build = time.perf_counter() - t0
    # First launches: deferred per-kernel code generation. A second identical render
    # costs the same minus the code generation, so the difference is its cost. Both
    # renders take the compiled scene (no second BVH build) and leave out their scene
    # upload (image.stats["upload_s"]: the first touches fresh memory, which is not
    # the program's cost; a 100 MiB mesh made it 0.7 s).
    def launch_s():
        s = render(scene, 16, 16, spp, device=device, specialize=specialize, compiled=cs).stats
        return s["render_s"] - s["upload_s"]
    first = launch_s()
    second = launch_s()
    return {"program_s": t_build, "first_launch_s": max(first - second, 0.0),
            "build_s": t_build + max(first - second, 0.0), "device": rt.device.name.strip(), "spp": spp}


def measure(scene_path, device=None, specialize=True, timeout=600, repeat=1) -> dict:
    """{"cold_s", "warm_s", ...}: build times of the scene's program in two fresh processes,
    the medians of ``repeat`` such pairs, each pair with a cache of its own (``cold_runs`` and
    ``warm_runs``: every pair's; one cold build on this shared machine moved by 20-30% from
    one run to the next, the mixed scene's 1.75-2.17 s on 2026-12-07)."""
    cmd = [sys.executable, "-m", "texray.bench.buildtime", str(scene_path)]
    if device is not None:
        cmd += ["--device", str(device)]
    if not specialize:
        cmd.append("--generic")
    pairs = []
    for _ in range(max(1, int(repeat))):
        with tempfile.TemporaryDirectory(prefix="texray-buildcache-") as cache:
            env = dict(os.environ, XDG_CACHE_HOME=cache, POCL_CACHE_DIR=os.path.join(cache, "pocl"),
                       CUDA_CACHE_PATH=os.path.join(cache, "nv"), PYOPENCL_NO_CACHE="0")
            runs = []
            for _ in range(2):
                out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
                if out.returncode != 0:
                    raise RuntimeError(f"texray.bench.buildtime {scene_path} failed:\n{out.stderr[-2000:]}")
                runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
            pairs.append(runs)
    med = lambda key, i: statistics.median(p[i][key] for p in pairs)
    return {"cold_s": med("build_s", 0), "warm_s": med("build_s", 1),
            "cold_program_s": med("program_s", 0), "cold_first_launch_s": med("first_launch_s", 0),
            "cold_runs": [p[0]["build_s"] for p in pairs], "warm_runs": [p[1]["build_s"] for p in pairs]}


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m texray.bench.buildtime", description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--device")
    ap.add_argument("--generic", action="store_true", help="time the generic program instead")
    a = ap.parse_args(argv)
    device = int(a.device) if a.device is not None and a.device.isdigit() else a.device
    print(json.dumps(_time_build(a.scene, device, not a.generic)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
