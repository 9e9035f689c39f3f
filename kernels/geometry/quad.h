#line 2 "geometry/quad.h"
/* Ray/bilinear patch intersection and the patch's texture mapping.
 *
 * The patch (the lecture's quadrilateral) is
 *     P(u, v) = (1-u)(1-v) P0 + u(1-v) P1 + uv P2 + (1-u)v P3,  (u, v) in [0, 1]^2,
 * possibly non-planar, twisted or degenerate.
 *
 * Intersection: Reshetov, "Cool Patches: A Geometric Approach to Ray/Bilinear
 * Patch Intersections" (Ray Tracing Gems, ch. 8, 2019), as in pbrt-v4's
 * IntersectBilinearPatch. For each u the segment from P(u, 0) to P(u, 1) lies on
 * a line; the ray meets that line where the signed volume
 *     f(u) = ((pa(u) - org) x dir) . pb(u),  pa(u) = lerp(P0, P1, u), pb(u) = lerp(P3 - P0, P2 - P1, u)
 * vanishes, a quadratic c2 u^2 + c1 u + c0 (c0 = f(0), c0 + c1 + c2 = f(1),
 * c2 = ((P1 - P0) x (P3 - P2)) . dir). For each root u in [0, 1] the closest
 * points of the ray and the line give t and v.
 *
 * Degenerate cases need no branch: a parallelogram or trapezoid has c2 = 0,
 * where the stable pair of roots u = q / c2, c0 / q (core/quadratic.h, q = -(c1 +
 * sign(c1) sqrt(disc)) / 2) gives one infinite root (rejected) and the linear one;
 * c2 = c1 = 0, or a ray parallel to the line (|dir x pb| = 0), give NaN or
 * infinite values that every range test rejects.
 *
 * Three changes to the published listing, for accuracy:
 * - Which parameter is solved for first. A ray nearly parallel to the v lines
 *   (a grazing ray along them) is nearly coplanar with all of them: f(u) is
 *   then small for every u and the root ill-conditioned (uv errors of 1e-2 at
 *   89.9 degrees from the normal of a saddle, against 6e-5 the other way).
 *   The patch is transposed (P1 and P3 swapped, u and v exchanged) when the
 *   ray is closer to parallel to the mean v edge (P3 - P0) + (P2 - P1) than to
 *   the mean u edge (P1 - P0) + (P2 - P3).
 * - (P0 - org) x dir and (P1 - org) x dir, from which c0, f(1) and the v of
 *   each root follow, use the exact differences (TwoSum pairs) and Kahan's FMA
 *   cross product (core/accurate.h): for a ray aimed at the patch these vectors are
 *   small and so are their errors, so (u, v) keeps ~1e-7 accuracy however far
 *   the origin is (the listing's float32 form loses u |P - org| / size, 1e-3
 *   at 1e4 for a patch of size 1).
 * - The discriminant uses Kahan's difference of products (core/quadratic.h
 *   quadratic_disc), so that nearly double roots (rays near a curved patch's
 *   silhouette) keep their accuracy. */
#ifndef TEXRAY_QUAD_H
#define TEXRAY_QUAD_H
#include "geometry/hit.h"
#include "core/frame.h"
#include "core/quadratic.h"

/* QuadVerts is four float4 (xyz, pad), read by quad_p0..quad_p3: accessors generated
 * from the dtype (texray.device.layout.VECTOR_VIEWS). */

/* The (v, t) of root u (the chapter's second step): the ray org + t dir meets the
 * line pa + v pb (pa = P(u, 0) - org, pb = P(u, 1) - P(u, 0)) where
 *     t = (dir x pb) . (pa x pb) / |dir x pb|^2,  v = (dir x pb) . (pa x dir) / |dir x pb|^2.
 * pa x dir is interpolated from the accurate end values w0 = (P0 - org) x dir,
 * w1 = (P1 - org) x dir (it is linear in u). Updates *best = (t, u, v) and
 * returns 1 when u and v are in [0, 1] and t in (max(tmin, t_floor), best.t). */
static inline int quad_try_root(float u, float3 q00, float3 q10, float3 w0, float3 w1, float3 e00, float3 e11,
                                float3 dir, float tmin, float t_floor, float3* best)
{
    if (!(u >= 0.0f && u <= 1.0f)) return 0;
    float3 pa = q00 + u * (q10 - q00);
    float3 pb = e00 + u * (e11 - e00);
    float3 pa_x_dir = w0 + u * (w1 - w0);
    float3 n = cross3(dir, pb);
    float det = dot3(n, n);
    float tn = dot3(n, cross3(pa, pb)), vn = dot3(n, pa_x_dir);
    if (!(det > 0.0f && vn >= 0.0f && vn <= det)) return 0;
    float t = tn / det;
    if (!(t > tmin && t > t_floor && t < best->x)) return 0;
    *best = (float3)(t, u, vn / det);
    return 1;
}

/* Nearest hit with t in (tmin, tmax), t in units of dir (not normalized); *uv
 * receives the bilinear parameters (u, v) of the hit. NaN anywhere, a zero
 * direction and fully degenerate patches give a miss. A hit closer than
 * gamma(8) of the largest coordinate of the vertices relative to the origin is
 * not reported: those differences are rounded once, and t's few further
 * roundings stay within that bound for non-grazing rays, so such a hit cannot
 * be told from the surface the ray starts on (pbrt-v4 6.8.5's reasoning for
 * triangles). */
TX_LINK_QUAD_TEST int quad_intersect_corners(float3 p0, float3 p1, float3 p2, float3 p3, float3 org, float3 dir, float tmin,
                                  float tmax, float* t, float2* uv)
{
    float3 eu = (p1 - p0) + (p2 - p3), ev = (p3 - p0) + (p2 - p1);
    float3 du = cross3(dir, eu), dv = cross3(dir, ev);
    int swap = dot3(dv, dv) / dot3(ev, ev) < dot3(du, du) / dot3(eu, eu);   /* |dir|^2 sin^2 of each angle */
    if (swap) {
        float3 tmp = p1;
        p1 = p3;
        p3 = tmp;
    }
    float3 q00, q10, l00, l10;
    tx_two_diff3(p0, org, &q00, &l00);
    tx_two_diff3(p1, org, &q10, &l10);
    float3 w0 = tx_cross_accurate(q00, dir) + cross3(l00, dir);   /* |l| <= u |q|: plain is enough */
    float3 w1 = tx_cross_accurate(q10, dir) + cross3(l10, dir);
    float3 e00 = p3 - p0, e11 = p2 - p1;
    float c2 = dot3(cross3(p1 - p0, p3 - p2), dir);
    float c0 = dot3(w0, e00);
    float c1 = dot3(w1, e11) - c0 - c2;
    float b = 0.5f * c1;                               /* core/quadratic.h: half the linear coefficient */
    float disc = quadratic_disc(c2, b, c0);
    if (!(disc >= 0.0f)) return 0;
    QuadRoots u = stable_roots(c2, b, c0, sqrt(disc), 1);
    float3 m = TX_MAX(TX_MAX(abs3(q00), abs3(q10)), TX_MAX(abs3(p2 - org), abs3(p3 - org)));
    float t_floor = gamma_n(8.0f) * TX_MAX(TX_MAX(m.x, m.y), m.z) * rsqrt(dot3(dir, dir));
    float3 best = (float3)(tmax, 0.0f, 0.0f);
    int hit = quad_try_root(u.t_near, q00, q10, w0, w1, e00, e11, dir, tmin, t_floor, &best);
    hit |= quad_try_root(u.t_far, q00, q10, w0, w1, e00, e11, dir, tmin, t_floor, &best);
    if (!hit) return 0;
    *t = best.x;
    *uv = swap ? best.zy : best.yz;
    return 1;
}

/* quad_intersect_corners on a QuadVerts record. The corners version also serves the side
 * patches of displaced meshes' prism shells (geometry/displace.h disp_tri_clip). */
static inline int quad_intersect(__global const QuadVerts* qv, float3 org, float3 dir, float tmin, float tmax,
                                 float* t, float2* uv)
{
    return quad_intersect_corners(quad_p0(qv), quad_p1(qv), quad_p2(qv), quad_p3(qv), org, dir, tmin, tmax, t, uv);
}

/* The patch's texture coordinates at its parameters (u, v) = param into g->uv, and
 * g->dpdu, g->dpdv with respect to them from pu = dP/du, pv = dP/dv: the one
 * parameterization of plain and displaced quads (geometry/displace.h).
 *
 * uv is the bilinear interpolation of the corners' uvs (corner_uv: u0 v0 at P0, u1 v1 at
 * P1, u2 v2 at P2, u3 v3 at P3; QuadShade.uv, Displaced.uv) at (u, v) (lecture). dpdu,
 * dpdv are with respect to them: [dP/ds dP/dt] = [dP/du dP/dv] J^-1 with J = d(s, t)/
 * d(u, v) (core/frame.h reparam_tangents). Where J is singular to float precision, or
 * not finite, dpdu and dpdv are the derivatives with respect to the bilinear (u, v)
 * instead. With a mirrored texture (det J < 0) dpdu x dpdv points opposite ng. */
static inline void quad_texcoords(__global const float* corner_uv, float2 param, float3 pu, float3 pv, Geom* g)
{
    float u = param.x, v = param.y;
    __global const float* t = corner_uv;
    float2 t0 = (float2)(t[0], t[1]), t1 = (float2)(t[2], t[3]);
    float2 t2 = (float2)(t[4], t[5]), t3 = (float2)(t[6], t[7]);
    float2 ta = t0 + u * (t1 - t0), tb = t3 + u * (t2 - t3);
    g->uv = ta + v * (tb - ta);
    float2 tu = (1.0f - v) * (t1 - t0) + v * (t2 - t3);    /* d(s, t)/du */
    float2 tv = (1.0f - u) * (t3 - t0) + u * (t2 - t1);    /* d(s, t)/dv */
    if (!reparam_tangents(tu, tv, pu, pv, &g->dpdu, &g->dpdv)) {
        g->dpdu = pu;
        g->dpdv = pv;
    }
}

/* Geometry at the bilinear parameters (u, v) of a hit.
 *
 * p = P(u, v); dP/du = lerp(P1 - P0, P2 - P3, v), dP/dv = lerp(P3 - P0, P2 - P1, u)
 * (pbrt-v4 BilinearPatch::InteractionFromIntersection); error bound gamma(6)
 * times the largest vertex coordinate (pbrt-v4).
 *
 * ng = normalize(dP/du x dP/dv). Where that cross product is rounding noise
 * (below 2^-20 of |dP/du| |dP/dv| after scaling both to unit size, i.e. a few
 * roundings of its components: a corner where two edges are collinear, the
 * fold of a bow-tie), ng falls back to the patch's mean normal (P2 - P0) x
 * (P3 - P1), then to the larger of the normals of triangles (P0, P1, P2) and
 * (P0, P2, P3), then to +z (all four vertices collinear: no normal exists).
 *
 * Texture coordinates: quad_texcoords. */
TX_LINK_PACKET_KINDS void quad_geom(__global const QuadVerts* qv, __global const QuadShade* qs, float2 param_uv, Geom* g)
{
    float u = param_uv.x, v = param_uv.y;
    float3 p0 = quad_p0(qv), p1 = quad_p1(qv), p2 = quad_p2(qv), p3 = quad_p3(qv);
    float3 pu = (1.0f - v) * (p1 - p0) + v * (p2 - p3);
    float3 pv = (1.0f - u) * (p3 - p0) + u * (p2 - p1);
    float3 a = p0 + u * (p1 - p0), b = p3 + u * (p2 - p3);
    g->p = a + v * (b - a);
    float3 pm = TX_MAX(TX_MAX(abs3(p0), abs3(p1)), TX_MAX(abs3(p2), abs3(p3)));
    g->perr = gamma_n(6.0f) * (float3)(TX_MAX(TX_MAX(pm.x, pm.y), pm.z));

    float3 zero = (float3)(0.0f);
    float3 n = cross3(tx_unit_or(pu, zero), tx_unit_or(pv, zero));
    if (!(dot3(n, n) > 9.094947e-13f)) {              /* (2^-20)^2 */
        n = cross3(p2 - p0, p3 - p1);
        if (!(TX_MAX(TX_MAX(fabs(n.x), fabs(n.y)), fabs(n.z)) > 0.0f)) {
            float3 n1 = cross3(p1 - p0, p2 - p0), n2 = cross3(p2 - p0, p3 - p0);
            n = dot3(n1, n1) >= dot3(n2, n2) ? n1 : n2;
        }
    }
    g->ng = tx_unit_or(n, (float3)(0.0f, 0.0f, 1.0f));

    quad_texcoords(qs->uv, param_uv, pu, pv, g);
}

#endif
