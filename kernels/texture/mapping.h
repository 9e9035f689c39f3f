#line 2 "texture/mapping.h"
/* Projection mappings (the lecture's planar, cylindrical and spherical
 * texture coordinates) and affine UV transforms.
 *
 * Coordinates travel with their derivatives (pbrt-v4 TexCoord2D): every
 * mapping takes the point p and its screen-space differentials dp/dx, dp/dy
 * and returns (u, v) with d(u,v)/dx and d(u,v)/dy, computed analytically
 * (chain rule through the mapping), so they are continuous across the
 * u = 0 / 1 seam. Zero differentials give zero derivatives.
 *
 * The frame: p is expressed in the frame as
 *   x_l = (p - origin).x,  y_l = (p - origin).y,  z_l = (p - origin).z
 * The axes are orthogonal and of equal length k. k = 1 (orthonormal) is the
 * frame of the scene; the host's texray.mapping.Projection.device_frame()
 * passes k = Projection.scale, which multiplies the planar (u, v) and the
 * cylindrical v, and leaves phi and theta (cylindrical u, spherical u, v)
 * unchanged (they only depend on ratios of x_l, y_l, z_l).
 *
 *   planar:      u = x_l, v = y_l                     (one unit = one repeat)
 *   cylindrical: u = phi / 2pi, v = z_l,              phi = atan2(y_l, x_l) in [0, 2pi)
 *   spherical:   u = phi / 2pi, v = 1 - theta / pi,   theta = atan2(sqrt(x_l^2 + y_l^2), z_l)
 *                (the sphere primitive's parameterization, geometry/spherical.h: the +z
 *                pole at v = 1, the top row)
 *
 * u of cylindrical/spherical is in [0, 1) (a value that would round to 1 is
 * returned as the largest float below 1): geometry/spherical.h azimuth_u, the
 * sphere's own. atan2 is used throughout (never acos), so theta is accurate near
 * the poles.
 *
 * Singularities: exactly on the cylinder/sphere axis (x_l = y_l = 0) phi is
 * undefined: u = 0; there and wherever x_l^2 + y_l^2 is below FLT_MIN,
 * du/dx = du/dy = 0. At a pole of the sphere the same holds for u and dv is 0
 * too (theta is not differentiable there); at the frame origin all
 * derivatives are 0. Just off the axis the derivatives are the exact ones,
 * which grow like |dp| / r (finite while |dp| / r < FLT_MAX). */
#ifndef TEXRAY_MAPPING_H
#define TEXRAY_MAPPING_H
#include "core/frame.h"
#include "geometry/spherical.h"

#define TX_MAP_PLANAR 0
#define TX_MAP_CYLINDRICAL 1
#define TX_MAP_SPHERICAL 2

#define TX_INV_PI 0.31830988618379067f
#define TX_INV_2PI 0.15915494309189535f
#define TX_MAP_TINY 1.17549435e-38f       /* FLT_MIN: below it r^2 is treated as 0 */

typedef struct { float2 uv; float2 duv_dx, duv_dy; } TexCoord;   /* duv_dx = d(u,v)/d(screen x) */
typedef struct { float3 origin, x, y, z; } Frame;                  /* orthogonal, equal-length axes */

/* The three mappings are `static`: each is called once (map_projection), so inlined
 * there whatever its size (shading/surface.h explains). */
static inline TexCoord map_planar(Frame f, float3 p, float3 dpdx, float3 dpdy)
{
    float3 d = p - f.origin;
    TexCoord t;
    t.uv = (float2)(dot3(d, f.x), dot3(d, f.y));
    t.duv_dx = (float2)(dot3(dpdx, f.x), dot3(dpdx, f.y));
    t.duv_dy = (float2)(dot3(dpdy, f.x), dot3(dpdy, f.y));
    return t;
}

static inline TexCoord map_cylindrical(Frame f, float3 p, float3 dpdx, float3 dpdy)
{
    float3 d = p - f.origin;
    float x = dot3(d, f.x), y = dot3(d, f.y), z = dot3(d, f.z);
    /* dphi = (x dy - y dx) / (x^2 + y^2), analytically: no seam. */
    float r2 = x * x + y * y;
    float inv_r2 = r2 >= TX_MAP_TINY ? 1.0f / r2 : 0.0f;
    float xx = dot3(dpdx, f.x), xy = dot3(dpdx, f.y);
    float yx = dot3(dpdy, f.x), yy = dot3(dpdy, f.y);
    TexCoord t;
    t.uv = (float2)(azimuth_u(x, y), z);
    t.duv_dx = (float2)((x * xy - y * xx) * inv_r2 * TX_INV_2PI, dot3(dpdx, f.z));
    t.duv_dy = (float2)((x * yy - y * yx) * inv_r2 * TX_INV_2PI, dot3(dpdy, f.z));
    return t;
}

static inline TexCoord map_spherical(Frame f, float3 p, float3 dpdx, float3 dpdy)
{
    float3 d = p - f.origin;
    float x = dot3(d, f.x), y = dot3(d, f.y), z = dot3(d, f.z);
    float r2 = x * x + y * y;                 /* rho^2 */
    float rho = sqrt(r2);
    float R2 = r2 + z * z;
    /* theta = atan2(rho, z) in [0, pi] (geometry/spherical.h);
     * dtheta = (z drho - rho dz) / R^2 with drho = (x dx + y dy) / rho:
     *        = (z (x dx + y dy) / rho - rho dz) / R^2 */
    float inv_r2 = r2 >= TX_MAP_TINY ? 1.0f / r2 : 0.0f;
    float inv_rho = r2 >= TX_MAP_TINY ? 1.0f / rho : 0.0f;
    float inv_R2 = R2 >= TX_MAP_TINY ? 1.0f / R2 : 0.0f;
    float xx = dot3(dpdx, f.x), xy = dot3(dpdx, f.y), xz = dot3(dpdx, f.z);
    float yx = dot3(dpdy, f.x), yy = dot3(dpdy, f.y), yz = dot3(dpdy, f.z);
    float dthx = (z * (x * xx + y * xy) * inv_rho - rho * xz) * inv_R2;
    float dthy = (z * (x * yx + y * yy) * inv_rho - rho * yz) * inv_R2;
    TexCoord t;
    t.uv = sphere_uv(x, y, z, rho);
    t.duv_dx = (float2)((x * xy - y * xx) * inv_r2 * TX_INV_2PI, -dthx * TX_INV_PI);
    t.duv_dy = (float2)((x * yy - y * yx) * inv_r2 * TX_INV_2PI, -dthy * TX_INV_PI);
    return t;
}

/* kind: TX_MAP_PLANAR / CYLINDRICAL / SPHERICAL (texray.mapping.PROJECTION_KINDS);
 * any other value maps planar. */
inline TexCoord map_projection(int kind, Frame f, float3 p, float3 dpdx, float3 dpdy)
{
    return kind == TX_MAP_SPHERICAL ? map_spherical(f, p, dpdx, dpdy)
         : (kind == TX_MAP_CYLINDRICAL ? map_cylindrical(f, p, dpdx, dpdy) : map_planar(f, p, dpdx, dpdy));
}

/* dP/du, dP/dv of a projected parameterization (u, v) = map(p), restricted to
 * the surface's tangent plane (unit normal n), for bump and normal mapping:
 * with orthonormal t1, t2 spanning that plane, J = [d(u,v)/dt1  d(u,v)/dt2]
 * (the mapping's derivatives, t1 and t2 as the differentials) and
 * [dP/du dP/dv] = [t1 t2] J^-1 (core/frame.h reparam_tangents). Where J is singular
 * -- |det J| at most 2^-16 of |J11 J22| + |J12 J21|, or not finite: the projection axis and
 * the sphere's poles, where the mapping's derivatives are 0 (header comment),
 * and surfaces the projection sees edge-on (a planar projection of a plane
 * perpendicular to it) -- the parameterization has no inverse: both are 0,
 * and shading/bump.h leaves the normal unperturbed there; so where the inverse overflows. */
inline void map_tangents(int kind, Frame f, float3 p, float3 n, float3* dpdu, float3* dpdv)
{
    float3 t1 = any_tangent(n);
    float3 t2 = cross3(n, t1);
    TexCoord tc = map_projection(kind, f, p, t1, t2);     /* J's columns: tc.duv_dx, tc.duv_dy */
    /* A far projection origin (1e17 from the object) makes J tiny everywhere, its
     * inverse beyond the float range: no usable tangents there either. */
    if (reparam_tangents(tc.duv_dx, tc.duv_dy, t1, t2, dpdu, dpdv) && finite3(*dpdu) && finite3(*dpdv)) return;
    *dpdu = *dpdv = (float3)(0.0f);
}

/* Affine UV transform, the 2x3 matrix of texray.mapping.UVTransform.matrix():
 * m0 = (a, b, c, d), m1 = (e, f):  u' = a u + b v + e,  v' = c u + d v + f. */
inline float2 uv_transform(float2 uv, float4 m0, float2 m1)
{
    return (float2)(m0.x * uv.x + m0.y * uv.y + m1.x, m0.z * uv.x + m0.w * uv.y + m1.y);
}

/* The linear part only: how derivatives (and any uv difference) transform. */
inline float2 uv_transform_vector(float2 d, float4 m0)
{
    return (float2)(m0.x * d.x + m0.y * d.y, m0.z * d.x + m0.w * d.y);
}

/* A TexCoord through the transform: uv by the affine map, derivatives by its linear part. */
inline TexCoord texcoord_transform(TexCoord t, float4 m0, float2 m1)
{
    TexCoord r;
    r.uv = uv_transform(t.uv, m0, m1);
    r.duv_dx = uv_transform_vector(t.duv_dx, m0);
    r.duv_dy = uv_transform_vector(t.duv_dy, m0);
    return r;
}

#endif
