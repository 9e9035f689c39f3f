#line 2 "shading/light_packet.h"
/* light_term (shading/light.h) for a chunk's samples as one vector computation
 * (stages/fused.cl with packets): each lane's surface, view vector, light and intensity
 * gathered straight into vectors, light_term's float operations over one floatN per
 * coordinate in its order and with its roundings (contraction off as there; dot3 and the
 * specular power as core/common.h and core/builtins.h compile them: accel/packet_vec.h),
 * each early return (an intensity not finite, a light at the point, N.L <= 0, a specular
 * power out of range) a lane mask. Every lane adds light_term's value bit for bit
 * (tests/kernels/test_packet.py). Lane by lane it was 9-10% of the frame (perf, globe and
 * textured meshes).
 *
 * On PoCL only (TX_LIGHT_PACKET): the power uses core/builtins.h's exp2 and log2, which
 * PoCL alone gets; other devices' vector divisions and square roots need not round as their
 * scalar ones do (Intel's runtime: geometry/triangle_packet.h). */
#ifndef TEXRAY_LIGHT_PACKET_H
#define TEXRAY_LIGHT_PACKET_H
#include "shading/light.h"
#include "accel/packet.h"
#include "accel/packet_vec.h"

#if TX_PACKET && TX_POCL
#define TX_LIGHT_PACKET 1

/* clamp_radiance1 (shading/light.h) lane by lane: the same two selects (NaN: TX_MAX_RADIANCE). */
static inline __attribute__((always_inline)) pfloat pf_clamp_radiance(pfloat x)
{
    x = PSEL_F(x <= TX_MAX_RADIANCE, x, (pfloat)(TX_MAX_RADIANCE));
    return PSEL_F(x >= -TX_MAX_RADIANCE, x, (pfloat)(-TX_MAX_RADIANCE));
}

/* light_term for every lane of ok as vectors: the surface point p, its shading normal nrm,
 * kd, ks and shininess, the view vector v, the light lp with its intensity in; the term in
 * the lanes of ok where light_term's is not 0, 0 in every other lane. */
static inline __attribute__((always_inline)) pfloat3 light_term_lanes(pfloat3 p, pfloat3 nrm, pfloat3 kd, pfloat3 ks,
                                                                      pfloat shin, pfloat3 v, pfloat3 lp, pfloat3 in,
                                                                      pint ok)
{
    /* light_term's degenerate cases (shading/light.h), as lane masks */
    ok &= pf3_finite(in);
    pfloat3 l = pf3_sub(lp, p);
    pfloat d2 = pf3_dot(l, l);
    pint scaled = ~((d2 >= FLT_MIN) & (d2 <= FLT_MAX));
    if (any(scaled & ok)) {
        pfloat mx = PMAX(PMAX(fabs(l.x), fabs(l.y)), fabs(l.z));
        ok &= ~scaled | ((mx > 0.0f) & (mx <= FLT_MAX));
        pfloat3 ls = pf3(l.x / mx, l.y / mx, l.z / mx);
        l = pf3_sel(scaled, ls, l);
        d2 = PSEL_F(scaled, pf3_dot(ls, ls), d2);
        in = pf3_sel(scaled, pf3(in.x / mx / mx, in.y / mx / mx, in.z / mx / mx), in);
    }
    l = pf3_scale(rsqrt(d2), l);
    pfloat ndl = pf3_dot(nrm, l);
    ok &= ndl > 0.0f;
    pfloat3 term = pf3_splat((float3)(0.0f));
    if (any(ok)) {
        term = pf3_scale(ndl, kd);
        if (TX_SPECULAR) {
            pfloat3 r = pf3_sub(pf3_scale(2.0f * ndl, nrm), l);
            pfloat rv = pf3_dot(r, v);
            pint spec = ok & (rv > 0.0f);
            if (any(spec)) {
                pfloat sp = pf_exp2(shin * pf_log2(rv));
                spec &= (sp >= 0.0f) & (sp <= FLT_MAX);
                term = pf3_sel(spec, pf3_add(term, pf3_scale(sp, ks)), term);
            }
        }
    }
    /* 0 where light_term returns 0 (as the scalar code adds it) */
    return pf3(PSEL_F(ok, in.x * (term.x / d2), (pfloat)(0.0f)), PSEL_F(ok, in.y * (term.y / d2), (pfloat)(0.0f)),
               PSEL_F(ok, in.z * (term.z / d2), (pfloat)(0.0f)));
}

/* c[j] += light_term(s + j, v[j], lpos[j], li[j * li_step]) for every lane j < m with vis[j]
 * (li_step 0: one intensity for every lane): the records gathered into vectors for
 * light_term_lanes. Lanes past m read lane m - 1's inputs; lanes not visible (a miss among
 * them) compute from whatever their records hold, masked off. */
inline void light_term_packet(const Surface* s, const float3* v, const float3* lpos, const float3* li, uint li_step,
                              const uchar* vis, uint m, float3* c)
{
    if (m == 0u) return;
#define TX_LT_J(j) TX_MIN((uint)(j), m - 1u)
#define TX_LT_VIS(j) (vis[TX_LT_J(j)] ? -1 : 0)
    pint ok = (pint)PGATHER(TX_LT_VIS);
    if (!any(ok)) return;
/* a Surface field's three floats as a pfloat3 */
#define TX_LT_SF(j, f) s[TX_LT_J(j)].f
#define TX_LT_S3(f) PGATHER_F3(TX_LT_SF, f)
    pfloat3 t = light_term_lanes(TX_LT_S3(p), TX_LT_S3(ns), TX_LT_S3(kd), TX_LT_S3(ks),
                                 (pfloat)PGATHER_A(TX_LT_SF, shininess), pf3_gather(v, 1u, m),
                                 pf3_gather(lpos, 1u, m), pf3_gather(li, li_step, m), ok);
    /* every visible lane adds its term, 0 where light_term returns 0 (as the scalar code adds) */
    float o[3][TX_PACKET];
    PSTORE(t.x, o[0]); PSTORE(t.y, o[1]); PSTORE(t.z, o[2]);
    for (uint j = 0; j < m; ++j)
        if (vis[j]) c[j] += (float3)(o[0][j], o[1][j], o[2][j]);
#undef TX_LT_J
#undef TX_LT_VIS
#undef TX_LT_SF
#undef TX_LT_S3
}
#else
#define TX_LIGHT_PACKET 0
#endif

#endif
