"""``texray bench``: the kernel benchmark.

Its command line: the options, the run over every chosen device (ray throughput,
the suite scenes, their builds, the sweeps, work-group sizes, the peers) and the
outputs (tables, ``--json``, ``--report``, ``--plot``, ``--compare``). What each
figure measures: :mod:`texray.bench`.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

from .. import __version__
from ..compile import compile_scene
from ..device import devices, select_device
from ..renderer.distributed import add_cluster_arguments, cluster_client
from ..scene import Scene
from .compare_peers import bench_peers
from .rays import bench_bvh, bench_mesh_scene, bench_rays
from .report import compare, markdown, print_device
from .suite import SUITE, bench_scene, build_times, local_size_sweep, program_variants, scenes_dir, suite_paths
from .sweep import SPP_VALUES, displaced, plot, sweep_scene


def _git_commit():
    """The commit of the source tree texray runs from (the package's repository), or None
    (a wheel installed outside one). Not the working directory's: the bench may be run
    from inside any other repository."""
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                             cwd=Path(__file__).resolve().parent, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return out or None


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
                    help=f"suite scenes (names in texray's scenes/bench/, or .toml paths), comma-separated "
                         f"(default {','.join(SUITE)}; '' for none)")
    ap.add_argument("--size", default=None, help="frame size WxH for every suite scene (default: each scene's)")
    ap.add_argument("--spp", type=int, default=None, help="spp for every suite scene (default: each scene's)")
    ap.add_argument("--no-generic", action="store_true", help="skip the generic-program comparison")
    ap.add_argument("--no-build", action="store_true", help="skip cold/warm build timing")
    ap.add_argument("--build-repeat", type=int, default=3,
                    help="fresh caches per cold/warm build figure, their median (default 3)")
    ap.add_argument("--triangles", type=int, default=1_000_000, help="ray-throughput mesh size (default 1M)")
    ap.add_argument("--rays", type=int, default=1024, help="primary rays per side (default 1024; 0: skip)")
    ap.add_argument("--sweep", default="", help="scenes to sweep speed/accuracy knobs on, comma-separated "
                                                "(e.g. globe,grazing_quad; displaced scenes such as "
                                                "terrain,displaced_wall,planet sweep the displacement "
                                                "methods against their tessellation)")
    ap.add_argument("--sweep-size", default="320x240", help="frame size of the sweeps (default 320x240)")
    ap.add_argument("--ref-spp", type=int, default=256, help="spp of the sweeps' reference images (default 256)")
    ap.add_argument("--sweep-spp", default=",".join(map(str, SPP_VALUES)),
                    help=f"spp values swept (default {','.join(map(str, SPP_VALUES))})")
    ap.add_argument("--local-sizes", default="", help="work-group sizes to time on the mixed scene, "
                                                      "e.g. 0,16,32,64,128 (0 = driver's choice)")
    ap.add_argument("--peers", action="store_true", help="also run the peers (pip install texray[peers])")
    add_cluster_arguments(ap)      # --scheduler / --workers: the sweeps' configurations run as Dask tasks
    ap.add_argument("--json", default=None, metavar="PATH",
                    help="also write the results as JSON here, for --compare and --from-json (default: no file)")
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
    if args.build_repeat < 1:
        ap.error("--build-repeat must be >= 1")
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
        out.write(f"BVH ({b['builder']} builder): {b['triangles']} triangles in {b['build_s']['median']:.2f} s "
                  f"({b['build_s']['min']:.2f}-{b['build_s']['max']:.2f}), SAH cost {b['sah_cost']:.2f}, "
                  f"{b['nodes']} nodes, depth {b['depth']}; numpy builder {b['numpy_build_s']['median']:.2f} s, "
                  f"SAH cost {b['numpy_sah_cost']:.2f}\n")
    if paths:
        all_scenes = sorted(scenes_dir().rglob("*.toml"))
        results["variants"] = program_variants(all_scenes)
        out.write(f"program variants to render all {len(all_scenes)} scenes in scenes/: "
                  f"{len(results['variants'])}\n")
    loaded = {}
    stack = contextlib.ExitStack()
    client = stack.enter_context(cluster_client(args.scheduler, args.workers)) if sweep_paths else None

    def scene_of(name, path):
        if name not in loaded:
            sc = Scene.load(path)
            loaded[name] = (sc, compile_scene(sc))
        return loaded[name]

    try:
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
                    r["builds"][name] = build_times(path, dev, generic=not args.no_generic,
                                                    repeat=args.build_repeat)
            for name, path in sweep_paths.items():
                sc, cs = scene_of(name, path)
                ref = "the tessellated reference" if displaced(sc) else f"reference {args.ref_spp} spp"
                out.write(f"  sweep {name}: {sweep_w}x{sweep_h}, {ref}...\n")
                out.flush()
                r["sweeps"][name] = sweep_scene(sc, cs, dev, sweep_w, sweep_h, args.repeat, args.ref_spp,
                                                _csv_ints(args.sweep_spp, "--sweep-spp"), client=client)
            if args.local_sizes:
                sc, cs = scene_of("mixed", suite_paths(["mixed"])["mixed"])
                sizes = _csv_ints(args.local_sizes, "--local-sizes")
                w, h = size or (640, 480)
                r["local_sizes"] = {"scene": "mixed", "size": f"{w}x{h}", "spp": 4,
                                    "frame_s": local_size_sweep(sc, cs, dev, w, h, 4, args.repeat, sizes)}
            if args.peers:
                peer_scenes = list(suite_paths(["globe", "grazing_quad", "brick_wall", "textured_meshes"]).values())
                measured = (r["rays"], work, results["bvh"]["scene_compile_s"]) if work is not None else None
                r["peers"] = bench_peers(dev, args.repeat, args.triangles, args.rays or 1024, peer_scenes,
                                         measured=measured)
            print_device(dname, r, out)
    finally:
        stack.close()
    if args.json:
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
