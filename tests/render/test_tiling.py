"""Tiles, memory limits and streamed output: a launch never holds more rays than
fit the device (or the memory limit the caller sets), and a render split into
many tiles, or streamed to a file band by band, is the same image as one tile.

A 16k x 16k render on a device with little memory is planned here exactly
(plan_rows against a device model with 256 MiB); rendering all 268M pixels
takes minutes on PoCL, so the streamed render below runs the full 16384-pixel
width over a few rows with a memory limit that allows only one row per tile."""
from types import SimpleNamespace

import numpy as np
import pytest

import texray as tx
from texray.device import layout
from texray.errors import DeviceError, SceneError
from texray.io.images import read_image
from texray.renderer import render, render_to_file
from texray.renderer.render import RAY_BYTES as _RAY_BYTES
from texray.renderer.tiling import MAX_TILE_PIXELS, plan_rows


def _scene():
    scene = tx.Scene(camera=tx.Camera(eye=(0, 1.2, 3), look_at=(0, 0.3, 0)),
                     lights=[tx.PointLight((2, 4, 3), (30, 30, 30))])
    checker = tx.Texture.from_array(np.kron((np.indices((8, 8)).sum(0) % 2), np.ones((4, 4)))[:, :, None]
                                    * np.array([0.8, 0.7, 0.5]) + 0.1)
    scene.add(tx.Sphere(center=(0, 0.5, 0), radius=0.5, material=tx.Material(diffuse=checker)))
    scene.add(tx.Quad((-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)))
    return scene


def _device(global_mem, max_alloc=None):
    return SimpleNamespace(global_mem_size=global_mem, max_mem_alloc_size=max_alloc or global_mem // 4,
                           name="model device")


def test_plan_16k_on_a_small_device():
    per_ray = _RAY_BYTES + 1
    dev = _device(256 << 20)
    rows = plan_rows(16384, 16384, per_ray, scene_bytes=10 << 20, dev=dev)
    # default limit: a quarter of the device; the rays of one tile fit what the scene leaves
    assert 1 <= rows < 16384
    assert rows * 16384 * per_ray + (10 << 20) <= (256 << 20) // 4
    assert rows * 16384 <= MAX_TILE_PIXELS
    # a tighter limit gives fewer rows, never zero
    tight = plan_rows(16384, 16384, per_ray, scene_bytes=10 << 20, dev=dev,
                      memory_limit=(10 << 20) + 16384 * per_ray)
    assert tight == 1
    # the largest single buffer (the Surface records) stays under the allocation limit
    dev2 = _device(1 << 34, max_alloc=1 << 24)
    rows2 = plan_rows(16384, 16384, per_ray, 0, dev2)
    assert rows2 * 16384 * layout.SURFACE.itemsize <= 1 << 24


def test_plan_refuses_when_not_one_row_fits():
    with pytest.raises(DeviceError, match="memory limit"):
        plan_rows(16384, 16384, _RAY_BYTES + 1, scene_bytes=63 << 20, dev=_device(256 << 20))
    with pytest.raises(SceneError, match="memory_limit"):
        plan_rows(64, 64, 100, 0, _device(1 << 30), memory_limit=-1)


def test_many_tiles_equal_one(device):
    scene = _scene()
    one = render(scene, 40, 30, 3, device=device, seed=7)
    assert one.stats["tiles"] == 1
    scene_bytes = sum(one.stats["device_bytes"].values())
    per_ray = one.stats["ray_buffer_bytes"] // (one.stats["tile_rows"] * 40)
    many = render(scene, 40, 30, 3, device=device, seed=7, memory_limit=scene_bytes + 3 * 40 * per_ray)
    assert many.stats["tile_rows"] == 3 and many.stats["tiles"] == 10
    np.testing.assert_array_equal(many.rgb, one.rgb)
    odd = render(scene, 40, 30, 3, device=device, seed=7, tile_pixels=40 * 7, aovs=("depth",))
    np.testing.assert_array_equal(odd.rgb, one.rgb)
    assert odd.aov["depth"].shape == (30, 40, 1)


def test_local_sizes_do_not_change_the_image(device):
    scene = _scene()
    ref = render(scene, 37, 23, 2, device=device, local_size=0)     # 851 pixels: not a multiple of any size
    for ls in (1, 16, 64):
        img = render(scene, 37, 23, 2, device=device, local_size=ls)
        assert img.stats["local_size"] == ls
        np.testing.assert_array_equal(img.rgb, ref.rgb)
    with pytest.raises(DeviceError, match="local_size"):
        render(scene, 8, 8, 1, device=device, local_size=-3)


def test_stream_full_16k_width_with_one_row_per_tile(device, tmp_path):
    scene = _scene()
    width, height = 16384, 4
    ref = render(scene, width, height, 1, device=device, seed=3)
    scene_bytes = sum(ref.stats["device_bytes"].values())
    per_ray = ref.stats["ray_buffer_bytes"] // (ref.stats["tile_rows"] * width)
    bands = []
    img = render(scene, width, height, 1, device=device, seed=3, memory_limit=scene_bytes + width * per_ray,
                 sink=lambda y0, rgb, aov: bands.append((y0, rgb.copy())))
    assert img.rgb is None and img.stats["tile_rows"] == 1
    assert [y for y, _ in bands] == [0, 1, 2, 3]
    np.testing.assert_array_equal(np.concatenate([b for _, b in bands]), ref.rgb)
    out = tmp_path / "wide.exr"
    stats = render_to_file(scene, out, width, height, 1, device=device, seed=3,
                           memory_limit=scene_bytes + width * per_ray)
    assert stats["tiles"] == 4
    px, _ = read_image(out)
    # EXR stores half floats: 2^-11 relative
    np.testing.assert_allclose(px[:, :, :3], ref.rgb, rtol=2 ** -10, atol=1e-6)
