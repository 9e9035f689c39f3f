#!/usr/bin/env python3
"""The two BVH builders A/B on the bench's mesh: build time, SAH cost and the rays' rate.

    python tools/bvh_ab.py [--triangles 1000000] [--rounds 5]

Both trees (compile_scene(..., bvh_builder="numpy" | "cells")) in one process; the bench's
1024x1024 pixel-centre primary rays and their shadow rays toward the light
(texray.bench.rays, texray.bench.peers), traced through texray.renderer.trace.Tracer on the
default device, interleaved, the first round dropped; medians. The README's "Time to first
image" quotes it.
"""
import argparse
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pyhost"))

from texray.bench.peers import primary_rays, shadow_rays  # noqa: E402
from texray.bench.rays import bench_mesh_scene  # noqa: E402
from texray.compile import compile_scene  # noqa: E402
from texray.renderer.trace import Tracer  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args(argv)
    scene = bench_mesh_scene(a.triangles)
    org, dirs = primary_rays(scene.camera, 1024)
    builders = ("numpy", "cells")
    compiled = {b: compile_scene(scene, bvh_builder=b) for b in builders}
    tracers = {b: Tracer(cs) for b, cs in compiled.items()}
    rates = {b: ([], []) for b in builders}
    for r in range(a.rounds):
        for b, t in tracers.items():
            h = t.closest(org, dirs)
            so, sd = shadow_rays(org, dirs, h.t, h.prim >= 0, scene.lights[0].position)
            _, secs = t.occluded(so, sd, 0.0, 1.0)
            if r:
                rates[b][0].append(len(dirs) / h.seconds * 1e-6)
                rates[b][1].append(len(so) / secs * 1e-6)
    med = {b: (statistics.median(p), statistics.median(s)) for b, (p, s) in rates.items()}
    for b in builders:
        cs = compiled[b]
        print(f"{b:6} build {cs.bvh.build_seconds:.2f} s, SAH cost {cs.bvh.sah_cost:.2f}; primary "
              f"{med[b][0]:.2f} Mrays/s, shadow {med[b][1]:.2f} Mrays/s (medians of {a.rounds - 1})")
    print(f"cells / numpy: primary {med['cells'][0] / med['numpy'][0]:.3f}, shadow {med['cells'][1] / med['numpy'][1]:.3f}")


if __name__ == "__main__":
    main()
