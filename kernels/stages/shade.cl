#line 2 "stages/shade.cl"
/* Stage 5: the local illumination of every hit (shading/light.h) by the lights the
 * shadow stage found visible, accumulated per pixel, and the pixel's mean so far written to
 * the image (core/common.h pixel_mean, as the fused kernel does). With TX_ONE_LIGHT the shadow stage
 * lets through at most the sample's own light (stages/shadow.cl), weighed by the light count
 * (light_intensity). */

__kernel void shade(__global const Ray* rays, __global const Surface* surf, __global const uchar* vis,
                    uint n, __global float4* accum, __global float* rgb,
                    TX_LIGHT_PARAMS, float4 ambient, float4 background)
{
    uint gid = TX_GID();
    if (gid >= n) return;
    float3 c = background.xyz;
    if (surf[gid].valid) {
        Surface s = surf[gid];
        float3 v = -normalize3(ray_dir(rays + gid));
        c = ambient.xyz * vload3(0, s.kd);
        FOR_EACH_LIGHT(i, nlights) {
            if (vis[(size_t)gid * nlights + i])
                c += light_term(&s, v, vload3(0, lights[i].position),
                                light_intensity(vload3(0, lights[i].intensity), nlights));
        }
    }
    float4 a = accum[gid] + (float4)(clamp_radiance(c), 1.0f);   /* one work-item per pixel of the tile: no race */
    accum[gid] = a;
    pixel_mean(a, gid, rgb);
}
