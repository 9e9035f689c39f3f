#line 2 "shading/terminator.h"
/* The shadow terminator of smooth-shaded low-poly meshes (Hanika, "Hacking the
 * Shadow Terminator", Ray Tracing Gems II, ch. 4, 2021).
 *
 * Near the terminator the interpolated vertex normal says a light is above the
 * surface while the flat triangle (or its neighbour) says it is below: the
 * shadow ray from the flat surface is blocked and the terminator follows the
 * facets. Shadow rays therefore start from the point the vertex normals imply:
 * P is projected onto each vertex's tangent plane (only where it lies below
 * that plane) and the projections are blended with the barycentrics,
 *     P' = P + sum_i b_i max(0, -(P - P_i) . n_i) n_i.
 * On a mesh approximating a convex surface P' lies close to the smooth
 * surface, above the facets, so a ray toward a light the smooth surface faces
 * leaves the mesh. P' = P wherever the vertex normals agree with the face. */
#ifndef TEXRAY_TERMINATOR_H
#define TEXRAY_TERMINATOR_H
#include "core/accurate.h"

/* P' - P for the point p = b0 p0 + b1 p1 + b2 p2 with unit vertex normals n0, n1, n2. */
static inline float3 terminator_lift(float3 p, float3 p0, float3 p1, float3 p2, float3 n0, float3 n1, float3 n2,
                                     float b0, float b1, float b2)
{
    float d0 = TX_MIN(0.0f, dot3(p - p0, n0));
    float d1 = TX_MIN(0.0f, dot3(p - p1, n1));
    float d2 = TX_MIN(0.0f, dot3(p - p2, n2));
    return -(b0 * d0 * n0 + b1 * d1 * n1 + b2 * d2 * n2);
}

#endif
