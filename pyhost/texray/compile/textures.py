"""Device packing of textures: one texture table and one shared half-float texel
buffer for a scene's (Texture, kind) entries (texray.scene.texture: kinds, filters)."""
from __future__ import annotations

import numpy as np

from ..device import layout
from ..errors import SceneError
from ..scene.mapping import WRAP_MODES, UVTransform
from ..scene.texture import FILTERS, HALF_MAX, MAX_TEXELS, MIP_FILTERS

def pack(entries):
    """One texture table and one shared texel buffer for ``entries`` = [(Texture, kind)],
    in table order; ``(layout.TEXTURE array, float16 texels (T*4,))``.

    Each distinct (pixels, kind) is packed once, with its MIP levels when some entry using
    it filters trilinearly or anisotropically (its other entries read level 0). Levels are contiguous: level l
    starts ``sum_{k<l} w_k h_k`` texels after the entry's ``offset`` (kernels/texture/texture.h
    computes this from width and height). Raises SceneError when the texels exceed the
    32-bit texel offsets."""
    keys, mip = [], {}
    for t, kind in entries:
        key = (id(t._pixels), kind)
        if key not in mip:
            keys.append((key, t, kind))
            mip[key] = False
        mip[key] |= t.filter in MIP_FILTERS
    blocks, offsets, nlevels, total = [], {}, {}, 0
    for key, t, kind in keys:
        levels = t.levels(kind, mip=mip[key])
        offsets[key], nlevels[key] = total, len(levels)
        total += sum(lv.shape[0] * lv.shape[1] for lv in levels)
        if total >= MAX_TEXELS:
            raise SceneError(f"{t.field}: {t.name}: the scene's textures need {total} texels or more, beyond the "
                             f"{MAX_TEXELS} that 32-bit texel offsets address")
        blocks.append(t.half_texels(kind, mip=mip[key]))      # float16, clamped to +-HALF_MAX; cached
    table = np.zeros(len(entries), layout.TEXTURE)
    for i, (t, kind) in enumerate(entries):
        key = (id(t._pixels), kind)
        table[i]["offset"] = offsets[key]
        table[i]["height"], table[i]["width"] = t.shape
        table[i]["wrap"] = WRAP_MODES[t.wrap]
        table[i]["filter"] = FILTERS[t.filter]
        table[i]["levels"] = nlevels[key] if t.filter in MIP_FILTERS else 1
        table[i]["max_aniso"] = t.max_aniso
        table[i]["m0"], table[i]["m1"] = (t.uv_transform or UVTransform()).device_args()
    # Half floats top out at 65504: each block is clamped so that bright HDR texels stay
    # finite (Texture.half_texels).
    texels = blocks[0] if len(blocks) == 1 else np.concatenate(blocks)
    return table, texels


def check_device_limits(texel_bytes, names, max_alloc, where="textures"):
    """SceneError when the texel buffer (``texel_bytes``) is larger than the device's largest
    buffer (``max_alloc``, CL_DEVICE_MAX_MEM_ALLOC_SIZE). ``names``: the textures, for the message."""
    if texel_bytes > max_alloc:
        raise SceneError(f"{where}: {', '.join(names)}: {texel_bytes} bytes of texels (MIP levels included) exceed "
                         f"the device's largest buffer, {max_alloc} bytes (CL_DEVICE_MAX_MEM_ALLOC_SIZE); use "
                         "smaller images or filter='bilinear'")
