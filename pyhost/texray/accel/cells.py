"""A faster BVH build for large inputs: Morton cells built in parallel on the CPU device.

The numpy builder (:mod:`texray.accel.bvh`) does O(n) array work per tree level, most of
it gathers: 3.6 s for a million triangles. Here the host (numpy) sorts the primitives'
centroids along a Morton curve and cuts the order into *cells*, runs of one Morton
prefix (an octree cell), refined until none holds more than :data:`CELL_PRIMS`; one
OpenCL work-item per cell then builds the cell's binned-SAH tree sequentially
(``kernels/accel/build.cl``: the numpy builder's rule, as compiled code), and a
numpy binned-SAH tree over the cells' boxes joins them (HLBVH's split of the work:
Garanzha et al. 2011). The kernel runs on PoCL's CPU device, whatever device renders:
the build is the host's job, OpenCL is how it gets compiled, threaded code.

Only the top levels differ from the numpy builder's tree: they split between cells,
not anywhere. :func:`build` returns the same :class:`texray.accel.bvh.BVH` record
(every primitive in exactly one leaf, leaves of at most ``max_leaf``, children
adjacent, root at 0), and its SAH cost is reported like the numpy one's.
"""
from __future__ import annotations

import threading
import time
import warnings

import numpy as np
import pyopencl as cl

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
    order, starts = morton_cells(lo, hi)
    try:
        nodes_raw, index, counts, depths = _run_cells(lo, hi, order, starts, max_leaf, kind, device)
    except Exception as e:                   # no PoCL device, or a driver failure: the reference builder
        warnings.warn(f"BVH build: the cell builder is unavailable ({type(e).__name__}: {e}); "
                      "building with numpy", stacklevel=3)
        return bvh.build(lo, hi, max_leaf=max_leaf, kind=kind)
    if np.any(counts == 0):
        warnings.warn("BVH build: a cell failed its checks; building with numpy", stacklevel=3)
        return bvh.build(lo, hi, max_leaf=max_leaf, kind=kind)
    nodes, depth = join_cells(nodes_raw, starts, counts, depths)
    return bvh.BVH(nodes, index, bvh.sah_cost(nodes), depth, time.perf_counter() - t0)


def morton_cells(lo, hi):
    """(order, starts): the primitives sorted by the Morton code of their centroids, and the
    cell boundaries in that order (starts[0] = 0, starts[-1] = n): runs of one code prefix,
    split by three more bits while longer than CELL_PRIMS."""
    n = len(lo)
    c = lo * np.float32(0.25)                # half the centroids, float32, in place: neither the sums
    c += hi * np.float32(0.25)               # nor the differences below overflow, whatever the boxes
    # per column: numpy's axis-0 reduction of an (n, 3) array is 10x slower (35 ms per 1.3M)
    cmin = np.array([c[:, j].min() for j in range(3)], np.float32)
    cmax = np.array([c[:, j].max() for j in range(3)], np.float32)
    ext = np.where(cmax > cmin, cmax.astype(np.float64) - cmin, 1.0)
    c -= cmin
    c *= ((1 << MORTON_BITS) / ext).astype(np.float32)
    q = np.minimum(c.astype(np.int32), (1 << MORTON_BITS) - 1)
    code = _spread(q[:, 0]) << np.uint32(2) | _spread(q[:, 1]) << np.uint32(1) | _spread(q[:, 2])
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


def _spread(v):
    """The bits of v (< 2^10) spread to every third bit."""
    v = v.astype(np.uint32)
    for shift, mask in ((16, 0x030000FF), (8, 0x0300F00F), (4, 0x030C30C3), (2, 0x09249249)):
        v = (v | v << np.uint32(shift)) & np.uint32(mask)
    return v


def _run_cells(lo, hi, order, starts, max_leaf, kind, device):
    """Run the kernel on ``device`` (a texray.device.runtime selector, or a Runtime):
    (node slots, leaf-ordered primitive ids, nodes used and depth per cell)."""
    rt = device if isinstance(device, Runtime) else runtime(device)
    with _program_lock:
        prg = rt.build('#include "accel/build.cl"\n')
    n, ncells = len(lo), len(starts) - 1
    box = np.ascontiguousarray(np.concatenate([lo, hi], axis=1), dtype=np.float32)
    # The node slots and the order live in host arrays the kernel writes through
    # (USE_HOST_PTR: no second 64 MiB per million primitives, no copy on a CPU device);
    # mapping them afterwards makes the results visible on any device.
    nodes = np.empty(2 * n, BVH_NODE)
    index = np.array(order, dtype=np.uint32)
    counts, depths = np.empty(ncells, np.uint32), np.empty(ncells, np.uint32)
    mf, ctx, q = cl.mem_flags, rt.context, rt.queue
    d_box = cl.Buffer(ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=box)
    d_index = cl.Buffer(ctx, mf.READ_WRITE | mf.USE_HOST_PTR, hostbuf=index)
    d_starts = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=starts)
    d_nodes = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=nodes)
    d_count = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=counts)
    d_depth = cl.Buffer(ctx, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=depths)
    k = cl.Kernel(prg, "bvh_build_cells")
    k.set_args(d_box, d_index, d_starts, d_nodes, d_count, d_depth, np.uint32(ncells), np.uint32(n),
               np.uint32(kind << LEAF_COUNT_BITS), np.uint32(max_leaf))
    cl.enqueue_nd_range_kernel(q, k, (ncells,), (1,))
    for buf, host in ((d_nodes, nodes), (d_index, index), (d_count, counts), (d_depth, depths)):
        mapped, _ = cl.enqueue_map_buffer(q, buf, cl.map_flags.READ, 0, host.shape, host.dtype, is_blocking=True)
        if mapped.ctypes.data != host.ctypes.data:     # a device that copies: take its result
            host[...] = mapped
        mapped.base.release(q)
    q.finish()
    return nodes, index, counts, depths


def join_cells(raw, starts, counts, depths):
    """(nodes, depth): a top tree over the cells' root boxes (numpy binned SAH, one cell
    per leaf) with each top leaf replaced by its cell's root, then every cell's other
    nodes, compacted (slot indices renumbered)."""
    root_slots = 2 * starts[:-1].astype(np.int64)
    roots = raw[root_slots]
    top = bvh.build(roots["bmin"], roots["bmax"], max_leaf=1, sah_leaf_max=1)
    # the cells' nodes but their roots, in slot order: cell c's slots 2 start_c + 1 ..
    # 2 start_c + counts_c - 1 go to len(top) + before_c + 0 ..
    keep_n = counts.astype(np.int64) - 1
    before = np.concatenate([[0], np.cumsum(keep_n)])
    total = int(before[-1])
    slots = np.repeat(root_slots + 1 - before[:-1], keep_n) + np.arange(total)
    body = raw[slots]
    nodes = np.concatenate([top.nodes, body])

    def new_index(slot):
        cell = np.searchsorted(root_slots, slot, side="right") - 1
        local = slot - root_slots[cell] - 1
        if np.any(local < 0) or np.any(local >= keep_n[cell]):
            raise AssertionError("cell join: a child slot outside its cell's nodes")
        return len(top.nodes) + before[cell] + local

    # top leaves -> their cell's root (one cell each: max_leaf=1)
    leaves = np.flatnonzero(top.nodes["count_kind"] != 0)
    cells = top.order[top.nodes["first"][leaves]]
    nodes[leaves] = roots[cells]
    # interior nodes pointing at raw slots: the cells' and the copied roots (the top
    # tree's own interior nodes already point into the top tree)
    remap = nodes["count_kind"] == 0
    top_own = np.zeros(len(nodes), bool)
    top_own[: len(top.nodes)] = True
    top_own[leaves] = False
    remap &= ~top_own
    nodes["first"][remap] = new_index(nodes["first"][remap].astype(np.int64))
    return nodes, int((_node_depths(top.nodes)[leaves] - 1 + depths[cells]).max())


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
