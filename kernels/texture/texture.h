#line 2 "texture/texture.h"
/* Texture lookups. Texels are linear RGBA halves (texray.texture decodes them per
 * role on the host), row 0 = the image's top row; u runs along columns, v = 0 is
 * the bottom row and v = 1 the top (the OBJ / OpenGL convention). Texel centres
 * sit at ((i + 0.5) / W, 1 - (j + 0.5) / H). Each texture carries its wrap mode
 * (wrap.h), UV transform and filter (TextureInfo, texray.layout.TEXTURE).
 *
 * Filters: FILTER_NEAREST (the texel the point falls in, level 0),
 * FILTER_BILINEAR (level 0), FILTER_TRILINEAR (bilinear in the two MIP
 * levels around the level of detail, blended linearly) and FILTER_ANISOTROPIC
 * (trilinear probes along the footprint's major axis, texture_anisotropic). The
 * code of a filter is compiled in only when some texture of the scene uses it
 * (TX_FILTER_*).
 *
 * MIP levels: level l is max(1, W >> l) x max(1, H >> l) texels, stored right
 * after level l - 1 (texray.texture.mip_pyramid makes them: exact box filter,
 * odd sizes included). Every level spans the whole [0, 1]^2, so the same uv
 * addresses every level. */
#ifndef TEXRAY_TEXTURE_H
#define TEXRAY_TEXTURE_H
#include "core/transcendental.h"
#include "texture/wrap.h"
#include "texture/mapping.h"

typedef struct { uint offset; int w, h; } TexLevel;     /* one MIP level: first texel, size */

/* Level l of a texture, l clamped to [0, levels - 1]. The offsets are summed on
 * the fly (no level table to upload): at most 31 steps, since a texture of at most
 * 2^31 texels a side has at most 32 levels (texray.texture.mip_pyramid); l is
 * clamped to 31 as well, so a corrupt level count cannot lengthen the loop. */
static inline TexLevel texture_level(__global const TextureInfo* ti, int l)
{
    uint off = ti->offset, w = ti->width, h = ti->height;
    int last = TX_MIN((int)ti->levels - 1, 31);
    l = l < last ? l : last;
    for (int k = 0; k < l; ++k) {
        off += w * h;
        w = TX_MAX(1u, w >> 1);
        h = TX_MAX(1u, h >> 1);
    }
    TexLevel r = { off, (int)w, (int)h };
    return r;
}

/* The level after lv (the caller knows it exists). */
static inline TexLevel texture_next_level(TexLevel lv)
{
    TexLevel r = { lv.offset + (uint)lv.w * (uint)lv.h, TX_MAX(1, lv.w >> 1), TX_MAX(1, lv.h >> 1) };
    return r;
}

static inline float4 texel_at(__global const half* texels, TexLevel lv, int x, int y)
{
    return vload_half4(lv.offset + (uint)y * (uint)lv.w + (uint)x, texels);
}

static inline float4 texel(__global const half* texels, __global const TextureInfo* ti, int x, int y)
{
    return vload_half4(ti->offset + (uint)y * ti->width + (uint)x, texels);
}

/* The four texels around uv in one level, wrap mode `mode`, and the weights ax, ay
 * of the second column and row (x = u w - 1/2 grows with u, y = (1 - v) h - 1/2
 * falls with v). Coordinates are reduced to a small range before scaling
 * (wrap_reduce), so huge (u, v) never overflow an int, and NaN maps to a defined
 * texel rather than out of bounds. Rows are wrapped from the top (1 - v), which
 * every wrap mode allows (wrap.h). */
typedef struct { float4 t00, t10, t01, t11; float ax, ay; } BilinearTaps;

/* bilinear_taps and texture_bilinear_level are always inlined: PoCL left them calls, the
 * taps returned through memory (perf, globe: the loads after the call were the hottest
 * instructions of the surface stage); inlined, tools/ab.py measured 0.96-0.97 of the frame
 * time on the globe, the bumped brick wall and the grazing quad (README, Performance). */
static inline __attribute__((always_inline)) BilinearTaps bilinear_taps(__global const half* texels, TexLevel lv,
                                                                        int mode, float2 uv)
{
    float x = wrap_reduce(uv.x, mode) * (float)lv.w - 0.5f;
    float y = (1.0f - wrap_reduce(uv.y, mode)) * (float)lv.h - 0.5f;
    float fx = floor(x), fy = floor(y);
    int x0 = wrap_index((int)fx, lv.w, mode), x1 = wrap_index((int)fx + 1, lv.w, mode);
    int y0 = wrap_index((int)fy, lv.h, mode), y1 = wrap_index((int)fy + 1, lv.h, mode);
    BilinearTaps k = { texel_at(texels, lv, x0, y0), texel_at(texels, lv, x1, y0),
                       texel_at(texels, lv, x0, y1), texel_at(texels, lv, x1, y1), x - fx, y - fy };
    return k;
}

/* Bilinear filtering of one level in wrap mode `mode` (bilinear_taps). */
static inline __attribute__((always_inline)) float4 texture_bilinear_level(__global const half* texels, TexLevel lv,
                                                                           int mode, float2 uv)
{
    BilinearTaps k = bilinear_taps(texels, lv, mode, uv);
    return (k.t00 * (1.0f - k.ax) + k.t10 * k.ax) * (1.0f - k.ay) + (k.t01 * (1.0f - k.ax) + k.t11 * k.ax) * k.ay;
}

/* Bilinear filtering of level 0 (uv already transformed). */
inline float4 texture_bilinear(__global const half* texels, __global const TextureInfo* ti, float2 uv)
{
    return texture_bilinear_level(texels, texture_level(ti, 0), (int)ti->wrap, uv);
}

/* The level-0 texel that uv falls in (wrap.h wrap_nearest; rows from the top). */
static inline float4 texture_nearest(__global const half* texels, __global const TextureInfo* ti, float2 uv)
{
    TexLevel lv = texture_level(ti, 0);
    int mode = (int)ti->wrap;
    return texel_at(texels, lv, wrap_nearest(uv.x, lv.w, mode), lv.h - 1 - wrap_nearest(uv.y, lv.h, mode));
}

/* Level of detail of a pixel footprint, the OpenGL rule (4.6 core, 8.14.1, isotropic):
 * lod = log2(rho), rho = the longer of the screen-x and screen-y steps of
 * (u W, v H), i.e. the footprint in level-0 texels. duv_dx, duv_dy: derivatives of
 * the transformed coordinates. Zero derivatives give -inf, NaN gives NaN: the
 * lookups clamp both to level 0. */
static inline float texture_lod(__global const TextureInfo* ti, float2 duv_dx, float2 duv_dy)
{
    float2 s = (float2)((float)ti->width, (float)ti->height);
    float2 a = duv_dx * s, b = duv_dy * s;
    return 0.5f * log2(TX_MAX(a.x * a.x + a.y * a.y, b.x * b.x + b.y * b.y));
}

/* lod clamped to [0, levels - 1]; NaN -> 0. */
static inline float texture_clamp_lod(__global const TextureInfo* ti, float lod)
{
    float last = (float)((int)ti->levels - 1);
    return lod > 0.0f ? TX_MIN(lod, last) : 0.0f;
}

/* Bilinear in level la, blended with level lb (the next) by frac; frac = 0 reads la only. */
inline float4 texture_blend_levels(__global const half* texels, TexLevel la, TexLevel lb, int mode, float2 uv,
                                   float frac)
{
    float4 c = texture_bilinear_level(texels, la, mode, uv);
    if (frac > 0.0f)
        c = c * (1.0f - frac) + texture_bilinear_level(texels, lb, mode, uv) * frac;
    return c;
}

/* Trilinear MIP mapping: bilinear in levels floor(lod) and floor(lod) + 1, blended
 * by the fraction (Williams 1983). lod <= 0 (magnification) is level 0 bilinear. */
inline float4 texture_trilinear(__global const half* texels, __global const TextureInfo* ti, float2 uv, float lod)
{
    lod = texture_clamp_lod(ti, lod);
    int l0 = (int)lod;
    TexLevel a = texture_level(ti, l0);
    return texture_blend_levels(texels, a, texture_next_level(a), (int)ti->wrap, uv, lod - (float)l0);
}

#if TX_FILTER_ANISOTROPIC
/* Anisotropic filtering after Feline (McCormack, Perry, Farkas, Jouppi, "Feline: Fast
 * Elliptical Lines for Anisotropic Texture Mapping", SIGGRAPH 1999), the scheme of GPU
 * anisotropic filtering. The pixel footprint in level-0 texels is the ellipse J s,
 * |s| <= 1/2, J = [a b] (a, b: the screen-x and screen-y steps of (u W, v H), as in
 * texture_lod); its full axis lengths major >= minor are J's singular values (for an
 * isotropic footprint both equal texture_lod's rho). The probes are trilinear lookups at
 * lod = log2(width), width = max(minor, major / max_aniso, 1 texel), evenly spaced on the
 * segment of length major - width along the major axis, centred on uv:
 * n = ceil(major / width) of them (clamped to [1, max_aniso]), at most `width` apart, so
 * together they cover the ellipse's length. Reaching the cap raises width (a coarser
 * level) instead of leaving gaps. As the footprint turns isotropic the segment shrinks to
 * a point, so the result tends to trilinear's without a jump. Probe k at distance t_k
 * from uv weighs exp(-2 x^2), x = t_k / (major / 2) (Feline's Gaussian, alpha = 2),
 * normalized. The 1-texel floor adds no probes under magnification, where one bilinear
 * tap already spans a texel. Cost: n (<= max_aniso) trilinear probes sharing one level
 * walk. Degenerate footprints: major = 0 (zero derivatives) is level 0, one probe; a
 * non-finite major (inf or NaN derivatives) is one trilinear probe at lod = log2(major)
 * (inf: the coarsest level; NaN: level 0). tests/reference.py aniso_footprint mirrors this. */
typedef struct {
    float2 axis_uv;              /* the major axis' unit vector in texels, in uv per texel */
    float major, width, spacing; /* level-0 texels: the footprint's length, the probes' width and spacing */
    int n;                       /* probes */
} AnisoFootprint;

inline AnisoFootprint texture_aniso_footprint(__global const TextureInfo* ti, float2 duv_dx, float2 duv_dy)
{
    float2 s = (float2)((float)ti->width, (float)ti->height);
    float2 a = duv_dx * s, b = duv_dy * s;
    /* J J^T = [[A, B], [B, C]]: eigenvalues (A + C) / 2 +- r */
    float A = a.x * a.x + b.x * b.x, B = a.x * a.y + b.x * b.y, C = a.y * a.y + b.y * b.y;
    float h = 0.5f * (A - C);
    float r = tx_hypot(h, B);
    AnisoFootprint f;
    f.major = sqrt(0.5f * (A + C) + r);
    /* minor = |det J| / major: no cancellation (core/accurate.h tx_diff_prod), unlike sqrt of the
     * smaller eigenvalue */
    float minor = fabs(tx_diff_prod(a.x, b.y, a.y, b.x)) / f.major;
    /* max_aniso in [1, 64] (texray.texture.MAX_ANISO_LIMIT; the host checks it): the probe
     * loop of texture_anisotropic runs n <= 64 times whatever the table says. */
    float max_aniso = (float)clamp(ti->max_aniso, 1u, 64u);
    f.width = TX_MAX(TX_MAX(minor, f.major / max_aniso), 1.0f);
    f.n = (int)TX_MIN(ceil(f.major / f.width), max_aniso);
    f.n = TX_MAX(f.n, 1);
    /* The major eigenvector, from whichever row of J J^T - lambda I is well conditioned. */
    float2 v = h >= 0.0f ? (float2)(h + r, B) : (float2)(B, r - h);
    float len = tx_hypot(v.x, v.y);
    float2 axis = len > 0.0f ? v / len : (float2)(1.0f, 0.0f);
    f.spacing = f.n > 1 ? TX_MAX(f.major - f.width, 0.0f) / (float)(f.n - 1) : 0.0f;
    f.axis_uv = axis / s;
    return f;
}

inline float4 texture_anisotropic(__global const half* texels, __global const TextureInfo* ti, float2 uv,
                                  float2 duv_dx, float2 duv_dy)
{
    AnisoFootprint f = texture_aniso_footprint(ti, duv_dx, duv_dy);
    if (!(f.major > 0.0f && f.major <= FLT_MAX))
        return texture_trilinear(texels, ti, uv, log2(f.major));
    float lod = texture_clamp_lod(ti, log2(f.width));
    int l0 = (int)lod;
    float frac = lod - (float)l0;
    int mode = (int)ti->wrap;
    TexLevel la = texture_level(ti, l0), lb = texture_next_level(la);
    float4 sum = (float4)(0.0f);
    float wsum = 0.0f;
    for (int k = 0; k < f.n; ++k) {
        float t = ((float)k - 0.5f * (float)(f.n - 1)) * f.spacing;    /* texels from uv */
        float x = 2.0f * t / f.major;
        float w = exp(-2.0f * x * x);
        sum += w * texture_blend_levels(texels, la, lb, mode, uv + t * f.axis_uv, frac);
        wsum += w;
    }
    return sum / wsum;
}
#endif

/* The texture's filter at transformed coordinates t (uv and screen derivatives). */
static inline float4 texture_sample(__global const half* texels, __global const TextureInfo* ti, TexCoord t)
{
#if TX_FILTER_ANISOTROPIC && !TX_FILTER_NEAREST && !TX_FILTER_BILINEAR && !TX_FILTER_TRILINEAR
    return texture_anisotropic(texels, ti, t.uv, t.duv_dx, t.duv_dy);
#elif TX_FILTER_TRILINEAR && !TX_FILTER_NEAREST && !TX_FILTER_BILINEAR && !TX_FILTER_ANISOTROPIC
    return texture_trilinear(texels, ti, t.uv, texture_lod(ti, t.duv_dx, t.duv_dy));
#elif TX_FILTER_NEAREST && !TX_FILTER_TRILINEAR && !TX_FILTER_BILINEAR && !TX_FILTER_ANISOTROPIC
    return texture_nearest(texels, ti, t.uv);
#else
#if TX_FILTER_ANISOTROPIC
    if (ti->filter == FILTER_ANISOTROPIC) return texture_anisotropic(texels, ti, t.uv, t.duv_dx, t.duv_dy);
#endif
#if TX_FILTER_TRILINEAR
    if (ti->filter == FILTER_TRILINEAR) return texture_trilinear(texels, ti, t.uv, texture_lod(ti, t.duv_dx, t.duv_dy));
#endif
#if TX_FILTER_NEAREST
    if (ti->filter == FILTER_NEAREST) return texture_nearest(texels, ti, t.uv);
#endif
    return texture_bilinear(texels, ti, t.uv);
#endif
}

/* A texture's value at surface coordinates tc (uv with d(uv)/dx, d(uv)/dy; zero
 * derivatives read level 0): its UV transform, then its filter. */
inline float4 texture_eval(__global const half* texels, __global const TextureInfo* ti, TexCoord tc)
{
    return texture_sample(texels, ti, texcoord_transform(tc, vload4(0, ti->m0), vload2(0, ti->m1)));
}

/* The (unclamped) lod texture_eval(ti, tc) uses, for trilinear textures. */
static inline float texture_eval_lod(__global const TextureInfo* ti, TexCoord tc)
{
    float4 m0 = vload4(0, ti->m0);
    return texture_lod(ti, uv_transform_vector(tc.duv_dx, m0), uv_transform_vector(tc.duv_dy, m0));
}

/* Contract: the (du, dv) size, in the texture's transformed coordinates, of one texel
 * of the MIP level a lookup at `lod` reads first (level floor(clamped lod); level 0
 * for a texture without MIP levels, i.e. any filter but trilinear and anisotropic). */
static inline float2 texture_texel_size(__global const TextureInfo* ti, float lod)
{
    TexLevel lv = texture_level(ti, (int)texture_clamp_lod(ti, lod));
    return (float2)(1.0f / (float)lv.w, 1.0f / (float)lv.h);
}

/* The lecture's texture used as label: the texture (premultiplied by alpha on the
 * host, role "label") where its transformed uv lies in [0, 1]^2, and 0 (absent)
 * elsewhere or for NaN uv; composite as kd (1 - a) + rgb. */
inline float4 texture_label(__global const half* texels, __global const TextureInfo* ti, TexCoord tc)
{
    TexCoord t = texcoord_transform(tc, vload4(0, ti->m0), vload2(0, ti->m1));
    if (!(t.uv.x >= 0.0f && t.uv.x <= 1.0f && t.uv.y >= 0.0f && t.uv.y <= 1.0f)) return (float4)(0.0f);
    return texture_sample(texels, ti, t);
}

#endif
