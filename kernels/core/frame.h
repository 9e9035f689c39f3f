#line 2 "core/frame.h"
/* Surface frames: the normal of a surface raised along its normal by a height
 * field, from the tangents dP/du, dP/dv and the height's gradient -- the formula
 * shared by bump mapping (shading/bump.h: derivation, direction and sign there)
 * and displacement (geometry/displace.h: the displaced surface's normal). */
#ifndef TEXRAY_FRAME_H
#define TEXRAY_FRAME_H
#include "core/accurate.h"

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
