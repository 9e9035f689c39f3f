"""Adaptive sampling's decision between rounds on the device (kernels/core/adaptive.h,
stages/adaptive.cl, as texray.renderer.frame adaptive_tile launches them): the stopping
rule against tests/reference.py's float64 rule, the 3x3 dilation within blocks of rows and
within the tile, the stamps of earlier rounds, the list of the pixels that go on."""
import numpy as np
import pyopencl as cl
import pytest

import reference as ref
from texray.device.features import Features, compile_options
from texray.renderer.adaptive import BLOCK_ROWS, FLOOR


def _decide(rt, acc, y2, threshold, rows, width, row0=0, listed=None, stamps=None, tag=1, device_length=False):
    """The tile indices that adaptive_count, _scan and _list write after adaptive_mark stamped the
    ``listed`` pixels (default: all, as a first round, with no list) of a tile of rows x width
    pixels from image row ``row0``, starting from ``stamps`` (default zeros); and the stamps.
    ``device_length``: the list's length given as a buffer (a later round's launch: a fixed
    number of work-items looping over the list, core/adaptive.h TX_FOR_LISTED)."""
    prg = rt.program(compile_options(Features(adaptive=True)))
    mark, cnt, scan, lst = (cl.Kernel(prg, k) for k in ("adaptive_mark", "adaptive_count", "adaptive_scan",
                                                         "adaptive_list"))
    n = rows * width
    mf, ctx, q, u = cl.mem_flags, rt.context, rt.queue, np.uint32
    first_round = listed is None            # every pixel: the kernels take no list (NULL)
    listed = np.arange(n, dtype=np.uint32) if first_round else np.asarray(listed, np.uint32)
    acc_b = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(acc, np.float32))
    y2_b = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(y2, np.float32))
    st = np.zeros(n, np.uint8) if stamps is None else np.asarray(stamps, np.uint8).copy()
    st_b = cl.Buffer(ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=st)
    act = np.full(max(n, len(listed)) + 1, 0xFFFFFFFF, np.uint32)      # one entry past the tile: untouched
    act[:len(listed)] = 0xFFFFFFFF if first_round else listed               # a first round reads no list
    act_b = cl.Buffer(ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=act)
    count = np.array([7], np.uint32)
    cnt_b = cl.Buffer(ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=count)
    if len(listed):
        if first_round or not device_length:
            mark(q, (len(listed),), None, acc_b, y2_b, None if first_round else act_b, None, u(len(listed)), st_b,
                 u(tag), np.float32(threshold), np.float32(FLOOR))
        else:                               # a later round: the list's length on the device, 3 work-groups
            len_b = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.array([len(listed)], np.uint32))
            mark(q, (3 * 8,), (8,), acc_b, y2_b, act_b, len_b, u(10 ** 6), st_b, u(tag), np.float32(threshold),
                 np.float32(FLOOR))
    rows_b = cl.Buffer(ctx, mf.READ_WRITE, 4 * rows)
    args = (st_b, u(tag), u(rows), u(width), u(row0), u(BLOCK_ROWS))
    cnt(q, (rows,), None, *args, rows_b)
    scan(q, (1,), None, rows_b, u(rows), cnt_b)
    lst(q, (rows,), None, *args, rows_b, act_b)
    cl.enqueue_copy(q, act, act_b)
    cl.enqueue_copy(q, count, cnt_b)
    cl.enqueue_copy(q, st, st_b)
    assert act[-1] == 0xFFFFFFFF
    out = act[:count[0]]
    assert np.all(np.diff(out.astype(np.int64)) > 0)        # each pixel once, in tile order
    return out, st


def _sums(rng, npix, nmax=16):
    """Accumulated sums of 2..nmax samples per pixel: some noisy, some nearly constant, some dark."""
    n = rng.integers(2, nmax + 1, npix)
    base = rng.choice([0.002, 0.05, 0.5, 3.0], npix)[:, None, None]
    spread = rng.choice([0.0, 1e-4, 0.01, 0.3, 1.0], npix)[:, None, None]
    s = base * (1 + spread * rng.standard_normal((npix, nmax, 3)))
    s = np.maximum(s, 0).astype(np.float32)
    live = np.arange(nmax)[None, :] < n[:, None]
    s = np.where(live[..., None], s, 0)
    y = s.astype(np.float32) @ ref.LUMINANCE.astype(np.float32)
    acc = np.zeros((npix, 4), np.float32)
    acc[:, :3] = s.sum(1)
    acc[:, 3] = n
    return acc, (y * y).sum(1).astype(np.float32)


def test_the_reference_is_the_sample_means_standard_error():
    rng = np.random.default_rng(3)
    samples = rng.random((50, 12, 3))                      # 50 pixels, 12 samples each
    y = samples @ ref.LUMINANCE
    mean, se = ref.adaptive_standard_error(samples.sum(1), (y * y).sum(1), np.full(50, 12))
    np.testing.assert_allclose(mean, y.mean(1), rtol=1e-12)
    np.testing.assert_allclose(se, y.std(1, ddof=1) / np.sqrt(12), rtol=1e-9)


@pytest.mark.parametrize("threshold", [0.5, 0.05, 0.002])
def test_the_device_stops_the_pixels_the_float64_rule_stops(rt, threshold):
    """Random sums (2-16 samples; noisy, nearly constant, dark): the device's float32 stamps
    are the float64 rule's, but where the standard error is within 1e-4 of the bound."""
    rng = np.random.default_rng(int(threshold * 1000))
    rows, width = 24, 40
    acc, y2 = _sums(rng, rows * width)
    _, st = _decide(rt, acc, y2, threshold, rows, width)
    mean, se = ref.adaptive_standard_error(acc[:, :3], y2, acc[:, 3])
    want = ref.adaptive_unconverged(mean, se, threshold)
    bound = threshold * np.maximum(mean, FLOOR)
    clear = np.abs(se - bound) > 1e-4 * bound
    assert clear.mean() > 0.97 and want[clear].any() and not want[clear].all()
    np.testing.assert_array_equal(st[clear] == 1, want[clear])
    assert set(np.unique(st)) <= {0, 1}


def test_a_constant_pixel_has_zero_error_never_negative_variance(rt):
    """Sums whose Y^2 rounds just above or below (sum Y)^2 / n: converged at any threshold."""
    c = np.float32(0.1)
    acc = np.zeros((4, 4), np.float32)
    acc[:, :3], acc[:, 3] = c * 8, 8
    yc = float(ref.LUMINANCE.sum() * c)
    y2 = (8 * yc * yc * np.array([1 - 1e-7, 1, 1 + 1e-7, 1 + 2e-7])).astype(np.float32)
    active, st = _decide(rt, acc, y2, 1e-3, 1, 4)
    assert len(active) == 0 and not st.any()


def test_the_rule_is_relative_with_a_dark_floor_and_dilated(rt):
    """Hand-made sums of 4 samples: se / mean 0.8% is converged at 1%, not at 0.5%; below a
    mean of FLOOR the bound is threshold * FLOOR; one noisy pixel keeps its 3x3
    neighbourhood sampling."""
    rows, width = 5, 6
    npix, n = rows * width, 4

    def sums(mean, se):
        """Sums of n samples with this mean luminance and standard error (grey samples)."""
        var = (se * se) * n
        y = np.float64(mean) * n
        acc = np.zeros((npix, 4), np.float32)
        acc[:, :3], acc[:, 3] = y / ref.LUMINANCE.sum(), n
        return acc, np.full(npix, var * (n - 1) + y * y / n, np.float32)

    assert len(_decide(rt, *sums(0.5, 0.004), 0.01, rows, width)[0]) == 0
    assert len(_decide(rt, *sums(0.5, 0.004), 0.005, rows, width)[0]) == npix
    assert len(_decide(rt, *sums(0.01, 0.0009), 0.01, rows, width)[0]) == 0      # 0.9 of 0.01 * FLOOR
    assert len(_decide(rt, *sums(0.01, 0.0011), 0.01, rows, width)[0]) == npix
    acc, y2 = sums(0.5, 0.004)
    noisy_acc, noisy_y2 = sums(0.5, 1.0)
    k = 2 * width + 3
    acc[k], y2[k] = noisy_acc[k], noisy_y2[k]
    active, _ = _decide(rt, acc, y2, 0.01, rows, width)
    want = np.zeros((rows, width), bool)
    want[1:4, 2:5] = True
    np.testing.assert_array_equal(active, np.flatnonzero(want))


def test_the_dilation_stays_within_a_block_of_rows_and_the_tile(rt):
    """A noisy pixel keeps its neighbours in its own block of BLOCK_ROWS image rows
    sampling, not those across the block's edge, nor outside the tile (a pixel's samples
    depend on its block alone)."""
    B, width = BLOCK_ROWS, 5
    rows = 2 * B
    acc = np.zeros((rows * width, 4), np.float32)
    acc[:, :3], acc[:, 3] = 2.0, 4                          # constant: converged
    y2 = np.full(rows * width, 4 * (0.5 * ref.LUMINANCE.sum()) ** 2, np.float32)
    noisy = acc.copy()
    noisy[(B - 1) * width + 2, :3] = [9.0, 0.0, 0.0]        # the last row of the first block
    y2n = y2.copy()
    y2n[(B - 1) * width + 2] = 40.0
    active, _ = _decide(rt, noisy, y2n, 0.01, rows, width)
    want = np.zeros((rows, width), bool)
    want[B - 2:B, 1:4] = True                               # not row B: the next block
    np.testing.assert_array_equal(active, np.flatnonzero(want))
    # a tile of B rows from image row B (a band's first block): its first row has nothing above
    t_acc, t_y2 = acc[:B * width].copy(), y2[:B * width].copy()
    t_acc[2], t_y2[2] = noisy[(B - 1) * width + 2], y2n[(B - 1) * width + 2]
    active, _ = _decide(rt, t_acc, t_y2, 0.01, B, width, row0=B)
    np.testing.assert_array_equal(active, [1, 2, 3, width + 1, width + 2, width + 3])
    # a tile smaller than a block (a tiny memory limit) that starts mid-block: within the tile
    active, _ = _decide(rt, t_acc[:3 * width], t_y2[:3 * width], 0.01, 3, width, row0=B + 5)
    np.testing.assert_array_equal(active, [1, 2, 3, width + 1, width + 2, width + 3])


@pytest.mark.parametrize("rows, width, row0", [(32, 37, 0), (16, 1, 16), (7, 9, 21), (48, 64, 8)])
def test_the_list_is_the_float64_rule_dilated(rt, rows, width, row0):
    """Random sums, a round that sampled a random subset of a tile's pixels (the others
    carry an older round's stamp or none): the device's list is the reference's
    dilation of the listed pixels' unconverged set, each pixel once."""
    _list_case(rt, rows, width, row0)


def test_the_decision_on_every_device(any_rt):
    """The same on each portability device (PoCL, Intel's runtime, Oclgrind: the atomic
    counter, the byte stamps); Oclgrind's memory checker logs nothing."""
    from conftest import OCLGRIND_LOG
    size = OCLGRIND_LOG.stat().st_size if OCLGRIND_LOG.exists() else 0
    _list_case(any_rt, 40, 23, 8)
    rng = np.random.default_rng(5)                          # a first round: no list (NULL)
    acc, y2 = _sums(rng, 16 * 9)
    active, _ = _decide(any_rt, acc, y2, 0.05, 16, 9)
    mean, se = ref.adaptive_standard_error(acc[:, :3], y2, acc[:, 3])
    bound = 0.05 * np.maximum(mean, FLOOR)
    assert np.all(np.abs(se - bound) > 1e-4 * bound)
    want = np.flatnonzero(ref.adaptive_dilate(ref.adaptive_unconverged(mean, se, 0.05), 16, 9))
    np.testing.assert_array_equal(active, want)
    if OCLGRIND_LOG.exists() and OCLGRIND_LOG.stat().st_size != size:
        with open(OCLGRIND_LOG) as f:
            f.seek(size)
            pytest.fail(f"{any_rt.device.name} logged:\n{f.read()[:4000]}")


def _list_case(rt, rows, width, row0):
    rng = np.random.default_rng(rows * 1000 + width)
    npix = rows * width
    acc, y2 = _sums(rng, npix)
    quiet = rng.random(npix) < 0.93                       # most pixels constant (grey 0.3): converged
    acc[quiet, :3] = acc[quiet, 3:4] * np.float32(0.3)
    y2[quiet] = acc[quiet, 3] * np.float32(0.09)
    threshold = 0.05
    listed = np.flatnonzero(rng.random(npix) < 0.6)
    acc[listed[len(listed) // 2]], y2[listed[len(listed) // 2]] = (9, 0, 0, 4), 40     # one surely noisy
    stamps = rng.choice([0, 1, 2], npix).astype(np.uint8)                    # older rounds' stamps: tag 3 now
    active, st = _decide(rt, acc, y2, threshold, rows, width, row0=row0, listed=listed, stamps=stamps, tag=3)
    looped = _decide(rt, acc, y2, threshold, rows, width, row0=row0, listed=listed, stamps=stamps, tag=3,
                     device_length=True)
    np.testing.assert_array_equal(looped[0], active)
    np.testing.assert_array_equal(looped[1], st)
    mean, se = ref.adaptive_standard_error(acc[:, :3], y2, acc[:, 3])
    bound = threshold * np.maximum(mean, FLOOR)
    assert np.all(np.abs(se - bound)[listed] > 1e-4 * bound[listed])        # no pixel on the edge of the rule
    open_ = np.zeros(npix, bool)
    open_[listed] = ref.adaptive_unconverged(mean, se, threshold)[listed]
    want = np.flatnonzero(ref.adaptive_dilate(open_, rows, width, row0))
    np.testing.assert_array_equal(active, want)
    assert 0 < len(want) < npix
    unlisted = np.setdiff1d(np.arange(npix), listed)
    np.testing.assert_array_equal(st[unlisted], stamps[unlisted])            # only the round's pixels stamped
