#line 2 "core/sampler.h"
/* Pixel sample positions: correlated multi-jittered sampling (Kensler 2013,
 * "Correlated Multi-Jittered Sampling", Pixar TM 13-01), which stratifies any
 * sample count N both as an m x n grid (m = floor(sqrt N), n = ceil(N / m))
 * and in each 1-D projection. Sample s of pixel p is a pure function of
 * (s, N, p, seed): renders are deterministic and tiles are independent. */
#ifndef TEXRAY_SAMPLER_H
#define TEXRAY_SAMPLER_H

/* Kensler's permute: a bijection of [0, w] (w + 1 the power of two >= l), applied
 * until the value lands in [0, l) (cycle walking). Bound: from i < l the walk stays on
 * i's cycle, which holds a value below l, so it ends within w + 1 - l + 1 <= l steps
 * (w < 2 l); from i >= l (a sample index past the count) a cycle might hold none, so
 * the walk stops after w + 1 steps whatever happens, and the % l keeps the result in
 * range. l <= 1 has the single value 0 (l = 0 would divide by zero). */
inline uint cmj_permute(uint i, uint l, uint p)
{
    if (l <= 1u) return 0u;
    uint w = l - 1u;
    w |= w >> 1; w |= w >> 2; w |= w >> 4; w |= w >> 8; w |= w >> 16;
    for (uint walk = 0u; walk <= w; ++walk) {
        i ^= p;             i *= 0xe170893du;
        i ^= p >> 16;       i ^= (i & w) >> 4;
        i ^= p >> 8;        i *= 0x0929eb3fu;
        i ^= p >> 23;       i ^= (i & w) >> 1;
        i *= 1u | p >> 27;  i *= 0x6935fa69u;
        i ^= (i & w) >> 11; i *= 0x74dcb303u;
        i ^= (i & w) >> 2;  i *= 0x9e501cc3u;
        i ^= (i & w) >> 2;  i *= 0xc860a3dfu;
        i &= w;             i ^= i >> 5;
        if (i < l) break;
    }
    /* (i + p) % l; a power of two l (w = l - 1) as a mask: the same value without a
     * division (CMJ's counts are powers of two at the usual spp). */
    return w + 1u == l ? (i + p) & w : (i + p) % l;
}

inline float cmj_randfloat(uint i, uint p)
{
    i ^= p;          i ^= i >> 17;
    i ^= i >> 10;    i *= 0xb36534e5u;
    i ^= i >> 12;    i ^= i >> 21;
    i *= 0x93fc4795u; i ^= 0xdf6e307fu;
    i ^= i >> 17;    i *= 1u | p >> 18;
    return (float)i * (1.0f / 4294967808.0f);
}

/* Sample s in [0, N) of the pattern p, in [0, 1)^2.
 *
 * The grid is m x n with m n = N exactly: m is the largest divisor of N not
 * above sqrt(N). Kensler's m = floor(sqrt N), n = ceil(N / m) leaves cells of
 * the last row empty when m n > N (N = 32: 5 x 7 = 35), so part of every pixel
 * is never sampled and the estimate is biased (the bench's spp sweep showed 32
 * spp further from the reference than 16). A prime N gets a 1 x N grid: still
 * one sample per 1/N band in each axis, and unbiased.
 *
 * Bounds: m starts at the float square root, within one of floor(sqrt N), and is
 * capped at 65535 (65536^2 wraps to 0 in uint), so the first two loops take a step or
 * two, and the third ends at m = 1 at the latest. N = 0 (no samples: the host never
 * asks) gives 1, so that no caller divides by zero. */
inline uint cmj_grid_m(uint N)
{
    if (N == 0u) return 1u;
    uint m = TX_MIN((uint)sqrt((float)N), 65535u);
    while (m * m > N) --m;                                   /* m >= 1: 1 <= N */
    while (m < 65535u && (m + 1u) * (m + 1u) <= N) ++m;
    while (N % m) --m;
    return m;
}

/* cmj_sample with the grid's m = cmj_grid_m(N) computed by the caller (once per pixel). */
inline float2 cmj_sample_m(uint s, uint N, uint m, uint p)
{
    uint n = N / m;
    s = cmj_permute(s, N, p * 0x51633e2du);
    uint sx = cmj_permute(s % m, m, p * 0x68bc21ebu);
    uint sy = cmj_permute(s / m, n, p * 0x02e5be93u);
    float jx = cmj_randfloat(s, p * 0x967a889bu);
    float jy = cmj_randfloat(s, p * 0x368cc8b7u);
    return (float2)(((float)(s % m) + ((float)sy + jx) / (float)n) / (float)m,
                    ((float)(s / m) + ((float)sx + jy) / (float)m) / (float)n);
}

inline float2 cmj_sample(uint s, uint N, uint p)
{
    return cmj_sample_m(s, N, cmj_grid_m(N), p);
}

inline uint hash_u32(uint x)
{
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

#endif
