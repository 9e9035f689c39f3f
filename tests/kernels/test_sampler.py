"""Pixel sampling: correlated multi-jittered samples are stratified in 2-D and in each
1-D projection, deterministic per seed, and average to the box-filtered pixel."""
import numpy as np
import pyopencl as cl
import pytest

import texray as tx
from texray.device import layout
from texray.device.features import Features, compile_options


def _sample_positions(rt, spp, width=3, height=2, seed=7, adaptive=False):
    """(spp, height*width, 2) sample positions inside their pixels, from the raygen kernel's
    rays (``adaptive``: the adaptive program's sample order, core/sampler.h cmj_cell)."""
    prg = rt.program(compile_options(Features(adaptive=adaptive)))
    cam = tx.Camera(eye=(0, 0, 0), look_at=(0, 0, -1), fov_y=90)
    eye, fwd, right, up = cam.basis(width / height)
    c = np.zeros(1, layout.CAMERA)
    c["eye"], c["forward"], c["right"], c["up"] = eye, fwd, right, up
    mf = cl.mem_flags
    cam_buf = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=c)
    n = width * height
    rays = cl.Buffer(rt.context, mf.READ_WRITE, n * layout.RAY.itemsize)
    out = []
    k = cl.Kernel(prg, "raygen")
    u = np.uint32
    for s in range(spp):
        k(rt.queue, (n,), None, rays, cam_buf, u(width), u(height), u(0), u(0), u(width), u(n), u(s), u(spp), u(seed), u(1))
        r = np.zeros(n, layout.RAY)
        cl.enqueue_copy(rt.queue, r, rays)
        d = r["dir"].astype(np.float64)
        x = (d @ right) / (right @ right)
        y = (d @ up) / (up @ up)
        px = (x + 1) / 2 * width
        py = (1 - y) / 2 * height
        ix, iy = np.meshgrid(np.arange(width), np.arange(height))
        out.append(np.stack([px - ix.ravel(), py - iy.ravel()], axis=-1))
    return np.array(out)


def _grid(spp):
    """The kernel's m x n grid: m the largest divisor of spp not above sqrt(spp)."""
    m = int(np.floor(np.sqrt(spp)))
    while spp % m:
        m -= 1
    return m, spp // m


@pytest.mark.parametrize("adaptive", [False, True])
@pytest.mark.parametrize("spp", [1, 2, 4, 5, 7, 12, 16, 30, 32])
def test_samples_are_stratified(rt, spp, adaptive):
    pos = _sample_positions(rt, spp, adaptive=adaptive)
    assert np.all((pos >= 0) & (pos < 1))
    m, n = _grid(spp)
    assert m * n == spp
    for pixel in range(pos.shape[1]):
        x, y = pos[:, pixel, 0], pos[:, pixel, 1]
        # in each 1-D projection no two samples share one of the N intervals (float32 slack 1e-5) ...
        for v in (x, y):
            lo = np.floor(v * spp + 1e-5).astype(int)
            hi = np.floor(v * spp - 1e-5).astype(int)
            assert len(set(lo.tolist())) == spp or len(set(hi.tolist())) == spp, (spp, pixel, v)
        # ... and every cell of the m x n grid holds exactly one sample: the pattern covers
        # the whole pixel (Kensler's ceil(N/m) rows left part of it unsampled for N = 32).
        cells = np.floor(x * m).astype(int) * n + np.floor(y * n).astype(int)
        assert sorted(cells.tolist()) == list(range(spp)), (spp, pixel)


@pytest.mark.parametrize("adaptive", [False, True])
@pytest.mark.parametrize("spp", [3, 7, 32, 35])
def test_samples_are_uniform_over_the_pixel(rt, spp, adaptive):
    """Unbiased: over many pixels' patterns the samples are uniform in the pixel. The
    quadrant fractions are 1/4 within 5 standard deviations of a binomial count."""
    pos = _sample_positions(rt, spp, width=48, height=32, adaptive=adaptive).reshape(-1, 2)
    total = len(pos)
    for qx in (0, 1):
        for qy in (0, 1):
            inside = np.mean(((pos[:, 0] >= 0.5) == qx) & ((pos[:, 1] >= 0.5) == qy))
            assert abs(inside - 0.25) < 5 * np.sqrt(0.25 * 0.75 / total), (spp, qx, qy, inside)
    # the corner band the old 5 x 7 grid never reached for 32 spp
    corner = np.mean((pos[:, 0] > 0.6) & (pos[:, 1] > 6 / 7))
    assert abs(corner - 0.4 / 7) < 5 * np.sqrt(0.057 / total) + 1e-3, (spp, corner)


@pytest.mark.parametrize("spp", [16, 32, 64, 12, 24])
def test_adaptive_prefixes_are_stratified(rt, spp):
    """Adaptive sampling may stop a pixel after any round (texray.renderer.adaptive): in its
    order (cmj_cell) the first n samples of the m x n grid take every row once and the
    columns in turn, the first 2n every row twice; Kensler's order, a random permutation,
    leaves rows empty. Each sample alone is still uniform over the pixel (the test above)."""
    m, n = _grid(spp)
    for adaptive in (True, False):
        pos = _sample_positions(rt, spp, width=8, height=4, adaptive=adaptive)
        row = np.floor(pos[..., 1] * n).astype(int)            # (spp, pixels)
        col = np.floor(pos[..., 0] * m).astype(int)
        stratified = []
        for t in (1, 2):
            for p in range(pos.shape[1]):
                rows = np.bincount(row[:t * n, p], minlength=n)
                cols = np.bincount(col[:t * n, p], minlength=m)
                stratified.append(np.all(rows == t) and cols.max() - cols.min() <= 1)
        if adaptive:
            assert all(stratified), (spp, row[:n].T, col[:n].T)
        else:
            assert not all(stratified)


def test_pixels_get_different_patterns_and_seeds_are_deterministic(rt):
    a = _sample_positions(rt, 4, seed=1)
    b = _sample_positions(rt, 4, seed=1)
    c = _sample_positions(rt, 4, seed=2)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    assert not np.allclose(a[:, 0], a[:, 1])


_PACKET_KERNEL = r"""
#include "core/common.h"
#include "core/sampler.h"
#if TX_TEST_W == 16
#define TX_TEST_SAMPLE(s, N, m, p, x, y) cmj_sample_packet16(vload16(0, s), N, m, vload16(0, p), x, y)
#else
#define TX_TEST_SAMPLE(s, N, m, p, x, y) cmj_sample_packet8(vload8(0, s), N, m, vload8(0, p), x, y)
#endif

/* Per work-item: TX_TEST_W samples s[lane] of patterns p[lane] (one per lane, as a chunk
 * spanning several pixels has) with count N[i], by the scalar cmj_sample_m and by
 * cmj_sample_packet, as (x, y) pairs side by side. */
__kernel void packet_vs_scalar(__global const uint* s, __global const uint* N, __global const uint* p,
                               __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    uint m = cmj_grid_m(N[i]);
    float x[TX_TEST_W], y[TX_TEST_W];
    uint sl[TX_TEST_W], pl[TX_TEST_W];
    for (uint j = 0; j < TX_TEST_W; ++j) { sl[j] = s[TX_TEST_W * i + j]; pl[j] = p[TX_TEST_W * i + j]; }
    TX_TEST_SAMPLE(sl, N[i], m, pl, x, y);
    __global float* o = out + 4 * TX_TEST_W * i;
    for (uint j = 0; j < TX_TEST_W; ++j) {
        float2 v = cmj_sample_m(sl[j], N[i], m, pl[j]);
        o[4 * j] = v.x; o[4 * j + 1] = v.y; o[4 * j + 2] = x[j]; o[4 * j + 3] = y[j];
    }
}
"""


@pytest.mark.parametrize("adaptive", [0, 1])
@pytest.mark.parametrize("width,lanes", [(8, 8), (8, 16), (16, 16)])
def test_packet_samples_are_the_scalar_ones_bit_for_bit(rt, rng, width, lanes, adaptive):
    """stages/fused.cl takes its chunks' sample positions from cmj_sample_packet8 and 16: every lane
    must be cmj_sample_m's position bit for bit, for power-of-two counts (mask and shift)
    and others (cycle walking and divisions), for one pixel's consecutive samples (lanes past
    the count too: a partial chunk) and for lanes of different pixels (their own patterns),
    for large counts and patterns."""
    from kernel_harness import build_test_program
    lanes = 16                                           # core/sampler.h TX_TEST_W, at either packet width
    counts = np.array([1, 2, 3, 4, 5, 7, 8, 12, 16, 30, 32, 64, 100, 127, 256, 1000, 4096, 65536, 70000],
                      np.uint32)
    N = np.repeat(counts, 40)
    s0 = (rng.integers(0, 1 << 20, N.size) % (N + lanes)).astype(np.uint32)   # some chunks run past N
    s0[::7] = 0
    s = (s0[:, None] + np.arange(lanes, dtype=np.uint32)).astype(np.uint32)
    p = np.repeat(rng.integers(0, 1 << 32, N.size, dtype=np.uint64).astype(np.uint32)[:, None], lanes, axis=1)
    mixed = np.arange(N.size) % 2 == 1                   # chunks over several pixels: a pattern per lane
    p[mixed] = rng.integers(0, 1 << 32, (mixed.sum(), lanes), dtype=np.uint64).astype(np.uint32)
    s[mixed] = (rng.integers(0, 1 << 20, (mixed.sum(), lanes)) % N[mixed, None]).astype(np.uint32)
    k = build_test_program(rt, (), _PACKET_KERNEL, (f"-DTX_PACKET={width}", f"-DTX_ADAPTIVE={adaptive}",
                                                        f"-DTX_TEST_W={lanes}"))
    mf = cl.mem_flags
    bufs = [cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))
            for a in (s, N, p)]
    out = np.zeros(N.size * lanes * 4, np.float32)
    bo = cl.Buffer(rt.context, mf.WRITE_ONLY, out.nbytes)
    k.packet_vs_scalar(rt.queue, (N.size,), None, *bufs, bo, np.uint32(N.size))
    cl.enqueue_copy(rt.queue, out, bo)
    out = out.reshape(N.size, lanes, 4)
    scalar, packet = out[..., :2], out[..., 2:]
    assert np.all((scalar >= 0) & (scalar < 1))
    assert np.array_equal(scalar.view(np.uint32), packet.view(np.uint32))
