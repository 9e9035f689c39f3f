#line 2 "geometry/displace.h"
/* Displacement mapping (the lecture's "Displacement Mapping" slides): the surface
 * S(u, v) = P(u, v) + H(u, v) n(u, v) of a quad, sphere or cylinder (Displaced,
 * texray.layout.DISPLACED), H the bilinear interpolant of a unorm16 height texture (texray.displace.quantize)
 * in world units (texray.displace: conventions of texture/texture.h, v = 0 the bottom row,
 * texel centres at (i + 0.5) / W; the texture's wrap mode).
 *
 * Every point q of space has local coordinates (u, v, h): for a parallelogram quad
 * the affine ones (q = P0 + u e0 + v e1 + h n), for another planar convex quad (a
 * trapezoid, DISP_TRAPEZOID) h = (q - P0).n and (u, v) the inverse of its bilinear
 * patch P0 + u e0 + v e1 + u v g at q's foot (disp_inverse_bilinear), for a sphere
 * the uv of its direction and h = |q - c| - r, for a cylinder its (theta, z) uv and
 * h = rho - r. Along a ray,
 * f(t) = h(t) - H(u(t), v(t)) is > 0 above the surface and < 0 below; outside the
 * (u, v) domain there is no surface (f = +inf, "above").
 *
 * Per ray: entry A and exit B of the bounding volume (slab [hmin, hmax] over a quad
 * in its local coordinates, which also clips to the (u, v) domain; over a trapezoid
 * the same h slab and the four half-spaces of its edges; shell [r + hmin,
 * r + hmax] for spheres and cylinders, cut at the inner sphere, which lies below
 * the surface everywhere), widened by delta, a rounding bound of h along the ray,
 * so that a surface lying on the volume's boundary (an all-zero or all-one map, or
 * scale 0) is still bracketed. Then one of:
 *   DISP_SEARCH: the lecture's linear search, N = steps samples from A to B, for the
 *     first sample on the other side of the surface than A, then M = refine
 *     bisection steps in that interval, and a secant step in the final bracket.
 *     DISP_ADAPTIVE: N / max(|cos|, 1/8) samples, cos between the ray and the
 *     normal at A.
 *   DISP_MAXMIP: Tevs, Ihrke, Seidel 2008 (maximum mipmaps), two-sided: a cell of
 *     the min-max pyramid is skipped when the ray's height over it lies entirely
 *     above its max or below its min, else descended; in a texel cell (the
 *     bilinear patch between four texel centres) f is a quadratic in t, solved
 *     exactly. Conservative: a cell is only skipped when it cannot hold a root, so
 *     no spike is missed whatever its width. On parallelogram quads (u, v, h affine
 *     in t); on spheres, cylinders (TX_DISP_MAXMIP_CURVED) and trapezoids
 *     (TX_DISP_MAXMIP_TRAPEZOID) by disp_maxmip_bisect: the segment cut into pieces
 *     where u, v and h are monotone in t (a trapezoid's is one piece), each bisected
 *     in t against the pyramid, texel cells by the bilinear patch's bound and a
 *     bracketed regula falsi; on mesh triangles (TX_DISP_MAXMIP_MESH) by
 *     disp_maxmip_mesh: the shell's sub-prisms over sub-triangles, bounded by the pyramid
 *     over their uv footprints, traversed front to back down to half-texel leaves, each
 *     clipped exactly and searched.
 *
 * DISP_TRIANGLE (TX_DISP_MESH): one triangle of a displaced mesh, the surface
 * S = P(b1, b2) + H N(b1, b2) with P and N interpolated linearly from the corners and
 * the vertex normals (N not renormalized), H read at the interpolated texture uv. Its
 * volume is the prism shell {P(b) + h N(b): b in the triangle, h in [slo, shi]} (the
 * triangle's bound of H from the min-max pyramid over its uv footprint): bottom and top
 * are the flat triangles P_i + h N_i at h = slo, shi, the three sides bilinear patches
 * (quad.h's intersector). A point q has (b1, b2, h) where q - P0 - h N0 lies in the plane
 * of E1 + h dN1 and E2 + h dN2: a cubic in h (disp_tri_local). The host keeps a shell only
 * where the map (b, h) -> P + h N has a Jacobian of at least cos 86 degrees of the flat
 * one over the whole prism (at h = 0: every vertex normal within 86 degrees of the face
 * normal), so that the coordinates are unique and the five faces bound the shell
 * (texray.compile.shells; a mesh with a triangle that fails is tessellated instead). The
 * search is the one below on the shell's entry..exit segment, with the shell's share of
 * the N samples (disp_tri_steps); samples within
 * TX_DISP_TRI_BAND of the triangle's edges are evaluated on the extended triangle, so
 * that the segment's ends, which lie on the side patches up to rounding, always count:
 * a crossing in the shell then lies between two evaluated samples of opposite sign, and
 * the shells of neighbouring triangles leave no hole between them. An any-hit ray that
 * entered through a side shared with another shell of the mesh (Displaced.edges) has
 * not come from outside the surface's volume (from_outside below).
 * Closest hit: the first sign change of f after A (seen from above or below).
 * Any hit (shadow rays): a crossing into the surface (f from + to -) always counts;
 * one out of it only when the ray entered the volume from outside (A > tmin): a ray
 * leaving the surface it starts on (self-shadowing) must not see its own origin. */
#ifndef TEXRAY_DISPLACE_H
#define TEXRAY_DISPLACE_H
#include "core/transcendental.h"

#include "geometry/hit.h"
#include "geometry/sphere.h"      /* the base shapes' parameterizations: sphere_uv, sphere_tangents, */
#include "geometry/cylinder.h"    /* cylinder_theta_rel, cylinder_tangents, */
#include "geometry/quad.h"        /* quad_texcoords */
#include "core/frame.h"
#include "core/quadratic.h"
#include "core/slab.h"
#include "texture/wrap.h"
#include "texture/bilinear.h"

#define TX_DISP_MAX_LEVELS 32
/* texray.displace.MAX_STEPS, MAX_REFINE: the host's limits on steps and refine, applied
 * again here so that the search's loops stay bounded whatever the table says. */
#define TX_DISP_MAX_STEPS 4096u
#define TX_DISP_MAX_REFINE 32u

typedef struct {
    float3 q0, dir;         /* ray origin relative to Displaced.p, direction */
    float3 e0, e1, n;       /* quad: edges and unit normal; sphere/cylinder: axis_x, axis_y, axis_z */
    float3 r0, r1;          /* quad: dual basis (u = q.r0, v = q.r1); trapezoid: e0 x n, g x n */
    float3 g;               /* trapezoid: the patch's twist p0 - p1 + p2 - p3 (0 for the others) */
    float k2, k1;           /* trapezoid: [g, e1], [e0, e1] (disp_inverse_bilinear) */
    uint shape, hoff;
    int w, h, mode;
    float radius, z0, z1, th0, span, hmin, hmax;
    float hstep;            /* world units per unorm16 step of the stored heights: (hmax - hmin) / 65535 */
    float delta;            /* rounding bound of h along the ray (header comment) */
#if TX_DISP_MESH
    float3 dn1, dn2;        /* triangle: N1 - N0, N2 - N0 (n = N0; e0, e1 = P1 - P0, P2 - P0) */
    float3 c0, c1, c2;      /* triangle: (e0 + h dn1) x (e1 + h dn2) = c0 + h c1 + h^2 c2 */
    float nc0, nc1, nc2;    /* triangle: n . c0, n . c1, n . c2 */
    float2 t0, t1, t2;      /* triangle: texture uv at P0, and its changes to P1, P2 */
    float slo, shi;         /* triangle: the shell's h range */
#endif
} DispFrame;

inline DispFrame disp_frame(__global const Displaced* d, float3 org, float3 dir)
{
    DispFrame f;
    f.q0 = org - vload3(0, d->p);
    f.dir = dir;
    f.e0 = vload3(0, d->e0); f.e1 = vload3(0, d->e1); f.n = vload3(0, d->n);
    f.shape = d->shape; f.hoff = d->hoff;
    f.w = (int)d->hw; f.h = (int)d->hh; f.mode = (int)d->wrap;
    f.radius = d->radius; f.z0 = d->z_min; f.z1 = d->z_max;
    f.th0 = d->theta_min; f.span = d->theta_max - d->theta_min;
    f.hmin = d->hmin; f.hmax = d->hmax;
    f.hstep = (f.hmax - f.hmin) * (1.0f / 65535.0f);
    float ext = TX_MAX(fabs(f.hmin), fabs(f.hmax));
    f.g = (float3)(0.0f);
    f.k2 = f.k1 = 0.0f;
    if (f.shape == DISP_QUAD) {
        float3 c1 = cross3(f.e1, f.n), c2 = cross3(f.n, f.e0);
        float inv = 1.0f / dot3(f.e0, c1);
        f.r0 = c1 * inv; f.r1 = c2 * inv;
        ext += sqrt(dot3(f.e0, f.e0)) + sqrt(dot3(f.e1, f.e1));
    } else if (f.shape == DISP_TRAPEZOID) {
        f.g = vload3(0, d->g);
        f.r0 = cross3(f.e0, f.n); f.r1 = cross3(f.g, f.n);
        f.k2 = dot3(cross3(f.g, f.e1), f.n); f.k1 = dot3(cross3(f.e0, f.e1), f.n);
        ext += sqrt(dot3(f.e0, f.e0)) + sqrt(dot3(f.e1, f.e1)) + sqrt(dot3(f.g, f.g));
    }
#if TX_DISP_MESH
    else if (f.shape == DISP_TRIANGLE) {
        f.r0 = f.r1 = (float3)(0.0f);
        f.dn1 = vload3(0, d->n1) - f.n; f.dn2 = vload3(0, d->n2) - f.n;
        f.c0 = cross3(f.e0, f.e1);
        f.c1 = cross3(f.e0, f.dn2) + cross3(f.dn1, f.e1);
        f.c2 = cross3(f.dn1, f.dn2);
        f.nc0 = dot3(f.n, f.c0); f.nc1 = dot3(f.n, f.c1); f.nc2 = dot3(f.n, f.c2);
        f.t0 = (float2)(d->uv[0], d->uv[1]);
        f.t1 = (float2)(d->uv[2], d->uv[3]) - f.t0; f.t2 = (float2)(d->uv[4], d->uv[5]) - f.t0;
        f.slo = d->slo; f.shi = d->shi;
        ext += sqrt(dot3(f.e0, f.e0)) + sqrt(dot3(f.e1, f.e1));     /* |N| <= 1: unit vertex normals */
    }
#endif
    else {
        f.r0 = f.r1 = (float3)(0.0f);
        ext += f.radius + (f.shape == DISP_CYLINDER ? TX_MAX(fabs(f.z0), fabs(f.z1)) : 0.0f);
    }
    /* A point of the volume is within ext of p; it is computed as q0 + t dir with
     * |t dir| <= |q0| + ext, and h from it in a few more operations: 16 roundings of
     * |q0| + ext bound h's error (pbrt-v4 3.9's gamma bounds). */
    f.delta = gamma_n(16.0f) * (sqrt(dot3(f.q0, f.q0)) + ext);
    return f;
}

/* Distance of x from [0, 1]; +inf for NaN. */
static inline float disp_unit_distance(float x)
{
    return x >= 0.0f && x <= 1.0f ? 0.0f : (x < 0.0f ? -x : (x > 1.0f ? x - 1.0f : INFINITY));
}

/* (u, v) of the trapezoid's planar bilinear patch u e0 + v e1 + u v g at the point q
 * (relative to its corner p0; components along n drop out of every cross product's n
 * part). With w = e0 + v g, q - v e1 = u w: crossing both sides with w gives
 * k2 v^2 + k1' v + k0 = 0, k2 = [g, e1], k1' = [e0, e1] + [q, g], k0 = [q, e0] ([a, b] =
 * (a x b).n = a.(b x n): disp_frame keeps the constants k2 and k1 = [e0, e1] and the
 * vectors r0 = e0 x n, r1 = g x n, so a sample costs two dot products), solved with
 * core/quadratic.h's stable roots (k2 = 0 leaves the linear root); of the two, the one
 * nearer [0, 1] (a convex quad has one root there for a point over it). Then
 * u = (q - v e1).w / w.w. NaN where no real root exists (q far outside). */
static inline float2 disp_inverse_bilinear(const DispFrame* f, float3 q)
{
    float k1 = f->k1 + dot3(q, f->r1), k0 = dot3(q, f->r0);
    float hb = 0.5f * k1, disc = quadratic_disc(f->k2, hb, k0);
    if (!(disc >= 0.0f)) return (float2)(NAN);
    QuadRoots r = stable_roots(f->k2, hb, k0, sqrt(disc), 1);
    float v = disp_unit_distance(r.t_far) < disp_unit_distance(r.t_near) ? r.t_far : r.t_near;
    float3 w = f->e0 + v * f->g;
    float u = dot3(q - v * f->e1, w) / dot3(w, w);
    return (float2)(u, v);
}

#if TX_DISP_MESH
/* How far beyond a triangle's edges (in barycentrics) its surface is still evaluated
 * (header comment): 2^-12, some hundred times the barycentrics' rounding at a side patch
 * hit, and small enough that the extended surface stays within the shell's bound (the
 * host widens each uv footprint by the same band, texray.compile.shells.BAND). */
#define TX_DISP_TRI_BAND 2.44140625e-4f
/* Newton steps on the cubic of disp_tri_local: from the linearized root, the error
 * squares each step (relative error ~ |h| |dN| / |E|, 0.1 for a coarse torus): four take
 * it below float32 rounding. They stop early once a step is below 2^-24 |h|, half an ulp
 * of h (at once where the vertex normals are equal: the cubic is then linear). */
#define TX_DISP_TRI_NEWTON 4
#define TX_DISP_TRI_NEWTON_TOL 5.9604645e-08f

/* (b1, b2, h) of the point q (relative to P0) in a mesh triangle's shell: q - h N0 =
 * b1 (E1 + h dN1) + b2 (E2 + h dN2), so (q - h N0) . ((E1 + h dN1) x (E2 + h dN2)) = 0,
 * a0 + a1 h + a2 h^2 + a3 h^3 with the frame's c_k; Newton from the linear root (exact at
 * once for equal vertex normals), then b from the plane's cross products. NaN where the
 * cubic has no usable root (a degenerate triangle). */
inline float3 disp_tri_local(const DispFrame* f, float3 q)
{
    float a0 = dot3(q, f->c0), a1 = dot3(q, f->c1) - f->nc0, a2 = dot3(q, f->c2) - f->nc1, a3 = -f->nc2;
    float h = -a0 / a1;
    for (int k = 0; k < TX_DISP_TRI_NEWTON; ++k) {
        float p = ((a3 * h + a2) * h + a1) * h + a0, dp = (3.0f * a3 * h + 2.0f * a2) * h + a1;
        float step = p / dp;
        h -= step;
        if (!(fabs(step) > TX_DISP_TRI_NEWTON_TOL * fabs(h))) break;
    }
    float3 u = f->e0 + h * f->dn1, v = f->e1 + h * f->dn2, w = q - h * f->n, c = cross3(u, v);
    float inv = 1.0f / dot3(c, c);
    return (float3)(dot3(cross3(w, v), c) * inv, dot3(cross3(u, w), c) * inv, h);
}

/* b = (b1, b2) in the triangle extended by TX_DISP_TRI_BAND; false for NaN. */
static inline int disp_tri_inside(float2 b)
{
    return b.x >= -TX_DISP_TRI_BAND && b.y >= -TX_DISP_TRI_BAND && b.x + b.y <= 1.0f + TX_DISP_TRI_BAND;
}

/* The texture uv of barycentrics b. */
static inline float2 disp_tri_uv(const DispFrame* f, float2 b)
{
    return f->t0 + b.x * f->t1 + b.y * f->t2;
}
#endif

/* (u, v, h) of the point q (relative to Displaced.p); u, v NaN or outside [0, 1]
 * where the primitive has no surface. */
inline float3 disp_local(const DispFrame* f, float3 q)
{
    if (f->shape == DISP_QUAD) return (float3)(dot3(q, f->r0), dot3(q, f->r1), dot3(q, f->n));
    if (f->shape == DISP_TRAPEZOID) return (float3)(disp_inverse_bilinear(f, q), dot3(q, f->n));
    float x = dot3(q, f->e0), y = dot3(q, f->e1), z = dot3(q, f->n);
    float rho = tx_hypot(x, y);
    if (f->shape == DISP_SPHERE) return (float3)(sphere_uv(x, y, z, rho), tx_hypot(rho, z) - f->radius);
    float rel = cylinder_theta_rel(x, y, f->th0);                   /* [0, 2pi] */
    return (float3)(rel / f->span, (z - f->z0) / (f->z1 - f->z0), rho - f->radius);
}

/* The four texels around texel-cell corner index (cx, cy) (cell grid of
 * texray.displace.minmax_pyramid: texels cx - 1, cx and rows cy - 1, cy). */
inline float4 disp_cell_corners(__global const ushort* hts, const DispFrame* f, int cx, int cy)
{
    int x0 = wrap_index(cx - 1, f->w, f->mode), x1 = wrap_index(cx, f->w, f->mode);
    int y0 = wrap_index(cy - 1, f->h, f->mode), y1 = wrap_index(cy, f->h, f->mode);
    __global const ushort* t = hts + f->hoff;
    float4 q = (float4)((float)t[y0 * f->w + x0], (float)t[y0 * f->w + x1], (float)t[y1 * f->w + x0],
                        (float)t[y1 * f->w + x1]);
    return f->hmin + q * f->hstep;
}

/* H(u, v) for (u, v) in [0, 1]^2 and its gradient (dH/du, dH/dv) (texture/texture.h's taps). */
static inline float disp_height(__global const ushort* hts, const DispFrame* f, float2 uv, float2* grad)
{
    float x = uv.x * (float)f->w + 0.5f, y = (1.0f - uv.y) * (float)f->h + 0.5f;
    float cx = floor(x), cy = floor(y);
    float ax = x - cx, ay = y - cy;
    float4 c = disp_cell_corners(hts, f, (int)cx, (int)cy);
    if (grad) {
        float2 d = bilinear_gradient(c.x, c.y, c.z, c.w, ax, ay);
        *grad = (float2)(d.x * (float)f->w, -d.y * (float)f->h);
    }
    return (c.x * (1.0f - ax) + c.y * ax) * (1.0f - ay) + (c.z * (1.0f - ax) + c.w * ax) * ay;
}

/* f(t) = h - H at the ray's point t (+inf outside the domain); *uv its (u, v). */
inline float disp_f(__global const ushort* hts, const DispFrame* f, float t, float2* uv)
{
#if TX_DISP_MESH
    if (f->shape == DISP_TRIANGLE) {               /* *uv: the barycentrics (b1, b2) */
        float3 b = disp_tri_local(f, f->q0 + t * f->dir);
        *uv = b.xy;
        if (!disp_tri_inside(b.xy)) return INFINITY;
        return b.z - disp_height(hts, f, disp_tri_uv(f, b.xy), 0);
    }
#endif
    float3 l = disp_local(f, f->q0 + t * f->dir);
    *uv = l.xy;
    if (!(l.x >= 0.0f && l.x <= 1.0f && l.y >= 0.0f && l.y <= 1.0f)) return INFINITY;
    return l.z - disp_height(hts, f, l.xy, 0);
}

/* The ray's interval [*a, *b] within (tmin, tmax) of the sphere |q| <= R: 0 if none. */
static inline int disp_ball(float3 q0, float3 dir, float R, float* a, float* b)
{
    float aa = dot3(dir, dir);
    float3 w = cross3(q0, dir);
    float disc = R * R - dot3(w, w) / aa;                 /* R^2 - (distance to the line)^2 */
    if (!(disc >= 0.0f)) return 0;
    float mid = -dot3(q0, dir) / aa, hc = sqrt(disc / aa);
    *a = mid - hc; *b = mid + hc;
    return 1;
}

/* Entry A and exit B of the (widened) volume within (tmin, tmax); 0 if the ray misses it. */
inline int disp_clip(const DispFrame* f, float tmin, float tmax, float* A, float* B)
{
    float tn = tmin, tf = tmax;
    float hlo = f->hmin - f->delta, hhi = f->hmax + f->delta;
    if (f->shape == DISP_QUAD) {
        float3 lo = disp_local(f, f->q0);
        float3 ld = (float3)(dot3(f->dir, f->r0), dot3(f->dir, f->r1), dot3(f->dir, f->n));
        /* (u, v) in [0, 1]^2 and h in [hlo, hhi]: exact slabs, the height range widened by delta */
        if (!(slab_clip(lo.x, ld.x, 0.0f, 1.0f, 1.0f, &tn, &tf) && slab_clip(lo.y, ld.y, 0.0f, 1.0f, 1.0f, &tn, &tf)
              && slab_clip(lo.z, ld.z, hlo, hhi, 1.0f, &tn, &tf)))
            return 0;
    } else if (f->shape == DISP_TRAPEZOID) {
        /* the h slab, and the inner side of each edge's plane through n (the corners
         * 0, e0, e0 + e1 + g, e1 counterclockwise about n: inward normal n x edge) */
        if (!slab_clip(dot3(f->q0, f->n), dot3(f->dir, f->n), hlo, hhi, 1.0f, &tn, &tf)) return 0;
        float3 c[4] = { (float3)(0.0f), f->e0, f->e0 + f->e1 + f->g, f->e1 };
        for (int i = 0; i < 4; ++i) {
            float3 m = cross3(f->n, c[(i + 1) & 3] - c[i]);
            if (!slab_clip(dot3(f->q0 - c[i], m), dot3(f->dir, m), 0.0f, INFINITY, 1.0f, &tn, &tf)) return 0;
        }
    } else if (f->shape == DISP_SPHERE) {
        float a, b;
        if (!disp_ball(f->q0, f->dir, f->radius + hhi, &a, &b)) return 0;
        tn = TX_MAX(tn, a); tf = TX_MIN(tf, b);
        float rin = f->radius + hlo;                       /* below the surface everywhere */
        if (rin > 0.0f && disp_ball(f->q0, f->dir, rin, &a, &b) && a > tn) tf = TX_MIN(tf, a);
    } else {
        float zo = dot3(f->q0, f->n), zd = dot3(f->dir, f->n);
        float3 qp = f->q0 - zo * f->n, dp = f->dir - zd * f->n;
        float R = f->radius + hhi;
        if (dot3(dp, dp) > 0.0f) {
            float a, b;
            if (!disp_ball(qp, dp, R, &a, &b)) return 0;
            tn = TX_MAX(tn, a); tf = TX_MIN(tf, b);
        } else if (!(dot3(qp, qp) <= R * R)) {
            return 0;
        }
        if (!slab_clip(zo, zd, f->z0, f->z1, 1.0f, &tn, &tf)) return 0;
    }
    *A = tn; *B = tf;
    return tn <= tf && tn < INFINITY;
}

#if TX_DISP_MESH
/* A crossing t of the ray with a face of a prism shell: widens [*ta, *tb], *entry the face
 * of the nearest, *n counts them. */
static inline void disp_tri_crossing(float t, int face, float* ta, float* tb, int* entry, int* n)
{
    if (t < *ta) { *ta = t; *entry = face; }
    *tb = TX_MAX(*tb, t);
    ++*n;
}

/* q inside the prism over the sub-triangle (o, k) (disp_tri_clip) between hlo and hhi. */
static inline int disp_tri_in_shell(const DispFrame* f, float3 q, float2 o, float k, float hlo, float hhi)
{
    float3 b = disp_tri_local(f, q);
    float2 s = (b.xy - o) * k;
    return s.x >= 0.0f && s.y >= 0.0f && s.x + s.y <= 1.0f && b.z >= hlo && b.z <= hhi;
}

/* Entry A and exit B of a mesh triangle's prism shell (header comment) within (tmin,
 * tmax), widened by delta in h like the other volumes: the first and last crossing of its
 * five faces, or tmin / tmax where the ray starts / ends inside. The bottom and top
 * (h = hlo, hhi) are flat triangles: (q - h N0) . C(h) = 0 is linear in t, met within
 * the triangle extended by TX_DISP_TRI_BAND (a ray through a shared edge, or lying in a
 * shared side patch, as rays from a convex mesh's centre toward its edges do, meets
 * the top and bottom of both shells beside it, where the exact test could reject it in
 * both); the sides are the bilinear patches between corners k, k + 1 (quad.h), each met
 * at most twice. A crossing count of the wrong parity (a crossing lost to rounding, or
 * one more in the band) takes the corners' box instead, which holds the shell:
 * conservative; it returns 2 then, and the search takes all N samples over the box's
 * segment (its ends lie outside the shell, where f is not evaluated).
 * *from_outside: the ray entered through the bottom, the top or a side on the mesh's
 * border (not through a side shared with a neighbour's shell, Displaced.edges).
 * The same for the prism of a sub-triangle of the triangle (maxmip, disp_maxmip_mesh): c, nv
 * its corners' positions (relative to P0) and normals, [slo, shi] its h range, (o, k) the
 * map from the triangle's barycentrics b to the sub-triangle's, (b - o) k (corners o,
 * o + (1/k, 0), o + (0, 1/k); the whole triangle: o = 0, k = 1, exact), in which the
 * band and the inside tests are taken; its sides are met by the same bilinear patches,
 * its bottom and top lie in the triangle's planes at h = slo, shi. */
inline int disp_tri_clip(__global const Displaced* d, const DispFrame* f, const float3* c, const float3* nv, float2 o,
                         float k_sub, float slo, float shi, float tmin, float tmax, float* A, float* B, int* from_outside)
{
    float hlo = slo - f->delta, hhi = shi + f->delta;
    float3 lo = (float3)(INFINITY), hi = (float3)(-INFINITY);
    for (int k = 0; k < 3; ++k) {
        float3 a = c[k] + hlo * nv[k], b = c[k] + hhi * nv[k];
        lo = TX_MIN(lo, TX_MIN(a, b)); hi = TX_MAX(hi, TX_MAX(a, b));
    }
    float tn = tmin, tf = tmax;
    if (!(slab_clip(f->q0.x, f->dir.x, lo.x, hi.x, 1.0f, &tn, &tf) && slab_clip(f->q0.y, f->dir.y, lo.y, hi.y, 1.0f, &tn, &tf)
          && slab_clip(f->q0.z, f->dir.z, lo.z, hi.z, 1.0f, &tn, &tf) && tn <= tf))
        return 0;
    float ta = INFINITY, tb = -INFINITY, t;
    int entry = -1, n = 0;
    for (int k = 0; k < 2; ++k) {
        float h = k ? hhi : hlo;
        float3 C = f->c0 + h * (f->c1 + h * f->c2), u = f->e0 + h * f->dn1, v = f->e1 + h * f->dn2;
        t = dot3(h * f->n - f->q0, C) / dot3(f->dir, C);
        if (!(t > tmin && t < tmax)) continue;
        float3 w = f->q0 + t * f->dir - h * f->n;
        float inv = 1.0f / dot3(C, C), b1 = dot3(cross3(w, v), C) * inv, b2 = dot3(cross3(u, w), C) * inv;
        if (disp_tri_inside(((float2)(b1, b2) - o) * k_sub)) disp_tri_crossing(t, 3 + k, &ta, &tb, &entry, &n);
    }
    for (int k = 0; k < 3; ++k) {
        int j = k == 2 ? 0 : k + 1;
        float3 p0 = c[k] + hlo * nv[k], p1 = c[j] + hlo * nv[j], p2 = c[j] + hhi * nv[j], p3 = c[k] + hhi * nv[k];
        float from = tmin;
        float2 uvq;
        for (int r = 0; r < 2 && quad_intersect_corners(p0, p1, p2, p3, f->q0, f->dir, from, tmax, &t, &uvq); ++r) {
            disp_tri_crossing(t, k, &ta, &tb, &entry, &n);
            from = t;
        }
    }
    int in0 = tn <= tmin && disp_tri_in_shell(f, f->q0 + tmin * f->dir, o, k_sub, hlo, hhi);
    int in1 = tf >= tmax && disp_tri_in_shell(f, f->q0 + tmax * f->dir, o, k_sub, hlo, hhi);
    if ((n + in0 + in1) & 1) {
        *A = tn; *B = tf;
        *from_outside = tn > tmin;
        return 2;
    }
    if (in0) { ta = tmin; entry = -1; }
    if (in1) tb = tmax;
    if (!(ta <= tb)) return 0;
    *A = clamp(ta, tn, tf); *B = clamp(tb, tn, tf);
    *from_outside = !in0 && !(entry >= 0 && entry < 3 && ((d->edges >> entry) & 1u));
    return 1;
}
#endif

#if TX_DISP_MESH
/* A shell's share of the search's N samples: N is the sample density of the quad's search,
 * N samples over the height field's whole range [hmin, hmax] along the normal, and a shell
 * takes the fraction of them that its segment spans: the smaller of its thickness
 * (shi - slo) / (hmax - hmin) and its segment's length against the quad's whole path
 * (hmax - hmin) / (|dir| cos), cos the largest over its vertex normals and face normal (the
 * most samples where the surface curves). A ray crossing k shells then takes about N
 * samples in all, as over a quad, not k N; at least 1 step (both ends). */
static inline uint disp_tri_steps(const DispFrame* f, float3 dir, float A, float B, uint steps)
{
    float3 nv1 = f->n + f->dn1, nv2 = f->n + f->dn2;
    float c = TX_MAX(TX_MAX(fabs(dot3(f->n, dir)), fabs(dot3(nv1, dir)) * rsqrt(dot3(nv1, nv1))),
                     TX_MAX(fabs(dot3(nv2, dir)) * rsqrt(dot3(nv2, nv2)), fabs(dot3(f->c0, dir)) * rsqrt(dot3(f->c0, f->c0))));
    float range = f->hmax - f->hmin;
    float share = TX_MIN((f->shi - f->slo) / range, (B - A) * c / range);
    if (!(share < 1.0f)) return steps;                 /* also NaN: a flat field (range 0) */
    return clamp((uint)ceil((float)steps * share), 1u, steps);
}
#endif

/* The lecture's search on [A, B] (header comment). Samples where the primitive has
 * no surface (outside the (u, v) domain, e.g. [A, B]'s ends rounded just past the
 * quad's edge, or a partial cylinder's gap) are skipped: they neither start nor end
 * a bracket. Bound: steps + 1 samples (steps <= 8 TX_DISP_MAX_STEPS, the caller
 * clamps it) and one refinement of `refine` (<= TX_DISP_MAX_REFINE) bisections. */
inline int disp_search(__global const ushort* hts, const DispFrame* f, float A, float B, uint steps, uint refine,
                       int any, int from_outside, float* t_hit, float2* uv_hit)
{
    float2 uv;
    float dt = (B - A) / (float)steps;
    float t_prev = A, f_prev = INFINITY;
    int below0 = -1;                                   /* side of the first sample with a surface */
    for (uint i = 0u; i <= steps; ++i) {
        float t = i == steps ? B : A + (float)i * dt;
        float fi = disp_f(hts, f, t, &uv);
        if (!(fi < INFINITY)) continue;
        int below = fi < 0.0f;
        if (below0 < 0) {
            below0 = below;
        } else if (below != below0) {
            if (any) {
                if (below || from_outside) { *t_hit = t; *uv_hit = uv; return 1; }
                below0 = below;                        /* left the surface it starts on */
            } else {
                float lo = t_prev, hi = t, flo = f_prev, fhi = fi;
                for (uint k = 0u; k < refine; ++k) {
                    float m = 0.5f * (lo + hi);
                    float fm = disp_f(hts, f, m, &uv);
                    if (!(fm < INFINITY)) break;
                    if ((fm < 0.0f) == below0) { lo = m; flo = fm; } else { hi = m; fhi = fm; }
                }
                float th = hi;
                if (flo != fhi)                        /* secant step in the final bracket */
                    th = clamp(lo + (hi - lo) * (flo / (flo - fhi)), lo, hi);
                disp_f(hts, f, th, uv_hit);
                *uv_hit = clamp(*uv_hit, 0.0f, 1.0f);
                *t_hit = th;
                return 1;
            }
        }
        t_prev = t; f_prev = fi;
    }
    return 0;
}

/* Smallest root s in [0, len] of c0 + c1 s + c2 s^2 that counts (header comment:
 * for any-hit rays, a root where f rises counts only when from_outside). The
 * discriminant is Kahan's (core/quadratic.h), as for the bilinear quad: near a double
 * root (a ray grazing a texel cell's patch) its sign is right, where the plain
 * difference of products could round it below 0 and drop the hit. */
static inline int disp_quadratic_root(float c0, float c1, float c2, float len, int any, int from_outside, float* s)
{
    float b = 0.5f * c1;                                  /* core/quadratic.h: half the linear coefficient */
    float disc = quadratic_disc(c2, b, c0);
    if (!(disc >= 0.0f)) return 0;
    /* Sorted; c2 = 0 (a linear cell) gives one infinite root and the linear one, c1 = c2 = 0
     * NaN or infinite roots, all rejected by the range test below; c1 = disc = 0 a root 0/0
     * (NaN) beside the double root q / c2 = 0. */
    QuadRoots qr = stable_roots(c2, b, c0, sqrt(disc), 1);
    float r[2] = { qr.t_near, qr.t_far };
    for (int k = 0; k < 2; ++k) {
        float x = r[k];
        if (!(x >= 0.0f && x <= len)) continue;
        if (any && !from_outside && !(c1 + 2.0f * c2 * x < 0.0f)) continue;
        *s = x;
        return 1;
    }
    return 0;
}

/* The min-max pyramid of the record's heights (texray.displace.minmax_pyramid): level l's
 * offset off[l] in the height buffer (pairs of unorm16 min, max, row by row) and its cell
 * grid cw[l] x ch[l] (level 0: (W + 1) x (H + 1) cells between texel centres, then halved,
 * rounded up). Returns the level count (<= TX_DISP_MAX_LEVELS); 0 where there is no
 * pyramid to index. */
static inline int disp_pyramid(__global const Displaced* d, const DispFrame* f, uint* off, int* cw, int* ch)
{
    int levels = TX_MIN((int)d->levels, TX_DISP_MAX_LEVELS);
    if (levels < 1 || f->w < 1 || f->h < 1) return 0;
    off[0] = d->moff; cw[0] = f->w + 1; ch[0] = f->h + 1;
    for (int l = 1; l < levels; ++l) {
        off[l] = off[l - 1] + 2u * (uint)(cw[l - 1] * ch[l - 1]);
        cw[l] = (cw[l - 1] + 1) / 2; ch[l] = (ch[l - 1] + 1) / 2;
    }
    return levels;
}

/* Exact min-max pyramid traversal on [A, B] (quads; header comment). Cell
 * coordinates X = u W + 1/2, Y = (1 - v) H + 1/2 (level 0: (W + 1) x (H + 1) cells),
 * affine in t; cells are tracked as integers, so rounding never loops or skips. */
inline int disp_maxmip(__global const ushort* hts, __global const Displaced* d, const DispFrame* f, float A, float B,
                       int any, int from_outside, float* t_hit, float2* uv_hit)
{
    uint off[TX_DISP_MAX_LEVELS];
    int cw[TX_DISP_MAX_LEVELS], ch[TX_DISP_MAX_LEVELS];
    int levels = disp_pyramid(d, f, off, cw, ch);
    if (!levels) return 0;                                /* no pyramid: nothing to index */
    float3 lo = disp_local(f, f->q0);
    float3 ld = (float3)(dot3(f->dir, f->r0), dot3(f->dir, f->r1), dot3(f->dir, f->n));
    float W = (float)f->w, H = (float)f->h;
    float X0 = lo.x * W + 0.5f, dX = ld.x * W, Y0 = (1.0f - lo.y) * H + 0.5f, dY = -ld.y * H;
    float h0 = lo.z, dh = ld.z;
    int sx = dX > 0.0f ? 1 : -1, sy = dY > 0.0f ? 1 : -1;
    int L = levels - 1, cx = 0, cy = 0;
    float t = A;
    /* Each level-0 cell the ray crosses is entered once, with at most one ascent and
     * `levels` descents per step: a bound that only a broken input can reach. Cells
     * only ever advance along the ray (a descent picks a child of the current cell,
     * an ascent the parent of the next), so the loop ends; whatever the input (NaN
     * distances included) it runs at most cap times. w and h are capped at 2^20 for
     * cap alone (no int overflow; a larger map gets a smaller cap, so at worst a miss). */
    int cap = (TX_MIN(f->w, 1 << 20) + TX_MIN(f->h, 1 << 20) + 4) * (2 * levels + 2) + 64;
    for (int it = 0; it < cap; ++it) {
        float size = (float)(1 << L);
        float bx = (float)(sx > 0 ? cx + 1 : cx) * size, by = (float)(sy > 0 ? cy + 1 : cy) * size;
        float tx = dX != 0.0f ? (bx - X0) / dX : INFINITY, ty = dY != 0.0f ? (by - Y0) / dY : INFINITY;
        float te = TX_MAX(TX_MIN(TX_MIN(tx, ty), B), t);
        float ha = h0 + t * dh, hb = h0 + te * dh;
        /* Dequantized like the texels (monotone in q), so the pyramid of the stored q bounds
         * the device's interpolant exactly. */
        float2 mm = f->hmin + convert_float2(vload2(0, hts + off[L] + 2u * (uint)(cy * cw[L] + cx))) * f->hstep;
        int skip = TX_MIN(ha, hb) > mm.y + f->delta || TX_MAX(ha, hb) < mm.x - f->delta;
        if (!skip) {
            if (L > 0) {
                --L;
                size *= 0.5f;
                float xt = X0 + t * dX, yt = Y0 + t * dY;
                float mx = (float)(2 * cx + 1) * size, my = (float)(2 * cy + 1) * size;
                int kx = 2 * cx + (xt > mx || (xt == mx && dX > 0.0f));
                int ky = 2 * cy + (yt > my || (yt == my && dY > 0.0f));
                cx = TX_MIN(kx, cw[L] - 1); cy = TX_MIN(ky, ch[L] - 1);
                continue;
            }
            /* Texel cell: f(t + s) = c0 + c1 s + c2 s^2 against the bilinear patch. */
            float4 c = disp_cell_corners(hts, f, cx, cy);
            float b = c.y - c.x, cc = c.z - c.x, dd = c.x - c.y - c.z + c.w;
            float fx0 = X0 + t * dX - (float)cx, fy0 = Y0 + t * dY - (float)cy;
            float c0 = ha - (c.x + b * fx0 + cc * fy0 + dd * fx0 * fy0);
            float c1 = dh - (b * dX + cc * dY + dd * (fx0 * dY + fy0 * dX));
            float c2 = -dd * dX * dY;
            float s;
            if (disp_quadratic_root(c0, c1, c2, te - t, any, from_outside, &s)) {
                float th = t + s;
                float3 l = disp_local(f, f->q0 + th * f->dir);
                *t_hit = th;
                *uv_hit = clamp(l.xy, 0.0f, 1.0f);
                return 1;
            }
        }
        if (te >= B) return 0;
        t = te;
        int px = cx >> 1, py = cy >> 1;
        if (tx <= ty) cx += sx; else cy += sy;
        if (cx < 0 || cy < 0 || cx >= cw[L] || cy >= ch[L]) return 0;
        /* Up one level only into a new parent: a sibling of the same parent is next in
         * line anyway, and going up there could descend, by rounding, into the cell
         * just left (a ray along a cell boundary would then never advance). */
        if (L < levels - 1 && ((cx >> 1) != px || (cy >> 1) != py)) { ++L; cx >>= 1; cy >>= 1; }
    }
    return 0;
}

#if TX_DISP_MAXMIP_CURVED || TX_DISP_MAXMIP_TRAPEZOID || TX_DISP_MAXMIP_MESH
/* The bilinear patch of a texel cell's corners c at fractions (ax, ay) (disp_height's). */
static inline float disp_bilerp(float4 c, float ax, float ay)
{
    return (c.x * (1.0f - ax) + c.y * ax) * (1.0f - ay) + (c.z * (1.0f - ax) + c.w * ax) * ay;
}

/* Level-0 cell index of the coordinate x, clamped to [0, n - 1] (NaN -> 0). */
static inline int disp_cell_index(float x, int n)
{
    return x >= 1.0f ? TX_MIN((int)TX_MIN(x, (float)(n - 1)), n - 1) : 0;
}

/* (min, max) of the interpolant over the rectangle [xlo, xhi] x [ylo, yhi] of cell
 * coordinates (indices clamped to the grid, NaN to cell 0): the pyramid's cells at the
 * finest level *L where it spans at most 2 x 2 of them; at level 0 (at most 2 x 2 texel
 * cells) the bilinear patch of each cell at the corners of the rectangle's part in it (a
 * bilinear function has its extremes over an axis-aligned rectangle at the corners), so
 * the bound tightens as the rectangle shrinks. off, cw, ch0, levels: disp_pyramid's. */
inline float2 disp_rect_bound(__global const ushort* hts, const DispFrame* f, const uint* off, const int* cw, int ch0,
                              int levels, float xlo, float xhi, float ylo, float yhi, int* level)
{
    int cx0 = disp_cell_index(xlo, cw[0]), cx1 = disp_cell_index(xhi, cw[0]);
    int cy0 = disp_cell_index(ylo, ch0), cy1 = disp_cell_index(yhi, ch0);
    int L = 0;
    float Hlo = INFINITY, Hhi = -INFINITY;
    while (L < levels - 1 && ((cx1 >> L) - (cx0 >> L) > 1 || (cy1 >> L) - (cy0 >> L) > 1)) ++L;
    for (int iy = cy0 >> L; iy <= cy1 >> L; ++iy)
        for (int ix = cx0 >> L; ix <= cx1 >> L; ++ix) {
            if (L == 0) {                                /* the patch over the rectangle's part in the cell */
                float4 c = disp_cell_corners(hts, f, ix, iy);
                float ax0 = clamp(xlo - (float)ix, 0.0f, 1.0f), ax1 = clamp(xhi - (float)ix, 0.0f, 1.0f);
                float ay0 = clamp(ylo - (float)iy, 0.0f, 1.0f), ay1 = clamp(yhi - (float)iy, 0.0f, 1.0f);
                float b00 = disp_bilerp(c, ax0, ay0), b10 = disp_bilerp(c, ax1, ay0);
                float b01 = disp_bilerp(c, ax0, ay1), b11 = disp_bilerp(c, ax1, ay1);
                Hlo = TX_MIN(Hlo, TX_MIN(TX_MIN(b00, b10), TX_MIN(b01, b11)));
                Hhi = TX_MAX(Hhi, TX_MAX(TX_MAX(b00, b10), TX_MAX(b01, b11)));
            } else {
                float2 mm = f->hmin + convert_float2(vload2(0, hts + off[L] + 2u * (uint)(iy * cw[L] + ix))) * f->hstep;
                Hlo = TX_MIN(Hlo, mm.x); Hhi = TX_MAX(Hhi, mm.y);
            }
        }
    *level = L;
    return (float2)(Hlo, Hhi);
}

#endif

#if TX_DISP_MAXMIP_CURVED || TX_DISP_MAXMIP_TRAPEZOID
/* Maxmip on spheres, cylinders (TX_DISP_MAXMIP_CURVED) and trapezoids
 * (TX_DISP_MAXMIP_TRAPEZOID; header comment): the ray's segment [A, B] is cut into
 * pieces on which the cell coordinates X = u W + 1/2, Y = (1 - v) H + 1/2 and the height
 * h are all monotone in t, and each piece is bisected in t (a dyadic, stackless
 * traversal, left half first) against the min-max pyramid.
 *
 * Cuts: where the ray passes closest to the axis (the azimuth sweeps less than pi along a
 * line, monotonically, but jumps by pi where the line meets the axis; the cylinder's rho,
 * so h, is least there); the sphere's closest point to its centre (h least) and the
 * extremum of its polar angle (cos theta = z / |q| has a derivative whose numerator is
 * linear in t, so theta is unimodal along a line); the seam, the meridian half-plane at
 * theta_min (a sphere's +x), and a partial cylinder's other end at theta_max (a piece in
 * its gap has no surface and is skipped). On a piece, X is taken from the azimuth
 * relative to the piece's midpoint (continuous: a piece sweeps less than pi), so no piece
 * wraps around the seam.
 *
 * A trapezoid (any planar convex quad that is no parallelogram) needs no cut: h is linear
 * in t, and u, v are monotone along the ray's foot in the plane while it stays over the
 * quad (the quad's part of the ray's segment, disp_clip). The iso-u and iso-v curves of
 * its bilinear patch are straight lines, and the inverse is smooth with a Jacobian that
 * never vanishes over a convex quad: where du/dt = 0 the foot runs along an iso-u line, a
 * straight line, so it stays on it and u is constant on the whole segment (a ray along
 * the normal, or one whose foot lies on an iso line); else du/dt keeps its sign; v
 * likewise. (The Jacobian [e0 + v g, e1 + u g] is affine in (u, v), positive at the
 * corners of a convex quad, so positive over it.)
 * (tests/kernels/test_displace_trapezoid.py checks this in float64 along rays at 0 to 90
 * degrees from the normal.) X, Y come from disp_inverse_bilinear, exactly the search's (u, v).
 *
 * An interval [ta, tb] of a piece then has its ray inside the rectangle spanned by its
 * ends' (X, Y) (widened by 2^-16 of the texture's size, a rounding bound) at heights
 * between its ends' h (widened by delta). The height field over that rectangle is bounded
 * by the pyramid's cells at the finest level where it spans at most 2 x 2 of them; at
 * level 0 (at most 2 x 2 texel cells) by the bilinear patch of each cell at the corners of
 * the rectangle's part in it (a bilinear function has its extremes over an axis-aligned
 * rectangle at the corners), so the bound tightens as the interval shrinks. The interval
 * is skipped when the two ranges are disjoint (its side of the surface then known), else
 * halved. At level 0, f is evaluated at the interval's ends: ends on either side of the
 * surface, over at most TX_DISP_BISECT_LEAF texel in X and Y, are taken to bracket one
 * root (f there is close to the quadratic of a quad's texel cell, which has at most two
 * roots: one sign change means one), polished by Illinois' regula falsi
 * (TX_DISP_BISECT_POLISH steps, then a secant step). An interval over at most
 * TX_DISP_BISECT_FINE texel in X and Y with no sign change at its ends is not halved
 * further: it holds no hit. This is where the traversal is not exact: the bound test alone
 * would need ever shorter intervals for a ray skimming just above the surface, so a ray
 * that dips below the surface and out again within 1/64 texel of (u, v) is missed (a
 * near-tangent ray; the search misses it too, between its samples); every root with a
 * sign change between such intervals is found, whatever the spike's width. Intervals are
 * also not halved below TX_DISP_BISECT_DEPTH levels or where the midpoint no longer splits
 * them in float32 (their ends' signs decide). A side of the surface that changes from one
 * interval (or piece) to the next, with no root between (a map that does not wrap across
 * the seam), is a crossing at their shared end, as the search sees it. Every loop is
 * bounded: pieces <= 5, bisection steps <= a cap from the texture's size (reached: a miss),
 * polish steps <= TX_DISP_BISECT_POLISH. */
#define TX_DISP_BISECT_DEPTH 24       /* dyadic levels of a piece: indices k < 2^24 are exact floats */
#define TX_DISP_BISECT_POLISH 16      /* regula falsi (Illinois) steps in a final bracket */
#define TX_DISP_BISECT_LEAF 0.25f     /* a bracket this small in X and Y (texels) holds one root */
#define TX_DISP_BISECT_FINE 0.015625f /* an interval this small in X and Y (1/64 texel) is not halved further */

typedef struct {
    float px, py;       /* the piece's reference direction: its midpoint's (x, y) about the axis */
    float xm, kx;       /* X at the reference direction; dX / d(azimuth) (0 on the axis); trapezoid: X = xm + kx u */
    float ky, kz;       /* sphere: dY / d(polar angle); cylinder: Y = ky + kz z; trapezoid: Y = ky + kz v */
} DispPiece;

/* (X, Y, h) of the ray's point t on a piece. */
inline float3 disp_piece_xyh(const DispFrame* f, const DispPiece* pc, float t)
{
    float3 q = f->q0 + t * f->dir;
    if (TX_DISP_MAXMIP_TRAPEZOID && f->shape == DISP_TRAPEZOID) {
        float3 l = disp_local(f, q);
        return (float3)(pc->xm + pc->kx * l.x, pc->ky + pc->kz * l.y, l.z);
    }
    float x = dot3(q, f->e0), y = dot3(q, f->e1), z = dot3(q, f->n);
    float rho = tx_hypot(x, y);
    float X = pc->xm + pc->kx * tx_atan2(pc->px * y - pc->py * x, pc->px * x + pc->py * y);
    if (f->shape == DISP_SPHERE) return (float3)(X, tx_atan2(rho, z) * pc->ky + 0.5f, tx_hypot(rho, z) - f->radius);
    return (float3)(X, pc->ky + pc->kz * z, rho - f->radius);
}

/* H at (X, Y) (disp_height's interpolant, from X, Y directly). */
static inline float disp_height_xy(__global const ushort* hts, const DispFrame* f, float X, float Y)
{
    int cx = disp_cell_index(X, f->w + 1), cy = disp_cell_index(Y, f->h + 1);
    float4 c = disp_cell_corners(hts, f, cx, cy);
    return disp_bilerp(c, clamp(X - (float)cx, 0.0f, 1.0f), clamp(Y - (float)cy, 0.0f, 1.0f));
}

/* The primitive's (u, v) of cell coordinates (X, Y), clamped to [0, 1]. */
static inline float2 disp_xy_uv(const DispFrame* f, float3 e)
{
    return clamp((float2)((e.x - 0.5f) / (float)f->w, 1.0f - (e.y - 0.5f) / (float)f->h), 0.0f, 1.0f);
}

/* Adds the cut t to s[*n] when it lies strictly inside (A, B). */
static inline void disp_cut(float t, float A, float B, float* s, int* n)
{
    if (t > A && t < B) s[(*n)++] = t;
}

/* The meridian half-plane through direction (c, s) about the axis: the t where the ray
 * crosses it, NaN where it does not (parallel, or crossing the opposite half-plane). */
static inline float disp_meridian(float c, float s, float x0, float y0, float dx, float dy)
{
    float t = (s * x0 - c * y0) / (c * dy - s * dx);
    return c * (x0 + t * dx) + s * (y0 + t * dy) > 0.0f ? t : NAN;
}

/* A root found at t, the side of the surface after it `below`: a hit (return 1) unless
 * an any-hit ray that started inside leaves the surface it starts on (header comment). */
static inline int disp_bisect_counts(int any, int from_outside, int below)
{
    return !any || below || from_outside;
}

/* The cuts of [A, B] into pieces (the comment above TX_DISP_BISECT_DEPTH), sorted into s;
 * their count (<= 4; none for a trapezoid). */
inline int disp_bisect_cuts(const DispFrame* f, float A, float B, float* s)
{
    int ns = 0;
    if (TX_DISP_MAXMIP_TRAPEZOID && f->shape == DISP_TRAPEZOID) return 0;
    int sphere = f->shape == DISP_SPHERE;
    float span = sphere ? 2.0f * M_PI_F : f->span;
    float x0 = dot3(f->q0, f->e0), y0 = dot3(f->q0, f->e1), z0 = dot3(f->q0, f->n);
    float dx = dot3(f->dir, f->e0), dy = dot3(f->dir, f->e1), dz = dot3(f->dir, f->n);
    float dd = dx * dx + dy * dy;
    disp_cut(-(x0 * dx + y0 * dy) / dd, A, B, s, &ns);                 /* closest to the axis */
    if (sphere) {
        float aa = dot3(f->dir, f->dir), qd = dot3(f->q0, f->dir);
        disp_cut(-qd / aa, A, B, s, &ns);                               /* closest to the centre */
        disp_cut(-(dz * dot3(f->q0, f->q0) - z0 * qd) / (dz * qd - z0 * aa), A, B, s, &ns);   /* polar extremum */
        disp_cut(disp_meridian(1.0f, 0.0f, x0, y0, dx, dy), A, B, s, &ns);                   /* the seam */
    } else {
        disp_cut(disp_meridian(cos(f->th0), sin(f->th0), x0, y0, dx, dy), A, B, s, &ns);
        if (span < 2.0f * M_PI_F)
            disp_cut(disp_meridian(cos(f->th0 + span), sin(f->th0 + span), x0, y0, dx, dy), A, B, s, &ns);
    }
    for (int i = 1; i < ns; ++i)
        for (int j = i; j > 0 && s[j - 1] > s[j]; --j) { float a = s[j]; s[j] = s[j - 1]; s[j - 1] = a; }
    return ns;
}

/* The piece [P0, P1]'s map from the ray to (X, Y, h) (DispPiece); 0 where the piece has no
 * surface (a partial cylinder's gap). */
static inline int disp_bisect_piece(const DispFrame* f, float P0, float P1, DispPiece* pc)
{
    float W = (float)f->w, Hf = (float)f->h;
    if (TX_DISP_MAXMIP_TRAPEZOID && f->shape == DISP_TRAPEZOID) {   /* X = u W + 1/2, Y = (1 - v) H + 1/2 */
        pc->px = pc->py = 0.0f;
        pc->xm = 0.5f; pc->kx = W;
        pc->ky = Hf + 0.5f; pc->kz = -Hf;
        return 1;
    }
    int sphere = f->shape == DISP_SPHERE;
    float span = sphere ? 2.0f * M_PI_F : f->span;
    float tm = 0.5f * (P0 + P1);
    float3 qm = f->q0 + tm * f->dir;
    pc->px = dot3(qm, f->e0); pc->py = dot3(qm, f->e1);
    float um;
    if (sphere) {
        um = azimuth_u(pc->px, pc->py);
        pc->ky = Hf * M_1_PI_F; pc->kz = 0.0f;
    } else {
        um = cylinder_theta_rel(pc->px, pc->py, f->th0) / span;
        pc->kz = -Hf / (f->z1 - f->z0); pc->ky = 0.5f - f->z1 * pc->kz;    /* (1 - v) H + 1/2 */
    }
    if (!(um <= 1.0f)) return 0;
    pc->xm = um * W + 0.5f;
    pc->kx = pc->px != 0.0f || pc->py != 0.0f ? W / span : 0.0f;
    return 1;
}

/* Whether this program takes maxmip on the shape by disp_maxmip_bisect (spheres and
 * cylinders: TX_DISP_MAXMIP_CURVED; trapezoids: TX_DISP_MAXMIP_TRAPEZOID). */
static inline int disp_bisected(uint shape)
{
    if (TX_DISP_MAXMIP_TRAPEZOID && shape == DISP_TRAPEZOID) return 1;
    return TX_DISP_MAXMIP_CURVED && (shape == DISP_SPHERE || shape == DISP_CYLINDER);
}

inline int disp_maxmip_bisect(__global const ushort* hts, __global const Displaced* d, const DispFrame* f,
                              float A, float B, int any, int from_outside, float* t_hit, float2* uv_hit)
{
    uint off[TX_DISP_MAX_LEVELS];
    int cw[TX_DISP_MAX_LEVELS], ch[TX_DISP_MAX_LEVELS];
    int levels = disp_pyramid(d, f, off, cw, ch);
    if (!levels) return 0;
    float W = (float)f->w, Hf = (float)f->h;
    float s[6];
    int ns = disp_bisect_cuts(f, A, B, s);
    s[ns] = B;

    float epsx = 1.52587890625e-05f * (W + 2.0f), epsy = 1.52587890625e-05f * (Hf + 2.0f);   /* 2^-16 (size + 2) */
    int side = -1;                                       /* below the surface (1), above (0), not yet known (-1) */
    int budget = (TX_MIN(f->w, 1 << 20) + TX_MIN(f->h, 1 << 20) + 4) * (2 * levels + 2 * TX_DISP_BISECT_DEPTH) + 256;
    float P0 = A;
    for (int p = 0; p <= ns; P0 = s[p], ++p) {
        float P1 = s[p];
        if (!(P1 > P0)) continue;
        DispPiece pc;
        if (!disp_bisect_piece(f, P0, P1, &pc)) continue;

        /* Dyadic traversal of [P0, P1]: interval k of 2^dep, its left end ta / ea carried. */
        float len = P1 - P0, scale = 1.0f;
        int dep = 0;
        uint k = 0u;
        float ta = P0;
        float3 ea = disp_piece_xyh(f, &pc, P0);
        float fa = 0.0f, fb = 0.0f;
        int fa_ok = 0, fb_ok = 0;
        for (;;) {
            if (--budget < 0) return 0;
            float tb = k + 1u == (1u << dep) ? P1 : P0 + len * ((float)(k + 1u) * scale);
            float3 eb = disp_piece_xyh(f, &pc, tb);
            float xlo = TX_MIN(ea.x, eb.x) - epsx, xhi = TX_MAX(ea.x, eb.x) + epsx;
            float ylo = TX_MIN(ea.y, eb.y) - epsy, yhi = TX_MAX(ea.y, eb.y) + epsy;
            float hlo = TX_MIN(ea.z, eb.z) - f->delta, hhi = TX_MAX(ea.z, eb.z) + f->delta;
            int L;
            float2 Hb = disp_rect_bound(hts, f, off, cw, ch[0], levels, xlo, xhi, ylo, yhi, &L);
            float Hlo = Hb.x, Hhi = Hb.y;
            int next = 1;                                /* go on to the next interval (else: halve this one) */
            if (hlo > Hhi || hhi < Hlo) {                /* no root: the interval's side is known */
                int below = hhi < Hlo;
                if (side >= 0 && below != side && disp_bisect_counts(any, from_outside, below)) {
                    *t_hit = ta; *uv_hit = disp_xy_uv(f, ea);
                    return 1;
                }
                side = below;
            } else {
                float tmid = P0 + len * ((float)(2u * k + 1u) * (0.5f * scale));
                int split = dep < TX_DISP_BISECT_DEPTH && tmid > ta && tmid < tb;
                if (L == 0 || !split) {
                    /* f at the ends (at ta: carried from the interval before, or its parent) */
                    if (!fa_ok) fa = ea.z - disp_height_xy(hts, f, ea.x, ea.y);
                    fb = eb.z - disp_height_xy(hts, f, eb.x, eb.y);
                    fa_ok = fb_ok = 1;
                    int ba = fa < 0.0f, bb = fb < 0.0f;
                    if (side >= 0 && ba != side && disp_bisect_counts(any, from_outside, ba)) {
                        *t_hit = ta; *uv_hit = disp_xy_uv(f, ea);
                        return 1;
                    }
                    side = ba;
                    float ex = fabs(eb.x - ea.x), ey = fabs(eb.y - ea.y);
                    if (bb != side && (!split || (ex <= TX_DISP_BISECT_LEAF && ey <= TX_DISP_BISECT_LEAF))) {
                        /* A bracket: Illinois' regula falsi, then a secant step. */
                        float lo = ta, hi = tb, flo = fa, fhi = fb;
                        int last = 0;
                        for (int i = 0; i < TX_DISP_BISECT_POLISH && flo != fhi; ++i) {
                            float m = lo + (hi - lo) * (flo / (flo - fhi));
                            if (!(m > lo && m < hi)) m = 0.5f * (lo + hi);
                            if (!(m > lo && m < hi)) break;
                            float3 em = disp_piece_xyh(f, &pc, m);
                            float fm = em.z - disp_height_xy(hts, f, em.x, em.y);
                            if ((fm < 0.0f) == side) {
                                lo = m; flo = fm;
                                if (last == 1) fhi *= 0.5f;
                                last = 1;
                            } else {
                                hi = m; fhi = fm;
                                if (last == 2) flo *= 0.5f;
                                last = 2;
                            }
                        }
                        float th = flo != fhi ? clamp(lo + (hi - lo) * (flo / (flo - fhi)), lo, hi) : hi;
                        if (disp_bisect_counts(any, from_outside, bb)) {
                            *t_hit = th; *uv_hit = disp_xy_uv(f, disp_piece_xyh(f, &pc, th));
                            return 1;
                        }
                        side = bb;                       /* left the surface it starts on */
                    } else if (split && (bb != side || ex > TX_DISP_BISECT_FINE || ey > TX_DISP_BISECT_FINE)) {
                        next = 0;
                    }
                } else {
                    next = 0;
                }
            }
            if (next) {
                ta = tb; ea = eb; fa = fb; fa_ok = fb_ok;
                while (dep > 0 && (k & 1u)) { k >>= 1; --dep; scale *= 2.0f; }
                if (dep == 0) break;
                ++k;
            } else {
                ++dep; k <<= 1; scale *= 0.5f;
            }
            fb_ok = 0;
        }
    }
    return 0;
}
#endif

#if TX_DISP_MESH && TX_DISP_MAXMIP_MESH
/* Maxmip on a mesh triangle's shell (TX_DISP_MAXMIP_MESH; header comment), in the spirit of
 * Thonat et al. 2021, "Tessellation-free displacement mapping for ray tracing": along a ray
 * (b1, b2, h) are not monotone in t (the shell's map P(b) + h N(b) is not affine where the
 * vertex normals differ), so neither disp_maxmip's cell walk nor the bisection's end-point
 * bounds apply. Instead the triangle's barycentric domain is subdivided, 4 to 1 (corners
 * and edge midpoints; a sub-triangle (o, k) has corners o, o + (1/k, 0), o + (0, 1/k), the
 * middle one k < 0, all dyadic: exact), and each sub-triangle's prism
 * {P(b) + h N(b): b in it, h in [lo, hi]} holds the surface over it when [lo, hi] bounds H
 * over its uv footprint: the rectangle of its corners' uv (affine in b), widened by the
 * host's band (texray.compile.shells.BAND) and a rounding bound, read by disp_rect_bound
 * (the pyramid, or at level 0 the bilinear patches), intersected with its parent's bound
 * (a rectangle that leaves [0, 1]^2 after the wrap, a mirror period or one across a repeat
 * seam, keeps the parent's). A sub-prism lies in the convex hull of its six corners
 * P_i + lo N_i, P_i + hi N_i (P + h N is a convex combination of them), so a ray that misses
 * the hull's slabs along the face normal and the three in-plane normals of the edges
 * (DispKdop: every sub-triangle's edges are parallel to the triangle's, so the directions
 * and the ray's projections are set up once per ray; the slabs widened by delta) cannot
 * meet the surface over it: conservative, a spike is never skipped. Nodes are visited
 * front to back (children sorted by their slab entry, a stack of at most
 * TX_DISP_MESH_STACK entries, depth at most TX_DISP_MESH_DEPTH), skipping those entered
 * beyond the nearest hit found; a sub-triangle whose uv footprint spans at most
 * TX_DISP_MESH_LEAF texel (the footprint scales with 1/|k|) is a leaf: its prism is clipped
 * exactly (disp_tri_clip on its corners and [lo, hi]: its ends lie on the prism's faces up
 * to rounding, within the band of the triangle's edges, where f is evaluated), on the
 * ray's (tmin, tmax), not the shell's (A, B): a leaf's top or bottom can lie within
 * rounding of the shell's (a flat-topped map: slo = shi), and its crossings at A or B
 * would fall outside the open interval (tests/render/test_mesh_maxmip.py, the torus).
 * The search (disp_search) runs on that segment with TX_DISP_MESH_STEPS steps and
 * TX_DISP_MESH_REFINE bisections, then its secant step (4 steps and 4 bisections: t
 * within 5e-7 of the quad's exact maxmip on 99% of the rays; the leaves' share of the
 * frame is small, mesh_terrain.toml measured 2% faster at 1 step, 10 bisections cost
 * 5% more). Nearest hit: the least over the leaves; any hit: the first that counts (the
 * shell's from_outside, as the search).
 *
 * What is exact and what is not: no part of the ray where the surface can be is skipped
 * (the slabs and the exact clip are conservative up to the delta widening; a root where
 * the ray crosses from one leaf to another is in both leaves' segments but, within
 * rounding of their common face, may be seen by neither: the search's shells have the
 * same limit). Within a leaf (at most TX_DISP_MESH_LEAF texel wide, so f is close to the
 * quadratic of a texel cell: at most two roots per cell it crosses) a root is found when f
 * changes sign between two of the search's samples: a ray that dips below the surface and
 * out again between two samples, 1/TX_DISP_MESH_STEPS of a leaf apart, is missed (a
 * near-tangent ray; disp_maxmip_bisect's 1/64 texel). A leaf that holds two roots reports the
 * first after the first sample's side (as the search). Measured against the float64 root
 * and the quad's maxmip: tests/render/test_mesh_maxmip.py. Every loop is bounded: nodes at most
 * TX_DISP_MESH_NODES per shell (reached: the nearest hit found so far, or a miss), the
 * search's samples and bisections. NaN input: every slab test fails (a miss). */
#define TX_DISP_MESH_DEPTH 16                          /* subdivision levels below the triangle */
#define TX_DISP_MESH_STACK (3 * TX_DISP_MESH_DEPTH + 1) /* 3 siblings waiting per level, 4 at the last */
#define TX_DISP_MESH_LEAF 0.5f                         /* a leaf's uv footprint in texels (X and Y) */
#define TX_DISP_MESH_STEPS 4u                          /* the search's steps in a leaf's segment */
#define TX_DISP_MESH_REFINE 4u                         /* and its bisections */
#define TX_DISP_MESH_NODES 4096                        /* nodes visited per shell */

/* A sub-triangle (o, k) (corners o, o + (1/k, 0), o + (0, 1/k); |k| = 2^depth, k < 0 the
 * flipped middle children) with its h bound [lo, hi] and the ray's entry t into its hull. */
typedef struct {
    float2 o;
    float k, lo, hi, t;
} DispSubTri;

/* The four slab directions of the sub-prisms' hulls (the face normal E1 x E2 and its
 * cross products with the edges E1, E2, E2 - E1, unnormalized; lanes x, y, z, w): the
 * projections of E1, E2, N0, dN1, dN2 and of the ray's origin, the reciprocals of the
 * direction's, and each slab's widening delta |d|. */
typedef struct {
    float4 pe0, pe1, pn, pn1, pn2, ro, ird, w;
} DispKdop;

inline DispKdop disp_kdop(const DispFrame* f)
{
    float3 d[4] = { f->c0, cross3(f->c0, f->e0), cross3(f->c0, f->e1), cross3(f->c0, f->e1 - f->e0) };
    float x[8][4];
    for (int i = 0; i < 4; ++i) {
        x[0][i] = dot3(f->e0, d[i]); x[1][i] = dot3(f->e1, d[i]);
        x[2][i] = dot3(f->n, d[i]); x[3][i] = dot3(f->dn1, d[i]); x[4][i] = dot3(f->dn2, d[i]);
        x[5][i] = dot3(f->q0, d[i]); x[6][i] = 1.0f / dot3(f->dir, d[i]);
        x[7][i] = f->delta * sqrt(dot3(d[i], d[i]));
    }
    DispKdop K;
    K.pe0 = vload4(0, x[0]); K.pe1 = vload4(0, x[1]); K.pn = vload4(0, x[2]); K.pn1 = vload4(0, x[3]);
    K.pn2 = vload4(0, x[4]); K.ro = vload4(0, x[5]); K.ird = vload4(0, x[6]); K.w = vload4(0, x[7]);
    return K;
}

/* [*tn, *tf] clipped to the slabs [mn, mx] (widened by K->w) of K's directions; 0 if
 * empty. Distances by the reciprocal: a direction with a zero projection gives infinite
 * ones, so its slab bounds nothing while the origin lies strictly inside it and empties
 * the interval otherwise; an origin exactly on such a slab's plane gives NaN (0 inf),
 * which empties it too (a miss), as does any NaN input. */
static inline int disp_kdop_clip(const DispKdop* K, float4 mn, float4 mx, float* tn, float* tf)
{
    float4 t0 = (mn - K->w - K->ro) * K->ird, t1 = (mx + K->w - K->ro) * K->ird;
    float4 a = TX_MIN(t0, t1), b = TX_MAX(t0, t1);
    *tn = TX_MAX(TX_MAX(*tn, TX_MAX(a.x, a.y)), TX_MAX(a.z, a.w));
    *tf = TX_MIN(TX_MIN(*tf, TX_MIN(b.x, b.y)), TX_MIN(b.z, b.w));
    return *tn <= *tf;
}

/* Tightens s's [lo, hi] (its parent's) to the height field's bound over its uv footprint
 * (disp_maxmip_mesh's comment); spread: the band's widening in uv. */
inline void disp_sub_bound(__global const ushort* hts, const DispFrame* f, const uint* off, const int* cw, int ch0,
                           int levels, float2 spread, DispSubTri* s)
{
    float inv = 1.0f / s->k;
    float2 u0 = disp_tri_uv(f, s->o), u1 = u0 + inv * f->t1, u2 = u0 + inv * f->t2;
    float2 lo = TX_MIN(u0, TX_MIN(u1, u2)) - spread, hi = TX_MAX(u0, TX_MAX(u1, u2)) + spread;
    if (f->mode == TX_WRAP_REPEAT) {
        float2 p = (float2)(floor(lo.x), floor(lo.y));
        lo -= p; hi -= p;
    } else if (f->mode == TX_WRAP_CLAMP) {
        lo = clamp(lo, 0.0f, 1.0f); hi = clamp(hi, 0.0f, 1.0f);
    }
    if (!(lo.x >= 0.0f && lo.y >= 0.0f && hi.x <= 1.0f && hi.y <= 1.0f)) return;
    float W = (float)f->w, Hf = (float)f->h;
    float epsx = 1.52587890625e-05f * (W + 2.0f), epsy = 1.52587890625e-05f * (Hf + 2.0f);   /* as the bisection's */
    int L;
    float2 b = disp_rect_bound(hts, f, off, cw, ch0, levels, lo.x * W + 0.5f - epsx, hi.x * W + 0.5f + epsx,
                               (1.0f - hi.y) * Hf + 0.5f - epsy, (1.0f - lo.y) * Hf + 0.5f + epsy, &L);
    s->lo = TX_MAX(s->lo, b.x); s->hi = TX_MIN(s->hi, b.y);
}

/* Positions (relative to P0) and normals of the sub-triangle s's corners. */
static inline void disp_sub_corners(const DispFrame* f, const DispSubTri* s, float3* c, float3* nv)
{
    float inv = 1.0f / s->k;
    float2 b[3] = { s->o, s->o + (float2)(inv, 0.0f), s->o + (float2)(0.0f, inv) };
    for (int j = 0; j < 3; ++j) {
        c[j] = b[j].x * f->e0 + b[j].y * f->e1;
        nv[j] = f->n + b[j].x * f->dn1 + b[j].y * f->dn2;
    }
}

inline int disp_maxmip_mesh(__global const ushort* hts, __global const Displaced* d, const DispFrame* f, float tmin,
                            float tmax, float A, float B, int any, int from_outside, float* t_hit, float2* uv_hit)
{
    uint off[TX_DISP_MAX_LEVELS];
    int cw[TX_DISP_MAX_LEVELS], ch[TX_DISP_MAX_LEVELS];
    int levels = disp_pyramid(d, f, off, cw, ch);
    if (!levels) return 0;
    DispKdop K = disp_kdop(f);
    float2 spread = TX_DISP_TRI_BAND * (fabs(f->t1) + fabs(f->t2));
    /* the triangle's uv footprint in texels; a sub-triangle's is this over |k| */
    float2 ext = TX_MAX(fabs(f->t1), TX_MAX(fabs(f->t2), fabs(f->t2 - f->t1)));
    float span = TX_MAX(ext.x * (float)f->w, ext.y * (float)f->h);
    DispSubTri stack[TX_DISP_MESH_STACK];
    stack[0].o = (float2)(0.0f); stack[0].k = 1.0f;
    stack[0].lo = f->slo; stack[0].hi = f->shi; stack[0].t = A;
    int sp = 1, found = 0;
    float best = B;
    float2 best_uv = (float2)(0.0f);
    for (int it = 0; it < TX_DISP_MESH_NODES && sp > 0; ++it) {
        DispSubTri s = stack[--sp];
        if (!(s.t <= best)) continue;                     /* entered beyond the nearest hit */
        float size = fabs(s.k);
        if (span <= TX_DISP_MESH_LEAF * size || size >= (float)(1 << TX_DISP_MESH_DEPTH)) {
            float a = A, b = B, th;
            float2 uvh;
            if (s.k != 1.0f) {                            /* the root's segment is [A, B] already */
                float3 c[3], nv[3];
                int outside;
                disp_sub_corners(f, &s, c, nv);
                if (!disp_tri_clip(d, f, c, nv, s.o, s.k, s.lo, s.hi, tmin, tmax, &a, &b, &outside)) continue;
            }
            if (disp_search(hts, f, a, b, TX_DISP_MESH_STEPS, TX_DISP_MESH_REFINE, any, from_outside, &th, &uvh)
                && th <= best) {
                if (any) { *t_hit = th; *uv_hit = uvh; return 1; }
                best = th; best_uv = uvh; found = 1;
            }
            continue;
        }
        /* The four children, nearest entry last on the stack: their corners are the node's
         * and its edges' midpoints (pb; child j's are pb[tri[j][.]]), projected once. Each
         * child is first clipped to its hull under the node's [lo, hi] (a wider hull: a
         * child the ray passes by costs no bound), then to the face normal's slab under
         * its own. */
        float inv = 1.0f / s.k, mid = 0.5f * inv;
        float2 pb[6] = { s.o, s.o + (float2)(inv, 0.0f), s.o + (float2)(0.0f, inv), s.o + (float2)(mid, 0.0f),
                         s.o + (float2)(0.0f, mid), s.o + (float2)(mid, mid) };
        float4 P[6], N[6], plo[6], phi[6];
        for (int i = 0; i < 6; ++i) {
            P[i] = pb[i].x * K.pe0 + pb[i].y * K.pe1;
            N[i] = K.pn + pb[i].x * K.pn1 + pb[i].y * K.pn2;
            float4 a = P[i] + s.lo * N[i], c = P[i] + s.hi * N[i];
            plo[i] = TX_MIN(a, c); phi[i] = TX_MAX(a, c);
        }
        const int tri[4][3] = { { 0, 3, 4 }, { 3, 1, 5 }, { 4, 5, 2 }, { 5, 4, 3 } };
        DispSubTri kid[4];
        int n = 0;
        for (int j = 0; j < 4; ++j) {
            int i0 = tri[j][0], i1 = tri[j][1], i2 = tri[j][2];
            float tn = A, tf = best;
            if (!disp_kdop_clip(&K, TX_MIN(plo[i0], TX_MIN(plo[i1], plo[i2])), TX_MAX(phi[i0], TX_MAX(phi[i1], phi[i2])),
                                &tn, &tf))
                continue;
            DispSubTri q;
            q.o = pb[i0];
            q.k = j == 3 ? -2.0f * s.k : 2.0f * s.k;
            q.lo = s.lo; q.hi = s.hi;
            disp_sub_bound(hts, f, off, cw, ch[0], levels, spread, &q);
            float4 mn = (float4)(INFINITY), mx = (float4)(-INFINITY);
            for (int m = 0; m < 3; ++m) {
                int i = tri[j][m];
                float a = P[i].x + q.lo * N[i].x, c = P[i].x + q.hi * N[i].x;
                mn.x = TX_MIN(mn.x, TX_MIN(a, c)); mx.x = TX_MAX(mx.x, TX_MAX(a, c));
            }
            mn.yzw = (float3)(-INFINITY); mx.yzw = (float3)(INFINITY);
            if (!disp_kdop_clip(&K, mn, mx, &tn, &tf)) continue;
            q.t = tn;
            int m = n++;
            for (; m > 0 && kid[m - 1].t < tn; --m) kid[m] = kid[m - 1];
            kid[m] = q;
        }
        for (int j = 0; j < n && sp < TX_DISP_MESH_STACK; ++j) stack[sp++] = kid[j];
    }
    if (found) { *t_hit = best; *uv_hit = best_uv; }
    return found;
}
#endif

/* Nearest (any = 0) or any (any = 1) hit of the displaced surface with t in (tmin,
 * tmax); *uv = the primitive's (u, v) at the hit. NaN input and degenerate frames
 * give a miss (every range test is false for NaN). */
inline int displaced_intersect(__global const Displaced* d, __global const ushort* hts, float3 org, float3 dir,
                               float tmin, float tmax, int any, float* t, float2* uv)
{
    DispFrame f = disp_frame(d, org, dir);
    float A, B;
    int from_outside, boxed = 0;
#if TX_DISP_MESH
    if (f.shape == DISP_TRIANGLE) {
        float3 c[3] = { (float3)(0.0f), f.e0, f.e1 };
        float3 nv[3] = { f.n, f.n + f.dn1, f.n + f.dn2 };
        int clip = disp_tri_clip(d, &f, c, nv, (float2)(0.0f), 1.0f, f.slo, f.shi, tmin, tmax, &A, &B, &from_outside);
        if (!clip) return 0;
        boxed = clip == 2;
    } else
#endif
    {
        if (!disp_clip(&f, tmin, tmax, &A, &B)) return 0;
        from_outside = A > tmin;
    }
    uint method = d->method;
    int hit;
    if ((method & 3u) == DISP_MAXMIP && f.shape == DISP_QUAD) {
        hit = disp_maxmip(hts, d, &f, A, B, any, from_outside, t, uv);
    }
#if TX_DISP_MESH && TX_DISP_MAXMIP_MESH
    else if ((method & 3u) == DISP_MAXMIP && f.shape == DISP_TRIANGLE) {
        hit = disp_maxmip_mesh(hts, d, &f, tmin, tmax, A, B, any, from_outside, t, uv);
    }
#endif
#if TX_DISP_MAXMIP_CURVED || TX_DISP_MAXMIP_TRAPEZOID
    else if ((method & 3u) == DISP_MAXMIP && disp_bisected(f.shape)) {
        hit = disp_maxmip_bisect(hts, d, &f, A, B, any, from_outside, t, uv);
    }
#endif
    else {
        uint steps = clamp(d->steps, 1u, TX_DISP_MAX_STEPS);
        if (method & DISP_ADAPTIVE) {
            float3 qa = f.q0 + A * dir;
            float3 nrm = f.shape == DISP_QUAD || f.shape == DISP_TRAPEZOID ? f.n
                       : (f.shape == DISP_SPHERE ? qa : qa - dot3(qa, f.n) * f.n);
#if TX_DISP_MESH
            if (f.shape == DISP_TRIANGLE) nrm = f.c0;
#endif
            float cosv = fabs(dot3(nrm, dir)) * rsqrt(dot3(nrm, nrm) * dot3(dir, dir));
            steps = (uint)ceil((float)steps / TX_MAX(cosv, 0.125f));   /* NaN cos -> 8 N */
        }
#if TX_DISP_MESH
        if (f.shape == DISP_TRIANGLE && !boxed) steps = disp_tri_steps(&f, dir, A, B, steps);
#endif
        hit = disp_search(hts, &f, A, B, steps, TX_MIN(d->refine, TX_DISP_MAX_REFINE), any, from_outside, t, uv);
    }
    return hit && *t > tmin && *t < tmax;
}

/* Geometry of a hit at t with the primitive's (u, v) = param (from
 * displaced_intersect): the point on the ray; the base surface's tangents dP/du, dP/dv
 * scaled to the displaced radius (S = c + (r + H) n for spheres: S_u = (r + H) n_u +
 * H_u n, the bump formula's P_u, P_v without its "B small" approximation); the normal:
 * the base surface's outward normal n turned by the height field's gradient (dH/du,
 * dH/dv) with core/frame.h bump_normal, the bump formula. uv: texture coordinates
 * (quads: those of the plain quad at param, with dP/du, dP/dv taken to them, quad.h
 * quad_texcoords; spheres and cylinders: their uv = param). */
inline void displaced_geom(__global const Displaced* d, __global const ushort* hts, float3 org, float3 dir,
                           float t, float2 param, Geom* g)
{
    DispFrame f = disp_frame(d, org, dir);
    float2 grad;
#if TX_DISP_MESH
    if (f.shape == DISP_TRIANGLE) {
        /* param: the barycentrics. The height field's gradient taken to them (dH/db_k =
         * grad . dt/db_k) turns the interpolated normal N(b) with the surface's tangents
         * at the displaced height, dP/db_k + H dN/db_k (the spheres' "tangents at the
         * displaced radius"); texture coordinates and the tangents with respect to them
         * as for a plain triangle, J = [t1 t2]. */
        float2 tex = disp_tri_uv(&f, param);
        float Ht = disp_height(hts, &f, tex, &grad);
        float3 pu = f.e0 + Ht * f.dn1, pv = f.e1 + Ht * f.dn2;
        float3 nb = tx_unit_or(f.n + param.x * f.dn1 + param.y * f.dn2, tx_unit_or(f.c0, f.n));
        g->p = org + t * dir;
        g->perr = gamma_n(16.0f) * (abs3(org) + abs3(t * dir) + (float3)(f.delta));
        g->ng = bump_normal(nb, pu, pv, (float2)(dot(grad, f.t1), dot(grad, f.t2)));
        g->uv = tex;
        if (!reparam_tangents(f.t1, f.t2, pu, pv, &g->dpdu, &g->dpdv)) {
            g->dpdu = pu;
            g->dpdv = pv;
        }
        return;
    }
#endif
    float H = disp_height(hts, &f, clamp(param, 0.0f, 1.0f), &grad);
    float3 p = org + t * dir;
    g->p = p;
    g->perr = gamma_n(16.0f) * (abs3(org) + abs3(t * dir) + (float3)(f.delta));
    if (f.shape == DISP_QUAD) {
        /* The height field's gradient is with respect to the patch's own (u, v), and so must
         * be the tangents it turns the normal with; texture coordinates and the tangents
         * with respect to them then come from the plain quad's parameterization. */
        g->ng = bump_normal(f.n, f.e0, f.e1, grad);
        quad_texcoords(d->uv, param, f.e0, f.e1, g);
        return;
    }
    if (f.shape == DISP_TRAPEZOID) {                   /* the same with the patch's tangents at param */
        float2 pc = clamp(param, 0.0f, 1.0f);
        float3 pu = f.e0 + pc.y * f.g, pv = f.e1 + pc.x * f.g;
        g->ng = bump_normal(f.n, pu, pv, grad);
        quad_texcoords(d->uv, param, pu, pv, g);
        return;
    }
    /* The base shape's tangents at the displaced radius R, through the point's direction
     * from the centre (axis): the base parameterization of sphere.h or cylinder.h. */
    float R = f.radius + H;
    float3 q = p - vload3(0, d->p);
    g->uv = param;
    if (f.shape == DISP_SPHERE) {
        g->ng = tx_unit_or(q, f.n);
        float3 pc = R * g->ng;
        float x = dot3(pc, f.e0), y = dot3(pc, f.e1), z = dot3(pc, f.n);
        sphere_tangents(x, y, z, tx_hypot(x, y), R, f.e0, f.e1, f.n, &g->dpdu, &g->dpdv);
    } else {
        float x = dot3(q, f.e0), y = dot3(q, f.e1);
        float rho = tx_hypot(x, y);
        g->ng = rho > 0.0f ? (x * f.e0 + y * f.e1) / rho : f.e0;
        cylinder_tangents(R * dot3(g->ng, f.e0), R * dot3(g->ng, f.e1), f.span, f.z1 - f.z0, f.e0, f.e1, f.n,
                          &g->dpdu, &g->dpdv);
    }
    g->ng = bump_normal(g->ng, g->dpdu, g->dpdv, grad);
}

#endif
