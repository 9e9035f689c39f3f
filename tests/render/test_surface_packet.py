"""The packet surface (kernels/shading/surface_packet.h): the fused kernel's sphere, quad and
triangle hits evaluated as vectors give the scalar surface_eval's records bit for bit, so the
image of a scene with packets equals the image without (TEXRAY_PACKET=0), at 8 and 16 lanes,
with AVX-512 too, through every path the packet code takes: packets whose lanes hit several
objects, materials and textures (the gathers), each wrap mode, UV transforms, bump mapping with
each kind of step (the exact gradient, one texel, a fixed step), materials without texture,
mirrored normals, vertex normals with the terminator's lift, misses and grazing hits; and a program whose every hit is a packet's (no
scalar surface code in its kernel) next to one with a cylinder (the other lanes stay scalar)."""
import numpy as np
import pytest

import texray as tx
from texray.device import runtime
from texray.device.features import cpu_avx512

from scenes_for_tests import box, quad


def _texture(seed, wrap, size=(24, 20), channels=3, **kw):
    rgb = np.random.default_rng(seed).random((size[1], size[0], channels)).astype(np.float32)
    return tx.Texture.from_array(rgb, name=f"t{seed}", wrap=wrap, **kw)


def _scene(cylinder=False, triangles=True):
    """Objects of every packet kind side by side (packets straddle them at 1 spp), materials
    that differ in texture, wrap, UV transform and bump step."""
    s = tx.Scene(camera=tx.Camera(eye=(0.3, 1.4, 4.5), look_at=(0, 0.4, 0), fov_y=55),
                 lights=[tx.PointLight((2.0, 4.0, 3.0), (30, 28, 26)), tx.PointLight((-3, 1, 2), (6, 7, 9))])
    height = _texture(7, "repeat", channels=1)
    uvt = tx.UVTransform(scale=(3.5, 2.25), rotation=35, offset=(-0.3, 0.7))
    mats = [
        tx.Material(diffuse=_texture(1, "repeat", uv_transform=uvt), specular=0.3, shininess=30,
                    bump=tx.Bump(height, 0.03, delta="analytic")),
        tx.Material(diffuse=_texture(2, "mirror", uv_transform=tx.UVTransform(scale=(5, 5), offset=(-2, -2))),
                    bump=tx.Bump(_texture(8, "clamp", channels=1), 0.05)),                 # one texel
        tx.Material(diffuse=_texture(3, "clamp", uv_transform=tx.UVTransform(scale=(3, 3), offset=(-1, -1))),
                    bump=tx.Bump(height, 0.02, delta=0.013)),                            # a fixed step
        tx.Material(diffuse=(0.6, 0.5, 0.4), specular=0.2, shininess=12),                # no texture
    ]
    # quads: a floor split in two materials, a wall facing away from the camera (mirrored normal)
    s.add(tx.Quad((-3, 0, 2), (0, 0, 2), (0, 0, -2), (-3, 0, -2), material=mats[0], name="floor_l"))
    s.add(tx.Quad((0, 0, 2), (3, 0, 2), (3, 0, -2), (0, 0, -2), material=mats[1], name="floor_r"))
    s.add(tx.Quad((-2.5, 0, -1.5), (-2.5, 2, -1.5), (2.5, 2, -1.5), (2.5, 0, -1.5), material=mats[2], name="wall"))
    s.add(tx.Sphere((-0.9, 0.5, 0.3), 0.5, material=mats[1], name="ball"))
    s.add(tx.Sphere((0.9, 0.45, 0.6), 0.45, material=mats[3], name="plain"))
    if triangles:
        p, f, uv = quad(0.0, 0.6, uv_repeat=2.0)
        p = p @ np.array([[1, 0, 0], [0, 0, 1], [0, 1, 0]], float) + (0.2, 1.1, 0.0)   # upright, facing +z
        s.add(tx.Mesh(p, f, uvs=uv, material=mats[0], name="panel"))
        # vertex normals (smooth shading, the terminator's shadow-ray lift) on a coarse box
        bp, bf = box((0.0, 0.35, 1.1), (0.35, 0.35, 0.3))
        s.add(tx.Mesh(bp, bf, normals=bp - bp.mean(axis=0), uvs=bp[:, :2] * 2.0, material=mats[1], name="smooth"))
    if cylinder:
        s.add(tx.Cylinder(0.2, (0.0, 1.2), origin=(1.9, 0, -0.5), axis_z=(0, 1, 0), material=mats[2], name="post"))
    return s


def _render(monkeypatch, scene, packet, spp, avx512=None, **kw):
    monkeypatch.setenv("TEXRAY_PACKET", str(packet))
    if avx512 is None:
        monkeypatch.delenv("TEXRAY_AVX512", raising=False)
    else:
        monkeypatch.setenv("TEXRAY_AVX512", str(avx512))
    img = tx.render(scene, 48, 36, spp, device="pocl", seed=3, **kw)
    assert img.stats["packet"] == packet
    return img


@pytest.fixture(scope="module")
def pocl():
    try:
        return runtime("pocl")
    except Exception as e:                 # noqa: BLE001 (no PoCL: nothing to compare)
        pytest.skip(f"PoCL is needed: {e}")


@pytest.mark.parametrize("kind", ["every hit a packet's", "with a cylinder", "quads and spheres"])
def test_packet_surfaces_equal_the_scalar_records_bit_for_bit(pocl, monkeypatch, kind):
    scene = _scene(cylinder=kind == "with a cylinder", triangles=kind != "quads and spheres")
    first = kind == "every hit a packet's"        # 8 lanes and adaptive sampling: one program each
    for spp in (1, 4):
        scalar = _render(monkeypatch, scene, 0, spp)
        assert scalar.rgb.std() > 0.05 and np.isfinite(scalar.rgb).all()
        for packet in (8, 16) if first else (16,):
            img = _render(monkeypatch, scene, packet, spp)
            assert np.array_equal(img.rgb, scalar.rgb), (kind, spp, packet)
    if first:
        adaptive = _render(monkeypatch, scene, 16, 8, adaptive=0.05)
        np.testing.assert_array_equal(adaptive.rgb, _render(monkeypatch, scene, 0, 8, adaptive=0.05).rgb)


def test_packet_surfaces_with_avx512_equal_the_scalar_records(pocl, monkeypatch):
    if not cpu_avx512():
        pytest.skip("a CPU with AVX-512")
    scene = _scene()
    scalar = _render(monkeypatch, scene, 0, 4)
    np.testing.assert_array_equal(_render(monkeypatch, scene, 16, 4, avx512=1).rgb, scalar.rgb)


def test_grazing_views_and_misses(pocl, monkeypatch):
    """Rays along the floor (grazing hits, the sky between them) and a camera inside a sphere."""
    scene = _scene(triangles=False)
    for cam in (tx.Camera(eye=(0, 0.004, 1.9), look_at=(0, 0.0, -2), fov_y=20),
                tx.Camera(eye=(-0.9, 0.5, 0.3), look_at=(0, 0.5, -1), fov_y=90)):
        scene.camera = cam
        scalar = _render(monkeypatch, scene, 0, 2)
        assert np.isfinite(scalar.rgb).all()
        np.testing.assert_array_equal(_render(monkeypatch, scene, 16, 2).rgb, scalar.rgb)
