#line 2 "core/transcendental.h"
/* atan2 and hypot written out, the same on every device. The builtins are accurate but
 * slow where a driver calls them out of line: PoCL's SLEEF versions (0.5 ulp) took 13%
 * of the globe scene's frame (perf: _cl_atan2 8%, Sleef_hypotf_u05 5%), for the sphere
 * and cylinder parameterizations and the anisotropic filter's axes. These are within a
 * few ulp, which is far below what any texture lookup resolves (tests/kernels/
 * test_transcendental.py bounds them against float64), and compiled under core/
 * accurate.h's FP_CONTRACT OFF, so every device rounds them alike. */
#ifndef TEXRAY_TRANSCENDENTAL_H
#define TEXRAY_TRANSCENDENTAL_H
#include "core/accurate.h"

/* atan(a) for |a| <= tan(pi/8): Cephes' atanf polynomial (S. Moshier), relative
 * error about 1e-7 there. */
static inline float tx_atan_poly(float a)
{
    float z = a * a;
    return ((((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z
             - 3.33329491539e-1f) * z) * a + a;
}

/* atan2(y, x) in [-pi, pi] with C99's special values: the quotient of the smaller
 * magnitude by the larger, in [0, 1] (reduced once more above tan(pi/8) by
 * atan a = pi/4 + atan((a - 1) / (a + 1))), then the octant restored. Both zero: 0 or
 * pi by x's sign; both infinite: the diagonal; NaN in, NaN out. Error at most 4 ulp of
 * the result (measured: 2). */
static inline float tx_atan2(float y, float x)
{
    if (x != x || y != y) return x + y;
    float ax = fabs(x), ay = fabs(y);
    int swap = ay > ax;
    float num = swap ? ax : ay, den = swap ? ay : ax;
    float a = den == 0.0f ? 0.0f : (num > FLT_MAX ? 1.0f : num / den);
    float r = a > 0.41421356f ? M_PI_4_F + tx_atan_poly((a - 1.0f) / (a + 1.0f)) : tx_atan_poly(a);
    if (swap) r = M_PI_2_F - r;
    if (as_uint(x) & 0x80000000u) r = M_PI_F - r;       /* x < 0, or x = -0 */
    return as_float((as_uint(r) & 0x7fffffffu) | (as_uint(y) & 0x80000000u));
}

/* sqrt(x^2 + y^2) without overflow or underflow: plain where the squares are safe
 * (larger magnitude in [2^-40, 2^60]), else both scaled by a power of two first
 * (exact). Within 1.5 ulp (tests/kernels/test_builtins.py); inf if either is infinite (even with a NaN), else NaN in,
 * NaN out. */
static inline float tx_hypot(float x, float y)
{
    float ax = fabs(x), ay = fabs(y);
    if (ax > FLT_MAX || ay > FLT_MAX) return INFINITY;
    float m = TX_MAX(ax, ay);
    if (m >= 9.094947e-13f && m <= 1.1529215e18f) return sqrt(ax * ax + ay * ay);
    if (!(m > 0.0f)) return ax + ay;                        /* both zero, or a NaN */
    float s = m > 1.0f ? 8.4703295e-22f : 1.2676506e30f;     /* 2^-70, 2^100 */
    ax *= s; ay *= s;
    return sqrt(ax * ax + ay * ay) / s;
}

#endif
