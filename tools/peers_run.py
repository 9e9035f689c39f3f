#!/usr/bin/env python3
"""texray against Embree and Mitsuba 3 on the same work (``texray bench --peers`` runs the
same; this script runs only the peers). Usage: ``python tools/peers_run.py [--device D]
[--repeat 5] [--triangles N] [--rays N] [scene.toml ...]``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
try:
    import texray  # noqa: F401
except ImportError:
    sys.path.insert(0, str(ROOT / "pyhost"))
from texray.bench.compare_peers import bench_peers


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default=None)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--rays", type=int, default=1024, help="primary rays per side")
    ap.add_argument("scenes", nargs="*", default=[str(ROOT / "scenes/bench/textured_meshes.toml"),
                                                  str(ROOT / "scenes/bench/globe.toml")])
    a = ap.parse_args(argv)
    r = bench_peers(a.device, a.repeat, a.triangles, a.rays, a.scenes)
    print("\n".join(r["lines"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
