"""Rendering: upload a compiled scene once, then run the kernels per tile and sample.

The fused pipeline (the default) runs raygen -> intersect -> surface -> shadow ->
shade in one kernel per pixel and sample (kernels/stages/fused.cl); the staged one
runs the five stage kernels in turn with per-ray records in device memory between
them, so that each stage is timed on its own; both give the same image. Tiles are
bands of whole rows (:mod:`.tiling`), small enough that a launch never runs long
enough to trip a GPU display watchdog and that the per-ray buffers fit the device;
the image is read back tile by tile, so device memory does not grow with the image
size.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np
import pyopencl as cl

from ..compile import CompiledScene, cache as scene_cache
from ..compile.textures import check_device_limits
from ..device import layout, runtime
from ..device.buffers import Uploaded
from ..device.features import compile_options, generic_features
from ..errors import DeviceError, SceneError
from ..io.images import ScanlineWriter
from ..scene import Scene
from .. import validate as V
from .adaptive import round_size, standard_error, still_active
from .image import Image, check_host_memory, host_image_bytes
from .tiling import MAX_FUSED_SAMPLES, plan_rows

STAGES = ("raygen", "intersect", "surface", "shadow", "shade")
PIPELINES = ("fused", "stages")
# Bytes per in-flight ray besides the shadow bytes: Ray + Hit + Surface + accumulator.
RAY_BYTES = layout.RAY.itemsize + layout.HIT.itemsize + layout.SURFACE.itemsize + 16


def render(scene, width=640, height=480, spp=1, *, device=None, seed=0, jitter=True, shadows=True,
           aovs=(), specialize=True, local_size=None, memory_limit=None, tile_pixels=None, progress=None,
           sink=None, compiled=None, texture_filter=None, pipeline="fused", adaptive=None, cache=True) -> Image:
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
    runs long enough to trip a GPU display watchdog).
    progress: optional callable(fraction_done) called after each pass.
    sink: optional callable(y0, rgb_rows, aov_rows) given each finished band
    of rows (float32 (rows, W, 3) and a dict like ``Image.aov``); the image is
    then not kept in host memory (``Image.rgb`` is None): see
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
    still samples (:mod:`texray.renderer.adaptive`); spp is then the most a
    pixel takes. ``stats["samples"]`` counts the samples taken. Fused pipeline
    only.
    cache: True (default) reads the compiled scene from the scene cache when this
    scene (not counting the camera) was compiled before, in any process, and stores
    it when its compile took long enough (:mod:`texray.compile.cache`; the README's
    "Scene cache"); False compiles it here and leaves the cache alone, as does
    ``TEXRAY_NO_CACHE=1``. ``stats["scene_cache"]``: "hit", "stored", "miss" or
    "off"; the same image either way.
    """
    width, height, spp, seed = V.render_settings(width, height, spp, seed)
    aovs = _check_options(aovs, pipeline, progress, sink, jitter=jitter, shadows=shadows, specialize=specialize,
                          cache=cache)
    if adaptive is not None:
        adaptive = V.number(adaptive, "adaptive", "render: ", 0.0, lo_open=True)
        if pipeline != "fused":
            raise SceneError("render: adaptive: adaptive sampling runs in the fused pipeline; pass pipeline='fused'")
    if sink is None:
        check_host_memory(host_image_bytes(width, height, aovs), width, height)
    t_start = time.perf_counter()
    cs, camera, cache_stats = _compiled(scene, compiled, shadows, texture_filter, aovs, specialize, cache)
    if adaptive is not None:
        cs.features = dataclasses.replace(cs.features, adaptive=True)
    t_compiled = time.perf_counter()
    rt = runtime(device)
    if cs.texels is not None:
        check_device_limits(cs.texels.nbytes, list(cs.texture_names), rt.device.max_mem_alloc_size)
    prg = rt.program(compile_options(cs.features))
    local = rt.local_size(local_size)
    t_built = time.perf_counter()

    fused = pipeline == "fused"
    nl = max(len(cs.lights), 1)
    # per pixel of a tile: the accumulator; the staged pipeline (and the AOV pass) add the records
    per_ray = (16 + (0 if fused and not aovs else RAY_BYTES - 16 + nl) + (4 * layout.AOV_FLOATS if aovs else 0)
               + (8 if adaptive is not None else 0))
    rows = plan_rows(width, height, per_ray, sum(cs.device_bytes().values()), rt.device,
                     memory_limit=memory_limit, tile_pixels=tile_pixels)
    run = _Run(rt, prg, cs, camera, width, height, spp, seed, jitter, local, rows, fused, aovs, adaptive)
    t_uploaded = time.perf_counter()
    img_rows = rows if sink is not None else height      # with a sink, only one band is kept
    out = np.empty((img_rows, width, 4), np.float32)
    aov_out = np.empty((img_rows, width, layout.AOV_FLOATS), np.float32) if aovs else None
    per_launch = max(1, min(spp, MAX_FUSED_SAMPLES // run.n_max)) if fused else 1
    launches = (spp + per_launch - 1) // per_launch
    if adaptive is not None:            # the most launches the rounds can take
        size = round_size(spp)
        launches = (spp + size - 1) // size * ((size + per_launch - 1) // per_launch)
    total_passes = ((height + rows - 1) // rows) * (launches + bool(aovs))

    def report(last):
        run.passes += 1
        if progress is not None:
            last.wait()
            progress(min(1.0, run.passes / total_passes))

    for y0 in range(0, height, rows):
        tile_rows = min(rows, height - y0)
        n = tile_rows * width
        gsize, lsize = rt.launch_size(n, local)
        oy = 0 if sink is not None else y0
        cl.enqueue_fill_buffer(rt.queue, run.accum, np.float32(0), 0, n * 16)
        if adaptive is not None:
            run.adaptive_tile(n, y0, tile_rows, per_launch, report)
        elif fused:
            for first in range(0, spp, per_launch):
                report(run.fused(gsize, lsize, n, y0, first, min(per_launch, spp - first)))
        else:
            for sample in range(spp):
                report(run.staged_sample(gsize, lsize, n, y0, sample))
        cl.enqueue_copy(rt.queue, out[oy:oy + tile_rows].reshape(-1, 4), run.accum, is_blocking=False)
        if aovs:
            run.trace(gsize, lsize, n, y0, 0, False, run.aov_buf)
            cl.enqueue_copy(rt.queue, aov_out[oy:oy + tile_rows].reshape(-1, layout.AOV_FLOATS), run.aov_buf,
                            is_blocking=False)
            report(_Finish(rt.queue))
        if sink is not None:
            rt.queue.finish()
            sink(y0, _mean(out[:tile_rows], spp, adaptive), _split_aovs(aov_out, aovs, tile_rows))
    rt.queue.finish()
    if progress is not None and run.passes < total_passes:
        progress(1.0)                   # adaptive sampling ended early
    t_end = time.perf_counter()
    rgb = None if sink is not None else np.ascontiguousarray(_mean(out, spp, adaptive))
    aov = {} if sink is not None else _split_aovs(aov_out, aovs, height)
    stage_s = {name: sum((e.profile.end - e.profile.start) for e in evs) * 1e-9 for name, evs in run.events.items()}
    stats = {
        "width": width, "height": height, "spp": spp, "device": rt.device.name.strip(),
        "triangles": int(len(cs.tri_verts)), "spheres": int(len(cs.spheres)), "cylinders": int(len(cs.cylinders)),
        "quads": int(len(cs.quad_verts)), "bvh_nodes": int(len(cs.nodes)), "bvh_depth": cs.wide_depth,
        "bvh_binary_nodes": int(len(cs.bvh.nodes)), "bvh_binary_depth": cs.bvh.depth,
        "bvh_build_s": cs.bvh.build_seconds, "sah_cost": cs.bvh.sah_cost,
        "scene_compile_s": t_compiled - t_start, "compile_steps_s": dict(cs.steps_s or {}),
        "blas_reused": cs.blas_reused,
        "program_build_s": t_built - t_compiled,
        "render_s": t_end - t_built, "upload_s": t_uploaded - t_built, "total_s": t_end - t_start,
        "stage_s": stage_s,
        "tile_rows": rows, "tiles": (height + rows - 1) // rows, "local_size": local,
        "device_bytes": cs.device_bytes(), "ray_buffer_bytes": run.n_max * per_ray,
        "features": cs.features, "specialized": bool(specialize), "pipeline": pipeline,
        "adaptive": adaptive, "samples": run.samples if adaptive is not None else width * height * spp,
        **cache_stats,
    }
    return Image(rgb=rgb, aov=aov, stats=stats)


def _mean(out, spp, adaptive):
    """The pixels' means from the accumulators (sum RGB, samples): each pixel's own count
    with adaptive sampling, else spp for all (the same value, divided the same way)."""
    if adaptive is None:
        return out[:, :, :3] / np.float32(spp)
    return out[:, :, :3] / out[:, :, 3:4]


class _Finish:
    """What a pass of several launches waits on: the whole queue."""

    def __init__(self, queue):
        self.queue = queue

    def wait(self):
        self.queue.finish()


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


def _compiled(scene, compiled, shadows, texture_filter, aovs, specialize, cache):
    """(the CompiledScene to render with the features these settings need, the camera,
    the scene cache's stats)."""
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
    return cs, (scene.camera if scene is not None else cs.camera), cache_stats


class _Run:
    """One render's device state: the uploaded scene, the per-tile buffers, the kernels and
    their profiling events; launches the fused kernel or one sample of the stages."""

    def __init__(self, rt, prg, cs, camera, width, height, spp, seed, jitter, local, rows, fused, aovs, adaptive):
        self.rt, self.cs, self.local, self.adaptive = rt, cs, local, adaptive
        self.samples = 0
        self.width, self.height, self.spp, self.seed, self.jitter = width, height, spp, seed, jitter
        self.n_max = rows * width
        self.passes = 0
        nl = max(len(cs.lights), 1)
        self.up = Uploaded(rt.context, cs)
        mf, ctx, n_max = cl.mem_flags, rt.context, self.n_max
        try:
            staged = not fused or aovs
            self.rays = cl.Buffer(ctx, mf.READ_WRITE, n_max * layout.RAY.itemsize) if staged else None
            hit_records = 2 if cs.features.instances else 1      # stages/intersect.cl: + the instances
            self.hits = cl.Buffer(ctx, mf.READ_WRITE, hit_records * n_max * layout.HIT.itemsize) if staged else None
            self.surf = cl.Buffer(ctx, mf.READ_WRITE, n_max * layout.SURFACE.itemsize) if staged else None
            self.vis = cl.Buffer(ctx, mf.READ_WRITE, n_max * nl) if not fused else None
            self.accum = cl.Buffer(ctx, mf.READ_WRITE, n_max * 16)
            self.aov_buf = cl.Buffer(ctx, mf.WRITE_ONLY, n_max * 4 * layout.AOV_FLOATS) if aovs else None
            self.active = cl.Buffer(ctx, mf.READ_ONLY, n_max * 4) if adaptive is not None else None
            self.sum_y2 = cl.Buffer(ctx, mf.READ_WRITE, n_max * 4) if adaptive is not None else None
            cam = np.zeros(1, layout.CAMERA)
            eye, fwd, right, upv = camera.basis(width / height)
            cam["eye"], cam["forward"], cam["right"], cam["up"] = eye, fwd, right, upv
            self.cam = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=cam)
        except cl.MemoryError as e:
            raise DeviceError(f"render: out of device memory for {n_max} rays per tile; pass a smaller "
                              f"tile_pixels ({e})") from None
        self.k = {name: cl.Kernel(prg, name) for name in STAGES + ("render_fused",)}
        self.events = {name: [] for name in (("render_fused",) if fused else STAGES)}
        if fused and aovs:
            self.events.update({name: [] for name in ("raygen", "intersect", "surface")})
        u32 = np.uint32
        self.geom, self.light = self.up.geom, self.up.light
        self.surface_args = self.up.args("SURFACE", cam=self.cam, image_w=u32(width), image_h=u32(height),
                                         spp=u32(spp))

    def _launch(self, name, gsize, lsize, *args):
        ev = self.k[name](self.rt.queue, gsize, lsize, *args)
        self.events[name].append(ev)
        return ev

    def fused(self, gsize, lsize, n, y0, first, count):
        """``count`` samples from ``first`` of every pixel of the tile at row y0."""
        u32, cs = np.uint32, self.cs
        return self._launch("render_fused", gsize, lsize, self.accum, self.active, self.sum_y2, u32(n), u32(y0),
                            u32(first), u32(count),
                            u32(self.seed), u32(self.jitter), *self.geom, *self.surface_args, *self.light,
                            cs.ambient, cs.background)

    def adaptive_tile(self, n, y0, rows, per_launch, report):
        """Sample the tile's n pixels in rounds, each round only those still active
        (texray.renderer.adaptive), up to spp samples."""
        q, spp, width = self.rt.queue, self.spp, self.width
        cl.enqueue_fill_buffer(q, self.sum_y2, np.float32(0), 0, n * 4)
        active = np.arange(n, dtype=np.uint32)
        acc, y2 = np.empty((n, 4), np.float32), np.empty(n, np.float32)
        done, size = 0, round_size(spp)
        while done < spp and len(active):
            cl.enqueue_copy(q, self.active, active)
            gsize, lsize = self.rt.launch_size(len(active), self.local)
            count = min(size, spp - done)
            for first in range(done, done + count, per_launch):
                report(self.fused(gsize, lsize, len(active), y0, first, min(per_launch, done + count - first)))
            self.samples += len(active) * count
            done += count
            if done < spp:
                cl.enqueue_copy(q, acc, self.accum)
                cl.enqueue_copy(q, y2, self.sum_y2)
                mean, se = standard_error(acc[:, :3], y2, acc[:, 3])
                active = np.flatnonzero(still_active(mean, se, self.adaptive, rows, width)).astype(np.uint32)

    def trace(self, gsize, lsize, n, y0, sample, jit, aov):
        """raygen -> intersect -> surface of one sample of the tile (``aov``: the AOV buffer or None)."""
        u32, w = np.uint32, self.width
        self._launch("raygen", gsize, lsize, self.rays, self.cam, u32(w), u32(self.height), u32(0), u32(y0), u32(w),
                     u32(n), u32(sample), u32(self.spp), u32(self.seed), u32(jit))
        self._launch("intersect", gsize, lsize, self.rays, self.hits, u32(n), *self.geom)
        self._launch("surface", gsize, lsize, self.rays, self.hits, self.surf, u32(n), *self.geom,
                     *self.surface_args, aov)

    def staged_sample(self, gsize, lsize, n, y0, sample):
        """One sample of the tile through the five stage kernels; the shade stage's event."""
        u32, cs = np.uint32, self.cs
        self.trace(gsize, lsize, n, y0, sample, self.jitter, None)
        if len(cs.lights):
            self._launch("shadow", gsize, lsize, self.surf, self.vis, u32(n), *self.geom, *self.light)
        return self._launch("shade", gsize, lsize, self.rays, self.surf, self.vis, u32(n), self.accum, *self.light,
                            cs.ambient, cs.background)


def _split_aovs(aov_out, names, rows):
    aov = {}
    for a in names:
        first, count = layout.AOVS[a]
        aov[a] = np.ascontiguousarray(aov_out[:rows, :, first:first + count])
    return aov


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
