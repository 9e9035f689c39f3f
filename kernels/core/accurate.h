#line 2 "core/accurate.h"
/* What the surface stage needs about a hit, and the accurate arithmetic the
 * analytic primitives (sphere.h, cylinder.h, quad.h) share.
 *
 * Error-free transformations: Knuth's TwoSum (TAOCP vol. 2, 4.2.2) and
 * Kahan's difference of products with an FMA (Jeannerod, Louvet, Muller,
 * "Further analysis of Kahan's algorithm for the accurate computation of 2x2
 * determinants", Math. Comp. 82, 2013: relative error at most 2u), as pbrt-v4
 * uses them (Pharr, Jakob, Humphreys, "Physically Based Rendering", 4th ed.,
 * B.2.9). OpenCL's fma() is correctly rounded on every conforming device.
 * Both rely on IEEE evaluation order: a build with -cl-unsafe-math-optimizations
 * (or -cl-fast-relaxed-math) may fold their error terms to zero, which leaves
 * plain float32 accuracy, never a wrong sign or a NaN. */
#ifndef TEXRAY_GEOM_H
#define TEXRAY_GEOM_H
/* No FMA contraction (as triangle.h): sphere_geom and cylinder_geom recompute
 * the intersection's roots and must get the very same floats. */
#pragma OPENCL FP_CONTRACT OFF

typedef struct {            /* what the surface stage needs about a hit, in world space */
    float3 p;               /* the hit point, on the surface */
    float3 ng;              /* unit geometric normal: outward for sphere/cylinder (away from the
                             * centre/axis); for the quad normalize(dP/du x dP/dv) of the bilinear
                             * parameters, the (P1-P0)x(P3-P0) side */
    float3 dpdu, dpdv;      /* dP/du, dP/dv with respect to the texture coordinates uv below */
    float2 uv;              /* texture coordinates (conventions in sphere.h, cylinder.h, quad.h) */
    float3 perr;            /* per-component absolute error bound of p (offset secondary rays along ng) */
} Geom;

/* a * b - c * d with relative error <= 2u (Kahan's algorithm): no
 * cancellation even where the two products nearly agree. */
inline float tx_diff_prod(float a, float b, float c, float d)
{
    float cd = c * d;
    float err = fma(-c, d, cd);        /* exactly cd - c * d */
    return fma(a, b, -cd) + err;
}

/* a x b, each component by tx_diff_prod: accurate even for nearly parallel a, b. */
inline float3 tx_cross_accurate(float3 a, float3 b)
{
    return (float3)(tx_diff_prod(a.y, b.z, a.z, b.y),
                    tx_diff_prod(a.z, b.x, a.x, b.z),
                    tx_diff_prod(a.x, b.y, a.y, b.x));
}

/* a + b, adding its rounding error exactly to *err (TwoSum). */
inline float tx_two_sum(float a, float b, float* err)
{
    float s = a + b;
    float bb = s - a;
    *err += (a - (s - bb)) + (b - bb);
    return s;
}

/* a - b = *hi + *lo exactly, per component (TwoSum: six additions, no branch). */
inline void tx_two_diff3(float3 a, float3 b, float3* hi, float3* lo)
{
    float3 s = a - b;
    float3 bb = s - a;                 /* the part of -b that made it into s */
    *lo = (a - (s - bb)) + (-b - bb);
    *hi = s;
}

/* v / |v| without overflow or underflow at any scale (v is first divided by
 * its largest component); `fallback` where v is zero or not finite. */
/* The roots of a t^2 + 2 b t + c = 0 (b: half the linear coefficient), given root =
 * sqrt(b^2 - a c) computed by the caller as accurately as its geometry allows: q =
 * -(b + sign(b) root), then c/q and q/a, which never subtract nearly equal numbers
 * (|c/q| <= |q/a|); sorted. c_ok = 0 marks the root c/q, which is 0 when c is, as the
 * surface the ray starts on rather than a hit. */
typedef struct {
    float t_near, t_far;
    int near_ok, far_ok;
} QuadRoots;

inline QuadRoots stable_roots(float a, float b, float c, float root, int c_ok)
{
    float q = -(b + copysign(root, b));
    float t_small = c / q, t_large = q / a;
    int small_first = t_small <= t_large;
    QuadRoots r = { small_first ? t_small : t_large, small_first ? t_large : t_small,
                    small_first ? c_ok : 1, small_first ? 1 : c_ok };
    return r;
}

inline float3 tx_unit_or(float3 v, float3 fallback)
{
    float m = TX_MAX(TX_MAX(fabs(v.x), fabs(v.y)), fabs(v.z));
    if (!(m > 0.0f && m <= FLT_MAX)) return fallback;
    v = v / m;                         /* not v * (1 / m): 1 / m overflows for tiny denormal m */
    return v * rsqrt(dot3(v, v));
}

#endif
