#line 2 "stages/surface.cl"
/* Stage 3: surface evaluation of every hit (shading/surface.h), and with TX_AOVS the
 * AOV record of each ray's pixel. */

__kernel void surface(__global const Ray* rays, __global const Hit* hits, __global Surface* out, uint n,
                      TX_GEOM_PARAMS, TX_SURFACE_PARAMS, __global float* aov)
{
    uint gid = TX_GID();
    if (gid >= n) return;
    __global const Hit* gh = hits + gid;
    HitRec h = { gh->t, gh->b1, gh->b2, gh->prim };
#if TX_INSTANCES
    h.inst = hits[n + gid].prim;     /* stages/intersect.cl */
#endif
    Surface s;
    surface_eval(ray_org(rays + gid), ray_dir(rays + gid), h, (const Geom*)0, TX_GEOM_ARGS, TX_SURFACE_ARGS, aov, gid, &s);
    if (s.valid) out[gid] = s;
    else out[gid].valid = 0u;
}
