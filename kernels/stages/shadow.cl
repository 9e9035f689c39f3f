#line 2 "stages/shadow.cl"
/* Stage 4: visibility of every point light from every hit (any-hit rays;
 * shading/shadow.h), one byte per (hit, light). With TX_ONE_LIGHT only the light the
 * sample takes (core/sampler.h light_pick: sample `sample` of spp of the pixel gid of the tile
 * of whole rows from row y0, pattern from `seed`) is traced; the others get 0. */

__kernel void shadow(__global const Surface* surf, __global uchar* vis, uint n, uint image_w, uint y0, uint sample,
                     uint spp, uint seed, TX_GEOM_PARAMS, TX_LIGHT_PARAMS)
{
    uint gid = TX_GID();
    if (gid >= n) return;
    if (!surf[gid].valid) return;
    Surface s = surf[gid];
    int lifted;
    float3 org = shadow_origin(&s, &lifted);
#if TX_ONE_LIGHT
    uint pat = pixel_pattern(image_w, gid % image_w, y0 + gid / image_w, seed);
    uint pick = light_pick(sample, pat, light_offset(pat, spp, nlights), nlights, light_block(spp, nlights));
#endif
    FOR_EACH_LIGHT(i, nlights) {
#if TX_ONE_LIGHT
        if (i != pick) { vis[(size_t)gid * nlights + i] = 0; continue; }
#endif
        vis[(size_t)gid * nlights + i] = light_visible(&s, org, lifted, vload3(0, lights[i].position),
                                                       TX_GEOM_ARGS);
    }
}
