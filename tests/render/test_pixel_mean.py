"""The image the device writes (kernels/core/common.h pixel_mean, from stages/fused.cl and
stages/shade.cl): each pixel's accumulated sums over its sample count, and the fused
kernel's first launch of a pixel starting the sums (nothing is zeroed before a frame)."""
import numpy as np
import pyopencl as cl
import pytest

import texray as tx
from texray.renderer import frame

from conftest import PORTABILITY_DEVICES


def _render_keeping_sums(monkeypatch, scene, w, h, spp, **kw):
    """(image, the accumulators (h*w x 4: sum R, G, B, count) as the render left them); one tile."""
    runs = []
    init = frame._Run.__init__

    def keep(self, *a, **k):
        init(self, *a, **k)
        runs.append(self)
    monkeypatch.setattr(frame._Run, "__init__", keep)
    img = tx.render(scene, w, h, spp, **kw)
    monkeypatch.setattr(frame._Run, "__init__", init)
    assert len(runs) == 1 and img.stats["tiles"] == 1
    run = runs[0]
    acc = np.empty((w * h, 4), np.float32)
    cl.enqueue_copy(run.rt.queue, acc, run.accum)
    return img, acc


def _check_quotient(img, acc, ulps=0):
    """Every pixel is its sums over its count, rounded once (the quotient of two floats,
    exact in float64's 53 bits, rounds as IEEE float32 division does); within ``ulps`` units
    in the last place where the device's division may be OpenCL's (2.5 ulp: GPUs)."""
    want = (acc[:, :3].astype(np.float64) / acc[:, 3:4].astype(np.float64)).astype(np.float32)
    got = img.rgb.reshape(-1, 3)
    if ulps == 0:
        np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32))
    else:
        assert np.all(np.abs(got.view(np.int32).astype(np.int64) - want.view(np.int32)) <= ulps)


@pytest.mark.parametrize("kw", [{}, {"pipeline": "stages"}, {"adaptive": 0.05}, {"split": True}],
                         ids=["fused", "stages", "adaptive", "split-launches"])
def test_the_image_is_the_sums_over_the_counts(device, scenes_dir, monkeypatch, kw):
    scene = tx.Scene.load(scenes_dir / "bench/mixed.toml")
    kw = dict(kw)
    if kw.pop("split", False):            # launches of 2 of the 5 samples: later launches add
        monkeypatch.setattr(frame, "fused_samples", lambda w, h, spp, rows=1: 2)
    img, acc = _render_keeping_sums(monkeypatch, scene, 40, 32, 5, device=device, seed=3, **kw)
    _check_quotient(img, acc)
    assert np.all(np.isfinite(img.rgb)) and img.rgb.max() > 0.05
    if "adaptive" in kw:
        assert acc[:, 3].sum() == img.stats["samples"] < 40 * 32 * 5 and set(np.unique(acc[:, 3])) == {4, 5}
    else:
        assert np.all(acc[:, 3] == 5)


@pytest.mark.parametrize("d", PORTABILITY_DEVICES, ids=[f"{d.type}:{d.name[:24]}" for d in PORTABILITY_DEVICES])
def test_the_image_is_the_sums_over_the_counts_on_every_device(scenes_dir, monkeypatch, d):
    """The same on each portability device (PoCL, Intel's runtime, Oclgrind): their division
    rounds once, as numpy's did on the host; OpenCL allows 2.5 ulp without
    -cl-fp32-correctly-rounded-divide-sqrt, which GPUs take (3 ulp allowed there)."""
    scene = tx.Scene.load(scenes_dir / "bench/globe.toml")
    img, acc = _render_keeping_sums(monkeypatch, scene, 16, 12, 3, device=d.index, seed=2)
    _check_quotient(img, acc, ulps=0 if d.type == "cpu" else 3)
    assert np.all(acc[:, 3] == 3)


@pytest.mark.parametrize("kw", [{}, {"adaptive": 0.05}, {"tile_pixels": 40 * 7}, {"split": True}],
                         ids=["one-launch", "adaptive", "tiles", "split-launches"])
def test_a_frame_does_not_read_what_its_buffers_held(device, scenes_dir, monkeypatch, kw):
    """The fused kernel's first launch of a pixel writes its sums (and with adaptive sampling
    its luminance squares; the first round's decision writes every stamp): a render whose
    fresh device buffers hold NaNs and stamps of a later round makes the same image, bit for
    bit, as one whose buffers the driver happened to zero."""
    scene = tx.Scene.load(scenes_dir / "bench/mixed.toml")
    kw = dict(kw)
    if kw.pop("split", False):
        monkeypatch.setattr(frame, "fused_samples", lambda w, h, spp, rows=1: 2)
    ref = tx.render(scene, 40, 32, 5, device=device, seed=3, **kw)
    init = frame._Run.__init__

    def dirty(self, *a, **k):
        init(self, *a, **k)
        q = self.rt.queue
        cl.enqueue_fill_buffer(q, self.accum, np.float32(np.nan), 0, self.n_max * 16)
        cl.enqueue_fill_buffer(q, self.rgb, np.float32(np.nan), 0, self.n_max * 12)
        if self.sum_y2 is not None:
            cl.enqueue_fill_buffer(q, self.sum_y2, np.float32(np.nan), 0, self.n_max * 4)
            cl.enqueue_fill_buffer(q, self.stamp, np.uint8(2), 0, self.n_max)      # the second round's tag
    monkeypatch.setattr(frame._Run, "__init__", dirty)
    img = tx.render(scene, 40, 32, 5, device=device, seed=3, **kw)
    assert np.all(np.isfinite(img.rgb)) and img.rgb.max() > 0.05
    np.testing.assert_array_equal(img.rgb.view(np.uint32), ref.rgb.view(np.uint32))
    if "adaptive" in kw:
        assert img.stats["samples"] == ref.stats["samples"] < 40 * 32 * 5
