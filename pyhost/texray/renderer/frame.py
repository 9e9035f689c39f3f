"""The device side of a render: a compiled scene's rows (the whole image, or a band of it)
run tile by tile through the fused kernel or the five stage kernels.

What a pixel's value depends on is fixed by the image, never by how it is cut: the
samples a fused launch sums come from the image's size (:func:`texray.renderer.tiling.
fused_samples`), and adaptive sampling decides per block of ADAPTIVE_BLOCK_ROWS rows
(:mod:`.adaptive`). So the rows y0..y1 rendered alone (``rows=``, a Dask task of
:mod:`.distributed`) equal those rows of the whole image bit for bit, whatever the tiles,
the memory limit or the device's memory.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from ..compile.textures import check_device_limits
from ..device import layout, runtime
from ..device.features import compile_options, light_block, pixels_per_item
from ..errors import DeviceError
from .adaptive import BLOCK_ROWS, FLOOR, round_size, round_sizes
from .tiling import fused_rows, fused_samples, plan_rows

STAGES = ("raygen", "intersect", "surface", "shadow", "shade")
# render()'s settings that render_rows takes as they are (with the device and local size: a band's options)
ROW_OPTIONS = ("seed", "jitter", "aovs", "adaptive", "pipeline", "memory_limit", "tile_pixels")
PIPELINES = ("fused", "stages")
# Bytes per in-flight ray besides the shadow bytes: Ray + Hit + Surface + accumulator.
RAY_BYTES = layout.RAY.itemsize + layout.HIT.itemsize + layout.SURFACE.itemsize + 16


@dataclass
class Rows:
    """What :func:`render_rows` returns: the rows' linear RGB (None with a sink), their AOVs,
    and how they were run."""
    rgb: np.ndarray | None
    aov: dict
    tile_rows: int
    tiles: int
    samples: int
    per_ray: int
    ray_buffer_bytes: int
    upload_s: float
    stage_s: dict = field(default_factory=dict)


def launch_unit(adaptive) -> int:
    """The rows a fused launch takes at least: adaptive sampling's tiles are whole blocks."""
    return BLOCK_ROWS if adaptive is not None else 1


def launch_samples(width, height, spp, adaptive=None) -> int:
    """Samples per pixel that a fused launch sums (the packet rule's input,
    texray.device.features.packet_width): fused_samples, within a round of adaptive sampling."""
    n = fused_samples(width, height, spp, launch_unit(adaptive))
    return min(n, round_size(spp)) if adaptive is not None else n


def device_program(cs, device, local_size, samples=0, stages=True):
    """(runtime, program, work-group size, packet width) to render ``cs`` on ``device`` with
    fused launches of ``samples`` samples per pixel (:func:`launch_samples`): the device's
    limits checked against the scene's textures, the scene's program built (or cached).
    ``stages``: the program holds the stage kernels (the staged pipeline; AOVs always do)."""
    rt = runtime(device)
    if cs.texels is not None:
        check_device_limits(cs.texels.nbytes, list(cs.texture_names), rt.device.max_mem_alloc_size)
    options = compile_options(cs.features, rt.kind, samples, stages=stages)
    packet = options["TX_PACKET"]
    return rt, rt.program(options), rt.local_size(local_size, packet), packet


def per_ray_bytes(cs, fused, aovs, adaptive):
    """Device bytes per pixel of a tile: the accumulator and the image's mean; the staged
    pipeline (and the AOV pass) add the per-ray records; adaptive sampling its luminance
    squares, its list of active pixels and the decisions' stamps (_Run.adaptive_tile)."""
    nl = max(len(cs.lights), 1)
    return (16 + 12 + (0 if fused and not aovs else RAY_BYTES - 16 + nl) + (4 * layout.AOV_FLOATS if aovs else 0)
            + (9 if adaptive is not None else 0))


def render_rows(rt, prg, cs, camera, width, height, spp, rows=None, *, seed=0, jitter=True, local=0, aovs=(),
                adaptive=None, pipeline="fused", memory_limit=None, tile_pixels=None, progress=None, sink=None,
                uploaded) -> Rows:
    """Rows ``rows = (y0, y1)`` (default: all) of the ``width`` x ``height`` image of ``cs``
    seen by ``camera``, with the program ``prg`` of runtime ``rt``; the arguments are
    texray.render's, checked. ``uploaded``: the scene's device buffers
    (:func:`texray.renderer.uploads.uploaded`, which keeps them across renders)."""
    y_start, y_end = (0, height) if rows is None else rows
    band = y_end - y_start
    fused = pipeline == "fused"
    per_ray = per_ray_bytes(cs, fused, aovs, adaptive)
    tile = plan_rows(width, band, per_ray, sum(cs.device_bytes().values()), rt.device,
                     memory_limit=memory_limit, tile_pixels=tile_pixels)
    per_launch = fused_samples(width, height, spp, launch_unit(adaptive)) if fused else 1
    if fused:                                # a launch's pixel samples: MAX_FUSED_SAMPLES at most
        tile = min(tile, fused_rows(width, per_launch, launch_unit(adaptive)))
    if adaptive is not None and tile >= BLOCK_ROWS:
        tile -= tile % BLOCK_ROWS            # whole blocks per tile: the stopping rule's unit
    t0 = time.perf_counter()
    run = _Run(rt, prg, cs, camera, width, height, spp, seed, jitter, local, tile, fused, aovs, adaptive, uploaded)
    upload_s = time.perf_counter() - t0
    img_rows = tile if sink is not None else band      # with a sink, only one band is kept
    out = np.empty((img_rows, width, 3), np.float32)
    aov_out = np.empty((img_rows, width, layout.AOV_FLOATS), np.float32) if aovs else None
    launches = (spp + per_launch - 1) // per_launch
    if adaptive is not None:            # the most launches the rounds can take
        launches = sum((c + per_launch - 1) // per_launch for c in round_sizes(spp))
    tiles = (band + tile - 1) // tile
    total_passes = tiles * (launches + bool(aovs))

    def report(last, share=1.0):
        run.passes += share             # share: the part of the tile the pass covered (adaptive_tile's halves)
        if progress is not None:
            last.wait()
            progress(min(1.0, run.passes / total_passes))

    # the fused kernel's pixels per work-item, for the program device_program built
    pixels = pixels_per_item(cs.features, rt.kind, launch_samples(width, height, spp, adaptive),
                             block=light_block(spp, len(cs.lights)))
    run.pixels = pixels
    for y0 in range(y_start, y_end, tile):
        tile_rows = min(tile, y_end - y0)
        n = tile_rows * width
        gsize, lsize = rt.launch_size(n, local)
        fsize, flsize = rt.launch_size((n + pixels - 1) // pixels, local)
        oy = 0 if sink is not None else y0 - y_start
        if not fused:                   # the shade stage adds to the sums; the fused kernel starts them
            cl.enqueue_fill_buffer(rt.queue, run.accum, np.float32(0), 0, n * 16)
        if adaptive is not None:
            run.adaptive_tile(n, y0, tile_rows, per_launch, (fsize, flsize), report)
        elif fused:
            for first in range(0, spp, per_launch):
                report(run.fused(fsize, flsize, n, y0, first, min(per_launch, spp - first)))
        else:
            for sample in range(spp):
                report(run.staged_sample(gsize, lsize, n, y0, sample))
        cl.enqueue_copy(rt.queue, out[oy:oy + tile_rows].reshape(-1), run.rgb, is_blocking=False)
        if aovs:
            run.trace(gsize, lsize, n, y0, 0, False, run.aov_buf)
            cl.enqueue_copy(rt.queue, aov_out[oy:oy + tile_rows].reshape(-1, layout.AOV_FLOATS), run.aov_buf,
                            is_blocking=False)
            report(_Finish(rt.queue))
        if sink is not None:
            rt.queue.finish()
            sink(y0, out[:tile_rows].copy(), split_aovs(aov_out, aovs, tile_rows, cs.scale))   # out: the next tile's
    rt.queue.finish()
    if progress is not None and run.passes < total_passes:
        progress(1.0)                   # adaptive sampling ended early
    rgb = None if sink is not None else out
    aov = {} if sink is not None else split_aovs(aov_out, aovs, band, cs.scale)
    stage_s = {name: sum((e.profile.end - e.profile.start) for e in evs) * 1e-9 for name, evs in run.events.items()}
    samples = run.adaptive_samples() if adaptive is not None else width * band * spp
    return Rows(rgb=rgb, aov=aov, tile_rows=tile, tiles=tiles, samples=samples, per_ray=per_ray,
                ray_buffer_bytes=run.n_max * per_ray, upload_s=upload_s, stage_s=stage_s)


def split_aovs(aov_out, names, rows, scale=1.0):
    """``Image.aov`` from the AOV pass's packed floats (texray.device.layout.AOVS), those in
    world units (layout.AOV_LENGTHS) back from the device's (``scale`` per world unit, a power
    of two: texray.compile.units)."""
    aov = {}
    for a in names:
        first, count = layout.AOVS[a]
        aov[a] = np.ascontiguousarray(aov_out[:rows, :, first:first + count])
        if scale != 1.0 and a in layout.AOV_LENGTHS:
            aov[a] *= np.float32(1.0 / scale)
    return aov


class _Finish:
    """What a pass of several launches waits on: the whole queue."""

    def __init__(self, queue):
        self.queue = queue

    def wait(self):
        self.queue.finish()


# Work-groups of adaptive sampling's later rounds, whose work-items loop over the list that the
# device wrote (stages/fused.cl render_fused, stages/adaptive.cl adaptive_mark: core/adaptive.h
# TX_FOR_LISTED): idle ones cost PoCL 0.45 us each, and 64 keep both threads busy on a list of
# any length (the image does not depend on it).
LATER_GROUPS = 64


class _Run:
    """One render's device state: the uploaded scene, the per-tile buffers, the kernels and
    their profiling events; launches the fused kernel or one sample of the stages."""

    def __init__(self, rt, prg, cs, camera, width, height, spp, seed, jitter, local, rows, fused, aovs, adaptive,
                 uploaded):
        self.rt, self.cs, self.local, self.adaptive = rt, cs, local, adaptive
        self.samples = 0
        self.pending = []       # adaptive_tile's lists' lengths (read back) and their rounds' samples
        self.pixels = 1         # the fused kernel's pixels per work-item (render_rows sets it)
        self.width, self.height, self.spp, self.seed, self.jitter = width, height, spp, seed, jitter
        self.n_max = rows * width
        self.passes = 0
        nl = max(len(cs.lights), 1)
        self.up = uploaded
        mf, ctx, n_max = cl.mem_flags, rt.context, self.n_max
        try:
            staged = not fused or aovs
            self.rays = cl.Buffer(ctx, mf.READ_WRITE, n_max * layout.RAY.itemsize) if staged else None
            hit_records = 2 if cs.features.instances else 1      # stages/intersect.cl: + the instances
            self.hits = cl.Buffer(ctx, mf.READ_WRITE, hit_records * n_max * layout.HIT.itemsize) if staged else None
            self.surf = cl.Buffer(ctx, mf.READ_WRITE, n_max * layout.SURFACE.itemsize) if staged else None
            self.vis = cl.Buffer(ctx, mf.READ_WRITE, n_max * nl) if not fused else None
            self.accum = cl.Buffer(ctx, mf.READ_WRITE, n_max * 16)
            self.rgb = cl.Buffer(ctx, mf.WRITE_ONLY, n_max * 12)
            self.aov_buf = cl.Buffer(ctx, mf.WRITE_ONLY, n_max * 4 * layout.AOV_FLOATS) if aovs else None
            self.active = cl.Buffer(ctx, mf.READ_WRITE, n_max * 4) if adaptive is not None else None
            self.sum_y2 = cl.Buffer(ctx, mf.READ_WRITE, n_max * 4) if adaptive is not None else None
            # adaptive sampling's decisions (stages/adaptive.cl): a stamp per pixel, the list's count
            self.stamp = cl.Buffer(ctx, mf.READ_WRITE, n_max) if adaptive is not None else None
            self.count = cl.Buffer(ctx, mf.READ_WRITE, 4) if adaptive is not None else None
            self.row_count = cl.Buffer(ctx, mf.READ_WRITE, rows * 4) if adaptive is not None else None
            cam = np.zeros(1, layout.CAMERA)
            eye, fwd, right, upv = camera.basis(width / height)
            cam["eye"], cam["forward"], cam["right"], cam["up"] = eye * cs.scale, fwd, right, upv   # device units
            self.cam = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=cam)
        except cl.MemoryError as e:
            raise DeviceError(f"render: out of device memory for {n_max} rays per tile; pass a smaller "
                              f"tile_pixels ({e})") from None
        self.events = {name: [] for name in (("render_fused",) if fused else STAGES)}
        if fused and aovs:
            self.events.update({name: [] for name in ("raygen", "intersect", "surface")})
        if adaptive is not None:
            self.events.update({name: [] for name in ("adaptive_mark", "adaptive_count", "adaptive_scan",
                                                      "adaptive_list")})
        self.k = {name: rt.kernel(prg, name) for name in self.events}     # only the kernels this render runs
        u32 = np.uint32
        self.geom, self.light = self.up.geom, self.up.light
        self.surface_args = self.up.args("SURFACE", cam=self.cam, image_w=u32(width), image_h=u32(height),
                                         spp=u32(spp))

    def _launch(self, name, gsize, lsize, *args):
        ev = self.k[name](self.rt.queue, gsize, lsize, *args)
        self.events[name].append(ev)
        return ev

    def fused(self, gsize, lsize, n, y0, first, count, active=None, listed_n=None):
        """``count`` samples from ``first`` of every pixel of the tile at row y0 (with adaptive
        sampling: of the n pixels listed in ``active``, or pixels 0 .. n - 1 for None; where
        ``listed_n`` is given, the list's length is read from it on the device, not n)."""
        u32, cs = np.uint32, self.cs
        return self._launch("render_fused", gsize, lsize, self.accum, self.rgb, active, listed_n, self.sum_y2,
                            u32(n), u32(y0), u32(first), u32(count), u32(self.pixels),
                            u32(self.seed), u32(self.jitter), *self.geom, *self.surface_args, *self.light,
                            cs.ambient, cs.background)

    def adaptive_tile(self, n, y0, rows, per_launch, first_size, report):
        """Sample the tile's n pixels in rounds, each round only those still active
        (texray.renderer.adaptive), up to spp samples; ``first_size``: the first round's (global,
        local) launch size, render_rows's for every pixel of the tile.

        Between rounds the device decides which pixels go on (stages/adaptive.cl: the stopping
        rule, the dilation within blocks, the list of those pixels and its length, written where
        the next round reads them). The host does not wait for the decision: a later round's
        launches take the list's length on the device (render_fused's and adaptive_mark's
        listed_n, a fixed number of work-items looping over the list), and the host reads each
        length back while the device renders, to count the samples and to stop enqueuing
        rounds after one with an empty list. (Until 2026-12-07 the host decided, in numpy on
        the read-back sums, and a tile ran as two halves on two queues; until 2026-12-07 it
        waited for each length to size the next launch: README "Adaptive sampling".)"""
        q, spp, width, u32 = self.rt.queue, self.spp, self.width, np.uint32
        done, listed, reads = 0, None, []
        rounds = round_sizes(spp)
        # a later round's work-items: at most LATER_GROUPS work-groups (the list is at most the
        # tile), each work-item looping over groups of pixels
        later = self.rt.launch_size(min(-(-n // self.pixels), LATER_GROUPS * (self.local or 64)), self.local)
        for tag, samples in enumerate(rounds, 1):
            # no round after one without pixels: the length before last, if it is back (waiting
            # for it held the host until PoCL's queue drained, the device idle meanwhile)
            if tag > 2 and reads[-2][0].command_execution_status == cl.command_execution_status.COMPLETE \
                    and not int(reads[-2][1][0]):
                break
            gsize, lsize = first_size if tag == 1 else later
            decide = done + samples < spp
            listed_n = None if tag == 1 else self.count
            for first in range(done, done + samples, per_launch):
                report(self.fused(gsize, lsize, n, y0, first, min(per_launch, done + samples - first), active=listed,
                                  listed_n=listed_n))
            done += samples
            if decide:                  # the decision for the next round: round `tag`'s stamps
                mg, ml = self.rt.launch_size(n, self.local) if tag == 1 else later
                self._launch("adaptive_mark", mg, ml, self.accum, self.sum_y2, listed, listed_n, u32(n), self.stamp,
                             u32(tag), np.float32(self.adaptive), np.float32(FLOOR))
                gsize, lsize = self.rt.launch_size(rows, self.local)
                rows_args = (self.stamp, u32(tag), u32(rows), u32(width), u32(y0), u32(BLOCK_ROWS))
                self._launch("adaptive_count", gsize, lsize, *rows_args, self.row_count)
                self._launch("adaptive_scan", (1,), None, self.row_count, u32(rows), self.count)
                self._launch("adaptive_list", gsize, lsize, *rows_args, self.row_count, self.active)
                length = np.zeros(1, np.uint32)
                reads.append((cl.enqueue_copy(q, length, self.count, is_blocking=False), length))
                listed = self.active
        # the samples: every pixel's first round, then each list's pixels the next round's (the
        # lengths are read once the queue is finished: adaptive_samples)
        self.samples += n * rounds[0]
        # (the copies' events kept: pyopencl waits for a dropped one's copy, which holds the array)
        self.pending += [(ev, length, s) for (ev, length), s in zip(reads, rounds[1:])]

    def adaptive_samples(self):
        """The samples adaptive_tile's later rounds took, from the lists' lengths (after the
        queue is finished)."""
        return self.samples + sum(int(length[0]) * s for _, length, s in self.pending)

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
            self._launch("shadow", gsize, lsize, self.surf, self.vis, u32(n), u32(self.width), u32(y0), u32(sample),
                         u32(self.spp), u32(self.seed), *self.geom, *self.light)
        return self._launch("shade", gsize, lsize, self.rays, self.surf, self.vis, u32(n), self.accum, self.rgb,
                            *self.light, cs.ambient, cs.background)
