#line 2 "geometry/sphere_packet.h"
/* geometry/sphere.h's sphere_intersect for every lane of a ray packet (accel/packet.h):
 * one sphere against TX_PACKET rays as floatN arithmetic, for the packet traversals'
 * sphere leaves (sphere_ray took a seventh of a textured globe's frame, lane by lane);
 * and its sphere_geom for a packet's sphere hits (sphere_geom_packet: with sphere_uv's
 * atan2 and hypot it took a third of the globe's kernel time, lane by lane).
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
static inline pfloat pf_two_sum(pfloat a, pfloat b, pfloat* err)
{
    pfloat s = a + b;
    pfloat bb = s - a;
    *err += (a - (s - bb)) + (b - bb);
    return s;
}

/* sphere_c lane by lane (a radius per lane). */
static inline pfloat sphere_c_packet(pfloat3 fh, pfloat3 fl, pfloat r)
{
    pfloat sx = fh.x * fh.x, sy = fh.y * fh.y, sz = fh.z * fh.z;
    pfloat rr = r * r;
    pfloat err = fma(fh.x, fh.x, -sx) + fma(fh.y, fh.y, -sy) + fma(fh.z, fh.z, -sz) - fma(r, r, -rr)
               + 2.0f * pf3_dot(fh, fl);
    pfloat s = pf_two_sum(sx, sy, &err);
    s = pf_two_sum(s, sz, &err);
    s = pf_two_sum(s, -rr, &err);
    return s + err;
}

/* core/quadratic.h's stable_roots lane by lane: the roots of a t^2 + 2 b t + c (root =
 * sqrt(a disc)), sorted, and whether each may be taken (the small root c/q only where c_ok). */
static inline void stable_roots_packet(pfloat a, pfloat b, pfloat c, pfloat root, pint c_ok, pfloat* t_near,
                                       pfloat* t_far, pint* near_ok, pint* far_ok)
{
    pfloat q = -(b + copysign(root, b));
    pfloat t_small = c / q, t_large = q / a;
    pint small_first = t_small <= t_large;
    *t_near = PSEL_F(small_first, t_small, t_large);
    *t_far = PSEL_F(small_first, t_large, t_small);
    *near_ok = PSEL_I(small_first, c_ok, (pint)(-1));
    *far_ok = PSEL_I(small_first, (pint)(-1), c_ok);
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
    pfloat c = sphere_c_packet(fh, fl, (pfloat)(r));
    m &= ~((pr->tmin >= 0.0f) & (b > 0.0f) & (c > 0.0f));     /* sphere_intersect's early miss */
    if (!any(m)) return m;
    pfloat3 w = pf3_add(pf3_cross_accurate(fh, dir), pf3_cross(fl, dir));
    pfloat disc = r * r - pf3_dot(w, w) / a;
    float g6 = gamma_n(6.0f);
    pint c_ok = fabs(c) > 2.0f * g6 * g6 * (pf3_dot(fh, fh) + r * r);
    m &= disc >= 0.0f;
    if (!any(m)) return m;
    pfloat t_near, t_far;
    pint near_ok, far_ok;
    stable_roots_packet(a, b, c, sqrt(a * disc), c_ok, &t_near, &t_far, &near_ok, &far_ok);
    pint hit_near = m & near_ok & (t_near > pr->tmin) & (t_near < tmax);
    pint hit_far = m & ~hit_near & far_ok & (t_far > pr->tmin) & (t_far < tmax);
    *t = PSEL_F(hit_near, t_near, t_far);
    return hit_near | hit_far;
}

/* core/transcendental.h's tx_atan_poly, tx_atan2 and tx_hypot, and geometry/spherical.h's
 * azimuth_u, lane by lane: the same operations in the same order, the scalar branches as
 * lane selects, so each lane's result is the scalar function's, bit for bit. */
static inline pfloat atan_poly_packet(pfloat a)
{
    pfloat z = a * a;
    return ((((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z
             - 3.33329491539e-1f) * z) * a + a;
}

static inline pfloat atan2_packet(pfloat y, pfloat x)
{
    pint nan = (x != x) | (y != y);
    pfloat ax = fabs(x), ay = fabs(y);
    pint swap = ay > ax;
    pfloat num = PSEL_F(swap, ax, ay), den = PSEL_F(swap, ay, ax);
    pfloat a = PSEL_F(den == 0.0f, (pfloat)(0.0f), PSEL_F(num > FLT_MAX, (pfloat)(1.0f), num / den));
    pfloat r = PSEL_F(a > 0.41421356f, M_PI_4_F + atan_poly_packet((a - 1.0f) / (a + 1.0f)), atan_poly_packet(a));
    r = PSEL_F(swap, M_PI_2_F - r, r);
    r = PSEL_F((as_pint(x) & (pint)(0x80000000)) != (pint)(0), M_PI_F - r, r);     /* x < 0, or x = -0 */
    r = as_pfloat((as_pint(r) & (pint)(0x7fffffff)) | (as_pint(y) & (pint)(0x80000000)));
    return PSEL_F(nan, x + y, r);
}

static inline pfloat hypot_packet(pfloat x, pfloat y)
{
    pfloat ax = fabs(x), ay = fabs(y);
    pfloat m = PMAX(ax, ay);
    pfloat plain = sqrt(ax * ax + ay * ay);
    pfloat s = PSEL_F(m > 1.0f, (pfloat)(8.4703295e-22f), (pfloat)(1.2676506e30f));     /* 2^-70, 2^100 */
    pfloat sx = ax * s, sy = ay * s;
    pfloat scaled = sqrt(sx * sx + sy * sy) / s;
    pfloat r = PSEL_F(m > 0.0f, scaled, ax + ay);                      /* both zero, or a NaN */
    r = PSEL_F((m >= 9.094947e-13f) & (m <= 1.1529215e18f), plain, r);
    return PSEL_F((ax > FLT_MAX) | (ay > FLT_MAX), (pfloat)(INFINITY), r);
}

static inline pfloat azimuth_u_packet(pfloat x, pfloat y)
{
    pfloat phi = atan2_packet(y, x);
    phi = PSEL_F(phi < 0.0f, phi + 2.0f * M_PI_F, phi);
    phi = PSEL_F((x != 0.0f) | (y != 0.0f), phi, (pfloat)(0.0f));
    return PMIN(PMAX(phi * (0.5f * M_1_PI_F), (pfloat)(0.0f)), (pfloat)(TX_ONE_MINUS_ULP));
}

/* sphere_geom(spheres + idx[j], org_j, dir_j, t_j, g + j) for the lanes j of m: the
 * packet's camera rays (org, dir) with their closest hits t on the spheres idx[j] (each
 * lane's own sphere, gathered). sphere_ray, sphere_root_is_near, tx_unit_or, sphere_uv
 * and sphere_tangents as floatN arithmetic, each lane's Geom sphere_geom's bit for bit
 * (tests/kernels/test_packet.py); the other lanes' g are left as they were. */
inline void sphere_geom_packet(__global const Sphere* spheres, const uint* idx, pint m, pfloat3 org, pfloat3 dir,
                               pfloat t, Geom* g, GeomLanes* gl)
{
    int ml[TX_PACKET];
    PSTORE(m, ml);
    uint k0 = packet_first_lane(ml);                /* the other lanes read its sphere */
    pfloat3 c, AX, AZ;
    pfloat r;
    if (packet_one_index(ml, idx, k0)) {            /* every lane on one sphere: read once */
        __global const Sphere* sp = spheres + idx[k0];
        float4 cr = sphere_center_radius(sp);
        c = pf3_splat(cr.xyz);
        r = (pfloat)(cr.w);
        AX = pf3_splat(sphere_axis_x(sp));
        AZ = pf3_splat(sphere_axis_z(sp));
    } else {
        float lc[4][TX_PACKET], lx[3][TX_PACKET], lz[3][TX_PACKET];
        for (uint j = 0; j < (uint)TX_PACKET; ++j) {
            __global const Sphere* sp = spheres + idx[ml[j] ? j : k0];
            float4 cr = sphere_center_radius(sp);
            float3 ax = sphere_axis_x(sp), az = sphere_axis_z(sp);
            lc[0][j] = cr.x; lc[1][j] = cr.y; lc[2][j] = cr.z; lc[3][j] = cr.w;
            lx[0][j] = ax.x; lx[1][j] = ax.y; lx[2][j] = ax.z;
            lz[0][j] = az.x; lz[1][j] = az.y; lz[2][j] = az.z;
        }
        c = pf3(PLOAD(lc[0]), PLOAD(lc[1]), PLOAD(lc[2]));
        r = PLOAD(lc[3]);
        AX = pf3(PLOAD(lx[0]), PLOAD(lx[1]), PLOAD(lx[2]));
        AZ = pf3(PLOAD(lz[0]), PLOAD(lz[1]), PLOAD(lz[2]));
    }
    /* sphere_ray */
    pfloat3 fh, fl;
    pf3_two_diff(org, c, &fh, &fl);
    pfloat a = pf3_dot(dir, dir);
    pfloat3 w = pf3_add(pf3_cross_accurate(fh, dir), pf3_cross(fl, dir));
    pfloat disc = r * r - pf3_dot(w, w) / a;
    pfloat b = pf3_dot(fh, dir);
    pfloat cc = sphere_c_packet(fh, fl, r);
    float g6 = gamma_n(6.0f);
    pint c_ok = fabs(cc) > 2.0f * g6 * g6 * (pf3_dot(fh, fh) + r * r);
    pfloat t_near, t_far;
    pint near_ok, far_ok;
    stable_roots_packet(a, b, cc, sqrt(a * disc), c_ok, &t_near, &t_far, &near_ok, &far_ok);
    /* sphere_root_is_near */
    pint near = PSEL_I(t_near == t_far, near_ok, fabs(t - t_near) <= fabs(t - t_far));
    /* sphere_geom */
    pfloat inv_a = 1.0f / a;
    pfloat half_chord = sqrt(PMAX(disc, (pfloat)(0.0f)) * inv_a);
    pfloat3 v = pf3_scale(inv_a, pf3_cross(dir, w));
    pfloat3 pc = pf3_add(v, pf3_scale(PSEL_F(near, -half_chord, half_chord), dir));
    pfloat3 n = pf3_unit_or(pc, AZ);
    pc = pf3_scale(r, n);
    pfloat3 p = pf3_add(c, pc);
    pfloat3 perr = pf3_add(pf3_scale((pfloat)(gamma_n(7.0f)), pf3_abs(pc)), pf3_scale((pfloat)(gamma_n(1.0f)), pf3_abs(p)));
    pfloat3 AY = pf3_cross(AZ, AX);
    pfloat x = pf3_dot(pc, AX), y = pf3_dot(pc, AY), z = pf3_dot(pc, AZ);
    pfloat rho = hypot_packet(x, y);
    pfloat gu = azimuth_u_packet(x, y);                                       /* sphere_uv */
    pfloat gv = PMAX(1.0f - atan2_packet(rho, z) * M_1_PI_F, (pfloat)(0.0f));
    pint pos = rho > 0.0f;                                                    /* sphere_tangents */
    pfloat cos_phi = PSEL_F(pos, x / rho, (pfloat)(1.0f)), sin_phi = PSEL_F(pos, y / rho, (pfloat)(0.0f));
    pfloat3 dp_dphi = pf3_sel(pos, pf3_sub(pf3_scale(x, AY), pf3_scale(y, AX)), pf3_scale(r, AY));
    pfloat3 dp_dtheta = pf3_sub(pf3_scale(z, pf3_add(pf3_scale(cos_phi, AX), pf3_scale(sin_phi, AY))),
                                pf3_scale(rho, AZ));
    pfloat3 dpdu = pf3_scale((pfloat)(2.0f * M_PI_F), dp_dphi), dpdv = pf3_scale((pfloat)(-M_PI_F), dp_dtheta);
    geom_store_packet(ml, p, n, dpdu, dpdv, gu, gv, perr, g, gl);
}

#endif
