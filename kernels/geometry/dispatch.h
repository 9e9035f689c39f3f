#line 2 "geometry/dispatch.h"
/* The one place that knows every primitive kind: which headers each kind needs, the
 * kinds' arrays as kernel parameters, and the two dispatches on a leaf's or a hit's
 * kind -- intersection (leaf_hit, called by accel/bvh.h's traversals) and surface
 * geometry (hit_geom, called by shading/surface.h). A new kind adds a header, an
 * array, and one branch to each of the two functions here.
 *
 * Kinds (texray.layout PRIM_*): triangles (always compiled), then spheres,
 * cylinders, bilinear quads and displaced surfaces, each compiled only when the
 * scene has one (TX_SPHERES, TX_CYLINDERS, TX_QUADS, TX_DISPLACEMENT); their headers
 * hold declarations and are included here under the same conditions. */
#ifndef TEXRAY_DISPATCH_H
#define TEXRAY_DISPATCH_H
#include "geometry/hit.h"
#include "geometry/triangle.h"
#if TX_SPHERES
#include "geometry/sphere.h"
#endif
#if TX_CYLINDERS
#include "geometry/cylinder.h"
#endif
#if TX_QUADS
#include "geometry/quad.h"
#endif
#if TX_DISPLACEMENT
#include "geometry/displace.h"
#endif

/* The scene's geometry as kernel parameters and as arguments; arrays of kinds
 * the scene does not use are NULL and their code is not compiled. */
#define TX_GEOM_PARAMS __global const float4* nodes, uint nnodes, __global const TriVerts* tris, \
    __global const Sphere* spheres, __global const Cylinder* cylinders, __global const QuadVerts* quads, \
    __global const Displaced* displaced, __global const ushort* heights
#define TX_GEOM_ARGS nodes, nnodes, tris, spheres, cylinders, quads, displaced, heights

/* The leaf's primitives against the ray with t in (tmin, h->t): a hit nearer
 * than h->t updates h. With `any` (a compile-time constant at every call) the
 * first hit returns 1 at once; otherwise every primitive is tested and the
 * return value is 0. Each loop runs at most LEAF_COUNT_MASK times (none if
 * first + count wraps). */
inline int leaf_hit(TX_GEOM_PARAMS, const WoopRay* w, float3 org, float3 dir, float tmin,
                    uint first, uint ck, int any, HitRec* h)
{
    uint end = first + (ck & LEAF_COUNT_MASK), kind = ck >> LEAF_COUNT_BITS;
    float t;
    float2 uv;
    if (kind == PRIM_TRIANGLE) {
        for (uint i = first; i < end; ++i) {
            __global const TriVerts* tr = tris + i;
            float b1, b2;
            if (triangle_intersect(w, tri_p0(tr), tri_p1(tr), tri_p2(tr), tmin, h->t, &t, &b1, &b2)) {
                h->t = t; h->b1 = b1; h->b2 = b2; h->prim = i;
                if (any) return 1;
            }
        }
    }
#if TX_SPHERES
    else if (kind == PRIM_SPHERE) {
        for (uint i = first; i < end; ++i)
            if (sphere_intersect(spheres + i, org, dir, tmin, h->t, &t)) {
                h->t = t; h->prim = (PRIM_SPHERE << HIT_KIND_SHIFT) | i;
                if (any) return 1;
            }
    }
#endif
#if TX_CYLINDERS
    else if (kind == PRIM_CYLINDER) {
        for (uint i = first; i < end; ++i)
            if (cylinder_intersect(cylinders + i, org, dir, tmin, h->t, &t)) {
                h->t = t; h->prim = (PRIM_CYLINDER << HIT_KIND_SHIFT) | i;
                if (any) return 1;
            }
    }
#endif
#if TX_QUADS
    else if (kind == PRIM_QUAD) {
        for (uint i = first; i < end; ++i)
            if (quad_intersect(quads + i, org, dir, tmin, h->t, &t, &uv)) {
                h->t = t; h->b1 = uv.x; h->b2 = uv.y; h->prim = (PRIM_QUAD << HIT_KIND_SHIFT) | i;
                if (any) return 1;
            }
    }
#endif
#if TX_DISPLACEMENT
    else if (kind == PRIM_DISPLACED) {
        for (uint i = first; i < end; ++i)
            if (displaced_intersect(displaced + i, heights, org, dir, tmin, h->t, any, &t, &uv)) {
                h->t = t; h->b1 = uv.x; h->b2 = uv.y; h->prim = (PRIM_DISPLACED << HIT_KIND_SHIFT) | i;
                if (any) return 1;
            }
    }
#endif
    return 0;
}

/* Material, object and primitive ids of a hit (texray.layout's TriShade, QuadShade and
 * the analytic records carry them). */
typedef struct { uint material, object, prim; } PrimIds;

/* `static`: called once, so inlined into surface_eval (shading/surface.h explains).
 * Surface geometry of the hit h of the ray (org, dir) into *g, by kind (each kind's
 * *_geom: the point, its error bound, the geometric normal, uv and dP/du, dP/dv with
 * respect to uv); returns the hit's ids. h->prim must not be TX_MISS. */
static inline PrimIds hit_geom(TX_GEOM_PARAMS, __global const TriShade* tri_shade, __global const QuadShade* quad_shade,
                        __global const float* uvs, float3 org, float3 dir, const HitRec* h, Geom* g)
{
    uint kind = h->prim >> HIT_KIND_SHIFT, idx = h->prim & HIT_INDEX_MASK;
    PrimIds ids = { 0u, 0u, 0u };
    if (kind == PRIM_TRIANGLE) {
        __global const TriShade* ts = tri_shade + idx;
        triangle_geom(tris + idx, ts, h->b1, h->b2, uvs, g);
        ids.material = ts->material; ids.object = ts->object; ids.prim = ts->prim;
    }
#if TX_SPHERES
    else if (kind == PRIM_SPHERE) {
        __global const Sphere* sp = spheres + idx;
        sphere_geom(sp, org, dir, h->t, g);
        ids.material = sp->material; ids.object = sp->object; ids.prim = sp->prim;
    }
#endif
#if TX_CYLINDERS
    else if (kind == PRIM_CYLINDER) {
        __global const Cylinder* cy = cylinders + idx;
        cylinder_geom(cy, org, dir, h->t, g);
        ids.material = cy->material; ids.object = cy->object; ids.prim = cy->prim;
    }
#endif
#if TX_QUADS
    else if (kind == PRIM_QUAD) {
        __global const QuadShade* qs = quad_shade + idx;
        quad_geom(quads + idx, qs, (float2)(h->b1, h->b2), g);
        ids.material = qs->material; ids.object = qs->object; ids.prim = qs->prim;
    }
#endif
#if TX_DISPLACEMENT
    else if (kind == PRIM_DISPLACED) {
        __global const Displaced* dp = displaced + idx;
        displaced_geom(dp, heights, org, dir, h->t, (float2)(h->b1, h->b2), g);
        ids.material = dp->material; ids.object = dp->object; ids.prim = dp->prim;
    }
#endif
    return ids;
}

#endif
