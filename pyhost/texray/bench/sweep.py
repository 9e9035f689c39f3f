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

import copy
import time
import dataclasses

import numpy as np

from ..compile import compile_scene
from ..errors import SceneError
from ..renderer import render
from ..scene import Bump, Displacement, Scene
from ..scene.shape import materials_of
from .suite import median_spread
from .suite import suite_paths

SPP_VALUES = (1, 2, 4, 8, 16, 32, 64)
FILTER_SPP = (1, 4, 16)
FILTERS = ("nearest", "bilinear", "trilinear", "anisotropic")
# Bump steps, in texels of the height texture ("analytic": the exact gradient of the
# bilinear interpolant, which the reference uses), each at BUMP_SPP samples.
BUMP_DELTAS = ("analytic", 0.5, 1, 2, 4, 8)
BUMP_SPP = (1, 4, 16)
# Adaptive sampling (texray.renderer.adaptive): thresholds, each with at most ADAPTIVE_SPP samples.
ADAPTIVE_THRESHOLDS = (0.1, 0.05, 0.02, 0.01)
ADAPTIVE_SPP = 64


def error_metrics(img, ref):
    """RMSE (linear RGB), RMSE relative to the reference's mean, and the fraction of
    pixels off by more than 0.02 (about half an 8-bit sRGB step in the mid-tones)."""
    d = img.astype(np.float64) - ref.astype(np.float64)
    rmse = float(np.sqrt(np.mean(d * d)))
    mean = float(np.mean(ref))
    return {"rmse": rmse, "rel_rmse": rmse / mean if mean > 0 else None,
            "bad_pixels": float(np.mean(np.max(np.abs(d), axis=2) > 0.02))}


def _bumps(scene):
    return [m.bump for o in scene.objects for m in materials_of(o) if m.bump is not None]


def _with_role(scene, role, make):
    """A copy of ``scene`` in which every material's ``role`` (bump, displacement) that is
    set is replaced by ``make(old)`` (one new material per old one); the scene itself is
    not changed."""
    out = copy.copy(scene)
    out.objects = []
    cache = {}
    def new(m):
        old = getattr(m, role)
        if old is None:
            return m
        if id(m) not in cache:
            cache[id(m)] = dataclasses.replace(m, **{role: make(old)})
        return cache[id(m)]

    for o in scene.objects:
        mats = materials_of(o)
        if any(getattr(m, role) is not None for m in mats):
            o = copy.copy(o)
            o.material = [new(m) for m in mats] if isinstance(o.material, (list, tuple)) else new(o.material)
        out.objects.append(o)
    return out


def with_bump_delta(scene, texels):
    """A copy of ``scene`` whose bump maps all use the step ``texels`` (texels of each height
    texture, or "analytic"); the scene itself is not changed."""

    def make(b):
        delta = "analytic" if texels == "analytic" else min(0.5, texels / max(b.texture.shape))
        return Bump(b.texture, height=b.height, delta=delta)
    return _with_role(scene, "bump", make)


def series_for(scene, compiled, spp_values=SPP_VALUES, filter_spp=FILTER_SPP):
    """The sweep's series for a scene: [(series name, [(label, render kwargs)])]; the kwarg
    ``bump_texels`` is applied to the scene (with_bump_delta), the others go to render().
    A displaced scene gets the displacement series instead (:func:`displacement_series`)."""
    if displaced(scene):
        return displacement_series(scene)
    out = [("spp", [(f"{s} spp", {"spp": s}) for s in spp_values]),
           (f"adaptive <= {ADAPTIVE_SPP} spp", [(f"adaptive {t}", {"spp": ADAPTIVE_SPP, "adaptive": t})
                                                 for t in ADAPTIVE_THRESHOLDS])]
    if len(scene.lights) >= 2:
        out.append(("one light per sample", [(f"1 light {s} spp", {"spp": s, "light_sampling": "one"})
                                             for s in spp_values]))
    if compiled.textures is not None:
        for f in FILTERS:
            out.append((f"filter={f}", [(f"{f} {s} spp", {"spp": s, "texture_filter": f}) for s in filter_spp]))
    if _bumps(scene):
        for d in BUMP_DELTAS:
            name = "bump delta=analytic" if d == "analytic" else f"bump delta={d} texel"
            out.append((name, [(f"delta {d} {s} spp", {"spp": s, "bump_texels": d}) for s in BUMP_SPP]))
    return out


def sweep_scene(scene, compiled, device, width, height, repeat, ref_spp=256, spp_values=SPP_VALUES,
                filter_spp=FILTER_SPP, client=None):
    """{"reference": ..., "series": {name: [point]}}, point = label, settings, time, errors.
    A displaced scene is swept by :func:`sweep_displacement` (``ref_spp``, ``spp_values`` and
    ``filter_spp`` do not apply). client: a dask.distributed.Client: the reference renders
    in bands on the cluster and each point is a task (its times are its worker's)."""
    if displaced(scene):
        return sweep_displacement(scene, device, width, height, repeat, client)
    ref_kw = {"texture_filter": "bilinear"} if compiled.textures is not None else {}
    ref_scene = with_bump_delta(scene, "analytic") if _bumps(scene) else scene
    ref = render(ref_scene, width, height, ref_spp, device=device, seed=12345, client=client, **ref_kw)
    if _bumps(scene):
        ref_kw = dict(ref_kw, bump="analytic")
    result = {"width": width, "height": height, "ref_spp": ref_spp, "reference_s": ref.stats["render_s"],
              "reference_settings": ref_kw, "series": {}}
    series = series_for(scene, compiled, spp_values, filter_spp)
    points = [kw for _, pts in series for _, kw in pts]
    measured = iter(run_points(sweep_point, (scene, width, height, device, repeat, ref.rgb), points, client))
    for name, pts in series:
        result["series"][name] = [{"label": label, **kw, **next(measured)} for label, kw in pts]
    return result


def sweep_point(scene, width, height, device, repeat, ref_rgb, kw):
    """One setting ``kw`` of a sweep: its frame time (median of ``repeat`` renders after a
    warm-up), mean samples per pixel and errors against the reference."""
    kw = dict(kw)
    spp = kw.pop("spp")
    sc = with_bump_delta(scene, kw.pop("bump_texels")) if "bump_texels" in kw else scene
    render(sc, width, height, spp, device=device, **kw)      # warm-up (program build)
    times, img, samples = [], None, None
    for i in range(repeat):
        r = render(sc, width, height, spp, device=device, seed=i, **kw)
        times.append(r.stats["render_s"])
        if img is None:
            img, samples = r.rgb, r.stats["samples"]
    return {"frame_s": median_spread(times), "mean_spp": samples / (width * height), **error_metrics(img, ref_rgb)}


def run_points(func, shared, points, client=None):
    """[func(*shared, point) for point in points], here or, with a Dask client, as one
    task per point (the shared arguments sent to every worker once), in order."""
    if client is None:
        return [func(*shared, p) for p in points]
    held = [client.scatter(a, broadcast=True, hash=False) if isinstance(a, (Scene, np.ndarray)) else a
            for a in shared]
    futures = [client.submit(func, *held, p, pure=False) for p in points]
    try:
        return client.gather(futures)
    finally:
        client.cancel(futures + [h for h in held if hasattr(h, "key")])


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
    cols = min(n, 3)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(5.6 * cols, 4.4 * rows), squeeze=False)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    for ax, (scene, sw) in zip(axes.ravel(), sweeps.items()):
        disp = sw.get("kind") == "displacement"
        for name, rows in sw["series"].items():
            t = [1e3 * r["frame_s"]["median"] for r in rows]
            e = [r["rmse"] for r in rows]
            ax.plot(t, e, "o-", label=name)
            for r, x, y in zip(rows, t, e):
                tag = r.get("spp", r.get("steps", r.get("resolution", "")))
                ax.annotate(str(tag), (x, y), textcoords="offset points", xytext=(3, 3), fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("frame time, setup included (ms)" if disp else "frame time (ms)")
        ax.set_ylabel(f"RMSE vs {sw['reference']}" if disp else f"RMSE vs {sw['ref_spp']}-spp reference")
        ax.set_title(f"{scene} {sw['width']}x{sw['height']} (labels: {'N' if disp else 'spp'})")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


# --- Displacement: the search's N and M, maxmip, against the tessellation ----
DISP_STEPS = (4, 8, 16, 32, 64, 128)
DISP_REFINE = (0, 4, 8)


# The displacement sweep's scenes: scenes/bench/<name>.toml (height maps from tools/make_assets.py).
DISP_SCENES = ("terrain", "displaced_wall", "planet")


def displaced(scene):
    """True when some object of ``scene`` has a displacement map."""
    return any(m.displacement is not None for o in scene.objects for m in materials_of(o))


def with_displacement(scene, method, **knobs):
    """A copy of ``scene`` whose displacement maps all use ``method`` and ``knobs`` (steps,
    refine, adaptive, resolution), keeping each map's texture, scale and offset; the
    scene itself is not changed."""
    return _with_role(scene, "displacement", lambda d: Displacement(d.texture, scale=d.scale, offset=d.offset,
                                                                    method=method, **knobs))


def maxmip_applies(scene):
    """maxmip displaces planar convex quads, spheres, cylinders and triangle meshes (their
    shells): does every displaced object take it?"""
    try:
        compile_scene(with_displacement(scene, "maxmip"))
    except SceneError:
        return False
    return True


def displacement_scenes(names=DISP_SCENES):
    """The displacement sweep's scenes, loaded from scenes/bench/: {name: (scene, factory)},
    factory(method, **knobs) -> the scene with every displacement map set to that method
    (:func:`with_displacement`)."""
    out = {}
    for name, path in suite_paths(list(names)).items():
        scene = Scene.load(path)
        out[name] = (scene, lambda method, _s=scene, **kw: with_displacement(_s, method, **kw))
    return out


def search_applies(scene):
    """The per-pixel search displaces spheres, cylinders, planar convex quads and triangle
    meshes (prism shells, texray.compile.shells): does every displaced object take it?"""
    try:
        compile_scene(with_displacement(scene, "search"))
    except SceneError:
        return False
    return True


def displacement_series(scene):
    """The displacement sweep's series, one curve per method: the linear + binary search with N
    varying at each M, the adaptive search, maxmip (where every displaced object is a
    planar convex quad, a sphere, a cylinder or a mesh: :func:`maxmip_applies`) and the
    tessellation at 1 and 2 vertices per texel (compared like the others with the
    reference, a tessellation at DISP_REF_RESOLUTION). A scene
    where the search does not apply gets the tessellations only (:func:`search_applies`).
    [(series name, [(label, {"method": ..., knobs})])]."""
    tessellate = ("tessellate", [(f"tessellate {r} vertex/texel", {"method": "tessellate", "resolution": r})
                                 for r in DISP_TESSELLATIONS])
    if not search_applies(scene):
        return [tessellate]
    out = [(f"search M={m}", [(f"search N={n} M={m}", {"method": "search", "steps": n, "refine": m})
                              for n in DISP_STEPS]) for m in DISP_REFINE]
    out.append(("search adaptive M=8", [(f"search adaptive N={n} M=8",
                                         {"method": "search", "steps": n, "refine": 8, "adaptive": True})
                                        for n in DISP_ADAPTIVE_STEPS]))
    if maxmip_applies(scene):
        out.append(("maxmip", [("maxmip", {"method": "maxmip"})]))
    return out + [tessellate]


DISP_ADAPTIVE_STEPS = (8, 32)
DISP_TESSELLATIONS = (1, 2)
# The reference: the true displaced surface as a tessellation fine enough that its own error
# is far below every compared setting's (4 vertices per texel and axis: each bilinear cell
# as 32 flat triangles), so "tessellate 1 vertex/texel" gets an error of its own and the
# search can be compared with it at equal error.
DISP_REF_RESOLUTION = 4
DISP_REFERENCE = f"tessellate ({DISP_REF_RESOLUTION} vertices/texel)"


def sweep_displacement(scene, device, width, height, repeat, client=None):
    """Every setting of :func:`displacement_series` against the tessellated reference, at 1
    spp through pixel centres. Per point: ``frame_s``, end to end (scene compile with the
    host tessellation, BVH build, upload, render: what a user waits for) over ``repeat``
    renders after an untimed one that also gives the AOVs; ``render_s``, the device part;
    ``device_mib``; RMSE (linear RGB) against the reference, and ``wrong_hit``, the
    fraction of pixels whose first hit differs from the reference's (another object, a
    hit against a miss, or depth off by more than 1%)."""

    series = displacement_series(scene)
    ref_scene = with_displacement(scene, "tessellate", resolution=DISP_REF_RESOLUTION)
    t0 = time.perf_counter()
    ref = render(ref_scene, width, height, 1, device=device, jitter=False, aovs=("depth", "object_id"))
    ref_s = time.perf_counter() - t0
    settings = [kw for _, pts in series for _, kw in pts]
    measured = iter(run_points(displacement_point, (scene, width, height, device, repeat), settings, client))
    points = {label: next(measured) for _, pts in series for label, _ in pts}
    result = {"kind": "displacement", "width": width, "height": height, "ref_spp": 1, "reference": DISP_REFERENCE,
              "reference_s": ref_s, "reference_device_mib": _mib(ref), "series": {}}
    for name, pts in series:
        rows = []
        for label, kw in pts:
            img, wall, dev = points[label]
            rows.append({"label": label, **kw, "frame_s": wall, "render_s": dev, "device_mib": _mib(img),
                         **error_metrics(img.rgb, ref.rgb), "wrong_hit": _wrong_hits(img, ref)})
        result["series"][name] = rows
    return result


def displacement_point(scene, width, height, device, repeat, kw):
    """One setting of the displacement sweep: (its first image, with the depth and object
    AOVs; median wall time; median device time)."""
    kw = dict(kw)
    sc = with_displacement(scene, kw.pop("method"), **kw)
    # cache=False: every render compiles the scene (tessellation, BVH) anew, as a first
    # render does; the scene cache would hand the timed renders the tessellation it
    # stored for the first (and keep 100 MiB entries of the bench's settings)
    first = render(sc, width, height, 1, device=device, jitter=False, aovs=("depth", "object_id"), cache=False)
    render(sc, width, height, 1, device=device, jitter=False, cache=False)     # warm-up: the program without AOVs
    wall, dev = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = render(sc, width, height, 1, device=device, jitter=False, cache=False)
        wall.append(time.perf_counter() - t0)
        dev.append(r.stats["render_s"])
    first.stats = {"device_bytes": first.stats["device_bytes"]}      # what the table reads
    return first, median_spread(wall), median_spread(dev)


def _mib(img):
    return sum(img.stats["device_bytes"].values()) / 2 ** 20


def _wrong_hits(img, ref):
    da, db = img.aov["depth"][..., 0], ref.aov["depth"][..., 0]
    oa, ob = img.aov["object_id"][..., 0], ref.aov["object_id"][..., 0]
    with np.errstate(invalid="ignore"):
        wrong = (oa != ob) | (np.isnan(da) != np.isnan(db)) | (np.abs(da - db) > 0.01 * db)
    return float(np.mean(wrong))
