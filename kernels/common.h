#line 2 "common.h"
/* Small numeric helpers shared by every stage.
 *
 * Dot and cross products are written as plain multiply-adds and min/max as
 * ternaries: on PoCL the builtins (dot, cross, fmin, fmax) measured up to 2x
 * slower inside the traversal loop. Every #if in the kernels uses a name that
 * texray.features.compile_options() emits. */
#ifndef TEXRAY_COMMON_H
#define TEXRAY_COMMON_H

/* Unit roundoff of float32 (2^-24). gamma_n(n) = n u / (1 - n u) bounds the
 * relative error of n chained float operations (Higham; pbrt-v4 3.9). */
#define TX_FLT_U 5.9604645e-08f
inline float gamma_n(float n) { return (n * TX_FLT_U) / (1.0f - n * TX_FLT_U); }

#define TX_MIN(a, b) ((a) < (b) ? (a) : (b))
#define TX_MAX(a, b) ((a) > (b) ? (a) : (b))
#define TX_MISS 0xffffffffu

inline float dot3(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline float3 cross3(float3 a, float3 b)
{
    return (float3)(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
inline float3 normalize3(float3 v)
{
    float l2 = dot3(v, v);
    return l2 > 0.0f ? v * rsqrt(l2) : v;
}
inline float3 abs3(float3 v) { return (float3)(fabs(v.x), fabs(v.y), fabs(v.z)); }

/* Component k (0, 1, 2) of v, without indexing a private vector through memory. */
inline float comp3(float3 v, int k) { return k == 0 ? v.x : (k == 1 ? v.y : v.z); }
inline float3 unit3(int k) { return (float3)(k == 0, k == 1, k == 2); }

/* 1/x, but +-2^100 instead of +-inf for |x| < 2^-100, so that slab tests never
 * compute 0 * inf = NaN for a ray parallel to a box face (madmann91/bvh's
 * safe_inverse). A direction component that small is zero for all purposes. */
#define TX_PARALLEL_INV 1.2676506e30f   /* 2^100: safe_inverse's value for a zero component */
inline float safe_inverse(float x)
{
    return fabs(x) < 7.888609e-31f ? copysign(TX_PARALLEL_INV, x) : 1.0f / x;
}

/* Move a point off a surface along n by `offset` (pbrt-v4 OffsetRayOrigin):
 * the offset is an error bound of p, and nextafter rounds away so that the
 * result is strictly on n's side even after rounding. */
inline float3 offset_point(float3 p, float3 n, float offset)
{
    float3 q = p + n * offset;
    q.x = n.x > 0.0f ? nextafter(q.x, INFINITY) : (n.x < 0.0f ? nextafter(q.x, -INFINITY) : q.x);
    q.y = n.y > 0.0f ? nextafter(q.y, INFINITY) : (n.y < 0.0f ? nextafter(q.y, -INFINITY) : q.y);
    q.z = n.z > 0.0f ? nextafter(q.z, INFINITY) : (n.z < 0.0f ? nextafter(q.z, -INFINITY) : q.z);
    return q;
}

/* Loop over the scene's n lights. With TX_MAX_LIGHTS (a bound the host compiles
 * in: 1, 2, 4 or 8) the trip count is a compile-time constant, so the compiler
 * can unroll it; the body runs only for i < n. Without it, a plain runtime loop. */
#if TX_MAX_LIGHTS
#define FOR_EACH_LIGHT(i, n) for (uint i = 0; i < (uint)TX_MAX_LIGHTS; ++i) if (i < (n))
#else
#define FOR_EACH_LIGHT(i, n) for (uint i = 0; i < (n); ++i)
#endif

inline float3 ray_org(__global const Ray* r) { return vload3(0, r->org); }
inline float3 ray_dir(__global const Ray* r) { return vload3(0, r->dir); }

#endif
