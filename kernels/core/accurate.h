#line 2 "core/accurate.h"
/* Accurate float32 arithmetic: the error-free transformations the analytic
 * primitives (geometry/sphere.h, cylinder.h, quad.h), the ray differentials and
 * the anisotropic footprint share, and a unit vector at any scale.
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
#ifndef TEXRAY_ACCURATE_H
#define TEXRAY_ACCURATE_H
#include "core/common.h"
/* No FMA contraction from here to the end of the program (a pragma holds to the end of
 * the translation unit, not of this file; texray.cl): sphere_geom and cylinder_geom
 * recompute the intersection's roots and must get the very same floats, and the
 * watertight triangle test (geometry/triangle.h) rounds both products of each edge
 * function alike. core/common.h and core/sampler.h come before it, with OpenCL's
 * default (contraction allowed), as they always have: moving this line above them
 * changes the bits of every image (measured on PoCL). */
#pragma OPENCL FP_CONTRACT OFF

/* a * b - c * d with relative error <= 2u (Kahan's algorithm): no
 * cancellation even where the two products nearly agree. */
static inline float tx_diff_prod(float a, float b, float c, float d)
{
    float cd = c * d;
    float err = fma(-c, d, cd);        /* exactly cd - c * d */
    return fma(a, b, -cd) + err;
}

/* a x b, each component by tx_diff_prod: accurate even for nearly parallel a, b. */
static inline float3 tx_cross_accurate(float3 a, float3 b)
{
    return (float3)(tx_diff_prod(a.y, b.z, a.z, b.y),
                    tx_diff_prod(a.z, b.x, a.x, b.z),
                    tx_diff_prod(a.x, b.y, a.y, b.x));
}

/* a + b, adding its rounding error exactly to *err (TwoSum). */
static inline float tx_two_sum(float a, float b, float* err)
{
    float s = a + b;
    float bb = s - a;
    *err += (a - (s - bb)) + (b - bb);
    return s;
}

/* a - b = *hi + *lo exactly, per component (TwoSum: six additions, no branch). */
static inline void tx_two_diff3(float3 a, float3 b, float3* hi, float3* lo)
{
    float3 s = a - b;
    float3 bb = s - a;                 /* the part of -b that made it into s */
    *lo = (a - (s - bb)) + (-b - bb);
    *hi = s;
}

/* v / |v| without overflow or underflow at any scale (v is first divided by
 * its largest component); `fallback` where v is zero or not finite. */
static inline float3 tx_unit_or(float3 v, float3 fallback)
{
    float m = TX_MAX(TX_MAX(fabs(v.x), fabs(v.y)), fabs(v.z));
    if (!(m > 0.0f && m <= FLT_MAX)) return fallback;
    v = v / m;                         /* not v * (1 / m): 1 / m overflows for tiny denormal m */
    return v * rsqrt(dot3(v, v));
}

#endif
