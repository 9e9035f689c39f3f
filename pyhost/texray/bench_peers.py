"""``texray bench --peers``: texray against its peers on the same work, in one run
(needs ``pip install texray[peers]``; see README "Peers").

1. Rays: the bench mesh (``procedural.bench_mesh``, 1M triangles) and 1024^2 pixel-centre
   primary rays (closest hit) plus shadow rays from their hits toward the bench light (any hit):
   texray (device kernel time) against Embree (embreex, 1 and all threads), with their hit agreement.
2. Frames: the given scenes at their own size and spp, ambient and specular 0 in both
   (``peers.comparable_scene``): texray against Mitsuba 3 (``llvm_ad_rgb``, ``direct``), times
   and image difference.

Every figure is a median over ``repeat`` runs after one warm-up; ratios are stated with their sense.
"""
from __future__ import annotations

import io
import os
import statistics
import time
from pathlib import Path

import texray as tx
from texray import peers, procedural
from texray.compile import compile_scene
from texray.trace import Tracer


def _ms(values):
    return {"median": statistics.median(values), "min": min(values), "max": max(values), "n": len(values)}


def cell(v, fmt=".2f", width=22):
    return f"{v['median']:{fmt}} ({v['min']:{fmt}}-{v['max']:{fmt}})".rjust(width)


def rays(device, triangles, size, repeat, threads_list):
    m = procedural.bench_mesh(triangles)
    scene = tx.Scene(camera=tx.Camera(eye=(0.0, 0.4, 3.2), look_at=(0, 0, 0), fov_y=40),   # = texray bench
                     lights=[tx.PointLight((3.0, 4.0, 5.0), (40, 40, 40))])
    scene.add(tx.Mesh(m.positions, m.faces, name=f"bench_mesh({triangles})"))
    t0 = time.perf_counter()
    cs = compile_scene(scene)
    build = time.perf_counter() - t0
    tracer = Tracer(cs, device)
    org, dirs = peers.primary_rays(scene.camera, size)
    prim, hits = [], None
    for i in range(repeat + 1):
        hits = tracer.closest(org, dirs)
        if i:
            prim.append(len(dirs) / hits.seconds * 1e-6)
    face = peers.texray_face_ids(cs, hits)
    so, sd = peers.shadow_rays(org, dirs, hits.t, face >= 0, scene.lights[0].position)
    shadow, occ = [], None
    for i in range(repeat + 1):
        occ, secs = tracer.occluded(so, sd, 0.0, 1.0)
        if i:
            shadow.append(len(so) / secs * 1e-6)
    ours = {"device": tracer.rt.device.name.strip(), "triangles": int(len(m.faces)), "rays": int(len(dirs)),
            "scene_compile_s": build, "primary_mrays_s": _ms(prim), "shadow_rays": int(len(so)),
            "shadow_mrays_s": _ms(shadow)}
    theirs = [peers.embree_rays(m.positions, m.faces, org, dirs, so, sd, repeat=repeat, threads=t,
                                texray_hits=(hits.t, face), texray_occluded=occ) for t in threads_list]
    return ours, theirs


def frames(path, device, repeat, width=None, height=None, spp=None):
    scene = tx.Scene.load(path)
    rs = getattr(scene, "render_settings", {}) or {}
    w, h, s = width or rs.get("width", 512), height or rs.get("height", 384), spp or rs.get("spp", 16)
    cmp, notes = peers.comparable_scene(scene)
    first = tx.render(cmp, w, h, s, device=device)
    runs = [tx.render(cmp, w, h, s, device=device) for _ in range(repeat)]
    ours = {"render_s": _ms([r.stats["render_s"] for r in runs]),
            "prep_s": _ms([r.stats["total_s"] - r.stats["render_s"] for r in runs]),
            "first_total_s": first.stats["total_s"]}
    rgb, st = peers.mitsuba_render(cmp, w, h, s, repeat=repeat)
    diff = peers.compare_images(runs[-1].rgb, rgb)
    return {"scene": str(path), "width": w, "height": h, "spp": s, "texray": ours, "mitsuba": st,
            "diff": diff, "notes": notes + st["notes"]}


def bench_peers(device, repeat=5, triangles=1_000_000, size=1024, scenes=(), threads=None):
    """Run the peers; returns the results dict with ``lines`` (the printed tables)."""
    threads = threads or sorted({1, os.cpu_count() or 1})
    out = io.StringIO()

    av = peers.available()
    out.write(f"texray {tx.__version__}; peers: " + ", ".join(
        f"{k} {v.get('version', '-')}" + (f" ({v['variant']}, LLVM {v['llvm']})" if v.get("variant") else "")
        if v["ok"] else f"{k} missing" for k, v in av.items()) + "\n")
    result = {"available": av}
    if av["embree"]["ok"]:
        ours, theirs = rays(device, triangles, size, repeat, threads)
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
                  "lights x pi; median render s (min-max)\n")
        out.write(f"| {'scene':<24} | {'texray s':>19} | {'Mitsuba s':>19} | {'ratio':>5} | {'Mi load s':>9} |"
                  f" {'Mi 1st s':>8} | {'RMSE':>7} | {'rel mean':>8} | {'rel |d|':>7} | {'px>0.05':>7} |\n")
        out.write(f"|{'-' * 26}|{'-' * 20}:|{'-' * 20}:|{'-' * 6}:|{'-' * 10}:|{'-' * 9}:|{'-' * 8}:|{'-' * 9}:|"
                  f"{'-' * 8}:|{'-' * 8}:|\n")
        for f in result["frames"]:
            o, m, d = f["texray"]["render_s"], f["mitsuba"]["render_s"], f["diff"]
            name = f"{Path(f['scene']).stem} {f['width']}x{f['height']} {f['spp']}spp"
            out.write(f"| {name:<24} | {cell(o, '.3f', 19)} | {cell(m, '.3f', 19)} | {m['median'] / o['median']:5.2f} |"
                      f" {f['mitsuba']['load_s']:9.3f} | {f['mitsuba']['first_render_s']:8.3f} | {d['rmse']:7.4f} |"
                      f" {100 * d['rel_mean_diff']:7.2f}% | {100 * d['rel_mean_abs']:6.2f}% |"
                      f" {100 * d['frac_pixels_over']:6.2f}% |\n")
        out.write("ratio = Mitsuba / texray render time (> 1: texray faster)\n")
        for line in skipped:
            out.write(f"  not compared: {line}\n")
        for note in dict.fromkeys(n for f in result["frames"] for n in f["notes"]):
            out.write(f"  note: {note}\n")
    result["lines"] = out.getvalue().rstrip("\n").splitlines()
    return result
