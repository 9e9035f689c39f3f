#line 2 "core/builtins.h"
/* Inline versions of builtins that PoCL calls out of line (TX_POCL: the host defines it
 * for PoCL devices only, texray.device.opencl). PoCL links its builtin library as code
 * built for a generic CPU, and LLVM does not inline a function whose target features
 * differ from its caller's, so every fabs, floor, fma, nextafter, copysign, sqrt, rsqrt,
 * vload3, vstore3, isnan, isinf, isfinite, any and all in a kernel was a call (perf on the globe scene: 10% of the frame in them).
 * Each replacement returns the very same float as PoCL's builtin for every input
 * (IEEE-754 defines all but rsqrt exactly, and PoCL's rsqrt is 1 / sqrt), so images
 * keep their bits (tests/kernels/test_builtins.py compares them on a million inputs). PoCL's
 * headers make each builtin a macro for its _cl_ name; these take the names over; other drivers inline their own builtins and keep them. */
#ifndef TEXRAY_BUILTINS_H
#define TEXRAY_BUILTINS_H
#if TX_POCL
/* On a CPU that PoCL's LLVM 14 compiles for without AVX-512 (znver3 on an AMD EPYC), clang
 * warns at every function that takes or passes a 16-lane vector ("AVX vector argument of type
 * float16 without 'avx512f' enabled changes the ABI", -Wpsabi), and -Werror builds
 * (tests/portability/test_build.py) failed. Within the program every such call has one ABI;
 * the hazard is a call into PoCL's library, built with AVX-512: none is left (the 16-lane
 * versions below), and test_packet.py checks that 16-lane programs build, run and reload. */
#pragma clang diagnostic ignored "-Wpsabi"

/* |x|: the sign bit cleared (NaN stays NaN). */
__attribute__((overloadable)) inline float tx_fabs(float x) { return as_float(as_uint(x) & 0x7fffffffu); }
__attribute__((overloadable)) inline float2 tx_fabs(float2 x) { return as_float2(as_uint2(x) & 0x7fffffffu); }
__attribute__((overloadable)) inline float3 tx_fabs(float3 x) { return as_float3(as_uint3(x) & 0x7fffffffu); }
__attribute__((overloadable)) inline float4 tx_fabs(float4 x) { return as_float4(as_uint4(x) & 0x7fffffffu); }
__attribute__((overloadable)) inline float8 tx_fabs(float8 x) { return as_float8(as_uint8(x) & 0x7fffffffu); }
__attribute__((overloadable)) inline float16 tx_fabs(float16 x) { return as_float16(as_uint16(x) & 0x7fffffffu); }
#undef fabs
#define fabs tx_fabs

/* floor and fma as LLVM's intrinsics, which become one instruction (roundss; vfmadd
 * where the target has FMA: __FMA__, else PoCL's own, correctly rounded, call). */
__attribute__((overloadable)) inline float tx_floor(float x) { return __builtin_floorf(x); }
#if defined(__AVX__)
__attribute__((overloadable)) inline float8 tx_floor(float8 x) { return __builtin_ia32_roundps256(x, 9); }  /* toward -inf */
#else
__attribute__((overloadable)) inline float8 tx_floor(float8 x)
{
    return (float8)(__builtin_floorf(x.s0), __builtin_floorf(x.s1), __builtin_floorf(x.s2), __builtin_floorf(x.s3),
                    __builtin_floorf(x.s4), __builtin_floorf(x.s5), __builtin_floorf(x.s6), __builtin_floorf(x.s7));
}
#endif
__attribute__((overloadable)) inline float16 tx_floor(float16 x) { return (float16)(tx_floor(x.lo), tx_floor(x.hi)); }
#undef floor
#define floor tx_floor
#if defined(__FMA__)
__attribute__((overloadable)) inline float tx_fma(float a, float b, float c) { return __builtin_fmaf(a, b, c); }
/* The packets' vectors (accel/packet.h) as one vfmadd (each lane rounded once, as the
 * scalar fma: the same floats). Written lane by lane, LLVM had left them scalar, joined by
 * inserts (the packets' sphere test: 80 scalar FMAs, 2026-12-06). */
__attribute__((overloadable)) inline float4 tx_fma(float4 a, float4 b, float4 c)
{
    return __builtin_ia32_vfmaddps(a, b, c);
}
__attribute__((overloadable)) inline float8 tx_fma(float8 a, float8 b, float8 c)
{
    return __builtin_ia32_vfmaddps256(a, b, c);
}
__attribute__((overloadable)) inline float16 tx_fma(float16 a, float16 b, float16 c)
{
    return (float16)(tx_fma(a.lo, b.lo, c.lo), tx_fma(a.hi, b.hi, c.hi));
}
#undef fma
#define fma tx_fma
#endif

/* The next float after x toward y (C99 nextafter): one step of the bit pattern, away
 * from zero when y is farther from zero on x's side, else toward it; from +-0 the
 * smallest denormal of y's sign; NaN in, NaN out; x == y gives y. */
static inline float tx_nextafter(float x, float y)
{
    if (x != x || y != y) return x + y;
    if (x == y) return y;
    if (x == 0.0f) return as_float(y > 0.0f ? 1u : 0x80000001u);
    uint u = as_uint(x);
    return as_float((x < y) == (x > 0.0f) ? u + 1u : u - 1u);
}
#undef nextafter
#define nextafter tx_nextafter

/* copysign: x's magnitude bits with y's sign bit. */
__attribute__((overloadable)) inline float tx_copysign(float x, float y)
{
    return as_float((as_uint(x) & 0x7fffffffu) | (as_uint(y) & 0x80000000u));
}
__attribute__((overloadable)) inline float8 tx_copysign(float8 x, float8 y)
{
    return as_float8((as_uint8(x) & 0x7fffffffu) | (as_uint8(y) & 0x80000000u));
}
__attribute__((overloadable)) inline float16 tx_copysign(float16 x, float16 y)
{
    return as_float16((as_uint16(x) & 0x7fffffffu) | (as_uint16(y) & 0x80000000u));
}
#undef copysign
#define copysign tx_copysign

/* sqrt (correctly rounded: sqrtss) and rsqrt as PoCL computes it, 1 / sqrt(x). The vector
 * versions as the CPU's vector square root where the target has it (sqrtps, vsqrtps: each
 * lane correctly rounded, so the same floats): LLVM left four or eight lanes of sqrtss
 * apart, joined by inserts (the packets' sphere geometry: 69 scalar square roots, none
 * packed, 2026-12-06). */
__attribute__((overloadable)) inline float tx_sqrt(float x) { return __builtin_sqrtf(x); }
__attribute__((overloadable)) inline float4 tx_sqrt(float4 x)
{
#if defined(__SSE__)
    return __builtin_ia32_sqrtps(x);
#else
    return (float4)(__builtin_sqrtf(x.x), __builtin_sqrtf(x.y), __builtin_sqrtf(x.z), __builtin_sqrtf(x.w));
#endif
}
__attribute__((overloadable)) inline float8 tx_sqrt(float8 x)
{
#if defined(__AVX__)
    return __builtin_ia32_sqrtps256(x);
#else
    return (float8)(tx_sqrt(x.lo), tx_sqrt(x.hi));
#endif
}
__attribute__((overloadable)) inline float16 tx_sqrt(float16 x) { return (float16)(tx_sqrt(x.lo), tx_sqrt(x.hi)); }
#undef sqrt
#define sqrt tx_sqrt
__attribute__((overloadable)) inline float tx_rsqrt(float x) { return 1.0f / __builtin_sqrtf(x); }
__attribute__((overloadable)) inline float8 tx_rsqrt(float8 x) { return 1.0f / tx_sqrt(x); }
__attribute__((overloadable)) inline float16 tx_rsqrt(float16 x) { return 1.0f / tx_sqrt(x); }
#undef rsqrt
#define rsqrt tx_rsqrt

/* vload3(o, p): three scalar loads (any address space; o and p are evaluated more than
 * once, so callers pass plain expressions). */
#undef vload3
#define vload3(o, p) ((float3)((p)[3 * (o)], (p)[3 * (o) + 1], (p)[3 * (o) + 2]))
/* vload2(o, p) of floats and ushorts (uvs, texture transforms, displacement heights): two
 * scalar loads, not PoCL's call (_cl_vload2: 0.4% of the textured meshes' frame). */
#define TX_VLOAD2(T, AS)                                                                           \
    __attribute__((overloadable)) inline T##2 tx_vload2(size_t o, const AS T* p)                   \
    {                                                                                              \
        return (T##2)(p[2 * o], p[2 * o + 1]);                                                     \
    }
TX_VLOAD2(float, __global)
TX_VLOAD2(float, __private)
TX_VLOAD2(float, __constant)
TX_VLOAD2(ushort, __global)
#undef TX_VLOAD2
#undef vload2
#define vload2 tx_vload2
/* tx_lane_bits(intN): the lanes' sign bits as a bit mask (lane j: bit j), where the target has
 * AVX: one movmskps per 8 lanes, and with AVX-512 (kernels/texray.cl TX_AVX512) the 16 bits as
 * one mask register (a lane mask from a comparison already is one: no shuffle). any() and
 * all() below test them (a lane mask's test in every packet traversal step; or-ing the lanes
 * down to one took shuffles and extracts), as does accel/packet_vec.h packet_first_lane. */
#if defined(__AVX__)
__attribute__((overloadable)) inline uint tx_lane_bits(int4 v) { return (uint)__builtin_ia32_movmskps(as_float4(v)); }
__attribute__((overloadable)) inline uint tx_lane_bits(int8 v) { return (uint)__builtin_ia32_movmskps256(as_float8(v)); }
#if TX_AVX512
__attribute__((overloadable)) inline uint tx_lane_bits(int16 v) { return (uint)__builtin_ia32_cvtd2mask512(v); }
#else
__attribute__((overloadable)) inline uint tx_lane_bits(int16 v) { return tx_lane_bits(v.lo) | tx_lane_bits(v.hi) << 8; }
#endif
#endif
/* any(intN): some lane's sign bit set (int8, int16: accel/packet.h's lane masks). */
#if defined(__AVX__)
__attribute__((overloadable)) inline int tx_any(int4 v) { return tx_lane_bits(v) != 0u; }
__attribute__((overloadable)) inline int tx_any(int8 v) { return tx_lane_bits(v) != 0u; }
#else
__attribute__((overloadable)) inline int tx_any(int4 v) { return (v.x | v.y | v.z | v.w) < 0; }
__attribute__((overloadable)) inline int tx_any(int8 v) { return tx_any(v.lo | v.hi); }
#endif
#if TX_AVX512
__attribute__((overloadable)) inline int tx_any(int16 v) { return tx_lane_bits(v) != 0u; }
#else
__attribute__((overloadable)) inline int tx_any(int16 v) { return tx_any(v.lo | v.hi); }
#endif
#undef any
#define any tx_any
/* all(intN): every lane's sign bit set (core/sampler.h's lane masks). */
#if defined(__AVX__)
__attribute__((overloadable)) inline int tx_all(int4 v) { return tx_lane_bits(v) == 0xfu; }
__attribute__((overloadable)) inline int tx_all(int8 v) { return tx_lane_bits(v) == 0xffu; }
#else
__attribute__((overloadable)) inline int tx_all(int4 v) { return (v.x & v.y & v.z & v.w) < 0; }
__attribute__((overloadable)) inline int tx_all(int8 v) { return tx_all(v.lo & v.hi); }
#endif
#if TX_AVX512
__attribute__((overloadable)) inline int tx_all(int16 v) { return tx_lane_bits(v) == 0xffffu; }
#else
__attribute__((overloadable)) inline int tx_all(int16 v) { return tx_all(v.lo & v.hi); }
#endif
#undef all
#define all tx_all

/* vstore3(v, o, p): three scalar stores (a statement; o and p are evaluated more than once). */
#undef vstore3
#define vstore3(v, o, p) do { float3 tx_v_ = (v); (p)[3 * (o)] = tx_v_.x; (p)[3 * (o) + 1] = tx_v_.y; \
                              (p)[3 * (o) + 2] = tx_v_.z; } while (0)
/* vstore16, vload16 (of private float, int or uint arrays and global floats: another address
 * space or type does not compile) and convert_float16 as two 8-lane halves: accel/packet.h's PSTORE,
 * geometry/triangle.h's TX_WOOP_EXACT_EDGES and core/sampler.h at TX_PACKET=16. Not for
 * speed: PoCL 3.0 picks its builtin library by the CPU's features (kernel-x86_64-...-avx512.bc
 * on an AMD EPYC with AVX-512) but compiles kernels for the CPU that LLVM 14 names (znver3,
 * without AVX-512: "AVX vector argument of type float16 without 'avx512f' enabled changes the
 * ABI"), so a 16-lane argument or result crosses between two ABIs. A call of the library's
 * vstore16, vload16 or convert_float16 left bitcode that LLVM cannot read back ("Invalid
 * cast": in the next process the program from PoCL's cache had no kernels) and whose code
 * generation aborted the process ("Do not know how to scalarize this operator's operand").
 * With these, and the inline versions above, no 16-lane value reaches the library
 * (tests/kernels/test_packet.py builds the 16-lane program twice, the second from the
 * cache; 2026-12-04, pocl-binary-distribution 3.0). */
/* vload8 and vstore8 (the 8-lane packets' PLOAD and PSTORE: accel/packet.h), vload4 and
 * vstore4 of floats (a texture's uv transform, texture/texture.h; triangle_intersect4's exact
 * edges, geometry/triangle.h; an instance's rows) and vstore2 of floats to global memory (uv
 * records): each one unaligned vector access through a type aligned like its element
 * (vmovups), not PoCL's call (_cl_vstore8: 0.7% of the grazing quad's frame, 2026-12-05;
 * _cl_vload4 on every texture lookup). The same bytes. TX_VLOAD_U and TX_VSTORE_U define
 * them for N lanes of T in address space AS. */
typedef float tx_float8u __attribute__((ext_vector_type(8), aligned(4)));
typedef int tx_int8u __attribute__((ext_vector_type(8), aligned(4)));
typedef uint tx_uint8u __attribute__((ext_vector_type(8), aligned(4)));
typedef float tx_float4u __attribute__((ext_vector_type(4), aligned(4)));
typedef float tx_float2u __attribute__((ext_vector_type(2), aligned(4)));
#define TX_VSTORE_U(N, T, AS)                                                                     \
    __attribute__((overloadable)) inline void tx_vstore##N(T##N v, size_t o, AS T* p)             \
    {                                                                                             \
        *(AS tx_##T##N##u*)(p + N * o) = v;                                                       \
    }
#define TX_VLOAD_U(N, T, AS)                                                                      \
    __attribute__((overloadable)) inline T##N tx_vload##N(size_t o, const AS T* p)                \
    {                                                                                             \
        return *(const AS tx_##T##N##u*)(p + N * o);                                              \
    }
#define TX_VLOADSTORE_U(N, T, AS) TX_VSTORE_U(N, T, AS) TX_VLOAD_U(N, T, AS)
TX_VLOADSTORE_U(8, float, __private)
TX_VLOADSTORE_U(8, int, __private)
TX_VLOADSTORE_U(8, uint, __private)
TX_VLOADSTORE_U(8, float, __global)
TX_VLOADSTORE_U(8, int, __global)
TX_VLOADSTORE_U(8, uint, __global)
TX_VLOADSTORE_U(4, float, __private)
TX_VLOADSTORE_U(4, float, __global)
TX_VLOAD_U(4, float, __constant)
TX_VSTORE_U(2, float, __global)
#undef TX_VLOADSTORE_U
#undef TX_VLOAD_U
#undef TX_VSTORE_U
#define TX_HALVES16(T, AS)                                                                        \
    __attribute__((overloadable)) inline void tx_vstore16(T##16 v, size_t o, AS T* p)             \
    {                                                                                             \
        tx_vstore8(v.lo, 2 * o, p); tx_vstore8(v.hi, 2 * o + 1, p);                               \
    }                                                                                             \
    __attribute__((overloadable)) inline T##16 tx_vload16(size_t o, const AS T* p)                \
    {                                                                                             \
        return (T##16)(tx_vload8(2 * o, p), tx_vload8(2 * o + 1, p));                             \
    }
TX_HALVES16(float, __private)
TX_HALVES16(int, __private)
TX_HALVES16(uint, __private)
TX_HALVES16(float, __global)
#undef TX_HALVES16
/* convert_float8 of uint8 and int8 (the CMJ sampler's packets, core/sampler_packet.h, and the
 * fused kernel's pixel coordinates) as clang's vector conversion, not PoCL's call
 * (_cl_convert_float8: 18 calls in the two packet samplers). Both are LLVM's uitofp / sitofp
 * of each lane, which IEEE-754 rounds to nearest: the same floats. */
__attribute__((overloadable)) inline float8 tx_convert_float8(uint8 v) { return __builtin_convertvector(v, float8); }
__attribute__((overloadable)) inline float8 tx_convert_float8(int8 v) { return __builtin_convertvector(v, float8); }
#undef convert_float8
#define convert_float8 tx_convert_float8
/* Round to nearest even in either form: the same floats. */
__attribute__((overloadable)) inline float16 tx_convert_float16(uint16 v)
{
    return (float16)(convert_float8(v.lo), convert_float8(v.hi));
}
__attribute__((overloadable)) inline float16 tx_convert_float16(int16 v)
{
    return (float16)(convert_float8(v.lo), convert_float8(v.hi));
}
#undef convert_float16
#define convert_float16 tx_convert_float16
/* convert_int8 and convert_int16 of floats (the packet surface's texel coordinates,
 * shading/surface_packet.h) as LLVM's fptosi of each lane: toward zero, as a C cast. */
__attribute__((overloadable)) inline int8 tx_convert_int8(float8 v) { return __builtin_convertvector(v, int8); }
__attribute__((overloadable)) inline int16 tx_convert_int16(float16 v)
{
    return (int16)(tx_convert_int8(v.lo), tx_convert_int8(v.hi));
}
#undef convert_int8
#define convert_int8 tx_convert_int8
#undef convert_int16
#define convert_int16 tx_convert_int16
#undef vstore16
#define vstore16 tx_vstore16
#undef vload16
#define vload16 tx_vload16
#undef vstore8
#define vstore8 tx_vstore8
#undef vload8
#define vload8 tx_vload8
#undef vstore4
#define vstore4 tx_vstore4
#undef vload4
#define vload4 tx_vload4
#undef vstore2
#define vstore2 tx_vstore2
/* clamp of floats and uints (ray differentials, texture/differentials.h; a cylinder's uv),
 * inline instead of a call (_cl_clamp: four per textured hit). fmin(fmax(x, lo), hi) as
 * OpenCL defines it, with PoCL's choices where IEEE-754 leaves one: a NaN operand gives the
 * other one, and of two equal operands (+0 and -0) each step returns its second, as x86's
 * maxss and minss do (test_builtins.py: PoCL's bits on every pair of special values). */
__attribute__((overloadable)) inline float tx_clamp(float x, float lo, float hi)
{
    float t = x > lo || lo != lo ? x : lo;
    return t < hi || hi != hi ? t : hi;
}
__attribute__((overloadable)) inline float2 tx_clamp(float2 x, float lo, float hi)
{
    return (float2)(tx_clamp(x.x, lo, hi), tx_clamp(x.y, lo, hi));
}
__attribute__((overloadable)) inline uint tx_clamp(uint x, uint lo, uint hi)
{
    uint t = x > lo ? x : lo;
    return t < hi ? t : hi;
}
#undef clamp
#define clamp tx_clamp
/* isnan, isinf, isfinite of a float (1 or 0, as the scalar builtins): its exponent bits. */
static inline int tx_isnan(float x) { return (as_uint(x) & 0x7fffffffu) > 0x7f800000u; }
static inline int tx_isinf(float x) { return (as_uint(x) & 0x7fffffffu) == 0x7f800000u; }
static inline int tx_isfinite(float x) { return (as_uint(x) & 0x7fffffffu) < 0x7f800000u; }
#undef isnan
#define isnan tx_isnan
#undef isinf
#define isinf tx_isinf
#undef isfinite
#define isfinite tx_isfinite

/* exp2 and log2 (Phong's exp2(n log2 x), shading/light.h; a texture's level of detail,
 * texture/texture.h) written out: PoCL's are calls into its library (perf, 640x480 textured
 * meshes: 5.7% of the frame in _cl_exp2 and _cl_log2). Unlike the replacements above they
 * are not PoCL's bits: within 1.5 ulp of float64 (test_builtins.py measures the largest
 * error on a million inputs and checks every special value: zeros, denormals, infinities,
 * NaN, negatives, the range's ends). OpenCL 1.2 allows 3 ulp for both. */
static inline float tx_log2(float x)
{
    uint u = as_uint(x);
    int e = -127;
    if (u - 0x00800000u >= 0x7f000000u) {       /* not a positive normal float */
        if (x != x) return x;
        if (x == 0.0f) return -INFINITY;
        if (x < 0.0f) return NAN;
        if (x == INFINITY) return x;
        x *= 0x1p23f;                           /* a denormal: normalized exactly */
        u = as_uint(x);
        e -= 23;
    }
    e += (int)(u >> 23);
    float m = as_float((u & 0x007fffffu) | 0x3f800000u);      /* [1, 2) */
    if (m > 1.41421356f) { m *= 0.5f; e += 1; }              /* [sqrt 1/2, sqrt 2] */
    /* ln m = 2 atanh(s) = f - s (f - R), f = m - 1 (exact), s = f / (2 + f), |s| <= 0.1716,
     * R = 2 s^2 / 3 + 2 s^4 / 5 + ... + 2 s^10 / 11 (the rest < 1e-10 of ln m): fdlibm's form,
     * in which s's rounding only reaches the small term s (f - R). */
    float f = m - 1.0f, s = f / (2.0f + f), z = s * s;
    float r = z * (0.666666667f + z * (0.4f + z * (0.285714286f + z * (0.222222222f + z * 0.181818182f))));
    return (float)e + (f * 1.44269504f - s * (f - r) * 1.44269504f);
}
#undef log2
#define log2 tx_log2
/* 2^x = 2^n 2^f, n = rint(x), |f| <= 1/2 exact; 2^f by its Taylor series to f^7 (the rest
 * < 6e-9 relative), scaled by 2^n as two powers of two (normal, so that the product rounds
 * once, also into the denormals). */
static inline float tx_exp2(float x)
{
    if (!(x > -150.0f)) return x != x ? x : 0.0f;     /* NaN; or below half the least denormal */
    if (x >= 128.0f) return INFINITY;
    float n = __builtin_rintf(x), f = x - n;
    float p = 1.0f + f * (0.693147181f + f * (0.240226507f + f * (0.0555041087f + f * (0.00961812911f
              + f * (0.00133335581f + f * (0.000154035304f + f * 1.52527338e-5f))))));
    int k = (int)n, k1 = k / 2;
    return p * as_float((uint)(k1 + 127) << 23) * as_float((uint)(k - k1 + 127) << 23);
}
#undef exp2
#define exp2 tx_exp2

/* vload_half4 (every texel read: texture/texture.h) as the CPU's own half-to-float
 * instruction where the target has F16C (vcvtph2ps: every x86 CPU PoCL's LLVM compiles
 * for since 2012), through clang's builtin: exact, as every half is a float, so the same
 * floats as PoCL's call (tests/kernels/test_builtins.py: all 65536 halves). PoCL's call
 * was 8.8% of the grazing quad's frame (perf, 2026-12-05); an inline bitwise widening
 * had measured slower than the call (tools/ab.py, textured scenes: 1.03-1.09x). The
 * four halves are one 8-byte load (texel offsets are 4-half aligned: vload_half4's
 * address is p + 4 o). Without F16C it stays PoCL's call. */
#if defined(__F16C__)
static inline float4 tx_vload_half4(size_t o, const __global half* p)
{
    ushort4 u = *(const __global ushort4*)((const __global ushort*)p + 4 * o);
    return __builtin_ia32_vcvtph2ps((short8)(as_short4(u), (short4)(0)));
}
#undef vload_half4
#define vload_half4 tx_vload_half4
#endif

#endif
#endif
