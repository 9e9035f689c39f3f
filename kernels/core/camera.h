#line 2 "core/camera.h"
/* Primary rays: the pinhole camera of texray.layout.CAMERA (dir = forward + x right +
 * y up for NDC (x, y) in [-1, 1]^2, y up; right and up scaled by the field of view and
 * aspect ratio) and each pixel's sample pattern (core/sampler.h). */
#ifndef TEXRAY_CAMERA_H
#define TEXRAY_CAMERA_H
#include "core/sampler.h"
#include "core/accurate.h"      /* after the FP_CONTRACT pragma, as the ray stage always was */

/* The sample pattern of pixel (px, py): a hash of the pixel and the seed. */
static inline uint pixel_pattern(uint width, uint px, uint py, uint seed)
{
    return hash_u32((py * width + px) ^ hash_u32(seed));
}

/* The camera ray through the point j in [0, 1)^2 of pixel (px, py); dir is not normalized. */
static inline void camera_ray(__constant Camera* cam, uint width, uint height, uint px, uint py, float2 j,
                              float3* org, float3* dir)
{
    float x = 2.0f * ((float)px + j.x) / (float)width - 1.0f;
    float y = 1.0f - 2.0f * ((float)py + j.y) / (float)height;
    *dir = vload3(0, cam->forward) + x * vload3(0, cam->right) + y * vload3(0, cam->up);
    *org = vload3(0, cam->eye);
}

#endif
