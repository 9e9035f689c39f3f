#line 2 "accel/packet_vec.h"
/* 3-vectors with one component per packet lane (pfloat3), and the scalar helpers the
 * packet intersectors mirror (geometry/quad_packet.h, sphere_packet.h), each rounding
 * as its scalar original does: dot3 and cross3 as core/common.h compiles them (FP
 * contraction on: they sit in a block that turns it on), Kahan's product and TwoSum
 * (core/accurate.h) with the same explicit fma and additions, contraction off. Lane j of
 * each result is the scalar helper's result for lane j's inputs, bit for bit. Always inlined:
 * PoCL left pf3_cross_accurate out of line (11% of a brick wall's frame in calls passing
 * structs through memory); inlined, tools/ab.py measured 0.95-0.98 of the frame time on the
 * brick wall, globe and grazing quad (16 spp, 5 rounds). */
#ifndef TEXRAY_PACKET_VEC_H
#define TEXRAY_PACKET_VEC_H

/* (E(0), E(1), .., E(TX_PACKET - 1)): one expression per lane as a vector literal, a gather
 * straight into a vector (shading/shadow.h, shading/light_packet.h). */
#define PGATHER(E) PGATHER_(E, TX_PACKET)
#define PGATHER_(E, n) PGATHER__(E, n)
#define PGATHER__(E, n) PGATHER_##n(E)
#define PGATHER_8(E) (E(0), E(1), E(2), E(3), E(4), E(5), E(6), E(7))
#define PGATHER_16(E) (E(0), E(1), E(2), E(3), E(4), E(5), E(6), E(7), E(8), E(9), E(10), E(11), E(12), E(13), \
                       E(14), E(15))
/* The same with an argument passed on: (E(0, a), E(1, a), ..). */
#define PGATHER_A(E, a) PGATHER_A_(E, a, TX_PACKET)
#define PGATHER_A_(E, a, n) PGATHER_A__(E, a, n)
#define PGATHER_A__(E, a, n) PGATHER_A_##n(E, a)
#define PGATHER_A_8(E, a) (E(0, a), E(1, a), E(2, a), E(3, a), E(4, a), E(5, a), E(6, a), E(7, a))
#define PGATHER_A_16(E, a) (E(0, a), E(1, a), E(2, a), E(3, a), E(4, a), E(5, a), E(6, a), E(7, a), E(8, a), \
                            E(9, a), E(10, a), E(11, a), E(12, a), E(13, a), E(14, a), E(15, a))
/* A three-float field f of each lane's record, E(j, f[0]) .. E(j, f[2]), as a pfloat3. */
#define PGATHER_F3(E, f) pf3((pfloat)PGATHER_A(E, f[0]), (pfloat)PGATHER_A(E, f[1]), (pfloat)PGATHER_A(E, f[2]))

/* A 3-vector per lane. */
typedef struct {
    pfloat x, y, z;
} pfloat3;

static inline __attribute__((always_inline)) pfloat3 pf3(pfloat x, pfloat y, pfloat z) { pfloat3 v = { x, y, z }; return v; }
static inline __attribute__((always_inline)) pfloat3 pf3_splat(float3 a) { return pf3((pfloat)(a.x), (pfloat)(a.y), (pfloat)(a.z)); }
/* a[min(j, m - 1) step] for lanes j as a pfloat3: lanes past m repeat lane m - 1's (m >= 1);
 * step 0 gives a[0] in every lane. */
static inline __attribute__((always_inline)) pfloat3 pf3_gather(const float3* a, uint step, uint m)
{
#define TX_G_X(j) a[TX_MIN((uint)(j), m - 1u) * step].x
#define TX_G_Y(j) a[TX_MIN((uint)(j), m - 1u) * step].y
#define TX_G_Z(j) a[TX_MIN((uint)(j), m - 1u) * step].z
    return pf3((pfloat)PGATHER(TX_G_X), (pfloat)PGATHER(TX_G_Y), (pfloat)PGATHER(TX_G_Z));
#undef TX_G_X
#undef TX_G_Y
#undef TX_G_Z
}
static inline __attribute__((always_inline)) pfloat3 pf3_add(pfloat3 a, pfloat3 b) { return pf3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline __attribute__((always_inline)) pfloat3 pf3_sub(pfloat3 a, pfloat3 b) { return pf3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline __attribute__((always_inline)) pfloat3 pf3_scale(pfloat s, pfloat3 a) { return pf3(s * a.x, s * a.y, s * a.z); }
static inline __attribute__((always_inline)) pfloat3 pf3_abs(pfloat3 a) { return pf3(fabs(a.x), fabs(a.y), fabs(a.z)); }
static inline __attribute__((always_inline)) pfloat3 pf3_max(pfloat3 a, pfloat3 b) { return pf3(PMAX(a.x, b.x), PMAX(a.y, b.y), PMAX(a.z, b.z)); }
static inline __attribute__((always_inline)) pfloat3 pf3_sel(pint c, pfloat3 a, pfloat3 b)
{
    return pf3(PSEL_F(c, a.x, b.x), PSEL_F(c, a.y, b.y), PSEL_F(c, a.z, b.z));
}

#pragma OPENCL FP_CONTRACT ON
/* core/common.h's dot3 and cross3, compiled as they are there (contraction on). */
static inline __attribute__((always_inline)) pfloat pf3_dot(pfloat3 a, pfloat3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline __attribute__((always_inline)) pfloat3 pf3_cross(pfloat3 a, pfloat3 b)
{
    return pf3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
/* core/builtins.h's tx_nextafter, lane by lane: the same cases in the same order as selects. */
static inline __attribute__((always_inline)) pfloat pf_nextafter(pfloat x, pfloat y)
{
    puint u = as_puint(x);
    pfloat r = as_pfloat(PSEL_I((x < y) == (x > 0.0f), as_pint(u + 1u), as_pint(u - 1u)));
    r = PSEL_F(x == 0.0f, as_pfloat(PSEL_I(y > 0.0f, (pint)(1), (pint)((int)0x80000001u))), r);
    r = PSEL_F(x == y, y, r);
    return PSEL_F((x != x) | (y != y), x + y, r);
}
/* core/common.h's offset_point, lane by lane, compiled as there (p + n * offset contracted):
 * each component one float step further along its normal component's sign. */
static inline __attribute__((always_inline)) pfloat pf_offset_step(pfloat q, pfloat n)
{
    pfloat step = pf_nextafter(q, PSEL_F(n > 0.0f, (pfloat)(INFINITY), (pfloat)(-INFINITY)));
    return PSEL_F((n > 0.0f) | (n < 0.0f), step, q);
}
static inline __attribute__((always_inline)) pfloat3 pf3_offset_point(pfloat3 p, pfloat3 n, pfloat offset)
{
    pfloat3 q = pf3(p.x + n.x * offset, p.y + n.y * offset, p.z + n.z * offset);
    return pf3(pf_offset_step(q.x, n.x), pf_offset_step(q.y, n.y), pf_offset_step(q.z, n.z));
}

#if TX_POCL
/* core/builtins.h's tx_log2 and tx_exp2 (PoCL's exp2 and log2) lane by lane, bit for bit:
 * the same statements, compiled as there (contraction on), the special values' branches as
 * lane selects (tests/kernels/test_builtins.py compares every lane with the scalar ones). */
static inline __attribute__((always_inline)) pfloat pf_log2(pfloat x)
{
    pint special = as_pint(as_puint(x) - 0x00800000u >= (puint)(0x7f000000u));   /* not a positive normal */
    pint den = special & (x > 0.0f) & (x < INFINITY);        /* a denormal: normalized exactly */
    x = PSEL_F(den, x * 0x1p23f, x);
    puint u = as_puint(x);
    pint e = (pint)(-127) + PSEL_I(den, (pint)(-23), (pint)(0)) + as_pint(u >> 23);
    pfloat m = as_pfloat((u & 0x007fffffu) | 0x3f800000u);   /* [1, 2) */
    pint big = m > 1.41421356f;                              /* to [sqrt 1/2, sqrt 2] */
    m = PSEL_F(big, m * 0.5f, m);
    e -= big;
    pfloat f = m - 1.0f, s = f / (2.0f + f), z = s * s;
    pfloat r = z * (0.666666667f + z * (0.4f + z * (0.285714286f + z * (0.222222222f + z * 0.181818182f))));
    pfloat y = __builtin_convertvector(e, pfloat) + (f * 1.44269504f - s * (f - r) * 1.44269504f);
    y = PSEL_F(special & (x == INFINITY), x, y);
    y = PSEL_F(special & (x < 0.0f), (pfloat)(NAN), y);
    y = PSEL_F(special & (x == 0.0f), (pfloat)(-INFINITY), y);
    return PSEL_F(x != x, x, y);
}
static inline __attribute__((always_inline)) pfloat pf_exp2(pfloat x)
{
    pint low = ~(x > -150.0f), high = x >= 128.0f;          /* NaN or below half the least denormal; overflow */
    pfloat xr = PSEL_F(low | high, (pfloat)(0.0f), x);
    /* rint(xr): |xr| < 128, so adding and subtracting 1.5 2^23 rounds it to an integer, to
     * nearest even, as rint does (a zero's sign aside, which neither f nor k below tells) */
    pfloat n = (xr + 12582912.0f) - 12582912.0f, f = xr - n;
    pfloat p = 1.0f + f * (0.693147181f + f * (0.240226507f + f * (0.0555041087f + f * (0.00961812911f
              + f * (0.00133335581f + f * (0.000154035304f + f * 1.52527338e-5f))))));
    pint k = __builtin_convertvector(n, pint), k1 = k / 2;
    pfloat y = p * as_pfloat(as_pint(as_puint(k1 + 127) << 23)) * as_pfloat(as_pint(as_puint(k - k1 + 127) << 23));
    y = PSEL_F(high, (pfloat)(INFINITY), y);
    return PSEL_F(low, PSEL_F(x != x, x, (pfloat)(0.0f)), y);
}
#endif
#pragma OPENCL FP_CONTRACT OFF

/* core/accurate.h's tx_diff_prod, tx_cross_accurate and tx_two_diff3, lane by lane. */
static inline __attribute__((always_inline)) pfloat pf_diff_prod(pfloat a, pfloat b, pfloat c, pfloat d)
{
    pfloat cd = c * d;
    pfloat err = fma(-c, d, cd);
    return fma(a, b, -cd) + err;
}
static inline __attribute__((always_inline)) pfloat3 pf3_cross_accurate(pfloat3 a, pfloat3 b)
{
    return pf3(pf_diff_prod(a.y, b.z, a.z, b.y), pf_diff_prod(a.z, b.x, a.x, b.z), pf_diff_prod(a.x, b.y, a.y, b.x));
}
static inline __attribute__((always_inline)) void pf3_two_diff(pfloat3 a, pfloat3 b, pfloat3* hi, pfloat3* lo)
{
    pfloat3 s = pf3_sub(a, b);
    pfloat3 bb = pf3_sub(s, a);
    pfloat3 nb = pf3(-b.x, -b.y, -b.z);
    *lo = pf3_add(pf3_sub(a, pf3_sub(s, bb)), pf3_sub(nb, bb));
    *hi = s;
}

/* core/accurate.h's tx_unit_or, lane by lane: v / |v| (v first divided by its largest
 * component), `fallback` where v is zero or not finite. */
static inline __attribute__((always_inline)) pfloat3 pf3_unit_or(pfloat3 v, pfloat3 fallback)
{
    pfloat m = PMAX(PMAX(fabs(v.x), fabs(v.y)), fabs(v.z));
    pfloat3 u = pf3(v.x / m, v.y / m, v.z / m);
    return pf3_sel((m > 0.0f) & (m <= FLT_MAX), pf3_scale(rsqrt(pf3_dot(u, u)), u), fallback);
}

/* core/common.h's finite3, lane by lane: -1 where every component of v is finite. */
static inline __attribute__((always_inline)) pint pf3_finite(pfloat3 v)
{
    return (fabs(v.x) <= FLT_MAX) & (fabs(v.y) <= FLT_MAX) & (fabs(v.z) <= FLT_MAX);
}

/* core/common.h's normalize3, lane by lane: v * rsqrt(|v|^2) where |v|^2 is a normal finite
 * float; else v divided by its largest component first; v itself where that is 0 or not
 * finite. */
static inline __attribute__((always_inline)) pfloat3 pf3_normalize3(pfloat3 v)
{
    pfloat l2 = pf3_dot(v, v);
    pint direct = (l2 >= FLT_MIN) & (l2 <= FLT_MAX);
    pfloat3 a = pf3_scale(rsqrt(l2), v);
    if (all(direct)) return a;
    pfloat ax = fabs(v.x), ay = fabs(v.y), az = fabs(v.z);
    pfloat m = PSEL_F(ax > ay, ax, ay);
    m = PSEL_F(m > az, m, az);
    pfloat3 w = pf3(v.x / m, v.y / m, v.z / m);
    pfloat3 b = pf3_scale(rsqrt(pf3_dot(w, w)), w);
    return pf3_sel(direct, a, pf3_sel((m > 0.0f) & (m <= FLT_MAX), b, v));
}

/* A packet geometry's vectors as arrays, lane j of each field at [field][j] (TX_GL_* below):
 * where the surface is evaluated as a packet too (shading/surface_packet.h), the geometry
 * stays in this form, read back as vectors, never written lane by lane. `set`: whether a
 * kind has stored its lanes since the packet began (the first stores every lane). */
enum { TX_GL_PX, TX_GL_PY, TX_GL_PZ, TX_GL_NX, TX_GL_NY, TX_GL_NZ, TX_GL_UX, TX_GL_UY, TX_GL_UZ,
       TX_GL_VX, TX_GL_VY, TX_GL_VZ, TX_GL_U, TX_GL_V, TX_GL_EX, TX_GL_EY, TX_GL_EZ, TX_GL_FIELDS };
typedef struct {
    float f[TX_GL_FIELDS][TX_PACKET];
    int set;
} GeomLanes;

/* Lane j's Geom from the vectors of a packet geometry (geometry/sphere_packet.h,
 * quad_packet.h, triangle_packet.h), for the lanes j with ml[j] set (a lane mask stored by
 * the caller); the others' left as they were: into g[j] (g not NULL) and into gl's arrays
 * (gl not NULL; the lanes of m, or every lane for the packet's first kind). */
static inline void geom_store_packet(const int* ml, pfloat3 p, pfloat3 ng, pfloat3 dpdu, pfloat3 dpdv, pfloat u, pfloat v,
                                     pfloat3 perr, Geom* g, GeomLanes* gl)
{
    if (gl) {
        pfloat val[TX_GL_FIELDS] = { p.x, p.y, p.z, ng.x, ng.y, ng.z, dpdu.x, dpdu.y, dpdu.z, dpdv.x, dpdv.y, dpdv.z,
                                     u, v, perr.x, perr.y, perr.z };
        pint m = PLOAD(ml);
        for (int k = 0; k < TX_GL_FIELDS; ++k)
            PSTORE(gl->set ? PSEL_F(m, val[k], PLOAD(gl->f[k])) : val[k], gl->f[k]);
        gl->set = 1;
    }
    if (!g) return;
    float o[17][TX_PACKET];
    PSTORE(p.x, o[0]); PSTORE(p.y, o[1]); PSTORE(p.z, o[2]);
    PSTORE(ng.x, o[3]); PSTORE(ng.y, o[4]); PSTORE(ng.z, o[5]);
    PSTORE(dpdu.x, o[6]); PSTORE(dpdu.y, o[7]); PSTORE(dpdu.z, o[8]);
    PSTORE(dpdv.x, o[9]); PSTORE(dpdv.y, o[10]); PSTORE(dpdv.z, o[11]);
    PSTORE(u, o[12]); PSTORE(v, o[13]);
    PSTORE(perr.x, o[14]); PSTORE(perr.y, o[15]); PSTORE(perr.z, o[16]);
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        if (!ml[j]) continue;
        g[j].p = (float3)(o[0][j], o[1][j], o[2][j]);
        g[j].ng = (float3)(o[3][j], o[4][j], o[5][j]);
        g[j].dpdu = (float3)(o[6][j], o[7][j], o[8][j]);
        g[j].dpdv = (float3)(o[9][j], o[10][j], o[11][j]);
        g[j].uv = (float2)(o[12][j], o[13][j]);
        g[j].perr = (float3)(o[14][j], o[15][j], o[16][j]);
    }
}

/* The lane a gather reads for lanes outside the stored mask ml (ints, nonzero where set):
 * its first lane (lane 0 when it is empty). On PoCL with AVX the lanes as bits (core/builtins.h
 * tx_lane_bits, as any() and all() take them) and their count of trailing zeros: the
 * scan of the stored mask lane by lane took 2-5% of a frame (perf, the textured meshes'
 * ground). Elsewhere the scan (no bit counting: LLVM's ctlz and cttz intrinsics are not all
 * Oclgrind 21.10 runs). */
static inline uint packet_first_lane(const int* ml)
{
#if TX_POCL && defined(__AVX__)
    uint bits = tx_lane_bits(PLOAD(ml) != (pint)(0));
    return bits != 0u ? (uint)__builtin_ctz(bits) : 0u;
#else
    uint k0 = 0u;
    for (uint j = TX_PACKET; j-- > 0u;)
        if (ml[j]) k0 = j;
    return k0;
#endif
}

/* Whether every lane of the stored mask ml holds idx[k0] (k0: its first lane,
 * packet_first_lane): then a packet geometry reads that one primitive once, as vectors of one
 * value, instead of gathering it lane by lane (the same values, so the same bits). One vector
 * comparison (a loop over the lanes took 1-2% of a frame). */
static inline int packet_one_index(const int* ml, const uint* idx, uint k0)
{
    pint other = PLOAD(idx) != (puint)(idx[k0]);
    return !any((PLOAD(ml) != (pint)(0)) & other);
}

#endif
