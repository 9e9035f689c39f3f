#line 2 "core/frame.h"
/* Tangent frames, written once for every technique that needs one:
 * - a unit tangent for a unit normal (a frame where a surface has no usable
 *   parameterization: degenerate uv triangles, projections, normal maps);
 * - tangents under a change of parameters, [dP/ds dP/dt] = [dP/du dP/dv] J^-1: the
 *   one 2x2 inverse (texture coordinates of quads and triangles, projection
 *   mappings, and the least-squares uv derivatives of texture/differentials.h);
 * - the normal of a surface raised along its normal by a height field, from its
 *   tangents and the height's gradient: the formula shared by bump mapping
 *   (shading/bump.h: derivation, direction and sign there) and displacement
 *   (geometry/displace.h: the displaced surface's normal). */
#ifndef TEXRAY_FRAME_H
#define TEXRAY_FRAME_H
#include "core/accurate.h"

/* A unit vector perpendicular to the unit vector n: z x n or x x n, whichever is
 * longer (at least 1/sqrt(2) before normalization, so never near zero). */
static inline float3 any_tangent(float3 n)
{
    return normalize3(fabs(n.x) > fabs(n.z) ? (float3)(-n.y, n.x, 0.0f) : (float3)(0.0f, -n.z, n.y));
}

/* [x y] = [p q] M^-1 for the 2x2 matrix M = [a b] (columns a, b), given inv = 1 / det M
 * (det M = a.x b.y - b.x a.y; the caller decides when M is invertible): with M =
 * d(s, t)/d(u, v) and p, q the derivatives of some quantity with respect to u and v,
 * x and y are its derivatives with respect to s and t. Componentwise in p, q, so two
 * right-hand sides can share one call (texture/differentials.h). */
static inline void mul_inverse2(float2 a, float2 b, float inv, float3 p, float3 q, float3* x, float3* y)
{
    *x = (b.y * p - a.y * q) * inv;
    *y = (a.x * q - b.x * p) * inv;
}

/* dP/ds, dP/dt for parameters (s, t) of the surface with J = d(s, t)/d(u, v) = [ju jv],
 * from dP/du, dP/dv (mul_inverse2). Returns 0, leaving *ps and *pt as they are, where J
 * is singular to float precision: |det J| at most 2^-16 of |J00 J11| + |J01 J10| (the
 * determinant is then within a few hundred roundings of zero and its inverse would
 * amplify them more than 6e4-fold), or not finite (NaN included). */
static inline int reparam_tangents(float2 ju, float2 jv, float3 pu, float3 pv, float3* ps, float3* pt)
{
    float det = ju.x * jv.y - jv.x * ju.y;
    float size = fabs(ju.x * jv.y) + fabs(jv.x * ju.y);
    if (!(fabs(det) > 1.5258789e-05f * size && size <= FLT_MAX)) return 0;   /* 2^-16 */
    mul_inverse2(ju, jv, 1.0f / det, pu, pv, ps, pt);
    return 1;
}

/* The unit normal, on n's side, of P + B n (shading/bump.h's header comment), from
 * the outward unit normal n, dP/du, dP/dv and (B_u, B_v) with respect to the same
 * (u, v): with P_u, P_v projected onto n's plane and j = (P_u x P_v) . n,
 *     N' ~ n + (B_u (n x P_v) - B_v (n x P_u)) / j.
 * n itself, bit for bit, where the gradient is zero, where P_u, P_v span no area on
 * n's plane (a pole, a singular projection: zero tangents) or where the result is not
 * finite. */
inline float3 bump_normal(float3 n, float3 dpdu, float3 dpdv, float2 grad)
{
    if (grad.x == 0.0f && grad.y == 0.0f) return n;
    float3 pu = dpdu - dot3(dpdu, n) * n, pv = dpdv - dot3(dpdv, n) * n;
    float j = dot3(cross3(pu, pv), n);
    if (!(fabs(j) > 0.0f)) return n;
    float3 r = n + (grad.x * cross3(n, pv) - grad.y * cross3(n, pu)) / j;
    return tx_unit_or(r, n);
}

#endif
