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
#include "core/sampler.h"
#include "accel/packet.h"
#include "accel/packet_vec.h"
#endif

/* The shadow ray's origin for the surface point s (see above); *lifted says whether the
 * side test uses the shading normal. */
static inline float3 shadow_origin(const Surface* s, int* lifted)
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
static inline int shadow_ray(const Surface* s, float3 org, int lifted, float3 lpos, float3* d)
{
    *d = lpos - org;
    if (!ray_valid(org, *d, 0.0f, 1.0f)) return 0;
    return dot3(*d, lifted ? vload3(0, s->ns) : vload3(0, s->ng)) > 0.0f;   /* NaN: 0 */
}

#if TX_SCALAR_TRAVERSAL
/* 1 when the light at lpos is visible from the shadow origin org of s. */
static inline uchar light_visible(const Surface* s, float3 org, int lifted, float3 lpos, TX_GEOM_PARAMS)
{
    float3 d;
    if (!shadow_ray(s, org, lifted, lpos, &d)) return 0;
    if (TX_SHADOWS) return !bvh_any(TX_GEOM_ARGS, org, d, 0.0f, 1.0f);
    return 1;
}
#endif

#if TX_PACKET
/* The shadow origins of a chunk's surface points as vectors: shadow_origin's origin, the
 * normal of shadow_ray's side test (ns where the origin was lifted, else ng) and the valid
 * points, computed once for every light of the chunk. */
typedef struct {
    pfloat3 o, n;
    pint valid;
} ShadowLanes;

/* shadow_origin for surface points as vectors (their p, lift, ng, ns, offset; the lanes of
 * valid have records): the same operations in the same order (the dot product and
 * offset_point contracted as in core/common.h: accel/packet_vec.h), so each lane's origin is
 * shadow_origin's bit for bit. */
static inline __attribute__((always_inline)) void shadow_origins_lanes(pfloat3 p, pfloat3 lift, pfloat3 ng,
                                                                       pfloat3 ns, pfloat offset, pint valid,
                                                                       ShadowLanes* out)
{
    pint lifted = pf3_dot(lift, lift) > 16.0f * offset * offset;     /* shadow_origin's test */
    out->o = pf3_offset_point(pf3_add(p, lift), ng, offset);
    out->n = pf3_sel(lifted, ns, ng);
    out->valid = valid;
}

/* shadow_origin for the m <= TX_PACKET surface points s[0..m) as one vector computation:
 * each lane's record gathered straight into vectors (lanes past m read lane m - 1's) for
 * shadow_origins_lanes. Lanes whose record is not valid compute on whatever it holds and are
 * masked off. */
inline void shadow_origins_packet(const Surface* s, uint m, ShadowLanes* out)
{
#define TX_SO(j, f) s[TX_MIN((uint)(j), m - 1u)].f
    pfloat3 p = PGATHER_F3(TX_SO, p), lift = PGATHER_F3(TX_SO, lift);
    pfloat3 ng = PGATHER_F3(TX_SO, ng), ns = PGATHER_F3(TX_SO, ns);
    pfloat offset = (pfloat)PGATHER_A(TX_SO, offset);
    pint valid = as_pint((puint)PGATHER_A(TX_SO, valid)) != 0;
#undef TX_SO
    shadow_origins_lanes(p, lift, ng, ns, offset, valid, out);
}

/* light_visible for the m <= TX_PACKET surface points s[0..m) with their shadow origins
 * (shadow_origins_packet), each toward its own light (lane j of *lights), as a lane mask: the
 * same answers, from one packet traversal (accel/packet.h). Points that are not valid get 0.
 * Every sample's rays toward one light (every lane's the same), or with TX_ONE_LIGHT each
 * sample's ray toward the light it picked: one packet for the chunk, not one per light with
 * the other lights' lanes idle. */
static inline pint light_visible_lanes(const ShadowLanes* sl, uint m, const pfloat3* lights, TX_GEOM_PARAMS)
{
    /* shadow_ray for every lane as one vector computation, the lights given as vectors
     * (pf3_splat of one light, or pf3_gather of each lane's), not written lane by lane into the
     * packet and read back as vectors, which stalled on the store-to-load forwarding (a fifth
     * of this function's time, perf on the globe) */
    if (m == 0u) return (pint)(0);
    pfloat3 o = sl->o, n = sl->n, l = *lights;
    pint live = sl->valid & (as_pint(TX_PKT_LANE_IDS) < (pint)((int)m));
    pfloat3 d = pf3_sub(l, o);
    /* ray_valid(o, d, 0, 1) (core/common.h), then the side test: the dot product as
     * shadow_ray's dot3 rounds it (accel/packet_vec.h pf3_dot) */
    pfloat ax = fabs(d.x), ay = fabs(d.y), az = fabs(d.z);
    live &= pf3_finite(o)
          & (ax <= TX_DIR_MAX) & (ay <= TX_DIR_MAX) & (az <= TX_DIR_MAX)
          & ((ax >= TX_DIR_MIN) | (ay >= TX_DIR_MIN) | (az >= TX_DIR_MIN));
    live &= pf3_dot(d, n) > 0.0f;
    if (TX_SHADOWS && any(live)) {               /* without: every valid ray's light, as light_visible */
        /* lanes not traced: any valid ray (origin 0, direction +z) */
        PacketRay r;
        PSTORE(PSEL_F(live, o.x, (pfloat)(0.0f)), r.org[0]);
        PSTORE(PSEL_F(live, o.y, (pfloat)(0.0f)), r.org[1]);
        PSTORE(PSEL_F(live, o.z, (pfloat)(0.0f)), r.org[2]);
        PSTORE(PSEL_F(live, d.x, (pfloat)(0.0f)), r.dir[0]);
        PSTORE(PSEL_F(live, d.y, (pfloat)(0.0f)), r.dir[1]);
        PSTORE(PSEL_F(live, d.z, (pfloat)(1.0f)), r.dir[2]);
        PSTORE((pfloat)(0.0f), r.range[0]);
        PSTORE((pfloat)(1.0f), r.range[1]);
        packet_setup(&r, live);
        live &= ~bvh_any_packet(TX_GEOM_ARGS, &r, live);              /* visible: traced and not occluded */
    }
    return live;
}

/* The same into vis[0..m) (the records' path of stages/fused.cl); the packet surfaces' path
 * takes light_visible_lanes's mask as it is (lanes from m on: 0). */
inline void light_visible_packet(const ShadowLanes* sl, uint m, const pfloat3* lights, TX_GEOM_PARAMS, uchar* vis)
{
    int occ[TX_PACKET];
    PSTORE(light_visible_lanes(sl, m, lights, TX_GEOM_ARGS), occ);
    for (uint j = 0; j < m; ++j) vis[j] = occ[j] != 0;
}
#endif

#endif
