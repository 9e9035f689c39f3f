#line 2 "bvh.h"
/* BVH traversal: closest hit ordered by child distance, and any hit.
 *
 * Node layout (texray.layout.BVH_NODE) read as two float4: (bmin, first) and
 * (bmax, count_kind). Interior nodes have count_kind == 0 and their children
 * at first and first + 1; leaves hold count_kind & LEAF_COUNT_MASK triangles
 * from `first` in the leaf-ordered triangle array. */
#ifndef TEXRAY_BVH_H
#define TEXRAY_BVH_H

#ifndef TX_STACK_SIZE
#define TX_STACK_SIZE 64
#endif

/* The scene's geometry as kernel parameters and as arguments; arrays of kinds
 * the scene does not use are NULL and their code is not compiled. */
#define TX_GEOM_PARAMS __global const float4* nodes, uint nnodes, __global const TriVerts* tris, \
    __global const Sphere* spheres, __global const Cylinder* cylinders, __global const QuadVerts* quads, \
    __global const Displaced* displaced, __global const ushort* heights
#define TX_GEOM_ARGS nodes, nnodes, tris, spheres, cylinders, quads, displaced, heights

/* Slab test for a ray with a zero direction component: such an axis bounds
 * nothing while the origin lies in [lo, hi] (boundaries included) and
 * excludes everything otherwise. The fast test cannot say so: the zero is
 * replaced by safe_inverse's huge finite value, and (lo - org) * inv is 0
 * rather than -inf when the origin lies exactly on a box face. */
inline float box_entry_parallel(float4 lo, float4 hi, float3 org, float3 inv_d, float tmin, float tmax)
{
    float tn = tmin, tf = tmax;
    float l[3] = { lo.x, lo.y, lo.z }, h[3] = { hi.x, hi.y, hi.z };
    float o[3] = { org.x, org.y, org.z }, inv[3] = { inv_d.x, inv_d.y, inv_d.z };
    for (int k = 0; k < 3; ++k) {
        if (fabs(inv[k]) >= TX_PARALLEL_INV) {
            if (o[k] < l[k] || o[k] > h[k]) return INFINITY;
            continue;
        }
        float t0 = (l[k] - o[k]) * inv[k], t1 = (h[k] - o[k]) * inv[k];
        tn = TX_MAX(tn, TX_MIN(t0, t1));
        tf = TX_MIN(tf, TX_MAX(t0, t1) * (1.0f + 2.0f * gamma_n(3.0f)));
    }
    return tn <= tf ? tn : INFINITY;
}

/* Slab test. The far distance is scaled by 1 + 2 gamma(3), which makes the
 * test conservative under float rounding (Ize 2013, "Robust BVH Ray
 * Traversal"); inv_d comes from safe_inverse so no NaN can arise from finite
 * bounds. `parallel` (the ray has a zero direction component) sends misses to
 * the exact test above, so the common case pays one branch. Returns the entry
 * distance, or INFINITY for a miss. */
inline float box_entry(float4 lo, float4 hi, float3 org, float3 inv_d, float tmin, float tmax, int parallel)
{
    float tx0 = (lo.x - org.x) * inv_d.x, tx1 = (hi.x - org.x) * inv_d.x;
    float ty0 = (lo.y - org.y) * inv_d.y, ty1 = (hi.y - org.y) * inv_d.y;
    float tz0 = (lo.z - org.z) * inv_d.z, tz1 = (hi.z - org.z) * inv_d.z;
    float nx = TX_MIN(tx0, tx1), fx = TX_MAX(tx0, tx1);
    float ny = TX_MIN(ty0, ty1), fy = TX_MAX(ty0, ty1);
    float nz = TX_MIN(tz0, tz1), fz = TX_MAX(tz0, tz1);
    float tn = TX_MAX(TX_MAX(nx, ny), TX_MAX(nz, tmin));
    float tf = TX_MIN(TX_MIN(fx, fy), fz) * (1.0f + 2.0f * gamma_n(3.0f));
    tf = TX_MIN(tf, tmax);
    if (tn <= tf) return tn;
    return parallel ? box_entry_parallel(lo, hi, org, inv_d, tmin, tmax) : INFINITY;
}

typedef struct { float t, b1, b2; uint prim; } HitRec;

/* Closest hit of the ray (org, dir) with t in (tmin, tmax). prim = TX_MISS on a miss. */
inline HitRec bvh_closest(TX_GEOM_PARAMS, float3 org, float3 dir, float tmin, float tmax)
{
    HitRec h = { tmax, 0.0f, 0.0f, TX_MISS };
    if (nnodes == 0u) return h;
    WoopRay w = woop_setup(org, dir);
    float3 inv_d = (float3)(safe_inverse(dir.x), safe_inverse(dir.y), safe_inverse(dir.z));
    int par = fabs(inv_d.x) >= TX_PARALLEL_INV || fabs(inv_d.y) >= TX_PARALLEL_INV || fabs(inv_d.z) >= TX_PARALLEL_INV;
    uint stack[TX_STACK_SIZE];
    float stack_t[TX_STACK_SIZE];
    int sp = 0;
    uint node = 0u;
    if (box_entry(nodes[0], nodes[1], org, inv_d, tmin, tmax, par) == INFINITY) return h;
    for (;;) {
        float4 a = nodes[2u * node], b = nodes[2u * node + 1u];
        uint ck = as_uint(b.w), first = as_uint(a.w);
        if (ck != 0u) {
            uint end = first + (ck & LEAF_COUNT_MASK), kind = ck >> LEAF_COUNT_BITS;
            if (kind == PRIM_TRIANGLE) {
                for (uint i = first; i < end; ++i) {
                    __global const TriVerts* tr = tris + i;
                    float t, b1, b2;
                    if (triangle_intersect(&w, tri_p0(tr), tri_p1(tr), tri_p2(tr), tmin, h.t, &t, &b1, &b2)) {
                        h.t = t; h.b1 = b1; h.b2 = b2; h.prim = i;
                    }
                }
            }
#if TX_SPHERES
            else if (kind == PRIM_SPHERE) {
                for (uint i = first; i < end; ++i) {
                    float t;
                    if (sphere_intersect(spheres + i, org, dir, tmin, h.t, &t)) {
                        h.t = t; h.prim = (PRIM_SPHERE << HIT_KIND_SHIFT) | i;
                    }
                }
            }
#endif
#if TX_CYLINDERS
            else if (kind == PRIM_CYLINDER) {
                for (uint i = first; i < end; ++i) {
                    float t;
                    if (cylinder_intersect(cylinders + i, org, dir, tmin, h.t, &t)) {
                        h.t = t; h.prim = (PRIM_CYLINDER << HIT_KIND_SHIFT) | i;
                    }
                }
            }
#endif
#if TX_QUADS
            else if (kind == PRIM_QUAD) {
                for (uint i = first; i < end; ++i) {
                    float t;
                    float2 uv;
                    if (quad_intersect(quads + i, org, dir, tmin, h.t, &t, &uv)) {
                        h.t = t; h.b1 = uv.x; h.b2 = uv.y; h.prim = (PRIM_QUAD << HIT_KIND_SHIFT) | i;
                    }
                }
            }
#endif
#if TX_DISPLACEMENT
            else if (kind == PRIM_DISPLACED) {
                for (uint i = first; i < end; ++i) {
                    float t;
                    float2 uv;
                    if (displaced_intersect(displaced + i, heights, org, dir, tmin, h.t, 0, &t, &uv)) {
                        h.t = t; h.b1 = uv.x; h.b2 = uv.y; h.prim = (PRIM_DISPLACED << HIT_KIND_SHIFT) | i;
                    }
                }
            }
#endif
        } else {
            float tl = box_entry(nodes[2u * first], nodes[2u * first + 1u], org, inv_d, tmin, h.t, par);
            float tr = box_entry(nodes[2u * first + 2u], nodes[2u * first + 3u], org, inv_d, tmin, h.t, par);
            if (tl != INFINITY && tr != INFINITY) {
                uint nearc = tl <= tr ? first : first + 1u;
                stack[sp] = nearc == first ? first + 1u : first;
                stack_t[sp] = TX_MAX(tl, tr);
                ++sp;
                node = nearc;
                continue;
            }
            if (tl != INFINITY) { node = first; continue; }
            if (tr != INFINITY) { node = first + 1u; continue; }
        }
        /* Pop the nearest pending node that can still hold a closer hit. */
        for (;;) {
            if (sp == 0) return h;
            --sp;
            if (stack_t[sp] <= h.t) break;
        }
        node = stack[sp];
    }
}

/* 1 if anything is hit with t in (tmin, tmax). */
inline int bvh_any(TX_GEOM_PARAMS, float3 org, float3 dir, float tmin, float tmax)
{
    if (nnodes == 0u) return 0;
    WoopRay w = woop_setup(org, dir);
    float3 inv_d = (float3)(safe_inverse(dir.x), safe_inverse(dir.y), safe_inverse(dir.z));
    int par = fabs(inv_d.x) >= TX_PARALLEL_INV || fabs(inv_d.y) >= TX_PARALLEL_INV || fabs(inv_d.z) >= TX_PARALLEL_INV;
    uint stack[TX_STACK_SIZE];
    int sp = 0;
    uint node = 0u;
    if (box_entry(nodes[0], nodes[1], org, inv_d, tmin, tmax, par) == INFINITY) return 0;
    for (;;) {
        float4 a = nodes[2u * node], b = nodes[2u * node + 1u];
        uint ck = as_uint(b.w), first = as_uint(a.w);
        if (ck != 0u) {
            uint end = first + (ck & LEAF_COUNT_MASK), kind = ck >> LEAF_COUNT_BITS;
            float t, b1, b2;
            if (kind == PRIM_TRIANGLE) {
                for (uint i = first; i < end; ++i) {
                    __global const TriVerts* tr = tris + i;
                    if (triangle_intersect(&w, tri_p0(tr), tri_p1(tr), tri_p2(tr), tmin, tmax, &t, &b1, &b2))
                        return 1;
                }
            }
#if TX_SPHERES
            else if (kind == PRIM_SPHERE) {
                for (uint i = first; i < end; ++i)
                    if (sphere_intersect(spheres + i, org, dir, tmin, tmax, &t)) return 1;
            }
#endif
#if TX_CYLINDERS
            else if (kind == PRIM_CYLINDER) {
                for (uint i = first; i < end; ++i)
                    if (cylinder_intersect(cylinders + i, org, dir, tmin, tmax, &t)) return 1;
            }
#endif
#if TX_QUADS
            else if (kind == PRIM_QUAD) {
                float2 uv;
                for (uint i = first; i < end; ++i)
                    if (quad_intersect(quads + i, org, dir, tmin, tmax, &t, &uv)) return 1;
            }
#endif
#if TX_DISPLACEMENT
            else if (kind == PRIM_DISPLACED) {
                float2 uv;
                for (uint i = first; i < end; ++i)
                    if (displaced_intersect(displaced + i, heights, org, dir, tmin, tmax, 1, &t, &uv)) return 1;
            }
#endif
        } else {
            int hl = box_entry(nodes[2u * first], nodes[2u * first + 1u], org, inv_d, tmin, tmax, par) != INFINITY;
            int hr = box_entry(nodes[2u * first + 2u], nodes[2u * first + 3u], org, inv_d, tmin, tmax, par) != INFINITY;
            if (hl && hr) { stack[sp++] = first + 1u; node = first; continue; }
            if (hl) { node = first; continue; }
            if (hr) { node = first + 1u; continue; }
        }
        if (sp == 0) return 0;
        node = stack[--sp];
    }
}

#endif
