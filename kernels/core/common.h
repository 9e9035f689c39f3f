#line 2 "core/common.h"
/* Small numeric helpers shared by every stage.
 *
 * Dot and cross products are written as plain multiply-adds and min/max as
 * ternaries: on PoCL the builtins (dot, cross, fmin, fmax) measured up to 2x
 * slower inside the traversal loop. Every #if in the kernels uses a name that
 * texray.features.compile_options() emits. */
#ifndef TEXRAY_COMMON_H
#define TEXRAY_COMMON_H
#include "core/builtins.h"
/* OpenCL's default, stated: this file and core/sampler.h have always been compiled
 * with FP contraction allowed (dot3 may become FMAs); core/accurate.h turns it off
 * for everything after them. */
#pragma OPENCL FP_CONTRACT ON

/* Intel's OpenCL CPU compiler (2026.2, __INTEL_LLVM_COMPILER) miscompiles float3
 * arguments: when it vectorizes a kernel across work-items, it gives each function it
 * has not inlined a vector variant, and every lane but the first reads that variant's
 * float3 arguments from the wrong place (packed 3 floats apart by the caller, read 4
 * apart), so rays, hits and shading mix between work-items; float4 arguments are
 * right. On that compiler every inline helper is therefore always inlined, and the
 * three marked TX_OUT_OF_LINE or TX_OUT_OF_LINE_SCALAR (bvh_closest_v, bvh_any_v in
 * accel/bvh.h, surface_eval_v in shading/surface.h: large, with several callers), which take
 * float4, are not declared inline: left out of line, they keep the kernels that call them
 * vectorizable. (PoCL's LLVM inlines by its own cost model whatever the keyword: a large
 * helper with several callers stays a call there, its struct arguments and result passed
 * through memory, unless marked always_inline, as texture/texture.h's bilinear lookup is.)
 *
 * Helpers are `static` where no packet program's fused kernel calls them out of line (the
 * scalar traversals, the stage kernels' helpers, small ones every caller inlines): a static
 * function is compiled only into a program that calls it, and a fused-only program
 * (TX_STAGES 0: texray.device.features compile_options) leaves out the stage kernels, so
 * PoCL's front end no longer optimises code no kernel of the program calls (a third of a
 * packet program's functions: 5-9% of a cold build's instructions, callgrind). The helpers
 * such kernels do call stay extern `inline`: a static one with a single caller would be
 * inlined by the front end already, and the whole kernel optimised twice (every helper
 * static cost a cold build 15% more). bvh_closest_v and bvh_any_v are static on PoCL only
 * (TX_OUT_OF_LINE_SCALAR): elsewhere they stay extern and out of line, as above for Intel's
 * compiler, and because Oclgrind's clang, inlining a static one into its one caller, emits an
 * intrinsic its interpreter does not know (llvm.experimental.noalias.scope.decl). */
#if defined(__INTEL_LLVM_COMPILER)
#define inline inline __attribute__((always_inline))
#endif
#if TX_POCL
#define TX_OUT_OF_LINE_SCALAR static __attribute__((unused))
#else
#define TX_OUT_OF_LINE_SCALAR
#endif
#define TX_OUT_OF_LINE

/* The scalar code a packet program runs (geometry/dispatch.h says why each can be left out):
 * TX_TRI_GEOM_PACKET, a packet program's triangle hits' geometry as packets (PoCL only);
 * TX_PRE_GEOM_ONLY, the fused kernel the only kernel (TX_STAGES 0) and the only caller of
 * surface_eval, with every sphere, quad and triangle hit's geometry and intersection from
 * the packets; TX_SCALAR_TRAVERSAL, its opposite: a program that traverses the tree one ray
 * at a time somewhere (the kernels without packets, the stage kernels, instances), which
 * alone defines bvh_closest and bvh_any (accel/bvh.h) and tests those kinds one ray at a
 * time (leaf_hit). The helpers that only such code calls are static where it is left out
 * (TX_LINK_PACKET_KINDS: the scalar intersection and geometry of spheres and quads, the
 * four-triangle test; TX_LINK_TRI_GEOM: triangle_geom; TX_LINK_QUAD_TEST: the quad test,
 * which displaced surfaces call too): a static function that no code calls is not compiled
 * at all, an extern one always is (the mixed scene's fused program compiled 2,600 lines of
 * IR, 12% of its functions', that no kernel called). Elsewhere they stay extern inline. */
#if TX_PACKET && TX_TRIANGLES && defined(TX_POCL)
#define TX_TRI_GEOM_PACKET 1
#else
#define TX_TRI_GEOM_PACKET 0
#endif
#if TX_PACKET && !TX_STAGES && !TX_INSTANCES
#define TX_PRE_GEOM_ONLY 1
#else
#define TX_PRE_GEOM_ONLY 0
#endif
#define TX_SCALAR_TRAVERSAL (!TX_PRE_GEOM_ONLY)
#if TX_PRE_GEOM_ONLY
#define TX_LINK_PACKET_KINDS static inline
#else
#define TX_LINK_PACKET_KINDS inline
#endif
#if TX_PRE_GEOM_ONLY && TX_TRI_GEOM_PACKET
#define TX_LINK_TRI_GEOM static inline
#else
#define TX_LINK_TRI_GEOM inline
#endif
#if TX_PRE_GEOM_ONLY && !TX_DISPLACEMENT
#define TX_LINK_QUAD_TEST static inline
#else
#define TX_LINK_QUAD_TEST inline
#endif

/* A kernel's body as a function of its own, which the __kernel calls with its scalar and
 * pointer arguments: on PoCL out of line (stages/fused.cl says what that saves), elsewhere
 * inline (Intel's compiler vectorizes the kernel across work-items). On PoCL with AVX-512
 * (kernels/texray.cl) it is also what keeps 16-lane vectors away from the kernel itself: a
 * kernel that passed one to an out-of-line helper (occluded_packet, bvh_any_packet's lane
 * mask) got lanes 8-15 wrong, while the same call between two helpers is right. */
#if TX_POCL
#define TX_KERNEL_BODY static __attribute__((noinline))
#else
#define TX_KERNEL_BODY static inline
#endif

/* The work-item's index in its launch. On PoCL the host lays a launch wider than
 * texray.device.opencl.GRID_WIDTH out as rows of at most that width (Runtime.launch_size), so
 * that no dimension of any grid reaches 65535 work-items: PoCL builds a kernel's work-group
 * function for grids narrower than that ("smallgrid") and a second, generic one for any wider,
 * and a process that rendered a scene small (a preview, the bench's 16x16 build probe) and then
 * at 512x384 (196,608 work-items in one dimension) compiled the kernel twice: 0.9-1.0 s more
 * for the mixed scene's first large frame. Other drivers keep one dimension (Intel's compiler,
 * which vectorizes across work-items, rounded a scalar program's image apart in the last bits
 * with the row's term in the index). TX_GRID_ROWS and TX_GROUP_ROW: the rows and a work-group's
 * row (stages/fused.cl's list loop, core/adaptive.h). */
#if TX_POCL
#define TX_GID() ((uint)get_global_id(1) * (uint)get_global_size(0) + (uint)get_global_id(0))
#define TX_GRID_ROWS() ((uint)get_global_size(1))
#define TX_GROUP_ROW() ((uint)get_group_id(1))
#else
#define TX_GID() ((uint)get_global_id(0))
#define TX_GRID_ROWS() 1u
#define TX_GROUP_ROW() 0u
#endif

/* Unit roundoff of float32 (2^-24). gamma_n(n) = n u / (1 - n u) bounds the
 * relative error of n chained float operations (Higham; pbrt-v4 3.9). */
#define TX_FLT_U 5.9604645e-08f
static inline float gamma_n(float n) { return (n * TX_FLT_U) / (1.0f - n * TX_FLT_U); }

#define TX_MIN(a, b) ((a) < (b) ? (a) : (b))
#define TX_MAX(a, b) ((a) > (b) ? (a) : (b))
#define TX_MISS 0xffffffffu

static inline float dot3(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline float3 cross3(float3 a, float3 b)
{
    return (float3)(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
/* v / |v|. Where |v|^2 is a normal, finite float this is v * rsqrt(|v|^2), bit for bit
 * as ever. Where it is not -- |v| above 2^64 (|v|^2 overflows: v * rsqrt(inf) = 0, or NaN
 * with an infinite component) or below 2^-63 (|v|^2 underflows: rsqrt(0) = inf) -- v is
 * first divided by its largest component, which is exact in direction. A zero or
 * non-finite v is returned as it is (the old result for zero; callers that can meet a
 * non-finite vector check it). */
static inline float3 normalize3(float3 v)
{
    float l2 = dot3(v, v);
    if (l2 >= FLT_MIN && l2 <= FLT_MAX) return v * rsqrt(l2);
    float m = fabs(v.x) > fabs(v.y) ? fabs(v.x) : fabs(v.y);
    m = m > fabs(v.z) ? m : fabs(v.z);
    if (!(m > 0.0f && m <= FLT_MAX)) return v;
    v = v / m;                         /* not v * (1 / m): 1 / m overflows for tiny denormal m */
    return v * rsqrt(dot3(v, v));
}

/* Whether every component of v is finite (false for NaN). */
static inline int finite3(float3 v)
{
    return fabs(v.x) <= FLT_MAX && fabs(v.y) <= FLT_MAX && fabs(v.z) <= FLT_MAX;
}
static inline float3 abs3(float3 v) { return (float3)(fabs(v.x), fabs(v.y), fabs(v.z)); }

/* Component k (0, 1, 2) of v, without indexing a private vector through memory. */
static inline float comp3(float3 v, int k) { return k == 0 ? v.x : (k == 1 ? v.y : v.z); }
static inline float3 unit3(int k) { return (float3)(k == 0, k == 1, k == 2); }

/* 1/x, but +-2^100 instead of +-inf for |x| < 2^-100, so that slab tests never
 * compute 0 * inf = NaN for a ray parallel to a box face (madmann91/bvh's
 * safe_inverse). A direction component that small is zero for all purposes. */
#define TX_PARALLEL_INV 1.2676506e30f   /* 2^100: safe_inverse's value for a zero component */
static inline float safe_inverse(float x)
{
    return fabs(x) < 7.888609e-31f ? copysign(TX_PARALLEL_INV, x) : 1.0f / x;
}

/* Whether the ray org + t dir, t in (tmin, tmax), can be traced at all. Every traversal
 * entry (accel/bvh.h) answers a miss for any other ray before it reads a node. Written so that
 * NaN fails every test. Required:
 * - org and dir finite: an infinite or NaN component makes the slab tests NaN, and the
 *   ternary min/max (TX_MIN/TX_MAX) drop a NaN operand, so an unused lane's empty box
 *   (lo = +inf, hi = -inf) would count as entered and its child index (0: the root) be
 *   pushed again, without end;
 * - some component of dir at least 2^-100 (7.9e-31): safe_inverse treats a smaller one
 *   as zero, so a direction with all three below it is the zero vector for all
 *   purposes (zero and denormal-length directions);
 * - every component of dir at most 2^126 (8.5e37): the reciprocal of a larger one is a
 *   denormal, which a device that flushes denormals makes 0, and 0 x inf is NaN again
 *   (the bound keeps results the same on every device). A shadow ray that long comes
 *   from a light farther than 2^126, whose I / d^2 < FLT_MAX / 2^252 = 2^-124 is nil;
 * - tmin < tmax: a NaN or empty interval holds no hit (tmin = -inf, tmax = +inf are fine).
 * For such a ray every slab distance (b - org) / dir is a number or +-inf, never NaN:
 * b - org is finite or +-inf, 1/dir finite and nonzero. */
#define TX_DIR_MIN 7.888609e-31f        /* 2^-100: safe_inverse's threshold */
#define TX_DIR_MAX 8.507059e+37f        /* 2^126 */
static inline int ray_valid(float3 org, float3 dir, float tmin, float tmax)
{
    float3 ad = abs3(dir);
    return finite3(org) && ad.x <= TX_DIR_MAX && ad.y <= TX_DIR_MAX && ad.z <= TX_DIR_MAX
        && (ad.x >= TX_DIR_MIN || ad.y >= TX_DIR_MIN || ad.z >= TX_DIR_MIN) && tmin < tmax;
}

/* Move a point off a surface along n by `offset` (pbrt-v4 OffsetRayOrigin):
 * the offset is an error bound of p, and nextafter rounds away so that the
 * result is strictly on n's side even after rounding. */
static inline float3 offset_point(float3 p, float3 n, float offset)
{
    float3 q = p + n * offset;
    q.x = n.x > 0.0f ? nextafter(q.x, INFINITY) : (n.x < 0.0f ? nextafter(q.x, -INFINITY) : q.x);
    q.y = n.y > 0.0f ? nextafter(q.y, INFINITY) : (n.y < 0.0f ? nextafter(q.y, -INFINITY) : q.y);
    q.z = n.z > 0.0f ? nextafter(q.z, INFINITY) : (n.z < 0.0f ? nextafter(q.z, -INFINITY) : q.z);
    return q;
}

/* Loop over the scene's n lights. With TX_MAX_LIGHTS (a bound the host compiles
 * in: 1, 2, 4 or 8) the trip count is a compile-time constant, so the compiler
 * can unroll it; the body runs only for i < n. Without it, a plain runtime loop. */
#if TX_MAX_LIGHTS
#define FOR_EACH_LIGHT(i, n) for (uint i = 0; i < (uint)TX_MAX_LIGHTS; ++i) if (i < (n))
#else
#define FOR_EACH_LIGHT(i, n) for (uint i = 0; i < (n); ++i)
#endif

static inline float3 ray_org(__global const Ray* r) { return vload3(0, r->org); }
static inline float3 ray_dir(__global const Ray* r) { return vload3(0, r->dir); }

/* The image's pixel i (three floats in rgb, what the host reads back): the mean of its
 * accumulator a (sum R, G, B, and the samples' count, an exact integer), one IEEE division per
 * channel -- numpy's float32 division by spp or by the count made the same bits on the host
 * until 2026-12-07. The kernels that add to a pixel's sums write it each time, the last time
 * with every sample in (stages/fused.cl, stages/shade.cl). */
static inline void pixel_mean(float4 a, uint i, __global float* rgb)
{
    vstore3(a.xyz / a.w, i, rgb);
}

#endif
