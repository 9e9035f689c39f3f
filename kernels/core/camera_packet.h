#line 2 "core/camera_packet.h"
/* A packet's camera rays (stages/fused.cl's chunk): camera_ray (core/camera.h) for every
 * lane as one vector computation, each lane through its own point (jx, jy) of its own pixel
 * (px, py). The same float operations in the same order as camera_ray, FP contraction off
 * (core/accurate.h's pragma holds here), so each lane's direction is camera_ray's bit for
 * bit; done lane by lane, its divisions and ray_valid's branches were about a twentieth of
 * the globe's frame (perf, 512x384, 16 spp). */
#ifndef TEXRAY_CAMERA_PACKET_H
#define TEXRAY_CAMERA_PACKET_H
#include "core/camera.h"
#include "accel/packet.h"
#include "accel/packet_vec.h"

/* The direction of camera_ray through the point (jx, jy) of pixel (px, py), lane by lane
 * (px, py: the pixel's coordinates as floats); every lane's origin is the eye. */
static inline pfloat3 camera_dir_packet(__constant Camera* cam, uint width, uint height, pfloat px, pfloat py, pfloat jx,
                                        pfloat jy)
{
    pfloat x = 2.0f * (px + jx) / (float)width - 1.0f;
    pfloat y = 1.0f - 2.0f * (py + jy) / (float)height;
    float3 f = vload3(0, cam->forward), r = vload3(0, cam->right), u = vload3(0, cam->up);
    return pf3(f.x + x * r.x + y * u.x, f.y + x * r.y + y * u.y, f.z + x * r.z + y * u.z);
}

/* ray_valid (core/common.h) lane by lane for rays from one origin org over (0, inf): the
 * lanes (-1) whose direction is finite, not above 2^126 and not below 2^-100 on every axis. */
static inline pint ray_valid_packet(float3 org, pfloat3 d)
{
    if (!finite3(org)) return (pint)(0);
    pfloat ax = fabs(d.x), ay = fabs(d.y), az = fabs(d.z);
    return (ax <= TX_DIR_MAX) & (ay <= TX_DIR_MAX) & (az <= TX_DIR_MAX)
         & ((ax >= TX_DIR_MIN) | (ay >= TX_DIR_MIN) | (az >= TX_DIR_MIN));
}

#endif
