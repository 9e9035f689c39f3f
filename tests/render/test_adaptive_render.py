"""Adaptive sampling in whole renders: fewer samples where the image has converged, the
error of the full render, and with a vanishing threshold the full render itself."""
import numpy as np
import pytest

import texray as tx
from texray.errors import SceneError


def _scene(scenes_dir):
    return tx.Scene.load(scenes_dir / "showcase.toml")


def test_adaptive_takes_fewer_samples_for_the_same_error(scenes_dir, device):
    scene = _scene(scenes_dir)
    ref = tx.render(scene, 64, 48, 256, device=device, seed=11).rgb
    full = tx.render(scene, 64, 48, 32, device=device)
    ada = tx.render(scene, 64, 48, 32, device=device, adaptive=0.03)
    assert full.stats["samples"] == 64 * 48 * 32 and ada.stats["samples"] < 0.9 * full.stats["samples"]
    assert np.all(np.isfinite(ada.rgb))
    err = lambda img: np.sqrt(np.mean((img - ref) ** 2))
    assert err(ada.rgb) < 1.15 * err(full.rgb), (err(ada.rgb), err(full.rgb))


def test_a_vanishing_threshold_samples_every_noisy_pixel_fully(scenes_dir, device):
    scene = _scene(scenes_dir)
    full = tx.render(scene, 48, 32, 16, device=device)
    ada = tx.render(scene, 48, 32, 16, device=device, adaptive=1e-30)
    # only pixels of zero variance (background, flat unshadowed ones) stop early
    np.testing.assert_allclose(ada.rgb, full.rgb, rtol=1e-5, atol=1e-6)
    assert ada.stats["samples"] <= full.stats["samples"]


def test_adaptive_is_deterministic_and_bounded_by_spp(scenes_dir, device):
    scene = _scene(scenes_dir)
    a = tx.render(scene, 40, 30, 24, device=device, adaptive=0.05, tile_pixels=40 * 7)
    b = tx.render(scene, 40, 30, 24, device=device, adaptive=0.05, tile_pixels=40 * 7)
    assert np.array_equal(a.rgb, b.rgb) and a.stats["samples"] == b.stats["samples"] <= 40 * 30 * 24


def test_a_tile_of_several_blocks_takes_the_samples_of_one_block_at_a_time(scenes_dir, device):
    """A tile of several blocks (one list of its active pixels, decided on the device:
    texray.renderer.frame adaptive_tile) and tiles of one block each: the same image bit for
    bit and the same sample count, with and without a progress callback."""
    from texray.renderer.adaptive import BLOCK_ROWS
    scene = _scene(scenes_dir)
    one_block = tx.render(scene, 40, 96, 24, device=device, adaptive=0.05, tile_pixels=40 * BLOCK_ROWS)
    assert one_block.stats["tile_rows"] == BLOCK_ROWS
    seen = []
    whole = tx.render(scene, 40, 96, 24, device=device, adaptive=0.05, progress=seen.append)
    assert whole.stats["tile_rows"] == 96 and seen[-1] == 1.0 and seen == sorted(seen)
    assert seen.count(1.0) == 1 and len(seen) >= 2
    assert np.array_equal(whole.rgb, one_block.rgb)
    assert whole.stats["samples"] == one_block.stats["samples"] < 40 * 96 * 24
    assert np.isfinite(whole.rgb).all() and whole.rgb.std() > 0.01


def test_later_rounds_take_every_listed_pixel_once_whatever_their_work_items(scenes_dir, device, monkeypatch):
    """Rounds after the first read the list's length on the device and loop over it
    (stages/fused.cl render_fused, frame.LATER_GROUPS work-groups): one work-group, the
    default and as many as the tile's groups of pixels give the same image bit for bit and the
    same samples; the samples are the rounds' lists' lengths as the host reads them back
    (every pixel's first round, then each list's pixels the next round's: a pixel that had
    converged adds nothing, and a round on an empty list samples nothing)."""
    from texray.renderer import frame
    from texray.renderer.adaptive import round_sizes
    scene = _scene(scenes_dir)
    ref = tx.render(scene, 40, 48, 32, device=device, adaptive=0.05)
    assert 40 * 48 * 4 < ref.stats["samples"] < 40 * 48 * 32
    for groups in (1, 10 ** 6):
        monkeypatch.setattr(frame, "LATER_GROUPS", groups)
        img = tx.render(scene, 40, 48, 32, device=device, adaptive=0.05)
        np.testing.assert_array_equal(img.rgb.view(np.uint32), ref.rgb.view(np.uint32))
        assert img.stats["samples"] == ref.stats["samples"]
    # every pixel converged after the first round: no list, no later samples
    first = round_sizes(32)[0]
    assert tx.render(scene, 40, 48, 32, device=device, adaptive=1e6).stats["samples"] == 40 * 48 * first
    # a vanishing threshold: every round takes every pixel but the constant ones (the sky's,
    # converged at any threshold) and their blocks
    tiny = tx.render(scene, 40, 48, 32, device=device, adaptive=1e-9)
    assert ref.stats["samples"] < tiny.stats["samples"] < 40 * 48 * 32
    monkeypatch.setattr(frame, "LATER_GROUPS", 1)
    assert tx.render(scene, 40, 48, 32, device=device, adaptive=1e-9).stats["samples"] == tiny.stats["samples"]


@pytest.mark.parametrize("value, match", [(0, r"adaptive: expected a number in \(0, inf\)"),
                                          (float("nan"), "adaptive"), ("x", "adaptive")])
def test_bad_thresholds_are_named(value, match):
    with pytest.raises(SceneError, match=match):
        tx.render(tx.Scene(), 8, 8, 4, adaptive=value)


def test_adaptive_needs_the_fused_pipeline():
    with pytest.raises(SceneError, match="fused"):
        tx.render(tx.Scene(), 8, 8, 4, adaptive=0.1, pipeline="stages")


def test_scene_files_and_the_cli_take_the_threshold(tmp_path):
    import pytest
    import texray as tx
    from texray.cli import main
    from texray.errors import SceneError
    path = tmp_path / "s.toml"
    path.write_text('[render]\nwidth = 8\nheight = 6\nspp = 8\nadaptive = 0.05\n'
                    '[[lights]]\nposition = [0, 2, 4]\n[[objects]]\ntype = "sphere"\n')
    assert tx.Scene.load(path).render_settings["adaptive"] == 0.05
    assert main(["render", str(path), "-o", str(tmp_path / "o.png")]) == 0 and (tmp_path / "o.png").exists()
    path.write_text('[render]\nadaptive = -1\n')
    with pytest.raises(SceneError, match=r"render\.adaptive: expected a number in \(0, inf\), got -1"):
        tx.Scene.load(path)
    with pytest.raises(SystemExit):
        main(["render", str(path), "-o", str(tmp_path / "o.png"), "--adaptive", "0"])
