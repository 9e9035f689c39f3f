"""Time to first image with and without the scene cache (the README's "Scene cache"),
and Mitsuba 3's for the same scene (``--mitsuba``; texray[peers]).

    python tools/scene_cache_timing.py [--repeat 3] [--size 1024] [--subdivisions 8] [--mitsuba]

A trimesh icosphere (subdivisions 8: 1,310,720 triangles) as numpy arrays, one light,
rendered at SIZE x SIZE, 1 spp, each run a fresh process timed from tx.Scene(...) to
the image: uncached (cache=False), then the first cached run (miss, stored) and the
second (hit), in an empty temporary cache folder, REPEAT times; prints the medians.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import json, sys, time
import numpy as np
import texray as tx
d = np.load(sys.argv[1])
positions, faces, size, cache = d["positions"], d["faces"], int(sys.argv[2]), sys.argv[3] == "on"
t0 = time.perf_counter()
scene = tx.Scene(camera=tx.Camera(eye=(0, 0.5, 3.2), look_at=(0, 0, 0), fov_y=40),
                 lights=[tx.PointLight((3, 4, 5), (40, 40, 40))], ambient=(0.05, 0.05, 0.05))
scene.add(tx.Mesh(positions, faces, material=tx.Material(diffuse=(0.8, 0.3, 0.2)), name="icosphere"))
t_scene = time.perf_counter()
img = tx.render(scene, size, size, 1, cache=cache)
t1 = time.perf_counter()
s = img.stats
out = {k: s[k] for k in ("scene_cache", "scene_cache_hash_s", "scene_cache_load_s", "scene_cache_store_s",
                         "scene_compile_s", "bvh_build_s", "program_build_s", "upload_s", "render_s")}
out.update(scene_s=t_scene - t0, first_launch_s=t_scene - t0 + s["scene_compile_s"] + s["program_build_s"]
           + s["upload_s"], image_s=t1 - t0, triangles=s["triangles"], checksum=float(img.rgb.astype(np.float64).sum()))
print(json.dumps(out))
"""
# Mitsuba 3 (llvm_ad_rgb, direct) on the same tx.Scene through texray.bench.peers: conversion and
# mi.load_dict (its Embree BVH build) as "compile", its first render (JIT, or its disk cache) as "render".
CHILD_MITSUBA = """
import json, sys, time
import numpy as np
import texray as tx
from texray.bench.peers import mitsuba_render
d = np.load(sys.argv[1])
positions, faces, size = d["positions"], d["faces"], int(sys.argv[2])
t0 = time.perf_counter()
scene = tx.Scene(camera=tx.Camera(eye=(0, 0.5, 3.2), look_at=(0, 0, 0), fov_y=40),
                 lights=[tx.PointLight((3, 4, 5), (40, 40, 40))])
scene.add(tx.Mesh(positions, faces, material=tx.Material(diffuse=(0.8, 0.3, 0.2)), name="icosphere"))
t_scene = time.perf_counter()
rgb, s = mitsuba_render(scene, size, size, 1, repeat=0)
t1 = time.perf_counter()
print(json.dumps({"scene_cache": "mitsuba", "scene_s": t_scene - t0, "scene_compile_s": s["load_s"],
                  "render_s": s["first_render_s"], "first_launch_s": t_scene - t0 + s["load_s"], "image_s": t1 - t0,
                  "variant": s["variant"]}))
"""
FIELDS = {"scene_s": "scene", "scene_cache_hash_s": "hash", "scene_cache_load_s": "load",
          "scene_cache_store_s": "store", "scene_compile_s": "compile", "bvh_build_s": "(bvh)",
          "program_build_s": "program", "upload_s": "upload", "render_s": "render", "first_launch_s": "1st launch",
          "image_s": "image"}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--size", type=int, default=1024)
    p.add_argument("--subdivisions", type=int, default=8)
    p.add_argument("--mitsuba", action="store_true", help="also time Mitsuba 3 on the scene, interleaved")
    args = p.parse_args(argv)
    import numpy as np
    import trimesh
    with tempfile.TemporaryDirectory() as tmp:
        mesh = trimesh.creation.icosphere(subdivisions=args.subdivisions)
        arrays = Path(tmp) / "mesh.npz"
        np.savez(arrays, positions=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces))
        env = {**os.environ, "PYTHONPATH": str(ROOT / "pyhost"), "TEXRAY_CACHE_DIR": str(Path(tmp) / "cache")}
        env.pop("TEXRAY_NO_CACHE", None)
        runs = {}
        for _ in range(args.repeat):
            for f in (Path(tmp) / "cache").glob("*"):
                f.unlink()
            for mode in ("off", "on", "on") + (("mitsuba",) if args.mitsuba else ()):
                child = CHILD_MITSUBA if mode == "mitsuba" else CHILD
                out = subprocess.run([sys.executable, "-c", child, str(arrays), str(args.size), mode], env=env,
                                     capture_output=True, text=True, check=True)
                r = json.loads(out.stdout.strip().splitlines()[-1])
                runs.setdefault(r["scene_cache"], []).append(r)
    checksums = {r["checksum"] for rs in runs.values() for r in rs if "checksum" in r}
    print(f"{runs['off'][0]['triangles']} triangles, {args.size}x{args.size}, 1 spp; medians of {args.repeat} "
          f"fresh processes; images {'identical' if len(checksums) == 1 else 'DIFFER'}")
    print("seconds " + "".join(f"{label:>11}" for label in FIELDS.values()))
    for status in ("off", "miss", "stored", "hit", "mitsuba"):
        rs = runs.get(status, [])
        if rs:
            print(f"{status:8}" + "".join(f"{statistics.median(r[f] for r in rs):11.3f}" if f in rs[0] else
                                          f"{'-':>11}" for f in FIELDS))
    if "mitsuba" in runs:
        tx_s = statistics.median(r["image_s"] for r in runs["off"])
        mi_s = statistics.median(r["image_s"] for r in runs["mitsuba"])
        print(f"time to first image, uncached: texray {tx_s:.2f} s, Mitsuba 3 ({runs['mitsuba'][0]['variant']}) "
              f"{mi_s:.2f} s: ratio Mitsuba/texray {mi_s / tx_s:.2f} (> 1: texray first)")


if __name__ == "__main__":
    main()
