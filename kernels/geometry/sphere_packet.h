#line 2 "geometry/sphere_packet.h"
/* geometry/sphere.h's sphere_intersect for every lane of a ray packet (accel/packet.h):
 * one sphere against TX_PACKET rays as floatN arithmetic, for the packet traversals'
 * sphere leaves (sphere_ray took a seventh of a textured globe's frame, lane by lane).
 *
 * The same formulas in the same order as sphere_intersect, sphere_ray, sphere_c and
 * stable_roots, with their roundings (FP contraction off as there; accel/packet_vec.h's
 * helpers round as the scalar ones do); the scalar code's branches are lane masks, so
 * each lane's hit and t are sphere_intersect's, bit for bit (tests/kernels/test_packet.py
 * compares them ray by ray). */
#ifndef TEXRAY_SPHERE_PACKET_H
#define TEXRAY_SPHERE_PACKET_H
#include "geometry/sphere.h"
#include "accel/packet_vec.h"

/* tx_two_sum lane by lane: a + b, its rounding error added to *err. */
inline pfloat pf_two_sum(pfloat a, pfloat b, pfloat* err)
{
    pfloat s = a + b;
    pfloat bb = s - a;
    *err += (a - (s - bb)) + (b - bb);
    return s;
}

/* sphere_c lane by lane. */
inline pfloat sphere_c_packet(pfloat3 fh, pfloat3 fl, float r)
{
    pfloat sx = fh.x * fh.x, sy = fh.y * fh.y, sz = fh.z * fh.z;
    float rr = r * r;
    pfloat err = fma(fh.x, fh.x, -sx) + fma(fh.y, fh.y, -sy) + fma(fh.z, fh.z, -sz) - fma(r, r, -rr)
               + 2.0f * pf3_dot(fh, fl);
    pfloat s = pf_two_sum(sx, sy, &err);
    s = pf_two_sum(s, sz, &err);
    s = pf_two_sum(s, (pfloat)(-rr), &err);
    return s + err;
}

/* sphere_intersect(s, org, dir, tmin, tmax) for the lanes m of the packet, tmax per lane:
 * the lanes with a hit, their t into *t. */
inline pint sphere_intersect_packet(const PacketRay* pr, __global const Sphere* s, pint m, pfloat tmax, pfloat* t)
{
    float4 cr = sphere_center_radius(s);
    float r = cr.w;
    pfloat3 org = pf3(pr->ox, pr->oy, pr->oz), dir = pf3(pr->dx, pr->dy, pr->dz);
    pfloat a = pf3_dot(dir, dir);
    if (!(r > 0.0f)) return (pint)(0);
    m &= a > 0.0f;
    pfloat3 fh, fl;
    pf3_two_diff(org, pf3_splat(cr.xyz), &fh, &fl);
    pfloat b = pf3_dot(fh, dir);
    pfloat c = sphere_c_packet(fh, fl, r);
    m &= ~((pr->tmin >= 0.0f) & (b > 0.0f) & (c > 0.0f));     /* sphere_intersect's early miss */
    if (!any(m)) return m;
    pfloat3 w = pf3_add(pf3_cross_accurate(fh, dir), pf3_cross(fl, dir));
    pfloat disc = r * r - pf3_dot(w, w) / a;
    float g6 = gamma_n(6.0f);
    pint c_ok = fabs(c) > 2.0f * g6 * g6 * (pf3_dot(fh, fh) + r * r);
    m &= disc >= 0.0f;
    if (!any(m)) return m;
    /* stable_roots(a, b, c, sqrt(a * disc), c_ok) */
    pfloat q = -(b + copysign(sqrt(a * disc), b));
    pfloat t_small = c / q, t_large = q / a;
    pint small_first = t_small <= t_large;
    pfloat t_near = PSEL_F(small_first, t_small, t_large), t_far = PSEL_F(small_first, t_large, t_small);
    pint near_ok = PSEL_I(small_first, c_ok, (pint)(-1)), far_ok = PSEL_I(small_first, (pint)(-1), c_ok);
    pint hit_near = m & near_ok & (t_near > pr->tmin) & (t_near < tmax);
    pint hit_far = m & ~hit_near & far_ok & (t_far > pr->tmin) & (t_far < tmax);
    *t = PSEL_F(hit_near, t_near, t_far);
    return hit_near | hit_far;
}

#endif
