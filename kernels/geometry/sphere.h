#line 2 "geometry/sphere.h"
/* Ray/sphere intersection and the sphere's texture mapping.
 *
 * Intersection: Haines, Guenther, Akenine-Moller, "Precision Improvements for
 * Ray/Sphere Intersection" (Ray Tracing Gems, ch. 7, 2019): the discriminant
 * comes from the squared distance l^2 between the centre and the ray, not from
 * b^2 - 4ac, and the roots from the stable pair t0 = c/q, t1 = q/a. Here l^2 is
 * computed through Lagrange's identity |f - (f.d^)d^|^2 = |f x d|^2 / |d|^2 with
 * the cross product by Kahan's FMA algorithm, and f = org - centre is carried
 * exactly as a TwoSum pair (core/accurate.h). That removes the two float32 roundings the
 * chapter's vector form keeps, each of size u |f|: for a sphere of radius r
 * seen from a distance |f|, they shift the decision by about u |f| / r of the
 * radius, i.e. by half the radius for r = 1e-3 at 1e4; with them removed the
 * decision is exact to a few ulp of l whatever the distance.
 *
 * Texture mapping: geometry/spherical.h sphere_uv (the lecture's sphere, and
 * pbrt-v4 Sphere) in the frame x = axis_x, z = axis_z, y = z x x. */
#ifndef TEXRAY_SPHERE_H
#define TEXRAY_SPHERE_H
#include "core/transcendental.h"
#include "geometry/hit.h"
#include "geometry/spherical.h"
#include "core/quadratic.h"

/* Sphere is read as float4 words by sphere_center_radius, sphere_axis_x, sphere_axis_z:
 * accessors generated from the dtype (texray.device.layout.VECTOR_VIEWS). */

/* c = |f|^2 - r^2 for f = fh + fl, to a few ulp of c even where the origin is
 * near the surface and the two terms nearly cancel (the near root c/q then keeps
 * its relative accuracy): the squares are split exactly with FMA (TwoProduct)
 * and summed with TwoSum, as in Ogita, Rump, Oishi, "Accurate Sum and Dot
 * Product" (SIAM J. Sci. Comput. 26(6), 2005), Dot2. The error is at most
 * u |c| + gamma(6)^2 (|fh|^2 + r^2) (the same paper's bound, with the dropped
 * |fl|^2 and the rounding of 2 fh.fl, both below 8 u^2 |fh|^2). */
static inline float sphere_c(float3 fh, float3 fl, float r)
{
    float sx = fh.x * fh.x, sy = fh.y * fh.y, sz = fh.z * fh.z, rr = r * r;
    float err = fma(fh.x, fh.x, -sx) + fma(fh.y, fh.y, -sy) + fma(fh.z, fh.z, -sz) - fma(r, r, -rr)
              + 2.0f * dot3(fh, fl);
    float s = tx_two_sum(sx, sy, &err);
    s = tx_two_sum(s, sz, &err);
    s = tx_two_sum(s, -rr, &err);
    return s + err;
}

/* What intersection and geometry derive from the ray: f = org - centre as
 * fh + fl, w = f x dir (accurate), a = |dir|^2, disc = r^2 - l^2 (l the distance
 * from the centre to the ray's line) and the two roots, sorted. A root is not
 * `ok` when c is within twice its error bound (sphere_c) of 0: the origin then
 * lies on the sphere to float precision, and the root c/q is the surface the
 * ray starts from, not a hit (pbrt-v4 6.8.5 rejects such t likewise). */
typedef struct {
    float3 fh, fl, w;
    float a, disc;
    QuadRoots roots;
} SphereRay;

TX_LINK_PACKET_KINDS SphereRay sphere_ray(float3 centre, float r, float3 org, float3 dir)
{
    SphereRay s;
    tx_two_diff3(org, centre, &s.fh, &s.fl);
    s.a = dot3(dir, dir);
    s.w = tx_cross_accurate(s.fh, dir) + cross3(s.fl, dir);   /* |fl| <= u |fh|: plain is enough */
    s.disc = r * r - dot3(s.w, s.w) / s.a;
    float b = dot3(s.fh, dir);                                /* half the linear coefficient */
    float c = sphere_c(s.fh, s.fl, r);
    float g6 = gamma_n(6.0f);
    int c_ok = fabs(c) > 2.0f * g6 * g6 * (dot3(s.fh, s.fh) + r * r);
    s.roots = stable_roots(s.a, b, c, sqrt(s.a * s.disc), c_ok);
    return s;
}

/* Nearest hit with t in (tmin, tmax), t in units of dir (not normalized).
 * Radius <= 0, a zero direction and NaN anywhere give a miss (every test is
 * written so that NaN fails it). */
TX_LINK_PACKET_KINDS int sphere_intersect(__global const Sphere* s, float3 org, float3 dir, float tmin, float tmax, float* t)
{
    float4 cr = sphere_center_radius(s);
    if (!(cr.w > 0.0f && dot3(dir, dir) > 0.0f)) return 0;
    /* Decided before the cross product and the roots: a ray that starts outside the sphere
     * (c > 0) and leads away from its centre (b > 0), as sphere_ray computes c and b, has
     * q = -(b + root) < 0 there, so both roots c/q and q/a are negative (or -0) whatever
     * the discriminant: a miss for tmin >= 0, the same answer sphere_ray's roots give. This
     * is every shadow ray that leaves a lit sphere toward its light. */
    float3 fh, fl;
    tx_two_diff3(org, cr.xyz, &fh, &fl);
    if (tmin >= 0.0f && dot3(fh, dir) > 0.0f && sphere_c(fh, fl, cr.w) > 0.0f) return 0;
    SphereRay sr = sphere_ray(cr.xyz, cr.w, org, dir);
    if (!(sr.disc >= 0.0f)) return 0;
    if (sr.roots.near_ok && sr.roots.t_near > tmin && sr.roots.t_near < tmax) {
        *t = sr.roots.t_near;
        return 1;
    }
    if (sr.roots.far_ok && sr.roots.t_far > tmin && sr.roots.t_far < tmax) {
        *t = sr.roots.t_far;
        return 1;
    }
    return 0;
}

/* Whether t (from sphere_intersect) is the near root. The two roots of a
 * sphere that is small against its distance can differ by an ulp or round to
 * the same float while their points lie a diameter apart, so t is matched
 * against the same computation's roots (FP_CONTRACT is off: both evaluate
 * identically); where they are equal, sphere_intersect took the near one if it
 * was ok. */
static inline int sphere_root_is_near(const SphereRay* sr, float t)
{
    if (sr->roots.t_near == sr->roots.t_far) return sr->roots.near_ok;
    return fabs(t - sr->roots.t_near) <= fabs(t - sr->roots.t_far);
}

/* dP/du, dP/dv with respect to sphere_uv's (u, v), for the sphere of radius r, at the
 * point (x, y, z) of its frame (ax, ay = az x ax, az), |(x, y, z)| = r, rho = hypot(x,
 * y): the one parameterization of the sphere and of its displaced surface (there at the
 * displaced radius, geometry/displace.h).
 * dpdu = 2pi dP/dphi, dpdv = -pi dP/dtheta, with dP/dphi = (-y, x, 0) and dP/dtheta =
 * (z cos(phi), z sin(phi), -rho) in the frame, so that dpdu x dpdv points outward. At an
 * exact pole (rho = 0) dP/dphi vanishes and phi is undefined: phi is taken as 0 (u = 0),
 * dpdu as 2pi r ay (the dP/dphi direction for phi = 0, scaled to the equator's length)
 * and dpdv = -pi z ax, the limit of dP/dtheta along phi = 0; dpdu x dpdv then still
 * points outward. */
static inline void sphere_tangents(float x, float y, float z, float rho, float r, float3 ax, float3 ay, float3 az,
                                   float3* dpdu, float3* dpdv)
{
    float cos_phi = 1.0f, sin_phi = 0.0f;
    float3 dp_dphi = r * ay;                         /* pole: see above */
    if (rho > 0.0f) {
        cos_phi = x / rho;
        sin_phi = y / rho;
        dp_dphi = x * ay - y * ax;
    }
    float3 dp_dtheta = z * (cos_phi * ax + sin_phi * ay) - rho * az;
    *dpdu = (2.0f * M_PI_F) * dp_dphi;
    *dpdv = -M_PI_F * dp_dtheta;
}

/* Geometry of the hit at t found by sphere_intersect.
 *
 * The point is not org + t dir, whose rounding (u |org + t dir|, and t's own
 * relative error times |f|) can be much larger than the sphere: it is the
 * closest point of the ray to the centre, v = dir x (f x dir) / |dir|^2,
 * plus or minus the half chord sqrt(disc) along dir^, both accurate relative
 * to r; then projected onto the sphere (p = c + r (p - c)/|p - c|) as pbrt-v4
 * does. Error bound, after pbrt-v4 6.8.5: gamma(7) |p - c| per component for
 * the projected offset (its length is r to within the scaling, the squared
 * length's gamma(3) halved by the root, rsqrt's 2 ulp and two products),
 * plus gamma(1) |p| for the final addition of the centre.
 *
 * uv: geometry/spherical.h sphere_uv; dP/du, dP/dv: sphere_tangents. */
TX_LINK_PACKET_KINDS void sphere_geom(__global const Sphere* s, float3 org, float3 dir, float t, Geom* g)
{
    float4 cr = sphere_center_radius(s);
    float3 c = cr.xyz;
    float r = cr.w;
    SphereRay sr = sphere_ray(c, r, org, dir);
    float inv_a = 1.0f / sr.a;
    float half_chord = sqrt(TX_MAX(sr.disc, 0.0f) * inv_a);
    float3 v = cross3(dir, sr.w) * inv_a;             /* closest point, relative to the centre */
    float3 pc = v + (sphere_root_is_near(&sr, t) ? -half_chord : half_chord) * dir;
    float3 n = tx_unit_or(pc, sphere_axis_z(s));      /* pc = 0 only for r below rounding */
    pc = r * n;
    g->p = c + pc;
    g->perr = gamma_n(7.0f) * abs3(pc) + gamma_n(1.0f) * abs3(g->p);
    g->ng = n;

    float3 ax = sphere_axis_x(s), az = sphere_axis_z(s);
    float3 ay = cross3(az, ax);
    float x = dot3(pc, ax), y = dot3(pc, ay), z = dot3(pc, az);
    float rho = tx_hypot(x, y);
    g->uv = sphere_uv(x, y, z, rho);
    sphere_tangents(x, y, z, rho, r, ax, ay, az, &g->dpdu, &g->dpdv);
}

#endif
