"""``texray bench``: the kernel benchmark.

Measures, on every OpenCL device (or the ones chosen with ``--device``):

* BVH build time and SAH cost of a 1M-triangle mesh (host side, once);
* closest-hit throughput of 1024^2 pixel-centre primary rays on that mesh and
  any-hit throughput of shadow rays from the hits toward a point light (the
  work of peers.md's Embree figures);
* the suite ``scenes/bench/`` (1M-triangle mesh, textured globe, textured quad
  at grazing angles, every primitive and mapping mixed): frame time and each
  kernel stage (OpenCL profiling events) for the program specialized to the
  scene and for the generic program with every feature compiled in; cold and
  warm build times of both (fresh processes); device memory;
* ``--sweep``: the speed/accuracy knobs (spp, texture filtering) against a
  reference image, as a table and an error-against-time plot (``--plot``);
* ``--local-sizes``: frame time per work-group size;
* ``--peers``: Embree and Mitsuba 3 on the same work (``texray[peers]``).

Every figure is the median over ``--repeat`` runs after one warm-up run, with
the spread (min-max) beside it. Prints tables, writes JSON (``--json``) and a
markdown report (``--report``); ``--compare A.json B.json`` prints the ratios
between two runs.
"""
from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__
from .bench_report import compare, markdown, print_device
from .bench_suite import (SUITE, bench_scene, build_times, local_size_sweep, median_spread, program_variants,
                          scenes_dir, suite_paths)
from .bench_sweep import SPP_VALUES, displaced, plot, sweep_scene


def _git_commit():
    """The commit of the source tree the bench runs from (the working directory's
    repository, else the package's), or None."""
    for where in (Path.cwd(), Path(__file__).resolve().parent):
        try:
            out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                 cwd=where, timeout=5).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            continue
        if out:
            return out
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
    """(compiled scene, BVH figures): the scene's compile time and the SAH build of its triangles."""
    from . import bvh
    from .compile import compile_scene, triangle_bounds
    t0 = time.perf_counter()
    cs = compile_scene(scene)
    compile_s = time.perf_counter() - t0
    lo, hi = triangle_bounds(cs.tri_verts)
    times, tree = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        tree = bvh.build(lo, hi)
        times.append(time.perf_counter() - t0)
    return cs, {"triangles": int(len(lo)), "build_s": median_spread(times), "sah_cost": tree.sah_cost,
                "nodes": int(len(tree.nodes)), "depth": tree.depth, "scene_compile_s": compile_s}


@dataclass
class RayWork:
    """The rays bench_rays traced and texray's answers, for the peers to trace the same."""
    compiled: object         # CompiledScene of the bench mesh
    mesh: object             # its texray.Mesh (positions, faces)
    org: np.ndarray
    dirs: np.ndarray
    hits: object             # texray.trace.Hits of the primary rays
    shadow_org: np.ndarray
    shadow_dirs: np.ndarray
    occluded: np.ndarray


def bench_rays(cs, scene, device, size, repeat):
    """(figures, RayWork): closest-hit Mrays/s of size^2 pixel-centre primary rays and
    any-hit Mrays/s of shadow rays from their hits toward the first light."""
    from .peers import primary_rays, shadow_rays
    from .trace import Tracer
    tracer = Tracer(cs, device)
    org, dirs = primary_rays(scene.camera, size)
    primary, shadow, hits = [], [], None
    for i in range(repeat + 1):
        hits = tracer.closest(org, dirs)
        if i:
            primary.append(len(dirs) / hits.seconds * 1e-6)
    hit = hits.prim >= 0
    so, sd = shadow_rays(org, dirs, hits.t, hit, scene.lights[0].position)
    for i in range(repeat + 1):
        occ, secs = tracer.occluded(so, sd, 0.0, 1.0)
        if i:
            shadow.append(len(so) / secs * 1e-6)
    figures = {"device": tracer.rt.device.name.strip(), "triangles": int(len(cs.tri_verts)),
               "rays": int(len(dirs)), "hit_fraction": float(hit.mean()),
               "primary_mrays_s": median_spread(primary),
               "shadow_rays": int(len(so)), "shadow_occluded_fraction": float(occ.mean()),
               "shadow_mrays_s": median_spread(shadow)}
    return figures, RayWork(cs, scene.objects[0], org, dirs, hits, so, sd, occ)


def _csv_ints(text, what):
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise SystemExit(f"texray bench: {what}: expected comma-separated integers, got {text!r}") from None


def _size(text):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        assert w > 0 and h > 0
        return w, h
    except (ValueError, AssertionError):
        raise SystemExit(f"texray bench: expected a size WxH, got {text!r}") from None


def main(argv=None):
    ap = argparse.ArgumentParser(prog="texray bench", description=__doc__.splitlines()[0])
    ap.add_argument("--compare", nargs=2, metavar=("A.json", "B.json"),
                    help="print ratios B/A between two earlier runs, and exit")
    ap.add_argument("--from-json", metavar="RUN.json",
                    help="write --report and --plot for an earlier run instead of running")
    ap.add_argument("--device", action="append",
                    help="device to run on (repeatable; default: every CPU and GPU device found)")
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per figure, after one warm-up (default 5)")
    ap.add_argument("--scenes", default=",".join(SUITE),
                    help=f"suite scenes (names in scenes/bench/ or .toml paths), comma-separated "
                         f"(default {','.join(SUITE)}; '' for none)")
    ap.add_argument("--size", default=None, help="frame size WxH for every suite scene (default: each scene's)")
    ap.add_argument("--spp", type=int, default=None, help="spp for every suite scene (default: each scene's)")
    ap.add_argument("--no-generic", action="store_true", help="skip the generic-program comparison")
    ap.add_argument("--no-build", action="store_true", help="skip cold/warm build timing")
    ap.add_argument("--triangles", type=int, default=1_000_000, help="ray-throughput mesh size (default 1M)")
    ap.add_argument("--rays", type=int, default=1024, help="primary rays per side (default 1024; 0: skip)")
    ap.add_argument("--sweep", default="", help="scenes to sweep speed/accuracy knobs on, comma-separated "
                                                "(e.g. globe,grazing_quad; displaced scenes such as "
                                                "terrain,displaced_wall,planet sweep the displacement "
                                                "methods against their tessellation)")
    ap.add_argument("--sweep-size", default="320x240", help="frame size of the sweeps (default 320x240)")
    ap.add_argument("--ref-spp", type=int, default=256, help="spp of the sweeps' reference images (default 256)")
    ap.add_argument("--sweep-spp", default=",".join(map(str, SPP_VALUES)), help="spp values swept")
    ap.add_argument("--local-sizes", default="", help="work-group sizes to time on the mixed scene, "
                                                      "e.g. 0,16,32,64,128 (0 = driver's choice)")
    ap.add_argument("--peers", action="store_true", help="also run the peers (pip install texray[peers])")
    ap.add_argument("--json", default="bench.json", help="JSON results (default bench.json)")
    ap.add_argument("--report", default=None, help="also write a markdown report here")
    ap.add_argument("--plot", default=None, help="error-against-time plot of the sweeps (PNG; needs matplotlib)")
    args = ap.parse_args(argv)
    out = sys.stdout
    if args.compare:
        return compare(*args.compare, out)
    if args.from_json:
        results = json.loads(Path(args.from_json).read_text())
        for dname, r in results["devices"].items():
            print_device(dname, r, out)
        _write_outputs(results, args, out)
        return 0
    if args.repeat < 1:
        ap.error("--repeat must be >= 1")
    from .compile import compile_scene
    from .device import devices, select_device
    from .scene import Scene
    chosen = args.device or [d.index for d in devices() if d.type in ("cpu", "gpu")]
    chosen = [int(d) if isinstance(d, str) and d.isdigit() else d for d in chosen]
    size = _size(args.size) if args.size else None
    sweep_w, sweep_h = _size(args.sweep_size)
    paths = suite_paths([n for n in args.scenes.split(",") if n.strip()]) if args.scenes.strip() else {}
    sweep_paths = suite_paths([n for n in args.sweep.split(",") if n.strip()]) if args.sweep.strip() else {}

    out.write(f"texray {__version__} bench: {platform.node()} {platform.processor() or platform.machine()}, "
              f"repeat {args.repeat}\n")
    results = {"texray": __version__, "commit": _git_commit(), "host": platform.node(),
               "date": time.strftime("%Y-%m-%d %H:%M"), "argv": sys.argv[1:] if argv is None else list(argv),
               "repeat": args.repeat, "devices": {}}
    mesh_scene = cs_mesh = None
    if args.rays:
        mesh_scene = bench_mesh_scene(args.triangles)
        cs_mesh, results["bvh"] = bench_bvh(mesh_scene, max(1, min(args.repeat, 3)))
        b = results["bvh"]
        out.write(f"BVH: {b['triangles']} triangles in {b['build_s']['median']:.2f} s "
                  f"({b['build_s']['min']:.2f}-{b['build_s']['max']:.2f}), SAH cost {b['sah_cost']:.2f}, "
                  f"{b['nodes']} nodes, depth {b['depth']}\n")
    if paths:
        all_scenes = sorted(scenes_dir().rglob("*.toml"))
        results["variants"] = program_variants(all_scenes)
        out.write(f"program variants to render all {len(all_scenes)} scenes in scenes/: "
                  f"{len(results['variants'])}\n")
    loaded = {}

    def scene_of(name, path):
        if name not in loaded:
            sc = Scene.load(path)
            loaded[name] = (sc, compile_scene(sc))
        return loaded[name]

    for dev in chosen:
        dname = select_device(dev).name.strip()
        r = results["devices"][dname] = {"scenes": {}, "builds": {}, "sweeps": {}}
        work = None
        if args.rays:
            r["rays"], work = bench_rays(cs_mesh, mesh_scene, dev, args.rays, args.repeat)
        for name, path in paths.items():
            sc, cs = scene_of(name, path)
            settings = getattr(sc, "render_settings", {})
            w, h = size or (settings.get("width", 640), settings.get("height", 480))
            spp = args.spp or settings.get("spp", 4)
            out.write(f"  {name}: {w}x{h} {spp} spp...\n")
            out.flush()
            r["scenes"][name] = bench_scene(sc, cs, dev, w, h, spp, args.repeat, generic=not args.no_generic)
            if not args.no_build:
                r["builds"][name] = build_times(path, dev, generic=not args.no_generic)
        for name, path in sweep_paths.items():
            sc, cs = scene_of(name, path)
            ref = "the tessellated reference" if displaced(sc) else f"reference {args.ref_spp} spp"
            out.write(f"  sweep {name}: {sweep_w}x{sweep_h}, {ref}...\n")
            out.flush()
            r["sweeps"][name] = sweep_scene(sc, cs, dev, sweep_w, sweep_h, args.repeat, args.ref_spp,
                                            _csv_ints(args.sweep_spp, "--sweep-spp"))
        if args.local_sizes:
            sc, cs = scene_of("mixed", suite_paths(["mixed"])["mixed"])
            sizes = _csv_ints(args.local_sizes, "--local-sizes")
            w, h = size or (640, 480)
            r["local_sizes"] = {"scene": "mixed", "size": f"{w}x{h}", "spp": 4,
                                "frame_s": local_size_sweep(sc, cs, dev, w, h, 4, args.repeat, sizes)}
        if args.peers:
            from .bench_peers import bench_peers
            peer_scenes = list(suite_paths(["globe", "grazing_quad", "brick_wall", "textured_meshes"]).values())
            measured = (r["rays"], work, results["bvh"]["scene_compile_s"]) if work is not None else None
            r["peers"] = bench_peers(dev, args.repeat, args.triangles, args.rays or 1024, peer_scenes,
                                     measured=measured)
        print_device(dname, r, out)
    Path(args.json).write_text(json.dumps(results, indent=1, default=str))
    out.write(f"\nwrote {args.json}\n")
    _write_outputs(results, args, out)
    return 0


def _write_outputs(results, args, out):
    """The plot (--plot) and the markdown report (--report) of a run's results."""
    plot_name = None
    if args.plot and any(d.get("sweeps") for d in results["devices"].values()):
        sweeps = {f"{s} ({dn})" if len(results["devices"]) > 1 else s: sw
                  for dn, d in results["devices"].items() for s, sw in d["sweeps"].items()}
        if plot(sweeps, args.plot):
            plot_name = args.plot
            out.write(f"wrote {args.plot}\n")
        else:
            out.write("no plot: matplotlib is not installed (pip install 'texray[bench]')\n")
    if args.report:
        rel = None
        if plot_name:
            try:
                rel = str(Path(plot_name).resolve().relative_to(Path(args.report).resolve().parent))
            except ValueError:
                rel = str(Path(plot_name).resolve())
        Path(args.report).write_text(markdown(results, rel))
        out.write(f"wrote {args.report}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
