#line 2 "core/sampler_packet.h"
/* core/sampler.h's cmj_sample_m for TX_CMJ_N samples, one per lane: included by
 * core/sampler.h once per width (TX_CMJ_N = 8, 16; no include guard), defining
 * cmj_permute_packetN, cmj_divmod_packetN and cmj_sample_packetN over uintN and floatN.
 * The same integer hashes and the same float operations, one statement each as in the
 * scalar code (FP contraction, which this file allows, fuses only within a statement), so
 * every lane's position is cmj_sample_m's bit for bit (tests/kernels/test_sampler.py). In
 * the scalar code the three permutations and the divisions by m took 8-16% of a frame
 * (perf, globe and quads at 4-16 spp). */
#define TX_CU TX_CMJ_T(uint)
#define TX_CF TX_CMJ_T(float)
/* The conversion and the store spelled out per width, not pasted: PoCL's headers make
 * `convert_float` and `vstore` macros of their own (_cl_convert_float, ...), which a pasted
 * argument would expand to before the paste, past core/builtins.h's 16-lane versions into a
 * library call that breaks the program on AVX2 targets (builtins.h). */
#if TX_CMJ_N == 16
#define TX_CMJ_TO_FLOAT(v) convert_float16(v)
#define TX_CMJ_STORE(v, p) vstore16(v, 0, p)
#else
#define TX_CMJ_TO_FLOAT(v) convert_float8(v)
#define TX_CMJ_STORE(v, p) vstore8(v, 0, p)
#endif

/* cmj_permute lane by lane (each lane its own pattern p): a lane's walk stops where the
 * scalar one breaks (its value kept, selected by bit operations: see accel/packet.h
 * PSEL_I), the loop when every lane has stopped or after the same w + 1 steps. */
static inline TX_CU TX_CMJ_T(cmj_permute_packet)(TX_CU i, uint l, TX_CU p)
{
    if (l <= 1u) return (TX_CU)(0u);
    uint w = cmj_mask(l);
    TX_CU done = (TX_CU)(0u);
    for (uint walk = 0u; walk <= w; ++walk) {
        TX_CU j = i;
        TX_CMJ_ROUND(j, p, w);
        i = (i & done) | (j & ~done);
        done |= TX_CMJ_T(as_uint)(i < (TX_CU)(l));
        if (all(TX_CMJ_T(as_int)(done))) break;
    }
    return w + 1u == l ? (i + p) & w : (i + p) % l;
}

/* s / m and s % m lane by lane; a power of two m (every power-of-two N) as a shift and a
 * mask, the same values without a division per lane (core/sampler.h cmj_log2). */
static inline void TX_CMJ_T(cmj_divmod_packet)(TX_CU s, uint m, TX_CU* q, TX_CU* r)
{
    uint k = cmj_log2(m);
    if (m == 1u << k) {
        *q = s >> k;
        *r = s & (m - 1u);
    } else {
        *q = s / m;
        *r = s % m;
    }
}

/* cmj_permute_packet where l is a power of two (1 included): one round maps [0, l) onto
 * itself (it ends with i &= w, w = l - 1), so the walk is that round and the result the same
 * value; l = 1 gives 0 (w = 0). Straight-line code, with no exit test per round. */
static inline TX_CU TX_CMJ_T(cmj_permute_pow2_packet)(TX_CU i, uint l, TX_CU p)
{
    uint w = l - 1u;
    TX_CMJ_ROUND(i, p, w);
    return (i + p) & w;
}

/* The body of cmj_sample_packet with the permutation PERM (below). */
#if TX_ADAPTIVE
#define TX_CMJ_CELL(PERM) do {                                 /* cmj_cell's order, lane by lane */ \
        uint n1 = TX_MAX(n, 1u);                                                                    \
        TX_CU run, col, row, unused;                                                                \
        TX_CMJ_T(cmj_divmod_packet)(s, cmj_lcm(m, n1), &run, &unused);                             \
        TX_CMJ_T(cmj_divmod_packet)(s + run, m, &unused, &col);                                    \
        TX_CMJ_T(cmj_divmod_packet)(s, n1, &unused, &row);                                         \
        s = PERM(col, m, p * TX_CMJ_SALT_C) + m * PERM(row, n, p * TX_CMJ_SALT_R);                 \
    } while (0)
#else
#define TX_CMJ_CELL(PERM) do { s = PERM(s, N, p * TX_CMJ_SALT_S); } while (0)
#endif
#define TX_CMJ_SAMPLE(PERM) do {                                                                    \
        TX_CMJ_CELL(PERM);                                                                          \
        TX_CU sd, sm;                                                                               \
        TX_CMJ_T(cmj_divmod_packet)(s, m, &sd, &sm);                                               \
        TX_CU sx = PERM(sm, m, px);                                                                 \
        TX_CU sy = PERM(sd, n, py);                                                                 \
        TX_CU bx = s, by = s;                                                                       \
        TX_CMJ_RANDBITS(bx, pjx);                                                                   \
        TX_CMJ_RANDBITS(by, pjy);                                                                   \
        TX_CF jx = TX_CMJ_TO_FLOAT(bx) * TX_CMJ_RANDSCALE;                                          \
        TX_CF jy = TX_CMJ_TO_FLOAT(by) * TX_CMJ_RANDSCALE;                                          \
        TX_CF fx = (TX_CMJ_TO_FLOAT(sm) + (TX_CMJ_TO_FLOAT(sy) + jx) / (float)n) / (float)m;        \
        TX_CF fy = (TX_CMJ_TO_FLOAT(sd) + (TX_CMJ_TO_FLOAT(sx) + jy) / (float)m) / (float)n;        \
        TX_CMJ_STORE(fx, x);                                                                        \
        TX_CMJ_STORE(fy, y);                                                                        \
    } while (0)

/* Sample s[lane] of pattern p[lane] (cmj_sample_m's N, m, one per lane: stages/fused.cl's
 * chunks, a pixel's consecutive samples or several pixels') into x[lane], y[lane]
 * (TX_CMJ_N of each). Where N is a power of two (so are m, n and their lcm) every
 * permutation is one round, and the sample's permutations -- each a chain of dependent
 * multiplies, latency bound -- are straight-line code the compiler interleaves (cmj_cell's
 * two with TX_ADAPTIVE, then the column's and the row's), where the walks' exit tests kept
 * them one after another. */
/* extern inline where the fused kernel may call it; static (compiled only where called:
 * accel/packet.h) at 8 lanes in a 16-lane program, whose fused kernel never does */
#if TX_CMJ_N == 8 && TX_PACKET == 16
static
#endif
inline void TX_CMJ_T(cmj_sample_packet)(TX_CU s, uint N, uint m, TX_CU p, float* x, float* y)
{
    uint n = N / m;
    TX_CU px = p * TX_CMJ_SALT_X, py = p * TX_CMJ_SALT_Y;
    TX_CU pjx = p * TX_CMJ_SALT_JX, pjy = p * TX_CMJ_SALT_JY;
    if (N == 1u << cmj_log2(N))
        TX_CMJ_SAMPLE(TX_CMJ_T(cmj_permute_pow2_packet));
    else
        TX_CMJ_SAMPLE(TX_CMJ_T(cmj_permute_packet));
}
#undef TX_CMJ_SAMPLE
#undef TX_CMJ_CELL

#undef TX_CMJ_TO_FLOAT
#undef TX_CMJ_STORE
#undef TX_CU
#undef TX_CF
