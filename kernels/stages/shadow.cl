#line 2 "stages/shadow.cl"
/* Stage 4: visibility of every point light from every hit (any-hit rays;
 * shading/shadow.h), one byte per (hit, light). */

__kernel void shadow(__global const Surface* surf, __global uchar* vis, uint n, TX_GEOM_PARAMS,
                     TX_LIGHT_PARAMS)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    if (!surf[gid].valid) return;
    Surface s = surf[gid];
    int lifted;
    float3 org = shadow_origin(&s, &lifted);
    FOR_EACH_LIGHT(i, nlights) {
        vis[(size_t)gid * nlights + i] = light_visible(&s, org, lifted, vload3(0, lights[i].position),
                                                       TX_GEOM_ARGS);
    }
}
