#line 2 "accel/build.cl"
/* The BVH build's sequential part, one work-item per cell (texray.accel.cells): a
 * binned-SAH tree over a cell's primitives, the same rule as the numpy builder
 * (texray.accel.bvh: 16 bins on each axis over the node's centroid range, max(4, count / 2)
 * for nodes of fewer than 32 primitives (the numpy builder decides that per level), plane cost
 * nL A(L) + nR A(R) with A the half surface area, a leaf at <= max_leaf primitives, a
 * split by count where no plane separates the centroids).
 *
 * Cell c owns index[start_c .. end_c) (primitive ids, permuted in place into leaf
 * order) and node slots [2 start_c, 2 end_c): its root at 2 start_c, the two children
 * of a node in adjacent slots; at most 2 count - 1 of them are used (out_count). A
 * leaf's `first` is a position in `index`; an interior node's the slot of its left
 * child. The host joins the cells under a top tree (texray.accel.cells).
 *
 * Host data, but checked all the same: a cell outside 0..n, a primitive id outside
 * 0..n, or a node count that would leave the cell's slots marks the cell failed
 * (out_count = 0) and the host falls back to the numpy builder. Depth: below
 * TX_BUILD_SAH_DEPTH levels every split is by count (halves), so no stack of
 * TX_BUILD_STACK entries can overflow for cells below 2^(TX_BUILD_STACK - TX_BUILD_SAH_DEPTH)
 * primitives; the host keeps cells far smaller. */

#define TX_BUILD_BINS 16
#define TX_BUILD_STACK 96
#define TX_BUILD_SAH_DEPTH 64

typedef struct { float lo[3], hi[3]; } BuildBox;

inline void build_box_empty(BuildBox* b)
{
    for (int a = 0; a < 3; ++a) { b->lo[a] = INFINITY; b->hi[a] = -INFINITY; }
}

inline void build_box_grow(BuildBox* b, const float* lo, const float* hi)
{
    for (int a = 0; a < 3; ++a) {
        b->lo[a] = lo[a] < b->lo[a] ? lo[a] : b->lo[a];
        b->hi[a] = hi[a] > b->hi[a] ? hi[a] : b->hi[a];
    }
}

inline void build_box_merge(BuildBox* b, const BuildBox* o)
{
    build_box_grow(b, o->lo, o->hi);
}

/* Half surface area of the box in units of `inv` (1 / the node's largest extent), so any
 * float32 coordinates give finite areas (as the numpy builder scales them). */
inline float build_half_area(const BuildBox* b, float inv)
{
    /* inv = 1 / the node's largest half extent: halves keep the differences finite */
    float dx = (0.5f * b->hi[0] - 0.5f * b->lo[0]) * inv, dy = (0.5f * b->hi[1] - 0.5f * b->lo[1]) * inv;
    float dz = (0.5f * b->hi[2] - 0.5f * b->lo[2]) * inv;
    return dx < 0.0f ? 0.0f : dx * dy + dy * dz + dz * dx;
}

inline void build_load(__global const float* box, uint id, float* lo, float* hi)
{
    __global const float* p = box + 6u * (size_t)id;
    lo[0] = p[0]; lo[1] = p[1]; lo[2] = p[2];
    hi[0] = p[3]; hi[1] = p[4]; hi[2] = p[5];
}

__kernel void bvh_build_cells(__global const float* box, __global uint* index, __global const uint* cell_start,
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
    build_box_empty(&st_nb[0]);
    build_box_empty(&st_cb[0]);
    for (uint k = start; k < end; ++k) {
        float lo[3], hi[3], cc[3];
        build_load(box, index[k], lo, hi);
        build_box_grow(&st_nb[0], lo, hi);
        cc[0] = 0.5f * lo[0] + 0.5f * hi[0]; cc[1] = 0.5f * lo[1] + 0.5f * hi[1]; cc[2] = 0.5f * lo[2] + 0.5f * hi[2];
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
        for (int a = 0; a < 3; ++a) { out->bmin[a] = nb.lo[a]; out->bmax[a] = nb.hi[a]; }
        if (count <= max_leaf) {
            out->first = b;
            out->count_kind = kind_bits | count;
            continue;
        }
        /* binned SAH over the three axes, one pass; centroids as lo/2 + hi/2 (no overflow near FLT_MAX), the
         * same expression everywhere so that a primitive's bin is the same in both passes */
        /* fewer bins for small nodes, as the numpy builder does (max(4, count / 2)): the
         * sweeps' cost is per bin, and most nodes are small */
        int nbins = (int)(count / 2u);
        nbins = nbins < 4 ? 4 : (nbins > TX_BUILD_BINS ? TX_BUILD_BINS : nbins);
        float ext = 0.0f, scale[3];
        for (int a = 0; a < 3; ++a) {
            float d = 0.5f * nb.hi[a] - 0.5f * nb.lo[a], dc = cb.hi[a] - cb.lo[a];   /* halves: finite */
            ext = d > ext ? d : ext;
            scale[a] = dc > 0.0f && dc <= FLT_MAX ? (float)nbins / dc : 0.0f;
        }
        float inv = ext > 0.0f ? 1.0f / ext : 1.0f;
        int best_axis = -1, best_split = 0;
        float best_cost = INFINITY;
        if (depth < TX_BUILD_SAH_DEPTH && (scale[0] > 0.0f || scale[1] > 0.0f || scale[2] > 0.0f)) {
            uint bin_n[3][TX_BUILD_BINS];
            BuildBox bin_box[3][TX_BUILD_BINS];
            for (int a = 0; a < 3; ++a)
                for (int i = 0; i < nbins; ++i) { bin_n[a][i] = 0u; build_box_empty(&bin_box[a][i]); }
            for (uint k = b; k < e; ++k) {
                float plo[3], phi[3];
                build_load(box, index[k], plo, phi);
                for (int a = 0; a < 3; ++a) {
                    int i = (int)(((0.5f * plo[a] + 0.5f * phi[a]) - cb.lo[a]) * scale[a]);
                    i = i < 0 ? 0 : (i > nbins - 1 ? nbins - 1 : i);
                    bin_n[a][i] += 1u;
                    build_box_grow(&bin_box[a][i], plo, phi);
                }
            }
            for (int a = 0; a < 3; ++a) {
                if (!(scale[a] > 0.0f)) continue;
                /* right-to-left: area and count of bins [i, B) */
                float right_a[TX_BUILD_BINS];
                uint right_n[TX_BUILD_BINS];
                BuildBox acc;
                build_box_empty(&acc);
                uint accn = 0u;
                for (int i = nbins - 1; i > 0; --i) {
                    build_box_merge(&acc, &bin_box[a][i]);
                    accn += bin_n[a][i];
                    right_a[i] = build_half_area(&acc, inv);
                    right_n[i] = accn;
                }
                build_box_empty(&acc);
                accn = 0u;
                for (int i = 1; i < nbins; ++i) {
                    build_box_merge(&acc, &bin_box[a][i - 1]);
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
        BuildBox lb, lc, rb, rc;
        build_box_empty(&lb); build_box_empty(&lc); build_box_empty(&rb); build_box_empty(&rc);
        uint mid = b + count / 2u;
        if (best_axis >= 0) {
            float lo = cb.lo[best_axis], sc = scale[best_axis];
            uint i = b, j = e;
            while (i < j) {
                float plo[3], phi[3], cc[3];
                build_load(box, index[i], plo, phi);
                cc[0] = 0.5f * plo[0] + 0.5f * phi[0]; cc[1] = 0.5f * plo[1] + 0.5f * phi[1]; cc[2] = 0.5f * plo[2] + 0.5f * phi[2];
                int bi = (int)((cc[best_axis] - lo) * sc);
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
                }
            }
            mid = i;
        }
        if (best_axis < 0 || mid == b || mid == e) {      /* by count (the second test cannot fail) */
            mid = b + count / 2u;
            build_box_empty(&lb); build_box_empty(&lc); build_box_empty(&rb); build_box_empty(&rc);
            for (uint k = b; k < e; ++k) {
                float plo[3], phi[3], cc[3];
                build_load(box, index[k], plo, phi);
                cc[0] = 0.5f * plo[0] + 0.5f * phi[0]; cc[1] = 0.5f * plo[1] + 0.5f * phi[1]; cc[2] = 0.5f * plo[2] + 0.5f * phi[2];
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
