"""Trace arbitrary rays against a scene's BVH: the intersect stage on its own.

For tests (device results against float64 references) and the benchmark
(closest-hit and any-hit throughput on given rays).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pyopencl as cl

from ..compile import CompiledScene, compile_scene
from ..device import layout, runtime
from ..device.buffers import Uploaded
from ..device.features import compile_options


@dataclass
class Hits:
    t: np.ndarray       # float32, tmax for a miss
    b1: np.ndarray
    b2: np.ndarray
    prim: np.ndarray    # int64 Hit.prim (kind << layout.HIT_KIND_SHIFT | leaf-order index), -1 for a miss
    seconds: float      # device time of the kernel (profiling events)


class Tracer:
    """A compiled scene uploaded to one device, ready to trace batches of rays."""

    def __init__(self, scene_or_compiled, device=None):
        cs = scene_or_compiled if isinstance(scene_or_compiled, CompiledScene) else compile_scene(scene_or_compiled)
        self.compiled = cs
        self.rt = runtime(device)
        # as a render with shadow rays would build it (a scene without lights has none), with
        # packets of `packet` rays per work-item where the device has them: the width for
        # batches of rays, a lane each (texray.device.features.trace_packet_width)
        options = compile_options(dataclasses.replace(cs.features, shadows=True), self.rt.kind, rays=True)
        self.program = self.rt.program(options)
        self.up = Uploaded(self.rt.context, cs)
        self.packet = options["TX_PACKET"]
        closest_packet = self.packet and not cs.features.instances
        self._k_closest = cl.Kernel(self.program, "intersect_packet" if closest_packet else "intersect")
        self._closest_items = self.packet if closest_packet else 1
        self._k_any = cl.Kernel(self.program, "occluded_packet" if self.packet else "occluded")
        # the renderer's work-group size for this program (PACKET_LOCAL_SIZES, LOCAL_SIZES)
        self.local = self.rt.local_size(None, self.packet)

    def _rays(self, org, dirs, tmin, tmax):
        n = len(dirs)
        r = np.zeros(n, layout.RAY)
        # in device units (texray.compile.units): origins and directions alike, so that t is the same
        s = self.compiled.scale
        r["org"], r["dir"] = np.broadcast_to(org, (n, 3)), dirs
        if s != 1.0:
            r["org"] *= np.float32(s)
            r["dir"] *= np.float32(s)
        r["tmin"], r["tmax"] = tmin, tmax
        mf = cl.mem_flags
        return n, cl.Buffer(self.rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=r)

    def closest(self, org, dirs, tmin=0.0, tmax=np.inf) -> Hits:
        n, rays = self._rays(org, dirs, tmin, tmax)
        out = np.zeros(n, layout.HIT)
        hits = cl.Buffer(self.rt.context, cl.mem_flags.WRITE_ONLY,   # intersect.cl: 2n records with instances
                         max(out.nbytes * (2 if self.up.features.instances else 1), 16))
        glob, loc = self.rt.launch_size(-(-n // self._closest_items), self.local)
        ev = self._k_closest(self.rt.queue, glob, loc, rays, hits, np.uint32(n), *self.up.geom)
        cl.enqueue_copy(self.rt.queue, out, hits, wait_for=[ev])
        prim = out["prim"].astype(np.int64)
        prim[out["prim"] == 0xFFFFFFFF] = -1
        return Hits(out["t"], out["b1"], out["b2"], prim, (ev.profile.end - ev.profile.start) * 1e-9)

    def occluded(self, org, dirs, tmin=0.0, tmax=1.0):
        """(bool array, device seconds): whether anything is hit with t in (tmin, tmax)."""
        n, rays = self._rays(org, dirs, tmin, tmax)
        out = np.zeros(n, np.uint8)
        buf = cl.Buffer(self.rt.context, cl.mem_flags.WRITE_ONLY, max(n, 16))
        glob, loc = self.rt.launch_size(-(-n // self.packet) if self.packet else n, self.local)
        ev = self._k_any(self.rt.queue, glob, loc, rays, buf, np.uint32(n), *self.up.geom)
        cl.enqueue_copy(self.rt.queue, out, buf, wait_for=[ev])
        return out.astype(bool), (ev.profile.end - ev.profile.start) * 1e-9
