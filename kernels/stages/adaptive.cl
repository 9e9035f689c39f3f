#line 2 "stages/adaptive.cl"
/* Adaptive sampling's decision between two rounds, on the device (texray.renderer.frame
 * adaptive_tile): which of a tile's pixels take the next round. Two launches on the queue
 * of the round's fused launches, so the sums never leave the device and the host reads
 * back one count:
 *
 *   adaptive_mark: each pixel of the round's list (`active`, n entries: the pixels the
 *     round sampled) stamps itself with `tag` (the round's number, >= 1) where it has not
 *     converged (core/adaptive.h), 0 where it has. Pixels the round did not sample keep
 *     an older stamp (the host zeroes the tile's stamps before its first round), so only
 *     this round's pixels count as unconverged: one that was not sampled had converged,
 *     and so had its neighbours, and it has no new samples.
 *   adaptive_list: each pixel of a half of the tile (rows x width from tile pixel p0,
 *     image row row0 at its top) goes on if a pixel of its 3x3 neighbourhood within its
 *     block of block_rows image rows (rows y / block_rows alike) and within the half
 *     carries the tag: it appends its tile index to `active` (counts[slot] entries: the
 *     half's atomic counter, which the host zeroes). The list's order depends on the work-items' timing, not
 *     what a pixel takes: its samples are fixed by its index and the round, and each
 *     pixel's sums by its own samples in order, whichever work-item takes it
 *     (texray.device.features.pixels_per_item). */
#if TX_ADAPTIVE

__kernel void adaptive_mark(__global const float4* accum, __global const float* sum_y2,
                            __global const uint* active, uint n, __global uchar* stamp, uint tag,
                            float threshold, float floor_y)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    uint p = active[gid];
    stamp[p] = adaptive_open(accum[p], sum_y2[p], threshold, floor_y) ? (uchar)tag : (uchar)0;
}

__kernel void adaptive_list(__global const uchar* stamp, uint tag, uint p0, uint rows, uint width, uint row0,
                            uint block_rows, __global uint* active, __global uint* counts, uint slot)
{
    uint gid = get_global_id(0);
    if (width == 0u || gid >= rows * width) return;
    uint r = gid / width, x = gid % width;
    uint y = row0 + r, b = TX_MAX(block_rows, 1u);
    uint r_lo = (r > 0u && (y % b) != 0u) ? r - 1u : r;                  /* the row above, in the block */
    uint r_hi = (r + 1u < rows && (y % b) != b - 1u) ? r + 1u : r;       /* the row below, in the block */
    uint x_lo = x > 0u ? x - 1u : x, x_hi = x + 1u < width ? x + 1u : x;
    uint t = tag & 0xffu;
    int go = 0;
    for (uint i = r_lo; i <= r_hi; ++i)
        for (uint j = x_lo; j <= x_hi; ++j)
            go |= stamp[p0 + i * width + j] == t;
    if (go)
        active[atomic_inc(counts + slot)] = p0 + gid;
}

#endif
