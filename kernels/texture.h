#line 2 "texture.h"
/* Texture lookups. Texels are linear RGBA halves, row 0 = the image's top row;
 * u runs along columns, v = 0 is the bottom row and v = 1 the top (the OBJ /
 * OpenGL convention). Texel centres sit at ((i + 0.5) / W, 1 - (j + 0.5) / H). */
#ifndef TEXRAY_TEXTURE_H
#define TEXRAY_TEXTURE_H

inline int wrap_repeat(int i, int n) { int r = i % n; return r < 0 ? r + n : r; }

inline float4 texel(__global const half* texels, __global const TextureInfo* ti, int x, int y)
{
    return vload_half4(ti->offset + (uint)y * ti->width + (uint)x, texels);
}

/* Bilinear filtering with repeat wrapping. Coordinates are reduced to [0, 1)
 * before scaling, so huge (u, v) never overflow an int; non-finite (u, v)
 * return black rather than reading out of bounds. */
inline float4 texture_bilinear(__global const half* texels, __global const TextureInfo* ti, float2 uv)
{
    if (!(isfinite(uv.x) && isfinite(uv.y))) return (float4)(0.0f);
    int w = (int)ti->width, h = (int)ti->height;
    float x = (uv.x - floor(uv.x)) * (float)w - 0.5f;
    float y = (1.0f - (uv.y - floor(uv.y))) * (float)h - 0.5f;
    float fx = floor(x), fy = floor(y);
    float ax = x - fx, ay = y - fy;
    int x0 = wrap_repeat((int)fx, w), x1 = wrap_repeat((int)fx + 1, w);
    int y0 = wrap_repeat((int)fy, h), y1 = wrap_repeat((int)fy + 1, h);
    float4 t00 = texel(texels, ti, x0, y0), t10 = texel(texels, ti, x1, y0);
    float4 t01 = texel(texels, ti, x0, y1), t11 = texel(texels, ti, x1, y1);
    return (t00 * (1.0f - ax) + t10 * ax) * (1.0f - ay) + (t01 * (1.0f - ax) + t11 * ax) * ay;
}

#endif
