"""When rendering on Dask pays (the README's "Rendering on a cluster"): one local render
against a LocalCluster of 1 and 2 worker processes on this machine, and the overheads.

    python tools/dask_timing.py [--scene scenes/showcase.toml] [--size 640x480] [--spp 16]
                                [--repeat 5] [--threads-per-worker-device 1]

Prints, in one run, medians of REPEAT renders each (after one untimed, which builds the
programs and ships the scene):
- local: tx.render on the default device (PoCL, every core);
- workers=N: tx.render(client=) on a LocalCluster of N processes, one Dask thread each,
  each worker's PoCL limited to --threads-per-worker-device cores (POCL_CPU_MAX_CU_NUM)
  so that N workers use N cores, as N machines would;
- the overheads: the scene's pickled bytes and the time to scatter it to every worker
  (once per scene), the round trip of an empty task, and a one-block band at 1 spp
  against the same band rendered locally (the per-band cost);
- a turntable of --frames frames at half the size by render_frames, locally and on the cluster;
- the model's prediction for each measured point (see the README) next to the measurement.
The images of every configuration are compared with the local one (bit for bit).
"""
import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "pyhost"))

import texray as tx  # noqa: E402
from texray.renderer import distributed  # noqa: E402


def _median_time(fn, repeat):
    fn()                                       # untimed: program builds, the scene shipped
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def _noop():
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "showcase.toml"))
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--workers", default="1,2", help="worker counts to measure (default 1,2)")
    ap.add_argument("--frames", type=int, default=8, help="turntable frames (half size) for render_frames (default 8)")
    ap.add_argument("--threads-per-worker-device", type=int, default=1,
                    help="cores each worker's PoCL may use (default 1)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    import dask.distributed as dd

    w, h = map(int, args.size.split("x"))
    scene = tx.Scene.load(args.scene)
    out = {"scene": args.scene, "size": args.size, "spp": args.spp, "repeat": args.repeat,
           "cpu_count": os.cpu_count(), "points": {}}
    local_s, local = _median_time(lambda: tx.render(scene, w, h, args.spp, device="cpu"), args.repeat)
    out["points"]["local"] = {"frame_s": local_s}
    # a turntable: render_frames submits every frame's bands at once
    fw, fh = w // 2, h // 2
    cams = [tx.Camera(eye=tuple(np.array([np.sin(a), 0, np.cos(a)]) * 3.6 + np.array([0, 1.4, 0])),
                      look_at=(0, 0.7, 0), fov_y=32) for a in np.linspace(0, 2 * np.pi, args.frames, endpoint=False)]
    local_frames_s, local_frames = _median_time(lambda: tx.render_frames(scene, cams, fw, fh, args.spp, device="cpu"),
                                                max(1, args.repeat // 2))
    out["points"]["local"]["frames_s"] = local_frames_s
    print(f"  local: {args.frames} frames of {fw}x{fh} (render_frames): {local_frames_s:.3f} s")
    band = (0, min(h, distributed.BLOCK_ROWS))
    band_local_s, _ = _median_time(lambda: tx.render(scene, w, h, 1, device="cpu", rows=band), args.repeat)
    print(f"{args.scene}: {w}x{h}, {args.spp} spp; local (PoCL, {os.cpu_count()} cores): {local_s:.3f} s")
    env = {"POCL_CPU_MAX_CU_NUM": str(args.threads_per_worker_device),      # PoCL >= 1.6
           "POCL_MAX_PTHREAD_COUNT": str(args.threads_per_worker_device)}   # older PoCL
    for n in [int(x) for x in args.workers.split(",")]:
        with dd.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                             env=env) as cluster, dd.Client(cluster) as client:
            client.wait_for_workers(n)
            t0 = time.perf_counter()
            first = tx.render(scene, w, h, args.spp, device="cpu", client=client)
            first_s = time.perf_counter() - t0
            d = first.stats["dask"]
            frame_s, img = _median_time(lambda: tx.render(scene, w, h, args.spp, device="cpu", client=client),
                                        args.repeat)
            task_s, _ = _median_time(lambda: client.submit(_noop, pure=False).result(), 20)
            band_s, _ = _median_time(lambda: tx.render(scene, w, h, 1, device="cpu", rows=band, client=client),
                                     args.repeat)
            frames_s, far_frames = _median_time(lambda: tx.render_frames(scene, cams, fw, fh, args.spp, device="cpu",
                                                                         client=client), max(1, args.repeat // 2))
            same = bool(np.array_equal(img.rgb, local.rgb)) and all(
                np.array_equal(a.rgb, b.rgb) for a, b in zip(far_frames, local_frames))
            point = {"workers": n, "frame_s": frame_s, "first_frame_s": first_s, "bands": d["bands"],
                     "band_rows": d["band_rows"], "ship_bytes": d["ship_bytes"], "ship_s": d["ship_s"],
                     "task_roundtrip_s": task_s, "one_band_s": band_s, "one_band_local_s": band_local_s,
                     "band_task_s_median": img.stats["dask"]["task_s_median"], "frames_s": frames_s,
                     "identical_to_local": same}
            out["points"][f"workers={n}"] = point
            print(f"  workers={n}: {frame_s:.3f} s ({local_s / frame_s:.2f}x local), first frame {first_s:.3f} s; "
                  f"{d['bands']} bands of {d['band_rows']} rows (median band {point['band_task_s_median']:.3f} s); "
                  f"scene {d['ship_bytes'] / 2**20:.1f} MiB shipped in {d['ship_s']:.3f} s; empty task "
                  f"{task_s * 1e3:.1f} ms; one {band[1]}-row band at 1 spp {band_s * 1e3:.1f} ms "
                  f"(local {band_local_s * 1e3:.1f} ms); {args.frames} frames {frames_s:.3f} s "
                  f"({local_frames_s / frames_s:.2f}x local); identical to local: {same}")
    base = out["points"].get("workers=1")
    if base:
        # the model: T(n) = T1_work / n + bands/n * per_band + once(ship); fitted on workers=1
        per_band = base["one_band_s"] - base["one_band_local_s"]
        work = base["frame_s"] - base["bands"] * per_band
        for key, p in out["points"].items():
            if key.startswith("workers="):
                p["model_s"] = work / p["workers"] + p["bands"] / p["workers"] * per_band
                print(f"  model {key}: {p['model_s']:.3f} s predicted, {p['frame_s']:.3f} s measured")
        out["model"] = {"work_s": work, "per_band_s": per_band}
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
