"""Seconds to each of a few renders of one scene in a fresh process with empty driver caches
(PoCL's and pyopencl's in a temporary folder), and the work-group functions PoCL compiled:
what a process pays for its first frames, e.g. a small preview and then the full size.

    python tools/first_frames.py TREE SCENE.toml WxH[@SPP] [WxH[@SPP] ...]

TREE: a source tree (``.`` or a ``git worktree add`` of another commit), whose host code and
kernels are used; SPP: 16 unless given. The scene cache is on, as for a user (in the
temporary folder: the first render compiles the scene and stores it). Each render's seconds are ``render`` from the call to
the image (the first includes the program's build and its first launch's code generation);
then the kernel folders of PoCL's cache, ``kernel/LOCAL-SIZES[-goffs0][-smallgrid]``, one per
work-group function compiled. Run two trees in turn, several times, for an A/B.
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

_CHILD = """
import glob, json, os, sys, time
import texray as tx
scene = tx.Scene.load(sys.argv[1])
out = []
for spec in sys.argv[2:]:
    size, _, spp = spec.partition("@")
    w, h = map(int, size.split("x"))
    t = time.perf_counter()
    tx.render(scene, w, h, int(spp or 16), device="pocl")
    out.append([spec, round(time.perf_counter() - t, 3)])
cache = os.environ["POCL_CACHE_DIR"]
folders = sorted("/".join(p.split(os.sep)[-2:]) for p in glob.glob(os.path.join(cache, "*", "*", "*", "*"))
                 if os.path.isdir(p))
print(json.dumps({"renders": out, "work_group_functions": folders}))
"""


def main(argv):
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    tree = Path(argv[0]).resolve()
    with tempfile.TemporaryDirectory(prefix="texray-first-frames-") as cache:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tree / "pyhost"), str(tree)]),
                   XDG_CACHE_HOME=cache, POCL_CACHE_DIR=os.path.join(cache, "pocl"))
        out = subprocess.run([sys.executable, "-c", _CHILD, *argv[1:]], env=env, capture_output=True, text=True)
    if out.returncode != 0:
        print(out.stderr[-3000:], file=sys.stderr)
        return out.returncode
    res = json.loads(out.stdout.strip().splitlines()[-1])
    print(" ".join(f"{spec} {s:.3f} s" for spec, s in res["renders"]), "|", " ".join(res["work_group_functions"]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
