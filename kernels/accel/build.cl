#line 2 "accel/build.cl"
/* The BVH build's data-parallel parts (texray.accel.cells), run on PoCL's CPU device:
 *
 * bvh_centroid_bounds, bvh_morton: the primitives' centroids (lo/4 + hi/4: finite for any
 *   float32 box), their bounds, and their 30-bit Morton codes; the host sorts the codes
 *   and cuts the order into cells.
 * bvh_build_cells: one work-item per cell, a binned-SAH tree over the cell's primitives,
 *   the same rule as the numpy builder (texray.accel.bvh: 16 bins on each axis over the
 *   node's centroid range, max(4, count / 2) for nodes of fewer than 32 primitives (the
 *   numpy builder decides that per level), plane cost nL A(L) + nR A(R) with A the half
 *   surface area, a leaf at <= max_leaf primitives, a split by count where no plane
 *   separates the centroids).
 * bvh_compact_cells: the cells' nodes, root excepted, copied into the final array behind
 *   the host's top tree, child indices renumbered.
 *
 * Cell c owns index[start_c .. end_c) (primitive ids, permuted in place into leaf order),
 * the boxes of those positions in rec (lo, hi as two float4 per position, copied there
 * in Morton order so that every pass reads them contiguously and the partition moves
 * them with their ids) and node slots [2 start_c, 2 end_c): its root at 2 start_c, the
 * two children of a node in adjacent slots; at most 2 count - 1 of them are used
 * (out_count). A leaf's `first` is a position in `index`; an interior node's the slot of
 * its left child.
 *
 * Host data, but checked all the same: a cell outside 0..n, a primitive id outside
 * 0..n, or a node count that would leave the cell's slots marks the cell failed
 * (out_count = 0) and the host falls back to the numpy builder. Depth: below
 * TX_BUILD_SAH_DEPTH levels every split is by count (halves), so no stack of
 * TX_BUILD_STACK entries can overflow for cells below 2^(TX_BUILD_STACK - TX_BUILD_SAH_DEPTH)
 * primitives; the host keeps cells far smaller.
 *
 * Boxes are float4 (w unused) with ternary min/max: PoCL's fmin/fmax are out-of-line
 * calls, and one vector select per bound does what three scalar ones did. The float
 * operations are the scalar ones lane by lane (products by 0.5 and 0.25 are exact, so
 * contraction cannot change them): the trees are the numpy builder's rule exactly. */

#define TX_BUILD_BINS 16
#define TX_BUILD_STACK 96
#define TX_BUILD_SAH_DEPTH 64
#define TX_BUILD_MORTON_BITS 10

#define BMIN4(a, b) ((a) < (b) ? (a) : (b))
#define BMAX4(a, b) ((a) > (b) ? (a) : (b))

typedef struct { float4 lo, hi; } BuildBox;

static inline BuildBox build_box_empty(void)
{
    BuildBox b;
    b.lo = (float4)(INFINITY);
    b.hi = (float4)(-INFINITY);
    return b;
}

static inline void build_box_grow(BuildBox* b, float4 lo, float4 hi)
{
    b->lo = BMIN4(lo, b->lo);
    b->hi = BMAX4(hi, b->hi);
}

/* Half surface area of the box in units of `inv` (1 / the node's largest half extent), so
 * any float32 coordinates give finite areas (as the numpy builder scales them). */
static inline float build_half_area(const BuildBox* b, float inv)
{
    float4 d = (0.5f * b->hi - 0.5f * b->lo) * inv;     /* halves keep the differences finite */
    return d.x < 0.0f ? 0.0f : d.x * d.y + d.y * d.z + d.z * d.x;
}

static inline float4 build_load3(__global const float* p, uint id)
{
    p += 3u * (size_t)id;
    return (float4)(p[0], p[1], p[2], 0.0f);
}

/* Work-item g of G: its share [g n / G, (g + 1) n / G) of the primitives. */
static inline void build_share(uint n, uint* b, uint* e)
{
    uint g = get_global_id(0), G = get_global_size(0);
    *b = (uint)(((ulong)n * g) / G);
    *e = (uint)(((ulong)n * (g + 1u)) / G);
}

/* Bounds of the centroids lo/4 + hi/4 over each work-item's share (the host takes the
 * min and max over the work-items): out[6 g .. 6 g + 6) = min xyz, max xyz. */
__kernel void bvh_centroid_bounds(__global const float* lo, __global const float* hi, uint n, __global float* out)
{
    uint b, e;
    build_share(n, &b, &e);
    float4 cmin = (float4)(INFINITY), cmax = (float4)(-INFINITY);
    for (uint k = b; k < e; ++k) {
        float4 c = 0.25f * build_load3(lo, k) + 0.25f * build_load3(hi, k);
        cmin = BMIN4(c, cmin);
        cmax = BMAX4(c, cmax);
    }
    __global float* o = out + 6u * get_global_id(0);
    o[0] = cmin.x; o[1] = cmin.y; o[2] = cmin.z;
    o[3] = cmax.x; o[4] = cmax.y; o[5] = cmax.z;
}

static inline uint build_spread(uint v)
{
    v = (v | v << 16) & 0x030000FFu;
    v = (v | v << 8) & 0x0300F00Fu;
    v = (v | v << 4) & 0x030C30C3u;
    v = (v | v << 2) & 0x09249249u;
    return v;
}

/* code[k]: the Morton code of primitive k's centroid, quantized as
 * min((int)((c - cmin) * scale), 2^10 - 1) per axis (scale = 2^10 / extent, from the host). */
__kernel void bvh_morton(__global const float* lo, __global const float* hi, uint n, float4 cmin, float4 scale,
                         __global uint* code)
{
    uint b, e;
    build_share(n, &b, &e);
    const int top = (1 << TX_BUILD_MORTON_BITS) - 1;
    for (uint k = b; k < e; ++k) {
        float4 c = 0.25f * build_load3(lo, k) + 0.25f * build_load3(hi, k);
        int4 q = convert_int4((c - cmin) * scale);    /* >= 0: cmin is the minimum; toward zero */
        q = q < (int4)(top) ? q : (int4)(top);
        code[k] = build_spread((uint)q.x) << 2 | build_spread((uint)q.y) << 1 | build_spread((uint)q.z);
    }
}

__kernel void bvh_build_cells(__global const float* box_lo, __global const float* box_hi, __global uint* index,
                              __global float4* rec, __global const uint* cell_start,
                              __global BVHNode* nodes, __global uint* out_count, __global uint* out_depth,
                              uint ncells, uint n, uint kind_bits, uint max_leaf)
{
    uint c = get_global_id(0);
    if (c >= ncells) return;
    uint start = cell_start[c], end = cell_start[c + 1u];
    out_count[c] = 0u;
    out_depth[c] = 0u;
    if (!(start < end && end <= n) || max_leaf < 1u) return;
    for (uint k = start; k < end; ++k)
        if (index[k] >= n) return;
    uint slot0 = 2u * start, slots = 2u * (end - start), used = 1u, maxdepth = 1u;
    /* the stack holds each pending node's range, depth and its box and centroid box, which
     * its parent's partition pass found: one pass over a node's primitives bins them, one
     * partitions them (and bounds both children) */
    uint st_slot[TX_BUILD_STACK], st_b[TX_BUILD_STACK], st_e[TX_BUILD_STACK], st_d[TX_BUILD_STACK];
    BuildBox st_nb[TX_BUILD_STACK], st_cb[TX_BUILD_STACK];
    int sp = 0;
    st_nb[0] = build_box_empty();
    st_cb[0] = build_box_empty();
    for (uint k = start; k < end; ++k) {
        float4 lo = build_load3(box_lo, index[k]), hi = build_load3(box_hi, index[k]);
        rec[2u * k] = lo;
        rec[2u * k + 1u] = hi;
        build_box_grow(&st_nb[0], lo, hi);
        float4 cc = 0.5f * lo + 0.5f * hi;
        build_box_grow(&st_cb[0], cc, cc);
    }
    st_slot[0] = 0u; st_b[0] = start; st_e[0] = end; st_d[0] = 1u; sp = 1;
    while (sp > 0) {
        --sp;
        uint slot = st_slot[sp], b = st_b[sp], e = st_e[sp], depth = st_d[sp];
        BuildBox nb = st_nb[sp], cb = st_cb[sp];
        maxdepth = depth > maxdepth ? depth : maxdepth;
        uint count = e - b;
        __global BVHNode* out = nodes + slot0 + slot;
        out->bmin[0] = nb.lo.x; out->bmin[1] = nb.lo.y; out->bmin[2] = nb.lo.z;
        out->bmax[0] = nb.hi.x; out->bmax[1] = nb.hi.y; out->bmax[2] = nb.hi.z;
        if (count <= max_leaf) {
            out->first = b;
            out->count_kind = kind_bits | count;
            continue;
        }
        /* binned SAH over the three axes, one pass; centroids as lo/2 + hi/2 (no overflow near
         * FLT_MAX), the same expression everywhere so that a primitive's bin is the same in
         * both passes. Fewer bins for small nodes, as the numpy builder does (max(4, count / 2)):
         * the sweeps' cost is per bin, and most nodes are small. */
        int nbins = (int)(count / 2u);
        nbins = nbins < 4 ? 4 : (nbins > TX_BUILD_BINS ? TX_BUILD_BINS : nbins);
        float4 half_ext = 0.5f * nb.hi - 0.5f * nb.lo, dc = cb.hi - cb.lo;      /* halves: finite */
        float ext = BMAX4(BMAX4(half_ext.x, half_ext.y), BMAX4(half_ext.z, 0.0f));
        float4 scale;
        scale.x = dc.x > 0.0f && dc.x <= FLT_MAX ? (float)nbins / dc.x : 0.0f;
        scale.y = dc.y > 0.0f && dc.y <= FLT_MAX ? (float)nbins / dc.y : 0.0f;
        scale.z = dc.z > 0.0f && dc.z <= FLT_MAX ? (float)nbins / dc.z : 0.0f;
        scale.w = 0.0f;
        float inv = ext > 0.0f ? 1.0f / ext : 1.0f;
        int best_axis = -1, best_split = 0;
        float best_cost = INFINITY;
        if (depth < TX_BUILD_SAH_DEPTH && (scale.x > 0.0f || scale.y > 0.0f || scale.z > 0.0f)) {
            uint bin_n[3][TX_BUILD_BINS];
            BuildBox bin_box[3][TX_BUILD_BINS];
            for (int a = 0; a < 3; ++a)
                for (int i = 0; i < nbins; ++i) { bin_n[a][i] = 0u; bin_box[a][i] = build_box_empty(); }
            int4 last = (int4)(nbins - 1);
            for (uint k = b; k < e; ++k) {
                float4 plo = rec[2u * k], phi = rec[2u * k + 1u];
                int4 bi = convert_int4(((0.5f * plo + 0.5f * phi) - cb.lo) * scale);
                bi = bi < (int4)(0) ? (int4)(0) : (bi > last ? last : bi);
                bin_n[0][bi.x] += 1u; build_box_grow(&bin_box[0][bi.x], plo, phi);
                bin_n[1][bi.y] += 1u; build_box_grow(&bin_box[1][bi.y], plo, phi);
                bin_n[2][bi.z] += 1u; build_box_grow(&bin_box[2][bi.z], plo, phi);
            }
            for (int a = 0; a < 3; ++a) {
                if (!(a == 0 ? scale.x > 0.0f : (a == 1 ? scale.y > 0.0f : scale.z > 0.0f))) continue;
                /* right-to-left: area and count of bins [i, B) */
                float right_a[TX_BUILD_BINS];
                uint right_n[TX_BUILD_BINS];
                BuildBox acc = build_box_empty();
                uint accn = 0u;
                for (int i = nbins - 1; i > 0; --i) {
                    build_box_grow(&acc, bin_box[a][i].lo, bin_box[a][i].hi);
                    accn += bin_n[a][i];
                    right_a[i] = build_half_area(&acc, inv);
                    right_n[i] = accn;
                }
                acc = build_box_empty();
                accn = 0u;
                for (int i = 1; i < nbins; ++i) {
                    build_box_grow(&acc, bin_box[a][i - 1].lo, bin_box[a][i - 1].hi);
                    accn += bin_n[a][i - 1];
                    if (accn == 0u || right_n[i] == 0u) continue;
                    float cost = (float)accn * build_half_area(&acc, inv) + (float)right_n[i] * right_a[i];
                    if (cost < best_cost) { best_cost = cost; best_axis = a; best_split = i; }
                }
            }
        }
        if (used + 2u > slots || sp + 2 > TX_BUILD_STACK) return;      /* cannot happen for a tree: failed */
        /* partition (primitives of bins < best_split first; without a plane, by count) and
         * bound both sides */
        BuildBox lb = build_box_empty(), lc = build_box_empty(), rb = build_box_empty(), rc = build_box_empty();
        uint mid = b + count / 2u;
        if (best_axis >= 0) {
            float lo = best_axis == 0 ? cb.lo.x : (best_axis == 1 ? cb.lo.y : cb.lo.z);
            float sc = best_axis == 0 ? scale.x : (best_axis == 1 ? scale.y : scale.z);
            uint i = b, j = e;
            while (i < j) {
                float4 plo = rec[2u * i], phi = rec[2u * i + 1u];
                float4 cc = 0.5f * plo + 0.5f * phi;
                int bi = (int)(((best_axis == 0 ? cc.x : (best_axis == 1 ? cc.y : cc.z)) - lo) * sc);
                bi = bi < 0 ? 0 : (bi > nbins - 1 ? nbins - 1 : bi);
                if (bi < best_split) {
                    build_box_grow(&lb, plo, phi);
                    build_box_grow(&lc, cc, cc);
                    ++i;
                } else {
                    build_box_grow(&rb, plo, phi);
                    build_box_grow(&rc, cc, cc);
                    --j;
                    uint t = index[i]; index[i] = index[j]; index[j] = t;
                    rec[2u * i] = rec[2u * j]; rec[2u * i + 1u] = rec[2u * j + 1u];
                    rec[2u * j] = plo; rec[2u * j + 1u] = phi;
                }
            }
            mid = i;
        }
        if (best_axis < 0 || mid == b || mid == e) {      /* by count (the second test cannot fail) */
            mid = b + count / 2u;
            lb = build_box_empty(); lc = build_box_empty(); rb = build_box_empty(); rc = build_box_empty();
            for (uint k = b; k < e; ++k) {
                float4 plo = rec[2u * k], phi = rec[2u * k + 1u];
                float4 cc = 0.5f * plo + 0.5f * phi;
                build_box_grow(k < mid ? &lb : &rb, plo, phi);
                build_box_grow(k < mid ? &lc : &rc, cc, cc);
            }
        }
        uint left = used;
        used += 2u;
        out->first = slot0 + left;
        out->count_kind = 0u;
        st_slot[sp] = left + 1u; st_b[sp] = mid; st_e[sp] = e; st_d[sp] = depth + 1u;
        st_nb[sp] = rb; st_cb[sp] = rc; ++sp;
        st_slot[sp] = left; st_b[sp] = b; st_e[sp] = mid; st_d[sp] = depth + 1u;
        st_nb[sp] = lb; st_cb[sp] = lc; ++sp;
    }
    out_count[c] = used;
    out_depth[c] = maxdepth;
}

/* Cell c's nodes but its root (slots 2 start_c + 1 .. 2 start_c + counts_c - 1) to
 * out[base_c ..] in slot order, an interior node's child slot s renumbered to
 * base_c + s - 2 start_c - 1 (leaves keep their positions in index). A node is two uint4:
 * (bmin, first), (bmax, count_kind). */
__kernel void bvh_compact_cells(__global const uint4* raw, __global const uint* cell_start,
                                __global const uint* counts, __global const uint* base, uint ncells,
                                __global uint4* out)
{
    uint c = get_global_id(0);
    if (c >= ncells) return;
    uint slot0 = 2u * cell_start[c], dst = base[c], m = counts[c];
    for (uint k = 1u; k < m; ++k) {
        uint4 a = raw[2u * (slot0 + k)], b = raw[2u * (slot0 + k) + 1u];
        if (b.w == 0u) a.w = dst + a.w - slot0 - 1u;
        out[2u * (dst + k - 1u)] = a;
        out[2u * (dst + k - 1u) + 1u] = b;
    }
}
