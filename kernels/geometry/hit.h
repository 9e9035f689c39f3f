#line 2 "geometry/hit.h"
/* What a hit is: the traversal's record of the closest (or any) hit, and the surface
 * geometry every primitive kind derives from it (geometry/dispatch.h), in world space. */
#ifndef TEXRAY_HIT_H
#define TEXRAY_HIT_H
#include "core/accurate.h"

/* A hit as the traversal finds it: t in units of the ray's direction, the kind's
 * parameters (b1, b2: a triangle's barycentrics of P1, P2; a quad's or a displaced
 * surface's (u, v); unused for spheres and cylinders) and prim = (kind << HIT_KIND_SHIFT)
 * | index in that kind's array (triangles: kind 0, the plain index), TX_MISS for none. */
#if TX_INSTANCES
/* inst: the instance (accel/instance.h) of a hit of kind PRIM_INSTANCE, whose index is then
 * the mesh's triangle in tri_verts; 0 (initializers leave it) otherwise. */
typedef struct { float t, b1, b2; uint prim, inst; } HitRec;
#else
typedef struct { float t, b1, b2; uint prim; } HitRec;
#endif

typedef struct {            /* what the surface stage needs about a hit, in world space */
    float3 p;               /* the hit point, on the surface */
    float3 ng;              /* unit geometric normal: outward for sphere/cylinder (away from the
                             * centre/axis); for the quad normalize(dP/du x dP/dv) of the bilinear
                             * parameters, the (P1-P0)x(P3-P0) side */
    float3 dpdu, dpdv;      /* dP/du, dP/dv with respect to the texture coordinates uv below */
    float2 uv;              /* texture coordinates (conventions in sphere.h, cylinder.h, quad.h) */
    float3 perr;            /* per-component absolute error bound of p (offset secondary rays along ng) */
} Geom;

#endif
