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

/* The mask w = 2^k - 1 >= l - 1 of cmj_permute (l >= 2). */
inline uint cmj_mask(uint l)
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

inline float cmj_randfloat(uint i, uint p)
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
inline uint cmj_grid_m(uint N)
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
inline uint cmj_lcm(uint m, uint n)
{
    uint a = m, b = n;
    while (b != 0u) { uint t = a % b; a = b; b = t; }      /* Euclid: a = gcd(m, n), O(log n) steps */
    return a != 0u ? m / a * n : 1u;
}

inline uint cmj_cell(uint k, uint N, uint m, uint p)
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
inline float2 cmj_sample_m(uint s, uint N, uint m, uint p)
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

inline float2 cmj_sample(uint s, uint N, uint p)
{
    return cmj_sample_m(s, N, cmj_grid_m(N), p);
}

#if TX_PACKET
/* cmj_sample_m for TX_PACKET samples, one per lane (stages/fused.cl's chunk of camera
 * rays): the same integer hashes and the same
 * float operations, one statement each as in the scalar code (FP contraction, which this
 * file allows, fuses only within a statement), so every lane's position is cmj_sample_m's
 * bit for bit (tests/kernels/test_sampler.py). In the scalar code the three permutations
 * and the divisions by m took 8-16% of a frame (perf, globe and quads at 4-16 spp). */
#define TX_CMJ_VT(t) TX_CMJ_VT_(t, TX_PACKET)
#define TX_CMJ_VT_(t, n) TX_CMJ_VT__(t, n)
#define TX_CMJ_VT__(t, n) t##n
typedef TX_CMJ_VT(uint) cmj_uint;
typedef TX_CMJ_VT(int) cmj_int;
typedef TX_CMJ_VT(float) cmj_float;
/* The conversion, load and store spelled out per width, not pasted by TX_CMJ_VT: PoCL's headers
 * make `convert_float`, `vload` and `vstore` macros of their own (_cl_convert_float, ...), which
 * TX_CMJ_VT's argument would expand to before the paste, past core/builtins.h's 16-lane
 * versions into a library call that breaks the program on AVX2 targets (builtins.h). */
#if TX_PACKET == 16
#define TX_CMJ_LANE_IDS (cmj_uint)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 9u, 10u, 11u, 12u, 13u, 14u, 15u)
#define TX_CMJ_TO_FLOAT(v) convert_float16(v)
#define TX_CMJ_LOAD(p) vload16(0, p)
#define TX_CMJ_STORE(v, p) vstore16(v, 0, p)
#else
#define TX_CMJ_LANE_IDS (cmj_uint)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u)
#define TX_CMJ_TO_FLOAT(v) convert_float8(v)
#define TX_CMJ_LOAD(p) vload8(0, p)
#define TX_CMJ_STORE(v, p) vstore8(v, 0, p)
#endif

/* cmj_permute lane by lane (each lane its own pattern p): a lane's walk stops where the
 * scalar one breaks (its value kept, selected by bit operations: see accel/packet.h
 * PSEL_I), the loop when every lane has stopped or after the same w + 1 steps. */
inline cmj_uint cmj_permute_packet(cmj_uint i, uint l, cmj_uint p)
{
    if (l <= 1u) return (cmj_uint)(0u);
    uint w = cmj_mask(l);
    cmj_uint done = (cmj_uint)(0u);
    for (uint walk = 0u; walk <= w; ++walk) {
        cmj_uint j = i;
        TX_CMJ_ROUND(j, p, w);
        i = (i & done) | (j & ~done);
        done |= TX_CMJ_VT(as_uint)(i < (cmj_uint)(l));
        if (all(TX_CMJ_VT(as_int)(done))) break;
    }
    return w + 1u == l ? (i + p) & w : (i + p) % l;
}

/* s / m and s % m lane by lane; a power of two m (every power-of-two N) as a shift and a
 * mask, the same values without a division per lane. (log2 m from the float's exponent, and
 * no (m & (m - 1)) == 0, which LLVM turns into llvm.ctpop: Oclgrind 21.10 cannot run it.) */
inline void cmj_divmod_packet(cmj_uint s, uint m, cmj_uint* q, cmj_uint* r)
{
    uint k = (as_uint((float)m) >> 23) - 127u;         /* floor(log2 m): m <= 65535 is exact in float */
    if (m == 1u << k) {
        *q = s >> k;
        *r = s & (m - 1u);
    } else {
        *q = s / m;
        *r = s % m;
    }
}

/* Sample s[lane] of pattern p[lane] (cmj_sample_m's N, m, one per lane: stages/fused.cl's
 * chunk, a pixel's consecutive samples or several pixels') into x[lane], y[lane]. */
inline void cmj_sample_packet(cmj_uint s, uint N, uint m, cmj_uint p, float* x, float* y)
{
    uint n = N / m;
    cmj_uint px = p * TX_CMJ_SALT_X, py = p * TX_CMJ_SALT_Y;
    cmj_uint pjx = p * TX_CMJ_SALT_JX, pjy = p * TX_CMJ_SALT_JY;
#if TX_ADAPTIVE
    {                                                    /* cmj_cell's order, lane by lane */
        uint n1 = TX_MAX(n, 1u);
        cmj_uint run, col, row, unused;
        cmj_divmod_packet(s, cmj_lcm(m, n1), &run, &unused);
        cmj_divmod_packet(s + run, m, &unused, &col);
        cmj_divmod_packet(s, n1, &unused, &row);
        s = cmj_permute_packet(col, m, p * TX_CMJ_SALT_C) + m * cmj_permute_packet(row, n, p * TX_CMJ_SALT_R);
    }
#else
    s = cmj_permute_packet(s, N, p * TX_CMJ_SALT_S);
#endif
    cmj_uint sd, sm;
    cmj_divmod_packet(s, m, &sd, &sm);
    cmj_uint sx = cmj_permute_packet(sm, m, px);
    cmj_uint sy = cmj_permute_packet(sd, n, py);
    cmj_uint bx = s, by = s;
    TX_CMJ_RANDBITS(bx, pjx);
    TX_CMJ_RANDBITS(by, pjy);
    cmj_float jx = TX_CMJ_TO_FLOAT(bx) * TX_CMJ_RANDSCALE;
    cmj_float jy = TX_CMJ_TO_FLOAT(by) * TX_CMJ_RANDSCALE;
    cmj_float fx = (TX_CMJ_TO_FLOAT(sm) + (TX_CMJ_TO_FLOAT(sy) + jx) / (float)n) / (float)m;
    cmj_float fy = (TX_CMJ_TO_FLOAT(sd) + (TX_CMJ_TO_FLOAT(sx) + jy) / (float)m) / (float)n;
    TX_CMJ_STORE(fx, x);
    TX_CMJ_STORE(fy, y);
}
#endif

inline uint hash_u32(uint x)
{
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

/* One light per camera sample (TX_ONE_LIGHT, render(light_sampling="one")): the light that
 * sample `sample` of the pixel with CMJ pattern p takes, of n >= 1. The pixel's samples take
 * the lights in turn, in blocks of b consecutive samples (light_block), from an offset drawn
 * per pixel: any run of a pixel's samples gives every light the same count to within b
 * (stratified, not drawn per sample: less noise for the same work), and a pixel whose spp is
 * a multiple of n gives each light exactly 1/n of them. Each sample's position in the pixel
 * is uniform whatever its index, so the estimator n x (the picked light's term) is unbiased:
 * exactly where spp is a multiple of n, else on average over the per-pixel offsets. The
 * offset hashes p with its own salt, independent of the positions' permutations
 * (TX_CMJ_SALT_*). n = 0: 0 (no light is then read). */
#define TX_LIGHT_SALT 0x2c1b3c6du
inline uint light_pick(uint sample, uint p, uint n, uint b)
{
    if (n == 0u) return 0u;
    b = b > 1u ? b : 1u;
#if TX_ADAPTIVE
    /* b (light_block): the pattern's row count n. cmj_cell takes the rows in turn, so that
     * the lights in turn would tie each light to rows (or columns); each run of b samples
     * takes them in a random order of its own instead (each light as often, on random rows) */
    uint i = sample - sample % b + cmj_permute(sample % b, b, hash_u32(p ^ TX_LIGHT_SALT ^ (sample / b)));
#else
    uint i = sample / b;
#endif
    return (i % n + hash_u32(p ^ TX_LIGHT_SALT) % n) % n;
}

/* The block b of light_pick for a pixel of spp samples and n lights: the largest power of two
 * up to 8 with spp a multiple of n b (1 where spp is no multiple of n), so that every light
 * gets exactly spp / n of the pixel's samples wherever n divides spp (blocks that do not
 * divide spp evenly among the lights measured an RMSE 5-10 times higher at 12 and 24 spp).
 * Blocks of 8 let a packet of 8 consecutive samples (accel/packet.h) trace its shadow rays
 * toward one light, as coherent as with every light. Adaptive sampling
 * (TX_ADAPTIVE) may stop a pixel after any round: there b = 1, so that every round holds
 * every light's samples. A function of the image's spp and the light count only, so every
 * path (packets or not, the staged pipeline) picks the same lights. */
inline uint light_block(uint spp, uint n)
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
