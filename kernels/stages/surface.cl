#line 2 "stages/surface.cl"
/* Stage 3: surface evaluation. Each primitive kind gives the hit's geometry
 * (point, geometric normal, dP/du, dP/dv, texture uv: Geom); triangles add
 * the interpolated vertex normal. Normals are then turned to the side the
 * ray came from, and the material's texture lookups give the local
 * illumination's kd, ks and n. With TX_AOVS, the stage also writes the AOV
 * record of texray.layout.AOVS (NaN, or -1 for ids, where the ray missed). */

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

/* The surface stage's parameters and arguments (besides the geometry's). */
#define TX_SURFACE_PARAMS __global const TriShade* tri_shade, __global const QuadShade* quad_shade, \
    __global const float* normals, __global const float* uvs, __global const Material* materials, \
    __global const TextureInfo* textures, __global const half* texels, __global const ObjectInfo* objects, \
    __constant Camera* cam, uint image_w, uint image_h, uint spp
#define TX_SURFACE_ARGS tri_shade, quad_shade, normals, uvs, materials, textures, texels, objects, \
    cam, image_w, image_h, spp

/* Evaluates the hit h of the ray (org, dir) into *s (s->valid = 0 for a miss); with
 * TX_AOVS and aov != NULL also writes record gid of the AOV buffer. */
inline void surface_eval(float3 org, float3 dir, HitRec hit, TX_GEOM_PARAMS, TX_SURFACE_PARAMS,
                         __global float* aov, uint gid, Surface* s)
{
    const HitRec* h = &hit;
    if (h->prim == TX_MISS) {
        s->valid = 0u;
#if TX_AOVS
        if (aov) write_miss_aovs(aov, gid);
#endif
        return;
    }
    uint kind = h->prim >> HIT_KIND_SHIFT, idx = h->prim & HIT_INDEX_MASK;
    Geom g;
    uint material = 0u, object = 0u, prim = 0u;
    int vertex_normal = 0;
    float3 ns_raw = (float3)(0.0f);
    float3 lift = (float3)(0.0f);         /* shadow-ray origin p + lift: terminator.h */
    if (kind == PRIM_TRIANGLE) {
        __global const TriShade* ts = tri_shade + idx;
        triangle_geom(tris + idx, ts, h->b1, h->b2, uvs, &g);
        material = ts->material; object = ts->object; prim = ts->prim;
#if TX_VERTEX_NORMALS
        if (ts->flags & TRI_HAS_NORMALS) {
            float b0 = 1.0f - h->b1 - h->b2;
            ns_raw = b0 * vload3(ts->v[0], normals) + h->b1 * vload3(ts->v[1], normals)
                   + h->b2 * vload3(ts->v[2], normals);
            /* Not finite (a normal of 1e39 is inf in float32; 0 x inf is NaN even at b = 0)
             * exactly when some vertex normal is not: the triangle is shaded flat then,
             * rather than from a NaN normal and a NaN shadow-ray lift. */
            vertex_normal = dot3(ns_raw, ns_raw) > 0.0f && finite3(ns_raw);
            if (vertex_normal && dot3(ns_raw, dir) < 0.0f)     /* seen from the normals' side */
                lift = terminator_lift(g.p, tri_p0(tris + idx), tri_p1(tris + idx), tri_p2(tris + idx),
                                       normalize3(vload3(ts->v[0], normals)), normalize3(vload3(ts->v[1], normals)),
                                       normalize3(vload3(ts->v[2], normals)), b0, h->b1, h->b2);
        }
#endif
    }
#if TX_SPHERES
    else if (kind == PRIM_SPHERE) {
        __global const Sphere* sp = spheres + idx;
        sphere_geom(sp, org, dir, h->t, &g);
        material = sp->material; object = sp->object; prim = sp->prim;
    }
#endif
#if TX_CYLINDERS
    else if (kind == PRIM_CYLINDER) {
        __global const Cylinder* cy = cylinders + idx;
        cylinder_geom(cy, org, dir, h->t, &g);
        material = cy->material; object = cy->object; prim = cy->prim;
    }
#endif
#if TX_QUADS
    else if (kind == PRIM_QUAD) {
        __global const QuadShade* qs = quad_shade + idx;
        quad_geom(quads + idx, qs, (float2)(h->b1, h->b2), &g);
        material = qs->material; object = qs->object; prim = qs->prim;
    }
#endif
#if TX_DISPLACEMENT
    else if (kind == PRIM_DISPLACED) {
        /* The found point; its normal from the height field's gradient (bump.h's formula). */
        __global const Displaced* dp = displaced + idx;
        float2 grad = displaced_geom(dp, heights, org, dir, h->t, (float2)(h->b1, h->b2), &g);
        g.ng = bump_normal(g.ng, g.dpdu, g.dpdv, grad);
        material = dp->material; object = dp->object; prim = dp->prim;
    }
#endif
    /* Texture coordinates with their screen-space derivatives (pbrt-v4 TextureEvalContext):
     * dp/dx, dp/dy from the camera (differentials.h), only where a trilinear or anisotropic
     * lookup needs them;
     * elsewhere zero, which texture.h reads as level 0. */
    float3 dpdx = (float3)(0.0f), dpdy = (float3)(0.0f);
    TexCoord tc;
    tc.uv = g.uv;
    tc.duv_dx = tc.duv_dy = (float2)(0.0f);
#if TX_FILTER_TRILINEAR || TX_FILTER_ANISOTROPIC
    camera_dp_dxy(cam, image_w, image_h, differential_scale(spp), dir, h->t, g.ng, &dpdx, &dpdy);
    tc = uv_differentials(g.uv, g.dpdu, g.dpdv, dpdx, dpdy);
#endif
#if TX_PROJECTIONS
    /* A projection mapping of the object replaces the primitive's own uv. */
    __global const ObjectInfo* ob = objects + object;
    if (ob->mapping >= 0) {
        Frame f = { vload3(0, ob->origin), vload3(0, ob->x), vload3(0, ob->y), vload3(0, ob->z) };
        tc = map_projection(ob->mapping, f, g.p, dpdx, dpdy);   /* derivatives by the chain rule */
        g.uv = tc.uv;
        map_tangents(ob->mapping, f, g.p, g.ng, &g.dpdu, &g.dpdv);   /* dP/du, dP/dv of that uv */
    }
#endif
    /* The outward shading normal (the vertex normals' side for meshes with them); a bump
     * or normal map replaces it in that frame (bump.h), before normals face the ray. */
    float3 n_out = vertex_normal ? normalize3(ns_raw) : g.ng;
    __global const Material* m = materials + material;
#if TX_BUMP
    if (m->bump_tex >= 0)
        n_out = bump_normal(n_out, g.dpdu, g.dpdv, bump_gradient(texels, textures + m->bump_tex, tc,
                                                                 m->bump_height, m->bump_delta));
#endif
#if TX_NORMAL_MAPS
    if (m->normal_tex >= 0) {
        __global const TextureInfo* nt = textures + m->normal_tex;
        float3 nm0 = (float3)(1.0f, 0.0f, 0.0f), nm1 = (float3)(0.0f, 1.0f, 0.0f), nm2 = (float3)(0.0f, 0.0f, 1.0f);
        if (m->normal_mode & TX_NORMAL_OBJECT) {
            __global const ObjectInfo* on = objects + object;
            nm0 = vload3(0, on->nm0); nm1 = vload3(0, on->nm1); nm2 = vload3(0, on->nm2);
        }
        n_out = normal_map_normal(n_out, g.dpdu, g.dpdv, texture_eval(texels, nt, tc).xyz, m->normal_mode,
                                  nm0, nm1, nm2);
    }
#endif
    float side = dot3(g.ng, dir) > 0.0f ? -1.0f : 1.0f;   /* face the incoming ray */
    float3 ng = side * g.ng;
    float3 ns = side * n_out;
#if TX_BUMP || TX_NORMAL_MAPS || TX_VERTEX_NORMALS
    ns = shading_normal_facing(ns, ng, -normalize3(dir));   /* bump.h: no normal facing away */
#endif

    /* Textures alter the terms of the local illumination (the lecture): kd, the label over
     * it, ks and n. Each role's code is compiled only when a material uses it. */
    float3 kd = vload3(0, m->diffuse), ks = vload3(0, m->specular);
    float shininess = m->shininess;
#if TX_TEXTURES
    if (m->diffuse_tex >= 0)
        kd *= texture_eval(texels, textures + m->diffuse_tex, tc).xyz;
#endif
#if TX_LABELS
    if (m->label_tex >= 0) {
        float4 lb = texture_label(texels, textures + m->label_tex, tc);   /* premultiplied */
        kd = kd * (1.0f - lb.w) + lb.xyz;                                 /* lerp(kd, rgb, alpha) */
    }
#endif
#if TX_SPECULAR_MAPS
    if (m->specular_tex >= 0)
        ks *= texture_eval(texels, textures + m->specular_tex, tc).xyz;
#endif
#if TX_SHININESS_MAPS
    if (m->shininess_tex >= 0)
        shininess *= texture_eval(texels, textures + m->shininess_tex, tc).x;   /* n = shininess * map */
#endif
    /* A hit whose point, normals or shading constants came out not finite (geometry at
     * the edge of float range, e.g. coordinates near 1e38 whose differences overflow;
     * non-finite material data) cannot be shaded: it is taken as a miss, the same answer
     * as for a ray the traversal rejects, so the pixel shows the background rather than
     * NaN. Every finite hit is unaffected. */
    if (!(finite3(g.p) && finite3(ng) && finite3(ns) && finite3(kd) && finite3(ks))) {
        s->valid = 0u;
#if TX_AOVS
        if (aov) write_miss_aovs(aov, gid);
#endif
        return;
    }
    vstore3(g.p, 0, s->p);
    s->offset = dot3(abs3(ng), g.perr);
    vstore3(ng, 0, s->ng);
    s->valid = 1u;
    vstore3(ns, 0, s->ns);
    vstore3(lift, 0, s->lift);
    s->shininess = shininess;
    vstore3(kd, 0, s->kd);
    vstore3(ks, 0, s->ks);
#if TX_AOVS
    if (aov) write_aovs(aov, gid, &g, ns, h->t * sqrt(dot3(dir, dir)), prim, object);
#endif
}

__kernel void surface(__global const Ray* rays, __global const Hit* hits, __global Surface* out, uint n,
                      TX_GEOM_PARAMS, TX_SURFACE_PARAMS, __global float* aov)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    __global const Hit* gh = hits + gid;
    HitRec h = { gh->t, gh->b1, gh->b2, gh->prim };
    Surface s;
    surface_eval(ray_org(rays + gid), ray_dir(rays + gid), h, TX_GEOM_ARGS, TX_SURFACE_ARGS, aov, gid, &s);
    if (s.valid) out[gid] = s;
    else out[gid].valid = 0u;
}
