#line 2 "stages/raygen.cl"
/* Stage 1: primary rays of one sample pass over one tile of pixels. */

/* The sample pattern of pixel (px, py): a hash of the pixel and the seed. */
inline uint pixel_pattern(uint width, uint px, uint py, uint seed)
{
    return hash_u32((py * width + px) ^ hash_u32(seed));
}

/* The camera ray through the point j in [0, 1)^2 of pixel (px, py); dir is not normalized. */
inline void camera_ray(__constant Camera* cam, uint width, uint height, uint px, uint py, float2 j,
                       float3* org, float3* dir)
{
    float x = 2.0f * ((float)px + j.x) / (float)width - 1.0f;
    float y = 1.0f - 2.0f * ((float)py + j.y) / (float)height;
    *dir = vload3(0, cam->forward) + x * vload3(0, cam->right) + y * vload3(0, cam->up);
    *org = vload3(0, cam->eye);
}

__kernel void raygen(__global Ray* rays, __constant Camera* cam,
                     uint width, uint height, uint x0, uint y0, uint tile_w, uint tile_n,
                     uint sample, uint spp, uint seed, uint jitter)
{
    uint gid = get_global_id(0);
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
