#line 2 "texture/differentials.h"
/* Ray differentials of primary rays (Igehy, "Tracing Ray Differentials",
 * SIGGRAPH 1999) and the texture-coordinate derivatives they give (pbrt-v4
 * SurfaceInteraction::ComputeDifferentials). Only camera rays are shaded, so
 * the surface stage derives them from the camera instead of carrying offset
 * rays through the pipeline. */
#ifndef TEXRAY_DIFFERENTIALS_H
#define TEXRAY_DIFFERENTIALS_H
#include "core/frame.h"
#include "texture/mapping.h"

#define TX_UV_DERIV_MAX 1.0e8f    /* pbrt-v4's clamp of du/dx...: beyond it a footprint is "everything" */

/* Footprint shrink for spp samples per pixel: each sample stands for 1/spp of
 * the pixel, so its footprint is 1/sqrt(spp) pixels across; at most 8x smaller
 * (pbrt-v4 RayIntegrator: max(1/8, 1/sqrt(spp))), the box filter of the samples
 * averages the rest. */
static inline float differential_scale(uint spp)
{
    return TX_MAX(0.125f, rsqrt((float)TX_MAX(spp, 1u)));
}

/* dp/dx, dp/dy of a hit p = eye + t d (d unnormalized, as core/camera.h makes it)
 * on its tangent plane with normal n, per pixel step in x and y, scaled by
 * `scale`. camera_ray's direction is d(x, y) = forward + x right + y up with NDC
 * x = 2 (px + jx) / W - 1 and y = 1 - 2 (py + jy) / H, so dd/dpx = 2 right / W
 * and dd/dpy = -2 up / H, and every ray starts at the eye. Igehy's transfer to
 * the plane: dp = t (dd - d (dd . n) / (d . n)): a differential, with no
 * cancellation of p - p' at large distances. d . n = 0 gives zero. */
static inline void camera_dp_dxy(__constant Camera* cam, uint width, uint height, float scale,
                                 float3 d, float t, float3 n, float3* dpdx, float3* dpdy)
{
    float3 ddx = vload3(0, cam->right) * (2.0f * scale / (float)width);
    float3 ddy = vload3(0, cam->up) * (-2.0f * scale / (float)height);
    float dn = dot3(d, n);
    float inv = dn != 0.0f ? 1.0f / dn : 0.0f;
    *dpdx = t * (ddx - d * (dot3(ddx, n) * inv));
    *dpdy = t * (ddy - d * (dot3(ddy, n) * inv));
}

/* d(u,v)/dx and d(u,v)/dy from dp/dx, dp/dy and the surface's dP/du, dP/dv:
 * the least-squares solution of dpdu du + dpdv dv = dp (normal equations with
 * A = [dpdu dpdv]); a singular or non-finite system gives 0, derivatives are
 * clamped to +-TX_UV_DERIV_MAX. */
static inline TexCoord uv_differentials(float2 uv, float3 dpdu, float3 dpdv, float3 dpdx, float3 dpdy)
{
    float a00 = dot3(dpdu, dpdu), a01 = dot3(dpdu, dpdv), a11 = dot3(dpdv, dpdv);
    float det = tx_diff_prod(a00, a11, a01, a01);      /* core/accurate.h: no cancellation */
    float inv = 1.0f / det;
    inv = isfinite(inv) ? inv : 0.0f;
    float bx0 = dot3(dpdu, dpdx), bx1 = dot3(dpdv, dpdx);
    float by0 = dot3(dpdu, dpdy), by1 = dot3(dpdv, dpdy);
    /* (du, dv) = (b0, b1) G^-1, G = A^T A = [[a00, a01], [a01, a11]] (symmetric), for
     * both screen directions at once: x = (du/dx, du/dy, -), y = (dv/dx, dv/dy, -). */
    float3 x, y;
    mul_inverse2((float2)(a00, a01), (float2)(a01, a11), inv, (float3)(bx0, by0, 0.0f), (float3)(bx1, by1, 0.0f),
                 &x, &y);
    float2 dx = (float2)(x.x, y.x), dy = (float2)(x.y, y.y);
    TexCoord r;
    r.uv = uv;
    r.duv_dx = (float2)(isfinite(dx.x) ? clamp(dx.x, -TX_UV_DERIV_MAX, TX_UV_DERIV_MAX) : 0.0f,
                        isfinite(dx.y) ? clamp(dx.y, -TX_UV_DERIV_MAX, TX_UV_DERIV_MAX) : 0.0f);
    r.duv_dy = (float2)(isfinite(dy.x) ? clamp(dy.x, -TX_UV_DERIV_MAX, TX_UV_DERIV_MAX) : 0.0f,
                        isfinite(dy.y) ? clamp(dy.y, -TX_UV_DERIV_MAX, TX_UV_DERIV_MAX) : 0.0f);
    return r;
}

#endif
