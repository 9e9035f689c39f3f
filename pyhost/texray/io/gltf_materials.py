"""glTF materials as texray Materials (texray.io.gltf): the metallic-roughness rule,
textures with their samplers and KHR_texture_transform, normal maps, and the host-side
bakes where a glTF texture has no texray counterpart.

The rule (glTF 2.0 metallic-roughness -> the lecture's Phong constants), per point::

    baseColor = baseColorFactor.rgb * baseColorTexture.rgb (sRGB decoded)
    m = metallicFactor * metallicRoughnessTexture.b,  r = roughnessFactor * metallicRoughnessTexture.g
    kd = baseColor (1 - m)
    F0 = 0.04 (1 - m) + baseColor m                  (the glTF spec's specular reflectance)
    n  = (2 / alpha^2 - 2) / 4, alpha = r^2, clamped to [1, 2048]
    ks = F0 (2 n + 1) / 4

Why: Walter et al. 2007 (eq. 33) match a microfacet lobe of roughness alpha with a
normalized Blinn-Phong distribution D = (n' + 2) / 2pi (N.H)^n', n' = 2 / alpha^2 - 2. The
lecture's lobe is Phong's (R.V)^n, and (N.H)^n' ~ (R.V)^(n'/4) (the angle between R and V
is twice the angle between N and H), so n = n' / 4. Its height: at the highlight the
microfacet radiance is E F D / 4 (G = 1, N.V = 1), and texray's terms are pi times
radiance (the lecture's Lambert kd (N.L) has no 1/pi), so ks = pi F0 (n' + 2) / 8pi =
F0 (2 n + 1) / 4: smooth surfaces get small bright highlights, rough ones broad dim ones,
as in a glTF viewer, instead of the same peak F0 for all.

Constant factors give constants; textures are baked on the host (see :class:`MaterialBuilder`).

Coordinates: texray's v = 0 is an image's bottom row (row 0 = top, as read), glTF's
(0, 0) is its top-left corner, so texray's uv is (u, 1 - v) of glTF's (texray.io.gltf)
and every texture transform is re-expressed in those flipped coordinates
(:func:`uv_transform_from_gltf`).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError
from ..scene.bump import NormalMap
from ..scene.heightfield import wrap_index
from ..scene.mapping import UVTransform
from ..scene.material import Material
from ..scene.texture import Texture
from .. import validate as V
from .images import read_texture_bytes, read_texture_file

DIELECTRIC_F0 = 0.04                 # the glTF spec's specular reflectance of non-metals
SHININESS_MIN, SHININESS_MAX = 1.0, 2048.0

WRAP_MODES = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
MAG_FILTERS = (9728, 9729)                        # NEAREST, LINEAR
MIN_FILTERS = (9728, 9729, 9984, 9985, 9986, 9987)  # NEAREST, LINEAR, the four mipmapped ones
_IMAGE_SUFFIXES = {"image/png": ".png", "image/jpeg": ".jpg"}
_IGNORED_TEXTURES = ("occlusionTexture", "emissiveTexture")
IGNORED_TOPIC = "ignored (texray has no equivalent)"


# --- the rule -------------------------------------------------------------------------
def phong_exponent(roughness):
    """The Phong exponent n of glTF roughness r (array or number): alpha = r^2 (the spec's
    GGX alpha, read as Beckmann's), n = (2 / alpha^2 - 2) / 4 (Walter et al. 2007, eq. 33's
    Blinn-Phong exponent, over 4 for the lecture's (R.V)^n lobe), clamped to [1, 2048]; r is
    clipped to [0, 1] first."""
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    alpha2 = np.maximum(r ** 4, 1e-300)
    return np.clip((2.0 / alpha2 - 2.0) / 4.0, SHININESS_MIN, SHININESS_MAX)


def specular_scale(n):
    """ks / F0 for a Phong exponent n: (2 n + 1) / 4, the normalized lobe's peak in
    texray's units (module docstring)."""
    return (2.0 * np.asarray(n, dtype=np.float64) + 1.0) / 4.0


def metal_rough_to_phong(base_rgb, metallic, roughness):
    """(kd, ks, n) of the rule (module docstring), float64, broadcast: ``base_rgb`` (..., 3)
    linear, ``metallic`` and ``roughness`` (...)."""
    base = np.asarray(base_rgb, dtype=np.float64)
    m = np.clip(np.asarray(metallic, dtype=np.float64), 0.0, 1.0)[..., None]
    n = phong_exponent(roughness)
    f0 = DIELECTRIC_F0 * (1.0 - m) + base * m
    return base * (1.0 - m), f0 * specular_scale(n)[..., None], n


def uv_transform_from_gltf(offset=(0.0, 0.0), rotation=0.0, scale=(1.0, 1.0)):
    """The texray :class:`UVTransform` doing in texray's coordinates what
    KHR_texture_transform (``offset``, ``rotation`` in radians, ``scale``) does in glTF's.

    glTF: g(x) = T(offset) R S x with R = [[cos, sin], [-sin, cos]] (row-major): what the
    extension's example ("the lower left quadrant ... rotated clockwise 90 degrees"), its
    sample model TextureTransformTest, three.js, Babylon.js and Blender do. The GLSL
    listing of the extension, read column-major, is the transpose (KhronosGroup/glTF
    issue 1563); implementations follow the example.
    texray's coordinates are y = F(x) = D x + e, D = diag(1, -1), e = (0, 1), and F is its
    own inverse, so the texray map is t(y) = F(g(F(y))) = (D R D) S y + D R S e + D o + e.
    D R D = R(theta), the counter-clockwise rotation in texray's (u, v), and D S D = S:
    UVTransform(scale=S, rotation=degrees(theta)), whose affine part R(theta) (S y - c) + c
    + offset' (pivot c = (0.5, 0.5)) matches when offset' = D R S e + D o + e - c + R(theta) c.
    """
    sx, sy = (float(x) for x in scale)
    ox, oy = (float(x) for x in offset)
    c, s = math.cos(rotation), math.sin(rotation)
    r_gltf = np.array([[c, s], [-s, c]])
    d = np.diag([1.0, -1.0])
    e = np.array([0.0, 1.0])
    pivot = np.array([0.5, 0.5])
    r_tex = np.array([[c, -s], [s, c]])
    t = d @ r_gltf @ (np.array([sx, sy]) * e) + d @ np.array([ox, oy]) + e
    off = t - pivot + r_tex @ pivot
    return UVTransform(scale=(sx, sy), offset=(float(off[0]), float(off[1])), rotation=math.degrees(rotation))


def gltf_uv_transform_apply(uv, offset=(0.0, 0.0), rotation=0.0, scale=(1.0, 1.0)):
    """KHR_texture_transform applied to (..., 2) glTF coordinates (the reference of
    :func:`uv_transform_from_gltf`): T(offset) R S uv, R = [[cos, sin], [-sin, cos]]."""
    uv = np.asarray(uv, dtype=np.float64) * np.asarray(scale, dtype=np.float64)
    c, s = math.cos(rotation), math.sin(rotation)
    return np.stack([c * uv[..., 0] + s * uv[..., 1], -s * uv[..., 0] + c * uv[..., 1]], axis=-1) + \
        np.asarray(offset, dtype=np.float64)


def sampler_options(wrap_s, wrap_t, mag_filter, min_filter):
    """(texray wrap, texray filter, whether wrap_t was overridden) of glTF sampler values
    (None = absent): one wrap mode for both axes (wrapS's); magFilter NEAREST -> "nearest",
    minFilter NEAREST/LINEAR (no MIP maps) -> "bilinear", mipmapped or absent -> "trilinear"."""
    wrap = WRAP_MODES[wrap_s]
    if mag_filter == 9728:
        filt = "nearest"
    elif min_filter in (9728, 9729):
        filt = "bilinear"
    else:
        filt = "trilinear"
    return wrap, filt, wrap_s != wrap_t


def _floats(v):
    return tuple(float(x) for x in v)


# --- numpy texture lookups (the bakes) ---------------------------------------------------
def bilinear(rgba, uv, wrap):
    """texture/texture.h's bilinear lookup of level 0 in numpy: ``rgba`` (H, W, C), row 0 =
    top, ``uv`` (..., 2) texray coordinates (v = 0 the bottom row), ``wrap`` a texray mode."""
    h, w = rgba.shape[:2]
    uv = np.asarray(uv, dtype=np.float64)
    x = uv[..., 0] * w - 0.5
    y = (1.0 - uv[..., 1]) * h - 0.5
    fx, fy = np.floor(x), np.floor(y)
    ax, ay = (x - fx)[..., None], (y - fy)[..., None]
    x0, y0 = fx.astype(np.int64), fy.astype(np.int64)
    x0, x1 = wrap_index(x0, w, wrap), wrap_index(x0 + 1, w, wrap)
    y0, y1 = wrap_index(y0, h, wrap), wrap_index(y0 + 1, h, wrap)
    a = np.asarray(rgba, dtype=np.float64)
    return (a[y0, x0] * (1 - ax) + a[y0, x1] * ax) * (1 - ay) + (a[y1, x0] * (1 - ax) + a[y1, x1] * ax) * ay


def texel_centres(height, width):
    """(H, W, 2) texray coordinates of the texel centres of an image, row 0 = top."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    return np.stack(np.broadcast_arrays(u[None, :], v[:, None]), axis=-1)


def _affine(uv_transform):
    m = np.eye(3)
    if uv_transform is not None:
        m[:2] = uv_transform.matrix()
    return m


def transfer_coordinates(uv, from_transform, to_transform):
    """Coordinates of texture A's lookup points (``uv``, after A's ``from_transform``) in
    texture B's (after ``to_transform``), both textures reading the same surface uv."""
    m = _affine(to_transform) @ np.linalg.inv(_affine(from_transform))
    return uv @ m[:2, :2].T + m[:2, 2]


def bake_scaled_normals(rgb, scale):
    """A tangent-space normal map's texels with glTF's normalTexture.scale applied:
    normalize((2 c - 1) * (scale, scale, 1)), re-encoded to [0, 1] (0.5 (n + 1)); texels
    encoding the zero vector become the flat normal (0.5, 0.5, 1)."""
    c = (2.0 * np.asarray(rgb, dtype=np.float64)[..., :3] - 1.0) * np.array([scale, scale, 1.0])
    length = np.linalg.norm(c, axis=-1, keepdims=True)
    n = np.where(length > 0, c / np.where(length > 0, length, 1.0), np.array([0.0, 0.0, 1.0]))
    return 0.5 * (n + 1.0)


# --- glTF textures ---------------------------------------------------------------------
class TexRef:
    """A textureInfo resolved: the texray Texture (the image's pixels with the sampler's
    wrap and filter and the transform), and what it came from."""

    def __init__(self, texture, image, jpath):
        self.texture, self.image, self.jpath = texture, image, jpath


class MaterialBuilder:
    """glTF materials of one file as texray Materials, made once per material index; each
    glTF image is decoded once into one Texture, whose variants (wrap, filter, transform)
    share its pixels (Texture.with_options)."""

    def __init__(self, doc, notes):
        self.doc, self.notes = doc, notes
        self._materials, self._images, self._variants = {}, {}, {}

    # --- images and textures ---
    def _image(self, k, who):
        if k in self._images:
            return self._images[k]
        doc = self.doc
        img = doc.item("images", k)
        where = f"images[{k}]"
        field = f"{doc.label}: {who}: {where}"
        mime = doc.get(img, "mimeType", where, "str", None)
        if "uri" in img:
            uri = doc.get(img, "uri", where, "str")
            if uri.startswith("data:"):
                data, mime_uri, _ = doc.uri_bytes(uri, f"{where}.uri")
                pixels, _, is_float = read_texture_bytes(data, self._suffix(data, mime_uri or mime, where), field,
                                                         f"{where} (its data: URI)")
            else:
                try:
                    path = doc.uri_path(uri, f"{where}.uri")
                except SceneError as e:
                    raise SceneError(f"{doc.label}: {who}: {str(e)[len(doc.label) + 2:]}") from None
                pixels, _, is_float = read_texture_file(path, field)
        elif "bufferView" in img:
            view = doc.ref(img, "bufferView", where, "bufferViews")
            data, start, length, _ = doc.buffer_view(view, f"{where}.bufferView")
            data = bytes(data[start:start + length])
            pixels, _, is_float = read_texture_bytes(data, self._suffix(data, mime, where), field,
                                                     f"{where} (bufferViews[{view}])")
        else:
            raise doc.error(where, "neither a uri nor a bufferView")
        # glTF: colour textures are sRGB-encoded 8/16-bit images; data roles (metallic-
        # roughness, normals) read the stored values whatever this says (texray.texture).
        colorspace = "linear" if is_float else "srgb"
        name = f"{doc.label}: {doc.name_of('images', k)}"
        tex = Texture(pixels, name=name, colorspace=colorspace, field=field)
        self._images[k] = tex
        return tex

    def _suffix(self, data, mime, where):
        if mime in _IMAGE_SUFFIXES:
            return _IMAGE_SUFFIXES[mime]
        if data[:8] == b"\x89PNG\r\n\x1a\n":
            return ".png"
        if data[:3] == b"\xff\xd8\xff":
            return ".jpg"
        if isinstance(mime, str) and mime.startswith("image/") and mime[6:].isalnum():
            return "." + mime[6:]
        raise self.doc.error(where, f"image of unknown type (mimeType {mime!r}; texray reads PNG and JPEG)")

    def _sampler(self, index, where):
        doc = self.doc
        if index is None:
            return "repeat", "trilinear"
        s = doc.item("samplers", index, where)
        sw = f"samplers[{index}]"
        vals = {}
        for key, allowed, default in (("wrapS", WRAP_MODES, 10497), ("wrapT", WRAP_MODES, 10497),
                                      ("magFilter", MAG_FILTERS, None), ("minFilter", MIN_FILTERS, None)):
            v = doc.get(s, key, sw, "int", default)
            if v is not None and v not in allowed:
                raise doc.error(f"{sw}.{key}", f"{v} is not a glTF {key} ({', '.join(map(str, allowed))})")
            vals[key] = v
        wrap, filt, differ = sampler_options(vals["wrapS"], vals["wrapT"], vals["magFilter"], vals["minFilter"])
        if differ:
            self.notes.add("texray has one wrap mode for both axes: wrapS is used for both",
                           f"wrapS {vals['wrapS']} / wrapT {vals['wrapT']}", sw)
        return wrap, filt

    def texture(self, info, jpath, who):
        """The TexRef of a textureInfo (None if the texture has no image texray reads)."""
        doc = self.doc
        if not isinstance(info, dict):
            raise doc.error(jpath, f"expected an object, got {info!r}")
        ti = doc.ref(info, "index", jpath, "textures")
        t = doc.item("textures", ti)
        tw = f"textures[{ti}]"
        tex_coord = doc.get(info, "texCoord", jpath, "int", 0)
        ext = doc.get(info, "extensions", jpath, "dict", {})
        uvt = None
        if "KHR_texture_transform" in ext:
            xw = f"{jpath}.extensions.KHR_texture_transform"
            x = doc.get(ext, "KHR_texture_transform", f"{jpath}.extensions", "dict")
            offset = doc.numbers(x, "offset", xw, 2, np.zeros(2))
            rotation = doc.number(x, "rotation", xw, 0.0)
            scale = doc.numbers(x, "scale", xw, 2, np.ones(2))
            tex_coord = doc.get(x, "texCoord", xw, "int", tex_coord)
            if np.any(scale == 0):
                raise doc.error(f"{xw}.scale", f"{V.show(scale)}: a zero scale maps the whole surface to one "
                                "line of the texture")
            if np.any(offset != 0) or rotation != 0 or np.any(scale != 1):
                try:
                    uvt = uv_transform_from_gltf(offset, rotation, scale)
                except SceneError as e:          # e.g. an offset beyond float32: name the file and field
                    raise doc.error(xw, f"offset {V.show(offset)}, rotation {rotation!r}, scale {V.show(scale)}: "
                                    f"{e}") from None
        if tex_coord != 0:
            self.notes.add("texray reads TEXCOORD_0 only: textures of other sets use TEXCOORD_0",
                           f"texCoord {tex_coord}", f"{who} {jpath.split('.')[-1]}")
        if "source" not in t:
            exts = ", ".join(doc.get(t, "extensions", tw, "dict", {})) or "none"
            self.notes.add("textures without a core source image (PNG/JPEG) ignored",
                           f"{tw} (extensions: {exts})", who)
            return None
        k = doc.ref(t, "source", tw, "images")
        wrap, filt = self._sampler(doc.ref(t, "sampler", tw, "samplers", None), f"{tw}.sampler")
        key = (k, wrap, filt, None if uvt is None else tuple(uvt.matrix().ravel()))
        if key not in self._variants:
            self._variants[key] = self._image(k, who).with_options(wrap=wrap, filter=filt, uv_transform=uvt)
        return TexRef(self._variants[key], k, jpath)

    # --- materials ---
    def material(self, index):
        """The texray Material of materials[index] (None: glTF's default material). Every
        SceneError names the file (texray's own checks of a texture, transform or material
        don't know it)."""
        if index not in self._materials:
            try:
                self._materials[index] = self._build(index)
            except SceneError as e:
                if str(e).startswith(self.doc.label):
                    raise
                raise self.doc.error(f"materials[{index}]", str(e)) from None
        return self._materials[index]

    def _build(self, index):
        doc = self.doc
        if index is None:
            # glTF's default material is a white, fully rough metal (kd 0, ks 1, n 1 by the rule
            # above): a broad grey sheen that reads as a bug. Primitives without a material get
            # texray's default grey diffuse material instead, as viewers show them.
            return Material()
        else:
            mat = doc.item("materials", index)
            where = who = f"materials[{index}]"
            who = doc.name_of("materials", index)
        pbr = doc.get(mat, "pbrMetallicRoughness", where, "dict", {})
        pw = f"{where}.pbrMetallicRoughness"
        factor = doc.numbers(pbr, "baseColorFactor", pw, 4, np.ones(4))
        if np.any(factor < 0) or np.any(factor > 1):
            raise doc.error(f"{pw}.baseColorFactor", f"{V.show(factor)}: expected numbers in [0, 1]")
        metallic = doc.number(pbr, "metallicFactor", pw, 1.0, 0.0, 1.0)
        roughness = doc.number(pbr, "roughnessFactor", pw, 1.0, 0.0, 1.0)
        base = self.texture(pbr["baseColorTexture"], f"{pw}.baseColorTexture", who) \
            if "baseColorTexture" in pbr else None
        mr = self.texture(pbr["metallicRoughnessTexture"], f"{pw}.metallicRoughnessTexture", who) \
            if "metallicRoughnessTexture" in pbr else None
        self._note_ignored(mat, where, who)
        kw = self._phong(factor[:3], metallic, roughness, base, mr, who)
        if "normalTexture" in mat:
            kw["normal_map"] = self._normal_map(mat["normalTexture"], f"{where}.normalTexture", who)
        try:
            return Material(**kw)
        except SceneError as e:
            raise SceneError(f"{doc.label}: {who}: {e}") from None

    def _note_ignored(self, mat, where, who):
        doc = self.doc
        for key in _IGNORED_TEXTURES:
            if key in mat:
                self.notes.add(IGNORED_TOPIC, key, who)
        emissive = doc.numbers(mat, "emissiveFactor", where, 3, np.zeros(3))
        if np.any(emissive != 0):
            self.notes.add(IGNORED_TOPIC, "emissiveFactor", who)
        for name in doc.get(mat, "extensions", where, "dict", {}):
            self.notes.add(IGNORED_TOPIC, name, who)
        mode = doc.get(mat, "alphaMode", where, "str", "OPAQUE")
        if mode not in ("OPAQUE", "MASK", "BLEND"):
            raise doc.error(f"{where}.alphaMode", f"{mode!r} (expected OPAQUE, MASK or BLEND)")
        if mode != "OPAQUE":
            self.notes.add("texray renders opaque surfaces: alpha ignored", f"alphaMode {mode}", who)

    def _phong(self, factor, metallic, roughness, base, mr, who):
        """Material keyword arguments of the rule (module docstring) for constant factors
        and/or the base colour and metallic-roughness textures.

        Bakes (numpy, on the host; each gives a float32 linear texture):
        * metallic-roughness texture: ks per texel of it, with baseColorFactor as the
          metal's colour (a base colour texture does not tint the metal's highlight:
          approximation); shininess = n_max and shininess_map = n(r_texel) / n_max;
          without a base colour texture, kd = factor (1 - m) per texel of it too.
        * base colour texture and a metallic-roughness texture: kd = base x factor x
          (1 - m) per texel of the base colour texture, m bilinear from the
          metallic-roughness texture at the same surface point (each texture's transform
          undone and applied; both read TEXCOORD_0).
        * base colour texture, constant m > 0: ks = (0.04 (1 - m) + base x factor x m) x
          (2 n + 1) / 4 per texel of the base colour texture (m = 0: a constant).
        Filtering a bake is not baking the filtered textures (kd, ks are products of
        filtered values in glTF renderers): texel-scale approximation."""
        if mr is None and base is None:
            kd, ks, n = metal_rough_to_phong(factor, metallic, roughness)
            return dict(diffuse=_floats(kd), specular=_floats(ks), shininess=float(n))
        if mr is None:
            n = float(phong_exponent(roughness))
            kw = dict(diffuse=base.texture, tint=_floats(factor * (1.0 - metallic)), shininess=n)
            if metallic == 0:
                kw["specular"] = float(DIELECTRIC_F0 * specular_scale(n))
            else:
                b = base.texture
                ks = (DIELECTRIC_F0 * (1 - metallic) + b.rgba[:, :, :3] * factor * metallic) * specular_scale(n)
                kw["specular"] = self._baked(ks, b, f"{who} ks")
            return kw
        t = mr.texture
        data = t.levels("data", mip=False)[0]
        m = np.clip(metallic * data[:, :, 2].astype(np.float64), 0.0, 1.0)
        r = np.clip(roughness * data[:, :, 1].astype(np.float64), 0.0, 1.0)
        _, ks, n = metal_rough_to_phong(factor, m, r)
        n_max = float(n.max())
        kw = dict(specular=self._baked(ks, t, f"{who} ks"), shininess=n_max,
                  shininess_map=self._baked(n / n_max, t, f"{who} shininess"))
        if base is None:
            kw["diffuse"] = self._baked(factor * (1.0 - m)[:, :, None], t, f"{who} kd")
        else:
            b = base.texture
            h, w = b.shape
            uv = transfer_coordinates(texel_centres(h, w), b.uv_transform, t.uv_transform)
            m_at = np.clip(metallic * bilinear(data[:, :, 2:3], uv, t.wrap)[:, :, 0], 0.0, 1.0)
            kw["diffuse"] = self._baked(b.rgba[:, :, :3] * factor * (1.0 - m_at)[:, :, None], b, f"{who} kd")
        return kw

    def _baked(self, values, like, what):
        """A float32 linear texture of baked ``values`` with the sampler options and
        transform of the texture ``like`` it was baked on."""
        return Texture.from_array(np.asarray(values, dtype=np.float32), colorspace="linear",
                                  name=f"{self.doc.label}: {what} (baked)", wrap=like.wrap,
                                  uv_transform=like.uv_transform, filter=like.filter, field=f"{self.doc.label}: {what}")

    def _normal_map(self, info, jpath, who):
        """texray NormalMap of a normalTexture.

        Green is NOT inverted (convention "opengl"): glTF's normal textures are "+Y up",
        green toward the image's top row (decreasing glTF v; the spec's bitangent, and why
        three.js negates MikkTSpace's sign for glTF's v-down coordinates). texray's
        tangent-space y runs along the bitangent on dP/dv's side (kernels/shading/bump.h),
        v being texray's, which is 1 - v_gltf with the image as read: increasing texray v
        also runs toward the image's top row. The v flip reverses dP/dv, and texray's y
        follows it, so both "up"s are the same direction on the surface; a "directx"
        (green-down) reading would tilt every normal the wrong way along the bitangent
        (tests/unit/test_gltf.py checks a tilted texel against glTF's frame)."""
        ref = self.texture(info, jpath, who)
        if ref is None:
            return None
        scale = self.doc.number(info, "scale", jpath, 1.0)
        t = ref.texture
        if t.channels < 3:
            raise SceneError(f"{self.doc.label}: {who}: {jpath}: {t.name} has {t.channels} channel(s); a normal map "
                             "needs 3 (RGB) or 4")
        if scale != 1.0:
            t = self._baked(bake_scaled_normals(t.levels("data", mip=False)[0], scale), t,
                            f"{who} normals x {scale:g}")
        return NormalMap(t, convention="opengl", space="tangent")
