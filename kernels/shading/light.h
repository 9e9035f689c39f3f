#line 2 "shading/light.h"
/* The lecture's local illumination of a surface point by point lights:
 *   I = ambient kd + sum_i I_i vis(i) / d_i^2 (kd (N.L_i) + ks (R_i.V)^n)
 * with N the shading normal facing the viewer, L_i and V unit vectors from
 * the point, R_i = 2 (N.L_i) N - L_i. Terms with N.L_i <= 0 contribute nothing
 * (the specular term included, so no highlight appears on the unlit side). */
#ifndef TEXRAY_LIGHT_H
#define TEXRAY_LIGHT_H
#include "core/accurate.h"

/* Light i's term I_i / d_i^2 (kd (N.L_i) + ks (R_i.V)^n) at the surface point s seen
 * along -v (v: unit vector from the point toward the eye). The callers only pass lights
 * that light_visible (shading/shadow.h) let through: finite, at a finite distance from a
 * finite point. What remains degenerate, each written so that the usual case computes
 * exactly what it always did:
 * - a light whose intensity is not finite (NaN, inf) adds nothing: inf x 0 for the
 *   unlit channels and points would be NaN;
 * - where d^2 = |l|^2 is not a normal float (d above 2^64 or below 2^-63), l is first
 *   divided by m, its largest component, and I / d^2 computed as (I / m / m) / |l / m|^2:
 *   l * rsqrt(d^2) would be 0 or inf, and I / d^2 0 / 0 for a tiny scene's tiny I and
 *   d. l = 0 (the light at the point itself, which light_visible never lets through)
 *   adds nothing;
 * - N.L and R.V are tested with > 0, false for NaN;
 * - the exponent n = shininess only enters as powr(R.V, n) with R.V > 0; n >= 0 and
 *   finite, R.V <= 1 (up to rounding) keep it in [0, 1]; a result that is NaN or inf
 *   (NaN n, or R.V rounded above 1 with n near FLT_MAX) leaves the specular term out.
 * The term is then finite unless I / d^2 itself exceeds the float range. */
static inline float3 light_term(const Surface* s, float3 v, float3 lpos, float3 intensity)
{
    if (!finite3(intensity)) return (float3)(0.0f);
    float3 p = vload3(0, s->p), nrm = vload3(0, s->ns);
    float3 l = lpos - p;
    float d2 = dot3(l, l);
    if (!(d2 >= FLT_MIN && d2 <= FLT_MAX)) {
        float m = TX_MAX(TX_MAX(fabs(l.x), fabs(l.y)), fabs(l.z));
        if (!(m > 0.0f && m <= FLT_MAX)) return (float3)(0.0f);
        l = l / m;
        d2 = dot3(l, l);                   /* in [1, 3] */
        intensity = intensity / m / m;     /* I / d^2 = (I / m^2) / |l / m|^2 */
    }
    l *= rsqrt(d2);
    float ndl = dot3(nrm, l);
    if (!(ndl > 0.0f)) return (float3)(0.0f);
    float3 term = vload3(0, s->kd) * ndl;
    if (TX_SPECULAR) {
        float3 r = 2.0f * ndl * nrm - l;
        float rv = dot3(r, v);
        if (rv > 0.0f) {
            /* powr(rv, n) as exp2(n log2 rv): PoCL's powr works in extended precision
             * (6% of the globe's frame); this is within n |log2 rv| ulp of it, under 1e-6
             * relative wherever the term is above 1e-6. */
            float sp = exp2(s->shininess * log2(rv));
            if (sp >= 0.0f && sp <= FLT_MAX) term += vload3(0, s->ks) * sp;
        }
    }
    return intensity * (term / d2);
}

/* The intensity light i contributes with in a sample: its own; with TX_ONE_LIGHT, where each
 * sample takes one of the n lights (core/sampler.h light_pick), n times its own, the picked
 * light standing for all n. */
static inline float3 light_intensity(float3 intensity, uint n)
{
#if TX_ONE_LIGHT
    return (float)n * intensity;
#else
    return intensity;
#endif
}

/* The largest radiance a sample adds to a pixel, either sign: FLT_MAX / 2^24, so that the
 * accumulator of texray.validate.MAX_SPP = 2^24 samples stays finite. The host keeps
 * every input finite in float32, but intensity / d^2 of a strong light close to a
 * point, or sums of such terms, can still exceed the float range (and a linear texture
 * may hold negative texels); such a sample is clamped (a NaN, which no finite input
 * produces, is clamped too rather than kept). Ordinary images are far inside the range
 * and unchanged bit for bit. */
#define TX_MAX_RADIANCE 2.0e31f

static inline float clamp_radiance1(float x)
{
    x = x <= TX_MAX_RADIANCE ? x : TX_MAX_RADIANCE;       /* NaN -> TX_MAX_RADIANCE */
    return x >= -TX_MAX_RADIANCE ? x : -TX_MAX_RADIANCE;
}

static inline float3 clamp_radiance(float3 c)
{
    return (float3)(clamp_radiance1(c.x), clamp_radiance1(c.y), clamp_radiance1(c.z));
}

#endif
