#line 2 "geometry/triangle_packet.h"
/* triangle_geom (geometry/triangle.h) for a packet's triangle hits: each lane's own
 * triangle gathered, then the point, its error bound, the geometric normal, uv and the
 * texture-coordinate tangents as one floatN computation per coordinate. The same formulas
 * in the same order as the scalar code with its roundings (FP contraction off, as in
 * triangle.h and core/frame.h; dot3, cross3 and normalize3 as core/common.h compiles them,
 * accel/packet_vec.h), the scalar code's branches as lane selects (the overflowing edge
 * product's scaled edges, normalize3's scaled path, reparam_tangents' singular fallback), so
 * each lane's Geom is triangle_geom's bit for bit (tests/kernels/test_packet.py). Done lane
 * by lane it was 6.5% of the textured meshes' frame (perf, 2026-12-05), a division and a
 * square root per normal and a division per hit among its scalar operations.
 * On PoCL only (TX_TRI_GEOM_PACKET, stages/fused.cl): Intel's runtime, where the
 * portability tests force packets, rounds its vector divisions and square roots apart from
 * its scalar ones, and the scalar geometry keeps its images those of its scalar path. */
#ifndef TEXRAY_TRIANGLE_PACKET_H
#define TEXRAY_TRIANGLE_PACKET_H
#include "geometry/triangle.h"
#include "accel/packet_vec.h"

/* triangle_geom(tris + idx[j], tri_shade + idx[j], b1_j, b2_j, uvs, g + j) for the lanes j of
 * m; the other lanes' g are left as they were. */
inline void triangle_geom_packet(__global const TriVerts* tris, __global const TriShade* tri_shade,
                                 __global const float* uvs, const uint* idx, pint m, pfloat b1, pfloat b2, Geom* g, GeomLanes* gl)
{
    int ml[TX_PACKET];
    PSTORE(m, ml);
    uint k0 = packet_first_lane(ml);                /* the other lanes read its triangle */
    pfloat3 p0, p1, p2;
    pfloat t0x, t0y, t1x, t1y, t2x, t2y;
    if (packet_one_index(ml, idx, k0)) {            /* every lane on one triangle: read once */
        uint i = idx[k0];
        __global const TriVerts* tv = tris + i;
        p0 = pf3_splat(tri_p0(tv)); p1 = pf3_splat(tri_p1(tv)); p2 = pf3_splat(tri_p2(tv));
        float2 t0, t1, t2;
        tri_corner_uvs(tri_shade + i, uvs, &t0, &t1, &t2);
        t0x = (pfloat)(t0.x); t0y = (pfloat)(t0.y); t1x = (pfloat)(t1.x);
        t1y = (pfloat)(t1.y); t2x = (pfloat)(t2.x); t2y = (pfloat)(t2.y);
    } else {
        float lp[9][TX_PACKET], lt[6][TX_PACKET];
        for (uint j = 0; j < (uint)TX_PACKET; ++j) {
            uint i = idx[ml[j] ? j : k0];
            __global const TriVerts* tv = tris + i;
            float3 c[3] = { tri_p0(tv), tri_p1(tv), tri_p2(tv) };
            for (int k = 0; k < 3; ++k) { lp[3 * k][j] = c[k].x; lp[3 * k + 1][j] = c[k].y; lp[3 * k + 2][j] = c[k].z; }
            float2 t0, t1, t2;
            tri_corner_uvs(tri_shade + i, uvs, &t0, &t1, &t2);
            lt[0][j] = t0.x; lt[1][j] = t0.y; lt[2][j] = t1.x; lt[3][j] = t1.y; lt[4][j] = t2.x; lt[5][j] = t2.y;
        }
        /* one vector load (PLOAD) each, though it spans the lanes' scalar stores just made
         * (not forwarded to it: it waits for them; frames within noise): built lane by lane
         * (TX_LANES), these vectors and the other kinds' were a tenth of a cold build's
         * instructions (accel/packet.h) */
#define TX_TG_P(k) pf3(PLOAD(lp[3 * (k)]), PLOAD(lp[3 * (k) + 1]), \
                       PLOAD(lp[3 * (k) + 2]))
        p0 = TX_TG_P(0); p1 = TX_TG_P(1); p2 = TX_TG_P(2);
#undef TX_TG_P
        t0x = PLOAD(lt[0]); t0y = PLOAD(lt[1]); t1x = PLOAD(lt[2]);
        t1y = PLOAD(lt[3]); t2x = PLOAD(lt[4]); t2y = PLOAD(lt[5]);
    }
    pfloat b0 = 1.0f - b1 - b2;
    pfloat3 e1 = pf3_sub(p1, p0), e2 = pf3_sub(p2, p0);
    pfloat3 q0 = pf3_scale(b0, p0), q1 = pf3_scale(b1, p1), q2 = pf3_scale(b2, p2);
    pfloat3 p = pf3_add(pf3_add(q0, q1), q2);
    pfloat3 perr = pf3_scale((pfloat)(gamma_n(7.0f)), pf3_add(pf3_add(pf3_abs(q0), pf3_abs(q1)), pf3_abs(q2)));
    pfloat3 nc = pf3_cross(e1, e2);
    pint fin = pf3_finite(nc);
    if (!all(fin | ~m)) {               /* edges beyond 2^64: the scaled edges' product */
        pfloat m1 = PMAX(PMAX(fabs(e1.x), fabs(e1.y)), fabs(e1.z)), m2 = PMAX(PMAX(fabs(e2.x), fabs(e2.y)), fabs(e2.z));
        nc = pf3_sel(fin, nc, pf3_cross(pf3(e1.x / m1, e1.y / m1, e1.z / m1), pf3(e2.x / m2, e2.y / m2, e2.z / m2)));
    }
    pfloat3 ng = pf3_normalize3(nc);
    pfloat u = b0 * t0x + b1 * t1x + b2 * t2x, v = b0 * t0y + b1 * t1y + b2 * t2y;
    /* reparam_tangents(uv1 - uv0, uv2 - uv0, e1, e2) (core/frame.h) */
    pfloat jux = t1x - t0x, juy = t1y - t0y, jvx = t2x - t0x, jvy = t2y - t0y;
    pfloat det = jux * jvy - jvx * juy;
    pfloat size = fabs(jux * jvy) + fabs(jvx * juy);
    pint ok = (fabs(det) > 1.5258789e-05f * size) & (size <= FLT_MAX);
    pfloat inv = 1.0f / det;
    pfloat3 dpdu = pf3_scale(inv, pf3_sub(pf3_scale(jvy, e1), pf3_scale(juy, e2)));
    pfloat3 dpdv = pf3_scale(inv, pf3_sub(pf3_scale(jux, e2), pf3_scale(jvx, e1)));
    if (!all(ok | ~m)) {                /* singular: any_tangent(ng) and ng x it (core/frame.h) */
        pfloat zero = (pfloat)(0.0f);
        pint xz = fabs(ng.x) > fabs(ng.z);
        pfloat3 a = pf3_normalize3(pf3(PSEL_F(xz, -ng.y, zero), PSEL_F(xz, ng.x, -ng.z), PSEL_F(xz, zero, ng.y)));
        dpdu = pf3_sel(ok, dpdu, a);
        dpdv = pf3_sel(ok, dpdv, pf3_cross(ng, a));
    }
    geom_store_packet(ml, p, ng, dpdu, dpdv, u, v, perr, g, gl);
}

#endif
