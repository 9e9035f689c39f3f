#line 2 "shading/bump.h"
/* Bump mapping (Blinn, "Simulation of Wrinkled Surfaces", SIGGRAPH 1978; the
 * lecture's "Bump mapping" slides) and normal maps: the material roles that
 * replace the shading normal.
 *
 * Direction. The height B(u, v) = height * H(u, v) (H: the texture's red
 * channel) raises the surface along its OUTWARD shading normal n (unit):
 * outward for spheres and cylinders, the vertex normals' side for meshes with
 * them, the vertex order's side otherwise (the quad's (P1-P0)x(P3-P0) side):
 *     P' = P + B n,   P'_u = P_u + B_u n,   P'_v = P_v + B_v n
 * (the lecture's approximation: the B n_u, B n_v terms are dropped, "B is very
 * small"). N' = P'_u x P'_v is then turned to n's side, whichever way P_u x P_v
 * points for the UV layout at hand (inward on a plane with u along +x and v
 * along +z seen from +y). With P_u, P_v first projected onto n's tangent plane
 * (a no-op except for interpolated vertex normals) and j = (P_u x P_v) . n,
 *     N' ~ n + (B_u (n x P_v) - B_v (n x P_u)) / j,
 * which is the lecture's N + (B_u (N x P_v) - B_v (N x P_u)) / |N| divided by
 * j (N = P_u x P_v = j n): the same direction, oriented to n. Heights are in
 * world units: scaling the uvs by k scales P_u, P_v by 1/k, B_u, B_v by 1/k and
 * j by 1/k^2, so the normal depends on the height field, not on its
 * parameterization.
 *
 * Sign. The lecture's slide ("Bump mapping", general case) prints
 *     B_u = (B(s - D, t) - B(s + D, t)) / 2D,
 * which is -dB/ds: with its own P' = P + B N/|N| that turns bumps into dents.
 * bump_gradient uses +dB/ds = (B(s + D) - B(s - D)) / 2D.
 *
 * Step D (Material.bump_delta, texray.Bump.delta): one texel of the level in
 * use (0), a step in texture coordinates (> 0), or the exact gradient of the
 * bilinear interpolant (< 0: one lookup of four texels instead of four
 * bilinear lookups; it is piecewise constant across texels, central
 * differences over one texel smooth it). */
#ifndef TEXRAY_BUMP_H
#define TEXRAY_BUMP_H
#include "core/frame.h"
#include "texture/bilinear.h"
#include "texture/texture.h"

/* Red channel of the texture at transformed coordinates t, through its filter. */
static inline float bump_value(__global const half* texels, __global const TextureInfo* ti, TexCoord t)
{
    return texture_sample(texels, ti, t).x;
}

/* (dH/ds, dH/dt) of the bilinear interpolant of level lv at st, exactly (the
 * taps and weights of texture_bilinear_level; x = s w - 1/2 grows with s,
 * y = (1 - t) h - 1/2 falls with t). Clamped edges give 0 across the edge, as
 * the interpolant does. */
inline float2 bump_gradient_bilinear(__global const half* texels, TexLevel lv, int mode, float2 st)
{
    BilinearTaps k = bilinear_taps(texels, lv, mode, st);
    float2 d = bilinear_gradient(k.t00.x, k.t10.x, k.t01.x, k.t11.x, k.ax, k.ay);
    return (float2)(d.x * (float)lv.w, -d.y * (float)lv.h);
}

/* (B_u, B_v) = height * gradient of H(T(u, v)) with respect to the surface's
 * (u, v) at tc (uv and its screen derivatives, which pick the MIP level of a
 * trilinear texture; zero derivatives: level 0). T is the texture's UV
 * transform (chain rule through its linear part); delta as Material.bump_delta
 * (0: one texel of the level in use, texture/texture.h texture_texel_size). Sign: +dB/du
 * (header comment). */
inline float2 bump_gradient(__global const half* texels, __global const TextureInfo* ti, TexCoord tc,
                            float height, float delta)
{
    float4 m0 = vload4(0, ti->m0);
    TexCoord t = texcoord_transform(tc, m0, vload2(0, ti->m1));
    /* Without a MIP filter in the program the derivatives are zero and every use of lod
     * below clamps it to level 0 (texture_clamp_lod): 0 without the log2 (2% of a bumped
     * brick wall's frame). */
    float lod = TX_FILTER_TRILINEAR || TX_FILTER_ANISOTROPIC ? texture_lod(ti, t.duv_dx, t.duv_dy) : 0.0f;
    float2 g;
    if (delta < 0.0f) {
        g = bump_gradient_bilinear(texels, texture_level(ti, (int)texture_clamp_lod(ti, lod)), (int)ti->wrap, t.uv);
    } else {
        float2 d = delta > 0.0f ? (float2)(delta, delta) : texture_texel_size(ti, lod);
        TexCoord a = t, b = t;
        a.uv.x += d.x;
        b.uv.x -= d.x;
        g.x = (bump_value(texels, ti, a) - bump_value(texels, ti, b)) / (2.0f * d.x);
        a.uv = b.uv = t.uv;
        a.uv.y += d.y;
        b.uv.y -= d.y;
        g.y = (bump_value(texels, ti, a) - bump_value(texels, ti, b)) / (2.0f * d.y);
    }
    /* s = m0.x u + m0.y v + ..., t = m0.z u + m0.w v + ... */
    return height * (float2)(g.x * m0.x + g.y * m0.z, g.x * m0.y + g.y * m0.w);
}

/* The normal a normal map's texel rgb encodes (2 rgb - 1), in world space, as a
 * unit vector; n itself where it encodes the zero vector.
 * Tangent space: T = P_u projected on n's plane, normalized; B = n x T, turned
 * to P_v's side (so mirrored UVs mirror the map); x along T, y along B (OpenGL,
 * "green up"; DirectX flips y), z along n. Object space (TX_NORMAL_OBJECT):
 * rgb is a normal in the object's coordinates, taken to world space by the
 * rows of normal_matrix (the inverse transpose of the object's transform). */
inline float3 normal_map_normal(float3 n, float3 dpdu, float3 dpdv, float3 rgb, uint mode,
                                float3 nm0, float3 nm1, float3 nm2)
{
    float3 c = 2.0f * rgb - 1.0f;
    if (mode & TX_NORMAL_DIRECTX) c.y = -c.y;
    float3 r;
    if (mode & TX_NORMAL_OBJECT) {
        r = (float3)(dot3(nm0, c), dot3(nm1, c), dot3(nm2, c));
    } else {
        float3 t = tx_unit_or(dpdu - dot3(dpdu, n) * n, any_tangent(n));
        float3 b = cross3(n, t);
        b = dot3(b, dpdv) < 0.0f ? -b : b;
        r = c.x * t + c.y * b + c.z * n;
    }
    return tx_unit_or(r, n);
}

/* Normal clamping: the unit vector a, turned within the plane of a and b
 * toward the unit vector b just far enough that dot(a, b) >= bound (bound in
 * [0, 1)); a unchanged when it already is. The turn is the smallest rotation
 * that meets the bound: bound b + sqrt(1 - bound^2) (a - (a.b) b) / |...|. */
inline float3 bump_turn_toward(float3 a, float3 b, float bound)
{
    float c = dot3(a, b);
    if (c >= bound) return a;
    float3 w = tx_unit_or(a - c * b, any_tangent(b));   /* a = -b: any direction will do */
    return bound * b + sqrt(1.0f - bound * bound) * w;
}

/* The least cosine between a corrected shading normal and the geometric normal or
 * the direction to the viewer: 2^-5, 1.8 degrees short of perpendicular; enough that
 * a light at the viewer always lights the point, small enough that only normals
 * that were (nearly) invisible change. */
#define TX_NORMAL_MIN_COS 0.03125f

/* The shading normal ns made usable (ng: the geometric normal and wo the unit
 * direction to the viewer, both on the viewer's side, dot(ng, wo) >= 0):
 * a perturbed normal may point below the geometric surface or away from the
 * viewer, where every light would leave the point black (speckles at grazing
 * angles). ns is first turned toward ng until dot(ns, ng) >= TX_NORMAL_MIN_COS,
 * then toward wo until dot(ns, wo) >= min(TX_NORMAL_MIN_COS, dot(ng, wo)) --
 * never more than the geometric normal itself faces the viewer, so ns = ng is
 * left exactly as it is. The second turn keeps dot(ns, ng) > 0: it runs along the
 * short arc from a normal above the surface to wo, which is above it too (an
 * open hemisphere contains the short arc between any two of its points). This
 * is the spirit of Keller et al.'s normal clamping and of pbrt/Mitsuba's
 * "flip invalid normals", done as the smallest rotation that makes ns valid. */
static inline float3 shading_normal_facing(float3 ns, float3 ng, float3 wo)
{
    ns = bump_turn_toward(ns, ng, TX_NORMAL_MIN_COS);
    return bump_turn_toward(ns, wo, TX_MIN(TX_NORMAL_MIN_COS, TX_MAX(dot3(ng, wo), 0.0f)));
}

#endif
