#line 2 "shadow.cl"
/* Stage 4: visibility of every point light from every hit (any-hit rays).
 *
 * The origin is offset along the geometric normal on the side the camera ray
 * came from, by the error bound of the hit point, so the ray cannot re-hit
 * its own surface (no acne). A light on the other side of the geometric
 * surface is occluded by that surface itself: it gets vis = 0 without a ray,
 * which is also what keeps light from leaking through closed meshes.
 *
 * On smooth-shaded meshes the surface stage gives a lift (terminator.h,
 * Hanika's shadow-terminator fix): the ray starts from p + lift, and where the
 * lift exceeds p's error bound the point counts as facing the light when the
 * shading normal does (the flat triangle's side test would bring the facets
 * back). */

__kernel void shadow(__global const Surface* surf, __global uchar* vis, uint n, TX_GEOM_PARAMS,
                     __global const PointLight* lights, uint nlights)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    __global const Surface* s = surf + gid;
    if (!s->valid) return;
    float3 ng = vload3(0, s->ng);
    float3 lift = vload3(0, s->lift), ns = vload3(0, s->ns);
    int lifted = dot3(lift, lift) > 16.0f * s->offset * s->offset;   /* beyond p's own rounding */
    float3 org = offset_point(vload3(0, s->p) + lift, ng, s->offset);
    FOR_EACH_LIGHT(i, nlights) {
        float3 d = vload3(0, lights[i].position) - org;
        uchar v = 0;
        if (dot3(d, lifted ? ns : ng) > 0.0f) {
#if TX_SHADOWS
            v = !bvh_any(TX_GEOM_ARGS, org, d, 0.0f, 1.0f);
#else
            v = 1;
#endif
        }
        vis[(size_t)gid * nlights + i] = v;
    }
}
