#line 2 "stages/intersect.cl"
/* Stage 2: closest hit of every ray of the tile. */

__kernel void intersect(__global const Ray* rays, __global Hit* hits, uint n, TX_GEOM_PARAMS)
{
    uint gid = TX_GID();
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
    uint gid = TX_GID();
    if (gid >= n) return;
    __global const Ray* r = rays + gid;
    out[gid] = (uchar)bvh_any(TX_GEOM_ARGS, ray_org(r), ray_dir(r), r->tmin, r->tmax);
}

#if TX_PACKET
/* Rays base .. base + TX_PACKET - 1 (those below n) of the buffer as a packet; act[j]: the
 * lanes to trace, the rays that pass ray_valid (the others answer a miss untraced, as in
 * bvh_closest and bvh_any). */
static inline void packet_of_rays(__global const Ray* rays, uint base, uint n, PacketRay* r, int* act)
{
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        float3 o = (float3)(0.0f), d = (float3)(0.0f, 0.0f, 1.0f);    /* lanes not traced: any valid ray */
        float t0 = 0.0f, t1 = INFINITY;
        act[j] = 0;
        if (j < n - base) {
            __global const Ray* ry = rays + base + j;
            t1 = ry->tmax;                     /* a missed lane's t, as bvh_closest answers */
            if (ray_valid(ray_org(ry), ray_dir(ry), ry->tmin, ry->tmax)) {
                o = ray_org(ry); d = ray_dir(ry); t0 = ry->tmin; act[j] = -1;
            }
        }
        packet_set_lane(r, j, o, d, t0, t1);
    }
    packet_setup(r, PLOAD(act));
}

/* `occluded` and `intersect` with TX_PACKET consecutive rays per work-item traced as one
 * packet (accel/packet.h): the same answers, bit for bit; how the tests and the benchmark
 * see the packet traversals alone. */
TX_KERNEL_BODY void occluded_packet_body(uint base, __global const Ray* rays, __global uchar* out, uint n,
                                         TX_GEOM_PARAMS)
{
    PacketRay r;
    int act[TX_PACKET], occ[TX_PACKET];
    packet_of_rays(rays, base, n, &r, act);
    PSTORE(bvh_any_packet(TX_GEOM_ARGS, &r, PLOAD(act)), occ);
    for (uint j = 0; j < (uint)TX_PACKET && j < n - base; ++j)
        out[base + j] = act[j] && occ[j];
}

__kernel void occluded_packet(__global const Ray* rays, __global uchar* out, uint n, TX_GEOM_PARAMS)
{
    uint base = TX_GID() * (uint)TX_PACKET;
    if (base >= n) return;
    occluded_packet_body(base, rays, out, n, TX_GEOM_ARGS);
}

#if !TX_INSTANCES
TX_KERNEL_BODY void intersect_packet_body(uint base, __global const Ray* rays, __global Hit* hits, uint n,
                                          TX_GEOM_PARAMS)
{
    PacketRay r;
    int act[TX_PACKET], hp[TX_PACKET];
    float ht[TX_PACKET], hb1[TX_PACKET], hb2[TX_PACKET];
    packet_of_rays(rays, base, n, &r, act);
    PacketHit h = bvh_closest_packet(TX_GEOM_ARGS, &r, PLOAD(act));
    PSTORE(h.t, ht); PSTORE(h.b1, hb1); PSTORE(h.b2, hb2); PSTORE(h.prim, hp);
    for (uint j = 0; j < (uint)TX_PACKET && j < n - base; ++j) {
        __global Hit* o = hits + base + j;
        o->t = ht[j]; o->b1 = hb1[j]; o->b2 = hb2[j]; o->prim = (uint)hp[j];
    }
}

__kernel void intersect_packet(__global const Ray* rays, __global Hit* hits, uint n, TX_GEOM_PARAMS)
{
    uint base = TX_GID() * (uint)TX_PACKET;
    if (base >= n) return;
    intersect_packet_body(base, rays, hits, n, TX_GEOM_ARGS);
}
#endif
#endif
