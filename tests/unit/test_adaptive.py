"""Adaptive sampling's error estimate and stopping rule (texray.renderer.adaptive)
against float64 numpy."""
import numpy as np

from texray.renderer import adaptive as A


def test_standard_error_is_the_sample_means_standard_error():
    rng = np.random.default_rng(3)
    samples = rng.random((50, 12, 3)).astype(np.float32)           # 50 pixels, 12 samples each
    y = samples.astype(np.float64) @ A.LUMINANCE.astype(np.float64)
    mean, se = A.standard_error(samples.astype(np.float64).sum(1), (y * y).sum(1), np.full(50, 12))
    np.testing.assert_allclose(mean, y.mean(1), rtol=1e-12)
    np.testing.assert_allclose(se, y.std(1, ddof=1) / np.sqrt(12), rtol=1e-9)


def test_a_constant_pixel_has_zero_error_never_negative_variance():
    c = np.float32(0.1)
    s = np.full((4, 3), c * 8, np.float32)
    y2 = np.full(4, 8 * float(A.LUMINANCE.sum() * c) ** 2 * (1 + 1e-7), np.float32)   # rounding above and below
    mean, se = A.standard_error(s, y2, np.full(4, 8))
    assert np.all(se >= 0) and np.all(se < 1e-4) and np.allclose(mean, A.LUMINANCE.sum() * 0.1 * 8 / 8)


def test_stopping_rule_is_relative_with_a_dark_floor_and_dilated():
    rows, width = 5, 6
    mean = np.full(rows * width, 0.5)
    se = np.full(rows * width, 0.004)           # 0.8% of 0.5: converged at 1%
    assert not A.still_active(mean, se, 0.01, rows, width).any()
    assert A.still_active(mean, se, 0.005, rows, width).all()
    dark = np.full(rows * width, 0.01)          # below the floor: 1% of 0.1
    assert not A.still_active(dark, np.full(rows * width, 0.0009), 0.01, rows, width).any()
    assert A.still_active(dark, np.full(rows * width, 0.0011), 0.01, rows, width).all()
    se2 = se.copy()
    se2[2 * width + 3] = 1.0                    # one noisy pixel keeps its 3x3 neighbourhood sampling
    act = A.still_active(mean, se2, 0.01, rows, width).reshape(rows, width)
    want = np.zeros((rows, width), bool)
    want[1:4, 2:5] = True
    np.testing.assert_array_equal(act, want)


def test_round_sizes():
    assert [A.round_size(s) for s in (1, 4, 8, 16, 64, 1024)] == [1, 4, 4, 4, 8, 128]
    # then each round as many samples as all before it, up to spp in all
    assert A.round_sizes(32) == [4, 4, 8, 16]
    assert A.round_sizes(24) == [4, 4, 8, 8]
    assert A.round_sizes(1024) == [128, 128, 256, 512]
    assert A.round_sizes(3) == [3] and A.round_sizes(5) == [4, 1]
    for spp in range(1, 300):
        r = A.round_sizes(spp)
        assert sum(r) == spp and min(r) >= 1 and len(r) <= 8



def test_the_dilation_stays_within_a_block_of_rows():
    """A noisy pixel keeps its neighbours in its own block of BLOCK_ROWS rows sampling,
    not those across the block's edge: a pixel's samples depend on its block only."""
    B, width = A.BLOCK_ROWS, 5
    rows = 2 * B
    mean, se = np.full(rows * width, 0.5), np.full(rows * width, 0.0)
    se[(B - 1) * width + 2] = 1.0                  # the last row of the first block
    act = A.still_active(mean, se, 0.01, rows, width).reshape(rows, width)
    want = np.zeros((rows, width), bool)
    want[B - 2:B, 1:4] = True                      # not row B: the next block
    np.testing.assert_array_equal(act, want)
    # the same tile seen from a band that starts at the second block: rows are image rows
    act2 = A.still_active(mean[B * width:], se[B * width:], 0.01, B, width, y0=B).reshape(B, width)
    assert not act2.any()
    se3 = np.zeros(B * width)
    se3[0 * width + 2] = 1.0                       # the band's first row: nothing above it in its block
    act3 = A.still_active(mean[:B * width], se3, 0.01, B, width, y0=B).reshape(B, width)
    assert act3[:2, 1:4].all() and act3.sum() == 6
