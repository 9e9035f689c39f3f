#line 2 "geometry/quad_packet.h"
/* geometry/quad.h's quad_intersect_corners for every lane of a ray packet (accel/packet.h):
 * one patch against TX_PACKET rays as floatN arithmetic, for the packet traversals' quad
 * leaves (the bilinear patch test took a quarter of a bump-mapped brick wall's frame, lane
 * by lane); and its quad_geom for a packet's quad hits (quad_geom_packet).
 *
 * The same formulas in the same order as the scalar code, with its roundings (FP
 * contraction off as there; accel/packet_vec.h's helpers round as the scalar ones do). The per-lane choices of
 * the scalar code (the transposition, the roots' order and their acceptance) are lane
 * masks, so each lane's hit, t and (u, v) are quad_intersect_corners', bit for bit
 * (tests/kernels/test_packet.py compares them ray by ray, and every scene's image is
 * unchanged). */
#ifndef TEXRAY_QUAD_PACKET_H
#define TEXRAY_QUAD_PACKET_H
#include "geometry/quad.h"
#include "accel/packet_vec.h"

/* quad_try_root for every lane: lanes of `m` whose root u gives a hit with t in
 * (max(tmin, t_floor), best_t) take it into *best_t, *best_u, *best_v; returns them. */
static inline pint quad_try_root_packet(pint m, pfloat u, pfloat3 q00, pfloat3 q10, pfloat3 w0, pfloat3 w1, pfloat3 e00,
                                        pfloat3 e11, pfloat3 dir, pfloat tmin, pfloat t_floor, pfloat* best_t,
                                        pfloat* best_u, pfloat* best_v)
{
    m &= (u >= 0.0f) & (u <= 1.0f);
    if (!any(m)) return m;
    pfloat3 pa = pf3_add(q00, pf3_scale(u, pf3_sub(q10, q00)));
    pfloat3 pb = pf3_add(e00, pf3_scale(u, pf3_sub(e11, e00)));
    pfloat3 pa_x_dir = pf3_add(w0, pf3_scale(u, pf3_sub(w1, w0)));
    pfloat3 n = pf3_cross(dir, pb);
    pfloat det = pf3_dot(n, n);
    pfloat tn = pf3_dot(n, pf3_cross(pa, pb)), vn = pf3_dot(n, pa_x_dir);
    m &= (det > 0.0f) & (vn >= 0.0f) & (vn <= det);
    pfloat t = tn / det;
    m &= (t > tmin) & (t > t_floor) & (t < *best_t);
    *best_t = PSEL_F(m, t, *best_t);
    *best_u = PSEL_F(m, u, *best_u);
    *best_v = PSEL_F(m, vn / det, *best_v);
    return m;
}

/* quad_intersect_corners(p0, p1, p2, p3, org, dir, tmin, tmax) for the lanes m of the
 * packet, tmax per lane: the lanes with a hit; their t and uv into *t, *u, *v. */
inline pint quad_intersect_packet(const PacketRay* r, float3 c0, float3 c1, float3 c2, float3 c3, pint m,
                                  pfloat tmax, pfloat* t, pfloat* u, pfloat* v)
{
    pfloat3 org = pf3(r->ox, r->oy, r->oz), dir = pf3(r->dx, r->dy, r->dz);
    pfloat3 eu = pf3_splat((c1 - c0) + (c2 - c3)), ev = pf3_splat((c3 - c0) + (c2 - c1));
    pfloat3 du = pf3_cross(dir, eu), dv = pf3_cross(dir, ev);
    pint swap = pf3_dot(dv, dv) / pf3_dot(ev, ev) < pf3_dot(du, du) / pf3_dot(eu, eu);
    pfloat3 p0 = pf3_splat(c0), p2 = pf3_splat(c2);
    pfloat3 p1 = pf3_sel(swap, pf3_splat(c3), pf3_splat(c1)), p3 = pf3_sel(swap, pf3_splat(c1), pf3_splat(c3));
    pfloat3 q00, q10, l00, l10;
    pf3_two_diff(p0, org, &q00, &l00);
    pf3_two_diff(p1, org, &q10, &l10);
    pfloat3 w0 = pf3_add(pf3_cross_accurate(q00, dir), pf3_cross(l00, dir));
    pfloat3 w1 = pf3_add(pf3_cross_accurate(q10, dir), pf3_cross(l10, dir));
    pfloat3 e00 = pf3_sub(p3, p0), e11 = pf3_sub(p2, p1);
    pfloat k2 = pf3_dot(pf3_cross(pf3_sub(p1, p0), pf3_sub(p3, p2)), dir);
    pfloat k0 = pf3_dot(w0, e00);
    pfloat k1 = pf3_dot(w1, e11) - k0 - k2;
    pfloat b = 0.5f * k1;
    pfloat disc = pf_diff_prod(b, b, k2, k0);                 /* quadratic_disc */
    m &= disc >= 0.0f;
    if (!any(m)) return m;
    /* stable_roots(k2, b, k0, sqrt(disc), 1) */
    pfloat q = -(b + copysign(sqrt(disc), b));
    pfloat t_small = k0 / q, t_large = q / k2;
    pint small_first = t_small <= t_large;
    pfloat t_near = PSEL_F(small_first, t_small, t_large), t_far = PSEL_F(small_first, t_large, t_small);
    pfloat3 mx = pf3_max(pf3_max(pf3_abs(q00), pf3_abs(q10)), pf3_max(pf3_abs(pf3_sub(p2, org)),
                                                                      pf3_abs(pf3_sub(p3, org))));
    pfloat t_floor = gamma_n(8.0f) * PMAX(PMAX(mx.x, mx.y), mx.z) * rsqrt(pf3_dot(dir, dir));
    pfloat bt = tmax, bu = (pfloat)(0.0f), bv = (pfloat)(0.0f);
    pint hit = quad_try_root_packet(m, t_near, q00, q10, w0, w1, e00, e11, dir, r->tmin, t_floor, &bt, &bu, &bv);
    hit |= quad_try_root_packet(m, t_far, q00, q10, w0, w1, e00, e11, dir, r->tmin, t_floor, &bt, &bu, &bv);
    *t = bt;
    *u = PSEL_F(swap, bv, bu);
    *v = PSEL_F(swap, bu, bv);
    return hit;
}

/* quad_geom(quads + idx[j], quad_shade + idx[j], (u_j, v_j), g + j) for the lanes j of m
 * (each lane's own quad, gathered), with quad_texcoords and reparam_tangents, as floatN
 * arithmetic: each lane's Geom quad_geom's bit for bit (tests/kernels/test_packet.py); the
 * other lanes' g are left as they were. */
inline void quad_geom_packet(__global const QuadVerts* quads, __global const QuadShade* quad_shade, const uint* idx,
                             pint m, pfloat u, pfloat v, Geom* g, GeomLanes* gl)
{
    int ml[TX_PACKET];
    PSTORE(m, ml);
    uint k0 = packet_first_lane(ml);                /* the other lanes read its quad */
    pfloat3 p0, p1, p2, p3;
    pfloat t0x, t0y, t1x, t1y, t2x, t2y, t3x, t3y;
    if (packet_one_index(ml, idx, k0)) {            /* every lane on one quad (a wall, a floor): read once */
        uint i = idx[k0];
        __global const QuadVerts* qv = quads + i;
        __global const float* t = quad_shade[i].uv;
        p0 = pf3_splat(quad_p0(qv)); p1 = pf3_splat(quad_p1(qv));
        p2 = pf3_splat(quad_p2(qv)); p3 = pf3_splat(quad_p3(qv));
        t0x = (pfloat)(t[0]); t0y = (pfloat)(t[1]); t1x = (pfloat)(t[2]); t1y = (pfloat)(t[3]);
        t2x = (pfloat)(t[4]); t2y = (pfloat)(t[5]); t3x = (pfloat)(t[6]); t3y = (pfloat)(t[7]);
    } else {
        float lp[12][TX_PACKET], lt[8][TX_PACKET];
        for (uint j = 0; j < (uint)TX_PACKET; ++j) {
            uint i = idx[ml[j] ? j : k0];
            __global const QuadVerts* qv = quads + i;
            float3 c[4] = { quad_p0(qv), quad_p1(qv), quad_p2(qv), quad_p3(qv) };
            for (int k = 0; k < 4; ++k) { lp[3 * k][j] = c[k].x; lp[3 * k + 1][j] = c[k].y; lp[3 * k + 2][j] = c[k].z; }
            for (int k = 0; k < 8; ++k) lt[k][j] = quad_shade[i].uv[k];
        }
#define TX_QG_P(k) pf3(PLOAD(lp[3 * (k)]), PLOAD(lp[3 * (k) + 1]), \
                       PLOAD(lp[3 * (k) + 2]))
        p0 = TX_QG_P(0); p1 = TX_QG_P(1); p2 = TX_QG_P(2); p3 = TX_QG_P(3);
#undef TX_QG_P
        t0x = PLOAD(lt[0]); t0y = PLOAD(lt[1]); t1x = PLOAD(lt[2]);
        t1y = PLOAD(lt[3]); t2x = PLOAD(lt[4]); t2y = PLOAD(lt[5]);
        t3x = PLOAD(lt[6]); t3y = PLOAD(lt[7]);
    }
    pfloat omv = 1.0f - v, omu = 1.0f - u;
    pfloat3 pu = pf3_add(pf3_scale(omv, pf3_sub(p1, p0)), pf3_scale(v, pf3_sub(p2, p3)));
    pfloat3 pv = pf3_add(pf3_scale(omu, pf3_sub(p3, p0)), pf3_scale(u, pf3_sub(p2, p1)));
    pfloat3 a = pf3_add(p0, pf3_scale(u, pf3_sub(p1, p0))), b = pf3_add(p3, pf3_scale(u, pf3_sub(p2, p3)));
    pfloat3 p = pf3_add(a, pf3_scale(v, pf3_sub(b, a)));
    pfloat3 pm = pf3_max(pf3_max(pf3_abs(p0), pf3_abs(p1)), pf3_max(pf3_abs(p2), pf3_abs(p3)));
    pfloat e = gamma_n(6.0f) * PMAX(PMAX(pm.x, pm.y), pm.z);
    pfloat3 zero = pf3_splat((float3)(0.0f));
    pfloat3 n = pf3_cross(pf3_unit_or(pu, zero), pf3_unit_or(pv, zero));
    pfloat3 nm = pf3_cross(pf3_sub(p2, p0), pf3_sub(p3, p1));           /* the fallbacks (quad_geom) */
    pfloat3 n1 = pf3_cross(pf3_sub(p1, p0), pf3_sub(p2, p0)), n2 = pf3_cross(pf3_sub(p2, p0), pf3_sub(p3, p0));
    pfloat3 nt = pf3_sel(pf3_dot(n1, n1) >= pf3_dot(n2, n2), n1, n2);
    nm = pf3_sel(PMAX(PMAX(fabs(nm.x), fabs(nm.y)), fabs(nm.z)) > 0.0f, nm, nt);
    n = pf3_sel(pf3_dot(n, n) > 9.094947e-13f, n, nm);
    pfloat3 ng = pf3_unit_or(n, pf3_splat((float3)(0.0f, 0.0f, 1.0f)));
    /* quad_texcoords */
    pfloat tax = t0x + u * (t1x - t0x), tay = t0y + u * (t1y - t0y);
    pfloat tbx = t3x + u * (t2x - t3x), tby = t3y + u * (t2y - t3y);
    pfloat gu = tax + v * (tbx - tax), gv = tay + v * (tby - tay);
    pfloat tux = omv * (t1x - t0x) + v * (t2x - t3x), tuy = omv * (t1y - t0y) + v * (t2y - t3y);
    pfloat tvx = omu * (t3x - t0x) + u * (t2x - t1x), tvy = omu * (t3y - t0y) + u * (t2y - t1y);
    /* reparam_tangents(tu, tv, pu, pv): mul_inverse2 where the Jacobian is not singular */
    pfloat det = tux * tvy - tvx * tuy;
    pfloat size = fabs(tux * tvy) + fabs(tvx * tuy);
    pint ok = (fabs(det) > 1.5258789e-05f * size) & (size <= FLT_MAX);
    pfloat inv = 1.0f / det;
    pfloat3 ds = pf3_scale(inv, pf3_sub(pf3_scale(tvy, pu), pf3_scale(tuy, pv)));
    pfloat3 dt = pf3_scale(inv, pf3_sub(pf3_scale(tux, pv), pf3_scale(tvx, pu)));
    geom_store_packet(ml, p, ng, pf3_sel(ok, ds, pu), pf3_sel(ok, dt, pv), gu, gv, pf3(e, e, e), g, gl);
}

#endif
