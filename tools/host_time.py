"""Host time per render: the median over N renders (after one) of ``stats["render_s"]``, of the
kernels' device time and of their difference, the host's work within ``render_s`` (uploads,
kernel objects, launches, readback, the mean of the samples), and of ``total_s - render_s``,
the host's work before it (the scene cache: hashing, finding or compiling the scene), for one
checkout of texray. The same scene object each time: an unchanged scene rendered again.

    python tools/host_time.py TREE SCENE.toml W H SPP N [ADAPTIVE]

TREE: a source tree (``.`` or a ``git worktree add`` of another commit), whose host code and
kernels are used. The scene is rendered as ``texray bench --peers`` renders it
(``texray.bench.peers.comparable_scene``) on PoCL, with ``render(adaptive=ADAPTIVE)`` if given
(SPP is then the most a pixel takes). Run two trees in turn, twice, for an A/B.
"""
import statistics
import sys
from pathlib import Path


def main(argv):
    tree, scene_path = argv[0], argv[1]
    w, h, spp, n = map(int, argv[2:6])
    kw = {"adaptive": float(argv[6])} if len(argv) > 6 else {}
    sys.path.insert(0, str(Path(tree).resolve() / "pyhost"))
    import texray.device.opencl as o
    o.KERNEL_DIR = Path(tree).resolve() / "kernels"
    o._kernel_sources_digest.cache_clear()
    import texray as tx
    from texray.bench import peers
    scene, _ = peers.comparable_scene(tx.Scene.load(scene_path))
    tx.render(scene, w, h, spp, device="pocl", **kw)
    stats = [tx.render(scene, w, h, spp, device="pocl", **kw).stats for _ in range(n)]
    kernel = [sum(s["stage_s"].values()) for s in stats]
    med = statistics.median
    print(f"{Path(tree).resolve().name} {Path(scene_path).stem}: render_s {med(s['render_s'] for s in stats) * 1e3:.2f} ms, "
          f"kernels {med(kernel) * 1e3:.2f} ms, host {med(s['render_s'] - k for s, k in zip(stats, kernel)) * 1e3:.2f} ms; "
          f"total_s - render_s {med(s['total_s'] - s['render_s'] for s in stats) * 1e3:.2f} ms "
          f"(scene cache: {stats[-1]['scene_cache']})")


if __name__ == "__main__":
    if len(sys.argv) not in (7, 8):
        sys.exit(__doc__)
    main(sys.argv[1:])
