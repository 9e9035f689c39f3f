"""Speed/accuracy sweeps: every knob that trades one for the other, measured as
frame time against the error from a reference image of the same scene.

The reference is the same scene at many samples per pixel (``ref_spp``,
default 256) with bilinear texture lookups and the exact (analytic) bump
gradient: the pixel's box-filtered integral of the surface, to which every
setting converges. Its own Monte
Carlo noise is about 1/sqrt(ref_spp / spp) of a swept setting's, so errors
below ~1/4 of the 16-spp error are not resolved (the table says the ref spp).

A *series* is one curve of the error-against-time plot: a knob held fixed
(e.g. the filter mode) while spp varies. New knobs (bump delta, displacement
steps) add series here; the table, JSON, report and plot take them as they are.
"""
from __future__ import annotations

import inspect

import numpy as np

from .bench_suite import median_spread

SPP_VALUES = (1, 2, 4, 8, 16, 32, 64)
FILTER_SPP = (1, 4, 16)
FILTERS = ("nearest", "bilinear", "trilinear")
# Bump steps, in texels of the height texture ("analytic": the exact gradient of the
# bilinear interpolant, which the reference uses), each at BUMP_SPP samples.
BUMP_DELTAS = ("analytic", 0.5, 1, 2, 4, 8)
BUMP_SPP = (1, 4, 16)


def error_metrics(img, ref):
    """RMSE (linear RGB), RMSE relative to the reference's mean, and the fraction of
    pixels off by more than 0.02 (about half an 8-bit sRGB step in the mid-tones)."""
    d = img.astype(np.float64) - ref.astype(np.float64)
    rmse = float(np.sqrt(np.mean(d * d)))
    mean = float(np.mean(ref))
    return {"rmse": rmse, "rel_rmse": rmse / mean if mean > 0 else None,
            "bad_pixels": float(np.mean(np.max(np.abs(d), axis=2) > 0.02))}


def _supports(name):
    from .render import render
    return name in inspect.signature(render).parameters


def _bumps(scene):
    return [o.material.bump for o in scene.objects if getattr(o.material, "bump", None) is not None]


def with_bump_delta(scene, texels):
    """A copy of ``scene`` whose bump maps all use the step ``texels`` (texels of each height
    texture, or "analytic"); the scene itself is not changed."""
    import copy
    import dataclasses
    from .bump import Bump
    out = copy.copy(scene)
    out.objects = []
    cache = {}
    for o in scene.objects:
        b = getattr(o.material, "bump", None)
        if b is not None:
            if id(o.material) not in cache:
                h, w = b.texture.shape
                delta = "analytic" if texels == "analytic" else min(0.5, texels / max(h, w))
                nb = Bump(b.texture, height=b.height, delta=delta)
                cache[id(o.material)] = dataclasses.replace(o.material, bump=nb)
            o = copy.copy(o)
            o.material = cache[id(o.material)]
        out.objects.append(o)
    return out


def series_for(scene, compiled, spp_values=SPP_VALUES, filter_spp=FILTER_SPP):
    """The sweep's series for a scene: [(series name, [(label, render kwargs)])]; the kwarg
    ``bump_texels`` is applied to the scene (with_bump_delta), the others go to render()."""
    out = [("spp", [(f"{s} spp", {"spp": s}) for s in spp_values])]
    if compiled.textures is not None and _supports("texture_filter"):
        for f in FILTERS:
            out.append((f"filter={f}", [(f"{f} {s} spp", {"spp": s, "texture_filter": f}) for s in filter_spp]))
    if _bumps(scene):
        for d in BUMP_DELTAS:
            name = "bump delta=analytic" if d == "analytic" else f"bump delta={d} texel"
            out.append((name, [(f"delta {d} {s} spp", {"spp": s, "bump_texels": d}) for s in BUMP_SPP]))
    return out


def sweep_scene(scene, compiled, device, width, height, repeat, ref_spp=256, spp_values=SPP_VALUES,
                filter_spp=FILTER_SPP):
    """{"reference": ..., "series": {name: [point]}}, point = label, settings, time, errors."""
    from .render import render
    ref_kw = {"texture_filter": "bilinear"} if compiled.textures is not None and _supports("texture_filter") else {}
    ref_scene = with_bump_delta(scene, "analytic") if _bumps(scene) else scene
    ref = render(ref_scene, width, height, ref_spp, device=device, seed=12345, **ref_kw)
    if _bumps(scene):
        ref_kw = dict(ref_kw, bump="analytic")
    result = {"width": width, "height": height, "ref_spp": ref_spp, "reference_s": ref.stats["render_s"],
              "reference_settings": ref_kw, "series": {}}
    for name, points in series_for(scene, compiled, spp_values, filter_spp):
        rows = []
        for label, kw in points:
            setting, kw = dict(kw), dict(kw)
            spp = kw.pop("spp")
            sc = with_bump_delta(scene, kw.pop("bump_texels")) if "bump_texels" in kw else scene
            render(sc, width, height, spp, device=device, **kw)      # warm-up (program build)
            times, img = [], None
            for i in range(repeat):
                r = render(sc, width, height, spp, device=device, seed=i, **kw)
                times.append(r.stats["render_s"])
                img = r.rgb if img is None else img
            rows.append({"label": label, **setting, "frame_s": median_spread(times),
                         **error_metrics(img, ref.rgb)})
        result["series"][name] = rows
    return result


def plot(sweeps, path):
    """Error (RMSE) against frame time, log-log, one panel per scene, one curve per
    series. Needs matplotlib (``pip install texray[bench]``); returns False without it."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    n = len(sweeps)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.2), squeeze=False)
    for ax, (scene, sw) in zip(axes[0], sweeps.items()):
        for name, rows in sw["series"].items():
            t = [1e3 * r["frame_s"]["median"] for r in rows]
            e = [r["rmse"] for r in rows]
            ax.plot(t, e, "o-", label=name)
            for r, x, y in zip(rows, t, e):
                ax.annotate(str(r["spp"]), (x, y), textcoords="offset points", xytext=(3, 3), fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("frame time (ms)")
        ax.set_ylabel(f"RMSE vs {sw['ref_spp']}-spp reference")
        ax.set_title(f"{scene} {sw['width']}x{sw['height']} (labels: spp)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True
