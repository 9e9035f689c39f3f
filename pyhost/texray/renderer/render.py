"""Rendering: upload a compiled scene once, then run the kernel stages per tile and sample.

Per sample pass over a tile of pixels: raygen -> intersect -> surface ->
shadow -> shade (accumulates into the tile's buffer). Tiles are bands of whole
rows, small enough that a launch never runs long enough to trip a GPU display
watchdog and that the per-ray buffers fit the device; the image is read back
tile by tile, so device memory does not grow with the image size.
"""
from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from . import layout
from .compile import CompiledScene, compile_scene, object_table
from .device import runtime
from .errors import DeviceError, SceneError
from .features import Features, compile_options
from .texture import check_device_limits
from . import validate as V

STAGES = ("raygen", "intersect", "surface", "shadow", "shade")
# Bytes per in-flight ray besides the shadow bytes: Ray + Hit + Surface + accumulator.
_RAY_BYTES = layout.RAY.itemsize + layout.HIT.itemsize + layout.SURFACE.itemsize + 16


@dataclass
class Image:
    """A render: ``rgb`` is linear float32 (H, W, 3); ``aov`` maps AOV names to float32
    (H, W, C) arrays; ``stats`` holds timings and sizes."""
    rgb: np.ndarray
    aov: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)

    def save(self, path):
        """PNG/JPEG/TIFF: sRGB-encoded 8-bit, clamped to [0, 1]; EXR: linear half RGB
        (float32 with the AOVs as further channels, ``uv.u``, ``position.x``...); HDR: linear float."""
        from .imageio import write_image, write_exr_layers
        if self.aov and str(path).lower().endswith(".exr"):
            write_exr_layers(path, self.rgb, self.aov)
        else:
            write_image(path, self.rgb)


def _host_image_bytes(width, height, aovs):
    return width * height * (16 + 4 * layout.AOV_FLOATS * bool(aovs))


def _check_host_memory(nbytes, width, height):
    """SceneError when the image kept in host memory cannot fit the memory available
    (MemAvailable, which counts reclaimable caches, plus free swap)."""
    avail = _host_memory_available()
    if avail is not None and nbytes > avail:
        raise SceneError(f"render: width, height: a {width} x {height} image needs {nbytes / 2**30:.1f} GiB of host "
                         f"memory and {avail / 2**30:.1f} GiB are available; render_to_file(...) or sink= "
                         "streams the image band by band")


def _host_memory_available():
    """Bytes of host memory a new allocation can get, or None where the system does not say
    (then numpy reports a failed allocation itself)."""
    fields = {}
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                key, _, rest = line.partition(":")
                fields[key] = int(rest.split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    if "MemAvailable" in fields:
        return fields["MemAvailable"] + fields.get("SwapFree", 0)
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


class _Uploaded:
    """Device buffers of one compiled scene (None for arrays the scene does not use)."""

    def __init__(self, ctx, cs: CompiledScene):
        mf = cl.mem_flags

        def buf(a):
            if a is None or a.nbytes == 0:
                return None
            return cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))
        self.nodes, self.tris, self.shade = buf(cs.nodes), buf(cs.tri_verts), buf(cs.tri_shade)
        self.spheres, self.cylinders = buf(cs.spheres), buf(cs.cylinders)
        self.quads, self.quad_shade = buf(cs.quad_verts), buf(cs.quad_shade)
        self.displaced, self.heights = buf(cs.displaced), buf(cs.heights)
        self.normals, self.uvs = buf(cs.normals), buf(cs.uvs)
        self.materials, self.textures, self.texels = buf(cs.materials), buf(cs.textures), buf(cs.texels)
        self.lights, self.objects = buf(cs.lights), buf(cs.objects)
        self.nnodes = np.uint32(len(cs.nodes))
        self.nlights = np.uint32(len(cs.lights))

    @property
    def geom(self):
        """The kernels' TX_GEOM_PARAMS arguments."""
        return (self.nodes, self.nnodes, self.tris, self.spheres, self.cylinders, self.quads, self.displaced,
                self.heights)


def render(scene, width=640, height=480, spp=1, *, device=None, seed=0, jitter=True, shadows=True,
           aovs=(), specialize=True, local_size=None, memory_limit=None, tile_pixels=None, progress=None,
           sink=None, compiled=None, texture_filter=None, pipeline="fused") -> Image:
    """Render ``scene`` to a linear RGB image.

    spp: samples per pixel (correlated multi-jittered within the pixel, box
    filtered); jitter=False puts every sample at the pixel centre. seed
    changes the sample pattern; the same seed gives the same image.
    aovs: names from :data:`texray.layout.AOVS`, evaluated by one extra pass of
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
    it is not modified.
    texture_filter: None (each texture's own filter) or "nearest", "bilinear",
    "trilinear" or "anisotropic" for every texture (texray.texture.FILTERS); for a precompiled
    scene pass it to compile_scene instead.
    """
    width, height, spp, seed = V.render_settings(width, height, spp, seed)
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
    for name, value in (("jitter", jitter), ("shadows", shadows), ("specialize", specialize)):
        if not isinstance(value, (bool, np.bool_)):
            raise SceneError(f"render: {name}: expected True or False, got {V.show(value)}")
    if sink is None:
        _check_host_memory(_host_image_bytes(width, height, aovs), width, height)
    t_start = time.perf_counter()
    if compiled is None:
        cs = compile_scene(scene, shadows=shadows, texture_filter=texture_filter)
    elif texture_filter is not None:
        raise SceneError(f"render: texture_filter={texture_filter!r} with a precompiled scene: pass it to "
                         "compile_scene(scene, texture_filter=...) instead")
    elif isinstance(compiled, CompiledScene):
        cs = dataclasses.replace(compiled)
        cs.features = dataclasses.replace(cs.features, shadows=bool(shadows) and len(cs.lights) > 0)
    else:
        raise SceneError(f"render: compiled: expected a CompiledScene, got {type(compiled).__name__}")
    if aovs:
        cs.features = dataclasses.replace(cs.features, aovs=True)
    if not specialize:
        cs.features = generic_features(cs.features)
        if cs.objects is None:                     # the generic program reads every object's mapping
            cs.objects = object_table(scene.objects, always=True)
    t_compiled = time.perf_counter()
    rt = runtime(device)
    if cs.texels is not None:
        check_device_limits(cs.texels.nbytes, sorted({t.name for o in scene.objects for t in o.material.textures}),
                            rt.device.max_mem_alloc_size)
    prg = rt.program(compile_options(cs.features))
    local = rt.local_size(local_size)
    t_built = time.perf_counter()

    fused = pipeline == "fused"
    nl = max(len(cs.lights), 1)
    # per pixel of a tile: the accumulator; the staged pipeline (and the AOV pass) add the records
    per_ray = 16 + (0 if fused and not aovs else _RAY_BYTES - 16 + nl) + (4 * layout.AOV_FLOATS if aovs else 0)
    rows = plan_rows(width, height, per_ray, sum(cs.device_bytes().values()), rt.device,
                     memory_limit=memory_limit, tile_pixels=tile_pixels)
    n_max = rows * width
    up = _Uploaded(rt.context, cs)
    mf = cl.mem_flags
    try:
        staged = not fused or aovs
        rays = cl.Buffer(rt.context, mf.READ_WRITE, n_max * layout.RAY.itemsize) if staged else None
        hits = cl.Buffer(rt.context, mf.READ_WRITE, n_max * layout.HIT.itemsize) if staged else None
        surf = cl.Buffer(rt.context, mf.READ_WRITE, n_max * layout.SURFACE.itemsize) if staged else None
        vis = cl.Buffer(rt.context, mf.READ_WRITE, n_max * nl) if not fused else None
        accum = cl.Buffer(rt.context, mf.READ_WRITE, n_max * 16)
        aov_buf = cl.Buffer(rt.context, mf.WRITE_ONLY, n_max * 4 * layout.AOV_FLOATS) if aovs else None
        cam = np.zeros(1, layout.CAMERA)
        eye, fwd, right, upv = scene.camera.basis(width / height)
        cam["eye"], cam["forward"], cam["right"], cam["up"] = eye, fwd, right, upv
        cam_buf = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=cam)
    except cl.MemoryError as e:
        raise DeviceError(f"render: out of device memory for {n_max} rays per tile; pass a smaller "
                          f"tile_pixels ({e})") from None

    k = {name: cl.Kernel(prg, name) for name in STAGES + ("render_fused",)}
    q = rt.queue
    img_rows = rows if sink is not None else height      # with a sink, only one band is kept
    out = np.empty((img_rows, width, 4), np.float32)
    aov_out = np.empty((img_rows, width, layout.AOV_FLOATS), np.float32) if aovs else None
    events = {name: [] for name in (("render_fused",) if fused else STAGES)}
    if fused and aovs:
        events.update({name: [] for name in ("raygen", "intersect", "surface")})
    u32 = np.uint32
    per_launch = max(1, min(spp, MAX_FUSED_SAMPLES // n_max)) if fused else 1
    launches = (spp + per_launch - 1) // per_launch
    passes, total_passes = 0, ((height + rows - 1) // rows) * (launches + bool(aovs))
    surface_args = (up.shade, up.quad_shade, up.normals, up.uvs, up.materials, up.textures, up.texels, up.objects,
                    cam_buf, u32(width), u32(height), u32(spp))

    def trace(gsize, n, y0, sample, jit, aov):
        events["raygen"].append(k["raygen"](q, gsize, lsize, rays, cam_buf, u32(width), u32(height), u32(0),
                                            u32(y0), u32(width), u32(n), u32(sample), u32(spp),
                                            u32(seed), u32(jit)))
        events["intersect"].append(k["intersect"](q, gsize, lsize, rays, hits, u32(n), *up.geom))
        events["surface"].append(k["surface"](q, gsize, lsize, rays, hits, surf, u32(n), *up.geom,
                                              *surface_args, aov))

    for y0 in range(0, height, rows):
        tile_rows = min(rows, height - y0)
        n = tile_rows * width
        gsize, lsize = rt.launch_size(n, local)
        oy = 0 if sink is not None else y0
        cl.enqueue_fill_buffer(q, accum, np.float32(0), 0, n * 16)
        for first in range(0, spp, per_launch) if fused else ():
            count = min(per_launch, spp - first)
            events["render_fused"].append(k["render_fused"](
                q, gsize, lsize, accum, u32(n), u32(y0), u32(first), u32(count), u32(seed),
                u32(jitter), *up.geom, *surface_args, up.lights, up.nlights, cs.ambient, cs.background))
            passes += 1
            if progress is not None:
                events["render_fused"][-1].wait()
                progress(passes / total_passes)
        for sample in range(spp) if not fused else ():
            trace(gsize, n, y0, sample, jitter, None)
            if up.nlights:
                events["shadow"].append(k["shadow"](q, gsize, lsize, surf, vis, u32(n), *up.geom,
                                                    up.lights, up.nlights))
            events["shade"].append(k["shade"](q, gsize, lsize, rays, surf, vis, u32(n), accum, up.lights, up.nlights,
                                              cs.ambient, cs.background))
            passes += 1
            if progress is not None:
                events["shade"][-1].wait()
                progress(passes / total_passes)
        cl.enqueue_copy(q, out[oy:oy + tile_rows].reshape(-1, 4), accum, is_blocking=False)
        if aovs:
            trace(gsize, n, y0, 0, False, aov_buf)
            cl.enqueue_copy(q, aov_out[oy:oy + tile_rows].reshape(-1, layout.AOV_FLOATS), aov_buf,
                            is_blocking=False)
            passes += 1
            if progress is not None:
                q.finish()
                progress(passes / total_passes)
        if sink is not None:
            q.finish()
            sink(y0, out[:tile_rows, :, :3] / np.float32(spp), _split_aovs(aov_out, aovs, tile_rows))
    q.finish()
    t_end = time.perf_counter()
    rgb = None if sink is not None else np.ascontiguousarray(out[:, :, :3] / np.float32(spp))
    aov = {} if sink is not None else _split_aovs(aov_out, aovs, height)
    stage_s = {name: sum((e.profile.end - e.profile.start) for e in evs) * 1e-9 for name, evs in events.items()}
    stats = {
        "width": width, "height": height, "spp": spp, "device": rt.device.name.strip(),
        "triangles": int(len(cs.tri_verts)), "spheres": int(len(cs.spheres)), "cylinders": int(len(cs.cylinders)),
        "quads": int(len(cs.quad_verts)), "bvh_nodes": int(len(cs.nodes)), "bvh_depth": cs.wide_depth,
        "bvh_binary_nodes": int(len(cs.bvh.nodes)), "bvh_binary_depth": cs.bvh.depth,
        "bvh_build_s": cs.bvh.build_seconds, "sah_cost": cs.bvh.sah_cost,
        "scene_compile_s": t_compiled - t_start, "program_build_s": t_built - t_compiled,
        "render_s": t_end - t_built, "total_s": t_end - t_start, "stage_s": stage_s,
        "tile_rows": rows, "tiles": (height + rows - 1) // rows, "local_size": local,
        "device_bytes": cs.device_bytes(), "ray_buffer_bytes": n_max * per_ray,
        "features": cs.features, "specialized": bool(specialize), "pipeline": pipeline,
    }
    return Image(rgb=rgb, aov=aov, stats=stats)


def _split_aovs(aov_out, names, rows):
    aov = {}
    for a in names:
        first, count = layout.AOVS[a]
        aov[a] = np.ascontiguousarray(aov_out[:rows, :, first:first + count])
    return aov


def generic_features(needed: Features) -> Features:
    """The generic program's features for a scene that needs ``needed``: every
    capability compiled in; the render settings (shadows, AOVs) kept."""
    g = Features.generic(stack_size=max(128, needed.stack_size))
    return dataclasses.replace(g, shadows=needed.shadows, aovs=needed.aovs)


PIPELINES = ("fused", "stages")
# Samples per launch of the fused kernel (pixels x samples): bounds a launch's run time
# like MAX_TILE_PIXELS does for the stage kernels.
MAX_FUSED_SAMPLES = 1 << 22

# The most rays in flight per launch: bounds a launch's run time (GPU display watchdogs
# kill kernels after ~2 s; 2^20 incoherent rays take a few ms on a GPU, ~0.5 s on PoCL).
MAX_TILE_PIXELS = 1 << 20


def plan_rows(width, height, per_ray_bytes, scene_bytes, dev, memory_limit=None, tile_pixels=None) -> int:
    """Rows per tile: whole rows, as many as fit both ``tile_pixels`` (default
    MAX_TILE_PIXELS) and the device memory left after the scene's arrays, within
    ``memory_limit`` (default a quarter of the device's memory) and the largest
    single allocation. Raises DeviceError when not even one row fits."""
    if memory_limit is None:
        memory_limit = dev.global_mem_size // 4
    memory_limit = V.integer(memory_limit, "memory_limit", "render: ", 1)
    free = memory_limit - scene_bytes
    if free < per_ray_bytes * width:
        raise DeviceError(f"render: the scene's arrays take {scene_bytes / 2**20:.1f} MiB and one row of "
                          f"{width} pixels {per_ray_bytes * width / 2**20:.2f} MiB, more than the memory "
                          f"limit {memory_limit / 2**20:.1f} MiB of {dev.name.strip()}")
    max_buffer = max(layout.SURFACE.itemsize, 4 * layout.AOV_FLOATS)    # the largest per-ray buffer
    by_memory = min(free // per_ray_bytes, dev.max_mem_alloc_size // max_buffer)
    limit = MAX_TILE_PIXELS if tile_pixels is None else V.integer(tile_pixels, "tile_pixels", "render: ", 1)
    pixels = min(by_memory, limit)
    return int(max(1, min(height, pixels // width)))


def render_to_file(scene, path, width, height, spp=1, **kwargs) -> dict:
    """Render straight into an image file, band by band: neither the device nor
    the host holds the whole image, so a 16k x 16k render needs only the scene
    and one band of rows in memory (see ``memory_limit`` of :func:`render`).
    Returns the render's stats. PNG/JPEG/TIFF are written as 8-bit sRGB, EXR as
    half and HDR as float linear RGB."""
    from .imageio import ScanlineWriter
    if "aovs" in kwargs and kwargs["aovs"]:
        raise SceneError("render_to_file: AOVs are not streamed; use render() and Image.save")
    width, height, spp, _ = V.render_settings(width, height, spp, kwargs.get("seed", 0))
    writer = ScanlineWriter(path, width, height)
    try:
        image = render(scene, width, height, spp, sink=lambda y0, rgb, _aov: writer.write(y0, rgb), **kwargs)
    finally:
        writer.close()
    return image.stats
