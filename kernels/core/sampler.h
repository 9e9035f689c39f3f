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
/* One round of Kensler's permutation hash, on i in place: written once for uint and for
 * the packet's uint vectors (cmj_permute, cmj_permute_packet); p and w are scalars. */
#define TX_CMJ_ROUND(i, p, w) do {                          \
        i ^= (p);             i *= 0xe170893du;             \
        i ^= (p) >> 16;       i ^= (i & (w)) >> 4;          \
        i ^= (p) >> 8;        i *= 0x0929eb3fu;             \
        i ^= (p) >> 23;       i ^= (i & (w)) >> 1;          \
        i *= 1u | (p) >> 27;  i *= 0x6935fa69u;             \
        i ^= (i & (w)) >> 11; i *= 0x74dcb303u;             \
        i ^= (i & (w)) >> 2;  i *= 0x9e501cc3u;             \
        i ^= (i & (w)) >> 2;  i *= 0xc860a3dfu;             \
        i &= (w);             i ^= i >> 5;                  \
    } while (0)

/* floor(log2 m) for m >= 1, from the float's exponent: exact below 2^24 (above, m rounds, and
 * a caller's test m == 1u << k then holds only for a power of two, as it should). Not
 * (m & (m - 1)) == 0, which LLVM turns into llvm.ctpop: Oclgrind 21.10 cannot run it. */
static inline uint cmj_log2(uint m) { return (as_uint((float)m) >> 23) - 127u; }

/* The mask w = 2^k - 1 >= l - 1 of cmj_permute (l >= 2). */
static inline uint cmj_mask(uint l)
{
    uint w = l - 1u;
    w |= w >> 1; w |= w >> 2; w |= w >> 4; w |= w >> 8; w |= w >> 16;
    return w;
}

inline uint cmj_permute(uint i, uint l, uint p)
{
    if (l <= 1u) return 0u;
    uint w = cmj_mask(l);
    for (uint walk = 0u; walk <= w; ++walk) {
        TX_CMJ_ROUND(i, p, w);
        if (i < l) break;
    }
    /* (i + p) % l; a power of two l (w = l - 1) as a mask: the same value without a
     * division (CMJ's counts are powers of two at the usual spp). */
    return w + 1u == l ? (i + p) & w : (i + p) % l;
}

/* Kensler's randfloat hash, on i in place (uint or uint vectors; p a scalar); the float is
 * i * 2^-32 (slightly less, so that it stays below 1). */
#define TX_CMJ_RANDBITS(i, p) do {                          \
        i ^= (p);          i ^= i >> 17;                    \
        i ^= i >> 10;      i *= 0xb36534e5u;                \
        i ^= i >> 12;      i ^= i >> 21;                    \
        i *= 0x93fc4795u;  i ^= 0xdf6e307fu;                \
        i ^= i >> 17;      i *= 1u | (p) >> 18;             \
    } while (0)
#define TX_CMJ_RANDSCALE (1.0f / 4294967808.0f)

static inline float cmj_randfloat(uint i, uint p)
{
    TX_CMJ_RANDBITS(i, p);
    return (float)i * TX_CMJ_RANDSCALE;
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
static inline uint cmj_grid_m(uint N)
{
    if (N == 0u) return 1u;
    uint m = TX_MIN((uint)sqrt((float)N), 65535u);
    while (m * m > N) --m;                                   /* m >= 1: 1 <= N */
    while (m < 65535u && (m + 1u) * (m + 1u) <= N) ++m;
    while (N % m) --m;
    return m;
}

/* Kensler's salts of the pattern p for the sample's permutation, its column and row
 * permutations and its two jitters (cmj_sample_m, cmj_sample_packet). */
#define TX_CMJ_SALT_S 0x51633e2du
#define TX_CMJ_SALT_X 0x68bc21ebu
#define TX_CMJ_SALT_Y 0x02e5be93u
#define TX_CMJ_SALT_JX 0x967a889bu
#define TX_CMJ_SALT_JY 0x368cc8b7u
#define TX_CMJ_SALT_R 0x7d4b2c19u     /* adaptive order's row and column permutations (cmj_cell) */
#define TX_CMJ_SALT_C 0x3a96f1e5u

/* The grid cell s (column s % m, row s / m) that sample k of pattern p takes.
 *
 * Kensler's order: s = a random permutation of k. A whole pattern is stratified, but
 * its first samples are a random subset of the cells, no better spread than independent
 * samples: adaptive sampling (TX_ADAPTIVE, texray.renderer.adaptive), which may stop a
 * pixel after any round of its samples, measured twice the error of a whole pattern of
 * as many samples (textured meshes, rounds of 8 of a 32-sample pattern: RMSE 0.0086 at
 * 8.5 samples per pixel against 0.0042 for 8-sample patterns).
 *
 * With TX_ADAPTIVE the order is stratified from the first sample: k takes row k % n and
 * column (k + k / L) % m, L = lcm(m, n), each through its own random permutation of the
 * pattern (rows and columns relabelled, so that each sample is uniform over the pixel).
 * Any first t n samples then take every row t times, any first samples every column
 * equally often to within one (round robin, shifted by one at each multiple of L); within
 * a run of L samples the (row, column) pairs differ (Chinese remainder theorem), and the
 * shift gives each run its own class of row - column modulo gcd(m, n): all N take every
 * cell once, the same stratification as Kensler's, in another order. */
static inline uint cmj_lcm(uint m, uint n)
{
    uint a = m, b = n;
    while (b != 0u) { uint t = a % b; a = b; b = t; }      /* Euclid: a = gcd(m, n), O(log n) steps */
    return a != 0u ? m / a * n : 1u;
}

static inline uint cmj_cell(uint k, uint N, uint m, uint p)
{
#if TX_ADAPTIVE
    uint n = TX_MAX(N / m, 1u);                             /* N = 0 (never asked): cell 0 */
    return cmj_permute((k + k / cmj_lcm(m, n)) % m, m, p * TX_CMJ_SALT_C)
         + m * cmj_permute(k % n, n, p * TX_CMJ_SALT_R);
#else
    return cmj_permute(k, N, p * TX_CMJ_SALT_S);
#endif
}

/* cmj_sample with the grid's m = cmj_grid_m(N) computed by the caller (once per pixel). */
static inline float2 cmj_sample_m(uint s, uint N, uint m, uint p)
{
    uint n = N / m;
    s = cmj_cell(s, N, m, p);
    uint sx = cmj_permute(s % m, m, p * TX_CMJ_SALT_X);
    uint sy = cmj_permute(s / m, n, p * TX_CMJ_SALT_Y);
    float jx = cmj_randfloat(s, p * TX_CMJ_SALT_JX);
    float jy = cmj_randfloat(s, p * TX_CMJ_SALT_JY);
    return (float2)(((float)(s % m) + ((float)sy + jx) / (float)n) / (float)m,
                    ((float)(s / m) + ((float)sx + jy) / (float)m) / (float)n);
}

static inline float2 cmj_sample(uint s, uint N, uint p)
{
    return cmj_sample_m(s, N, cmj_grid_m(N), p);
}

#if TX_PACKET
/* cmj_sample_m for 8 or 16 samples, one per lane (stages/fused.cl's chunks of camera rays):
 * cmj_sample_packet8 and cmj_sample_packet16, core/sampler_packet.h at each width. The
 * fused kernel takes the positions of two chunks of 8 in one call of the 16-lane version
 * where two are left: the hashes are a chain of dependent multiplies (latency bound: 9% of
 * the globe's frame at 8 lanes), so that 16 lanes take little more time than 8. Where one
 * chunk is left (4 spp: two pixels of 4 samples per work-item) the 8-lane version: 16 lanes
 * there measured 1.05-1.1 of the frame time. */
#define TX_CMJ_T(t) TX_CMJ_T_(t, TX_CMJ_N)
#define TX_CMJ_T_(t, n) TX_CMJ_T__(t, n)
#define TX_CMJ_T__(t, n) t##n
#define TX_LANE_IDS_8 (0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u)
#define TX_LANE_IDS_16 (0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 9u, 10u, 11u, 12u, 13u, 14u, 15u)
#define TX_CMJ_N 8
#include "core/sampler_packet.h"
#undef TX_CMJ_N
#define TX_CMJ_N 16
#include "core/sampler_packet.h"
#undef TX_CMJ_N
#define TX_CMJ_W 16                             /* the widest: stages/fused.cl's positions */
/* Lane ids, a uint load and its conversion to float at the packet's width (accel/packet.h's
 * TX_PACKET lanes: stages/fused.cl's camera rays, shading/shadow.h), spelled out per width:
 * see core/sampler_packet.h. */
#if TX_PACKET == 16
#define TX_PKT_LANE_IDS (uint16)TX_LANE_IDS_16
#define TX_PKT_TO_FLOAT(v) convert_float16(v)
#define TX_PKT_ULOAD(p) vload16(0, p)
#else
#define TX_PKT_LANE_IDS (uint8)TX_LANE_IDS_8
#define TX_PKT_TO_FLOAT(v) convert_float8(v)
#define TX_PKT_ULOAD(p) vload8(0, p)
#endif
#endif

static inline uint hash_u32(uint x)
{
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

/* One light per camera sample (TX_ONE_LIGHT, render(light_sampling="one")): the light that
 * sample `sample` of the pixel with CMJ pattern p takes, of n >= 1, given the pixel's
 * light_offset off. The pixel's samples take the lights in turn, in blocks of b consecutive
 * samples (light_block), from the offset: any run of a pixel's samples gives every light the
 * same count to within b (stratified, not drawn per sample: less noise for the same work), and
 * a pixel whose spp is a multiple of n gives each light exactly 1/n of them. Each sample's
 * position in the pixel is uniform whatever its index, so the estimator n x (the picked
 * light's term) is unbiased: exactly where spp is a multiple of n, else on average over the
 * per-pixel offsets. n = 0: 0 (no light is then read). */
#define TX_LIGHT_SALT 0x2c1b3c6du              /* light_offset's and the adaptive order's */
static inline uint light_pick(uint sample, uint p, uint off, uint n, uint b)
{
    if (n == 0u) return 0u;
    b = b > 1u ? b : 1u;
#if TX_ADAPTIVE
    /* b (light_block): the pattern's row count n. cmj_cell takes the rows in turn, so that
     * the lights in turn would tie each light to rows (or columns); each run of b samples
     * takes them in a random order of its own instead (each light as often, on random rows) */
    uint i = sample - sample % b + cmj_permute(sample % b, b, hash_u32(p ^ TX_LIGHT_SALT ^ (sample / b)));
#else
    uint i = sample >> cmj_log2(b);              /* sample / b: light_block's b is a power of two */
#endif
    uint k = i % n + off;                        /* (i % n + off) % n: both terms below n */
    return k >= n ? k - n : k;
}

/* The offset of light_pick for the pixel of pattern p at spp samples, of n lights: drawn per
 * pixel (p hashed with its own salt, independent of the positions' permutations,
 * TX_CMJ_SALT_*) where n does not divide spp, so that the lights short of a sample differ from
 * pixel to pixel; 0 where it does (and not with adaptive sampling), for there every light
 * takes exactly spp / n of each pixel's samples whatever the offset, and sample k's position
 * is a random permutation's per pixel (cmj_cell), so the offset moved nothing but which
 * samples go where: without it, sample k of every pixel takes the same light, and a packet of
 * several pixels' block k (stages/fused.cl, light blocks) traces its shadow rays toward one
 * light. n = 0: 0. */
static inline uint light_offset(uint p, uint spp, uint n)
{
    if (n == 0u) return 0u;
#if !TX_ADAPTIVE
    if (spp % n == 0u) return 0u;
#endif
    return hash_u32(p ^ TX_LIGHT_SALT) % n;
}

/* The block b of light_pick for a pixel of spp samples and n lights: the largest power of two
 * up to 8 with spp a multiple of n b (1 where spp is no multiple of n), so that every light
 * gets exactly spp / n of the pixel's samples wherever n divides spp (blocks that do not
 * divide spp evenly among the lights measured an RMSE 5-10 times higher at 12 and 24 spp).
 * Blocks of 8 let a packet of 8 consecutive samples (accel/packet.h) trace its shadow rays
 * toward one light, as coherent as with every light; a packet of 16 takes one block of each of
 * 16 / b pixels (stages/fused.cl, light blocks). Adaptive sampling
 * (TX_ADAPTIVE) may stop a pixel after any round: there b is the rows of the pixel's sample
 * grid, each run of them giving every light its share in an order of its own (light_pick). A function of the image's spp and the light count only, so every
 * path (packets or not, the staged pipeline) picks the same lights. */
static inline uint light_block(uint spp, uint n)
{
#if TX_ADAPTIVE
    return TX_MAX(spp / cmj_grid_m(spp), 1u);
#else
    uint b = 1u;
    while (b < 8u && n != 0u && spp % (2u * b * n) == 0u) b *= 2u;
    return b;
#endif
}

#endif
