#line 2 "texture/wrap.h"
/* Texture wrap modes: what a texel index or a texture coordinate outside the
 * image means. Mode numbers are texray.mapping.WRAP_MODES on the host.
 *
 *   repeat  ..., n-2, n-1 | 0, 1, ..., n-1 | 0, 1, ...
 *   clamp   ..., 0, 0     | 0, 1, ..., n-1 | n-1, n-1, ...
 *   mirror  ..., 1, 0     | 0, 1, ..., n-1 | n-1, n-2, ...   (OpenGL MIRRORED_REPEAT:
 *           each edge texel is repeated once, the period is 2n texels / 2 in u)
 *
 * The functions index along an increasing coordinate (column i covers
 * u in [i/n, (i+1)/n)). Every mode is symmetric under i -> n-1-i together with
 * u -> 1-u, so rows counted from the top (texture.h: row 0 = top, v = 0 at the
 * bottom) use the same functions on 1 - v, or row = n - 1 - wrap_nearest(v, ...).
 *
 * Robustness: nothing here converts an unreduced float to int. Huge |u| (1e9,
 * FLT_MAX) and negative u are reduced with floor first; NaN u gives texel 0 /
 * coordinate 0; +-inf give 0 (repeat, mirror) or the edge (clamp). Every index
 * returned is in [0, n-1] for n >= 1 (n <= 2^30); n <= 0 returns 0. An unknown
 * mode is treated as repeat. */
#ifndef TEXRAY_WRAP_H
#define TEXRAY_WRAP_H
#include "core/accurate.h"

#define TX_WRAP_REPEAT 0
#define TX_WRAP_CLAMP 1
#define TX_WRAP_MIRROR 2

/* Texel index i (any int, e.g. the two taps of a bilinear footprint) -> [0, n-1]. */
inline int wrap_index(int i, int n, int mode)
{
    if (n <= 1) return 0;
    if (mode == TX_WRAP_CLAMP) return i < 0 ? 0 : (i >= n ? n - 1 : i);
    if (mode == TX_WRAP_MIRROR) {
        int p = n + n;                       /* period; n <= 2^30 so no overflow */
        int r = i % p;
        r = r < 0 ? r + p : r;
        return r < n ? r : p - 1 - r;
    }
    int r = i % n;
    return r < 0 ? r + n : r;
}

/* u reduced to a small range with the same wrapped texture, for bilinear
 * footprints: repeat -> [0, 1], mirror -> [0, 2] (one period), clamp -> [-1, 2]
 * (everything beyond samples the edge anyway). Then x = r * n - 0.5,
 * i0 = (int)floor(x) cannot overflow, and wrap_index(i0, n, mode),
 * wrap_index(i0 + 1, n, mode) with weight x - floor(x) give the same result as
 * the unreduced u would (up to float32 rounding of the reduction, exact for
 * |u| < 2^23 in repeat/mirror when u is representable). NaN and +-inf -> 0
 * (clamp: +inf -> 2, -inf -> -1). */
inline float wrap_reduce(float u, int mode)
{
    if (isnan(u)) return 0.0f;
    if (mode == TX_WRAP_CLAMP) return u < -1.0f ? -1.0f : (u > 2.0f ? 2.0f : u);
    if (isinf(u)) return 0.0f;
    if (mode == TX_WRAP_MIRROR) return u - 2.0f * floor(0.5f * u);
    return u - floor(u);
}

/* Coordinate for nearest lookups: u' in [0, 1], the wrapped u (NaN -> 0).
 * Texel min((int)(u' * n), n - 1) is the one the wrapped u falls in, except
 * exactly on a texel boundary inside a mirrored period, where the reflection
 * picks the neighbour; wrap_nearest is exact there too. u' = 1 only for clamp
 * u >= 1, mirror at odd integers, and repeat u in (-2^-25, 0), where
 * u - floor(u) rounds to 1 (the last texel, as it should be). */
inline float wrap_coord(float u, int mode)
{
    if (isnan(u)) return 0.0f;
    if (mode == TX_WRAP_CLAMP) return u < 0.0f ? 0.0f : (u > 1.0f ? 1.0f : u);
    float r = wrap_reduce(u, mode);
    return (mode == TX_WRAP_MIRROR && r > 1.0f) ? 2.0f - r : r;
}

/* Nearest texel index in [0, n-1] of coordinate u: wrap_index(floor(u * n)),
 * computed without overflow (columns; for rows see above). */
inline int wrap_nearest(float u, int n, int mode)
{
    if (n <= 1) return 0;
    if (mode == TX_WRAP_MIRROR) {
        /* index in the reduced period [0, 2], then reflected: exact on boundaries */
        int i = (int)(wrap_reduce(u, mode) * (float)n);      /* in [0, 2n] */
        return wrap_index(i, n, mode);                       /* 2n (u just below 0) -> 0 */
    }
    int i = (int)(wrap_coord(u, mode) * (float)n);           /* in [0, n] */
    return i < n ? i : n - 1;                                /* n: u = 1 (clamp) or u -> 0- (repeat) */
}

#endif
