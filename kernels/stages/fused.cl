#line 2 "stages/fused.cl"
/* All five stages in one kernel: each work-item takes one pixel of the tile
 * through `nsamples` samples (raygen -> closest hit -> surface -> shadow rays
 * -> shading) and adds their sum to the pixel's accumulator. Same functions,
 * same samples, same image as the staged pipeline, without the per-ray
 * records between stages in global memory; the stage kernels stay for timing
 * each stage alone and for the AOV pass. */

/* With TX_ADAPTIVE (adaptive sampling, texray.renderer.adaptive) the work-items take the
 * tile's pixels listed in `active` (n of them) and each also adds the squares of its
 * samples' luminance to sum_y2, the host's variance estimate; otherwise work-item gid
 * is pixel gid of the tile and both are NULL. */
__kernel void render_fused(__global float4* accum, __global const uint* active, __global float* sum_y2, uint n,
                           uint y0, uint sample0, uint nsamples, uint seed, uint jitter,
                           TX_GEOM_PARAMS, TX_SURFACE_PARAMS, TX_LIGHT_PARAMS, float4 ambient, float4 background)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
#if TX_ADAPTIVE
    gid = active[gid];
    float y2 = 0.0f;
#endif
    uint px = gid % image_w, py = y0 + gid / image_w;
    uint pattern = pixel_pattern(image_w, px, py, seed), grid_m = cmj_grid_m(spp);
    float3 sum = (float3)(0.0f);
    for (uint k = 0; k < nsamples; ++k) {
        float2 j = jitter ? cmj_sample_m(sample0 + k, spp, grid_m, pattern) : (float2)(0.5f, 0.5f);
        float3 org, dir;
        camera_ray(cam, image_w, image_h, px, py, j, &org, &dir);
        HitRec h = bvh_closest(TX_GEOM_ARGS, org, dir, 0.0f, INFINITY);
        Surface s;
        surface_eval(org, dir, h, TX_GEOM_ARGS, TX_SURFACE_ARGS, (__global float*)0, gid, &s);
        float3 c = background.xyz;
        if (s.valid) {
            float3 v = -normalize3(dir);
            c = ambient.xyz * vload3(0, s.kd);
            int lifted;
            float3 sorg = shadow_origin(&s, &lifted);
            FOR_EACH_LIGHT(i, nlights) {
                float3 lpos = vload3(0, lights[i].position);
                if (light_visible(&s, sorg, lifted, lpos, TX_GEOM_ARGS))
                    c += light_term(&s, v, lpos, vload3(0, lights[i].intensity));
            }
        }
        c = clamp_radiance(c);
        sum += c;
#if TX_ADAPTIVE
        float y = 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;     /* Rec. 709 luminance */
        y2 += y * y;
#endif
    }
    accum[gid] += (float4)(sum, (float)nsamples);
#if TX_ADAPTIVE
    sum_y2[gid] += y2;
#endif
}
