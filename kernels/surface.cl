#line 2 "surface.cl"
/* Stage 3: surface evaluation. From a hit, the lecture's barycentric
 * interpolation P = (1 - b1 - b2) P0 + b1 P1 + b2 P2 gives the point, the
 * shading normal and the texture coordinates; the material's texture lookups
 * give the local-illumination constants kd, ks and n. */

__kernel void surface(__global const Ray* rays, __global const Hit* hits, __global Surface* out, uint n,
                      __global const TriVerts* tris, __global const TriShade* shade, __global const float* normals, __global const float* uvs,
                      __global const Material* materials, __global const TextureInfo* textures,
                      __global const half* texels)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    __global const Hit* h = hits + gid;
    __global Surface* s = out + gid;
    if (h->prim == TX_MISS) { s->valid = 0u; return; }
    __global const TriVerts* tv = tris + h->prim;
    __global const TriShade* tr = shade + h->prim;
    float b1 = h->b1, b2 = h->b2, b0 = 1.0f - b1 - b2;
    float3 p0 = tri_p0(tv), p1 = tri_p1(tv), p2 = tri_p2(tv);
    float3 p = b0 * p0 + b1 * p1 + b2 * p2;
    /* Error bound of the interpolated point (pbrt-v4 6.8.5): the shadow-ray
     * origin moves this far along the geometric normal. */
    float3 perr = gamma_n(7.0f) * (abs3(b0 * p0) + abs3(b1 * p1) + abs3(b2 * p2));

    float3 ng = normalize3(cross3(p1 - p0, p2 - p0));
    float side = dot3(ng, ray_dir(rays + gid)) > 0.0f ? -1.0f : 1.0f;   /* face the incoming ray */
    ng *= side;
    float3 ns = ng;
#if TX_VERTEX_NORMALS
    if (tr->flags & TRI_HAS_NORMALS) {
        float3 m = b0 * vload3(tr->v[0], normals) + b1 * vload3(tr->v[1], normals) + b2 * vload3(tr->v[2], normals);
        float l2 = dot3(m, m);
        if (l2 > 0.0f) ns = side * m * rsqrt(l2);
    }
#endif
    __global const Material* m = materials + tr->material;
    float3 kd = vload3(0, m->diffuse);
#if TX_TEXTURES
    if (m->diffuse_tex >= 0) {
        float2 uv = (float2)(b1, b2);
        if (tr->flags & TRI_HAS_UVS)
            uv = b0 * vload2(tr->v[0], uvs) + b1 * vload2(tr->v[1], uvs) + b2 * vload2(tr->v[2], uvs);
        kd *= texture_bilinear(texels, textures + m->diffuse_tex, uv).xyz;
    }
#endif
    vstore3(p, 0, s->p);
    s->offset = dot3(abs3(ng), perr);
    vstore3(ng, 0, s->ng);
    s->valid = 1u;
    vstore3(ns, 0, s->ns);
    s->shininess = m->shininess;
    vstore3(kd, 0, s->kd);
    vstore3(vload3(0, m->specular), 0, s->ks);
}
