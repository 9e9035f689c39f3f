#line 2 "accel/instance.h"
/* Instances: the second level of a two-level BVH (as Embree's and OptiX's instances).
 * A top-level leaf of kind PRIM_INSTANCE lists instance records (texray.layout.INSTANCE);
 * each holds its mesh's BLAS root in the shared node array, whose leaves are triangles in
 * the mesh's own space. The ray is moved into that space by w2o (the direction not
 * renormalized, so t is the same in both spaces and h->t bounds both) and the BLAS is
 * traversed as accel/bvh.h traverses the top tree; hits keep the instance in h->inst.
 * Included only with TX_INSTANCES (accel/bvh.h). Never trusts its input: a BLAS lane of
 * another kind (an instance inside an instance) is skipped, and the node budget and index
 * checks of bvh.h hold here too. */
#ifndef TEXRAY_INSTANCE_H
#define TEXRAY_INSTANCE_H

/* Row r of a 3x4 matrix stored as 12 floats (passed as (__global const float*)&in->o2w, the
 * whole array: indexing past a row of the float[3][4] is out of bounds to Oclgrind). */
inline float4 xf_row(__global const float* m, uint r) { return vload4(r, m); }

inline float3 xf_point(__global const float* m, float3 p)
{
    float4 a = xf_row(m, 0u), b = xf_row(m, 1u), c = xf_row(m, 2u);
    return (float3)(a.x * p.x + a.y * p.y + a.z * p.z + a.w, b.x * p.x + b.y * p.y + b.z * p.z + b.w,
                    c.x * p.x + c.y * p.y + c.z * p.z + c.w);
}

inline float3 xf_vector(__global const float* m, float3 v)
{
    float4 a = xf_row(m, 0u), b = xf_row(m, 1u), c = xf_row(m, 2u);
    return (float3)(a.x * v.x + a.y * v.y + a.z * v.z, b.x * v.x + b.y * v.y + b.z * v.z,
                    c.x * v.x + c.y * v.y + c.z * v.z);
}

/* |M| v for the 3x3 part of m (the error bounds below). */
inline float3 xf_abs_vector(__global const float* m, float3 v)
{
    float4 a = fabs(xf_row(m, 0u)), b = fabs(xf_row(m, 1u)), c = fabs(xf_row(m, 2u));
    return (float3)(a.x * v.x + a.y * v.y + a.z * v.z, b.x * v.x + b.y * v.y + b.z * v.z,
                    c.x * v.x + c.y * v.y + c.z * v.z);
}

#define TX_SORT2(i, j) do { if (t[j] < t[i]) { float tt_ = t[i]; t[i] = t[j]; t[j] = tt_; \
    uint c_ = c[i]; c[i] = c[j]; c[j] = c_; c_ = k[i]; k[i] = k[j]; k[j] = c_; } } while (0)

/* The BLAS from wide node `root` against the object-space ray, t in (tmin, h->t); a
 * nearer hit updates h (prim = PRIM_INSTANCE << HIT_KIND_SHIFT | triangle, inst). With
 * `any` the first hit returns 1. Closest-first order as bvh_closest. */
static int blas_traverse(TX_GEOM_PARAMS, uint root, uint inst, float4 org4, float4 dir4, float tmin, int any,
                         HitRec* h)
{
    float3 org = org4.xyz, dir = dir4.xyz;     /* float4, not float3: core/common.h (out of line) */
    if (!ray_valid(org, dir, tmin, h->t)) return 0;
    WoopRay w = woop_setup(org, dir);
    float3 inv_d = (float3)(safe_inverse(dir.x), safe_inverse(dir.y), safe_inverse(dir.z));
    int par = fabs(inv_d.x) >= TX_PARALLEL_INV || fabs(inv_d.y) >= TX_PARALLEL_INV || fabs(inv_d.z) >= TX_PARALLEL_INV;
    int nx = inv_d.x < 0.0f, ny = inv_d.y < 0.0f, nz = inv_d.z < 0.0f;
    uint stack[TX_STACK_SIZE], stack_ck[TX_STACK_SIZE];
    float stack_t[TX_STACK_SIZE];
    int sp = 0, found = 0;
    uint node = root, ck = 0u, budget = nnodes;
    for (;;) {
        if (ck != 0u) {
            if ((ck >> LEAF_COUNT_BITS) == PRIM_TRIANGLE) {        /* anything else: skipped */
                uint count = ck & LEAF_COUNT_MASK;
                if (node + count < node) count = 0u;                  /* wraps: a broken tree */
                for (uint q = 0; q < count; q += 4u) {
                    float t, b1, b2;
                    int lane = triangle_intersect4(&w, tris + node + q, TX_MIN(count - q, 4u), 0u, TX_MISS,
                                                   tmin, h->t, &t, &b1, &b2);   /* ties: the first met */
                    if (lane >= 0) {
                        h->t = t; h->b1 = b1; h->b2 = b2; h->inst = inst;
                        h->prim = (PRIM_INSTANCE << HIT_KIND_SHIFT) | ((node + q + (uint)lane) & HIT_INDEX_MASK);
                        found = 1;
                        if (any) return 1;
                    }
                }
            }
        } else {
            if (node >= nnodes || budget-- == 0u) return found;
            __global const float4* nd = nodes + 8u * node;
            float4 e = box4_entry(nd, org, dir, inv_d, nx, ny, nz, tmin, h->t, par);
            uint4 ch = as_uint4(nd[6]), kk = as_uint4(nd[7]);
            float t[4] = { e.x, e.y, e.z, e.w };
            uint c[4] = { ch.x, ch.y, ch.z, ch.w }, k[4] = { kk.x, kk.y, kk.z, kk.w };
            TX_SORT2(0, 1); TX_SORT2(2, 3); TX_SORT2(0, 2); TX_SORT2(1, 3); TX_SORT2(1, 2);
            if (t[0] < INFINITY) {
                for (int i = 3; i > 0; --i) {
                    if (t[i] < INFINITY && sp < TX_STACK_SIZE) {
                        stack[sp] = c[i]; stack_ck[sp] = k[i]; stack_t[sp] = t[i]; ++sp;
                    }
                }
                node = c[0]; ck = k[0];
                continue;
            }
        }
        for (;;) {
            if (sp == 0) return found;
            --sp;
            if (stack_t[sp] <= h->t) break;
        }
        node = stack[sp]; ck = stack_ck[sp];
    }
}
#undef TX_SORT2

/* The instances [first, end) of a top-level leaf against the world ray (geometry/dispatch.h). */
int instance_leaf(TX_GEOM_PARAMS, float4 org4, float4 dir4, float tmin, uint first, uint end, int any, HitRec* h)
{
    float3 org = org4.xyz, dir = dir4.xyz;     /* float4, not float3: core/common.h (out of line) */
    int found = 0;
    end = TX_MIN(end, ninstances);             /* a bad index is a miss */
    for (uint i = first; i < end; ++i) {
        __global const Instance* in = instances + i;
        __global const float* w2o = (__global const float*)&in->w2o;
        float3 o = xf_point(w2o, org), d = xf_vector(w2o, dir);
        if (blas_traverse(TX_GEOM_ARGS, in->root, i, (float4)(o, 0.0f), (float4)(d, 0.0f), tmin, any, h)) {
            found = 1;
            if (any) return 1;
        }
    }
    return found;
}

/* The object-space surface geometry g of a hit in instance `in`, moved to world space:
 * the point by o2w with its error bound grown as pbrt-v4's Transform::ApplyPoint (the
 * rounding of the product and the object-space bound carried through |M|), dP/du and
 * dP/dv by o2w's 3x3 (they are linear in the vertices), the geometric normal by the
 * normal matrix times det_sign: the side the world-space vertex order gives, as for the
 * same triangles copied (a mirror reverses the winding). */
void instance_geom(__global const Instance* in, Geom* g)
{
    __global const float* m = (__global const float*)&in->o2w;
    float3 p = g->p;
    float3 mp = xf_abs_vector(m, abs3(p)) + fabs((float3)(xf_row(m, 0u).w, xf_row(m, 1u).w, xf_row(m, 2u).w));
    g->perr = (1.0f + gamma_n(3.0f)) * xf_abs_vector(m, g->perr) + gamma_n(3.0f) * mp;
    g->p = xf_point(m, p);
    g->ng = normalize3(in->det_sign * xf_vector((__global const float*)&in->nrm, g->ng));
    g->dpdu = xf_vector(m, g->dpdu);
    g->dpdv = xf_vector(m, g->dpdv);
}

#endif
