"""A/B frame times of two checkouts of texray, interleaved, in fresh processes.

    python tools/ab.py BASE NEW [SCENE.toml ...] [--size 512x384] [--spp 8] [--rounds 3]
                       [--frames 5] [--device pocl] [--light-sampling all|one] [--no-shadows]
                       [--adaptive T] [--base-env K=V ...] [--new-env K=V ...]

BASE and NEW are source trees (a `git worktree add /tmp/base <commit>` of the commit
before, and this one). Each round renders each scene once with BASE's host code and
kernels, then with NEW's, each in its own process (one warm-up frame, then the median of
``--frames`` frames' ``stats["render_s"]``), so that both see the same machine load;
it prints every round's times and the median of the rounds' ratios NEW / BASE (< 1:
NEW is faster). The default scenes are the bench's globe, textured meshes, bumped
brick wall and grazing quad. ``--light-sampling one`` renders both sides with one light
per sample (``render(light_sampling="one")``, Mitsuba's estimator); ``--no-shadows``
without shadow rays (``render(shadows=False)``); ``--adaptive T`` with adaptive sampling
(``render(adaptive=T)``, ``--spp`` the most a pixel takes). ``--base-env``/``--new-env`` set environment variables in
one side's processes, so that one tree A/Bs a setting:

    python tools/ab.py . . scenes/bench/textured_meshes.toml --base-env TEXRAY_PACKET=8 --new-env TEXRAY_PACKET=16
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENES = [ROOT / "scenes" / "bench" / f"{n}.toml"
                  for n in ("globe", "textured_meshes", "brick_wall", "grazing_quad")]

# Runs in the child: that tree's texray (PYTHONPATH) with that tree's kernels (an
# editable install elsewhere would otherwise supply its own kernels/).
_CHILD = r"""
import json, statistics, sys
from pathlib import Path
tree, scene, w, h, spp, frames, device, ls, shadows, adaptive = sys.argv[1:11]
import texray.device.opencl as o
o.KERNEL_DIR = Path(tree) / "kernels"
o._kernel_sources_digest.cache_clear()
import texray as tx
s = tx.Scene.load(scene)
kw = {"light_sampling": ls} if ls != "all" else {}
if shadows == "0":
    kw["shadows"] = False
if adaptive:
    kw["adaptive"] = float(adaptive)
tx.render(s, int(w), int(h), int(spp), device=device, **kw)
ts = [tx.render(s, int(w), int(h), int(spp), device=device, **kw).stats["render_s"] for _ in range(int(frames))]
print(json.dumps(statistics.median(ts)))
"""


def frame_time(tree: Path, scene: Path, size, spp, frames, device, extra_env=(), light_sampling="all",
               shadows=True, adaptive=None) -> float:
    tree = tree.resolve()
    env = dict(os.environ, PYTHONPATH=str(tree / "pyhost"), **dict(extra_env))
    out = subprocess.run([sys.executable, "-c", _CHILD, str(tree), str(scene), str(size[0]), str(size[1]),
                          str(spp), str(frames), device, light_sampling, str(int(shadows)),
                          "" if adaptive is None else repr(float(adaptive))], env=env, capture_output=True, text=True, cwd="/")
    if out.returncode != 0:
        raise SystemExit(f"ab: {tree} on {scene} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python tools/ab.py", description=__doc__.splitlines()[0])
    ap.add_argument("base", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("scenes", nargs="*", type=Path)
    ap.add_argument("--size", default="512x384")
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--device", default="Portable Computing Language",
                    help="device name (default PoCL's platform, which every version matches)")
    ap.add_argument("--light-sampling", choices=("all", "one"), default="all",
                    help="render(light_sampling=...) on both sides (default all)")
    ap.add_argument("--no-shadows", action="store_true", help="render(shadows=False) on both sides")
    ap.add_argument("--adaptive", type=float, default=None, metavar="T",
                    help="render(adaptive=T) on both sides (--spp: the most a pixel takes)")
    ap.add_argument("--base-env", action="append", default=[], metavar="K=V",
                    help="an environment variable of BASE's processes (repeatable)")
    ap.add_argument("--new-env", action="append", default=[], metavar="K=V",
                    help="an environment variable of NEW's processes (repeatable)")
    a = ap.parse_args(argv)
    envs = []
    for opt, items in (("--base-env", a.base_env), ("--new-env", a.new_env)):
        env = {}
        for item in items:
            key, eq, value = item.partition("=")
            if not eq or not key:
                ap.error(f"{opt}: expected K=V, got {item!r}")
            env[key] = value
        envs.append(env)
    size = tuple(int(v) for v in a.size.lower().split("x"))
    for tree in (a.base, a.new):
        if not (tree / "kernels" / "texray.cl").is_file() or not (tree / "pyhost" / "texray").is_dir():
            ap.error(f"{tree}: not a texray source tree (kernels/texray.cl, pyhost/texray)")
    for scene in [s.resolve() for s in a.scenes] or DEFAULT_SCENES:
        ratios = []
        for r in range(a.rounds):
            tb = frame_time(a.base, scene, size, a.spp, a.frames, a.device, envs[0], a.light_sampling,
                            not a.no_shadows, a.adaptive)
            tn = frame_time(a.new, scene, size, a.spp, a.frames, a.device, envs[1], a.light_sampling,
                            not a.no_shadows, a.adaptive)
            ratios.append(tn / tb)
            print(f"{scene.stem:18s} round {r + 1}: base {tb * 1e3:8.1f} ms  new {tn * 1e3:8.1f} ms  "
                  f"new/base {tn / tb:.3f}", flush=True)
        print(f"{scene.stem:18s} median new/base {statistics.median(ratios):.3f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
