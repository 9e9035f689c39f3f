"""Rendering: check the settings, compile the scene (or take it from the scene cache),
build its program and run it on a device (:mod:`.frame`) or on a Dask cluster
(:mod:`.distributed`).

The fused pipeline (the default) runs raygen -> intersect -> surface -> shadow ->
shade in one kernel per pixel and sample (kernels/stages/fused.cl); the staged one
runs the five stage kernels in turn with per-ray records in device memory between
them, so that each stage is timed on its own; both give the same image. Tiles are
bands of whole rows (:mod:`.tiling`), small enough that a launch never runs long
enough to trip a GPU display watchdog and that the per-ray buffers fit the device;
the image is read back tile by tile, so device memory does not grow with the image
size. Neither the tiles nor a band's place change a pixel (:mod:`.frame`).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from ..compile import CompiledScene, cache as scene_cache
from ..device import layout
from ..device.features import LIGHT_SAMPLING, generic_features
from ..errors import SceneError
from ..io.images import ScanlineWriter
from ..scene import Camera, Scene
from .. import validate as V
from . import distributed, uploads
from .adaptive import BLOCK_ROWS
from .frame import PIPELINES, RAY_BYTES, ROW_OPTIONS, device_program, launch_samples, render_rows
from .image import Image, check_host_memory, host_image_bytes

__all__ = ["LIGHT_SAMPLING", "RAY_BYTES", "Setup", "prepare", "render", "render_to_file", "scene_stats", "setup"]


def render(scene, width=640, height=480, spp=1, *, device=None, seed=0, jitter=True, shadows=True,
           aovs=(), specialize=True, local_size=None, memory_limit=None, tile_pixels=None, progress=None,
           sink=None, compiled=None, texture_filter=None, pipeline="fused", adaptive=None, cache=True, rows=None,
           client=None, camera=None, light_sampling="all") -> Image:
    """Render ``scene`` to a linear RGB image.

    spp: samples per pixel (correlated multi-jittered within the pixel, box
    filtered); jitter=False puts every sample at the pixel centre. seed
    changes the sample pattern; the same seed gives the same image.
    aovs: names from :data:`texray.device.layout.AOVS`, evaluated by one extra pass of
    pixel-centre rays and returned in ``image.aov[name]`` as float32 (H, W, C)
    arrays (NaN, or -1 for the ids, where the ray hits nothing).
    device: see :func:`texray.device.select_device`.
    pipeline: "fused" (default) runs every stage in one kernel per pixel, up to
    MAX_FUSED_SAMPLES samples of a tile per launch; "stages" runs the five
    stage kernels in turn with per-ray records in device memory between them,
    so each stage is timed on its own (``stats["stage_s"]``). Same image.
    specialize: compile the kernels for exactly the features the scene uses
    (default); False uses the one generic program with every feature compiled
    in (same image; the benchmark's baseline).
    local_size: work-group size of the per-ray kernels (0: the driver's
    choice; default: :meth:`texray.device.Runtime.local_size`).
    memory_limit: bytes of device memory the render may use (default: a
    quarter of the device's memory); the scene's arrays count against it and
    the rest bounds the rays in flight per tile. tile_pixels bounds them
    directly (default: from the memory limit, at most 2^20 so that no launch
    runs long enough to trip a GPU display watchdog). Neither changes the image.
    progress: optional callable(fraction_done) called after each pass.
    sink: optional callable(y0, rgb_rows, aov_rows) given each finished band
    of rows (float32 (rows, W, 3) and a dict like ``Image.aov``), in order of y0;
    the image is then not kept in host memory (``Image.rgb`` is None): see
    :func:`render_to_file` for images larger than memory.
    compiled: the result of :func:`texray.compile.compile_scene` for this
    scene, to skip compiling it again (the BVH of a big mesh takes seconds);
    it is not modified; the camera is ``scene``'s. ``scene`` may itself be a
    CompiledScene: then its own camera is used.
    texture_filter: None (each texture's own filter) or "nearest", "bilinear",
    "trilinear" or "anisotropic" for every texture (texray.device.layout.FILTERS); for a precompiled
    scene pass it to compile_scene instead.
    adaptive: None (every pixel takes spp samples) or a threshold t > 0: a
    pixel stops sampling once the standard error of its mean luminance is at
    most t times that mean (t times 0.1 below a mean of 0.1), checked after
    each round of about spp / 8 samples (at least 8), and while no neighbour
    in its block of 16 rows still samples (:mod:`texray.renderer.adaptive`);
    spp is then the most a pixel takes. ``stats["samples"]`` counts the samples
    taken. Fused pipeline only.
    light_sampling: "all" (default) sums every light's term in every sample (one shadow
    ray per light); "one" traces one shadow ray per sample, toward one light weighted by
    the light count, each pixel's samples taking the lights in turn from a per-pixel offset
    (kernels/core/sampler.h light_pick): the same mean, with more noise per sample and
    fewer rays, as Mitsuba's direct integrator samples its emitters. It changes nothing
    with fewer than two lights. Both pipelines, adaptive sampling too.
    cache: True (default) reads the compiled scene from the scene cache when this
    scene (not counting the camera) was compiled before, in any process, and stores
    it when its compile took long enough (:mod:`texray.compile.cache`; the README's
    "Scene cache"); the last two compiled scenes also stay in memory, so that an
    unchanged scene rendered again (another camera, size or spp) is not compiled
    again. False compiles it here and leaves the cache alone, as does
    ``TEXRAY_NO_CACHE=1``. ``stats["scene_cache"]``: "kept", "hit", "stored", "miss"
    or "off"; the same image either way.
    rows: None (the whole image) or (y0, y1): only the image's rows y0 <= y < y1, as
    a (y1 - y0, W, 3) image equal bit for bit to those rows of the whole image (with
    adaptive sampling y0 and y1 must be multiples of 16, or y1 = height).
    client: a ``dask.distributed.Client`` or a scheduler's address ("tcp://host:8786"):
    the image is cut into bands of rows that the cluster's workers render
    (:mod:`texray.renderer.distributed`; ``pip install 'texray[dask]'``), the same
    image, bit for bit, as without it on the same kind of device; ``device`` is
    then chosen on each worker. ``stats["dask"]`` tells the bands and the workers.
    camera: a :class:`texray.Camera` to render from instead of the scene's (see
    :func:`texray.render_frames` for a camera path).
    """
    dask_client = None if client is None else distributed.connect(client, "render: client")
    s = setup(scene, width, height, spp, device=device, seed=seed, jitter=jitter, shadows=shadows, aovs=aovs,
              specialize=specialize, local_size=local_size, memory_limit=memory_limit, tile_pixels=tile_pixels,
              progress=progress, sink=sink, compiled=compiled, texture_filter=texture_filter, pipeline=pipeline,
              adaptive=adaptive, cache=cache, rows=rows, camera=camera, light_sampling=light_sampling)
    if dask_client is not None:
        out = distributed.render_bands(dask_client, s.cs, s.camera, s.width, s.height, s.spp, s.rows, s.options,
                                       progress, sink)
        s.stats.update(out.stats, total_s=time.perf_counter() - s.t_start)
        return Image(rgb=out.rgb, aov=out.aov, stats=s.stats)
    t_compiled = time.perf_counter()
    samples = launch_samples(s.width, s.height, s.spp, s.options["adaptive"])
    rt, prg, local, packet = device_program(s.cs, device, local_size, samples, stages=s.options["pipeline"] == "stages")
    t_built = time.perf_counter()
    up, kept = uploads.uploaded(rt, s.cs, uploads.local_key(s.cs))
    t_uploaded = time.perf_counter()
    out = render_rows(rt, prg, s.cs, s.camera, s.width, s.height, s.spp, s.rows, local=local, progress=progress,
                      sink=sink, uploaded=up, **{k: s.options[k] for k in ROW_OPTIONS})
    t_end = time.perf_counter()
    s.stats.update({
        "device": rt.device.name.strip(), "program_build_s": t_built - t_compiled,
        "render_s": t_end - t_built, "upload_s": t_uploaded - t_built + out.upload_s, "upload_kept": kept,
        "total_s": t_end - s.t_start,
        "stage_s": out.stage_s, "tile_rows": out.tile_rows, "tiles": out.tiles, "local_size": local,
        "ray_buffer_bytes": out.ray_buffer_bytes, "samples": out.samples, "packet": packet,
    })
    return Image(rgb=out.rgb, aov=out.aov, stats=s.stats)


@dataclass
class Setup:
    """A render's checked settings and its compiled scene, before any device work
    (:func:`setup`): what render() runs here and a Dask cluster runs in bands."""
    cs: CompiledScene
    camera: Camera
    width: int
    height: int
    spp: int
    rows: tuple | None
    options: dict        # what every band needs: device, local_size and frame.ROW_OPTIONS
    stats: dict          # scene_stats() and scene_compile_s
    t_start: float


def setup(scene, width=640, height=480, spp=1, *, device=None, seed=0, jitter=True, shadows=True, aovs=(),
          specialize=True, local_size=None, memory_limit=None, tile_pixels=None, progress=None, sink=None,
          compiled=None, texture_filter=None, pipeline="fused", adaptive=None, cache=True, rows=None,
          camera=None, light_sampling="all") -> Setup:
    """Check :func:`render`'s settings (its arguments, less ``client``) and compile the
    scene (or take it from the scene cache)."""
    width, height, spp, seed = V.render_settings(width, height, spp, seed)
    aovs = _check_options(aovs, pipeline, progress, sink, jitter=jitter, shadows=shadows, specialize=specialize,
                          cache=cache)
    if adaptive is not None:
        adaptive = V.number(adaptive, "adaptive", "render: ", 0.0, lo_open=True)
        if pipeline != "fused":
            raise SceneError("render: adaptive: adaptive sampling runs in the fused pipeline; pass pipeline='fused'")
    V.one_of(light_sampling, LIGHT_SAMPLING, "light_sampling", "render: ")
    rows = _check_rows(rows, height, adaptive)
    band = height if rows is None else rows[1] - rows[0]
    if sink is None:
        check_host_memory(host_image_bytes(width, band, aovs), width, band)
    t_start = time.perf_counter()
    if camera is not None and not isinstance(camera, Camera):
        raise SceneError(f"render: camera: expected a texray.Camera, got {V.show(camera)}")
    cs, scene_camera, cache_stats = prepare(scene, compiled, shadows, texture_filter, aovs, specialize, cache,
                                            adaptive, light_sampling)
    stats = scene_stats(cs, width, height, spp, specialize, pipeline, adaptive, cache_stats)
    stats["light_sampling"] = light_sampling
    stats["scene_compile_s"] = time.perf_counter() - t_start
    options = dict(device=device, local_size=local_size, seed=seed, jitter=jitter, aovs=aovs, adaptive=adaptive,
                   pipeline=pipeline, memory_limit=memory_limit, tile_pixels=tile_pixels)
    return Setup(cs, scene_camera if camera is None else camera, width, height, spp, rows, options, stats, t_start)


def scene_stats(cs, width, height, spp, specialize, pipeline, adaptive, cache_stats):
    """The stats of a render that come from the scene and the settings."""
    return {
        "width": width, "height": height, "spp": spp,
        "triangles": int(len(cs.tri_verts)), "spheres": int(len(cs.spheres)), "cylinders": int(len(cs.cylinders)),
        "quads": int(len(cs.quad_verts)), "bvh_nodes": int(len(cs.nodes)), "bvh_depth": cs.wide_depth,
        "bvh_binary_nodes": int(len(cs.bvh.nodes)), "bvh_binary_depth": cs.bvh.depth,
        "bvh_build_s": cs.bvh.build_seconds, "sah_cost": cs.bvh.sah_cost,
        "compile_steps_s": dict(cs.steps_s or {}), "blas_reused": cs.blas_reused,
        "scene_scale": cs.scale,
        "device_bytes": cs.device_bytes(), "features": cs.features, "specialized": bool(specialize),
        "pipeline": pipeline, "adaptive": adaptive, **cache_stats,
    }


def _check_rows(rows, height, adaptive):
    """``rows`` as a (y0, y1) tuple of ints, or None for the whole image."""
    if rows is None:
        return None
    if (not isinstance(rows, (tuple, list)) or len(rows) != 2
            or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in rows)):
        raise SceneError(f"render: rows: expected (y0, y1), two integers, got {V.show(rows)}")
    y0, y1 = int(rows[0]), int(rows[1])
    if not 0 <= y0 < y1 <= height:
        raise SceneError(f"render: rows: expected 0 <= y0 < y1 <= height = {height}, got ({y0}, {y1})")
    if adaptive is not None and (y0 % BLOCK_ROWS or (y1 % BLOCK_ROWS and y1 != height)):
        raise SceneError(f"render: rows: adaptive sampling decides per block of {BLOCK_ROWS} rows; y0 and y1 "
                         f"must be multiples of {BLOCK_ROWS} (or y1 = height), got ({y0}, {y1})")
    return y0, y1


def _check_options(aovs, pipeline, progress, sink, **flags):
    """The AOV names as a tuple, after checking every render option that is not a size."""
    if isinstance(aovs, str):
        aovs = (aovs,)
    if not isinstance(aovs, (list, tuple)):
        raise SceneError(f"render: aovs: expected a list of AOV names, got {V.show(aovs)}")
    aovs = tuple(aovs)
    for a in aovs:
        if not isinstance(a, str) or a not in layout.AOVS:
            raise SceneError(f"render: aovs: unknown AOV {V.show(a)} (known: {', '.join(layout.AOVS)})")
    V.one_of(pipeline, PIPELINES, "pipeline", "render: ")
    V.callable_or_none(progress, "progress", "render: ")
    V.callable_or_none(sink, "sink", "render: ")
    for name, value in flags.items():
        if not isinstance(value, (bool, np.bool_)):
            raise SceneError(f"render: {name}: expected True or False, got {V.show(value)}")
    return aovs


def prepare(scene, compiled, shadows, texture_filter, aovs, specialize, cache, adaptive=None, light_sampling="all"):
    """(the CompiledScene to render with the features these settings need, the camera,
    the scene cache's stats). One light per sample is compiled in only where there are two
    lights or more (with one it is the same estimator, so the same program and image)."""
    if isinstance(scene, CompiledScene) and compiled is None:
        compiled, scene = scene, None
    cache_stats = scene_cache.off_stats()
    if compiled is None:
        cs, cache_stats = scene_cache.compiled(scene, shadows=shadows, texture_filter=texture_filter, enabled=cache)
    elif texture_filter is not None:
        raise SceneError(f"render: texture_filter={texture_filter!r} with a precompiled scene: pass it to "
                         "compile_scene(scene, texture_filter=...) instead")
    elif isinstance(compiled, CompiledScene):
        if scene is not None and not isinstance(scene, Scene):
            raise SceneError(f"render: expected a texray.Scene, got {type(scene).__name__}")
        cs = dataclasses.replace(compiled)
        cs.features = dataclasses.replace(cs.features, shadows=bool(shadows) and len(cs.lights) > 0)
    else:
        raise SceneError(f"render: compiled: expected a CompiledScene, got {type(compiled).__name__}")
    if aovs:
        cs.features = dataclasses.replace(cs.features, aovs=True)
    if not specialize:
        cs.features = generic_features(cs.features)
        if cs.objects is None:                     # the generic program reads every object's mapping
            cs.objects = cs.objects_generic
    if adaptive is not None:
        cs.features = dataclasses.replace(cs.features, adaptive=True)
    if light_sampling == "one" and len(cs.lights) >= 2:
        cs.features = dataclasses.replace(cs.features, one_light=True)
    return cs, (scene.camera if scene is not None else cs.camera), cache_stats


def render_to_file(scene, path, width, height, spp=1, **kwargs) -> dict:
    """Render straight into an image file, band by band: neither the device nor
    the host holds the whole image, so a 16k x 16k render needs only the scene
    and one band of rows in memory (see ``memory_limit`` of :func:`render`).
    Returns the render's stats. PNG/JPEG/TIFF are written as 8-bit sRGB, EXR as
    half and HDR as float linear RGB."""
    if "aovs" in kwargs and kwargs["aovs"]:
        raise SceneError("render_to_file: AOVs are not streamed; use render() and Image.save")
    width, height, spp, _ = V.render_settings(width, height, spp, kwargs.get("seed", 0))
    writer = ScanlineWriter(path, width, height)
    try:
        image = render(scene, width, height, spp, sink=lambda y0, rgb, _aov: writer.write(y0, rgb), **kwargs)
    finally:
        writer.close()
    return image.stats
