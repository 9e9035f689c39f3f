#line 2 "shading/shadow.h"
/* Visibility of a point light from a surface point (any-hit rays): what the shadow
 * stage (stages/shadow.cl) and the fused kernel ask for each light.
 *
 * The origin is offset along the geometric normal on the side the camera ray
 * came from, by the error bound of the hit point, so the ray cannot re-hit
 * its own surface (no acne). A light on the other side of the geometric
 * surface is occluded by that surface itself: it gets vis = 0 without a ray,
 * which is also what keeps light from leaking through closed meshes.
 *
 * On smooth-shaded meshes the surface stage gives a lift (shading/terminator.h,
 * Hanika's shadow-terminator fix): the ray starts from p + lift, and where the
 * lift exceeds p's error bound the point counts as facing the light when the
 * shading normal does (the flat triangle's side test would bring the facets
 * back). */
#ifndef TEXRAY_SHADOW_H
#define TEXRAY_SHADOW_H
#include "accel/bvh.h"

/* The shadow ray's origin for the surface point s (see above); *lifted says whether the
 * side test uses the shading normal. */
inline float3 shadow_origin(const Surface* s, int* lifted)
{
    float3 lift = vload3(0, s->lift);
    *lifted = dot3(lift, lift) > 16.0f * s->offset * s->offset;   /* beyond p's own rounding */
    return offset_point(vload3(0, s->p) + lift, vload3(0, s->ng), s->offset);
}

/* 1 when the light at lpos is visible from the shadow origin org of s. A shadow ray
 * that ray_valid (core/common.h) rejects -- a light or a surface point that is not finite
 * (a light at 1e39 is inf in float32), a light farther than 2^126 on an axis, a light
 * at the shadow origin itself (d = 0) -- sees no light: 0, also without TX_SHADOWS, so
 * that shading never meets such a light (its I / d^2 would be 0 x inf or inf / inf).
 * For every other light the test is unchanged. */
inline uchar light_visible(const Surface* s, float3 org, int lifted, float3 lpos, TX_GEOM_PARAMS)
{
    float3 d = lpos - org;
    if (!ray_valid(org, d, 0.0f, 1.0f)) return 0;
    if (!(dot3(d, lifted ? vload3(0, s->ns) : vload3(0, s->ng)) > 0.0f)) return 0;   /* NaN: 0 */
    if (TX_SHADOWS) return !bvh_any(TX_GEOM_ARGS, org, d, 0.0f, 1.0f);
    return 1;
}

#endif
