#line 2 "geometry/cylinder.h"
/* Ray/cylinder intersection and the cylinder's texture mapping: the lecture's
 * partial open cylinder x = r cos(theta), y = r sin(theta), z in [z_min, z_max],
 * theta in [theta_min, theta_max], in the frame (origin; x = axis_x, z = axis_z,
 * y = z x x). No caps; both sides can be hit.
 *
 * Intersection: the quadratic |f_perp + t d_perp|^2 = r^2 of the ray's
 * components across the axis (f = org - origin; pbrt-v4 Cylinder::BasicIntersect
 * writes it in the frame), solved as Haines et al. solve the sphere's ("Precision
 * Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7, 2019):
 * disc = r^2 - l^2 from the distance l between the axis and the ray's line,
 * then the stable roots t0 = c/q, t1 = q/a. It is computed in world space, not
 * in the frame: l |d_perp| = (f x dir) . axis_z with f carried exactly as a
 * TwoSum pair and f x dir by Kahan's FMA algorithm (core/accurate.h): for a ray aimed
 * at the cylinder f x dir is small, and the decision and the hit point keep an
 * accuracy of about u r however far the origin is (rotating f into the frame
 * first would cost u |f|, see sphere.h). The hit points come from the closest
 * approach of the two lines -- radial part w (dir x axis_z) / a, axial
 * coordinate (f x dir).(axis_z x dir) / a -- plus or minus the half chord
 * sqrt(disc / a) along dir, not from org + t dir. Rays nearly parallel to the
 * axis take another route (cylinder_ray).
 *
 * A root whose point lies outside the z or theta range is not a hit and the
 * ray goes on to the other root (the far wall's inside). theta = atan2(y, x) -
 * theta_min is reduced modulo 2pi into [0, 2pi] before the comparison with
 * theta_max - theta_min, so a range may start anywhere ([-0.5, 1.0], [5.5, 7.0],
 * [0, 2pi]).
 *
 * Texture mapping (lecture): s = (theta - theta_min) / (theta_max - theta_min),
 * t = (z - z_min) / (z_max - z_min), uv = (s, t); dpdu = (theta_max -
 * theta_min) dP/dtheta, dpdv = (z_max - z_min) axis_z, so that dpdu x dpdv
 * points outward (away from the axis) like ng. */
#ifndef TEXRAY_CYLINDER_H
#define TEXRAY_CYLINDER_H
#include "core/transcendental.h"
#include "geometry/hit.h"
#include "core/quadratic.h"

/* What intersection and geometry derive from the ray. */
typedef struct {
    float3 d_perp;         /* dir's component across the axis */
    float3 radial_mid;     /* closest approach to the axis: its offset from the axis */
    float a, b, c;         /* the quadratic a t^2 + 2 b t + c, c = |f_perp|^2 - r^2 */
    float c_err;           /* bound on c's rounding error */
    float disc;            /* r^2 - l^2 */
    float dz;              /* dir . axis_z */
    float z_mid;           /* axial coordinate of the closest approach (aimed rays) */
    float fz;              /* f . axis_z (other rays) */
    int aimed;             /* which of the two: see cylinder_ray */
    QuadRoots roots;       /* sorted; not ok: the surface the ray starts on (see below) */
} CylRay;

/* Two ways to the signed distance w = l |d_perp| and to the hit's axial
 * coordinate, each accurate where the other is not:
 * - w = (f x dir) . axis_z, z = z_mid +- h dz, for rays aimed at the cylinder
 *   from afar: f x dir is small (|f| sin(f, dir)), and its rounding too;
 * - w = f . (dir x axis_z), z = f . axis_z + t dz, for rays nearly parallel to
 *   the axis, where the closest approach of the two lines runs away (z_mid is
 *   then large and cancels against h dz) and dir x axis_z is small.
 * The first is used when |f x dir| <= |f| |dir x axis_z| (the direction is
 * closer to f's than to the axis'): its error u |f x dir| is then the smaller. */
inline CylRay cylinder_ray(__global const Cylinder* cy, float3 org, float3 dir)
{
    float4 o = cylinder_origin_radius(cy);
    float3 az = cylinder_axis_z(cy);
    float r = o.w;
    float3 fh, fl;
    tx_two_diff3(org, o.xyz, &fh, &fl);
    float3 d_cross_z = tx_cross_accurate(dir, az);
    float3 f_cross_d = tx_cross_accurate(fh, dir) + cross3(fl, dir);   /* |fl| <= u |fh|: plain is enough */
    float3 f_cross_z = tx_cross_accurate(fh, az) + cross3(fl, az);     /* f_perp turned a right angle */
    CylRay c;
    c.dz = dot3(dir, az);
    c.d_perp = dir - c.dz * az;
    c.a = dot3(d_cross_z, d_cross_z);
    c.aimed = dot3(f_cross_d, f_cross_d) <= dot3(fh, fh) * c.a;
    float w = c.aimed ? dot3(f_cross_d, az) : dot3(fh, d_cross_z) + dot3(fl, d_cross_z);
    float ff = dot3(f_cross_z, f_cross_z), rr = r * r;
    c.disc = rr - w * w / c.a;
    c.b = dot3(f_cross_z, d_cross_z);                   /* = f_perp . d_perp */
    c.c = ff - rr;
    /* f_cross_z is accurate to 2u per component: |f_perp|^2 to gamma(3) + 4u,
     * r^2 and the subtraction add u each, within gamma(8) (|f_perp|^2 + r^2). */
    c.c_err = gamma_n(8.0f) * (ff + rr);
    c.radial_mid = (w / c.a) * d_cross_z;
    c.z_mid = -dot3(f_cross_d, d_cross_z) / c.a;
    c.fz = dot3(fh, az) + dot3(fl, az);
    c.roots = stable_roots(c.a, c.b, c.c, sqrt(c.a * c.disc), fabs(c.c) > c.c_err);
    return c;
}

/* theta - theta_min of the frame point (x, y), reduced into [0, 2pi]. The
 * float32 reduction can land a hair below 0 (when d / 2pi rounds up to an
 * integer), which is moved up by 2pi: a full cylinder has no crack at theta_min. */
inline float cylinder_theta_rel(float x, float y, float theta_min)
{
    float d = tx_atan2(y, x) - theta_min;
    d -= (2.0f * M_PI_F) * floor(d * (0.5f * M_1_PI_F));
    return d < 0.0f ? d + 2.0f * M_PI_F : d;
}

/* The hit point of root t, the near (side = -1) or the far (side = +1) one,
 * relative to the origin: its offset from the axis (world space) and its
 * axial coordinate. */
static inline float3 cylinder_point(const CylRay* c, float t, float side, float* z)
{
    float h = side * sqrt(TX_MAX(c->disc, 0.0f) / c->a);
    *z = c->aimed ? c->z_mid + h * c->dz : c->fz + t * c->dz;
    return c->radial_mid + h * c->d_perp;
}

/* Whether root t (side -1 near, +1 far) is in (tmin, tmax) and its point in the z and theta ranges. */
static inline int cylinder_in_range(__global const Cylinder* cy, const CylRay* c, float t, float side,
                                    float tmin, float tmax, float span)
{
    if (!(t > tmin && t < tmax)) return 0;
    float3 ax = cylinder_axis_x(cy), az = cylinder_axis_z(cy);
    float z;
    float3 radial = cylinder_point(c, t, side, &z);
    if (!(z >= cy->z_min && z <= cy->z_max)) return 0;
    float x = dot3(radial, ax), y = dot3(radial, cross3(az, ax));
    return cylinder_theta_rel(x, y, cy->theta_min) <= span;
}

/* Nearest hit with t in (tmin, tmax) whose point lies in the z and theta
 * ranges; t in units of dir (not normalized). Radius <= 0, z_max <= z_min,
 * theta_max <= theta_min, a direction parallel to the axis (or zero) and NaN
 * anywhere give a miss. A root within the rounding error of c (the origin is
 * on the surface to float precision) is the surface the ray starts from and
 * is skipped (pbrt-v4 6.8.5 rejects such t likewise). */
inline int cylinder_intersect(__global const Cylinder* cy, float3 org, float3 dir, float tmin, float tmax,
                              float* t)
{
    float r = cy->radius, span = cy->theta_max - cy->theta_min;
    if (!(r > 0.0f && cy->z_max > cy->z_min && span > 0.0f)) return 0;
    CylRay c = cylinder_ray(cy, org, dir);
    if (!(c.a > 0.0f && c.disc >= 0.0f)) return 0;
    if (c.roots.near_ok && cylinder_in_range(cy, &c, c.roots.t_near, -1.0f, tmin, tmax, span)) {
        *t = c.roots.t_near;
        return 1;
    }
    if (c.roots.far_ok && cylinder_in_range(cy, &c, c.roots.t_far, 1.0f, tmin, tmax, span)) {
        *t = c.roots.t_far;
        return 1;
    }
    return 0;
}

/* Whether t (from cylinder_intersect) is the near root: as sphere_root_is_near,
 * t is matched against the same computation's roots; where they are equal,
 * cylinder_intersect took the near one if it was ok and in range. */
static inline int cylinder_root_is_near(__global const Cylinder* cy, const CylRay* c, float t)
{
    if (c->roots.t_near == c->roots.t_far)
        return c->roots.near_ok
            && cylinder_in_range(cy, c, t, -1.0f, -INFINITY, INFINITY, cy->theta_max - cy->theta_min);
    return fabs(t - c->roots.t_near) <= fabs(t - c->roots.t_far);
}

/* dP/du, dP/dv with respect to the cylinder's (u, v) (header comment), at the point
 * whose offset from the axis has coordinates (x, y) in the frame (ax, ay = az x ax, az),
 * |(x, y)| the radius: dpdu = span dP/dtheta = span (x ay - y ax), dpdv = height az
 * (span = theta_max - theta_min, height = z_max - z_min). The one parameterization of
 * the cylinder and of its displaced surface (there at the displaced radius,
 * geometry/displace.h). */
static inline void cylinder_tangents(float x, float y, float span, float height, float3 ax, float3 ay, float3 az,
                                     float3* dpdu, float3* dpdv)
{
    *dpdu = span * (x * ay - y * ax);
    *dpdv = height * az;
}

/* Geometry of the hit at t found by cylinder_intersect: the root's point
 * (cylinder_point; near or far by cylinder_root_is_near), its radial offset
 * projected onto the circle of radius r (pbrt-v4
 * Cylinder::InteractionFromIntersection). Error bound: gamma(7) of the radial
 * offset per component (its length is r to within the rounding of the
 * projection, as for the sphere) plus gamma(2) of the three terms summed into
 * p. The axial coordinate's error moves the point within the surface and is
 * left out, as in pbrt-v4 6.8.5. */
inline void cylinder_geom(__global const Cylinder* cy, float3 org, float3 dir, float t, Geom* g)
{
    float4 o = cylinder_origin_radius(cy);
    float3 ax = cylinder_axis_x(cy), az = cylinder_axis_z(cy);
    float3 ay = cross3(az, ax);
    float r = o.w, z_min = cy->z_min, z_max = cy->z_max;
    float span = cy->theta_max - cy->theta_min;
    CylRay c = cylinder_ray(cy, org, dir);
    float z;
    float3 radial = cylinder_point(&c, t, cylinder_root_is_near(cy, &c, t) ? -1.0f : 1.0f, &z);
    float3 n = tx_unit_or(radial, ax);          /* radial = 0 only for r below rounding */
    radial = r * n;
    float3 axial = z * az;
    g->p = o.xyz + radial + axial;
    g->perr = gamma_n(7.0f) * abs3(radial) + gamma_n(2.0f) * (abs3(o.xyz) + abs3(radial) + abs3(axial));
    g->ng = n;
    float x = dot3(radial, ax), y = dot3(radial, ay);
    float rel = cylinder_theta_rel(x, y, cy->theta_min);
    g->uv = (float2)(clamp(rel / span, 0.0f, 1.0f), clamp((z - z_min) / (z_max - z_min), 0.0f, 1.0f));
    cylinder_tangents(x, y, span, z_max - z_min, ax, ay, az, &g->dpdu, &g->dpdv);
}

#endif
