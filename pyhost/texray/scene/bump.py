"""Bump maps (Blinn 1978) and normal maps: the material roles that alter the shading normal.

Both read *data* textures: their texel values are used as stored in the file,
never decoded from sRGB, whatever the texture's colorspace.
The device side is ``kernels/shading/bump.h``.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..device import layout
from ..errors import SceneError
from .. import validate as V
from .texture import Texture

CONVENTIONS = {"opengl": 0, "directx": layout.TX_NORMAL_DIRECTX}
SPACES = {"tangent": 0, "object": layout.TX_NORMAL_OBJECT}


def data_texture(texture, where):
    """The Texture of a data role: a Texture, or a path loaded as one. Data roles read the
    stored values whatever the texture's colorspace (texray.texture, kind "data")."""
    if isinstance(texture, (str, Path)):
        return Texture.load(texture, colorspace="linear", field=f"{where}texture")
    if not isinstance(texture, Texture):
        raise SceneError(f"{where}texture: expected a texray.Texture or a path, got {texture!r}")
    return texture


@dataclass
class Bump:
    """A height field B(u, v) = height * texture.r raising the surface along its outward
    shading normal (Blinn bump mapping; the normal only, the surface stays put).

    height: world units per texture unit (a texel value of 1 raises the surface by
    ``height``), so the look does not depend on how the surface is parameterized;
    0 renders exactly as no bump map. Negative heights carve dents.
    delta: the step of the central differences for dB/du, dB/dv, in the texture's
    coordinates (after its UV transform): None = one texel of the texture,
    a number in (0, 0.5], or "analytic" = the exact gradient of the bilinear
    interpolant (the limit of small steps; one lookup of four texels).
    """
    texture: object
    height: float = 0.01
    delta: object = None

    def __post_init__(self):
        self.texture = data_texture(self.texture, "bump.")
        self.validate()

    def validate(self, where="bump."):
        V.number(self.height, "height", where, limit=V.COORD_LIMIT)
        if not (self.delta is None or (isinstance(self.delta, str) and self.delta == "analytic")):
            V.number(self.delta, "delta", where, 0.0, 0.5, lo_open=True)
        return self

    def device_delta(self):
        """Material.bump_delta: layout.BUMP_DELTA_* or the step."""
        if self.delta is None:
            return layout.BUMP_DELTA_TEXEL
        if self.delta == "analytic":
            return layout.BUMP_DELTA_ANALYTIC
        return float(self.delta)


@dataclass
class NormalMap:
    """A normal map: RGB in [0, 1] encodes a unit normal (2 c - 1).

    convention: "opengl" (green = +bitangent, "Y up") or "directx" (green flipped).
    space: "tangent" (x along dP/du, y along the bitangent on dP/dv's side, z the
    outward shading normal; a flat map is (0.5, 0.5, 1)) or "object" (the normal in
    the object's own coordinates, before its transform).
    The texture needs 3 or 4 channels.
    """
    texture: object
    convention: str = "opengl"
    space: str = "tangent"

    def __post_init__(self):
        self.texture = data_texture(self.texture, "normal_map.")
        self.validate()

    def validate(self, where="normal_map."):
        V.one_of(self.convention, tuple(CONVENTIONS), "convention", where)
        V.one_of(self.space, tuple(SPACES), "space", where)
        if self.texture.channels < 3:
            raise SceneError(f"{where}texture: {self.texture.name} has {self.texture.channels} channel(s); "
                             "a normal map needs 3 (RGB) or 4")
        return self

    def device_mode(self):
        """Material.normal_mode: layout.TX_NORMAL_* bits."""
        return CONVENTIONS[self.convention] | SPACES[self.space]
