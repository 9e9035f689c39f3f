#line 2 "shade.cl"
/* Stage 5: the lecture's local illumination, accumulated per pixel:
 *   I = ambient kd + sum_i I_i vis(i) / d_i^2 (kd (N.L_i) + ks (R_i.V)^n)
 * with N the shading normal facing the viewer, L_i and V unit vectors from
 * the point, R_i = 2 (N.L_i) N - L_i. Terms with N.L_i <= 0 contribute nothing
 * (the specular term included, so no highlight appears on the unlit side). */

/* Light i's term I_i / d_i^2 (kd (N.L_i) + ks (R_i.V)^n) at the surface point s seen
 * along -v (v: unit vector from the point toward the eye). */
inline float3 light_term(const Surface* s, float3 v, float3 lpos, float3 intensity)
{
    float3 p = vload3(0, s->p), nrm = vload3(0, s->ns);
    float3 l = lpos - p;
    float d2 = dot3(l, l);
    l *= rsqrt(d2);
    float ndl = dot3(nrm, l);
    if (ndl <= 0.0f) return (float3)(0.0f);
    float3 term = vload3(0, s->kd) * ndl;
#if TX_SPECULAR
    float3 r = 2.0f * ndl * nrm - l;
    float rv = dot3(r, v);
    if (rv > 0.0f) term += vload3(0, s->ks) * powr(rv, s->shininess);
#endif
    return intensity * (term / d2);
}

__kernel void shade(__global const Ray* rays, __global const Surface* surf, __global const uchar* vis,
                    uint n, __global float4* accum,
                    __global const PointLight* lights, uint nlights, float4 ambient, float4 background)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    float3 c = background.xyz;
    if (surf[gid].valid) {
        Surface s = surf[gid];
        float3 v = -normalize3(ray_dir(rays + gid));
        c = ambient.xyz * vload3(0, s.kd);
        FOR_EACH_LIGHT(i, nlights) {
            if (vis[(size_t)gid * nlights + i])
                c += light_term(&s, v, vload3(0, lights[i].position), vload3(0, lights[i].intensity));
        }
    }
    accum[gid] += (float4)(c, 1.0f);   /* one work-item per pixel of the tile: no race */
}
