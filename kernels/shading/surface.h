#line 2 "shading/surface.h"
/* Surface evaluation: the hit of a camera ray turned into the Surface record the
 * shadow and shade stages read (texray.layout.SURFACE), in five steps, each an inline
 * function:
 *   geometry        the kind's Geom (geometry/dispatch.h hit_geom), the interpolated
 *                   vertex normal and shadow-ray lift of smooth meshes, the ids;
 *   texture coords  uv with its screen-space derivatives (ray differentials), or a
 *                   projection mapping's (s, t) and tangents in its place;
 *   shading normal  the outward normal, a bump or normal map's, then both normals
 *                   turned to the side the ray came from;
 *   material        the local illumination's kd, ks and n through the texture roles;
 *   write           the record, and with TX_AOVS the AOV record of texray.layout.AOVS
 *                   (NaN, or -1 for ids, where the ray missed).
 * Code a scene does not need is left out by its feature constants: `if (TX_X)` where
 * the code compiles in every program (the compiler drops the dead branch, and it still
 * type-checks), `#if TX_X` where it calls a header that only such programs include
 * (texray.cl, geometry/dispatch.h).
 *
 * The steps are `static inline`: each has one call site, and a function of internal
 * linkage called once is inlined whatever its size, so the five steps compile to the
 * one function surface_eval was. As plain `inline` (external linkage) PoCL left them
 * as calls passing their records through memory: the surface stage ran 10-14% slower
 * on scenes/bench/mixed.toml (paired A/B). Likewise hit_geom and texture/mapping.h's
 * three mappings. */
#ifndef TEXRAY_SURFACE_H
#define TEXRAY_SURFACE_H
#include "geometry/dispatch.h"
#include "texture/differentials.h"
#include "texture/texture.h"
#if TX_BUMP || TX_NORMAL_MAPS || TX_VERTEX_NORMALS
#include "shading/bump.h"
#endif
#if TX_VERTEX_NORMALS
#include "shading/terminator.h"
#endif

/* The surface stage's parameters and arguments (besides the geometry's). */
#define TX_SURFACE_PARAMS __global const TriShade* tri_shade, __global const QuadShade* quad_shade, \
    __global const float* normals, __global const float* uvs, __global const Material* materials, \
    __global const TextureInfo* textures, __global const half* texels, __global const ObjectInfo* objects, \
    __constant Camera* cam, uint image_w, uint image_h, uint spp
#define TX_SURFACE_ARGS tri_shade, quad_shade, normals, uvs, materials, textures, texels, objects, \
    cam, image_w, image_h, spp

/* What the geometry step finds about a hit. */
typedef struct {
    Geom g;
    PrimIds ids;
    float3 ns_raw;          /* interpolated vertex normal, unnormalized (where vertex_normal) */
    float3 lift;            /* shadow-ray origin p + lift: shading/terminator.h; 0 elsewhere */
    int vertex_normal;      /* whether ns_raw is the outward shading normal (a usable vertex normal) */
} SurfaceGeom;

/* The local illumination's material terms at the hit. */
typedef struct {
    float3 kd, ks;
    float shininess;        /* the exponent n */
} MaterialTerms;

inline void write_aovs(__global float* aov, uint gid, const Geom* g, float3 ns, float depth, uint prim, uint object)
{
    __global float* a = aov + (size_t)gid * AOV_FLOATS;
    vstore2(g->uv, 0, a + AOV_UV);
    vstore3(g->p, 0, a + AOV_POSITION);
    vstore3(g->ng, 0, a + AOV_NORMAL);
    vstore3(ns, 0, a + AOV_SHADING_NORMAL);
    a[AOV_DEPTH] = depth;
    a[AOV_PRIMITIVE_ID] = (float)prim;
    a[AOV_OBJECT_ID] = (float)object;
    vstore3(g->dpdu, 0, a + AOV_DPDU);
    vstore3(g->dpdv, 0, a + AOV_DPDV);
}

inline void write_miss_aovs(__global float* aov, uint gid)
{
    __global float* a = aov + (size_t)gid * AOV_FLOATS;
    for (uint i = 0; i < AOV_FLOATS; ++i) a[i] = NAN;
    a[AOV_PRIMITIVE_ID] = -1.0f;
    a[AOV_OBJECT_ID] = -1.0f;
}

/* Step 1, geometry: the kind's Geom and ids (hit_geom); for triangles with vertex
 * normals also their interpolation and the shadow-ray lift (shading/terminator.h). */
static inline void surface_geometry(float3 org, float3 dir, const HitRec* h, TX_GEOM_PARAMS, TX_SURFACE_PARAMS,
                             SurfaceGeom* sg)
{
    sg->ids = hit_geom(TX_GEOM_ARGS, tri_shade, quad_shade, uvs, org, dir, h, &sg->g);
    sg->vertex_normal = 0;
    sg->ns_raw = (float3)(0.0f);
    sg->lift = (float3)(0.0f);
#if TX_VERTEX_NORMALS
    if ((h->prim >> HIT_KIND_SHIFT) != PRIM_TRIANGLE) return;
    uint idx = h->prim & HIT_INDEX_MASK;
    __global const TriShade* ts = tri_shade + idx;
    if (ts->flags & TRI_HAS_NORMALS) {
        float b0 = 1.0f - h->b1 - h->b2;
        float3 ns_raw = b0 * vload3(ts->v[0], normals) + h->b1 * vload3(ts->v[1], normals)
                      + h->b2 * vload3(ts->v[2], normals);
        /* Not finite (a normal of 1e39 is inf in float32; 0 x inf is NaN even at b = 0)
         * exactly when some vertex normal is not: the triangle is shaded flat then,
         * rather than from a NaN normal and a NaN shadow-ray lift. */
        int vertex_normal = dot3(ns_raw, ns_raw) > 0.0f && finite3(ns_raw);
        if (vertex_normal && dot3(ns_raw, dir) < 0.0f)     /* seen from the normals' side */
            sg->lift = terminator_lift(sg->g.p, tri_p0(tris + idx), tri_p1(tris + idx), tri_p2(tris + idx),
                                       normalize3(vload3(ts->v[0], normals)), normalize3(vload3(ts->v[1], normals)),
                                       normalize3(vload3(ts->v[2], normals)), b0, h->b1, h->b2);
        sg->ns_raw = ns_raw;
        sg->vertex_normal = vertex_normal;
    }
#endif
}

/* Step 2, texture coordinates with their screen-space derivatives (pbrt-v4
 * TextureEvalContext) into *tcp: dp/dx, dp/dy from the camera (texture/differentials.h),
 * only where a trilinear or anisotropic lookup needs them; elsewhere zero, which
 * texture/texture.h reads as level 0. A projection mapping of the object replaces the
 * primitive's own uv, and with it g's uv, dP/du and dP/dv. (An out-parameter, not a
 * returned TexCoord: returned, its struct-returning callees wrote into the caller's
 * return slot, which left llvm.experimental.noalias.scope.decl calls in the optimized
 * program that Oclgrind 21.10 cannot run.) */
static inline void surface_texcoords(float3 dir, float t, __global const ObjectInfo* objects, __constant Camera* cam,
                                  uint image_w, uint image_h, uint spp, uint object, Geom* g, TexCoord* tcp)
{
    float3 dpdx = (float3)(0.0f), dpdy = (float3)(0.0f);
    TexCoord tc;
    tc.uv = g->uv;
    tc.duv_dx = tc.duv_dy = (float2)(0.0f);
    if (TX_FILTER_TRILINEAR || TX_FILTER_ANISOTROPIC) {
        camera_dp_dxy(cam, image_w, image_h, differential_scale(spp), dir, t, g->ng, &dpdx, &dpdy);
        tc = uv_differentials(g->uv, g->dpdu, g->dpdv, dpdx, dpdy);
    }
    if (TX_PROJECTIONS) {
        __global const ObjectInfo* ob = objects + object;
        if (ob->mapping >= 0) {
            Frame f = { vload3(0, ob->origin), vload3(0, ob->x), vload3(0, ob->y), vload3(0, ob->z) };
            tc = map_projection(ob->mapping, f, g->p, dpdx, dpdy);   /* derivatives by the chain rule */
            g->uv = tc.uv;
            map_tangents(ob->mapping, f, g->p, g->ng, &g->dpdu, &g->dpdv);   /* dP/du, dP/dv of that uv */
        }
    }
    *tcp = tc;
}

/* Step 3, the shading normal: the outward one (the vertex normals' side for meshes with
 * them); a bump or normal map replaces it in that frame (shading/bump.h), before normals
 * face the ray. *ng, *ns: the geometric and shading normals on the side the ray came
 * from (no shading normal facing away: shading_normal_facing). */
static inline void surface_normals(float3 dir, const SurfaceGeom* sg, TexCoord tc, __global const Material* m,
                            __global const TextureInfo* textures, __global const half* texels,
                            __global const ObjectInfo* objects, float3* ng, float3* ns)
{
    const Geom* g = &sg->g;
    float3 n_out = sg->vertex_normal ? normalize3(sg->ns_raw) : g->ng;
#if TX_BUMP
    if (m->bump_tex >= 0)
        n_out = bump_normal(n_out, g->dpdu, g->dpdv, bump_gradient(texels, textures + m->bump_tex, tc,
                                                                   m->bump_height, m->bump_delta));
#endif
#if TX_NORMAL_MAPS
    if (m->normal_tex >= 0) {
        __global const TextureInfo* nt = textures + m->normal_tex;
        float3 nm0 = (float3)(1.0f, 0.0f, 0.0f), nm1 = (float3)(0.0f, 1.0f, 0.0f), nm2 = (float3)(0.0f, 0.0f, 1.0f);
        if (m->normal_mode & TX_NORMAL_OBJECT) {
            __global const ObjectInfo* on = objects + sg->ids.object;
            nm0 = vload3(0, on->nm0); nm1 = vload3(0, on->nm1); nm2 = vload3(0, on->nm2);
        }
        n_out = normal_map_normal(n_out, g->dpdu, g->dpdv, texture_eval(texels, nt, tc).xyz, m->normal_mode,
                                  nm0, nm1, nm2);
    }
#endif
    float side = dot3(g->ng, dir) > 0.0f ? -1.0f : 1.0f;   /* face the incoming ray */
    *ng = side * g->ng;
    *ns = side * n_out;
#if TX_BUMP || TX_NORMAL_MAPS || TX_VERTEX_NORMALS
    *ns = shading_normal_facing(*ns, *ng, -normalize3(dir));   /* shading/bump.h */
#endif
}

/* Step 4, the material: textures alter the terms of the local illumination (the
 * lecture): kd, the label over it, ks and n. Each role's code is compiled only when a
 * material uses it. */
static inline MaterialTerms surface_material(__global const Material* m, __global const TextureInfo* textures,
                                      __global const half* texels, TexCoord tc)
{
    MaterialTerms mt = { vload3(0, m->diffuse), vload3(0, m->specular), m->shininess };
    if (TX_TEXTURES && m->diffuse_tex >= 0)
        mt.kd *= texture_eval(texels, textures + m->diffuse_tex, tc).xyz;
    if (TX_LABELS && m->label_tex >= 0) {
        float4 lb = texture_label(texels, textures + m->label_tex, tc);   /* premultiplied */
        mt.kd = mt.kd * (1.0f - lb.w) + lb.xyz;                           /* lerp(kd, rgb, alpha) */
    }
    if (TX_SPECULAR_MAPS && m->specular_tex >= 0)
        mt.ks *= texture_eval(texels, textures + m->specular_tex, tc).xyz;
    if (TX_SHININESS_MAPS && m->shininess_tex >= 0)
        mt.shininess *= texture_eval(texels, textures + m->shininess_tex, tc).x;   /* n = shininess * map */
    return mt;
}

/* Step 5, write: the Surface record (and AOVs). A hit whose point, normals or shading
 * constants came out not finite (geometry at the edge of float range, e.g. coordinates
 * near 1e38 whose differences overflow; non-finite material data) cannot be shaded: it
 * is taken as a miss, the same answer as for a ray the traversal rejects, so the pixel
 * shows the background rather than NaN. Every finite hit is unaffected. */
static inline void surface_write(const SurfaceGeom* sg, float3 ng, float3 ns, const MaterialTerms* mt, float depth,
                          __global float* aov, uint gid, Surface* s)
{
    const Geom* g = &sg->g;
    if (!(finite3(g->p) && finite3(ng) && finite3(ns) && finite3(mt->kd) && finite3(mt->ks))) {
        s->valid = 0u;
        if (TX_AOVS && aov) write_miss_aovs(aov, gid);
        return;
    }
    vstore3(g->p, 0, s->p);
    s->offset = dot3(abs3(ng), g->perr);
    vstore3(ng, 0, s->ng);
    s->valid = 1u;
    vstore3(ns, 0, s->ns);
    vstore3(sg->lift, 0, s->lift);
    s->shininess = mt->shininess;
    vstore3(mt->kd, 0, s->kd);
    vstore3(mt->ks, 0, s->ks);
    if (TX_AOVS && aov) write_aovs(aov, gid, g, ns, depth, sg->ids.prim, sg->ids.object);
}

/* Evaluates the hit h of the ray (org, dir) into *s (s->valid = 0 for a miss); with
 * TX_AOVS and aov != NULL also writes record gid of the AOV buffer. */
inline void surface_eval(float3 org, float3 dir, HitRec hit, TX_GEOM_PARAMS, TX_SURFACE_PARAMS,
                         __global float* aov, uint gid, Surface* s)
{
    const HitRec* h = &hit;
    if (h->prim == TX_MISS) {
        s->valid = 0u;
        if (TX_AOVS && aov) write_miss_aovs(aov, gid);
        return;
    }
    SurfaceGeom sg;
    surface_geometry(org, dir, h, TX_GEOM_ARGS, TX_SURFACE_ARGS, &sg);
    TexCoord tc;
    surface_texcoords(dir, h->t, objects, cam, image_w, image_h, spp, sg.ids.object, &sg.g, &tc);
    __global const Material* m = materials + sg.ids.material;
    float3 ng, ns;
    surface_normals(dir, &sg, tc, m, textures, texels, objects, &ng, &ns);
    MaterialTerms mt = surface_material(m, textures, texels, tc);
    surface_write(&sg, ng, ns, &mt, h->t * sqrt(dot3(dir, dir)), aov, gid, s);
}

#endif
