"""The cell BVH builder's time in fresh processes (what a user's first render pays: the
kernel's first launch and first-touch memory included), on the 1.3M-triangle icosphere
of tools/scene_cache_timing.py; optionally A/B against another source tree's pyhost/.

    python tools/bvh_fresh_timing.py [--runs 7] [--other /path/to/old/pyhost]

Each run is a new Python process timing texray.accel.cells.build alone; runs of the two
trees alternate; prints the medians (seconds, and seconds per million triangles) and
the SAH costs (equal when the trees are).
"""
import argparse
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHILD = """
import sys, time
import numpy as np, trimesh
sys.path.insert(0, sys.argv[1])
from texray.accel import cells
m = trimesh.creation.icosphere(subdivisions=8)
tri = np.asarray(m.vertices, np.float32)[np.asarray(m.faces)]
lo, hi = tri.min(1), tri.max(1)
t0 = time.perf_counter()
tree = cells.build(lo, hi)
print(time.perf_counter() - t0, tree.sah_cost, len(lo))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--other", default=None, help="another tree's pyhost/ folder to compare with")
    args = ap.parse_args()
    trees = {"this": str(ROOT / "pyhost")}
    if args.other:
        trees["other"] = args.other
    times = {k: [] for k in trees}
    sah, n = {}, 0
    for _ in range(args.runs):
        for name, path in trees.items():
            out = subprocess.run([sys.executable, "-c", CHILD, path], capture_output=True, text=True, check=True)
            t, cost, n = out.stdout.split()
            times[name].append(float(t))
            sah[name] = float(cost)
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"{name}: median {med:.3f} s ({med / int(n) * 1e6:.3f} s per million, {min(ts):.3f}-{max(ts):.3f}), "
              f"SAH cost {sah[name]:.4f}, {n} triangles, {args.runs} fresh processes")


if __name__ == "__main__":
    main()
