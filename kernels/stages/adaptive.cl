#line 2 "stages/adaptive.cl"
/* Adaptive sampling's decision between two rounds, on the device (texray.renderer.frame
 * adaptive_tile): which of a tile's pixels take the next round. Launches on the queue of the
 * round's fused launches, so the sums never leave the device, and the next round reads the
 * list and its length where they are written (the host reads the length back later, for the
 * sample count):
 *
 *   adaptive_mark: each pixel of the round's list (`active`, n entries, or as many as
 *     *listed_n where the device wrote the length; the pixels the round sampled; NULL in the
 *     first round, which samples pixels 0 .. n - 1) stamps itself with `tag` (the round's
 *     number, >= 1) where it has not converged (core/adaptive.h), 0 where it has. Pixels the
 *     round did not sample keep an older stamp (the first round samples and so stamps every
 *     pixel), so only this round's pixels count as unconverged: one that was not sampled had
 *     converged, and so had its neighbours, and it has no new samples. (Folded into the fused
 *     kernel's last launch of a round, the stamps cost that launch 0.3-0.9 ms on the brick
 *     wall's 512x256 tile against this kernel's 0.22: three dependent divisions per pixel at
 *     the end of a work-item's run, which the work-items of a kernel of their own overlap.)
 *   adaptive_count, adaptive_scan, adaptive_list: each pixel of the tile (rows x width,
 *     image row row0 at its top) goes on if a pixel of its 3x3 neighbourhood within its
 *     block of block_rows image rows (rows y / block_rows alike) and within the tile
 *     carries the tag. Work-item r counts row r's pixels that go on, one work-item turns
 *     the counts into each row's first entry (and the list's length, *count, what the host
 *     reads back), and work-item r writes row r's tile indices from there: the list in
 *     tile order, as the host's numpy made it, whatever the work-items' timing. (An order
 *     that depended on it, appended through an atomic counter, changed the displaced torus's
 *     image in its last bits from run to run: the work-items of the next round take their
 *     pixels from the list a few at a time, and its displacement search rounds by the packet
 *     its lanes share. One work-item per pixel, reading its 9 stamps through bounds tests,
 *     cost 1 ms of CPU time per round on a 512x256 tile (perf); a row's sliding window reads
 *     a third of that, with no division per pixel.) */
#if TX_ADAPTIVE

static inline void adaptive_mark_one(__global const float4* accum, __global const float* sum_y2,
                                     __global const uint* active, uint i, __global uchar* stamp, uint tag,
                                     float threshold, float floor_y)
{
    uint p = active ? active[i] : i;
    stamp[p] = adaptive_open(accum[p], sum_y2[p], threshold, floor_y) ? (uchar)tag : (uchar)0;
}

__kernel void adaptive_mark(__global const float4* accum, __global const float* sum_y2,
                            __global const uint* active, __global const uint* listed_n, uint n,
                            __global uchar* stamp, uint tag, float threshold, float floor_y)
{
    if (listed_n) {
        TX_FOR_LISTED(i, *listed_n)
            adaptive_mark_one(accum, sum_y2, active, i, stamp, tag, threshold, floor_y);
        return;
    }
    uint gid = TX_GID();
    if (gid < n)
        adaptive_mark_one(accum, sum_y2, active, gid, stamp, tag, threshold, floor_y);
}

/* Row r's pixels that go on (a 3x3 neighbourhood within the block carries the tag t): their
 * count, and where `out` is not NULL their tile indices written from out[k] in order. A window
 * sliding along the row: column x's 3x1 neighbourhood (the rows above and below where they are
 * in the block and the tile, else row r itself) is read once for three pixels. */
static inline uint adaptive_row(__global const uchar* stamp, uchar t, uint r, uint rows, uint width, uint row0,
                                uint block_rows, __global uint* out, uint k)
{
    uint y = row0 + r, b = TX_MAX(block_rows, 1u);
    __global const uchar* s0 = stamp + r * width;
    __global const uchar* su = (r > 0u && (y % b) != 0u) ? s0 - width : s0;
    __global const uchar* sd = (r + 1u < rows && (y % b) != b - 1u) ? s0 + width : s0;
#define TX_AD_COL(x) ((su[x] == t) | (s0[x] == t) | (sd[x] == t))
    uint n = 0u;
    int prev = 0, cur = width ? TX_AD_COL(0) : 0;
    for (uint x = 0; x < width; ++x) {
        int next = x + 1u < width ? TX_AD_COL(x + 1u) : 0;
        if (prev | cur | next) {
            if (out) out[k + n] = r * width + x;
            ++n;
        }
        prev = cur; cur = next;
    }
#undef TX_AD_COL
    return n;
}

/* Row r's count of pixels that go on. */
__kernel void adaptive_count(__global const uchar* stamp, uint tag, uint rows, uint width, uint row0,
                             uint block_rows, __global uint* row_count)
{
    uint r = TX_GID();
    if (r < rows)
        row_count[r] = adaptive_row(stamp, (uchar)tag, r, rows, width, row0, block_rows, 0, 0u);
}

/* The rows' first entries in the list (an exclusive prefix sum of their counts, in place)
 * and the list's length in *count: one work-item, a tile's rows in turn. */
__kernel void adaptive_scan(__global uint* row_count, uint rows, __global uint* count)
{
    if (TX_GID() != 0u) return;
    uint total = 0u;
    for (uint r = 0; r < rows; ++r) {
        uint c = row_count[r];
        row_count[r] = total;
        total += c;
    }
    *count = total;
}

/* Row r's pixels that go on, in order, from its first entry of the list. */
__kernel void adaptive_list(__global const uchar* stamp, uint tag, uint rows, uint width, uint row0,
                            uint block_rows, __global const uint* row_first, __global uint* active)
{
    uint r = TX_GID();
    if (r < rows)
        adaptive_row(stamp, (uchar)tag, r, rows, width, row0, block_rows, active, row_first[r]);
}

#endif
