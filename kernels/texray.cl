#line 2 "texray.cl"
/* The whole program, the one file the host builds (texray.device; -I kernels/):
 * texray.layout's generated declarations are prepended by the host, then this.
 *
 * Kernels: render_fused (stages/fused.cl) takes each pixel through every step of a
 * sample in one work-item -- the default pipeline; the five stage kernels (raygen,
 * intersect, surface, shadow, shade: stages/) do the same steps one per launch with
 * per-ray records between them in global memory, for timing each step alone (texray
 * bench) and for the AOV pass (compiled in with TX_STAGES: a fused render's program on PoCL
 * leaves them out, and the helpers only they call, core/common.h); `occluded` times any-hit
 * traversal alone;
 * adaptive_mark, _count, _scan and _list (stages/adaptive.cl, with TX_ADAPTIVE) decide which
 * pixels take adaptive sampling's next round. Both
 * pipelines call the same functions and give the same image, bit for bit.
 *
 * Folders by role, each header including what it needs (include guards):
 *   core/      small helpers, sampling, accurate arithmetic, the maths shared by
 *              several techniques (quadratics, frames, slabs), the camera
 *   geometry/  what a hit is, each primitive kind (intersection and parameterization)
 *              and the one dispatch on kinds (geometry/dispatch.h)
 *   accel/     BVH traversal
 *   texture/   wrap modes, projection mappings, ray differentials, texture lookups
 *   shading/   surface evaluation, bump and normal maps, shadows, local illumination
 *   stages/    the __kernel entry points, which only unpack the work-item id
 * Every #if uses a name from texray.features.compile_options().
 *
 * Floating-point contraction: OpenCL's default (on) for core/common.h and
 * core/sampler.h, off from core/accurate.h's pragma to the end; see there. The order
 * of the first three includes is therefore part of the images' bits. */
/* AVX-512 on PoCL where the CPU has it and the host's rule takes it (texray.device.features
 * avx512): PoCL's LLVM compiles for the CPU it knows, Zen 3 (AVX2) on a Zen 4; every function
 * of the program, the kernels included, gets the target features, and min_vector_width lets
 * the 16-lane packets' vectors be 512-bit registers where the CPU's tuning prefers 256. No
 * arithmetic changes (no fast-math, the same contraction): the images are the same bits. */
#if TX_AVX512
#pragma clang attribute push (__attribute__((target("avx512f,avx512vl,avx512bw,avx512dq"))), apply_to = function)
#pragma clang attribute push (__attribute__((min_vector_width(512))), apply_to = function)
#endif
#include "core/common.h"
#include "core/sampler.h"
#include "core/accurate.h"
#include "core/adaptive.h"
#include "core/camera.h"
#include "geometry/dispatch.h"
#include "accel/bvh.h"
#include "shading/surface.h"
#include "shading/shadow.h"
#include "shading/light.h"
#if TX_PACKET
#include "core/camera_packet.h"
#include "shading/light_packet.h"
#include "shading/surface_packet.h"
#endif
#if TX_STAGES
#include "stages/raygen.cl"
#include "stages/intersect.cl"
#include "stages/surface.cl"
#include "stages/shadow.cl"
#include "stages/shade.cl"
#endif
#include "stages/fused.cl"
#include "stages/adaptive.cl"
#if TX_AVX512
#pragma clang attribute pop
#pragma clang attribute pop
#endif
