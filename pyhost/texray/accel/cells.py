"""A faster BVH build for large inputs: Morton cells built in parallel on the CPU device.

The numpy builder (:mod:`texray.accel.bvh`) does O(n) array work per tree level, most of
it gathers: 3.6 s for a million triangles. Here kernels (``kernels/accel/build.cl``)
compute the primitives' centroids and their Morton codes, the host (numpy) sorts the
codes and cuts the order into *cells*, runs of one Morton prefix (an octree cell),
refined until none holds more than :data:`CELL_PRIMS`; one OpenCL work-item per cell
then builds the cell's binned-SAH tree sequentially (the numpy builder's rule, as
compiled code), a numpy binned-SAH tree over the cells' boxes joins them (HLBVH's split
of the work: Garanzha et al. 2011) and a last kernel copies the cells' nodes behind it.
The kernels run on PoCL's CPU device, whatever device renders: the build is the host's
job, OpenCL is how it gets compiled, threaded code.

Only the top levels differ from the numpy builder's tree: they split between cells,
not anywhere. :func:`build` returns the same :class:`texray.accel.bvh.BVH` record
(every primitive in exactly one leaf, leaves of at most ``max_leaf``, children
adjacent, root at 0), and its SAH cost is reported like the numpy one's.
"""
from __future__ import annotations

import threading
import time
import warnings
from typing import NamedTuple

import numpy as np
import pyopencl as cl
from pyopencl import cltypes

from ..device import Runtime, runtime
from ..device.layout import BVH_NODE, LEAF_COUNT_BITS
from . import bvh

# Inputs below this many primitives use the numpy builder (its cost there is small, and
# the kernel program's first build costs 0.5-1 s once per machine).
MIN_PRIMS = 100_000
# Cells are refined while they hold more primitives than this (and Morton bits remain).
CELL_PRIMS = 2048
MORTON_BITS = 10                 # per axis: 30-bit codes

_program_lock = threading.Lock()


def build(bmin, bmax, *, max_leaf=4, kind=0, device="pocl") -> bvh.BVH:
    """A BVH over the boxes (as :func:`texray.accel.bvh.build`, default settings) built
    by cells on ``device`` (default PoCL's CPU device; a texray.device.runtime selector
    or a Runtime); the numpy builder where that is not possible (no such device, a
    failed cell), with a warning."""
    t0 = time.perf_counter()
    lo, hi = bvh.check_boxes(bmin, bmax)
    n = len(lo)
    if n <= max(max_leaf, 1) * 2:
        return bvh.build(lo, hi, max_leaf=max_leaf, kind=kind)
    lo, hi = np.ascontiguousarray(lo), np.ascontiguousarray(hi)
    try:
        rt = device if isinstance(device, Runtime) else runtime(device)
        order, starts = morton_cells(lo, hi, rt)
        run = _run_cells(lo, hi, order, starts, max_leaf, kind, rt)
        if np.any(run.counts == 0):
            warnings.warn("BVH build: a cell failed its checks; building with numpy", stacklevel=2)
            return bvh.build(lo, hi, max_leaf=max_leaf, kind=kind)
        nodes, depth = join_cells(run, starts, rt)
    except Exception as e:                   # no PoCL device, or a driver failure: the reference builder
        warnings.warn(f"BVH build: the cell builder is unavailable ({type(e).__name__}: {e}); "
                      "building with numpy", stacklevel=2)
        return bvh.build(lo, hi, max_leaf=max_leaf, kind=kind)
    return bvh.BVH(nodes, run.index, bvh.sah_cost(nodes), depth, time.perf_counter() - t0)


# Work-items of the data-parallel kernels (bvh_centroid_bounds, bvh_morton): each takes a
# contiguous share, enough of them to keep every core of a CPU device busy.
SHARES = 64


class CellRun(NamedTuple):
    """What bvh_build_cells leaves: every cell's node slots (host memory the kernel wrote,
    2 n records), the leaf-ordered primitive ids, and per cell its nodes used (0: failed)
    and depth."""
    raw: np.ndarray
    index: np.ndarray
    counts: np.ndarray
    depths: np.ndarray


def _program(rt):
    with _program_lock:
        return rt.build('#include "accel/build.cl"\n')


def _read_back(rt, pairs):
    """Map each (buffer, host array) for reading, so that a device's writes through
    USE_HOST_PTR are visible in the host array (copied there by a device that copies)."""
    q = rt.queue
    for buf, host in pairs:
        mapped, _ = cl.enqueue_map_buffer(q, buf, cl.map_flags.READ, 0, host.shape, host.dtype, is_blocking=True)
        if mapped.ctypes.data != host.ctypes.data:
            host[...] = mapped
        mapped.base.release(q)
    q.finish()


def morton_codes(lo, hi, rt) -> np.ndarray:
    """The 30-bit Morton code (MORTON_BITS per axis) of each box's centroid over the
    centroids' bounds, computed by the kernels bvh_centroid_bounds and bvh_morton."""
    prg, n = _program(rt), len(lo)
    mf, ctx, q = cl.mem_flags, rt.context, rt.queue
    d_lo = cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=lo)
    d_hi = cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=hi)
    shares = max(1, min(SHARES, n))
    part = np.empty((shares, 6), np.float32)
    d_part = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=part)
    k = cl.Kernel(prg, "bvh_centroid_bounds")
    k.set_args(d_lo, d_hi, np.uint32(n), d_part)
    cl.enqueue_nd_range_kernel(q, k, (shares,), (1,))
    _read_back(rt, [(d_part, part)])
    cmin, cmax = part[:, :3].min(axis=0), part[:, 3:].max(axis=0)
    ext = np.where(cmax > cmin, cmax.astype(np.float64) - cmin, 1.0)
    scale = ((1 << MORTON_BITS) / ext).astype(np.float32)
    code = np.empty(n, np.uint32)
    d_code = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=code)
    k = cl.Kernel(prg, "bvh_morton")
    k.set_args(d_lo, d_hi, np.uint32(n), cltypes.make_float4(*cmin.tolist(), 0.0),
               cltypes.make_float4(*scale.tolist(), 0.0), d_code)
    cl.enqueue_nd_range_kernel(q, k, (shares,), (1,))
    _read_back(rt, [(d_code, code)])
    return code


def morton_cells(lo, hi, device="pocl"):
    """(order, starts): the primitives sorted by the Morton code of their centroids, and the
    cell boundaries in that order (starts[0] = 0, starts[-1] = n): runs of one code prefix,
    split by three more bits while longer than CELL_PRIMS."""
    rt = device if isinstance(device, Runtime) else runtime(device)
    n = len(lo)
    code = morton_codes(np.ascontiguousarray(lo, np.float32), np.ascontiguousarray(hi, np.float32), rt)
    order = np.argsort(code).astype(np.uint32)      # deterministic; ties in any fixed order
    code = code[order]
    bounds = np.array([0, n], np.int64)
    for level in range(1, MORTON_BITS + 1):
        sizes = np.diff(bounds)
        if sizes.max() <= CELL_PRIMS:
            break
        key = code >> np.uint32(3 * (MORTON_BITS - level))
        cand = np.flatnonzero(key[1:] != key[:-1]) + 1        # where this level's prefix changes
        seg = np.searchsorted(bounds, cand, side="right") - 1  # the current cell holding each
        keep = cand[sizes[seg] > CELL_PRIMS]
        bounds = np.union1d(bounds, keep)
    return order, bounds.astype(np.uint32)


def _run_cells(lo, hi, order, starts, max_leaf, kind, rt) -> CellRun:
    """Run bvh_build_cells on the Runtime ``rt``."""
    prg = _program(rt)
    n, ncells = len(lo), len(starts) - 1
    # The node slots and the order live in host arrays the kernel writes through
    # (USE_HOST_PTR: no second copy on a CPU device); mapping them afterwards makes the
    # results visible on any device. rec (the boxes in cell order) is the kernel's own.
    raw = np.empty(2 * n, BVH_NODE)
    index = np.array(order, dtype=np.uint32)
    counts, depths = np.empty(ncells, np.uint32), np.empty(ncells, np.uint32)
    mf, ctx, q = cl.mem_flags, rt.context, rt.queue
    d_lo = cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=lo)
    d_hi = cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=hi)
    d_index = cl.Buffer(ctx, mf.READ_WRITE | mf.USE_HOST_PTR, hostbuf=index)
    d_rec = cl.Buffer(ctx, mf.READ_WRITE, size=32 * n)
    d_starts = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=starts)
    d_raw = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=raw)
    d_count = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=counts)
    d_depth = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=depths)
    k = cl.Kernel(prg, "bvh_build_cells")
    k.set_args(d_lo, d_hi, d_index, d_rec, d_starts, d_raw, d_count, d_depth, np.uint32(ncells), np.uint32(n),
               np.uint32(kind << LEAF_COUNT_BITS), np.uint32(max_leaf))
    cl.enqueue_nd_range_kernel(q, k, (ncells,), (1,))
    _read_back(rt, [(d_raw, raw), (d_index, index), (d_count, counts), (d_depth, depths)])
    return CellRun(raw, index, counts, depths)


def join_cells(run, starts, rt):
    """(nodes, depth): a top tree over the cells' root boxes (numpy binned SAH, one cell
    per leaf) with each top leaf replaced by its cell's root, then every cell's other
    nodes in slot order (bvh_compact_cells: cell c's slots 2 start_c + 1 ..
    2 start_c + counts_c - 1 go to len(top) + before_c + 0 .., child slots renumbered)."""
    counts, ncells = run.counts, len(run.counts)
    root_slots = 2 * starts[:-1].astype(np.int64)
    roots = run.raw[root_slots]
    top = bvh.build(roots["bmin"], roots["bmax"], max_leaf=1, sah_leaf_max=1)
    keep_n = counts.astype(np.int64) - 1
    base = len(top.nodes) + np.concatenate([[0], np.cumsum(keep_n)])
    if base[-1] >= 2 ** 32:
        raise ValueError("BVH build: more nodes than 32-bit indices address")
    nodes = np.empty(int(base[-1]), BVH_NODE)
    body = nodes[len(top.nodes):]
    if len(body):
        prg, mf, ctx, q = _program(rt), cl.mem_flags, rt.context, rt.queue
        d_raw = cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=run.raw)
        d_starts = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=starts)
        d_counts = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=counts)
        d_base = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=base[:-1].astype(np.uint32))
        d_out = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=nodes)
        k = cl.Kernel(prg, "bvh_compact_cells")
        k.set_args(d_raw, d_starts, d_counts, d_base, np.uint32(ncells), d_out)
        cl.enqueue_nd_range_kernel(q, k, (ncells,), (1,))
        _read_back(rt, [(d_out, nodes)])
    nodes[: len(top.nodes)] = top.nodes
    # top leaves -> their cell's root (one cell each: max_leaf=1), its child slot renumbered
    leaves = np.flatnonzero(top.nodes["count_kind"] != 0)
    cells = top.order[top.nodes["first"][leaves]]
    root = roots[cells]
    inner = root["count_kind"] == 0
    root["first"][inner] = (base[cells[inner]] + root["first"][inner].astype(np.int64)
                            - root_slots[cells[inner]] - 1)
    nodes[leaves] = root
    return nodes, int((_node_depths(top.nodes)[leaves] - 1 + run.depths[cells]).max())


def _node_depths(nodes):
    """Depth (root 1) of every node of a tree (the top tree: a few thousand nodes at most)."""
    depth = np.zeros(len(nodes), np.int64)
    frontier, d = np.array([0]), 1
    while len(frontier):
        depth[frontier] = d
        inner = frontier[nodes["count_kind"][frontier] == 0]
        first = nodes["first"][inner].astype(np.int64)
        frontier, d = np.concatenate([first, first + 1]), d + 1
    return depth
