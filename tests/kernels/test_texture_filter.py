"""Texture filtering and ray differentials on the device (kernels/texture/texture.h,
differentials.h) against float64 numpy references (tests/reference.py).

* texture_eval for nearest, bilinear, trilinear and anisotropic in every wrap mode, odd sizes,
  with a UV transform, on random coordinates and footprints, in each compile-time
  specialization (one filter compiled in, or all four with the runtime switch): within 2e-5
  of the float64 reference on the same half texels (nearest: away from texel boundaries,
  where float32 and float64 may pick different texels; anisotropic: away from integer
  major / width ratios, where they may take different probe counts);
* anisotropic degenerate footprints: zero derivatives read level 0 bilinearly (one probe), an
  isotropic footprint equals trilinear within float rounding, NaN / inf derivatives read
  defined texels (finite, within the texels' range); the cap raises the level;
* anisotropic against trilinear on a grazing floor, against a 256-spp bilinear reference;
* texture_eval_lod / texture_texel_size against the OpenGL rule in float64;
* texture_label: 0 outside [0, 1]^2 after the label's transform, the texture inside;
* camera_dp_dxy and uv_differentials against central differences of the exact float64
  ray-plane intersection and numpy's least squares;
* through the renderer: a trilinear plane facing the camera at a known distance reads the
  level log2(texels per pixel) computed by hand, and a plane at a grazing angle matches the
  float64 footprint reference per pixel; labels and specular / shininess maps match the float64
  reference renderer; texture_filter overrides every texture.
"""
from __future__ import annotations

import types

import numpy as np
import pyopencl as cl
import pytest
import reference as ref
import texray as tx
from scenes_for_tests import quad
from texray.device import layout
from texray.compile import textures as packing
from texray.scene import texture as txt
from texray.compile import compile_scene
from kernel_harness import build_test_program

_KERNELS = r"""
#include "core/common.h"
#include "core/accurate.h"
#include "texture/wrap.h"
#include "texture/mapping.h"
#include "texture/differentials.h"
#include "texture/texture.h"

/* in: 6 floats per lookup (uv, duv_dx, duv_dy); out: texture_eval, then (lod, texel size u, v, label alpha) */
__kernel void lookup(__global const half* texels, __global const TextureInfo* textures, uint tex,
                     __global const float* in, __global float4* out, __global float4* aux, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    __global const TextureInfo* ti = textures + tex;
    TexCoord t;
    t.uv = vload2(3 * i, in); t.duv_dx = vload2(3 * i + 1, in); t.duv_dy = vload2(3 * i + 2, in);
    out[2 * i] = texture_eval(texels, ti, t);
    out[2 * i + 1] = texture_label(texels, ti, t);
    float lod = texture_eval_lod(ti, t);
    float2 ts = texture_texel_size(ti, lod);
    aux[i] = (float4)(lod, ts.x, ts.y, 0.0f);
}

/* per point: d, t, n, dpdu, dpdv (15 floats) -> dpdx, dpdy (6), uv derivatives (4) */
__kernel void differentials(__constant Camera* cam, uint w, uint h, uint spp, __global const float* in,
                            __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    float3 d = vload3(5 * i, in), nn = vload3(5 * i + 2, in), dpdu = vload3(5 * i + 3, in), dpdv = vload3(5 * i + 4, in);
    float t = in[15 * i + 3];
    float3 dpdx, dpdy;
    camera_dp_dxy(cam, w, h, differential_scale(spp), d, t, nn, &dpdx, &dpdy);
    TexCoord tc = uv_differentials((float2)(0.0f), dpdu, dpdv, dpdx, dpdy);
    vstore3(dpdx, 0, out + 10 * i);
    vstore3(dpdy, 0, out + 10 * i + 3);
    vstore2(tc.duv_dx, 0, out + 10 * i + 6);
    vstore2(tc.duv_dy, 0, out + 10 * i + 8);
}
"""

FILTER_NAMES = ("nearest", "bilinear", "trilinear", "anisotropic")
# The filters compiled in: each alone (the specialized paths) and all four (the runtime switch).
VARIANTS = [(1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1), (1, 1, 1, 1)]


def _program(rt, variant):
    k = build_test_program(rt, ("core/common.h", "core/accurate.h", "texture/wrap.h", "texture/mapping.h",
                                "texture/differentials.h", "texture/texture.h"),
                           _KERNELS, [f"-DTX_FILTER_{n.upper()}={v}" for n, v in zip(FILTER_NAMES, variant)])
    return {"lookup": k.lookup, "differentials": k.differentials}


def _buf(rt, a):
    a = np.ascontiguousarray(a)
    return cl.Buffer(rt.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=a)


def _lookup(rt, variant, table, texels, tex, uv, dx, dy):
    n = len(uv)
    inp = np.stack([uv, dx, dy], 1).astype(np.float32).ravel()
    out = np.zeros((2 * n, 4), np.float32)
    aux = np.zeros((n, 4), np.float32)
    ob = cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    ab = cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, aux.nbytes)
    _program(rt, variant)["lookup"](rt.queue, (n,), None, _buf(rt, texels), _buf(rt, table), np.uint32(tex),
                                    _buf(rt, inp), ob, ab, np.uint32(n))
    cl.enqueue_copy(rt.queue, out, ob)
    cl.enqueue_copy(rt.queue, aux, ab)
    return out[0::2].astype(np.float64), out[1::2].astype(np.float64), aux.astype(np.float64)


@pytest.mark.parametrize("variant", VARIANTS, ids=lambda v: "nbta"[v.index(1)] if sum(v) == 1 else "all")
def test_filters_match_numpy(rt, rng, variant):
    filters = [f for f, on in zip(FILTER_NAMES, variant) if on]
    img = rng.uniform(0, 1, (13, 22, 4)).astype(np.float32)      # odd and even sizes: 5 levels
    base = tx.Texture.from_array(img, uv_transform=tx.UVTransform(scale=(1.5, 0.75), offset=(0.2, -0.1),
                                                                  rotation=20))
    entries = [(base.with_options(wrap=w, filter=f, max_aniso=8), "colour") for f in filters
               for w in ("repeat", "clamp", "mirror")]
    table, texels = packing.pack(entries)
    cs = types.SimpleNamespace(textures=table, texels=texels)
    n = 4000
    uv = rng.uniform(-2.5, 3.5, (n, 2))
    # footprints from 1/100 texel to the whole texture, log-uniform, random directions
    scale = 10.0 ** rng.uniform(-3.5, 0.5, (n, 1))
    dx, dy = rng.normal(size=(n, 2)) * scale, rng.normal(size=(n, 2)) * scale
    uv32, dx32, dy32 = (a.astype(np.float32).astype(np.float64) for a in (uv, dx, dy))
    for tex, (t, _) in enumerate(entries):
        got, label, aux = _lookup(rt, variant, table, texels, tex, uv32, dx32, dy32)
        want = ref.sample(cs, tex, uv32, dx32, dy32)
        keep = np.ones(n, bool)
        tuv, a = ref.transform_uv(cs, tex, uv32)
        if t.filter == "nearest":          # float32 and float64 may round to different texels at boundaries
            frac = np.stack([tuv[:, 0] * 22, tuv[:, 1] * 13], 1) % 1.0
            keep = np.all(np.minimum(frac, 1 - frac) > 1e-4, axis=1)
        if t.filter == "anisotropic":        # the probe count n = ceil(major / width) may differ
            major, width, nprobe, _, _ = ref.aniso_footprint(table[tex], dx32 @ a.T, dy32 @ a.T)
            ratio = major / width
            keep = np.abs(ratio - np.round(ratio)) > 1e-4 * ratio
            assert nprobe.max() == 8 and (nprobe > 1).mean() > 0.5 and (nprobe == 1).sum() > 50
        err = np.abs(got - want).max(1)[keep]
        assert err.max() < 2e-5, f"{t}: worst {err.max():.3g} at uv {uv32[keep][err.argmax()]}"
        # the level of detail and the texel size of the level in use
        lod = ref.texture_lod(table[tex], dx32 @ a.T, dy32 @ a.T)
        np.testing.assert_allclose(aux[:, 0], lod, atol=1e-4)
        level = np.floor(np.clip(lod, 0, table[tex]["levels"] - 1)).astype(int)
        sizes = np.array(txt.level_sizes(13, 22))[level]
        sure = np.abs(lod - np.round(lod)) > 1e-3           # float32 and float64 agree on the level
        np.testing.assert_array_equal(aux[sure, 1:3], (1.0 / sizes[sure, ::-1]).astype(np.float32))
        # the label: the texture inside [0, 1]^2 after the transform, absent outside
        inside = np.all((tuv >= 0) & (tuv <= 1), axis=1)
        assert np.all(label[~inside] == 0) and inside.sum() > 30          # ~2 % of the points
        np.testing.assert_allclose(label[inside & keep], got[inside & keep], atol=2e-5)


def test_differentials_match_float64(rt, rng):
    """camera_dp_dxy on random planes equals central differences (h = 1e-5 pixel) of the exact
    float64 intersection of the pixel's ray with the plane; uv_differentials equals lstsq."""
    w, h, spp = 320, 200, 1
    cam_obj = tx.Camera(eye=(0.3, 1.2, 4.0), look_at=(0, 0, 0), fov_y=50)
    eye, fwd, right, up = cam_obj.basis(w / h)
    cam = np.zeros(1, layout.CAMERA)
    cam["eye"], cam["forward"], cam["right"], cam["up"] = eye, fwd, right, up
    n_pts = 500
    px, py = rng.uniform(0, w, n_pts), rng.uniform(0, h, n_pts)

    def direction(px, py):
        return fwd + (2 * px / w - 1)[:, None] * right + (1 - 2 * py / h)[:, None] * up
    d = direction(px, py)
    t = rng.uniform(1, 8, n_pts)
    p = eye + t[:, None] * d
    nrm = rng.normal(size=(n_pts, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm *= -np.sign(np.sum(nrm * d, 1))[:, None]
    dpdu, dpdv = rng.normal(size=(n_pts, 3)), rng.normal(size=(n_pts, 3))

    def hit(px, py):
        dd = direction(px, py)
        tt = np.sum((p - eye) * nrm, 1) / np.sum(dd * nrm, 1)
        return eye + tt[:, None] * dd
    eps = 1e-5
    want_dx = (hit(px + eps, py) - hit(px - eps, py)) / (2 * eps)
    want_dy = (hit(px, py + eps) - hit(px, py - eps)) / (2 * eps)
    inp = np.concatenate([d, t[:, None], np.zeros((n_pts, 2)), nrm, dpdu, dpdv], 1)   # d, (t, 0, 0), n, ...
    out = np.zeros((n_pts, 10), np.float32)
    ob = cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    _program(rt, (0, 0, 1))["differentials"](rt.queue, (n_pts,), None, _buf(rt, cam), np.uint32(w), np.uint32(h),
                                             np.uint32(spp), _buf(rt, inp.astype(np.float32)), ob, np.uint32(n_pts))
    cl.enqueue_copy(rt.queue, out, ob)
    scale = np.linalg.norm(want_dx, axis=1) + np.linalg.norm(want_dy, axis=1)
    for got, want in ((out[:, 0:3], want_dx), (out[:, 3:6], want_dy)):
        err = np.linalg.norm(got - want, axis=1) / scale
        assert err.max() < 1e-4, f"worst relative error {err.max():.3g}"
    a = np.stack([dpdu, dpdv], 2)                                     # (n, 3, 2)
    for k, dp in ((6, out[:, 0:3]), (8, out[:, 3:6])):
        sol = np.stack([np.linalg.lstsq(a[i], dp[i].astype(np.float64), rcond=None)[0] for i in range(n_pts)])
        np.testing.assert_allclose(out[:, k:k + 2], sol, rtol=1e-3, atol=1e-4 * np.abs(sol).max())


# --- through the renderer ---------------------------------------------------------------
def _plane_scene(tex, eye, look_at, size=2.0, fov=40.0, up=(0, 1, 0)):
    """A floor quad y = 0, uv = (x, -z) / (2 size) + 1/2, lit by ambient 1 only: colour = texture."""
    p, f, uv = quad(0.0, size)
    scene = tx.Scene(camera=tx.Camera(eye=eye, look_at=look_at, fov_y=fov, up=up), ambient=(1, 1, 1))
    scene.add(tx.Mesh(p, f, uvs=uv, material=tx.Material(diffuse=tex), name="floor"))
    return scene


def _floor_reference(scene, width, height, size=2.0):
    """float64 per-pixel uv and d(uv)/dx, d(uv)/dy of the pixel-centre rays on the floor y = 0 by central
    differences of the exact intersection (the footprint the kernels estimate); NaN off the floor."""
    eye, fwd, right, up = scene.camera.basis(width / height)
    px, py = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    px, py = px.ravel(), py.ravel()

    def uv_at(px, py):
        d = fwd + (2 * px / width - 1)[:, None] * right + (1 - 2 * py / height)[:, None] * up
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -eye[1] / d[:, 1]
        q = eye + t[:, None] * d
        uv = np.stack([q[:, 0], -q[:, 2]], 1) / (2 * size) + 0.5
        ok = (t > 0) & np.all((uv > 0) & (uv < 1), axis=1)
        return np.where(ok[:, None], uv, np.nan)
    e = 1e-3
    uv = uv_at(px, py)
    dx = (uv_at(px + e, py) - uv_at(px - e, py)) / (2 * e)
    dy = (uv_at(px, py + e) - uv_at(px, py - e)) / (2 * e)
    return uv, dx, dy


def test_lod_of_a_plane_at_known_distance(device):
    """Seen straight down from height D with vertical field of view fov over H pixels, a pixel spans
    2 D tan(fov / 2) / H world units; the floor (side 2 size) holds N texels across, so the footprint is
    N 2 D tan(fov/2) / (2 size H) texels and the level log2 of that: 1.5 here by construction."""
    n, size, fov, hpx = 256, 2.0, 40.0, 64
    lod_want = 1.5
    d = 2 ** lod_want * 2 * size * hpx / (n * 2 * np.tan(np.radians(fov / 2)))
    img = np.random.default_rng(5).uniform(0, 1, (n, n, 3)).astype(np.float32)
    tex = tx.Texture.from_array(img, filter="trilinear")
    scene = _plane_scene(tex, eye=(0, d, 1e-9), look_at=(0, 0, 0), size=size, fov=fov, up=(0, 0, -1))
    out = tx.render(scene, hpx, hpx, spp=1, device=device, jitter=False)
    uv, dx, dy = _floor_reference(scene, hpx, hpx, size)
    cs = compile_scene(scene)
    lod = ref.texture_lod(cs.textures[0], dx, dy)
    ok = np.isfinite(lod)
    assert ok.mean() > 0.9
    # the float64 footprint agrees with the closed form at the image centre (the plane is seen head-on)
    centre = (hpx // 2) * hpx + hpx // 2
    assert lod[centre] == pytest.approx(lod_want, abs=2e-3)
    want = ref.trilinear(ref.texture_levels(cs, 0), uv[ok], lod[ok], 0)[:, :3]
    err = np.abs(out.rgb.reshape(-1, 3)[ok] - want).max()
    assert err < 2e-3, f"worst {err:.3g}"
    # and not level 0 or level 2: the levels differ by far more than that here
    for wrong in (lod[ok] - 0.5, lod[ok] + 0.5):
        alt = ref.trilinear(ref.texture_levels(cs, 0), uv[ok], wrong, 0)[:, :3]
        assert np.abs(out.rgb.reshape(-1, 3)[ok] - alt).max() > 20 * err


def test_grazing_plane_matches_float64_footprint(device):
    """A long floor seen at a grazing angle: per pixel, the trilinear colour at the float64 footprint.
    Tolerance: the level comes from float32 differentials, 1e-3 of a level off moves the blend by
    1e-3 of the two levels' difference."""
    img = np.random.default_rng(6).uniform(0, 1, (128, 128, 3)).astype(np.float32)
    tex = tx.Texture.from_array(img, filter="trilinear")
    w, h = 96, 64
    scene = _plane_scene(tex, eye=(0.3, 0.35, 2.2), look_at=(0, 0, -2), size=2.0)
    out = tx.render(scene, w, h, spp=1, device=device, jitter=False)
    uv, dx, dy = _floor_reference(scene, w, h)
    cs = compile_scene(scene)
    lod = ref.texture_lod(cs.textures[0], dx, dy)
    ok = np.isfinite(lod)
    assert ok.mean() > 0.4 and np.nanmax(lod) > 4 and np.nanmin(lod) < 1     # a range of levels
    want = ref.trilinear(ref.texture_levels(cs, 0), uv[ok], lod[ok], 0)[:, :3]
    err = np.abs(out.rgb.reshape(-1, 3)[ok] - want).max(1)
    assert np.quantile(err, 0.99) < 1e-4 and err.max() < 1e-3, f"worst {err.max():.3g}"


def test_texture_filter_override(device):
    img = np.random.default_rng(7).uniform(0, 1, (64, 64, 3)).astype(np.float32)
    scene = _plane_scene(tx.Texture.from_array(img, filter="trilinear"), eye=(0.3, 0.35, 2.2), look_at=(0, 0, -2))
    tri = tx.render(scene, 48, 32, device=device, jitter=False)
    bil = tx.render(scene, 48, 32, device=device, jitter=False, texture_filter="bilinear")
    scene.objects[0].material.diffuse = tx.Texture.from_array(img)       # bilinear of its own
    own = tx.render(scene, 48, 32, device=device, jitter=False)
    np.testing.assert_array_equal(bil.rgb, own.rgb)
    assert np.abs(tri.rgb - bil.rgb).max() > 0.1
    assert bil.stats["features"].filter_bilinear and not bil.stats["features"].filter_trilinear
    with pytest.raises(tx.SceneError, match=r"render: texture_filter: expected None or one of"):
        tx.render(scene, 8, 8, device=device, texture_filter="ewa")


def _roles_scene(label_uvt, spec, shin):
    p, f, uv = quad(0.0, 2.0)
    base = np.random.default_rng(8).uniform(0.2, 0.8, (16, 16, 3)).astype(np.float32)
    logo = np.random.default_rng(9).uniform(0, 1, (8, 12, 4)).astype(np.float32)
    logo[..., 3] = np.where(logo[..., 3] > 0.5, 1.0, np.round(logo[..., 3] * 2, 1))   # opaque, half, clear
    mat = tx.Material(diffuse=tx.Texture.from_array(base), tint=(0.9, 0.8, 1.0),
                      specular=spec, shininess=60, shininess_map=shin,
                      label=tx.Label(tx.Texture.from_array(logo, colorspace="srgb"), uv_transform=label_uvt))
    scene = tx.Scene(camera=tx.Camera(eye=(0, 2.5, 2.5), look_at=(0, 0, 0), fov_y=50),
                     lights=[tx.PointLight((0.3, 2.0, -0.6), (6, 6, 6))], ambient=(0.1, 0.1, 0.1))
    scene.add(tx.Mesh(p, f, uvs=uv, material=mat, name="floor"))
    return scene


def test_roles_match_float64_reference(device):
    """Label (its own transform, clamped so it appears once, alpha 1 / 0.5 / 0), specular colour map
    and shininess map on a lit floor: the render equals tests/reference.py's float64 image."""
    rng = np.random.default_rng(10)
    spec = tx.Texture.from_array(rng.uniform(0, 1, (8, 8, 3)).astype(np.float32))
    shin = tx.Texture.from_array(rng.uniform(0.1, 1, (4, 4)).astype(np.float32))
    uvt = tx.UVTransform(scale=(3, 3), offset=(-1, -1.2))          # the label on uv [1/3, 2/3] x [0.4, 0.73]
    scene = _roles_scene(uvt, spec, shin)
    w, h = 96, 72
    img = tx.render(scene, w, h, device=device, jitter=False, shadows=False)
    want, ids, _ = ref.render_reference(scene, w, h)
    hit = ids >= 0
    err = np.abs(img.rgb - want)[hit].max(1)
    assert np.quantile(err, 0.995) < 2e-4 * (1 + want[hit].max()) and err.max() < 1e-2, f"worst {err.max():.3g}"
    f = img.stats["features"]
    assert f.labels and f.specular_maps and f.shininess_maps
    # Each role changes the image where the reference says it should (no test that cannot fail):
    plain = tx.render(_roles_scene(uvt, 1.0, None), w, h, device=device, jitter=False, shadows=False).rgb
    plain_ref, _, _ = ref.render_reference(_roles_scene(uvt, 1.0, None), w, h)
    changed = np.abs(want - plain_ref).max(-1) > 1e-2
    assert changed.sum() > 50
    assert np.all(np.abs(img.rgb - plain).max(-1)[changed & hit] > 1e-3)


def test_label_appears_once_and_composites_with_alpha(device):
    """An opaque red label with a half-transparent right half, scaled to a quarter of the floor: inside,
    kd = lerp(base, red, alpha); outside [0, 1]^2 after its transform, the base colour alone (no repeat,
    no clamp-to-edge streak)."""
    p, f, uv = quad(0.0, 2.0)
    logo = np.zeros((4, 8, 4), np.float32)
    logo[..., 0] = 1.0
    logo[:, :4, 3], logo[:, 4:, 3] = 1.0, 0.5
    base = (0.2, 0.4, 0.6)
    mat = tx.Material(diffuse=base, label=tx.Label(tx.Texture.from_array(logo, filter="nearest"),
                                                    uv_transform=tx.UVTransform(scale=(2, 2), offset=(-0.5, -0.5))))
    scene = tx.Scene(camera=tx.Camera(eye=(0, 4, 1e-6), look_at=(0, 0, 0), up=(0, 0, -1), fov_y=60),
                     ambient=(1, 1, 1))
    scene.add(tx.Mesh(p, f, uvs=uv, material=mat, name="floor"))
    w = 64
    img = tx.render(scene, w, w, device=device, jitter=False).rgb.reshape(-1, 3)
    uvp, _, _ = _floor_reference(scene, w, w)
    on = np.all(np.isfinite(uvp), 1)
    luv = 2 * uvp - 0.5
    inside = on & np.all((luv > 0.01) & (luv < 0.99), 1)
    outside = on & np.any((luv < -0.01) | (luv > 1.01), 1)
    left = inside & (luv[:, 0] < 0.49)
    right = inside & (luv[:, 0] > 0.51)
    assert left.sum() > 50 and right.sum() > 50 and outside.sum() > 500
    np.testing.assert_allclose(img[outside], np.broadcast_to(base, (outside.sum(), 3)), atol=1e-6)
    np.testing.assert_allclose(img[left], np.broadcast_to((1, 0, 0), (left.sum(), 3)), atol=1e-3)
    half = 0.5 * np.array(base) + 0.5 * np.array([1, 0, 0])
    np.testing.assert_allclose(img[right], np.broadcast_to(half, (right.sum(), 3)), atol=1e-3)


# --- anisotropic filtering ------------------------------------------------------------
def _aniso_entries(img, max_aniso=16):
    base = tx.Texture.from_array(img, filter="anisotropic", max_aniso=max_aniso)
    entries = [(base, "colour"), (base.with_options(filter="trilinear"), "colour")]
    table, texels = packing.pack(entries)
    return table, texels, types.SimpleNamespace(textures=table, texels=texels)


def test_anisotropic_degenerate_footprints(rt, rng):
    """Zero derivatives: level 0 bilinear, one probe. An isotropic footprint (the screen steps
    orthogonal and equally long in texels, any size and direction): trilinear's value within
    float rounding (the probes collapse onto uv). NaN / inf / huge derivatives: finite values
    within the texels' range, never NaN. The cap: a 100:1 footprint with max_aniso = 4 takes 4
    probes at a level raised to major / 4, as the float64 reference does."""
    img = rng.uniform(0, 1, (24, 16, 4)).astype(np.float32)
    table, texels, cs = _aniso_entries(img)
    variant = (0, 0, 1, 1)
    n = 2000
    uv = rng.uniform(-1, 2, (n, 2))
    zero = np.zeros((n, 2))
    got, _, _ = _lookup(rt, variant, table, texels, 0, uv, zero, zero)
    tri, _, _ = _lookup(rt, variant, table, texels, 1, uv, zero, zero)
    np.testing.assert_array_equal(got, tri)
    np.testing.assert_allclose(got, ref.bilinear_level(ref.texture_levels(cs, 0)[0], uv, 0), atol=2e-6)
    # isotropic: a = k (cos, sin), b = k (-sin, cos) in texels; k from 1/100 to 100 texels
    k = 10.0 ** rng.uniform(-2, 2, n)
    th = rng.uniform(0, 2 * np.pi, n)
    w, h = 16.0, 24.0
    dx = np.stack([k * np.cos(th) / w, k * np.sin(th) / h], 1)
    dy = np.stack([-k * np.sin(th) / w, k * np.cos(th) / h], 1)
    got, _, _ = _lookup(rt, variant, table, texels, 0, uv, dx, dy)
    tri, _, _ = _lookup(rt, variant, table, texels, 1, uv, dx, dy)
    assert np.abs(got - tri).max() < 2e-6, f"worst {np.abs(got - tri).max():.3g}"
    # ... while an anisotropic footprint of the same length is sharper than trilinear's
    got2, _, _ = _lookup(rt, variant, table, texels, 0, uv, dx, dy * 0.05)
    tri2, _, _ = _lookup(rt, variant, table, texels, 1, uv, dx, dy * 0.05)
    assert np.abs(got2 - tri2)[k > 4].max() > 0.05
    # non-finite and huge derivatives
    bad = np.array([np.nan, np.inf, -np.inf, 1e30, -1e30, 0.0, 1e-30])
    pick = rng.integers(0, len(bad), (n, 4))
    ddx, ddy = bad[pick[:, :2]], bad[pick[:, 2:]]
    uv_bad = uv.copy()
    uv_bad[::7] = np.nan
    got, _, _ = _lookup(rt, variant, table, texels, 0, uv_bad, ddx, ddy)
    stored = cs.texels.astype(np.float64).reshape(-1, 4)
    assert np.all(np.isfinite(got))
    assert np.all(got >= stored.min(0) - 1e-6) and np.all(got <= stored.max(0) + 1e-6)
    # the cap raises the level: 100:1 footprints along random directions
    table4, texels4, cs4 = _aniso_entries(img, max_aniso=4)
    long_ = np.stack([20 * np.cos(th) / w, 20 * np.sin(th) / h], 1)
    short = np.stack([-0.2 * np.sin(th) / w, 0.2 * np.cos(th) / h], 1)
    major, width, nprobe, _, _ = ref.aniso_footprint(table4[0], long_, short)
    np.testing.assert_allclose(major, 20) and np.testing.assert_allclose(width, 5)
    assert np.all(nprobe == 4)
    got, _, _ = _lookup(rt, variant, table4, texels4, 0, uv, long_, short)
    np.testing.assert_allclose(got, ref.sample(cs4, 0, uv, long_, short), atol=2e-5)


def test_anisotropic_beats_trilinear_at_grazing_angles(device, scenes_dir):
    """scenes/bench/grazing_quad.toml (a 40x repeated checker floor to the horizon), 160x120,
    RMSE against its 256-spp bilinear render (the pixels' box-filtered integral). Measured
    (PoCL): at 1 spp through pixel centres bilinear 0.181, trilinear 0.068, anisotropic 0.043;
    at 4 spp jittered 0.064, 0.048, 0.031. Asserted: anisotropic below 0.8x trilinear in both.
    Not asserted, because it does not hold: at 1 spp *jittered* anisotropic (0.110) is no
    better than trilinear (0.101): the sample's random position within the pixel then
    dominates the error, and trilinear's over-blur hides that noise."""
    scene = tx.Scene.load(scenes_dir / "bench" / "grazing_quad.toml")
    w, h = 160, 120
    want = tx.render(scene, w, h, 256, device=device, seed=12345, texture_filter="bilinear").rgb.astype(np.float64)

    def rmse(f, spp, jitter):
        img = tx.render(scene, w, h, spp, device=device, seed=1, texture_filter=f, jitter=jitter)
        return float(np.sqrt(np.mean((img.rgb - want) ** 2))), img
    for spp, jitter in ((1, False), (4, True)):
        tri, _ = rmse("trilinear", spp, jitter)
        ani, img = rmse("anisotropic", spp, jitter)
        assert ani < 0.8 * tri, f"{spp} spp: anisotropic {ani:.4f}, trilinear {tri:.4f}"
        assert img.stats["features"].filter_anisotropic and not img.stats["features"].filter_trilinear
