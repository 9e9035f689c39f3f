#line 2 "texture.h"
/* Texture lookups. Texels are linear RGBA halves, row 0 = the image's top row;
 * u runs along columns, v = 0 is the bottom row and v = 1 the top (the OBJ /
 * OpenGL convention). Texel centres sit at ((i + 0.5) / W, 1 - (j + 0.5) / H).
 * Each texture carries its wrap mode (wrap.h) and UV transform (TextureInfo). */
#ifndef TEXRAY_TEXTURE_H
#define TEXRAY_TEXTURE_H

inline float4 texel(__global const half* texels, __global const TextureInfo* ti, int x, int y)
{
    return vload_half4(ti->offset + (uint)y * ti->width + (uint)x, texels);
}

/* The texture's UV transform applied to uv. */
inline float2 texture_coords(__global const TextureInfo* ti, float2 uv)
{
    return uv_transform(uv, vload4(0, ti->m0), vload2(0, ti->m1));
}

/* Bilinear filtering in the texture's wrap mode. Coordinates are reduced to a
 * small range before scaling (wrap_reduce), so huge (u, v) never overflow an
 * int, and NaN maps to a defined texel rather than out of bounds. Rows are
 * wrapped from the top (1 - v), which every wrap mode allows (wrap.h). */
inline float4 texture_bilinear(__global const half* texels, __global const TextureInfo* ti, float2 uv)
{
    int w = (int)ti->width, h = (int)ti->height, mode = (int)ti->wrap;
    float x = wrap_reduce(uv.x, mode) * (float)w - 0.5f;
    float y = (1.0f - wrap_reduce(uv.y, mode)) * (float)h - 0.5f;
    float fx = floor(x), fy = floor(y);
    float ax = x - fx, ay = y - fy;
    int x0 = wrap_index((int)fx, w, mode), x1 = wrap_index((int)fx + 1, w, mode);
    int y0 = wrap_index((int)fy, h, mode), y1 = wrap_index((int)fy + 1, h, mode);
    float4 t00 = texel(texels, ti, x0, y0), t10 = texel(texels, ti, x1, y0);
    float4 t01 = texel(texels, ti, x0, y1), t11 = texel(texels, ti, x1, y1);
    return (t00 * (1.0f - ax) + t10 * ax) * (1.0f - ay) + (t01 * (1.0f - ax) + t11 * ax) * ay;
}

#endif
