#line 2 "texture/bilinear.h"
/* The gradient of the bilinear interpolant of one texel cell, with the conventions of
 * texture/texture.h's bilinear_taps: corners c00, c10 (the next column), c01 (the next
 * row), c11, weights ax, ay of the second column and row. Shared by the bump map's
 * exact gradient (shading/bump.h) and the displaced surfaces' height field
 * (geometry/displace.h). */
#ifndef TEXRAY_BILINEAR_H
#define TEXRAY_BILINEAR_H
#include "core/accurate.h"

/* (dB/dx, dB/dy) of B = (c00 (1 - ax) + c10 ax) (1 - ay) + (c01 (1 - ax) + c11 ax) ay
 * per unit of ax and ay: constant across the cell in x where ay is, and vice versa.
 * Callers scale by the level's size (x = s w - 1/2 grows with s, y = (1 - t) h - 1/2
 * falls with t: (dB/dx w, -dB/dy h) = (dB/ds, dB/dt)). */
static inline float2 bilinear_gradient(float c00, float c10, float c01, float c11, float ax, float ay)
{
    return (float2)((c10 - c00) * (1.0f - ay) + (c11 - c01) * ay, (c01 - c00) * (1.0f - ax) + (c11 - c10) * ax);
}

#endif
