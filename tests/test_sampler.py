"""Pixel sampling: correlated multi-jittered samples are stratified in 2-D and in each
1-D projection, deterministic per seed, and average to the box-filtered pixel."""
import numpy as np
import pyopencl as cl
import pytest

import texray as tx
from texray import layout
from texray.features import Features, compile_options


def _sample_positions(rt, spp, width=3, height=2, seed=7):
    """(spp, height*width, 2) sample positions inside their pixels, from the raygen kernel's rays."""
    prg = rt.program(compile_options(Features()))
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


@pytest.mark.parametrize("spp", [1, 2, 4, 5, 7, 16, 30])
def test_samples_are_stratified(rt, spp):
    pos = _sample_positions(rt, spp)
    assert np.all((pos >= 0) & (pos < 1))
    m = int(np.floor(np.sqrt(spp)))
    n = -(-spp // m)
    for pixel in range(pos.shape[1]):
        x, y = pos[:, pixel, 0], pos[:, pixel, 1]
        # N samples are the first N of an m x n pattern (m = floor(sqrt N), n = ceil(N / m)):
        # in each 1-D projection no two share one of the m*n intervals (float32 slack 1e-5) ...
        for v in (x, y):
            lo = np.floor(v * m * n + 1e-5).astype(int)
            hi = np.floor(v * m * n - 1e-5).astype(int)
            assert len(set(lo.tolist())) == spp or len(set(hi.tolist())) == spp, (spp, pixel, v)
        # ... and in 2-D no two share a cell of the m x n grid.
        cells = np.floor(x * m).astype(int) * n + np.floor(y * n).astype(int)
        assert len(set(cells.tolist())) == spp, (spp, pixel)


def test_pixels_get_different_patterns_and_seeds_are_deterministic(rt):
    a = _sample_positions(rt, 4, seed=1)
    b = _sample_positions(rt, 4, seed=1)
    c = _sample_positions(rt, 4, seed=2)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    assert not np.allclose(a[:, 0], a[:, 1])
