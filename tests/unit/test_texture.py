"""texray.texture on the host: files, colour spaces per role, MIP pyramids, packing, errors.

* sRGB decode/encode round-trips (every 8-bit code, and floats);
* the MIP pyramid equals an independent float64 reference (exact area integration of the
  piecewise-constant previous level through cumulative sums), odd and non-square sizes included;
* every supported format / bit depth / channel count, written with OpenImageIO into tmp_path,
  loads to the written values within the format's quantization, with the colour space the
  file implies;
* roles: colour decodes sRGB, data keeps stored values, labels are premultiplied; a texture in
  two kinds is packed twice, variants of one texture once; only trilinear textures get levels;
* errors name the file, field and value: corrupt and truncated files, a wrong channel count,
  non-finite texels, textures beyond the device's buffer size or the 32-bit texel offsets.
"""
from __future__ import annotations

import copy
import pickle
import re

import numpy as np
import OpenImageIO as oiio
import pytest
import texray as tx
from scenes_for_tests import quad
from texray.compile import textures as packing
from texray.scene import texture as txt
from texray.io.colour import linear_to_srgb, srgb_to_linear
from texray.compile import compile_scene
from texray.errors import SceneError


def _write(path, data, fmt, unassociated=True, colorspace=None):
    h, w, c = data.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    if unassociated:
        spec.attribute("oiio:UnassociatedAlpha", 1)
    if colorspace:
        spec.attribute("oiio:ColorSpace", colorspace)
    if str(path).endswith(".jpg"):            # best quality, no chroma subsampling
        spec.attribute("Compression", "jpeg:100")
        spec.attribute("jpeg:subsampling", "4:4:4")
    out = oiio.ImageOutput.create(str(path))
    assert out is not None and out.open(str(path), spec), oiio.geterror()
    assert out.write_image(np.ascontiguousarray(data, np.float32))
    out.close()


def _scene(material, uv_repeat=1.0):
    p, f, uv = quad(0.0, 1.0, uv_repeat)
    scene = tx.Scene(camera=tx.Camera(eye=(0, 3, 0.01), look_at=(0, 0, 0)))
    scene.add(tx.Mesh(p, f, uvs=uv, material=material, name="floor"))
    return scene


# --- colour ------------------------------------------------------------------
def test_srgb_round_trips():
    codes = np.arange(256) / 255.0
    back = np.round(linear_to_srgb(srgb_to_linear(codes)) * 255.0)
    np.testing.assert_array_equal(back, np.arange(256))
    x = np.linspace(0, 1, 10001)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(x)), x, atol=2e-6)
    # IEC 61966-2-1 anchor points: the linear segment's end and mid-grey.
    assert srgb_to_linear(0.04045) == pytest.approx(0.04045 / 12.92, rel=1e-6)
    assert srgb_to_linear(0.5) == pytest.approx(((0.5 + 0.055) / 1.055) ** 2.4, rel=1e-6)


def test_roles_decode_per_kind():
    raw = np.random.default_rng(3).uniform(0, 1, (4, 5, 4)).astype(np.float32)
    t = tx.Texture.from_array(raw, colorspace="srgb")
    colour, data, label = t.levels("colour", False)[0], t.levels("data", False)[0], t.levels("label", False)[0]
    np.testing.assert_allclose(colour[..., :3], srgb_to_linear(raw[..., :3]), rtol=1e-6)
    np.testing.assert_array_equal(colour[..., 3], raw[..., 3])             # alpha is never decoded
    np.testing.assert_array_equal(data, raw)                                # data roles: stored values
    np.testing.assert_allclose(label[..., :3], colour[..., :3] * raw[..., 3:], rtol=1e-6)   # premultiplied
    grey = tx.Texture.from_array(raw[..., 0])
    np.testing.assert_array_equal(grey.rgba, np.concatenate([raw[..., [0, 0, 0]], np.ones((4, 5, 1))], -1))
    ga = tx.Texture.from_array(raw[..., :2])
    np.testing.assert_array_equal(ga.rgba[..., 3], raw[..., 1])


# --- MIP pyramid ---------------------------------------------------------------
def _area_halve(a, axis):
    """float64 reference of one MIP step: output i is the mean of the piecewise-constant input
    over [i n / m, (i + 1) n / m] (m = max(1, n // 2)), by differences of its integral."""
    a = np.moveaxis(np.asarray(a, np.float64), axis, 0)
    n = a.shape[0]
    m = max(1, n // 2)
    cum = np.concatenate([np.zeros((1,) + a.shape[1:]), np.cumsum(a, axis=0)])

    def integral(x):                       # integral of the input over [0, x], x in texels
        i = np.minimum(np.floor(x).astype(int), n - 1)
        frac = (x - i).reshape((-1,) + (1,) * (a.ndim - 1))
        return cum[i] + frac * a[i]

    edges = np.arange(m + 1) * (n / m)
    out = (integral(edges[1:]) - integral(edges[:-1])) / (n / m)
    return np.moveaxis(out, 0, axis)


@pytest.mark.parametrize("shape", [(1, 1), (2, 2), (8, 8), (5, 7), (7, 3), (1, 9), (13, 1), (6, 11), (33, 20)])
def test_mip_pyramid_matches_area_reference(shape, rng):
    img = rng.uniform(0, 1, shape + (4,)).astype(np.float32)
    levels = txt.mip_pyramid(img)
    assert [lv.shape[:2] for lv in levels] == txt.level_sizes(*shape)
    assert len(levels) == int(np.floor(np.log2(max(shape)))) + 1
    assert levels[-1].shape[:2] == (1, 1)
    np.testing.assert_array_equal(levels[0], img)
    ref = img.astype(np.float64)
    for lv in levels[1:]:
        ref = _area_halve(_area_halve(ref, 0), 1)
        np.testing.assert_allclose(lv, ref, rtol=1e-6, atol=1e-7)


def test_mip_pyramid_keeps_constants_and_means():
    np.testing.assert_allclose(txt.mip_pyramid(np.full((9, 5, 4), 0.3, np.float32))[-1], 0.3, rtol=1e-6)
    img = np.random.default_rng(0).uniform(size=(16, 8, 4))
    for lv in txt.mip_pyramid(img):             # power-of-two sizes: every level keeps the mean
        np.testing.assert_allclose(lv.mean(axis=(0, 1)), img.mean(axis=(0, 1)), rtol=1e-6)


# --- files -------------------------------------------------------------------------
# (extension, OIIO format, channels, absolute tolerance or None for relative, expected colour space)
_FORMATS = [
    ("png", "uint8", c, 0.5 / 255 + 1e-6, "srgb") for c in (1, 2, 3, 4)] + [
    ("png", "uint16", c, 0.5 / 65535 + 1e-7, "srgb") for c in (1, 2, 3, 4)] + [
    ("tif", "uint8", c, 0.5 / 255 + 1e-6, "srgb") for c in (1, 2, 3, 4)] + [
    ("tif", "uint16", c, 0.5 / 65535 + 1e-7, "srgb") for c in (1, 3, 4)] + [
    ("tif", "half", c, None, "linear") for c in (1, 4)] + [
    ("tif", "float", c, 1e-7, "linear") for c in (1, 2, 3, 4)] + [
    ("exr", "half", c, None, "linear") for c in (1, 2, 3, 4)] + [
    ("exr", "float", c, 1e-7, "linear") for c in (1, 3, 4)] + [
    ("jpg", "uint8", c, 3.0 / 255, "srgb") for c in (1, 3)] + [
    ("hdr", "float", 3, "rgbe", "linear")]


@pytest.mark.parametrize("ext,fmt,channels,tol,colorspace", _FORMATS,
                         ids=[f"{e}-{f}-{c}" for e, f, c, _, _ in _FORMATS])
def test_every_format_loads_the_written_values(tmp_path, ext, fmt, channels, tol, colorspace):
    h, w = 12, 17
    y, x = np.mgrid[0:h, 0:w]
    # Smooth ramps (JPEG's DCT keeps them within a few codes), distinct per channel; alpha in
    # [0.5, 1] so that un-premultiplying EXR colour stays well conditioned.
    data = np.stack([(x + 2 * y) / (w + 2 * h), (w - x) / w, (y + 1) / (h + 1), 0.5 + 0.5 * x / w], -1)
    data = data[..., [0, 3] if channels == 2 else slice(0, channels)].astype(np.float32)
    if ext == "hdr":
        data = data * 4.0                     # HDR holds any positive value
    written = data.copy()
    if ext == "exr" and channels == 4:        # EXR colour is premultiplied by convention (RGBA)
        written[..., :-1] *= written[..., -1:]
    path = tmp_path / f"t.{ext}"
    _write(path, written, fmt)
    t = tx.Texture.load(path)
    assert t.colorspace == colorspace and t.channels == channels and t.shape == (h, w)
    if tol is None:                           # half: 11 significant bits (and the un-premultiply)
        np.testing.assert_allclose(t.raw, data, rtol=2.0 ** -10, atol=1e-7)
    elif tol == "rgbe":                       # shared exponent: 8 bits relative to the largest channel
        np.testing.assert_allclose(t.raw, data, atol=data.max(-1, keepdims=True).max() / 128)
    else:
        np.testing.assert_allclose(t.raw, data, atol=tol, rtol=0)
    # The role decode follows the colour space.
    expect = srgb_to_linear(t.raw[..., :3]) if colorspace == "srgb" else t.raw[..., :3]
    if channels >= 3:
        np.testing.assert_allclose(t.rgba[..., :3], expect, rtol=1e-6)


def test_colorspace_override_and_tagged_files(tmp_path):
    data = np.full((4, 4, 3), 0.5, np.float32)
    _write(tmp_path / "a.png", data, "uint8")
    assert tx.Texture.load(tmp_path / "a.png", colorspace="linear").rgba[0, 0, 0] == pytest.approx(128 / 255)
    assert tx.Texture.load(tmp_path / "a.png").rgba[0, 0, 0] == pytest.approx(srgb_to_linear(128 / 255))
    _write(tmp_path / "lin.png", data, "uint8", colorspace="lin_rec709")      # 8-bit, tagged linear
    assert tx.Texture.load(tmp_path / "lin.png").colorspace == "linear"
    _write(tmp_path / "srgb.exr", data, "half", colorspace="sRGB")             # float, tagged sRGB
    assert tx.Texture.load(tmp_path / "srgb.exr").colorspace == "srgb"
    _write(tmp_path / "g22.png", data, "uint8", colorspace="g22_rec709")
    with pytest.raises(SceneError, match=r"texture\.colorspace: .*g22\.png is tagged with colour space "
                                         r"'g22_rec709_scene', neither sRGB nor linear"):
        tx.Texture.load(tmp_path / "g22.png")
    assert tx.Texture.load(tmp_path / "g22.png", colorspace="srgb").colorspace == "srgb"
    with pytest.raises(SceneError, match=r"texture\.colorspace: expected one of auto, srgb, linear, got 'rec'"):
        tx.Texture.load(tmp_path / "a.png", colorspace="rec")


# --- errors ------------------------------------------------------------------------
def test_corrupt_and_truncated_files_are_errors(tmp_path, rng):
    (tmp_path / "junk.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(200)))
    with pytest.raises(SceneError, match=r"texture\.file: cannot read image .*junk\.png"):
        tx.Texture.load(tmp_path / "junk.png")
    noise = rng.uniform(size=(96, 96, 3)).astype(np.float32)
    for ext, fmt in (("png", "uint8"), ("tif", "uint16"), ("exr", "half"), ("jpg", "uint8")):
        full = tmp_path / f"full.{ext}"
        _write(full, noise, fmt)
        cut = tmp_path / f"cut.{ext}"
        cut.write_bytes(full.read_bytes()[: full.stat().st_size * 3 // 5])
        with pytest.raises(SceneError, match=rf"textures\.t\.file: .*cut\.{ext}"):
            tx.Texture.load(cut, field="textures.t")


def test_non_finite_texels_are_errors(tmp_path):
    a = np.zeros((3, 4, 3), np.float32)
    a[1, 2, 0] = np.inf
    with pytest.raises(SceneError, match=r"non-finite texel inf at row 1, column 2, channel 0"):
        tx.Texture.from_array(a)
    _write(tmp_path / "inf.exr", a, "float")
    with pytest.raises(SceneError, match=r"inf\.exr: non-finite texel inf at row 1, column 2"):
        tx.Texture.load(tmp_path / "inf.exr")


def test_bad_arguments_name_the_field():
    with pytest.raises(SceneError, match=r"texture\.filter: <array>: expected one of nearest, bilinear, trilinear, "
                                         r"anisotropic, got 'cubic'"):
        tx.Texture.from_array(np.ones((2, 2)), filter="cubic")
    with pytest.raises(SceneError, match=r"expected an \(H, W\) or \(H, W, 1\.\.4\) image, got shape \(2, 2, 5\)"):
        tx.Texture.from_array(np.ones((2, 2, 5)))
    with pytest.raises(SceneError, match=r"label\.texture: expected a texray\.Texture"):
        tx.Label("logo.png")
    with pytest.raises(SceneError, match=r"render: texture_filter: expected None or one of .*got 'box'"):
        compile_scene(_scene(tx.Material(diffuse=tx.Texture.from_array(np.ones((2, 2))))), texture_filter="box")


def test_wrong_channel_count_for_the_role():
    rgb = tx.Texture.from_array(np.ones((4, 4, 3)), name="spec.png")
    with pytest.raises(SceneError, match=r"shininess_map: spec\.png has 3 channels; a shininess map takes 1"):
        tx.Material(shininess=40, shininess_map=rgb).validate()
    neg = tx.Texture.from_array(-np.ones((4, 4)), name="neg.exr")
    with pytest.raises(SceneError, match=r"neg\.exr: shininess_map values must be >= 0.*got -1\.0"):
        compile_scene(_scene(tx.Material(shininess_map=neg)))


def test_textures_beyond_the_device_or_32_bit_offsets(monkeypatch):
    big = tx.Texture.from_array(np.ones((64, 64, 3)), name="huge.exr", filter="trilinear")
    cs = compile_scene(_scene(tx.Material(diffuse=big)))
    with pytest.raises(SceneError, match=r"textures: huge\.exr: 43688 bytes of texels .* exceed the device's "
                                         r"largest buffer, 40000 bytes"):
        packing.check_device_limits(cs.texels.nbytes, ["huge.exr"], 40000)
    packing.check_device_limits(cs.texels.nbytes, ["huge.exr"], cs.texels.nbytes)       # fits exactly
    monkeypatch.setattr(packing, "MAX_TEXELS", 5000)
    with pytest.raises(SceneError, match=r"texture: huge\.exr: .* 5000 that 32-bit texel offsets address"):
        compile_scene(_scene(tx.Material(diffuse=big)))


def test_render_checks_the_texel_buffer_against_the_device(monkeypatch):
    import sys
    r = sys.modules["texray.renderer.frame"]           # where render() checks the device (frame.device_program)
    seen = {}

    def check(nbytes, names, max_alloc):
        seen.update(nbytes=nbytes, names=names, max_alloc=max_alloc)
        packing.check_device_limits(nbytes, names, 100)
    monkeypatch.setattr(r, "check_device_limits", check)
    tex = tx.Texture.from_array(np.ones((8, 8, 3)), name="wall.png")
    with pytest.raises(SceneError, match=r"wall\.png: 512 bytes of texels"):
        tx.render(_scene(tx.Material(diffuse=tex)), 8, 8, device="cpu")
    assert seen["nbytes"] == 8 * 8 * 8 and seen["names"] == ["wall.png"] and seen["max_alloc"] > 0


# --- packing ---------------------------------------------------------------------
def test_packing_per_kind_and_variant():
    rng = np.random.default_rng(1)
    grey = tx.Texture.from_array(rng.uniform(size=(8, 6)), colorspace="srgb", name="g")
    shifted = grey.with_options(uv_transform=tx.UVTransform(offset=(0.5, 0)))
    # diffuse + specular (colour) share texels; shininess (data) is packed again
    cs = compile_scene(_scene(tx.Material(diffuse=grey, specular=shifted, shininess_map=grey)))
    assert len(cs.textures) == 3 and cs.texels.size == 2 * 8 * 6 * 4
    assert cs.textures["offset"][0] == cs.textures["offset"][1] != cs.textures["offset"][2]
    m = cs.materials[0]
    assert (m["diffuse_tex"], m["specular_tex"], m["shininess_tex"], m["label_tex"]) == (0, 1, 2, -1)
    f = cs.features
    assert f.specular_maps and f.shininess_maps and not f.labels and f.specular
    assert f.filter_bilinear and not f.filter_nearest and not f.filter_trilinear
    texels = cs.texels.astype(np.float64).reshape(-1, 4)
    np.testing.assert_allclose(texels[:48, 0], srgb_to_linear(grey.raw[..., 0]).ravel(), rtol=1e-3)
    np.testing.assert_allclose(texels[48:, 0], grey.raw[..., 0].ravel(), rtol=1e-3)   # data: not decoded
    # only the label role present: its premultiplied texels only
    rgba = rng.uniform(size=(4, 4, 4)).astype(np.float32)
    cs = compile_scene(_scene(tx.Material(label=tx.Label(tx.Texture.from_array(rgba)))))
    assert cs.features.labels and not cs.features.specular_maps and cs.textures["wrap"][0] == 1   # clamp
    np.testing.assert_allclose(cs.texels.astype(np.float64).reshape(4, 4, 4)[..., :3],
                               rgba[..., :3] * rgba[..., 3:], rtol=1e-3)
    # no texture, nothing uploaded
    cs = compile_scene(_scene(tx.Material()))
    assert cs.textures is None and "texels" not in cs.device_bytes()


def test_packed_texels_are_the_levels_in_half_floats_converted_once():
    rng = np.random.default_rng(5)
    colour = tx.Texture.from_array(rng.uniform(size=(8, 6, 3)) * 3, colorspace="linear", name="c")
    tri = colour.with_options(filter="trilinear")
    hdr = tx.Texture.from_array(np.full((2, 3), txt.HALF_MAX), colorspace="srgb", name="hdr")
    scene = _scene(tx.Material(diffuse=tri, specular=colour, shininess_map=hdr))
    cs = compile_scene(scene)
    # the reference: every packed level in float32, clamped to the half range, then converted
    levels = tri.levels("colour", mip=True) + hdr.levels("data", mip=False)
    ref = np.clip(np.concatenate([lv.reshape(-1) for lv in levels]), -txt.HALF_MAX, txt.HALF_MAX)
    np.testing.assert_array_equal(cs.texels, ref.astype(np.float16))
    assert np.isfinite(cs.texels.astype(np.float32)).all()
    # the conversion is kept on the texture's pixels: compiling again converts nothing
    a = tri.half_texels("colour", mip=True)
    assert a is colour.half_texels("colour", mip=True) and not a.flags.writeable
    cs2 = compile_scene(scene)
    np.testing.assert_array_equal(cs2.texels, cs.texels)


def test_texels_are_read_only_and_not_the_callers_array():
    """The derived caches (role kinds, levels, half texels) are made once from ``raw``: an
    edit in place would leave them stale, so ``raw`` cannot be edited, and the caller's own
    float32 array is copied, not kept."""
    mine = np.full((4, 5, 3), 0.25, dtype=np.float32)
    t = tx.Texture.from_array(mine, name="mine")
    before = t.half_texels().copy()
    mine[:] = 0.75                                              # the caller's array, after
    np.testing.assert_array_equal(t.raw, 0.25)
    np.testing.assert_array_equal(t.half_texels(), before)
    with pytest.raises(ValueError, match="read-only"):
        t.raw[0, 0, 0] = 1.0
    assert not t.with_options(filter="trilinear").raw.flags.writeable
    wide = np.full((2, 2), 0.5)                                 # float64: converted, so already a copy
    assert not tx.Texture.from_array(wide).raw.flags.writeable
    assert not tx.Texture.procedural("checker", size=8).raw.flags.writeable
    assert not pickle.loads(pickle.dumps(t)).raw.flags.writeable and not copy.deepcopy(t).raw.flags.writeable


def test_only_trilinear_textures_get_levels():
    img = np.random.default_rng(2).uniform(size=(8, 5, 3))
    bil = tx.Texture.from_array(img)
    tri = bil.with_options(filter="trilinear")
    cs = compile_scene(_scene(tx.Material(diffuse=bil)))
    assert cs.textures["levels"][0] == 1 and cs.texels.size == 8 * 5 * 4
    cs = compile_scene(_scene(tx.Material(diffuse=tri, specular=bil)))
    sizes = txt.level_sizes(8, 5)
    assert list(cs.textures["levels"]) == [len(sizes), 1] and cs.textures["offset"][0] == cs.textures["offset"][1]
    assert cs.texels.size == 4 * sum(h * w for h, w in sizes)
    assert cs.device_bytes()["texels"] == cs.texels.size * 2
    assert cs.features.filter_trilinear and cs.features.filter_bilinear
    cs = compile_scene(_scene(tx.Material(diffuse=tri, specular=bil)), texture_filter="nearest")
    assert list(cs.textures["filter"]) == [0, 0] and list(cs.textures["levels"]) == [1, 1]
    assert cs.features.filter_nearest and not cs.features.filter_trilinear


def test_anisotropic_textures_get_levels_and_their_bound():
    img = np.random.default_rng(3).uniform(size=(8, 5, 3))
    ani = tx.Texture.from_array(img, filter="anisotropic", max_aniso=4)
    assert ani.max_aniso == 4 and ani.with_options(filter="bilinear").max_aniso == 4
    assert tx.Texture.from_array(img).max_aniso == txt.DEFAULT_MAX_ANISO == 16
    cs = compile_scene(_scene(tx.Material(diffuse=ani, specular=ani.with_options(filter="trilinear"))))
    assert list(cs.textures["levels"]) == [len(txt.level_sizes(8, 5))] * 2
    assert list(cs.textures["filter"]) == [3, 2] and list(cs.textures["max_aniso"]) == [4, 4]
    assert cs.features.filter_anisotropic and cs.features.filter_trilinear and not cs.features.filter_bilinear
    cs = compile_scene(_scene(tx.Material(diffuse=tx.Texture.from_array(img))), texture_filter="anisotropic")
    assert cs.features.filter_anisotropic and cs.textures["levels"][0] > 1
    assert not compile_scene(_scene(tx.Material(diffuse=ani)), texture_filter="trilinear").features.filter_anisotropic
    for bad in (0, 65, 2.5, True, "8", None):
        with pytest.raises(SceneError, match=r"texture\.max_aniso: <array>: expected an integer in 1\.\.64, got "
                                             + re.escape(repr(bad))):
            tx.Texture.from_array(img, filter="anisotropic", max_aniso=bad)


def test_procedural_constructors():
    t = tx.Texture.procedural("checker", size=16, n_checks=2, filter="trilinear")
    assert t.colorspace == "srgb" and t.shape == (16, 16) and t.filter == "trilinear"
    h = tx.Texture.procedural("bricks_height", size=(8, 16))
    assert h.colorspace == "linear" and h.channels == 1
    assert tx.Texture.procedural("noise", size=8, seed=3).channels == 1
    with pytest.raises(SceneError, match=r"texture\.procedural: expected one of checker"):
        tx.Texture.procedural("plasma")
    with pytest.raises(SceneError, match=r"texture\.procedural: checker: colour: not a parameter of checker"):
        tx.Texture.procedural("checker", colour=1)


def test_texture_is_still_importable_from_scene():
    from texray.scene import Texture
    assert Texture is tx.Texture is txt.Texture


# --- scene files -------------------------------------------------------------------
_SCENE = """
[camera]
eye = [0, 3, 0.01]
[textures.logo]
file = "logo.png"
filter = "trilinear"
max_aniso = 8
[textures.gloss]
procedural = "noise"
params = { size = 16, seed = 2 }
[materials.m]
diffuse = [0.5, 0.5, 0.5]
specular = "logo"
shininess = 50
shininess_map = "gloss"
label = { texture = "logo", uv_transform = { scale = [2, 2], offset = [-0.5, -0.5] } }
[[objects]]
type = "quad"
p0 = [-1, 0, 1]
p1 = [1, 0, 1]
p2 = [1, 0, -1]
p3 = [-1, 0, -1]
material = "m"
"""


def test_scene_file_roles(tmp_path):
    _write(tmp_path / "logo.png", np.full((4, 4, 4), 0.5, np.float32), "uint8")
    (tmp_path / "s.toml").write_text(_SCENE)
    m = tx.Scene.load(tmp_path / "s.toml").objects[0].material
    assert m.specular.filter == "trilinear" and m.specular.colorspace == "srgb" and m.specular.max_aniso == 8
    assert m.shininess_map.max_aniso == 16
    assert m.shininess_map.name == "<noise>" and m.shininess_map.channels == 1
    assert isinstance(m.label, tx.Label) and m.label.texture is m.specular
    assert m.label.uv_transform.scale == (2.0, 2.0) and m.label.device_texture.wrap == "clamp"
    bad = [
        ('label = { texture = "logo", uv_transform = { scale = [2, 2], offset = [-0.5, -0.5] } }',
         'label = { texture = "nope" }', r"s\.toml: materials\.m\.label\.texture: no texture named 'nope'"),
        ('label = { texture = "logo", uv_transform = { scale = [2, 2], offset = [-0.5, -0.5] } }',
         'label = { image = "logo" }', r"materials\.m\.label\.image: unknown key"),
        ('specular = "logo"', 'specular = "spec"', r"materials\.m\.specular: no texture named 'spec'"),
        ('shininess_map = "gloss"', "shininess_map = 3", r"materials\.m\.shininess_map: expected str, got 3"),
        ('filter = "trilinear"', 'filter = "mip"', r"textures\.logo\.filter: .*got 'mip'"),
        ("max_aniso = 8", "max_aniso = 0",
         r"s\.toml: textures\.logo\.max_aniso: \S*logo\.png: expected an integer in 1\.\.64, got 0"),
        ("max_aniso = 8", "max_aniso = 8.5", r"textures\.logo\.max_aniso: expected int"),
        ('procedural = "noise"', 'procedural = "noise"\nmax_aniso = 99',
         r"textures\.gloss\.max_aniso: <noise>: expected an integer in 1\.\.64, got 99"),
        ('params = { size = 16, seed = 2 }', 'params = { size = 16, octave = 2 }',
         r"textures\.gloss\.procedural: noise: octave: not a parameter"),
        ('procedural = "noise"', 'procedural = "noise"\nfile = "logo.png"',
         r"textures\.gloss: expected exactly one of 'file' or 'procedural'"),
    ]
    for old, new, msg in bad:
        assert old in _SCENE
        (tmp_path / "s.toml").write_text(_SCENE.replace(old, new))
        with pytest.raises(SceneError, match=msg):
            tx.Scene.load(tmp_path / "s.toml")
