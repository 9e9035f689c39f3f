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


# --- Displacement (issue 7): the search's N and M, maxmip, against the tessellation ----
DISP_STEPS = (4, 8, 16, 32, 64, 128)
DISP_REFINE = (0, 4, 8)


def displacement_scenes(size=256):
    """The sweep's scenes, built in code: a brick wall seen at grazing angles, a planet
    with mountains, a terrain with one-texel spikes; each {name: (scene, Displacement
    factory(method, **knobs))}."""
    from .displace import Displacement
    from .scene import Camera, Material, PointLight, Quad, Scene, Sphere
    from .texture import Texture
    rng = np.random.default_rng(7)
    y, x = np.mgrid[0:size, 0:size] / size
    row = np.floor(y * 8)
    bx = (x * 4 + 0.5 * (row % 2)) % 1
    by = (y * 8) % 1
    brick = np.minimum(np.minimum(bx, 1 - bx) * 4, np.minimum(by, 1 - by) * 2).clip(0, 0.1) * 10
    freq = np.fft.fftfreq(size)
    spec = rng.normal(size=(size, size)) + 1j * rng.normal(size=(size, size))
    spec /= np.maximum(np.hypot(freq[None, :], freq[:, None]), 1.0 / size) ** 2.2
    mountains = np.real(np.fft.ifft2(spec))
    mountains = (mountains - mountains.min()) / np.ptp(mountains)
    terrain = 0.25 * mountains
    ij = rng.integers(0, size, (size // 4, 2))
    terrain[ij[:, 0], ij[:, 1]] = 1.0                      # one-texel spikes
    light = [PointLight(position=(3, 4, 3), intensity=(25, 25, 25))]

    def tex(a):
        return Texture.from_array(a.astype(np.float32)[:, :, None], wrap="clamp")

    def factory(t, scale):
        return lambda method, **kw: Displacement(t, scale=scale, method=method, **kw)

    out = {}
    wall = factory(tex(brick), 0.04)
    out["brick wall (grazing)"] = (lambda d: _one(Scene(camera=Camera(eye=(-1.6, 0.25, 0.9), look_at=(0.4, 0.0, -0.6),
                                                                      fov_y=40), lights=light),
                                                  Quad((-1, -0.6, 0), (1, -0.6, 0), (1, 0.6, 0), (-1, 0.6, 0),
                                                       material=Material(diffuse=(0.7, 0.35, 0.25),
                                                                         displacement=d))), wall)
    planet = factory(Texture.from_array(mountains.astype(np.float32)[:, :, None]), 0.08)
    out["planet"] = (lambda d: _one(Scene(camera=Camera(eye=(0, 0.4, 3.2), look_at=(0, 0, 0), fov_y=35), lights=light),
                                    Sphere(radius=0.8, axis_z=(0, 1, 0), material=Material(displacement=d))), planet)
    spikes = factory(tex(terrain), 0.3)
    out["terrain (spikes)"] = (lambda d: _one(Scene(camera=Camera(eye=(0, 0.9, 1.9), look_at=(0, 0, -0.2), fov_y=45),
                                                    lights=light),
                                              Quad((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1),
                                                   material=Material(diffuse=(0.5, 0.6, 0.4), displacement=d))),
                               spikes)
    return out


def _one(scene, obj):
    scene.add(obj)
    return scene


def displacement_sweep(device=None, width=384, height=288, repeat=3, size=256, steps=DISP_STEPS,
                       refine=DISP_REFINE):
    """{scene: [row]}: the tessellated reference (one vertex per texel) and every search
    (N, M), adaptive N and maxmip setting: frame time (median of ``repeat`` renders at 1
    spp, pixel centres; end to end: scene compile, BVH, upload, render), its render part,
    device memory, RMSE against the reference and the fraction of pixels whose first hit
    differs (a different object, a hit against a miss, or depth off by more than 1%)."""
    import time

    from .render import render
    result = {}
    for name, (make, disp) in displacement_scenes(size).items():
        def run(d):
            times, img = [], None
            for _ in range(repeat):
                t0 = time.perf_counter()
                img = render(make(d), width, height, 1, device=device, jitter=False, aovs=("depth", "object_id"))
                times.append(time.perf_counter() - t0)
            return img, float(np.median(times))
        ref, ref_s = run(disp("tessellate"))
        rows = [_disp_row("tessellate (1 vertex/texel)", ref, ref_s, ref)]
        for n in steps:
            for m in refine:
                img, s = run(disp("search", steps=n, refine=m))
                rows.append(_disp_row(f"search N={n} M={m}", img, s, ref))
        for n in (8, 32):
            img, s = run(disp("search", steps=n, refine=8, adaptive=True))
            rows.append(_disp_row(f"search adaptive N={n} M=8", img, s, ref))
        if "planet" not in name:
            img, s = run(disp("maxmip"))
            rows.append(_disp_row("maxmip", img, s, ref))
        result[name] = rows
    return result


def _disp_row(label, img, seconds, ref):
    da, db = img.aov["depth"][..., 0], ref.aov["depth"][..., 0]
    oa, ob = img.aov["object_id"][..., 0], ref.aov["object_id"][..., 0]
    with np.errstate(invalid="ignore"):
        wrong = (oa != ob) | (np.isnan(da) != np.isnan(db)) | (np.abs(da - db) > 0.01 * db)
    return {"setting": label, "time_s": seconds, "render_s": img.stats["render_s"],
            "device_mib": sum(img.stats["device_bytes"].values()) / 2 ** 20,
            "rmse": error_metrics(img.rgb, ref.rgb)["rmse"], "wrong_hit": float(np.mean(wrong))}


def displacement_table(result):
    """Markdown table of :func:`displacement_sweep`."""
    lines = []
    for name, rows in result.items():
        lines += [f"**{name}**", "", "| setting | frame s | render s | device MiB | RMSE | wrong first hit |",
                  "|---|---|---|---|---|---|"]
        for r in rows:
            lines.append(f"| {r['setting']} | {r['time_s']:.3f} | {r['render_s']:.3f} | {r['device_mib']:.2f} | "
                         f"{r['rmse']:.4f} | {100 * r['wrong_hit']:.2f}% |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":                      # python -m texray.bench_sweep [WIDTH HEIGHT]
    import sys
    w, h = (int(sys.argv[1]), int(sys.argv[2])) if len(sys.argv) > 2 else (384, 288)
    print(displacement_table(displacement_sweep(width=w, height=h)))
