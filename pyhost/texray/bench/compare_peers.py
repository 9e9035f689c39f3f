"""``texray bench --peers``: texray against its peers on the same work, in one run
(needs ``pip install texray[peers]``; see README "Peers").

1. Rays: the bench mesh (``procedural.bench_mesh``, 1M triangles) and 1024^2 pixel-centre
   primary rays (closest hit) plus shadow rays from their hits toward the bench light (any hit):
   texray (device kernel time) against Embree (embreex, 1 and all threads), with their hit agreement.
2. Frames: the given scenes at their own size and spp, ambient and specular 0 in both
   (``peers.comparable_scene``): texray against Mitsuba 3 (``llvm_ad_rgb``, ``direct``), times
   and image difference. Mitsuba's ``direct`` traces one shadow ray per camera sample toward
   one light; with several lights texray is timed both ways: every light per sample (its
   default) and ``light_sampling="one"``, the same estimator as Mitsuba's (equal work).
3. Time to error: Mitsuba's error at that spp (RMSE against its own REF_SPP-sample image)
   is the target; texray's time to it is its fastest setting (spp from TTE_SPP, or
   adaptive sampling with a threshold from TTE_ADAPTIVE; each spp also with one light per
   sample where there are several lights) whose RMSE against texray's own
   REF_SPP-sample image is no larger. Each renderer against its own converged image, so
   that their conventions (filtering, sampling) do not count as error.

Every figure is a median over ``repeat`` runs after one warm-up (each time-to-error setting's
time too: one run of a 20 ms frame caught a 45% hiccup and picked a slower setting); ratios
are stated with their sense. texray's and Mitsuba's frames are timed in alternating rounds
(:func:`paired`), and so is the time-to-error setting found, against Mitsuba's frames: on a
shared machine the load changes by the minute, and a ratio of two blocks timed minutes apart
measured the load as much as the renderers (the textured meshes 0.84-1.19 in three runs of one
commit, 2026-12-07). Each renderer's timed frame follows an untimed one of its own
(:func:`paired` says why).
"""
from __future__ import annotations

import io
import os
import time
from pathlib import Path

import numpy as np

import texray as tx
from texray.compile import compile_scene

from . import peers
from .rays import bench_mesh_scene, bench_rays
from .suite import median_spread


REF_SPP = 256
TTE_SPP = (1, 2, 3, 4, 5, 6, 8, 12, 16, 24, 32, 48, 64)   # no multiple of 8: packets shared by pixels
# each with at most 2x Mitsuba's spp; 0.5 and 0.3 since 2026-12-07: on the bumped brick wall at
# <= 8 spp they reach Mitsuba's 4-spp error with 4.02 and 4.14 samples per pixel on average
# (RMSE 0.00432, 0.00369 against its 0.00446), faster than 5 uniform spp (17.4 against 19.1 ms)
TTE_ADAPTIVE = (0.5, 0.3, 0.2, 0.1, 0.05, 0.02)
# The settings the search found within TTE_RETIME of the fastest (at most TTE_CANDIDATES) are
# timed again in alternating rounds with Mitsuba's frames, and the fastest there is texray's:
# the search's own times move with the load (run peers_s50e: the grazing quad's 4 spp took
# 14.3 ms in the search, right after Mitsuba's renders, and 9 ms in the rounds, where the
# setting the search picked, adaptive 0.5 at 5.2 spp, took 13 ms).
TTE_RETIME = 1.5
TTE_CANDIDATES = 3


def rmse(a, b):
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    return float(np.sqrt(np.mean(d * d)))


def time_to_error(cmp, w, h, s, device, mitsuba_rgb, mitsuba_s, repeat=1, mitsuba=None):
    """Mitsuba's error at ``s`` spp and the settings texray needs to reach it (see the
    module docstring); per setting the median time of ``repeat`` renders after a warm-up
    (the same seed: the same image each time). With ``mitsuba`` (a :class:`peers.MitsubaFrames`
    of the same scene at ``s`` spp), the fastest settings (TTE_RETIME, TTE_CANDIDATES) are timed
    again against Mitsuba's frames in alternating rounds (:func:`paired`) and the fastest there
    is texray's (``retimed``: each candidate's rounds median): ``mitsuba_s`` and the setting's
    ``render_s`` are then those rounds' medians (``scan_render_s``: its time in the search)."""
    mi_ref, _ = peers.mitsuba_render(cmp, w, h, REF_SPP, seed=7)
    target = rmse(mitsuba_rgb, mi_ref)
    ref = tx.render(cmp, w, h, REF_SPP, device=device, seed=7).rgb
    tried = []
    settings = [{"spp": n} for n in TTE_SPP] + [{"spp": 2 * s, "adaptive": t} for t in TTE_ADAPTIVE]
    if len(cmp.lights) >= 2:
        settings += [{"spp": n, "light_sampling": "one"} for n in TTE_SPP]
    for kw in settings:
        tx.render(cmp, w, h, device=device, **kw)                     # warm-up: the program's build
        runs = [tx.render(cmp, w, h, device=device, seed=1, **kw) for _ in range(max(int(repeat), 1))]
        r = runs[-1]
        tried.append({**kw, "render_s": float(np.median([x.stats["render_s"] for x in runs])),
                      "mean_spp": r.stats["samples"] / (w * h), "rmse": rmse(r.rgb, ref)})
    reached = [t for t in tried if t["rmse"] <= target]
    best = min(reached, key=lambda t: t["render_s"]) if reached else None
    out = {"target_rmse": target, "ref_spp": REF_SPP, "mitsuba_s": mitsuba_s, "texray": best, "tried": tried}
    if best is not None and mitsuba is not None:
        cands = [t for t in sorted(reached, key=lambda t: t["render_s"])
                 if t["render_s"] <= TTE_RETIME * best["render_s"]][:TTE_CANDIDATES]

        def frame(kw):
            kw = {k: kw[k] for k in ("spp", "adaptive", "light_sampling") if k in kw}
            return lambda: tx.render(cmp, w, h, device=device, seed=1, **kw).stats["render_s"]
        fns = {f"texray{i}": frame(c) for i, c in enumerate(cands)}
        times = paired({**fns, "mitsuba": mitsuba.frame}, repeat)
        med = [median_spread(times[f"texray{i}"])["median"] for i in range(len(cands))]
        i = int(np.argmin(med))
        out["texray"] = {**cands[i], "scan_render_s": cands[i]["render_s"], "render_s": med[i]}
        out["retimed"] = [{**c, "rounds_render_s": m} for c, m in zip(cands, med)]
        out["mitsuba_s"] = median_spread(times["mitsuba"])["median"]
        out["round_ratios"] = median_spread(round_ratios(times["mitsuba"], times[f"texray{i}"]))
    return out


def paired(frames: dict, rounds) -> dict:
    """Alternating rounds: each round renders, for every function of ``frames`` in order (name
    -> a call that renders one frame and returns its seconds), one frame untimed and then the
    frame it times; the seconds per name. On this shared machine the load moves by 10-50% from
    one minute to the next: timed in blocks, one renderer's frames can fall in a quiet minute
    and the other's in a busy one, and a ratio between them moves with the load; timed in
    rounds, a change of load falls on both. The untimed frame first: a texray frame right after
    a Mitsuba frame took 2.5-3 ms more than the next one (bumped brick wall, 512x256, 4 spp:
    medians 21.4 / 21.9 / 21.0 against 18.5 / 19.3 / 18.6 ms in three sets of five rounds;
    Mitsuba's first and second frames took the same), so each renderer is timed as it runs
    frame after frame, as in a block."""
    times = {k: [] for k in frames}
    for _ in range(max(int(rounds), 1)):
        for k, f in frames.items():
            f()
            times[k].append(float(f()))
    return times


def round_ratios(theirs, ours):
    """The peer's time over texray's, round by round (> 1: texray faster)."""
    return [a / b for a, b in zip(theirs, ours)]


def span(v, width=9):
    """A median_spread's range, "min-max" ("-" where there is none: a run from before the rounds)."""
    return (f"{v['min']:.2f}-{v['max']:.2f}" if v else "-").rjust(width)


def cell(v, fmt=".2f", width=22):
    return f"{v['median']:{fmt}} ({v['min']:{fmt}}-{v['max']:{fmt}})".rjust(width)


def rays(device, triangles, size, repeat, threads_list, measured=None):
    """(texray's figures, Embree's per thread count) on the same mesh and rays. ``measured``:
    (figures, :class:`texray.bench.rays.RayWork`, scene compile seconds) of a bench run that traced them
    already; else the bench mesh is built and traced here as ``texray bench`` does."""
    if measured is None:
        scene = bench_mesh_scene(triangles)
        t0 = time.perf_counter()
        cs = compile_scene(scene)
        compile_s = time.perf_counter() - t0
        figures, work = bench_rays(cs, scene, device, size, repeat)
    else:
        figures, work, compile_s = measured
    face = peers.texray_face_ids(work.compiled, work.hits)
    theirs = [peers.embree_rays(work.mesh.positions, work.mesh.faces, work.org, work.dirs, work.shadow_org,
                                work.shadow_dirs, repeat=repeat, threads=t, texray_hits=(work.hits.t, face),
                                texray_occluded=work.occluded) for t in threads_list]
    return dict(figures, scene_compile_s=compile_s), theirs


def frames(path, device, repeat, width=None, height=None, spp=None, tte=True):
    """One scene's frames, texray's and Mitsuba's timed in alternating rounds (:func:`paired`)
    after a warm-up of each: ``repeat`` rounds of texray's frames, Mitsuba's and, with several
    lights, texray's with one light per sample (each an untimed frame and a timed one)."""
    scene = tx.Scene.load(path)
    rs = getattr(scene, "render_settings", {}) or {}
    w, h, s = width or rs.get("width", 512), height or rs.get("height", 384), spp or rs.get("spp", 16)
    cmp, notes = peers.comparable_scene(scene)
    several = len(cmp.lights) >= 2              # Mitsuba's estimator: one light per camera sample
    first = tx.render(cmp, w, h, s, device=device)
    mitsuba = peers.MitsubaFrames(cmp, w, h, s)
    if several:
        tx.render(cmp, w, h, s, device=device, light_sampling="one")
    last, prep = {}, {"all": [], "one": []}        # the last frame and host times per light sampling

    def texray_frame(sampling="all"):
        def once():
            kw = {"light_sampling": "one"} if sampling == "one" else {}
            r = last[sampling] = tx.render(cmp, w, h, s, device=device, **kw)
            prep[sampling].append(r.stats["total_s"] - r.stats["render_s"])
            return r.stats["render_s"]
        return once

    calls = {"texray": texray_frame(), "mitsuba": mitsuba.frame}
    if several:
        calls["texray_one_light"] = texray_frame("one")
    times = paired(calls, repeat)
    ours = {"render_s": median_spread(times["texray"]),
            "prep_s": median_spread(prep["all"][1::2]),          # the timed frames' (paired: every second)
            "first_total_s": first.stats["total_s"]}
    st = mitsuba.stats(times["mitsuba"])
    rgb = mitsuba.rgb
    out = {"scene": str(path), "width": w, "height": h, "spp": s, "texray": ours, "mitsuba": st,
           "round_ratios": median_spread(round_ratios(times["mitsuba"], times["texray"])),
           "diff": peers.compare_images(last["all"].rgb, rgb), "notes": notes + st["notes"]}
    if several:
        out["texray_one_light"] = {"render_s": median_spread(times["texray_one_light"]),
                                   "round_ratios": median_spread(round_ratios(times["mitsuba"],
                                                                              times["texray_one_light"])),
                                   "diff": peers.compare_images(last["one"].rgb, rgb)}
    if tte:
        out["time_to_error"] = time_to_error(cmp, w, h, s, device, rgb, st["render_s"]["median"], repeat,
                                             mitsuba=mitsuba)
    return out


def bench_peers(device, repeat=5, triangles=1_000_000, size=1024, scenes=(), threads=None, measured=None):
    """Run the peers; returns the results dict with ``lines`` (the printed tables). ``measured``:
    see :func:`rays`."""
    threads = threads or sorted({1, os.cpu_count() or 1})
    out = io.StringIO()

    av = peers.available()
    out.write(f"texray {tx.__version__}; peers: " + ", ".join(
        f"{k} {v.get('version', '-')}" + (f" ({v['variant']}, LLVM {v['llvm']})" if v.get("variant") else "")
        if v["ok"] else f"{k} missing" for k, v in av.items()) + "\n")
    result = {"available": av}
    if av["embree"]["ok"]:
        ours, theirs = rays(device, triangles, size, repeat, threads, measured)
        result["rays"] = {"texray": ours, "embree": theirs}
        out.write(f"\nRays: {ours['triangles']} triangles, {ours['rays']} primary + {ours['shadow_rays']} shadow "
                  f"rays; texray on {ours['device']} (kernel time), Embree wall clock; median (min-max) Mrays/s\n")
        out.write(f"| {'':<22} | {'primary (closest)':>22} | {'shadow (any hit)':>22} | {'BVH build s':>11} |\n")
        out.write(f"|{'-' * 24}|{'-' * 24}:|{'-' * 24}:|{'-' * 13}:|\n")

        def row(name, p, s, b):
            out.write(f"| {name:<22} | {cell(p)} | {cell(s)} | {b:11.2f} |\n")
        row("texray", ours["primary_mrays_s"], ours["shadow_mrays_s"], ours["scene_compile_s"])
        for e in theirs:
            row(f"Embree {e['threads']} thread(s)", e["primary_mrays_s"], e["shadow_mrays_s"], e["build_s"]["median"])
        for e in theirs:
            out.write(f"texray / Embree {e['threads']}T: primary {ours['primary_mrays_s']['median'] / e['primary_mrays_s']['median']:.2f}x, "
                      f"shadow {ours['shadow_mrays_s']['median'] / e['shadow_mrays_s']['median']:.2f}x\n")
        a = theirs[-1]["agreement"]
        out.write(f"agreement: same face {100 * a['hit_face_agree']:.3f}%, hit/miss {100 * a['hit_miss_agree']:.3f}%, "
                  f"t rel diff median {a['t_rel_diff_median']:.1e} max {a['t_rel_diff_max']:.1e}, "
                  f"shadow {100 * a['shadow_agree']:.3f}%\n")
        out.write("(texray 'BVH build' = compile_scene incl. its BVH; Embree's = scene creation + commit)\n")
    if av["mitsuba"]["ok"]:
        result["frames"], skipped = [], []
        for p in scenes:
            try:
                result["frames"].append(frames(p, device, repeat))
            except peers.Unsupported as e:       # a feature Mitsuba has no equivalent for
                skipped.append(f"{Path(p).stem}: {e}")
        result["skipped"] = skipped
        out.write(f"\nFrames: ambient 0, specular 0 in both; Mitsuba {av['mitsuba']['variant']} direct, "
                  f"lights x pi; median render s (min-max) of {repeat} alternating rounds "
                  "(per round an untimed and a timed frame of each)\n")
        out.write(f"| {'scene':<24} | {'texray s':>19} | {'Mitsuba s':>19} | {'ratio':>5} | {'rounds':>9} |"
                  f" {'Mi load s':>9} | {'Mi 1st s':>8} | {'RMSE':>7} | {'rel mean':>8} | {'rel |d|':>7} |"
                  f" {'px>0.05':>7} |\n")
        out.write(f"|{'-' * 26}|{'-' * 20}:|{'-' * 20}:|{'-' * 6}:|{'-' * 10}:|{'-' * 10}:|{'-' * 9}:|{'-' * 8}:|"
                  f"{'-' * 9}:|{'-' * 8}:|{'-' * 8}:|\n")
        for f in result["frames"]:
            o, m, d = f["texray"]["render_s"], f["mitsuba"]["render_s"], f["diff"]
            name = f"{Path(f['scene']).stem} {f['width']}x{f['height']} {f['spp']}spp"
            out.write(f"| {name:<24} | {cell(o, '.3f', 19)} | {cell(m, '.3f', 19)} | {m['median'] / o['median']:5.2f} |"
                      f" {span(f.get('round_ratios'))} |"
                      f" {f['mitsuba']['load_s']:9.3f} | {f['mitsuba']['first_render_s']:8.3f} | {d['rmse']:7.4f} |"
                      f" {100 * d['rel_mean_diff']:7.2f}% | {100 * d['rel_mean_abs']:6.2f}% |"
                      f" {100 * d['frac_pixels_over']:6.2f}% |\n")
            if "texray_one_light" in f:           # the same scene, Mitsuba's estimator
                one = f["texray_one_light"]
                o, d = one["render_s"], one["diff"]
                name = "  1 light per sample"
                out.write(f"| {name:<24} | {cell(o, '.3f', 19)} | {cell(m, '.3f', 19)} | {m['median'] / o['median']:5.2f} |"
                          f" {span(one.get('round_ratios'))} | {'':>9} | {'':>8} | {d['rmse']:7.4f} |"
                          f" {100 * d['rel_mean_diff']:7.2f}% | {100 * d['rel_mean_abs']:6.2f}% |"
                          f" {100 * d['frac_pixels_over']:6.2f}% |\n")
        out.write("ratio = Mitsuba / texray median render time (> 1: texray faster); rounds: the ratio's range over "
                  "the rounds; '1 light per sample': texray with light_sampling='one', Mitsuba's estimator "
                  "(equal work)\n")
        out.write(f"\nTime to Mitsuba's error at the scene's spp (each renderer's RMSE against its own {REF_SPP}-spp "
                  "image); texray's settings that reach it and were the fastest in the search (within "
                  f"{TTE_RETIME}x, at most {TTE_CANDIDATES}) timed again in alternating rounds with Mitsuba's "
                  "frames, the fastest there\n")
        out.write(f"| {'scene':<24} | {'target RMSE':>11} | {'Mitsuba s':>9} | {'texray s':>8} | {'ratio':>5} |"
                  f" {'rounds':>9} | {'texray setting':<26} |\n")
        out.write(f"|{'-' * 26}|{'-' * 12}:|{'-' * 10}:|{'-' * 9}:|{'-' * 6}:|{'-' * 10}:|{'-' * 28}|\n")
        for f in result["frames"]:
            t = f.get("time_to_error")
            if t is None:
                continue
            name = f"{Path(f['scene']).stem} {f['width']}x{f['height']} {f['spp']}spp"
            b = t["texray"]
            if b is None:
                out.write(f"| {name:<24} | {t['target_rmse']:11.5f} | {t['mitsuba_s']:9.3f} | {'-':>8} | {'-':>5} |"
                          f" {'-':>9} | {'not reached':<26} |\n")
                continue
            setting = (f"{b['spp']} spp" if "adaptive" not in b else
                       f"adaptive {b['adaptive']:g}, <= {b['spp']} spp ({b['mean_spp']:.1f})")
            if b.get("light_sampling") == "one":
                setting += ", 1 light"
            out.write(f"| {name:<24} | {t['target_rmse']:11.5f} | {t['mitsuba_s']:9.3f} | {b['render_s']:8.3f} |"
                      f" {t['mitsuba_s'] / b['render_s']:5.2f} | {span(t.get('round_ratios'))} | {setting:<26} |\n")
        out.write("ratio = Mitsuba's time / texray's time to the same error (> 1: texray faster)\n")
        for line in skipped:
            out.write(f"  not compared: {line}\n")
        for note in dict.fromkeys(n for f in result["frames"] for n in f["notes"]):
            out.write(f"  note: {note}\n")
    result["lines"] = out.getvalue().rstrip("\n").splitlines()
    return result
