"""Every scene in scenes/ renders its stored image (tests/scene_images.py): bit for bit
(the sha256 of the float32 image) on the device that stored it, and on every test device
(tests/conftest.py) within the device-agreement tolerance (at most 0.1% of pixels off by more than
0.02, mean absolute difference below 1e-4 elsewhere; the 16-bit sRGB PNG holds the
image to 2e-5). A new scene without a stored image fails: store it with
``python tests/scene_images.py --write``."""
import json

import numpy as np
import pytest

import scene_images as S

STORED = json.loads((S.STORE / "hashes.json").read_text())


@pytest.mark.parametrize("path", S.scene_paths(), ids=S.key)
def test_scene_renders_its_stored_image(path, device):
    assert S.key(path) in STORED["scenes"], f"{S.key(path)}: no stored image; run tests/scene_images.py --write"
    assert (STORED["width"], STORED["height"], STORED["spp"]) == (S.WIDTH, S.HEIGHT, S.SPP)
    rgb = S.render(path, device=device)
    assert np.all(np.isfinite(rgb))
    ref = S.read_png(S.png_path(path))
    diff = np.abs(np.clip(rgb, 0, 1) - ref).max(axis=2)
    assert np.mean(diff > 0.02) <= 1e-3, f"{np.mean(diff > 0.02):.3%} of the pixels differ by more than 0.02"
    assert diff[diff <= 0.02].mean() < 1e-4
    if S.device_signature(device) == STORED["device"]:
        assert S.sha256(rgb) == STORED["scenes"][S.key(path)], "not bit-identical to the stored image"


def test_every_stored_image_has_a_scene():
    assert sorted(STORED["scenes"]) == sorted(S.key(p) for p in S.scene_paths())
