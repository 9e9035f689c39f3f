"""Textures: loading, colour spaces per role and MIP pyramids (device packing:
texray.compile.textures).

A :class:`Texture` keeps the values as stored (raw, 1-4 channels, float32) and
the colour space they are encoded in. What the device gets depends on the
*role* a material gives the texture, known only when a scene is compiled:

* ``"colour"`` (diffuse kd, specular ks): sRGB-encoded values are decoded to
  linear (IEC 61966-2-1); alpha is kept linear.
* ``"label"`` (the lecture's texture used as label): decoded like a colour, then
  premultiplied by alpha, so that filtering the label and compositing it
  (``kd (1 - a) + rgb``) commute: a filtered premultiplied label is the
  filtered composite, with no fringes where alpha drops to 0.
* ``"data"`` (shininess, height, normals): the stored values, never decoded.

A texture used in two roles of different kinds is packed twice; otherwise once,
also when several :meth:`Texture.with_options` variants share its pixels.

Filters (``filter=``): ``"nearest"`` (the texel the point falls in),
``"bilinear"`` (the default: the four nearest texels, level 0 only) and
``"trilinear"`` (bilinear in the two MIP levels around the pixel footprint's
level of detail, blended; the footprint comes from ray differentials, see
kernels/texture/texture.h) and ``"anisotropic"`` (up to ``max_aniso`` trilinear probes
along the footprint's major axis at the level of its minor axis, Gaussian
weighted: Feline, McCormack et al. 1999). Only trilinear and anisotropic
textures get MIP levels.
"""
from __future__ import annotations


import numpy as np

from ..device import layout
from ..errors import SceneError
from ..io.colour import srgb_to_linear
from ..io.images import read_texture_file
from .. import procedural as _procedural_module
from ..procedural.textures import check_texture_params
from .. import validate as V
from .mapping import WRAP_MODES, UVTransform

FILTERS = layout.FILTERS                  # name -> TextureInfo.filter (the device's FILTER_*)
MIP_FILTERS = ("trilinear", "anisotropic")       # the filters that read MIP levels
DEFAULT_MAX_ANISO = 16        # probes of an anisotropic lookup (GPUs' usual maximum, 16:1)
MAX_ANISO_LIMIT = 64          # beyond this a probe costs more than it adds at any angle a pixel sees
COLORSPACES = ("auto", "srgb", "linear")
KINDS = ("colour", "label", "data")
HALF_MAX = 65504.0            # largest finite half float: texels are stored as halves
MAX_TEXELS = 2**32            # TextureInfo offsets and texel indices are 32-bit

# Colour-space names (OpenImageIO's oiio:ColorSpace, lower case) read as sRGB or linear.
_SRGB_NAMES = ("srgb",)
_LINEAR_NAMES = ("lin", "scene_linear", "acescg", "aces2065", "raw", "data")


class Texture:
    """An image for a material: raw values (H, W, C), C in 1..4, row 0 = the top row.

    ``colorspace``: ``"srgb"`` or ``"linear"``: how the stored values encode
    colour. Colour roles decode sRGB, data roles (shininess, height, normal
    maps) use the stored values whatever this says. 1 channel is grey, 2 are
    grey + alpha, 3 RGB, 4 RGBA; missing alpha is 1.
    ``filter``: "nearest", "bilinear" (default), "trilinear" or "anisotropic" (MIP mapped).
    ``max_aniso``: the most probes an anisotropic lookup takes (an int in 1..64,
    default 16): footprints longer than ``max_aniso`` times their width are read at a
    coarser level so that the probes still cover them. Kept, unused, by other filters.
    ``wrap``: "repeat", "clamp" or "mirror" outside [0, 1]. ``uv_transform``:
    a :class:`texray.mapping.UVTransform` applied to the lookup coordinates.
    :meth:`with_options` makes a texture sharing the pixels (uploaded once).
    """

    def __init__(self, pixels: np.ndarray, name: str = "<array>", colorspace="linear", wrap="repeat",
                 uv_transform=None, filter="bilinear", field="texture", max_aniso=DEFAULT_MAX_ANISO):
        self.name = name
        self.field = field
        if not isinstance(name, str):
            raise SceneError(f"{field}: name: expected a string, got {V.show(name)}")
        V.one_of(colorspace, ("srgb", "linear"), "colorspace", f"{field}.")
        if isinstance(pixels, _Pixels):
            self._pixels = pixels
        else:
            self._pixels = _Pixels(_check_pixels(pixels, name, field), colorspace)
        self.wrap, self.uv_transform, self.filter, self.max_aniso = wrap, uv_transform, filter, max_aniso
        self.validate()
        self.max_aniso = int(max_aniso)

    def validate(self):
        """Check the options (they may have been changed since the texture was made)."""
        field, name = self.field, self.name
        V.one_of(self.wrap, tuple(WRAP_MODES), "wrap", f"{field}.")
        if not isinstance(self.filter, str) or self.filter not in FILTERS:
            raise SceneError(f"{field}.filter: {name}: expected one of {', '.join(FILTERS)}, got "
                             f"{V.show(self.filter)}")
        if self.uv_transform is not None and not isinstance(self.uv_transform, UVTransform):
            raise SceneError(f"{field}.uv_transform: {name}: expected a texray.UVTransform, got "
                             f"{V.show(self.uv_transform)}")
        m = self.max_aniso
        if isinstance(m, (bool, np.bool_)) or not isinstance(m, (int, np.integer)) or not 1 <= m <= MAX_ANISO_LIMIT:
            raise SceneError(f"{field}.max_aniso: {name}: expected an integer in 1..{MAX_ANISO_LIMIT}, "
                             f"got {V.show(m)}")
        if self.uv_transform is not None:
            self.uv_transform.validate()
        return self

    # --- construction --------------------------------------------------------
    @classmethod
    def load(cls, path, colorspace="auto", filter="bilinear", wrap="repeat", uv_transform=None, field="texture",
             max_aniso=DEFAULT_MAX_ANISO):
        """Read PNG, JPEG, TIFF, EXR, HDR (anything OpenImageIO reads; 8/16-bit, half, float;
        1-4 channels). ``colorspace="auto"`` takes the file's ``oiio:ColorSpace`` (sRGB or
        linear names), else integer pixels are sRGB and half/float pixels linear. An
        unreadable, truncated or empty file, an unknown colour space or non-finite texels
        raise SceneError naming the file."""
        V.one_of(colorspace, COLORSPACES, "colorspace", f"{field}.")
        pixels, file_cs, is_float = read_texture_file(path, field)
        if colorspace == "auto":
            colorspace = auto_colorspace(file_cs, is_float, path, field)
        return cls(pixels, str(path), colorspace, wrap, uv_transform, filter, field, max_aniso)

    @classmethod
    def from_array(cls, array, colorspace="linear", name="<array>", field="texture", wrap="repeat",
                   uv_transform=None, filter="bilinear", max_aniso=DEFAULT_MAX_ANISO):
        """A texture from (H, W) or (H, W, C) numbers, C in 1..4; row 0 is the top row.
        ``colorspace``: how the numbers encode colour ("linear" or "srgb")."""
        return cls(array, name, colorspace, wrap, uv_transform, filter, field, max_aniso)

    @classmethod
    def procedural(cls, kind, filter="bilinear", wrap="repeat", uv_transform=None, max_aniso=DEFAULT_MAX_ANISO,
                   **params):
        """A texture from :mod:`texray.procedural`: ``kind`` is one of :data:`PROCEDURAL`
        ("checker", "bricks", "bricks_height", "noise", "wood", "marble", "tiles", "globe",
        "label"); ``params`` go to the generator (``size``, ``seed``...). Colours are
        sRGB-encoded display values, heights and noise linear data."""
        V.one_of(kind, tuple(PROCEDURAL), "procedural", "texture.")
        make, colorspace = PROCEDURAL[kind]
        check_texture_params(make, params, f"texture.procedural: {kind}: ")
        try:
            pixels = make(**params)
        except TypeError as e:
            raise SceneError(f"texture.procedural: {kind}: {e}") from None
        return cls(pixels, f"<{kind}>", colorspace, wrap, uv_transform, filter, max_aniso=max_aniso)

    def with_options(self, wrap=None, uv_transform=None, filter=None, max_aniso=None):
        """The same pixels (uploaded once) with another wrap mode, UV transform, filter and/or
        anisotropy bound."""
        return Texture(self._pixels, self.name, self.colorspace, wrap or self.wrap,
                       uv_transform if uv_transform is not None else self.uv_transform,
                       filter or self.filter, self.field, self.max_aniso if max_aniso is None else max_aniso)

    # --- what the pixels are -------------------------------------------------
    @property
    def colorspace(self) -> str:
        return self._pixels.colorspace

    @property
    def raw(self) -> np.ndarray:
        """The stored values, float32 (H, W, C), read-only (make a new texture to change them)."""
        return self._pixels.raw

    @property
    def channels(self) -> int:
        return self._pixels.raw.shape[2]

    @property
    def shape(self):
        return self._pixels.raw.shape[:2]

    @property
    def rgba(self) -> np.ndarray:
        """Level 0 as a colour role sees it: linear float32 RGBA (H, W, 4)."""
        return self._pixels.rgba("colour")

    def levels(self, kind="colour", mip=True) -> list[np.ndarray]:
        """The MIP pyramid (level 0 first) of this texture in role ``kind`` (see :data:`KINDS`),
        float32 (h, w, 4) arrays; only level 0 when ``mip`` is False."""
        return self._pixels.levels(kind) if mip else [self._pixels.rgba(kind)]

    def half_texels(self, kind="colour", mip=True) -> np.ndarray:
        """:meth:`levels` as the device's flat float16 RGBA texels (cached)."""
        return self._pixels.half_texels(kind, mip)

    def __repr__(self):
        return f"Texture({self.name!r}, {self.shape[1]}x{self.shape[0]}x{self.channels}, {self.filter})"


class _Pixels:
    """Raw pixels shared by the variants of one texture, with the role kinds and MIP
    pyramids made from them on first use. ``raw`` is read-only (a copy where the caller's
    array was float32 already): the caches below are made from it once, so an edit in
    place would leave them stale. To change texels, make a new :class:`Texture`."""

    DERIVED = ("_rgba", "_levels", "_half", "_digest")   # caches made from the others: not content (texray.compile.scene_hash)
    HASH_ONCE = True        # raw and colorspace never change: the scene hash walks them once (its _digest)

    def __init__(self, raw, colorspace):
        self.raw, self.colorspace = raw, colorspace
        self._rgba, self._levels, self._half = {}, {}, {}
        self._digest = None

    def __setstate__(self, state):                 # a copy or an unpickled one: read-only again
        self.__dict__.update(state)
        self.raw.flags.writeable = False

    def rgba(self, kind):
        if kind not in self._rgba:
            self._rgba[kind] = role_rgba(self.raw, self.colorspace, kind)
        return self._rgba[kind]

    def levels(self, kind):
        if kind not in self._levels:
            self._levels[kind] = mip_pyramid(self.rgba(kind))
        return self._levels[kind]

    def half_texels(self, kind, mip):
        """The levels (all with ``mip``, else level 0) as the device stores them: one flat
        float16 array of RGBA texels, level after level, clamped to +-HALF_MAX. Kept, so
        that rendering a scene again does not convert its textures again (a third of a small
        scene's per-render host time)."""
        key = (kind, bool(mip))
        if key not in self._half:
            levels = self.levels(kind) if mip else [self.rgba(kind)]
            texels = np.concatenate([lv.reshape(-1) for lv in levels])
            if not (texels.max(initial=0.0) <= HALF_MAX and texels.min(initial=0.0) >= -HALF_MAX):
                texels = np.clip(texels, -HALF_MAX, HALF_MAX)
            self._half[key] = texels.astype(np.float16)
            self._half[key].flags.writeable = False
        return self._half[key]


def _check_pixels(array, name, field):
    if isinstance(array, (str, bytes)) or array is None:
        raise SceneError(f"{field}: {name}: expected an array of numbers, got {V.show(array)}")
    try:
        a = np.asarray(array)
        if a.dtype == object:
            a = np.asarray(array, dtype=np.float64)
    except (TypeError, ValueError):
        raise SceneError(f"{field}: {name}: expected an array of numbers (equal-length rows), got "
                         f"{type(array).__name__}") from None
    if a.dtype.kind not in "iuf":
        raise SceneError(f"{field}: {name}: expected an array of numbers, got an array of {a.dtype}")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[2] not in (1, 2, 3, 4) or a.shape[0] < 1 or a.shape[1] < 1:
        raise SceneError(f"{field}: {name}: expected an (H, W) or (H, W, 1..4) image, got shape {np.shape(array)}")
    wide = a.astype(np.float64)
    if not np.all(np.isfinite(wide)):
        bad = np.argwhere(~np.isfinite(wide))[0]
        raise SceneError(f"{field}: {name}: non-finite texel {V.show(wide[tuple(bad)])} at row {bad[0]}, "
                         f"column {bad[1]}, channel {bad[2]}")
    if np.abs(wide).max() > HALF_MAX:
        bad = np.argwhere(np.abs(wide) > HALF_MAX)[0]
        raise SceneError(f"{field}: {name}: texel {V.show(wide[tuple(bad)])} at row {bad[0]}, column {bad[1]}, "
                         f"channel {bad[2]} is beyond {HALF_MAX:g}, the largest half float (texels are stored "
                         "as half floats on the device)")
    out = np.ascontiguousarray(a, dtype=np.float32)
    if np.may_share_memory(out, a):            # the caller's own array: keep a copy they cannot edit under us
        out = out.copy()
    out.flags.writeable = False                # texels are content: the derived caches and the device copy follow them
    return out


def role_rgba(raw, colorspace, kind):
    """Linear float32 RGBA (H, W, 4) of raw (H, W, C) values for a role ``kind``
    ("colour", "label" or "data"; see the module docstring)."""
    c = raw.shape[2]
    rgb = raw[:, :, [0, 0, 0]] if c < 3 else raw[:, :, :3]
    alpha = raw[:, :, 3:4] if c == 4 else (raw[:, :, 1:2] if c == 2 else np.ones_like(raw[:, :, :1]))
    if kind != "data" and colorspace == "srgb":
        rgb = srgb_to_linear(rgb)
    if kind == "label":
        alpha = np.clip(alpha, 0.0, 1.0)
        rgb = rgb * alpha
    elif kind not in KINDS:
        raise ValueError(f"unknown texture kind {kind!r}")
    return np.ascontiguousarray(np.concatenate([rgb, alpha], axis=2), dtype=np.float32)


def _halve(a, axis):
    """One MIP step along ``axis``: n texels -> max(1, floor(n / 2)), each output texel the
    exact box-filter average (area coverage) of the input texels under it.

    Even n: output i averages inputs 2i and 2i+1. Odd n = 2m + 1 (the non-power-of-two
    case): output i covers (2m+1)/m inputs starting at i (2m+1)/m, i.e. a polyphase 3-tap
    filter over inputs 2i, 2i+1, 2i+2 with weights (m - i, m, i + 1) / (2m + 1)
    (Nvidia, "Non-power-of-two mipmap creation", 2005). n = 1 stays."""
    n = a.shape[axis]
    if n == 1:
        return a
    a = np.moveaxis(a, axis, 0)
    m = n // 2
    if n % 2 == 0:
        out = 0.5 * (a[0::2] + a[1::2])
    else:
        i = np.arange(m, dtype=np.float64).reshape((m,) + (1,) * (a.ndim - 1))
        out = ((m - i) * a[0:2 * m:2] + m * a[1::2] + (i + 1) * a[2::2]) / n
    return np.moveaxis(out, 0, axis)


def mip_pyramid(level0) -> list[np.ndarray]:
    """Every MIP level of a (H, W, C) image, level 0 first, down to 1x1.

    Level l is (max(1, H >> l), max(1, W >> l)): each step floors n / 2, and odd
    sizes use the exact area-weighted 3-tap filter of :func:`_halve`, so every level
    is the box filter of level 0 over its texels' footprints (separable, in the
    values' own space: linear for every role). Computed in float64, returned float32.
    floor(log2(max(H, W))) + 1 levels."""
    levels = [np.asarray(level0, dtype=np.float32)]
    cur = np.asarray(level0, dtype=np.float64)
    while cur.shape[0] > 1 or cur.shape[1] > 1:
        cur = _halve(_halve(cur, 0), 1)
        levels.append(cur.astype(np.float32))
    return levels


def level_sizes(height, width):
    """[(h, w)] of every MIP level (as :func:`mip_pyramid` makes them)."""
    out = [(height, width)]
    while out[-1] != (1, 1):
        h, w = out[-1]
        out.append((max(1, h >> 1), max(1, w >> 1)))
    return out


def auto_colorspace(name, is_float, path, field):
    n = name.lower()
    if not n:
        return "linear" if is_float else "srgb"
    if any(k in n for k in _SRGB_NAMES):
        return "srgb"
    if any(k in n for k in _LINEAR_NAMES):
        return "linear"
    raise SceneError(f"{field}.colorspace: {path} is tagged with colour space {name!r}, neither sRGB nor "
                     "linear: pass colorspace='srgb' or 'linear'")


# --- procedural ----------------------------------------------------------------
def _procedural():
    p = _procedural_module
    return {
        "checker": (p.checker, "srgb"), "bricks": (p.bricks, "srgb"), "bricks_height": (p.bricks_height, "linear"),
        "noise": (p.value_noise, "linear"), "wood": (p.wood, "srgb"), "marble": (p.marble, "srgb"),
        "tiles": (p.tiles, "srgb"), "globe": (p.globe, "srgb"), "label": (p.label, "srgb"),
    }


PROCEDURAL = _procedural()


class Label:
    """The lecture's texture used as a label: composited over the material's diffuse colour,
    ``kd = lerp(kd, label.rgb, label.alpha)``, where its (transformed) coordinates fall in
    [0, 1]^2, and absent elsewhere (it appears once: no repeat, no clamp-to-edge streaks).

    ``uv_transform`` (a :class:`texray.UVTransform`) places it, replacing the texture's
    own; e.g. ``UVTransform(scale=(4, 4), offset=(-1.5, -1.5))`` shows it on the uv square
    [0.375, 0.625]^2. Textures without alpha are opaque labels."""

    def __init__(self, texture, uv_transform=None):
        if not isinstance(texture, Texture):
            raise SceneError(f"label.texture: expected a texray.Texture, got {texture!r}")
        if uv_transform is not None and not isinstance(uv_transform, UVTransform):
            raise SceneError(f"label.uv_transform: expected a texray.UVTransform, got {uv_transform!r}")
        self.texture, self.uv_transform = texture, uv_transform
        # Clamped lookups: the bilinear taps at the label's border never wrap to the other side.
        self.device_texture = texture.with_options(wrap="clamp", uv_transform=uv_transform)

    def __repr__(self):
        return f"Label({self.texture!r}, uv_transform={self.uv_transform!r})"
