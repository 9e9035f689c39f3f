#line 2 "geometry/spherical.h"
/* The sphere's parameterization, written once: the texture coordinates of the sphere
 * primitive (geometry/sphere.h), of its displaced surface (geometry/displace.h) and of
 * the spherical projection mapping (texture/mapping.h), whose azimuth the cylindrical
 * projection shares.
 *
 * In a frame (x, y, z) (right-handed, z the pole), theta = atan2(sqrt(x^2 + y^2), z) is
 * the polar angle from +z and phi = atan2(y, x) in [0, 2pi) the azimuth from +x toward
 * +y. The lecture's s = theta/pi, t = phi/2pi give uv = (t, 1 - s) = (phi/2pi,
 * 1 - theta/pi): an equirectangular image (v = 0 its bottom row) maps with the north
 * pole at the top. atan2 keeps the sign of y that the lecture's acos(x / (r sin(pi s)))
 * loses, has no division by sin(theta) = 0, and keeps theta accurate near the poles. */
#ifndef TEXRAY_SPHERICAL_H
#define TEXRAY_SPHERICAL_H
#include "core/accurate.h"
#include "core/transcendental.h"

#define TX_ONE_MINUS_ULP 0.99999994f      /* largest float below 1 */

/* u = phi/2pi in [0, 1) of the azimuth of (x, y): clamped, since just below the seam
 * phi = -tiny gives 2pi - tiny, and float32 2pi and 1/2pi round up (a u that would
 * round to 1 is the largest float below 1), and phi = -0 would give u = -0. On the
 * axis (x = y = 0: an exact pole) phi is undefined and taken as 0 (u = 0); NaN gives 0.
 * Near the axis phi keeps its accuracy of about u r / rho radians, the conditioning of
 * the azimuth itself. */
inline float azimuth_u(float x, float y)
{
    float phi = 0.0f;
    if (x != 0.0f || y != 0.0f) {
        phi = tx_atan2(y, x);
        if (phi < 0.0f) phi += 2.0f * M_PI_F;
    }
    return TX_MIN(TX_MAX(phi * (0.5f * M_1_PI_F), 0.0f), TX_ONE_MINUS_ULP);
}

/* (u, v) = (phi/2pi, 1 - theta/pi) of the point (x, y, z), given rho = |(x, y)| (the
 * caller's, computed as its geometry allows); v clamped to [0, 1] (float32 pi and 1/pi
 * round up at the south pole). */
inline float2 sphere_uv(float x, float y, float z, float rho)
{
    return (float2)(azimuth_u(x, y), TX_MAX(1.0f - tx_atan2(rho, z) * M_1_PI_F, 0.0f));
}

#endif
