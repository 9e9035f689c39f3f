#line 2 "cylinder.h"
/* Ray/cylinder intersection and the cylinder's texture mapping: the lecture's
 * partial open cylinder x = r cos(theta), y = r sin(theta), z in [z_min, z_max],
 * theta in [theta_min, theta_max], in the frame (origin; x = axis_x, z = axis_z,
 * y = z x x). No caps; both sides can be hit.
 *
 * Intersection: the 2-D quadratic |(fx, fy) + t (dx, dy)|^2 = r^2 in the
 * frame's xy plane (pbrt-v4 Cylinder::BasicIntersect), solved as for the sphere
 * (Haines et al., Ray Tracing Gems ch. 7): disc = r^2 - l^2 with l the
 * distance from the axis to the projected ray, from the 2-D cross product
 * fx dy - fy dx (Kahan's FMA algorithm, geom.h), then the stable roots
 * t0 = c/q, t1 = q/a. A root whose point lies outside the z or theta range is
 * not a hit, and the ray goes on to the other root (the far wall's inside).
 * theta = atan2(y, x) - theta_min is reduced modulo 2pi into [0, 2pi) before
 * the comparison with theta_max - theta_min, so a range may start anywhere
 * ([-0.5, 1.0], [5.5, 7.0], [0, 2pi]).
 *
 * Texture mapping (lecture): s = (theta - theta_min) / (theta_max - theta_min),
 * t = (z - z_min) / (z_max - z_min), uv = (s, t); dpdu = (theta_max -
 * theta_min) dP/dtheta, dpdv = (z_max - z_min) axis_z, so dpdu x dpdv points
 * outward (away from the axis) like ng.
 *
 * Accuracy: the ray is rotated into the frame with plain dot products, so the
 * hit is located to about u |org - origin| (not u r as for the sphere): a
 * cylinder small against its distance from the ray origin gets uv errors of
 * order u |org - origin| / r (tests/test_primitives.py measures them). */
#ifndef TEXRAY_CYLINDER_H
#define TEXRAY_CYLINDER_H

/* The ray in the cylinder's frame, and what the quadratic needs. */
typedef struct {
    float3 f, d;           /* org - origin and dir, in the frame */
    float f_l1;            /* |org - origin| in the 1-norm, world components (error scale of f) */
    float a, w, disc;      /* dx^2 + dy^2, fx dy - fy dx, r^2 - l^2 */
} CylRay;

inline CylRay cylinder_ray(__global const Cylinder* cy, float3 org, float3 dir)
{
    __global const float4* w4 = (__global const float4*)cy;
    float4 o = w4[0];
    float3 ax = w4[1].xyz, az = w4[2].xyz;
    float3 ay = cross3(az, ax);
    float3 f = org - o.xyz;
    CylRay c;
    c.f = (float3)(dot3(f, ax), dot3(f, ay), dot3(f, az));
    c.d = (float3)(dot3(dir, ax), dot3(dir, ay), dot3(dir, az));
    c.f_l1 = fabs(f.x) + fabs(f.y) + fabs(f.z);
    c.a = c.d.x * c.d.x + c.d.y * c.d.y;
    c.w = tx_diff_prod(c.f.x, c.d.y, c.f.y, c.d.x);
    c.disc = o.w * o.w - c.w * c.w / c.a;
    return c;
}

/* theta - theta_min of the frame point (x, y), reduced into [0, 2pi]. The
 * float32 reduction can land a hair below 0 (when d / 2pi rounds up to an
 * integer), which is moved up by 2pi: a full cylinder has no crack at theta_min. */
inline float cylinder_theta_rel(float x, float y, float theta_min)
{
    float d = atan2(y, x) - theta_min;
    d -= (2.0f * M_PI_F) * floor(d * (0.5f * M_1_PI_F));
    return d < 0.0f ? d + 2.0f * M_PI_F : d;
}

/* Whether root t is in (tmin, tmax) and its point in the z and theta ranges. */
inline int cylinder_in_range(const CylRay* c, float t, float tmin, float tmax,
                             float z_min, float z_max, float theta_min, float span)
{
    if (!(t > tmin && t < tmax)) return 0;
    float z = c->f.z + t * c->d.z;
    if (!(z >= z_min && z <= z_max)) return 0;
    return cylinder_theta_rel(c->f.x + t * c->d.x, c->f.y + t * c->d.y, theta_min) <= span;
}

/* Nearest hit with t in (tmin, tmax) whose point lies in the z and theta
 * ranges; t in units of dir (not normalized). Radius <= 0, z_max <= z_min,
 * theta_max <= theta_min, a direction parallel to the axis (or zero) and NaN
 * anywhere give a miss. A root within the rounding error of c (the origin is
 * on the surface to float precision) is the surface the ray starts from and
 * is skipped (pbrt-v4 6.8.5 rejects such t likewise). */
inline int cylinder_intersect(__global const Cylinder* cy, float3 org, float3 dir, float tmin, float tmax, float* t)
{
    float r = cy->radius, z_min = cy->z_min, z_max = cy->z_max;
    float theta_min = cy->theta_min, span = cy->theta_max - cy->theta_min;
    if (!(r > 0.0f && z_max > z_min && span > 0.0f)) return 0;
    CylRay c = cylinder_ray(cy, org, dir);
    if (!(c.a > 0.0f && c.disc >= 0.0f)) return 0;
    float b = c.f.x * c.d.x + c.f.y * c.d.y;
    float ff = c.f.x * c.f.x + c.f.y * c.f.y, rr = r * r;
    float cc = ff - rr;
    /* Bound on cc's error: fx, fy are off by up to gamma(4) |f|_1 each (the
     * subtraction and the rotation), which moves fx^2 + fy^2 by twice that
     * times |fx| + |fy|; the squares, r^2 and the subtraction add gamma(4). */
    float dc = gamma_n(4.0f) * (ff + rr + 2.0f * (fabs(c.f.x) + fabs(c.f.y)) * c.f_l1);
    float q = -(b + copysign(sqrt(c.a * c.disc), b));
    float t_small = cc / q, t_large = q / c.a;     /* |cc/q| <= |q/a| */
    int known_small = fabs(cc) > dc;
    float t_near = TX_MIN(t_small, t_large), t_far = TX_MAX(t_small, t_large);
    int known_near = t_near == t_small ? known_small : 1;
    int known_far = t_far == t_small ? known_small : 1;
    if (known_near && cylinder_in_range(&c, t_near, tmin, tmax, z_min, z_max, theta_min, span)) {
        *t = t_near;
        return 1;
    }
    if (known_far && cylinder_in_range(&c, t_far, tmin, tmax, z_min, z_max, theta_min, span)) {
        *t = t_far;
        return 1;
    }
    return 0;
}

/* Geometry of the hit at t found by cylinder_intersect. The frame point
 * (x, y) = f + t d is projected onto the circle of radius r (pbrt-v4
 * Cylinder::InteractionFromIntersection); z = fz + t dz. Error bound: pbrt-v4's
 * gamma(3) |(x, y, 0)| for the projected point, taken to world space with the
 * rotation's and the origin's roundings (gamma(5) on |x||axis_x| + |y||axis_y|
 * + |z||axis_z|, plus gamma(1) |p|). The error of z along the axis, from t,
 * moves the point within the surface and is left out, as in pbrt-v4. */
inline void cylinder_geom(__global const Cylinder* cy, float3 org, float3 dir, float t, Geom* g)
{
    __global const float4* w4 = (__global const float4*)cy;
    float4 o = w4[0];
    float3 ax = w4[1].xyz, az = w4[2].xyz;
    float3 ay = cross3(az, ax);
    float r = o.w, z_min = cy->z_min, z_max = cy->z_max;
    float span = cy->theta_max - cy->theta_min;
    CylRay c = cylinder_ray(cy, org, dir);
    float x = c.f.x + t * c.d.x, y = c.f.y + t * c.d.y, z = c.f.z + t * c.d.z;
    float rho = hypot(x, y);
    if (rho > 0.0f) {
        x *= r / rho;
        y *= r / rho;
    } else {                         /* only for a radius below rounding: any point of the circle */
        x = r;
        y = 0.0f;
    }
    float3 radial = x * ax + y * ay;
    g->p = o.xyz + radial + z * az;
    g->perr = gamma_n(5.0f) * (fabs(x) * abs3(ax) + fabs(y) * abs3(ay) + fabs(z) * abs3(az))
            + gamma_n(1.0f) * abs3(g->p);
    g->ng = tx_unit_or(radial, ax);
    float rel = cylinder_theta_rel(x, y, cy->theta_min);
    g->uv = (float2)(clamp(rel / span, 0.0f, 1.0f), clamp((z - z_min) / (z_max - z_min), 0.0f, 1.0f));
    g->dpdu = span * (x * ay - y * ax);
    g->dpdv = (z_max - z_min) * az;
}

#endif
