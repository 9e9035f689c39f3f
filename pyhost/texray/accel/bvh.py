"""Binned-SAH bounding volume hierarchy, built one tree level at a time with numpy.

Algorithm
---------
The tree is built top-down and breadth-first.  Each step handles *all* nodes of
one depth at once with array operations over all of their primitives; the only
Python loops are over levels (about log2 n), the three axes and the bins, never
over nodes or primitives.  Work is O(n) per level, O(n log n) in all.

* Centroids are sorted once along each axis.  For each axis ``a`` the builder
  keeps the primitives of the still-open ("active") nodes -- id, centroid
  coordinate on ``a``, box -- in arrays in which every active node is a
  contiguous segment sorted by centroid ``a``.
* Binning (Wald 2007, on all three axes): a node's centroid range along ``a``
  is given by the first and last element of its segment and is cut into equal
  bins.  Since the segment is sorted, bin ids never decrease inside it, so each
  (node, bin) cell is one run of consecutive primitives; per-cell counts and
  bounds come from ``np.minimum.reduceat`` over run starts while runs are few,
  from ``np.minimum.at`` once they are short.  Boxes are stored as
  ``(min x, min y, min z, -max x, -max y, -max z)`` so one minimum gives both
  corners.  A level whose active nodes hold on average fewer than ``2 * bins``
  primitives uses ``max(4, average / 2)`` bins, as more would be mostly empty
  (it changes the SAH cost of typical trees by well under 1%).  Levels of at most
  TOP_LEVEL_NODES nodes (the tree's first six) may bin finer (``top_bins``): few nodes,
  so cheap, and where one large primitive (a ground plane's triangles) stretches the
  centroid range, 16 bins leave the objects in a few of them (below).
* Plane costs: a backward and a forward sweep over the bins give, for every
  plane, node and axis, ``nL * A(L) + nR * A(R)`` (``A`` = half surface area,
  computed in float32 after scaling each node's extents by 1 / its largest
  extent, so any float32 coordinates are safe); the cheapest plane wins.
* Partition: on the split axis the left child is a prefix of the segment; a
  per-primitive left/right flag carries the decision to the other axes.  Each
  axis' arrays are then reordered by one stable gather (``np.flatnonzero`` of
  "goes to an open left child", then of "goes to an open right child"), which
  keeps every child contiguous and sorted; left children form one block and
  right children another, and each level records which segment is which node.
  Primitives of new leaves are copied to the output ``order`` straight away.
* Nodes are emitted level by level, so the two children of an interior node
  are adjacent.  Node bounds are float32 minima/maxima of the primitives'
  float32 boxes, hence exact.

Leaf policy
-----------
* A node with ``count <= max_leaf`` primitives is always a leaf.
* Optional SAH termination: a node with ``max_leaf < count <= sah_leaf_max``
  becomes a leaf when its leaf cost ``t_isect * count * A(node)`` is at most
  the cost of its best split ``t_trav * A(node) + t_isect * (nL * A(L) + nR *
  A(R))`` (infinite when no plane separates its centroids).  It is off by
  default (``sah_leaf_max=None`` means ``max_leaf``), so that ``max_leaf`` is a
  hard limit callers can rely on (a top-level tree built with ``max_leaf=1``
  has one primitive per leaf).  With t_trav = t_isect it changes the SAH cost
  of typical scenes by under 0.2%; ``sah_leaf_max=16`` is a good value when
  traversal is dear relative to intersection.
* Any other node is split at its best SAH plane; when no plane separates the
  centroids (all centroids equal, or extents beyond float32 range made every
  plane's cost overflow), it is split in the middle by count.

So no leaf holds more than :func:`leaf_size_limit` ``= max(max_leaf,
sah_leaf_max)`` primitives (``max_leaf`` with the defaults).

Cost: about 3-4 s and 200 MB of working memory for a million triangles
(numpy, single-threaded, on a 2-core AMD EPYC VM).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..device.layout import BVH_NODE, LEAF_COUNT_MASK, PRIM_TRIANGLE, decode_leaf, encode_leaf

# Levels of at most this many nodes bin with ``top_bins`` (build).
TOP_LEVEL_NODES = 64

# Grouped minima use np.minimum.reduceat (cost per run) while there are fewer
# than this many runs per primitive, np.minimum.at (cost per primitive) above.
_RUNS_PER_PRIM = 0.1


@dataclass
class BVH:
    """A built tree.

    nodes: ``BVH_NODE`` structured array, root at index 0 (empty when n == 0).
    order: (n,) uint32; leaf slot ``i`` holds original primitive ``order[i]``.
    sah_cost: :func:`sah_cost` of ``nodes`` with the build's costs.
    depth: number of levels (a single-leaf tree has depth 1, an empty one 0).
    build_seconds: wall-clock time of :func:`build`.
    """
    nodes: np.ndarray
    order: np.ndarray
    sah_cost: float
    depth: int
    build_seconds: float


def leaf_size_limit(max_leaf: int = 4, sah_leaf_max: int | None = None) -> int:
    """Largest number of primitives a leaf built with these settings can hold."""
    return max(max_leaf, sah_leaf_max or max_leaf)


def build(bmin, bmax, *, max_leaf=4, bins=16, kind=PRIM_TRIANGLE, t_trav=1.0,
          t_isect=1.0, sah_leaf_max=None, top_bins=None) -> BVH:
    """Build a binned-SAH BVH over axis-aligned primitive boxes.

    bmin, bmax: (n, 3) primitive box corners, world units (float32; other real
        dtypes are converted, rounding outward).
    max_leaf: nodes with at most this many primitives are always leaves; with
        the default ``sah_leaf_max`` no leaf holds more.
    bins: SAH bins per axis and node (>= 2; fewer on levels of small nodes,
        see the module docstring).
    kind: primitive kind stored in every leaf (``layout.PRIM_*``).
    t_trav, t_isect: SAH costs of one node traversal and one intersection.
    sah_leaf_max: largest node the SAH may keep as a leaf rather than split it
        (module docstring); None = ``max_leaf``, i.e. SAH termination off.
    top_bins: bins per axis and node on levels of at most TOP_LEVEL_NODES nodes (at
        least ``bins``); None = ``bins``.

    Raises ValueError for bad shapes, NaN/inf bounds, bmin > bmax, or bad settings.
    """
    t0 = time.perf_counter()
    lo, hi = check_boxes(bmin, bmax)
    sah_leaf_max = max_leaf if sah_leaf_max is None else sah_leaf_max
    _check_settings(max_leaf, bins, kind, t_trav, t_isect, sah_leaf_max)
    top_bins = bins if top_bins is None else max(bins, int(top_bins))
    n = len(lo)
    if n == 0:
        nodes, order, depth = np.zeros(0, BVH_NODE), np.zeros(0, np.uint32), 0
    elif n <= max_leaf:
        bounds = np.concatenate((lo.min(axis=0), -hi.max(axis=0)))[:, None]
        nodes = _node_records(bounds, np.zeros(1, np.int64), encode_leaf([n], kind))
        order, depth = np.arange(n, dtype=np.uint32), 1
    else:
        builder = _LevelBuilder(lo, hi, max_leaf, bins, kind, t_trav, t_isect,
                                max(sah_leaf_max, max_leaf), top_bins)
        nodes, order, depth = builder.run()
    cost = sah_cost(nodes, t_trav, t_isect)
    return BVH(nodes, order, cost, depth, time.perf_counter() - t0)


def node_area(nodes) -> np.ndarray:
    """Half surface area (float64) of each ``layout.BVH_NODE`` record's box."""
    b0, b1 = nodes["bmin"], nodes["bmax"]          # per axis: no (n, 3) float64 copies
    ex = b1[:, 0].astype(np.float64) - b0[:, 0]
    ey = b1[:, 1].astype(np.float64) - b0[:, 1]
    ez = b1[:, 2].astype(np.float64) - b0[:, 2]
    return ex * ey + ey * ez + ez * ex


def sah_cost(nodes, t_trav=1.0, t_isect=1.0) -> float:
    """SAH cost of a tree, relative to its root's surface area.

    ``sum(t_trav * A(n) for interior n) + sum(t_isect * count(n) * A(n) for
    leaves n)``, divided by ``A(root)``; areas are computed in float64.  If the
    root has zero area every node does too, and every ratio is taken as 1.
    An empty tree costs 0.
    """
    if len(nodes) == 0:
        return 0.0
    area = node_area(nodes)
    count, _ = decode_leaf(nodes["count_kind"])
    weight = np.where(count == 0, t_trav, t_isect * count.astype(np.float64))
    if area[0] <= 0.0:
        return float(weight.sum())
    return float((weight * area).sum() / area[0])


# --- input checks -----------------------------------------------------------

def check_boxes(bmin, bmax):
    """Validate the box arrays; return them as (n, 3) float32, rounded outward."""
    lo, hi = np.asarray(bmin), np.asarray(bmax)
    for name, a in (("bmin", lo), ("bmax", hi)):
        if a.ndim != 2 or a.shape[1] != 3:
            raise ValueError(f"{name} must have shape (n, 3), got {a.shape}")
        if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
            raise ValueError(f"{name} must hold real numbers, got dtype {a.dtype}")
    if lo.shape != hi.shape:
        raise ValueError(f"bmin and bmax shapes differ: {lo.shape} vs {hi.shape}")
    lo, hi = _to_float32(lo, -np.inf), _to_float32(hi, np.inf)
    for name, a in (("bmin", lo), ("bmax", hi)):
        if not np.isfinite(a).all():
            bad = ~np.isfinite(a).all(axis=1)
            raise ValueError(f"{name} has NaN or infinite values (or values beyond float32 "
                             f"range) in {bad.sum()} boxes, first at index {bad.argmax()}")
    if (lo > hi).any():
        bad = (lo > hi).any(axis=1)
        raise ValueError(f"bmin > bmax in {bad.sum()} boxes, first at index {bad.argmax()}")
    return lo, hi


def _to_float32(a, toward):
    """``a`` as float32, rounding each value that is not exact ``toward`` +-inf."""
    if a.dtype == np.float32:
        return a
    with np.errstate(over="ignore", invalid="ignore"):    # overflow: caught by the caller
        f = a.astype(np.float32)
        wrong = (f > a) if toward < 0 else (f < a)
    return np.where(wrong, np.nextafter(f, np.float32(toward)), f)


def _check_settings(max_leaf, bins, kind, t_trav, t_isect, sah_leaf_max):
    if not 1 <= max_leaf <= LEAF_COUNT_MASK:
        raise ValueError(f"max_leaf must be in 1..{LEAF_COUNT_MASK}, got {max_leaf}")
    if not 1 <= sah_leaf_max <= LEAF_COUNT_MASK:
        raise ValueError(f"sah_leaf_max must be in 1..{LEAF_COUNT_MASK}, got {sah_leaf_max}")
    if bins < 2:
        raise ValueError(f"bins must be at least 2, got {bins}")
    if not 0 <= kind <= 255:
        raise ValueError(f"kind must fit in 8 bits, got {kind}")
    if not (np.isfinite(t_trav) and np.isfinite(t_isect) and t_trav >= 0 and t_isect > 0):
        raise ValueError(f"need t_trav >= 0 and t_isect > 0, got {t_trav}, {t_isect}")


# --- geometry helpers -------------------------------------------------------

def _half_area(b):
    """Half surface area (float64) of boxes ``b`` of shape (6, ...): min xyz, -max xyz."""
    e = -(b[3:].astype(np.float64) + b[:3])
    return e[0] * e[1] + e[1] * e[2] + e[2] * e[0]


def _scaled_half_area(b, inv_s):
    """Half area (float32) of boxes ``b`` (6, ..., k), in units of ``1 / inv_s[k]**2``.

    Scaling each node's extents to about 1 keeps the products in float32 range
    for any coordinates; empty boxes (all +inf) give +inf.
    """
    e = b[3:] + b[:3]                # minus the extents
    e *= inv_s
    area = e[0] * e[1]
    area += e[1] * e[2]
    area += e[2] * e[0]
    return area


def _inverse_size(bounds):
    """Per node 1 / (largest extent), float32, for :func:`_scaled_half_area`."""
    size = -(bounds[3:].astype(np.float64) + bounds[:3]).min(axis=0)
    with np.errstate(divide="ignore"):
        inv = np.where(size > 0, 1.0 / size, 1.0)
    return np.clip(inv, 2.0 ** -126, 2.0 ** 126).astype(np.float32)


def _exclusive_cumsum(x):
    out = np.zeros(len(x), np.int64)
    np.cumsum(x[:-1], out=out[1:])
    return out


def _node_records(bounds, first, count_kind):
    """BVH_NODE records from bounds (6, k), ``first`` (k,) and ``count_kind`` (k,)."""
    rec = np.zeros(bounds.shape[1], BVH_NODE)
    rec["bmin"] = bounds[:3].T
    rec["bmax"] = -bounds[3:].T
    rec["first"] = first
    rec["count_kind"] = count_kind
    return rec


def _segment_bounds(box, sizes):
    """Bounds (6, s) of consecutive column segments of ``box`` (6, m); sizes >= 1."""
    starts = _exclusive_cumsum(sizes)
    if len(sizes) <= _RUNS_PER_PRIM * box.shape[1]:
        return np.minimum.reduceat(box, starts, axis=1)
    out = np.full((6, len(sizes)), np.inf, np.float32)
    _min_at(out, np.repeat(np.arange(len(sizes)), sizes), box)
    return out


def _min_at(out, index, values):
    """``out[:, index[i]] = min(out[:, index[i]], values[:, i])`` for every column i."""
    for r in range(len(out)):
        np.minimum.at(out[r], index, values[r])


# --- binned SAH --------------------------------------------------------------

@dataclass
class _Segments:
    """Active nodes of a level as contiguous segments of the per-axis arrays."""
    cnt: np.ndarray    # (k,) int64 primitives per node
    start: np.ndarray  # (k,) int64 first element of each segment
    node: np.ndarray   # (m,) int64 node of each element

    @classmethod
    def of(cls, cnt):
        return cls(cnt, _exclusive_cumsum(cnt), np.repeat(np.arange(len(cnt)), cnt))

    def per_element(self, values):
        return np.repeat(values, self.cnt)


@dataclass
class _Axis:
    """Active primitives sorted, inside each node's segment, along one axis."""
    ids: np.ndarray    # (m,) uint32 original primitive index
    cent: np.ndarray   # (m,) float32 centroid coordinate on this axis
    box: np.ndarray    # (6, m) float32 boxes, min xyz then -max xyz

    def taken(self, src):
        """The elements ``src`` (m',) in that order."""
        return _Axis(self.ids[src], self.cent[src], np.take(self.box, src, axis=1))

    def head(self, m):
        return _Axis(self.ids[:m], self.cent[:m], self.box[:, :m])


def _bin(ax, seg, bins, mins, counts):
    """Bin one axis: bounds into ``mins`` (6, bins * k), sizes into ``counts`` (bins * k,).

    A node's centroid range is cut into ``bins`` equal bins; cell ``b * k + node``.
    ``mins`` must hold +inf and ``counts`` 0.  As each node's segment is sorted,
    a cell's primitives are consecutive: while runs are few, reduce by run.
    """
    k, m = len(seg.cnt), len(ax.cent)
    cmin = ax.cent[seg.start].astype(np.float64)
    ext = ax.cent[seg.start + seg.cnt - 1] - cmin
    scale = np.divide(bins * (1.0 - 2.0 ** -20), ext, out=np.zeros_like(ext), where=ext > 0)
    # float32 unless a centroid range overflows it; rounding keeps x monotone.
    ftype = np.float32 if ext.max() < 1e38 else np.float64
    scale = np.minimum(scale, np.finfo(ftype).max).astype(ftype)
    x = ax.cent - seg.per_element(cmin.astype(ftype))
    x *= seg.per_element(scale)
    cell = x.astype(np.intp)
    np.minimum(cell, bins - 1, out=cell)
    cell *= k
    cell += seg.node
    if bins * k <= _RUNS_PER_PRIM * m:
        runs = np.concatenate(([0], np.flatnonzero(cell[1:] != cell[:-1]) + 1))
        mins[:, cell[runs]] = np.minimum.reduceat(ax.box, runs, axis=1)
        counts[cell[runs]] = np.diff(runs, append=m)
    else:
        _min_at(mins, cell, ax.box)
        counts[:] = np.bincount(cell, minlength=len(counts))


def _best_planes(dense, count, inv_s):
    """Cheapest plane per axis and node from bin bounds (3, 6, bins, k) and counts (3, bins, k).

    Returns ``cost`` (3, k) float32, ``nL*A(L) + nR*A(R)`` in units of
    ``1 / inv_s**2`` (inf when no plane has primitives on both sides), and
    ``n_left`` (3, k).  Sweeps plane by plane so that the working set is a few
    (3, 6, k) slices rather than whole (bins, k) grids.
    """
    bins = dense.shape[2]
    area = lambda b: _scaled_half_area(b.transpose(1, 0, 2), inv_s)  # noqa: E731
    right = dense[:, :, -1].copy()
    n_right = count[:, -1].copy()
    right_cost = np.empty((bins - 1,) + n_right.shape, np.float32)
    with np.errstate(invalid="ignore", over="ignore"):   # empty side: inf * 0 = nan
        for i in range(bins - 2, -1, -1):
            np.multiply(area(right), n_right, out=right_cost[i], casting="unsafe")
            np.minimum(right, dense[:, :, i], out=right)
            n_right += count[:, i]
        left = dense[:, :, 0].copy()
        n_left = count[:, 0].copy()
        best = np.full(n_left.shape, np.inf, np.float32)
        best_n = np.zeros_like(n_left)
        for i in range(bins - 1):
            if i:
                np.minimum(left, dense[:, :, i], out=left)
                n_left += count[:, i]
            cost = area(left) * n_left.astype(np.float32)
            cost += right_cost[i]
            better = cost < best                       # nan never is
            np.copyto(best, cost, where=better)
            np.copyto(best_n, n_left, where=better)
    return best, best_n


# --- the level-by-level builder --------------------------------------------

@dataclass
class _Level:
    """All nodes of one depth, in output order."""
    cnt: np.ndarray     # (k,) int64 primitives per node
    bounds: np.ndarray  # (6, k) float32, min xyz then -max xyz
    leaf: np.ndarray    # (k,) bool, known leaves
    first: np.ndarray   # (k,) int64 ``first`` field, where known
    active: np.ndarray  # (ka,) int64 nodes still to split or finish, in the
    #                     order of their segments in the per-axis arrays


class _LevelBuilder:
    """State of one build: per-axis arrays of the active primitives and the output."""

    def __init__(self, lo, hi, max_leaf, bins, kind, t_trav, t_isect, sah_leaf_max, top_bins):
        self.max_leaf, self.bins, self.kind, self.top_bins = max_leaf, bins, kind, top_bins
        self.t_trav, self.t_isect, self.sah_leaf_max = t_trav, t_isect, sah_leaf_max
        n = len(lo)
        box = np.concatenate((lo.T, -hi.T))                # (6, n)
        cent = (lo * np.float32(0.5) + hi * np.float32(0.5)).T
        self.axes = []
        for a in range(3):
            ids = np.argsort(cent[a]).astype(np.uint32)
            self.axes.append(_Axis(ids, cent[a][ids], np.take(box, ids, axis=1)))
        self.flag = np.empty(n, bool)                      # scratch: goes left?
        self.order = np.empty(n, np.uint32)
        self.filled = 0                                    # leaf slots written
        self.grid = np.empty(0, np.float32)                # reused bin storage
        self.level = _Level(np.array([n]), np.minimum.reduce(box, axis=1)[:, None],
                            np.zeros(1, bool), np.zeros(1, np.int64), np.zeros(1, np.int64))

    def run(self):
        """Returns (nodes, order, depth)."""
        records, base = [], 0
        while self.level is not None:
            lvl, self.level = self.level, None
            k = len(lvl.cnt)
            if len(lvl.active):
                self._split(lvl, base + k)                 # sets self.level
            count_kind = np.zeros(k, np.uint32)
            count_kind[lvl.leaf] = encode_leaf(lvl.cnt[lvl.leaf], self.kind)
            records.append(_node_records(lvl.bounds, lvl.first, count_kind))
            base += k
        return np.concatenate(records), self.order, len(records)

    def _split(self, lvl, next_base):
        """Make each active node of ``lvl`` a leaf or split it; children go to ``self.level``."""
        cnt, bounds = lvl.cnt[lvl.active], lvl.bounds[:, lvl.active]
        seg = _Segments.of(cnt)
        inv_s = _inverse_size(bounds)
        costs, n_lefts = _best_planes(*self._bins(seg), inv_s)
        area = _half_area(bounds) * inv_s.astype(np.float64) ** 2
        leaf, axis, n_left = self._choose(cnt, area, costs, n_lefts)
        self._mark_left(seg, axis, n_left)
        self._partition(lvl, seg, leaf, n_left, next_base)

    def _bins(self, seg):
        """Bin bounds (3, 6, bins, k) and counts (3, bins, k) of the active nodes."""
        k = len(seg.cnt)
        bins = min(self.top_bins if k <= TOP_LEVEL_NODES else self.bins,
                   max(4, len(seg.node) // (2 * k)))             # module docstring
        size = 3 * 6 * bins * k
        if len(self.grid) < size:
            self.grid = np.empty(2 * size, np.float32)
        dense = self.grid[:size].reshape(3, 6, bins, k)
        dense.fill(np.inf)
        count = np.zeros((3, bins, k), np.int32)
        for a, ax in enumerate(self.axes):
            _bin(ax, seg, bins, dense[a].reshape(6, -1), count[a].reshape(-1))
        return dense, count

    def _choose(self, cnt, area, costs, n_lefts):
        """Per active node: leaf?, split axis, primitives going left (all, for leaves)."""
        cols = np.arange(len(cnt))
        axis = np.argmin(costs, axis=0)
        best_cost, n_left = costs[axis, cols], n_lefts[axis, cols].astype(np.int64)
        split_cost = self.t_trav * area + self.t_isect * best_cost
        leaf = (cnt <= self.sah_leaf_max) & (self.t_isect * cnt * area <= split_cost)
        middle = ~leaf & ~np.isfinite(best_cost)
        axis[leaf | middle] = 0
        n_left[middle] = cnt[middle] // 2
        n_left[leaf] = cnt[leaf]
        return leaf, axis, n_left

    def _mark_left(self, seg, axis, n_left):
        """``self.flag[id]``: primitive goes to the left child (a prefix on the split axis)."""
        chosen = self.axes[0].ids.copy()
        for a in (1, 2):
            np.copyto(chosen, self.axes[a].ids, where=seg.per_element(axis == a))
        self.flag[chosen] = np.arange(len(chosen)) < seg.per_element(seg.start + n_left)

    def _partition(self, lvl, seg, leaf, n_left, next_base):
        """Reorder the per-axis arrays into the children's segments; emit new leaves.

        The reordered axis-0 array holds four blocks of segments, each in the
        active nodes' order: left children that stay active, right children
        that stay active, then the tail (copied to ``order``): new leaves
        (leaf nodes, left children with at most ``max_leaf`` primitives) and
        right children with at most ``max_leaf`` primitives.  The other axes
        keep only the first two blocks.  Stable, so segments stay sorted.
        """
        n_right, split = seg.cnt - n_left, ~leaf
        act_l = split & (n_left > self.max_leaf)
        act_r = split & (n_right > self.max_leaf)
        blocks = [(act_l, n_left), (act_r, n_right), (~act_l, n_left), (split & ~act_r, n_right)]
        sizes = np.concatenate([n[b] for b, n in blocks])
        block_base = _exclusive_cumsum([b.sum() for b, _ in blocks])
        seg_of = [base + np.cumsum(b) - 1 for base, (b, _) in zip(block_base, blocks)]
        m_new = int(sizes[:block_base[2]].sum())

        in_l, in_r = seg.per_element(act_l), seg.per_element(act_r)
        new_axes = []
        for a, ax in enumerate(self.axes):
            left = self.flag[ax.ids]
            parts = [left & in_l, left < in_r]            # to open left / right children
            if a == 0:                                    # to new leaves, left / right
                parts += [left > in_l, ~(left | in_r)]
            new_axes.append(ax.taken(np.concatenate([np.flatnonzero(p) for p in parts])))
        tail = new_axes[0].ids[m_new:]
        self.order[self.filled:self.filled + len(tail)] = tail
        slot = _exclusive_cumsum(sizes) + (self.filled - m_new)   # of tail segments
        self.filled += len(tail)
        seg_bounds = _segment_bounds(new_axes[0].box, sizes)
        self.axes = [ax.head(m_new) for ax in new_axes]

        # Children in output order: the two of the r-th split node at 2r, 2r + 1.
        split_out = np.zeros(len(lvl.cnt), bool)
        split_out[lvl.active[split]] = True
        rank = (np.cumsum(split_out) - 1)[lvl.active]
        lvl.leaf[lvl.active[leaf]] = True
        lvl.first[lvl.active[leaf]] = slot[seg_of[2][leaf]]
        lvl.first[lvl.active[split]] = next_base + 2 * rank[split]
        if not split.any():
            return
        child = np.empty(2 * int(split.sum()), np.int64)            # segment of each
        child[2 * rank[split]] = np.where(act_l, seg_of[0], seg_of[2])[split]
        child[2 * rank[split] + 1] = np.where(act_r, seg_of[1], seg_of[3])[split]
        child_cnt = sizes[child]
        small = child_cnt <= self.max_leaf
        self.level = _Level(child_cnt, seg_bounds[:, child], small,
                            np.where(small, slot[child], 0),
                            np.concatenate((2 * rank[act_l], 2 * rank[act_r] + 1)))
