"""The benchmark's standard scenes (``scenes/bench/``) and what is measured on each.

Per scene and device: whole frames and each kernel stage (OpenCL profiling
events), for the specialized program (compiled for the scene's features) and
the generic one (every feature compiled in); cold and warm program builds
(fresh processes, see :mod:`texray.bench.buildtime`); device memory. Every figure is
the median over ``repeat`` runs after one warm-up run, with min and max.
"""
from __future__ import annotations

import importlib.util
import statistics
from pathlib import Path

from ..compile import compile_scene
from ..device.features import compile_options
from ..renderer import render
from ..scene import Scene
from .buildtime import measure

# The suite, in the order it runs. Each is scenes/bench/<name>.toml.
SUITE = ("mesh1m", "globe", "grazing_quad", "mixed", "brick_wall", "bump_globe")


def median_spread(values):
    values = list(values)
    return {"median": statistics.median(values), "min": min(values), "max": max(values), "n": len(values)}


def scenes_dir() -> Path:
    """The scenes shipped with texray: the source tree's ``scenes/`` when running from one
    (pyhost/texray/bench/suite.py -> the repository), else the installed package
    ``texray.scenes`` (the same folder, put into the wheel). Not the working directory's:
    the bench runs the same scenes wherever it is started."""
    repo = Path(__file__).resolve().parents[3] / "scenes"
    if (repo / "bench").is_dir():
        return repo
    try:
        spec = importlib.util.find_spec("texray.scenes")
    except ImportError:
        spec = None
    for loc in (spec.submodule_search_locations or ()) if spec is not None else ():
        if (Path(loc) / "bench").is_dir():
            return Path(loc)
    raise SystemExit("texray bench: the suite scenes (scenes/bench/) were not found: the installation is incomplete")


def suite_paths(names=None) -> dict[str, Path]:
    """name -> scene file for the chosen suite scenes (default: all of SUITE): a name of
    ``scenes/bench/`` (shipped with texray, see :func:`scenes_dir`), or a path to a .toml
    file, taken as it is (relative to the working directory)."""
    out = {}
    for name in names or SUITE:
        p = Path(name)
        if p.suffix == ".toml":
            if not p.is_file():
                raise SystemExit(f"texray bench: no scene file {name} (a .toml path is taken relative to the "
                                 f"working directory {Path.cwd()})")
            out[p.stem] = p
        elif (scenes_dir() / "bench" / f"{name}.toml").is_file():
            out[name] = scenes_dir() / "bench" / f"{name}.toml"
        else:
            raise SystemExit(f"texray bench: no suite scene {name!r} (known: {', '.join(_bench_names())}, "
                             f"or a .toml path)")
    return out


def _bench_names():
    return sorted(p.stem for p in (scenes_dir() / "bench").glob("*.toml"))


def frame_stats(runs, samples, shadow_rays):
    """Medians and spreads of a list of render stats."""
    stages = {k: median_spread([r["stage_s"][k] for r in runs]) for k in runs[0]["stage_s"]}
    frame = median_spread([r["render_s"] for r in runs])
    per_stage = {}
    for k, v in stages.items():
        work = shadow_rays if k == "shadow" else samples
        per_stage[k] = work / v["median"] * 1e-6 if v["median"] > 0 and work else None
    return {"frame_s": frame, "msamples_s": samples / frame["median"] * 1e-6, "stage_s": stages,
            "stage_mrays_s": per_stage}


def bench_scene(scene, compiled, device, width, height, spp, repeat, generic=True, local_size=None):
    """Frames of one scene on one device: the specialized program (fused pipeline, and the
    staged one for the per-stage times) and the generic program (fused)."""
    samples = width * height * spp
    shadow_rays = samples * len(compiled.lights) if compiled.features.shadows else 0
    out = {"width": width, "height": height, "spp": spp, "lights": int(len(compiled.lights))}
    variants = [("specialized", True, "fused"), ("stages", True, "stages")]
    if generic:
        variants.append(("generic", False, "fused"))
    for name, specialize, pipeline in variants:
        kw = dict(device=device, compiled=compiled, specialize=specialize, local_size=local_size, pipeline=pipeline)
        first = render(scene, width, height, spp, **kw)                    # warm-up (and build)
        runs = [render(scene, width, height, spp, **kw).stats for _ in range(repeat)]
        r = frame_stats(runs, samples, shadow_rays)
        r["program_build_s"] = first.stats["program_build_s"]
        r["device_bytes"] = sum(first.stats["device_bytes"].values())
        r["ray_buffer_bytes"] = first.stats["ray_buffer_bytes"]
        r["features"] = {k: v for k, v in vars(first.stats["features"]).items()}
        out[name] = r
    out["stages_over_fused"] = out["stages"]["frame_s"]["median"] / out["specialized"]["frame_s"]["median"]
    if generic:
        out["generic_over_specialized"] = (out["generic"]["frame_s"]["median"]
                                           / out["specialized"]["frame_s"]["median"])
    return out


def build_times(path, device, generic=True, repeat=1):
    """Cold and warm build seconds of the scene's specialized (and generic) program, medians
    of ``repeat`` fresh caches each (:func:`texray.bench.buildtime.measure`)."""
    out = {"specialized": measure(path, device, specialize=True, repeat=repeat)}
    if generic:
        out["generic"] = measure(path, device, specialize=False, repeat=repeat)
    return out


def program_variants(paths):
    """The distinct programs (feature sets) that rendering every scene in ``paths`` builds
    on PoCL's CPU device (the default; the packet rule depends on the device)."""
    seen = {}
    for p in paths:
        key = tuple(sorted(compile_options(compile_scene(Scene.load(p)).features, "pocl").items()))
        seen.setdefault(key, []).append(str(p))
    return [{"defines": dict(k), "scenes": v} for k, v in seen.items()]


def local_size_sweep(scene, compiled, device, width, height, spp, repeat, sizes):
    """Frame time per work-group size (0 = the driver's choice), interleaved over repeats
    so that machine noise hits every size alike."""
    times = {s: [] for s in sizes}
    for s in sizes:       # warm-up: PoCL generates code per local size
        render(scene, width, height, spp, device=device, compiled=compiled, local_size=s)
    for _ in range(repeat):
        for s in sizes:
            times[s].append(render(scene, width, height, spp, device=device, compiled=compiled,
                                   local_size=s).stats["render_s"])
    return {str(s): median_spread(v) for s, v in times.items()}
