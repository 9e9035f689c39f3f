#line 2 "stages/intersect.cl"
/* Stage 2: closest hit of every ray of the tile. */

__kernel void intersect(__global const Ray* rays, __global Hit* hits, uint n, TX_GEOM_PARAMS)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    __global const Ray* r = rays + gid;
    HitRec h = bvh_closest(TX_GEOM_ARGS, ray_org(r), ray_dir(r), r->tmin, r->tmax);
    __global Hit* o = hits + gid;
    o->t = h.t; o->b1 = h.b1; o->b2 = h.b2; o->prim = h.prim;
#if TX_INSTANCES
    hits[n + gid].prim = h.inst;     /* the host allocates 2n records with instances */
#endif
}

/* Any hit of every ray with t in (tmin, tmax): 1 = occluded. Used by the
 * benchmark and the tests to time and check shadow-ray traversal alone. */
__kernel void occluded(__global const Ray* rays, __global uchar* out, uint n, TX_GEOM_PARAMS)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    __global const Ray* r = rays + gid;
    out[gid] = (uchar)bvh_any(TX_GEOM_ARGS, ray_org(r), ray_dir(r), r->tmin, r->tmax);
}
