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
#if TX_PACKET
#include "accel/packet.h"
#endif

/* The shadow ray's origin for the surface point s (see above); *lifted says whether the
 * side test uses the shading normal. */
inline float3 shadow_origin(const Surface* s, int* lifted)
{
    float3 lift = vload3(0, s->lift);
    *lifted = dot3(lift, lift) > 16.0f * s->offset * s->offset;   /* beyond p's own rounding */
    return offset_point(vload3(0, s->p) + lift, vload3(0, s->ng), s->offset);
}

/* Whether the light at lpos can be seen from the shadow origin org of s at all, before
 * any ray is traced; *d is the shadow ray's direction (t in (0, 1) reaches the light).
 * A shadow ray that ray_valid (core/common.h) rejects -- a light or a surface point that is
 * not finite (a light at 1e39 is inf in float32), a light farther than 2^126 on an axis, a
 * light at the shadow origin itself (d = 0) -- sees no light: 0, also without TX_SHADOWS,
 * so that shading never meets such a light (its I / d^2 would be 0 x inf or inf / inf).
 * Nor does a light on the far side of the surface (the side test). */
inline int shadow_ray(const Surface* s, float3 org, int lifted, float3 lpos, float3* d)
{
    *d = lpos - org;
    if (!ray_valid(org, *d, 0.0f, 1.0f)) return 0;
    return dot3(*d, lifted ? vload3(0, s->ns) : vload3(0, s->ng)) > 0.0f;   /* NaN: 0 */
}

/* 1 when the light at lpos is visible from the shadow origin org of s. */
inline uchar light_visible(const Surface* s, float3 org, int lifted, float3 lpos, TX_GEOM_PARAMS)
{
    float3 d;
    if (!shadow_ray(s, org, lifted, lpos, &d)) return 0;
    if (TX_SHADOWS) return !bvh_any(TX_GEOM_ARGS, org, d, 0.0f, 1.0f);
    return 1;
}

#if TX_PACKET
/* light_visible for the m <= TX_PACKET surface points s[0..m) with their shadow origins
 * org[j] and lifted[j] (shadow_origin), each toward its own light lpos[j], into vis[j]: the
 * same answers, from one packet traversal (accel/packet.h). Points that are not valid get 0.
 * Every sample's rays toward one light (lpos[j] all equal), or with TX_ONE_LIGHT each
 * sample's ray toward the light it picked: one packet for the chunk, not one per light with
 * the other lights' lanes idle. */
inline void light_visible_packet(const Surface* s, const float3* org, const int* lifted, uint m, const float3* lpos,
                                 TX_GEOM_PARAMS, uchar* vis)
{
    PacketRay r;
    int act[TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        float3 o = (float3)(0.0f), d = (float3)(0.0f, 0.0f, 1.0f);    /* lanes not traced: any valid ray */
        act[j] = 0;
        if (j < m && s[j].valid) {
            float3 dj;
            if (shadow_ray(s + j, org[j], lifted[j], lpos[j], &dj)) { o = org[j]; d = dj; act[j] = -1; }
        }
        packet_set_lane(&r, j, o, d, 0.0f, 1.0f);
    }
    packet_setup(&r, (pint)(TX_LANES(act)));
    int occ[TX_PACKET];
    PSTORE(bvh_any_packet(TX_GEOM_ARGS, &r, (pint)(TX_LANES(act))), occ);
    for (uint j = 0; j < m; ++j) vis[j] = act[j] && !occ[j];
}
#endif

#endif
