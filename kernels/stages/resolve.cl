#line 2 "stages/resolve.cl"
/* The image: each pixel's mean from its accumulator (sum R, G, B, samples), three floats per
 * pixel of the tile in `rgb`, what the host reads back (texray.renderer.frame render_rows).
 * The divisor is `spp` for every pixel where it is > 0 (every pixel took spp samples), else
 * the pixel's own count (adaptive sampling). One IEEE division per channel, as numpy's
 * float32 division on the host made the same image until 2026-12-08 (0.3 ms of a 512x256
 * frame's host time, and a read-back of 16 bytes per pixel instead of 12). */
__kernel void resolve(__global const float4* accum, __global float* rgb, uint n, float spp)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    float4 a = accum[i];
    float d = spp > 0.0f ? spp : a.w;
    vstore3(a.xyz / d, i, rgb);
}
