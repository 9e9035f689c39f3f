#line 2 "stages/raygen.cl"
/* Stage 1: primary rays of one sample pass over one tile of pixels (core/camera.h). */

__kernel void raygen(__global Ray* rays, __constant Camera* cam,
                     uint width, uint height, uint x0, uint y0, uint tile_w, uint tile_n,
                     uint sample, uint spp, uint seed, uint jitter)
{
    uint gid = TX_GID();
    if (gid >= tile_n) return;
    uint px = x0 + gid % tile_w, py = y0 + gid / tile_w;
    float2 j = jitter ? cmj_sample(sample, spp, pixel_pattern(width, px, py, seed)) : (float2)(0.5f, 0.5f);
    float3 org, dir;
    camera_ray(cam, width, height, px, py, j, &org, &dir);
    __global Ray* r = rays + gid;
    vstore3(org, 0, r->org);
    vstore3(dir, 0, r->dir);
    r->tmin = 0.0f;
    r->tmax = INFINITY;
}
