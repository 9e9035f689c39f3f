"""Rendering: upload a compiled scene once, then run the kernel stages per tile and sample.

Per sample pass over a tile of pixels: raygen -> intersect -> surface ->
shadow -> shade (accumulates into the tile's buffer). Tiles are bands of whole
rows, small enough that a launch never runs long enough to trip a GPU display
watchdog and that the per-ray buffers fit the device; the image is read back
tile by tile, so device memory does not grow with the image size.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from . import layout
from .compile import CompiledScene, compile_scene
from .device import runtime
from .errors import DeviceError, SceneError
from .features import compile_options

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


def _positive_int(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
        raise SceneError(f"render: {name} must be a positive integer, got {value!r}")
    return int(value)


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
        self.normals, self.uvs = buf(cs.normals), buf(cs.uvs)
        self.materials, self.textures, self.texels = buf(cs.materials), buf(cs.textures), buf(cs.texels)
        self.lights, self.objects = buf(cs.lights), buf(cs.objects)
        self.nnodes = np.uint32(len(cs.nodes))
        self.nlights = np.uint32(len(cs.lights))

    @property
    def geom(self):
        """The kernels' TX_GEOM_PARAMS arguments."""
        return (self.nodes, self.nnodes, self.tris, self.spheres, self.cylinders, self.quads)


def render(scene, width=640, height=480, spp=1, *, device=None, seed=0, jitter=True, shadows=True,
           aovs=(), tile_pixels=None, progress=None) -> Image:
    """Render ``scene`` to a linear RGB image.

    spp: samples per pixel (correlated multi-jittered within the pixel, box
    filtered); jitter=False puts every sample at the pixel centre. seed
    changes the sample pattern; the same seed gives the same image.
    aovs: names from :data:`texray.layout.AOVS`, evaluated by one extra pass of
    pixel-centre rays and returned in ``image.aov[name]`` as float32 (H, W, C)
    arrays (NaN, or -1 for the ids, where the ray hits nothing).
    device: see :func:`texray.device.select_device`. tile_pixels bounds the
    rays in flight per launch (default: chosen from the device's memory).
    progress: optional callable(fraction_done) called after each pass.
    """
    width, height, spp = _positive_int(width, "width"), _positive_int(height, "height"), _positive_int(spp, "spp")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise SceneError(f"render: seed must be an integer, got {seed!r}")
    aovs = (aovs,) if isinstance(aovs, str) else tuple(aovs)
    for a in aovs:
        if a not in layout.AOVS:
            raise SceneError(f"render: aovs: unknown AOV {a!r} (known: {', '.join(layout.AOVS)})")
    t_start = time.perf_counter()
    cs = compile_scene(scene, shadows=shadows)
    if aovs:
        cs.features = dataclasses.replace(cs.features, aovs=True)
    t_compiled = time.perf_counter()
    rt = runtime(device)
    prg = rt.program(compile_options(cs.features))
    t_built = time.perf_counter()
    up = _Uploaded(rt.context, cs)

    nl = max(int(up.nlights), 1)
    per_ray = _RAY_BYTES + nl + (4 * layout.AOV_FLOATS if aovs else 0)
    if tile_pixels is None:
        budget = min(rt.device.max_mem_alloc_size, rt.device.global_mem_size // 4)
        tile_pixels = int(min(1 << 20, max(budget // per_ray, 1)))
    rows = max(1, min(height, _positive_int(tile_pixels, "tile_pixels") // width))
    n_max = rows * width
    mf = cl.mem_flags
    try:
        rays = cl.Buffer(rt.context, mf.READ_WRITE, n_max * layout.RAY.itemsize)
        hits = cl.Buffer(rt.context, mf.READ_WRITE, n_max * layout.HIT.itemsize)
        surf = cl.Buffer(rt.context, mf.READ_WRITE, n_max * layout.SURFACE.itemsize)
        vis = cl.Buffer(rt.context, mf.READ_WRITE, n_max * nl)
        accum = cl.Buffer(rt.context, mf.READ_WRITE, n_max * 16)
        aov_buf = cl.Buffer(rt.context, mf.WRITE_ONLY, n_max * 4 * layout.AOV_FLOATS) if aovs else None
        cam = np.zeros(1, layout.CAMERA)
        eye, fwd, right, upv = scene.camera.basis(width / height)
        cam["eye"], cam["forward"], cam["right"], cam["up"] = eye, fwd, right, upv
        cam_buf = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=cam)
    except cl.MemoryError as e:
        raise DeviceError(f"render: out of device memory for {n_max} rays per tile; pass a smaller "
                          f"tile_pixels ({e})") from None

    k = {name: cl.Kernel(prg, name) for name in STAGES}
    q = rt.queue
    out = np.empty((height, width, 4), np.float32)
    aov_out = np.empty((height, width, layout.AOV_FLOATS), np.float32) if aovs else None
    events = {name: [] for name in STAGES}
    u32 = np.uint32
    passes, total_passes = 0, ((height + rows - 1) // rows) * (spp + bool(aovs))

    def trace(gsize, n, y0, sample, jit, aov):
        events["raygen"].append(k["raygen"](q, gsize, None, rays, cam_buf, u32(width), u32(height), u32(0),
                                            u32(y0), u32(width), u32(n), u32(sample), u32(spp),
                                            u32(seed & 0xFFFFFFFF), u32(jit)))
        events["intersect"].append(k["intersect"](q, gsize, None, rays, hits, u32(n), *up.geom))
        events["surface"].append(k["surface"](q, gsize, None, rays, hits, surf, u32(n), *up.geom, up.shade,
                                              up.quad_shade, up.normals, up.uvs, up.materials, up.textures,
                                              up.texels, up.objects, aov))

    for y0 in range(0, height, rows):
        tile_rows = min(rows, height - y0)
        n = tile_rows * width
        gsize = (n,)
        cl.enqueue_fill_buffer(q, accum, np.float32(0), 0, n * 16)
        for sample in range(spp):
            trace(gsize, n, y0, sample, jitter, None)
            if up.nlights:
                events["shadow"].append(k["shadow"](q, gsize, None, surf, vis, u32(n), *up.geom,
                                                    up.lights, up.nlights))
            events["shade"].append(k["shade"](q, gsize, None, rays, surf, vis, u32(n), accum, up.lights, up.nlights,
                                              cs.ambient, cs.background))
            passes += 1
            if progress is not None:
                events["shade"][-1].wait()
                progress(passes / total_passes)
        cl.enqueue_copy(q, out[y0:y0 + tile_rows].reshape(-1, 4), accum, is_blocking=False)
        if aovs:
            trace(gsize, n, y0, 0, False, aov_buf)
            cl.enqueue_copy(q, aov_out[y0:y0 + tile_rows].reshape(-1, layout.AOV_FLOATS), aov_buf, is_blocking=False)
            passes += 1
            if progress is not None:
                q.finish()
                progress(passes / total_passes)
    q.finish()
    t_end = time.perf_counter()
    rgb = out[:, :, :3] / np.float32(spp)
    aov = {}
    for a in aovs:
        first, count = layout.AOVS[a]
        aov[a] = np.ascontiguousarray(aov_out[:, :, first:first + count])
    stage_s = {name: sum((e.profile.end - e.profile.start) for e in evs) * 1e-9 for name, evs in events.items()}
    stats = {
        "width": width, "height": height, "spp": spp, "device": rt.device.name.strip(),
        "triangles": int(len(cs.tri_verts)), "spheres": int(len(cs.spheres)), "cylinders": int(len(cs.cylinders)),
        "quads": int(len(cs.quad_verts)), "bvh_nodes": int(len(cs.nodes)), "bvh_depth": cs.bvh.depth,
        "bvh_build_s": cs.bvh.build_seconds, "sah_cost": cs.bvh.sah_cost,
        "scene_compile_s": t_compiled - t_start, "program_build_s": t_built - t_compiled,
        "render_s": t_end - t_built, "total_s": t_end - t_start, "stage_s": stage_s,
        "tile_rows": rows, "device_bytes": cs.device_bytes(), "features": cs.features,
    }
    return Image(rgb=np.ascontiguousarray(rgb), aov=aov, stats=stats)
