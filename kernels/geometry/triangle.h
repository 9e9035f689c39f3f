#line 2 "geometry/triangle.h"
/* Watertight ray/triangle intersection (Woop, Benthin, Wald 2013, "Watertight
 * Ray/Triangle Intersection", JCGT 2(1)).
 *
 * The ray is sheared so that it runs along +z from the origin; the 2-D edge
 * functions U, V, W of the sheared vertices then decide the hit. A vertex's
 * sheared coordinates depend only on the ray and the vertex, and every edge
 * function is a difference of products of them, so two triangles sharing an
 * edge compute that edge function from the same numbers: a ray never slips
 * through a shared edge or vertex. This needs FP_CONTRACT OFF (an FMA would
 * round one product and not the other), and a float64 recomputation when an
 * edge function rounds to exactly zero (when the device has fp64). */
#ifndef TEXRAY_TRIANGLE_H
#define TEXRAY_TRIANGLE_H
#include "geometry/hit.h"
#include "core/frame.h"
#pragma OPENCL FP_CONTRACT OFF
#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

typedef struct {
    float3 org;
    float3 rx, ry, rz;   /* shear rows: (x', y', z') = (rx.q, ry.q, rz.q) for q = vertex - org */
} WoopRay;

/* The shear's axes: kz the direction's largest component, kx and ky the others in the
 * order that keeps the winding. */
static inline void woop_axes(float3 dir, int* kx, int* ky, int* kz)
{
    float3 ad = abs3(dir);
    *kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
    *kx = *kz == 2 ? 0 : *kz + 1;
    *ky = *kx == 2 ? 0 : *kx + 1;
    if (comp3(dir, *kz) < 0.0f) { int t = *kx; *kx = *ky; *ky = t; }   /* keep the winding */
}

static inline WoopRay woop_setup(float3 org, float3 dir)
{
    int kx, ky, kz;
    woop_axes(dir, &kx, &ky, &kz);
    float dz = comp3(dir, kz);
    float sx = comp3(dir, kx) / dz, sy = comp3(dir, ky) / dz, sz = 1.0f / dz;
    WoopRay w;
    w.org = org;
    w.rx = unit3(kx) - sx * unit3(kz);
    w.ry = unit3(ky) - sy * unit3(kz);
    w.rz = sz * unit3(kz);
    return w;
}

/* The watertight test's arithmetic, written once for two shapes of vector code:
 * triangle_intersect4 (one ray, a float4 lane per triangle) and, with TX_PACKET,
 * triangle_any_packet (one triangle, a lane per ray of a packet: accel/packet.h). Each
 * macro is plain arithmetic on its operands, scalar or vector alike, so that a lane
 * computes the same floats in both: a packet's any-hit answers are the scalar ones, bit
 * for bit.
 * TX_WOOP_SHEAR: component (r.x, r.y, r.z) . q of a vertex q = (X, Y, Z) - org relative
 * to the ray origin, as explicit multiply-adds under FP_CONTRACT OFF. */
#define TX_WOOP_SHEAR(rx_, ry_, rz_, X, Y, Z) ((rx_) * (X) + (ry_) * (Y) + (rz_) * (Z))
/* The edge functions of the sheared 2-D vertices a, b, c. */
#define TX_WOOP_EDGES(U, V, W, ax, ay, bx, by, cx, cy) \
    U = (cx) * (by) - (cy) * (bx); V = (ax) * (cy) - (ay) * (cx); W = (bx) * (ay) - (by) * (ax)
/* The rounding-error bound of t = T / det (pbrt-v4 6.5.3, "Conservative Ray-Triangle t
 * Tests"): a ray leaving a surface from a point offset by that surface's error bound
 * cannot re-hit it: t > delta_t is required. */
#define TX_WOOP_DELTA_T(T_, delta_t, ax, ay, az, bx, by, bz, cx, cy, cz, U, V, W, inv) do { \
    T_ max_z = TX_MAX(TX_MAX(fabs(az), fabs(bz)), fabs(cz)); \
    T_ max_x = TX_MAX(TX_MAX(fabs(ax), fabs(bx)), fabs(cx)); \
    T_ max_y = TX_MAX(TX_MAX(fabs(ay), fabs(by)), fabs(cy)); \
    T_ delta_z = gamma_n(3.0f) * max_z; \
    T_ delta_x = gamma_n(5.0f) * (max_x + max_z); \
    T_ delta_y = gamma_n(5.0f) * (max_y + max_z); \
    T_ delta_e = 2.0f * (gamma_n(2.0f) * max_x * max_y + delta_y * max_x + delta_x * max_y); \
    T_ max_e = TX_MAX(TX_MAX(fabs(U), fabs(V)), fabs(W)); \
    delta_t = 3.0f * (gamma_n(3.0f) * max_e * max_z + delta_e * max_z + delta_z * max_e) * fabs(inv); \
} while (0)
/* Where an edge function rounded to exactly zero, lanes k in [0, N) recomputed in float64
 * (when the device has it); the nine sheared coordinates and the three edge functions are
 * vectors of N lanes (vstore/vload of that width). */
#ifdef cl_khr_fp64
#define TX_WOOP_EXACT_EDGES(N, U, V, W, ax, ay, bx, by, cx, cy) do { \
    float u_[N], v_[N], w_[N], ax_[N], ay_[N], bx_[N], by_[N], cx_[N], cy_[N]; \
    vstore##N(U, 0, u_); vstore##N(V, 0, v_); vstore##N(W, 0, w_); \
    vstore##N(ax, 0, ax_); vstore##N(ay, 0, ay_); vstore##N(bx, 0, bx_); vstore##N(by, 0, by_); \
    vstore##N(cx, 0, cx_); vstore##N(cy, 0, cy_); \
    for (int j = 0; j < N; ++j) { \
        if (u_[j] == 0.0f || v_[j] == 0.0f || w_[j] == 0.0f) { \
            u_[j] = (float)((double)cx_[j] * (double)by_[j] - (double)cy_[j] * (double)bx_[j]); \
            v_[j] = (float)((double)ax_[j] * (double)cy_[j] - (double)ay_[j] * (double)cx_[j]); \
            w_[j] = (float)((double)bx_[j] * (double)ay_[j] - (double)by_[j] * (double)ax_[j]); \
        } \
    } \
    U = vload##N(0, u_); V = vload##N(0, v_); W = vload##N(0, w_); \
} while (0)
#endif

/* The triangles tr[0..n) of a leaf (n in 1..4), the scene's triangles index, index + 1,
 * ..., against the ray at once, one per float4 lane, so that most leaves cost one vector
 * test and an early exit instead of n scalar ones (perf, textured meshes on PoCL: the
 * scalar test was 53% of the frame). Lanes >= n repeat triangle 0 (no read past the array)
 * and are masked out. Returns the lane of the nearest hit with t in (tmin, tmax), writing
 * t and the barycentrics b1, b2 of p1, p2 (P = (1 - b1 - b2) P0 + b1 P1 + b2 P2, the
 * lecture's form); -1 for none. Degenerate (zero-area) triangles and NaN inputs never hit.
 * Ties go to the lower index: among lanes, and against the closest hit so far, `best` (its
 * prim, at t = tmax; TX_MISS for none, when the interval is open at tmax), so that the
 * closest hit of a ray is the same whatever order a traversal meets the triangles in (a
 * packet's, accel/packet.h, or the scalar one's). */
TX_LINK_PACKET_KINDS int triangle_intersect4(const WoopRay* w, __global const TriVerts* tr, uint n, uint index, uint best,
                               float tmin, float tmax, float* t, float* b1, float* b2)
{
    __global const TriVerts* t1 = tr + (n > 1u ? 1 : 0);
    __global const TriVerts* t2 = tr + (n > 2u ? 2 : 0);
    __global const TriVerts* t3 = tr + (n > 3u ? 3 : 0);
    float3 a0 = tri_p0(tr), a1 = tri_p0(t1), a2 = tri_p0(t2), a3 = tri_p0(t3);
    float3 b0_ = tri_p1(tr), b1_ = tri_p1(t1), b2_ = tri_p1(t2), b3_ = tri_p1(t3);
    float3 c0 = tri_p2(tr), c1 = tri_p2(t1), c2 = tri_p2(t2), c3 = tri_p2(t3);
    float3 o = w->org;
    float4 Ax = (float4)(a0.x, a1.x, a2.x, a3.x) - o.x, Ay = (float4)(a0.y, a1.y, a2.y, a3.y) - o.y,
           Az = (float4)(a0.z, a1.z, a2.z, a3.z) - o.z;
    float4 Bx = (float4)(b0_.x, b1_.x, b2_.x, b3_.x) - o.x, By = (float4)(b0_.y, b1_.y, b2_.y, b3_.y) - o.y,
           Bz = (float4)(b0_.z, b1_.z, b2_.z, b3_.z) - o.z;
    float4 Cx = (float4)(c0.x, c1.x, c2.x, c3.x) - o.x, Cy = (float4)(c0.y, c1.y, c2.y, c3.y) - o.y,
           Cz = (float4)(c0.z, c1.z, c2.z, c3.z) - o.z;
    float3 rx = w->rx, ry = w->ry, rz = w->rz;
    float4 ax = TX_WOOP_SHEAR(rx.x, rx.y, rx.z, Ax, Ay, Az), ay = TX_WOOP_SHEAR(ry.x, ry.y, ry.z, Ax, Ay, Az);
    float4 bx = TX_WOOP_SHEAR(rx.x, rx.y, rx.z, Bx, By, Bz), by = TX_WOOP_SHEAR(ry.x, ry.y, ry.z, Bx, By, Bz);
    float4 cx = TX_WOOP_SHEAR(rx.x, rx.y, rx.z, Cx, Cy, Cz), cy = TX_WOOP_SHEAR(ry.x, ry.y, ry.z, Cx, Cy, Cz);
    float4 U, V, W;
    TX_WOOP_EDGES(U, V, W, ax, ay, bx, by, cx, cy);
#ifdef cl_khr_fp64
    if (any((U == 0.0f) | (V == 0.0f) | (W == 0.0f)))    /* rare: an edge function rounded to 0 */
        TX_WOOP_EXACT_EDGES(4, U, V, W, ax, ay, bx, by, cx, cy);
#endif
    /* NaN edge functions fail both sign tests: a miss. */
    int4 ok = ((U >= 0.0f) & (V >= 0.0f) & (W >= 0.0f)) | ((U <= 0.0f) & (V <= 0.0f) & (W <= 0.0f));
    ok &= (int4)(0, 1, 2, 3) < (int4)((int)n);
    if (!any(ok)) return -1;
    float4 det = U + V + W;
    float4 az = TX_WOOP_SHEAR(rz.x, rz.y, rz.z, Ax, Ay, Az), bz = TX_WOOP_SHEAR(rz.x, rz.y, rz.z, Bx, By, Bz);
    float4 cz = TX_WOOP_SHEAR(rz.x, rz.y, rz.z, Cx, Cy, Cz);
    float4 T = U * az + V * bz + W * cz;
    float4 inv = 1.0f / det;
    float4 tt = T * inv;
    int4 tie = (tt == tmax) & (best != TX_MISS ? (uint4)(index) + (uint4)(0u, 1u, 2u, 3u) < (uint4)(best) : (int4)(0));
    ok &= (det != 0.0f) & (tt > tmin) & ((tt < tmax) | tie);     /* NaN t fails */
    if (!any(ok)) return -1;
    float4 delta_t;
    TX_WOOP_DELTA_T(float4, delta_t, ax, ay, az, bx, by, bz, cx, cy, cz, U, V, W, inv);
    ok &= tt > delta_t;
    int lane = -1;
    float near = tmax;
    if (ok.s0) { lane = 0; near = tt.s0; }
    if (ok.s1 && (lane < 0 || tt.s1 < near)) { lane = 1; near = tt.s1; }
    if (ok.s2 && (lane < 0 || tt.s2 < near)) { lane = 2; near = tt.s2; }
    if (ok.s3 && (lane < 0 || tt.s3 < near)) { lane = 3; near = tt.s3; }
    if (lane < 0) return -1;
    float4 vb1 = V * inv, vb2 = W * inv;
    *t = near;
    *b1 = lane == 0 ? vb1.s0 : (lane == 1 ? vb1.s1 : (lane == 2 ? vb1.s2 : vb1.s3));
    *b2 = lane == 0 ? vb2.s0 : (lane == 1 ? vb2.s1 : (lane == 2 ? vb2.s2 : vb2.s3));
    return lane;
}

/* TriVerts is three float4 (xyz, pad), read by tri_p0..tri_p2: accessors generated
 * from the dtype (texray.device.layout.VECTOR_VIEWS). */

/* The triangle's corners' texture coordinates: its mesh's uvs where it has them, else
 * (0, 0), (1, 0), (0, 1). */
static inline void tri_corner_uvs(__global const TriShade* ts, __global const float* uvs, float2* uv0, float2* uv1,
                                  float2* uv2)
{
    *uv0 = (float2)(0.0f, 0.0f); *uv1 = (float2)(1.0f, 0.0f); *uv2 = (float2)(0.0f, 1.0f);
    if (uvs != 0 && (ts->flags & TRI_HAS_UVS)) {
        *uv0 = vload2(ts->v[0], uvs); *uv1 = vload2(ts->v[1], uvs); *uv2 = vload2(ts->v[2], uvs);
    }
}

/* Surface geometry of a triangle hit (b1, b2): the lecture's barycentric form
 * P = (1 - b1 - b2) P0 + b1 P1 + b2 P2 for the point and the texture
 * coordinates; ng = normalize((P1 - P0) x (P2 - P0)), the side the vertex
 * order gives. dP/du and dP/dv solve [dP/du dP/dv] [duv1 duv2] = [P1-P0 P2-P0]
 * from the uv differences (pbrt-v4 Triangle::InteractionFromIntersection;
 * core/frame.h reparam_tangents); a triangle whose edge cross product overflows
 * (edges beyond 2^64) or underflows still gets its unit normal (scaled edges,
 * normalize3); where [duv1 duv2] is singular to float precision (reparam_tangents:
 * a uv triangle of (nearly) zero area, or uvs whose differences overflow) they are an
 * arbitrary orthonormal frame around ng, so that bump mapping never sees NaN. */
TX_LINK_TRI_GEOM void triangle_geom(__global const TriVerts* tv, __global const TriShade* ts, float b1, float b2,
                          __global const float* uvs, Geom* g)
{
    float b0 = 1.0f - b1 - b2;
    float3 p0 = tri_p0(tv), p1 = tri_p1(tv), p2 = tri_p2(tv);
    float3 e1 = p1 - p0, e2 = p2 - p0;
    g->p = b0 * p0 + b1 * p1 + b2 * p2;
    /* Error bound of the interpolated point (pbrt-v4 6.8.5). */
    g->perr = gamma_n(7.0f) * (abs3(b0 * p0) + abs3(b1 * p1) + abs3(b2 * p2));
    float3 nc = cross3(e1, e2);
    if (!finite3(nc))                  /* edges beyond 2^64: the product overflows; scaled edges */
        nc = cross3(e1 / TX_MAX(TX_MAX(fabs(e1.x), fabs(e1.y)), fabs(e1.z)),   /* give its direction */
                    e2 / TX_MAX(TX_MAX(fabs(e2.x), fabs(e2.y)), fabs(e2.z)));
    g->ng = normalize3(nc);            /* core/common.h: also where |nc|^2 under- or overflows */
    float2 uv0, uv1, uv2;
    tri_corner_uvs(ts, uvs, &uv0, &uv1, &uv2);
    g->uv = b0 * uv0 + b1 * uv1 + b2 * uv2;
    if (!reparam_tangents(uv1 - uv0, uv2 - uv0, e1, e2, &g->dpdu, &g->dpdv)) {
        g->dpdu = any_tangent(g->ng);
        g->dpdv = cross3(g->ng, g->dpdu);
    }
}

#endif
