#line 2 "accel/bvh.h"
/* BVH traversal of the 4-wide tree: closest hit ordered by child distance,
 * and any hit.
 *
 * Node layout (texray.layout.BVH4_NODE, built by texray.wide) read as eight
 * float4: lo_x, hi_x, lo_y, hi_y, lo_z, hi_z of the four children, then their
 * child indices and count_kind as uint4. A lane with count_kind == 0 is an
 * interior child (wide node `child`); otherwise a leaf of
 * count_kind & LEAF_COUNT_MASK primitives of kind count_kind >> LEAF_COUNT_BITS
 * from `child` in that kind's leaf-ordered array. The four slab tests are
 * float4 arithmetic: SIMD on a CPU driver, one 128-byte read on a GPU. */
#ifndef TEXRAY_BVH_H
#define TEXRAY_BVH_H
#include "core/slab.h"
#include "geometry/dispatch.h"

#ifndef TX_STACK_SIZE
#define TX_STACK_SIZE 64
#endif

/* Entry distance of the ray into the box [lo, hi] (INFINITY for a miss) by the exact
 * slab test (core/slab.h), for rays with a zero direction component: such an axis
 * bounds nothing while the origin lies in [lo, hi] (boundaries included) and excludes
 * everything otherwise. The fast test (box4_entry) cannot say so: the zero is
 * replaced by safe_inverse's huge finite value, and (lo - org) * inv is 0 rather than
 * -inf when the origin lies exactly on a box face. The far distance is scaled by
 * 1 + 2 gamma(3), which makes the test conservative under float rounding (Ize 2013,
 * "Robust BVH Ray Traversal"). */
static inline float box_entry_parallel(float4 lo, float4 hi, float3 org, float3 dir, float tmin, float tmax)
{
    float tn = tmin, tf = tmax, grow = 1.0f + 2.0f * gamma_n(3.0f);
    if (!(slab_clip(org.x, dir.x, lo.x, hi.x, grow, &tn, &tf) && slab_clip(org.y, dir.y, lo.y, hi.y, grow, &tn, &tf)
          && slab_clip(org.z, dir.z, lo.z, hi.z, grow, &tn, &tf)))
        return INFINITY;
    return tn <= tf && tf > 0.0f ? tn : INFINITY;
}

/* Entry distances of the ray into the four child boxes of a wide node, INFINITY
 * for a miss. The near and far planes are chosen per axis by the direction's
 * sign (neg), so the empty box (lo = +inf, hi = -inf) of an unused lane gives
 * near = +inf and always misses; the far distance is scaled by 1 + 2 gamma(3)
 * (Ize 2013). For a ray that passes ray_valid (core/common.h) -- the callers check --
 * org is finite and inv_d (safe_inverse) finite and nonzero, so no distance is
 * NaN, not even for the empty boxes; the lane test tn <= tf is false for NaN
 * anyway. A ray with a zero direction component (par) re-tests its missed
 * lanes exactly, so the common case pays one branch.
 * A box the ray leaves at t <= 0 is a miss too, even where tn <= tf: with tmin >= 0 that
 * is tn = tf = 0, an origin exactly on the box's far face or in a flat box, and every
 * surface point in the box lies at an exact t <= 0 (the box's exit bounds it): a hit there
 * could only be the rounding of the ray's own origin (which the triangle test's error bound
 * delta_t already rejects), never one at t > 0. A shadow ray from
 * a ground plane started in the plane's flat leaf box and tested its triangles; it no longer
 * does (tools/ab.py: textured meshes 0.94). For tmin > 0 such a box already fails tn <= tf. */
static inline float4 box4_entry(__global const float4* nd, float3 org, float3 dir, float3 inv_d, int nx, int ny, int nz,
                                float tmin, float tmax, int par)
{
    float4 lox = nd[0], hix = nd[1], loy = nd[2], hiy = nd[3], loz = nd[4], hiz = nd[5];
    float4 tnx = ((nx ? hix : lox) - org.x) * inv_d.x, tfx = ((nx ? lox : hix) - org.x) * inv_d.x;
    float4 tny = ((ny ? hiy : loy) - org.y) * inv_d.y, tfy = ((ny ? loy : hiy) - org.y) * inv_d.y;
    float4 tnz = ((nz ? hiz : loz) - org.z) * inv_d.z, tfz = ((nz ? loz : hiz) - org.z) * inv_d.z;
    float4 tn = TX_MAX(TX_MAX(tnx, tny), TX_MAX(tnz, (float4)(tmin)));
    float4 tf = TX_MIN(TX_MIN(tfx, tfy), tfz) * (1.0f + 2.0f * gamma_n(3.0f));
    tf = TX_MIN(tf, (float4)(tmax));
    float4 t = ((tn <= tf) & (tf > 0.0f)) ? tn : (float4)(INFINITY);
    if (par) {
        float l[4] = { t.x, t.y, t.z, t.w };
        float ax[4] = { lox.x, lox.y, lox.z, lox.w }, ay[4] = { loy.x, loy.y, loy.z, loy.w };
        float az[4] = { loz.x, loz.y, loz.z, loz.w }, bx[4] = { hix.x, hix.y, hix.z, hix.w };
        float by[4] = { hiy.x, hiy.y, hiy.z, hiy.w }, bz[4] = { hiz.x, hiz.y, hiz.z, hiz.w };
        for (int k = 0; k < 4; ++k)
            if (l[k] == INFINITY)
                l[k] = box_entry_parallel((float4)(ax[k], ay[k], az[k], 0.0f), (float4)(bx[k], by[k], bz[k], 0.0f),
                                          org, dir, tmin, tmax);
        t = (float4)(l[0], l[1], l[2], l[3]);
    }
    return t;
}

#if TX_SCALAR_TRAVERSAL                  /* core/common.h: a packet program may have none */
/* Compare-exchange of two (distance, child, count_kind) entries by distance. */
#define TX_SORT2(i, j) do { if (t[j] < t[i]) { float tt_ = t[i]; t[i] = t[j]; t[j] = tt_; \
    uint c_ = c[i]; c[i] = c[j]; c[j] = c_; c_ = k[i]; k[i] = k[j]; k[j] = c_; } } while (0)

/* Closest hit of the ray (org, dir) with t in (tmin, tmax). prim = TX_MISS on a miss,
 * and for any ray that fails ray_valid (core/common.h: NaN or infinite components, a zero
 * direction, a NaN or empty interval), before any node is read.
 * The stack holds lanes (child, count_kind) with their entry distance; a lane
 * farther than the closest hit so far is skipped when popped. At most three
 * lanes are pushed per wide level: TX_STACK_SIZE >= 3 x the tree's depth + 1
 * (texray.wide.stack_depth, features.stack_size_for), so a push never finds the
 * stack full in a tree the host built; should one (a tree deeper than the program
 * was compiled for), the lane is dropped -- that subtree is not searched, which can
 * miss a hit but never writes past the stack. Bound: a lane is only entered through
 * its parent's entered box, so in a tree every wide node is entered at most once per
 * ray and the loop runs at most 4 x nnodes + 1 times (nodes and leaf lanes). The
 * kernel does not rely on that: it enters at most nnodes wide nodes, each with an
 * index below nnodes, and returns what it found so far otherwise -- an out-of-range
 * child or a cycle in a corrupt node array ends the traversal instead of reading past
 * the array or running forever (two integer tests per node, within the timing noise). */
TX_OUT_OF_LINE_SCALAR HitRec bvh_closest_v(TX_GEOM_PARAMS, float4 org4, float4 dir4, float tmin, float tmax)
{
    float3 org = org4.xyz, dir = dir4.xyz;     /* float4, not float3: common.h */
    HitRec h = { tmax, 0.0f, 0.0f, TX_MISS };
    if (nnodes == 0u || !ray_valid(org, dir, tmin, tmax)) return h;
    WoopRay w = leaf_ray(org, dir);
    float3 inv_d = (float3)(safe_inverse(dir.x), safe_inverse(dir.y), safe_inverse(dir.z));
    int par = fabs(inv_d.x) >= TX_PARALLEL_INV || fabs(inv_d.y) >= TX_PARALLEL_INV || fabs(inv_d.z) >= TX_PARALLEL_INV;
    int nx = inv_d.x < 0.0f, ny = inv_d.y < 0.0f, nz = inv_d.z < 0.0f;
    uint stack[TX_STACK_SIZE], stack_ck[TX_STACK_SIZE];
    float stack_t[TX_STACK_SIZE];
    int sp = 0;
    uint node = 0u, ck = 0u, budget = nnodes;   /* wide nodes left to enter: see above */
    for (;;) {
        if (ck != 0u) {
            leaf_hit(TX_GEOM_ARGS, &w, org, dir, tmin, node, ck, 0, 0, &h);
        } else {
            if (node >= nnodes || budget-- == 0u) return h;   /* only in a broken tree: see above */
            __global const float4* nd = nodes + 8u * node;
            float4 e = box4_entry(nd, org, dir, inv_d, nx, ny, nz, tmin, h.t, par);
            uint4 ch = as_uint4(nd[6]), kk = as_uint4(nd[7]);
            float t[4] = { e.x, e.y, e.z, e.w };
            uint c[4] = { ch.x, ch.y, ch.z, ch.w }, k[4] = { kk.x, kk.y, kk.z, kk.w };
            /* Sort the four lanes by entry distance (misses, at INFINITY, last). A lane
             * counts as entered only when t < INFINITY, which NaN fails too. */
            TX_SORT2(0, 1); TX_SORT2(2, 3); TX_SORT2(0, 2); TX_SORT2(1, 3); TX_SORT2(1, 2);
            if (t[0] < INFINITY) {
                for (int i = 3; i > 0; --i) {
                    if (t[i] < INFINITY && sp < TX_STACK_SIZE) {   /* full: dropped (above) */
                        stack[sp] = c[i]; stack_ck[sp] = k[i]; stack_t[sp] = t[i]; ++sp;
                    }
                }
                node = c[0]; ck = k[0];
                continue;
            }
        }
        /* Pop the nearest pending lane that can still hold a closer hit. */
        for (;;) {
            if (sp == 0) return h;
            --sp;
            if (stack_t[sp] <= h.t) break;
        }
        node = stack[sp]; ck = stack_ck[sp];
    }
}
#undef TX_SORT2

static inline HitRec bvh_closest(TX_GEOM_PARAMS, float3 org, float3 dir, float tmin, float tmax)
{
    return bvh_closest_v(TX_GEOM_ARGS, (float4)(org, 0.0f), (float4)(dir, 0.0f), tmin, tmax);
}

/* 1 if anything is hit with t in (tmin, tmax). Leaf lanes are tested as soon
 * as their box is entered, interior lanes pushed. 0 for a ray that fails ray_valid
 * (core/common.h), before any node is read. Up to four lanes are pushed per node and one
 * popped at once: TX_STACK_SIZE >= 3 x depth + 1 holds them; a push that finds the
 * stack full is dropped (as in bvh_closest: only a tree deeper than the program's
 * bound, where it can miss a hit). Bound: every wide node entered at most once, at
 * most nnodes iterations, enforced as in bvh_closest (0 for a corrupt tree). */
TX_OUT_OF_LINE_SCALAR int bvh_any_v(TX_GEOM_PARAMS, float4 org4, float4 dir4, float tmin, float tmax)
{
    float3 org = org4.xyz, dir = dir4.xyz;     /* float4, not float3: common.h */
    if (nnodes == 0u || !ray_valid(org, dir, tmin, tmax)) return 0;
    HitRec h = { tmax, 0.0f, 0.0f, TX_MISS };
    WoopRay w = leaf_ray(org, dir);
    float3 inv_d = (float3)(safe_inverse(dir.x), safe_inverse(dir.y), safe_inverse(dir.z));
    int par = fabs(inv_d.x) >= TX_PARALLEL_INV || fabs(inv_d.y) >= TX_PARALLEL_INV || fabs(inv_d.z) >= TX_PARALLEL_INV;
    int nx = inv_d.x < 0.0f, ny = inv_d.y < 0.0f, nz = inv_d.z < 0.0f;
    uint stack[TX_STACK_SIZE];
    int sp = 0;
    uint node = 0u, budget = nnodes;            /* wide nodes left to enter: see above */
    for (;;) {
        if (node >= nnodes || budget-- == 0u) return 0;       /* only in a broken tree: see above */
        __global const float4* nd = nodes + 8u * node;
        float4 e = box4_entry(nd, org, dir, inv_d, nx, ny, nz, tmin, tmax, par);
        uint4 ch = as_uint4(nd[6]), kk = as_uint4(nd[7]);
        float t[4] = { e.x, e.y, e.z, e.w };
        uint c[4] = { ch.x, ch.y, ch.z, ch.w }, k[4] = { kk.x, kk.y, kk.z, kk.w };
        for (int i = 0; i < 4; ++i) {
            if (!(t[i] < INFINITY)) continue;          /* missed (NaN fails too) */
            if (k[i] != 0u) {
                if (leaf_hit(TX_GEOM_ARGS, &w, org, dir, tmin, c[i], k[i], 1, 0, &h)) return 1;
            } else if (sp < TX_STACK_SIZE) {           /* full: dropped (above) */
                stack[sp++] = c[i];
            }
        }
        if (sp == 0) return 0;
        node = stack[--sp];
    }
}

static inline int bvh_any(TX_GEOM_PARAMS, float3 org, float3 dir, float tmin, float tmax)
{
    return bvh_any_v(TX_GEOM_ARGS, (float4)(org, 0.0f), (float4)(dir, 0.0f), tmin, tmax);
}
#endif

#if TX_INSTANCES
#include "accel/instance.h"
#endif

#endif
