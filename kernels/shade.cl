#line 2 "shade.cl"
/* Stage 5: the lecture's local illumination, accumulated per pixel:
 *   I = ambient kd + sum_i I_i vis(i) / d_i^2 (kd (N.L_i) + ks (R_i.V)^n)
 * with N the shading normal facing the viewer, L_i and V unit vectors from
 * the point, R_i = 2 (N.L_i) N - L_i. Terms with N.L_i <= 0 contribute nothing
 * (the specular term included, so no highlight appears on the unlit side). */

__kernel void shade(__global const Ray* rays, __global const Surface* surf, __global const uchar* vis,
                    uint n, __global float4* accum,
                    __global const PointLight* lights, uint nlights, float4 ambient, float4 background)
{
    uint gid = get_global_id(0);
    if (gid >= n) return;
    __global const Surface* s = surf + gid;
    float3 c = background.xyz;
    if (s->valid) {
        float3 p = vload3(0, s->p), nrm = vload3(0, s->ns);
        float3 kd = vload3(0, s->kd), ks = vload3(0, s->ks);
        float3 v = -normalize3(ray_dir(rays + gid));
        c = ambient.xyz * kd;
        FOR_EACH_LIGHT(i, nlights) {
            if (!vis[(size_t)gid * nlights + i]) continue;
            float3 l = vload3(0, lights[i].position) - p;
            float d2 = dot3(l, l);
            l *= rsqrt(d2);
            float ndl = dot3(nrm, l);
            if (ndl <= 0.0f) continue;
            float3 term = kd * ndl;
#if TX_SPECULAR
            float3 r = 2.0f * ndl * nrm - l;
            float rv = dot3(r, v);
            if (rv > 0.0f) term += ks * powr(rv, s->shininess);
#endif
            c += vload3(0, lights[i].intensity) * (term / d2);
        }
    }
    accum[gid] += (float4)(c, 1.0f);   /* one work-item per pixel of the tile: no race */
}
