"""``texray bench``: the kernel benchmark.

Measures, on every OpenCL device (or the ones chosen):

* BVH build time and SAH cost for a 1M-triangle mesh (host side, once);
* closest-hit throughput of 1024^2 pixel-centre primary rays on that mesh and
  any-hit throughput of shadow rays from the hits toward a point light
  (the work of peers.md's Embree figures);
* frame time of the showcase scene at 1 and 16 spp, with each kernel stage
  timed by OpenCL profiling events.

Every figure is the median over ``--repeat`` runs after one warm-up run, with
the spread (min-max) beside it. Prints a table and writes JSON.
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from . import __version__


def _median_spread(values):
    return {"median": statistics.median(values), "min": min(values), "max": max(values), "n": len(values)}


def _git_commit():
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=Path(__file__).resolve().parent, timeout=5).stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        return None


def bench_mesh_scene(triangles):
    from . import procedural
    from .scene import Camera, Mesh, PointLight, Scene
    m = procedural.bench_mesh(triangles)
    scene = Scene(camera=Camera(eye=(0.0, 0.4, 3.2), look_at=(0, 0, 0), fov_y=40),
                  lights=[PointLight((3.0, 4.0, 5.0), (40, 40, 40))])
    scene.add(Mesh(m.positions, m.faces, name=f"bench_mesh({triangles})"))
    return scene


def bench_bvh(scene, repeat):
    from . import bvh
    from .compile import compile_scene
    cs = compile_scene(scene)
    from .compile import triangle_bounds
    lo, hi = triangle_bounds(cs.tri_verts)
    times, tree = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        tree = bvh.build(lo, hi)
        times.append(time.perf_counter() - t0)
    return cs, {"triangles": int(len(lo)), "build_s": _median_spread(times), "sah_cost": tree.sah_cost,
                "nodes": int(len(tree.nodes)), "depth": tree.depth}


def bench_rays(cs, scene, device, size, repeat):
    """Closest-hit Mrays/s of pixel-centre primary rays and any-hit Mrays/s of shadow rays."""
    from .trace import Tracer
    tracer = Tracer(cs, device)
    eye, fwd, right, up = scene.camera.basis(1.0)
    px = (np.arange(size) + 0.5) / size * 2 - 1
    x, y = np.meshgrid(px, -px)
    dirs = (fwd + x[..., None] * right + y[..., None] * up).reshape(-1, 3).astype(np.float32)
    org = np.broadcast_to(eye.astype(np.float32), dirs.shape)
    primary, shadow, hits = [], [], None
    for i in range(repeat + 1):
        hits = tracer.closest(org, dirs)
        if i:
            primary.append(len(dirs) / hits.seconds * 1e-6)
    hit = hits.prim >= 0
    p = org[hit] + hits.t[hit, None] * dirs[hit]
    n = p / np.linalg.norm(p, axis=1, keepdims=True)          # the bench mesh is star-shaped about 0
    so = (p + 1e-4 * n).astype(np.float32)
    sd = (np.asarray(scene.lights[0].position, np.float32) - so).astype(np.float32)
    for i in range(repeat + 1):
        occ, secs = tracer.occluded(so, sd, 0.0, 1.0)
        if i:
            shadow.append(len(so) / secs * 1e-6)
    return {"rays": int(len(dirs)), "hit_fraction": float(hit.mean()),
            "primary_mrays_s": _median_spread(primary),
            "shadow_rays": int(len(so)), "shadow_occluded_fraction": float(occ.mean()),
            "shadow_mrays_s": _median_spread(shadow)}


def bench_frame(scene, device, width, height, spp, repeat):
    from .render import render
    render(scene, width, height, spp, device=device)               # warm-up: builds the program
    runs = [render(scene, width, height, spp, device=device).stats for _ in range(repeat)]
    stages = {k: _median_spread([r["stage_s"][k] for r in runs]) for k in runs[0]["stage_s"]}
    frame = _median_spread([r["render_s"] for r in runs])
    samples = width * height * spp
    return {"width": width, "height": height, "spp": spp, "frame_s": frame,
            "msamples_s": samples / frame["median"] * 1e-6,
            "primary_mrays_s": samples / stages["intersect"]["median"] * 1e-6 if stages["intersect"]["median"] else None,
            "stage_s": stages, "program_build_s": runs[0]["program_build_s"],
            "device_bytes": runs[0]["device_bytes"]}


def _print_device(name, r, out):
    rays = r["rays"]
    out.write(f"\n== {name}\n")
    out.write(f"  primary rays  {rays['rays']:>9} rays, {100 * rays['hit_fraction']:.0f}% hit: "
              f"{rays['primary_mrays_s']['median']:7.2f} Mrays/s "
              f"({rays['primary_mrays_s']['min']:.2f}-{rays['primary_mrays_s']['max']:.2f})\n")
    out.write(f"  shadow rays   {rays['shadow_rays']:>9} rays, {100 * rays['shadow_occluded_fraction']:.0f}% occluded: "
              f"{rays['shadow_mrays_s']['median']:7.2f} Mrays/s "
              f"({rays['shadow_mrays_s']['min']:.2f}-{rays['shadow_mrays_s']['max']:.2f})\n")
    for f in r["frames"]:
        st = "  ".join(f"{k} {1e3 * v['median']:.1f}" for k, v in f["stage_s"].items())
        out.write(f"  showcase {f['width']}x{f['height']} {f['spp']:>2} spp: {1e3 * f['frame_s']['median']:8.1f} ms "
                  f"({1e3 * f['frame_s']['min']:.1f}-{1e3 * f['frame_s']['max']:.1f}), "
                  f"{f['msamples_s']:.2f} Msamples/s; stages ms: {st}\n")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="texray bench", description=__doc__.splitlines()[0])
    ap.add_argument("--device", action="append",
                    help="device to run on (repeatable; default: every CPU and GPU device found)")
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per figure, after one warm-up (default 5)")
    ap.add_argument("--triangles", type=int, default=1_000_000, help="bench mesh size (default 1M)")
    ap.add_argument("--rays", type=int, default=1024, help="primary rays per side (default 1024)")
    ap.add_argument("--scene", default=None, help="showcase scene file (default: scenes/showcase.toml)")
    ap.add_argument("--size", default="640x480", help="showcase frame size WxH (default 640x480)")
    ap.add_argument("--spp", type=int, action="append", help="showcase spp (repeatable; default 1 and 16)")
    ap.add_argument("--json", default="bench.json", help="where to write the JSON results (default bench.json)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error("--repeat must be >= 1")
    from .device import devices
    from .scene import Scene
    chosen = args.device or [d.index for d in devices() if d.type in ("cpu", "gpu")]
    chosen = [int(d) if isinstance(d, str) and d.isdigit() else d for d in chosen]
    scene_path = Path(args.scene) if args.scene else _default_scene()
    width, height = (int(v) for v in args.size.lower().split("x"))
    spps = args.spp or [1, 16]

    out = sys.stdout
    out.write(f"texray {__version__} bench: {platform.node()} {platform.processor() or platform.machine()}, "
              f"repeat {args.repeat}\n")
    mesh_scene = bench_mesh_scene(args.triangles)
    cs, bvh_result = bench_bvh(mesh_scene, max(1, min(args.repeat, 3)))
    out.write(f"BVH: {bvh_result['triangles']} triangles in {bvh_result['build_s']['median']:.2f} s "
              f"({bvh_result['build_s']['min']:.2f}-{bvh_result['build_s']['max']:.2f}), "
              f"SAH cost {bvh_result['sah_cost']:.2f}, {bvh_result['nodes']} nodes, depth {bvh_result['depth']}\n")
    showcase = Scene.load(scene_path)
    results = {"texray": __version__, "commit": _git_commit(), "host": platform.node(),
               "argv": sys.argv[1:] if argv is None else list(argv), "repeat": args.repeat,
               "bvh": bvh_result, "devices": {}}
    from .device import select_device
    for dev in chosen:
        name = select_device(dev).name.strip()
        r = {"rays": bench_rays(cs, mesh_scene, dev, args.rays, args.repeat),
             "frames": [bench_frame(showcase, dev, width, height, s, args.repeat) for s in spps]}
        results["devices"][name] = r
        _print_device(name, r, out)
    Path(args.json).write_text(json.dumps(results, indent=1, default=str))
    out.write(f"\nwrote {args.json}\n")
    return 0


def _default_scene():
    here = Path(__file__).resolve()
    for base in (Path.cwd(), here.parents[2]):
        p = base / "scenes" / "showcase.toml"
        if p.is_file():
            return p
    raise SystemExit("texray bench: scenes/showcase.toml not found; pass --scene")


if __name__ == "__main__":
    sys.exit(main())
