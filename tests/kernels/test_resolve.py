"""The image from the accumulators on the device (kernels/stages/resolve.cl, as
texray.renderer.frame render_rows launches it), and the fused kernel's first launch
starting the sums (stages/fused.cl: no buffer is zeroed before a frame)."""
import numpy as np
import pyopencl as cl
import pytest

import texray as tx
from texray.device.features import Features, compile_options
from texray.renderer import frame


def _resolve(rt, acc, spp):
    """resolve's rgb for the float4 accumulators ``acc`` (n x 4) and divisor ``spp`` (0: each
    pixel's count); one float past the image is checked untouched."""
    prg = rt.program(compile_options(Features()))
    k = cl.Kernel(prg, "resolve")
    n = len(acc)
    mf = cl.mem_flags
    acc_b = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(acc, np.float32))
    out = np.full(3 * n + 1, np.nan, np.float32)
    out_b = cl.Buffer(rt.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=out)
    k(rt.queue, (n + 64,), None, acc_b, out_b, np.uint32(n), np.float32(spp))   # work-items past n do nothing
    cl.enqueue_copy(rt.queue, out, out_b)
    assert np.isnan(out[-1])
    return out[:-1].reshape(n, 3)


def _sums(rng, n):
    """Sums of 1..4096 samples of radiance in [0, 40) (clamped samples: never negative), counts."""
    counts = rng.integers(1, 4097, n).astype(np.float32)
    acc = np.zeros((n, 4), np.float32)
    acc[:, :3] = (rng.random((n, 3)) ** 3 * 40 * counts[:, None]).astype(np.float32)
    acc[:5, :3] = [[0, 0, 0], [1e-30, 3e-39, 0], [40 * 4096, 1, 2], [7, 7, 7], [0.1, 0.2, 0.3]]
    acc[:, 3] = counts
    return acc


@pytest.mark.parametrize("spp", [0, 1, 3, 16, 1000])
def test_the_means_are_the_correctly_rounded_quotients(rt, spp):
    """Each channel over spp (or over the pixel's own count where spp is 0) is the float64
    quotient rounded once to float32 (the quotient of two floats, exact in float64 to 53 bits,
    rounds as IEEE float32 division does)."""
    acc = _sums(np.random.default_rng(spp + 1), 3000)
    got = _resolve(rt, acc, spp)
    d = np.float64(spp) if spp else acc[:, 3:4].astype(np.float64)
    want = (acc[:, :3].astype(np.float64) / d).astype(np.float32)
    np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32))


def test_resolve_on_every_device(any_rt):
    """The same bits on each portability device (PoCL, Intel's runtime, Oclgrind)."""
    acc = _sums(np.random.default_rng(9), 257)
    for spp in (0, 7):
        d = np.float64(spp) if spp else acc[:, 3:4].astype(np.float64)
        want = (acc[:, :3].astype(np.float64) / d).astype(np.float32)
        np.testing.assert_array_equal(_resolve(any_rt, acc, spp).view(np.uint32), want.view(np.uint32))


@pytest.mark.parametrize("kw", [{}, {"adaptive": 0.05}, {"tile_pixels": 40 * 7}, {"split": True}],
                         ids=["one-launch", "adaptive", "tiles", "split-launches"])
def test_a_frame_does_not_read_what_its_buffers_held(device, scenes_dir, monkeypatch, kw):
    """The fused kernel's first launch of a pixel writes its sums (and with adaptive sampling
    its luminance squares; the first round's decision writes every stamp): a render whose
    fresh device buffers hold NaNs and stamps of a later round makes the same image, bit for
    bit, as one whose buffers the driver happened to zero."""
    scene = tx.Scene.load(scenes_dir / "bench/mixed.toml")
    kw = dict(kw)
    if kw.pop("split", False):            # launches of 2 of the 5 samples: later launches add
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
