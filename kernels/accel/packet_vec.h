#line 2 "accel/packet_vec.h"
/* 3-vectors with one component per packet lane (pfloat3), and the scalar helpers the
 * packet intersectors mirror (geometry/quad_packet.h, sphere_packet.h), each rounding
 * as its scalar original does: dot3 and cross3 as core/common.h compiles them (FP
 * contraction on: they sit in a block that turns it on), Kahan's product and TwoSum
 * (core/accurate.h) with the same explicit fma and additions, contraction off. Lane j of
 * each result is the scalar helper's result for lane j's inputs, bit for bit. Always inlined:
 * PoCL left pf3_cross_accurate out of line (11% of a brick wall's frame in calls passing
 * structs through memory); inlined, tools/ab.py measured 0.95-0.98 of the frame time on the
 * brick wall, globe and grazing quad (16 spp, 5 rounds). */
#ifndef TEXRAY_PACKET_VEC_H
#define TEXRAY_PACKET_VEC_H

/* A 3-vector per lane. */
typedef struct {
    pfloat x, y, z;
} pfloat3;

static inline __attribute__((always_inline)) pfloat3 pf3(pfloat x, pfloat y, pfloat z) { pfloat3 v = { x, y, z }; return v; }
static inline __attribute__((always_inline)) pfloat3 pf3_splat(float3 a) { return pf3((pfloat)(a.x), (pfloat)(a.y), (pfloat)(a.z)); }
static inline __attribute__((always_inline)) pfloat3 pf3_add(pfloat3 a, pfloat3 b) { return pf3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline __attribute__((always_inline)) pfloat3 pf3_sub(pfloat3 a, pfloat3 b) { return pf3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline __attribute__((always_inline)) pfloat3 pf3_scale(pfloat s, pfloat3 a) { return pf3(s * a.x, s * a.y, s * a.z); }
static inline __attribute__((always_inline)) pfloat3 pf3_abs(pfloat3 a) { return pf3(fabs(a.x), fabs(a.y), fabs(a.z)); }
static inline __attribute__((always_inline)) pfloat3 pf3_max(pfloat3 a, pfloat3 b) { return pf3(PMAX(a.x, b.x), PMAX(a.y, b.y), PMAX(a.z, b.z)); }
static inline __attribute__((always_inline)) pfloat3 pf3_sel(pint c, pfloat3 a, pfloat3 b)
{
    return pf3(PSEL_F(c, a.x, b.x), PSEL_F(c, a.y, b.y), PSEL_F(c, a.z, b.z));
}

#pragma OPENCL FP_CONTRACT ON
/* core/common.h's dot3 and cross3, compiled as they are there (contraction on). */
static inline __attribute__((always_inline)) pfloat pf3_dot(pfloat3 a, pfloat3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline __attribute__((always_inline)) pfloat3 pf3_cross(pfloat3 a, pfloat3 b)
{
    return pf3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
#pragma OPENCL FP_CONTRACT OFF

/* core/accurate.h's tx_diff_prod, tx_cross_accurate and tx_two_diff3, lane by lane. */
static inline __attribute__((always_inline)) pfloat pf_diff_prod(pfloat a, pfloat b, pfloat c, pfloat d)
{
    pfloat cd = c * d;
    pfloat err = fma(-c, d, cd);
    return fma(a, b, -cd) + err;
}
static inline __attribute__((always_inline)) pfloat3 pf3_cross_accurate(pfloat3 a, pfloat3 b)
{
    return pf3(pf_diff_prod(a.y, b.z, a.z, b.y), pf_diff_prod(a.z, b.x, a.x, b.z), pf_diff_prod(a.x, b.y, a.y, b.x));
}
static inline __attribute__((always_inline)) void pf3_two_diff(pfloat3 a, pfloat3 b, pfloat3* hi, pfloat3* lo)
{
    pfloat3 s = pf3_sub(a, b);
    pfloat3 bb = pf3_sub(s, a);
    pfloat3 nb = pf3(-b.x, -b.y, -b.z);
    *lo = pf3_add(pf3_sub(a, pf3_sub(s, bb)), pf3_sub(nb, bb));
    *hi = s;
}

#endif
