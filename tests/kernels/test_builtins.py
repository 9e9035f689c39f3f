"""The kernels' own arithmetic helpers on the device, against the builtins and float64:

* core/builtins.h (PoCL only, TX_POCL): tx_fabs, tx_floor, tx_fma, tx_nextafter,
  tx_copysign, tx_sqrt, tx_rsqrt, clamp, convert_float8, any, all, vload3, vload4 and vstore4 return the very bits of PoCL's builtins, on
  every special value (zeros, denormals, the float range's ends, infinities, NaNs) and a
  million random bit patterns: the images keep their bits; vload_half4 on all 65536 halves;
* core/builtins.h's exp2 and log2 (PoCL only): within 1.5 ulp of float64 (measured: exp2
  0.84, log2 1.17), every special value as C99 says, denormal results of exp2 within one denormal;
* core/transcendental.h (every device): tx_atan2 within 4 ulp of float64 atan2 (measured
  on PoCL: at most 2 ulp), tx_hypot within 1.5 ulp of float64 hypot (measured: 1.16), both at
  any scale (from denormals to FLT_MAX) and on C99's special values.
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from kernel_harness import build_test_program

_KERNELS = r"""
#include "core/common.h"
#include "core/transcendental.h"

__kernel void trig(__global const float* y, __global const float* x, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    out[2 * i] = tx_atan2(y[i], x[i]);
    out[2 * i + 1] = tx_hypot(y[i], x[i]);
}
"""

_POCL_KERNELS = r"""
#include "core/common.h"

/* Pairs (x, y) in, per pair: the helper's result, then the builtin's. */
__kernel void unary(__global const float* x, __global const float* y, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    float a = x[i], b = y[i];
    __global float* o = out + 22 * i;
    o[0] = fabs(a); o[2] = floor(a); o[4] = fma(a, b, y[(i + 1) % n]); o[6] = nextafter(a, b);
    o[8] = copysign(a, b); o[10] = sqrt(a); o[12] = rsqrt(a);
    float3 v = vload3(0, x + 3 * (i / 3));
    o[14] = v.x + v.y;
    /* PoCL's own (its headers' names for them). */
    o[1] = _cl_fabs(a); o[3] = _cl_floor(a); o[5] = _cl_fma(a, b, y[(i + 1) % n]); o[7] = _cl_nextafter(a, b);
    o[9] = _cl_copysign(a, b); o[11] = _cl_sqrt(a); o[13] = _cl_rsqrt(a);
    float3 w = _cl_vload3(0, x + 3 * (i / 3));
    o[15] = w.x + w.y;
    o[16] = (float)isnan(a); o[17] = (float)_cl_isnan(a); o[18] = (float)isinf(a); o[19] = (float)_cl_isinf(a);
    o[20] = (float)isfinite(a); o[21] = (float)_cl_isfinite(a);
}

/* vstore3 against PoCL's: the triple x[3i..] stored at out[3i..] and out2[3i..]. */
__kernel void store3(__global const float* x, __global float* out, __global float* out2, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    float3 v = (float3)(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    vstore3(v, i, out);
    _cl_vstore3(v, i, out2);
}

/* The float8 and float16 versions (the packets' vectors), lane by lane against PoCL's scalar
 * builtin: each work-item takes 16 consecutive pairs. */
__kernel void vector(__global const float* x, __global const float* y, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (16 * i + 16 > n) return;
    float16 a = vload16(i, x), b = vload16(i, y), c = vload16(i, y + 1);
    float8 a8 = a.lo, b8 = b.lo, c8 = c.lo;
    float16 r[4] = { fma(a, b, c), copysign(a, b), sqrt(a), rsqrt(a) };
    float8 r8[4] = { fma(a8, b8, c8), copysign(a8, b8), sqrt(a8), rsqrt(a8) };
    __global float* o = out + 16 * 12 * i;
    for (int k = 0; k < 4; ++k) {
        vstore16(r[k], 0, o + 48 * k);
        vstore8(r8[k], 0, o + 48 * k + 16);
    }
    for (int j = 0; j < 16; ++j) {
        float aj = x[16 * i + j], bj = y[16 * i + j], cj = y[16 * i + j + 1];
        o[32 + j] = _cl_fma(aj, bj, cj); o[80 + j] = _cl_copysign(aj, bj);
        o[128 + j] = _cl_sqrt(aj); o[176 + j] = _cl_rsqrt(aj);
    }
}

/* vload_half4 (core/builtins.h's where the target has F16C) and PoCL's own, of the halves
 * h[4i..4i+3]: out[8i..8i+3] and out[8i+4..8i+7]. */
__kernel void halves(__global const half* h, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    vstore4(vload_half4(i, h), 0, out + 8 * i);
    vstore4(_cl_vload_half4(i, h), 0, out + 8 * i + 4);
}

/* clamp(x, lo, hi) of floats against PoCL's: out[2i], out[2i + 1]; and of uints. */
__kernel void clamps(__global const float* x, __global const float* y, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    float a = x[i], lo = y[i], hi = y[(i + 1) % n];
    out[4 * i] = clamp(a, lo, hi);
    out[4 * i + 1] = _cl_clamp(a, lo, hi);
    uint ua = as_uint(a), ulo = as_uint(lo) >> (i % 32u), uhi = as_uint(hi);
    out[4 * i + 2] = as_float(clamp(ua, ulo, uhi));
    out[4 * i + 3] = as_float(_cl_clamp(ua, ulo, uhi));
}

/* convert_float8 of the bits of x[8i..8i+7] as uint8 and int8, vload4 and vstore4 of
 * floats (private and global), each against PoCL's: 48 floats per work-item. */
__kernel void convert_load(__global const float* x, __global const float* y, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (8 * i + 8 > n) return;
    uint8 u = vload8(i, (__global const uint*)x);
    __global float* o = out + 48 * i;
    vstore8(convert_float8(u), 0, o);
    vstore8(_cl_convert_float8(u), 0, o + 8);
    vstore8(convert_float8(as_int8(u)), 0, o + 16);
    vstore8(_cl_convert_float8(as_int8(u)), 0, o + 24);
    float p[8];
    for (int k = 0; k < 8; ++k) p[k] = x[8 * i + k];
    float4 a = vload4(1, p), b = _cl_vload4(1, p);
    vstore4(a, 8, o);                          /* o[32..35] */
    _cl_vstore4(b, 9, o);                      /* o[36..39] */
    vstore4(vload4(2 * i, x), 10, o);          /* o[40..43]: x[8i..8i+3] */
    _cl_vstore4(_cl_vload4(2 * i, x), 11, o);  /* o[44..47] */
}

/* any and all of int4, int8 and int16 lane masks against PoCL's: 12 answers per work-item,
 * its 16 ints x[16i..] (as their bits) and y's sign bits mixed in. */
__kernel void masks(__global const float* x, __global const float* y, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (16 * i + 16 > n) return;
    int16 v = as_int16(vload16(i, x));
    int16 w = as_int16(vload16(i, y)) >> 31;     /* whole-lane masks: -1 or 0 */
    int16 u = (i & 1u) ? w : v;
    __global float* o = out + 12 * i;
    o[0] = any(u.lo.lo); o[1] = _cl_any(u.lo.lo); o[2] = all(u.lo.lo); o[3] = _cl_all(u.lo.lo);
    o[4] = any(u.lo); o[5] = _cl_any(u.lo); o[6] = all(u.lo); o[7] = _cl_all(u.lo);
    /* no 16-lane value may reach PoCL's library (core/builtins.h): PoCL's answer for 16 lanes
     * is that of its two halves */
    o[8] = any(u); o[9] = _cl_any(u.lo) || _cl_any(u.hi); o[10] = all(u); o[11] = _cl_all(u.lo) && _cl_all(u.hi);
}

/* exp2 and log2 (core/builtins.h's, on PoCL) of x: out[2i], out[2i + 1]. */
__kernel void explog(__global const float* x, __global const float* y, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    out[2 * i] = exp2(x[i]);
    out[2 * i + 1] = log2(x[i]);
}
"""

_SPECIAL = np.array([0.0, -0.0, 1e-45, -1e-45, 1.1754942e-38, 1.1754944e-38, -1.1754944e-38, 0.5, 1.0, -1.0,
                     1.5, -1.5, 2.5, -2.5, 3.4028235e38, -3.4028235e38, np.inf, -np.inf, np.nan, 1e-30, 1e30,
                     0.49999997, 8388607.5, -8388607.5, 16777217.0], np.float32)


def _pairs(rng, n):
    """Every pair of special values, then random bit patterns (NaNs and all)."""
    sx, sy = np.meshgrid(_SPECIAL, _SPECIAL)
    rx = rng.integers(0, 2**32, n, dtype=np.uint64).astype(np.uint32).view(np.float32)
    ry = rng.integers(0, 2**32, n, dtype=np.uint64).astype(np.uint32).view(np.float32)
    return np.concatenate([sx.ravel(), rx]), np.concatenate([sy.ravel(), ry])


def _run(rt, kernel, x, y, width, source=_KERNELS):
    k = build_test_program(rt, (), source)
    mf = cl.mem_flags
    bx = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
    by = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=y)
    out = np.zeros(len(x) * width, np.float32)
    bo = cl.Buffer(rt.context, mf.WRITE_ONLY, out.nbytes)
    getattr(k, kernel)(rt.queue, (len(x),), None, bx, by, bo, np.uint32(len(x)))
    cl.enqueue_copy(rt.queue, out, bo)
    return out.reshape(len(x), width)


def test_pocl_inline_builtins_keep_the_bits(rt, rng):
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces builtins on PoCL only")
    x, y = _pairs(rng, 1 << 20)
    out = _run(rt, "unary", x, y, 22, _POCL_KERNELS)
    names = ["fabs", "floor", "fma", "nextafter", "copysign", "sqrt", "rsqrt", "vload3", "isnan", "isinf", "isfinite"]
    assert out[:, 16].sum() > 0 and out[:, 18].sum() > 0 and 0 < out[:, 20].sum() < len(x)   # each answer seen
    for j, name in enumerate(names):
        mine, theirs = out[:, 2 * j].view(np.uint32), out[:, 2 * j + 1].view(np.uint32)
        both_nan = np.isnan(out[:, 2 * j]) & np.isnan(out[:, 2 * j + 1])
        bad = (mine != theirs) & ~both_nan
        assert not bad.any(), (f"{name}: {bad.sum()} inputs differ, e.g. x={x[bad][:3]} y={y[bad][:3]}: "
                               f"{out[bad, 2 * j][:3]} vs builtin {out[bad, 2 * j + 1][:3]}")


def test_pocl_clamp_keeps_the_bits(rt, rng):
    """clamp of floats (core/builtins.h's, on PoCL) gives PoCL's builtin's bits for every pair of
    special values as (x, lo) with hi the next pair's y, and a million random bit patterns
    (NaNs, signed zeros, lo > hi included); clamp of uints PoCL's value."""
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces builtins on PoCL only")
    x, y = _pairs(rng, 1 << 20)
    out = _run(rt, "clamps", x, y, 4, _POCL_KERNELS)
    for j, name in ((0, "clamp(float)"), (2, "clamp(uint)")):
        mine, theirs = out[:, j].view(np.uint32), out[:, j + 1].view(np.uint32)
        bad = (mine != theirs) & ~(np.isnan(out[:, j]) & np.isnan(out[:, j + 1]))
        assert not bad.any(), f"{name}: {bad.sum()} inputs differ, e.g. x={x[bad][:3]} lo={y[bad][:3]}"
    lo, hi = y, np.roll(y, -1)
    ok = (lo <= hi) & ~np.isnan(x)                 # where OpenCL defines it: fmin(fmax(x, lo), hi)
    np.testing.assert_array_equal(out[ok, 0], np.minimum(np.maximum(x[ok], lo[ok]), hi[ok]))


def test_pocl_convert_and_vload4_keep_the_bits(rt, rng):
    """convert_float8 of uint8 and int8 (every bit pattern class: zero, the ends, above 2^24
    where rounding happens) and vload4 / vstore4 of floats (core/builtins.h's, on PoCL): PoCL's
    builtins' bits, and numpy's round-to-nearest conversion."""
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces builtins on PoCL only")
    special = np.array([0, 1, 2**24 - 1, 2**24, 2**24 + 1, 2**24 + 3, 2**31 - 1, 2**31, 2**31 + 1, 2**32 - 1,
                        2**32 - 129, 2**32 - 128, 2**32 - 127, 0x7fffff80, 0x7fffffc0, 0xffffff7f], np.uint64)
    u = np.concatenate([special, rng.integers(0, 2**32, 1 << 18, dtype=np.uint64)]).astype(np.uint32)
    u = u[: len(u) // 8 * 8]
    x = u.view(np.float32)
    out = _run(rt, "convert_load", x, x, 48, _POCL_KERNELS)[: len(x) // 8].reshape(-1, 48)
    n = len(out)
    np.testing.assert_array_equal(out[:, 0:8].view(np.uint32), out[:, 8:16].view(np.uint32))
    np.testing.assert_array_equal(out[:, 16:24].view(np.uint32), out[:, 24:32].view(np.uint32))
    np.testing.assert_array_equal(out[:, 0:8].ravel(), u[: 8 * n].astype(np.float32))
    np.testing.assert_array_equal(out[:, 16:24].ravel(), u[: 8 * n].view(np.int32).astype(np.float32))
    xb = x[: 8 * n].reshape(n, 8).view(np.uint32)
    for lo, want in ((32, xb[:, 4:8]), (36, xb[:, 4:8]), (40, xb[:, 0:4]), (44, xb[:, 0:4])):
        np.testing.assert_array_equal(out[:, lo:lo + 4].view(np.uint32), want)


def test_pocl_any_and_all_answer_as_the_builtins(rt, rng):
    """any and all of 4, 8 and 16 lanes (core/builtins.h's: movmskps where the target has AVX)
    give PoCL's answers on random ints and on lane masks, every answer seen both ways."""
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces builtins on PoCL only")
    n = 1 << 16
    bits = rng.integers(0, 2**32, (2, 16 * n), dtype=np.uint64).astype(np.uint32)
    bits[1, : 16 * 64] = 0x80000000                    # some groups of masks all set
    bits[1, 16 * 64: 16 * 128] = 0                     # and all clear
    x, y = bits[0].view(np.float32), bits[1].view(np.float32)
    k = build_test_program(rt, (), _POCL_KERNELS)
    mf = cl.mem_flags
    bx = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
    by = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=y)
    out = np.zeros(12 * n, np.float32)
    bo = cl.Buffer(rt.context, mf.WRITE_ONLY, out.nbytes)
    k.masks(rt.queue, (n,), None, bx, by, bo, np.uint32(16 * n))
    cl.enqueue_copy(rt.queue, out, bo)
    out = out.reshape(n, 6, 2)
    np.testing.assert_array_equal(out[:, :, 0], out[:, :, 1])
    for j in range(6):
        assert 0 < out[:, j, 0].sum() < n, f"answer {j} always the same"
    u = np.where((np.arange(n) % 2 == 1)[:, None], (bits[1].view(np.int32) >> 31).reshape(n, 16),
                 bits[0].view(np.int32).reshape(n, 16))
    for j, lanes in enumerate((4, 8, 16)):
        neg = u[:, :lanes] < 0
        np.testing.assert_array_equal(out[:, 2 * j, 0], neg.any(axis=1))
        np.testing.assert_array_equal(out[:, 2 * j + 1, 0], neg.all(axis=1))


def test_pocl_vload_half4_widens_every_half_exactly(rt):
    """Every one of the 65536 halves (zeros, denormals, infinities, NaNs) through the kernels'
    vload_half4, at every position of a four-half load: numpy's float16 -> float32 value (a
    half is exactly a float) and PoCL's own builtin's bits; NaNs stay NaN."""
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces builtins on PoCL only")
    h = np.arange(65536, dtype=np.uint16)
    h = np.concatenate([h, np.roll(h, 1), np.roll(h, 2), np.roll(h, 3)])   # each half in each lane
    n = len(h) // 4
    k = build_test_program(rt, (), _POCL_KERNELS)
    mf = cl.mem_flags
    bh = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=h)
    out = np.zeros(8 * n, np.float32)
    bo = cl.Buffer(rt.context, mf.WRITE_ONLY, out.nbytes)
    k.halves(rt.queue, (n,), None, bh, bo, np.uint32(n))
    cl.enqueue_copy(rt.queue, out, bo)
    out = out.reshape(n, 2, 4)
    want = h.view(np.float16).astype(np.float32).reshape(n, 4)
    nan = np.isnan(want)
    assert nan.sum() == 4 * 2 * 1023 and (want == 0).sum() == 8
    for got in (out[:, 0], out[:, 1]):
        assert np.isnan(got[nan]).all()
        np.testing.assert_array_equal(got[~nan].view(np.uint32), want[~nan].view(np.uint32))


def test_pocl_vstore3_stores_as_the_builtin(rt, rng):
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces builtins on PoCL only")
    n = 4099
    x = rng.integers(0, 2**32, 3 * n, dtype=np.uint64).astype(np.uint32).view(np.float32)
    k = build_test_program(rt, (), _POCL_KERNELS)
    mf = cl.mem_flags
    bx = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
    outs = [np.full(3 * n, 7.0, np.float32) for _ in range(2)]
    bufs = [cl.Buffer(rt.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=o) for o in outs]
    k.store3(rt.queue, (n,), None, bx, *bufs, np.uint32(n))
    for o, b in zip(outs, bufs):
        cl.enqueue_copy(rt.queue, o, b)
    np.testing.assert_array_equal(outs[0].view(np.uint32), x.view(np.uint32))
    np.testing.assert_array_equal(outs[1].view(np.uint32), x.view(np.uint32))


def test_pocl_vector_builtins_keep_the_bits(rt, rng):
    """fma, copysign, sqrt and rsqrt on float8 and float16 (core/builtins.h) give PoCL's
    scalar builtin's bits in every lane."""
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces builtins on PoCL only")
    x, y = _pairs(rng, 1 << 18)
    n = len(x) // 16 * 16
    x, y = x[:n], np.concatenate([y[:n], y[:1]])
    k = build_test_program(rt, (), _POCL_KERNELS)
    mf = cl.mem_flags
    bx = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
    by = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=y)
    out = np.zeros(n * 12, np.float32)
    bo = cl.Buffer(rt.context, mf.WRITE_ONLY, out.nbytes)
    k.vector(rt.queue, (n // 16,), None, bx, by, bo, np.uint32(n))
    cl.enqueue_copy(rt.queue, out, bo)
    out = out.reshape(n // 16, 4, 3, 16)            # (group, function, [float16, float8 (8 lanes), PoCL's], lane)
    for f, name in enumerate(["fma", "copysign", "sqrt", "rsqrt"]):
        theirs = out[:, f, 2]
        for got, lanes in ((out[:, f, 0], 16), (out[:, f, 1, :8], 8)):
            want = theirs[:, :lanes]
            bad = (got.view(np.uint32) != want.view(np.uint32)) & ~(np.isnan(got) & np.isnan(want))
            assert not bad.any(), f"{name} on {lanes} lanes: {bad.sum()} inputs differ"


def _ulps(got, want):
    """|got - want| in ulps of want (float32), from float64 values."""
    want32 = want.astype(np.float32)
    ulp = np.spacing(np.abs(want32)).astype(np.float64)
    return np.abs(got.astype(np.float64) - want) / ulp


def test_atan2_and_hypot_against_float64(rt, rng):
    n = 1 << 18
    # Magnitudes spread over the whole float range, both signs, exact axes and diagonals.
    y = (rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-44, 38, n)).astype(np.float32)
    x = (rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-44, 38, n)).astype(np.float32)
    near = rng.uniform(-2, 2, (2, n)).astype(np.float32)           # similar magnitudes: every octant
    ys = np.concatenate([y, near[0], near[0], np.zeros(4, np.float32), [1, -1, 1, -1, 3e38, 1e-40]])
    xs = np.concatenate([x, near[1], near[0], [1, -1, 1, -1], np.ones(4, np.float32), [3e38, -1e-40]])
    ys, xs = ys.astype(np.float32), xs.astype(np.float32)
    out = _run(rt, "trig", ys, xs, 2)
    y64, x64 = ys.astype(np.float64), xs.astype(np.float64)
    ref_atan = np.arctan2(y64, x64)
    ref_hyp = np.hypot(y64, x64)
    normal = np.abs(ref_atan) >= np.finfo(np.float32).tiny          # results above the denormals
    assert _ulps(out[normal, 0], ref_atan[normal]).max() <= 4.0
    tiny = ~normal              # y / x below FLT_MIN: a device may flush the quotient to 0
    assert np.abs(out[tiny, 0] - ref_atan[tiny]).max() <= np.finfo(np.float32).tiny
    finite = ref_hyp <= np.finfo(np.float32).max
    normal_h = finite & (ref_hyp >= np.finfo(np.float32).tiny)
    assert _ulps(out[normal_h, 1], ref_hyp[normal_h]).max() <= 1.5
    assert np.all(np.isinf(out[~finite, 1]))


@pytest.mark.parametrize("y, x, atan2, hypot", [
    (0.0, 0.0, 0.0, 0.0), (-0.0, 0.0, -0.0, 0.0), (0.0, -0.0, np.pi, 0.0), (-0.0, -0.0, -np.pi, 0.0),
    (1.0, 0.0, np.pi / 2, 1.0), (-1.0, 0.0, -np.pi / 2, 1.0), (0.0, -1.0, np.pi, 1.0), (-0.0, -1.0, -np.pi, 1.0),
    (np.inf, np.inf, np.pi / 4, np.inf), (np.inf, -np.inf, 3 * np.pi / 4, np.inf),
    (-np.inf, 1.0, -np.pi / 2, np.inf), (1.0, -np.inf, np.pi, np.inf), (-1.0, np.inf, -0.0, np.inf),
    (np.nan, 1.0, np.nan, np.nan), (1.0, np.nan, np.nan, np.nan), (np.inf, np.nan, np.nan, np.inf),
    (3e38, 3e38, np.pi / 4, np.inf), (1e-45, 1e-45, np.pi / 4, 1e-45 * np.sqrt(2)),
])
def test_special_values(rt, y, x, atan2, hypot):
    out = _run(rt, "trig", np.array([y], np.float32), np.array([x], np.float32), 2)[0]
    for got, want in ((out[0], atan2), (out[1], hypot)):
        if np.isnan(want):
            assert np.isnan(got)
        else:
            assert got == pytest.approx(np.float32(want), rel=3e-7, abs=1.5e-45) and np.signbit(got) == np.signbit(want)


def test_pocl_exp2_and_log2_against_float64(rt, rng):
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces exp2 and log2 on PoCL only")
    n = 1 << 20
    ex = rng.uniform(-152, 130, n)                                   # every exponent, denormal results, overflow
    ex[: n // 4] = rng.uniform(-1, 1, n // 4)                        # around 2^0 (specular exponents' range)
    lx = rng.integers(0, 0x7f800000, n, dtype=np.uint64).astype(np.uint32).view(np.float32)   # every positive float
    lx[: n // 4] = rng.uniform(0.5, 2.0, n // 4)                     # around 1, where log2 is near 0
    x = np.concatenate([ex.astype(np.float32), lx, _SPECIAL, np.float32([-150, -149.5, -149, -126.5, -126, 127.5,
                                                                            127.99999, 128, np.nextafter(1, 2, dtype=np.float32),
                                                                            np.nextafter(1, 0, dtype=np.float32), 1.4142135])])
    out = _run(rt, "explog", x, x, 2, _POCL_KERNELS)
    x64 = x.astype(np.float64)
    with np.errstate(all="ignore"):
        want_e, want_l = np.exp2(x64), np.log2(x64)
        over = want_e.astype(np.float32) == np.inf           # float64's result rounds above FLT_MAX
    tiny = np.finfo(np.float32).tiny
    # exp2: 1.5 ulp where the result is normal and finite; one denormal step below FLT_MIN;
    # overflow to +inf exactly where float64's result rounds above FLT_MAX.
    normal = (want_e >= tiny) & ~over
    assert _ulps(out[normal, 0], want_e[normal]).max() <= 1.5
    sub = (want_e < tiny) & ~np.isnan(x64)
    assert np.abs(out[sub, 0] - want_e[sub]).max() <= 2.0 ** -149 and (out[sub, 0] >= 0).all()
    assert np.all(out[over, 0] == np.inf) and np.all(out[~over & ~np.isnan(x64), 0] < np.inf)
    # log2: 1.5 ulp (near 1, where the result nears 0, in ulps of at least 2^-47).
    fin = np.isfinite(want_l) & (x64 > 0)
    ulp = np.maximum(np.spacing(np.abs(want_l[fin]).astype(np.float32)).astype(np.float64), 2.0 ** -47)
    assert (np.abs(out[fin, 1] - want_l[fin]) / ulp).max() <= 1.5
    # Special values, as C99 (and PoCL's own) say.
    for v, e2, l2 in ((0.0, 1.0, -np.inf), (-0.0, 1.0, -np.inf), (np.inf, np.inf, np.inf), (-np.inf, 0.0, np.nan),
                      (np.nan, np.nan, np.nan), (-1.0, 0.5, np.nan), (1.0, 2.0, 0.0), (-1e-45, 1.0, np.nan)):
        got = _run(rt, "explog", np.float32([v]), np.float32([v]), 2, _POCL_KERNELS)[0]
        for g, w in ((got[0], e2), (got[1], l2)):
            assert (np.isnan(g) and np.isnan(w)) or g == w, (v, g, w)


_PACKET_EXPLOG = r"""
#include "core/common.h"
#include "accel/packet.h"
#include "accel/packet_vec.h"

/* accel/packet_vec.h's pf_exp2 and pf_log2 on TX_PACKET values at once, then the scalar
 * exp2 and log2 (core/builtins.h's) of each: out[4i ..] = pf_exp2, exp2, pf_log2, log2. */
__kernel void pexplog(__global const float* x, __global const float* y, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i * TX_PACKET >= n) return;
    float a[TX_PACKET], e[TX_PACKET], l[TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) a[j] = x[i * TX_PACKET + j];
    PSTORE(pf_exp2(PLOAD(a)), e);
    PSTORE(pf_log2(PLOAD(a)), l);
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        __global float* o = out + 4 * (i * TX_PACKET + j);
        o[0] = e[j]; o[1] = exp2(a[j]); o[2] = l[j]; o[3] = log2(a[j]);
    }
}
"""


@pytest.mark.parametrize("width", [8, 16])
def test_pocl_packet_exp2_and_log2_are_the_scalar_ones(rt, rng, width):
    """pf_exp2 and pf_log2 (accel/packet_vec.h: shading/light_packet.h's specular power) give
    core/builtins.h's exp2 and log2 bit for bit in every lane: a million random bit patterns
    (NaNs, infinities, denormals, negatives), the exponents around the specular powers' and
    the special values; their branches as lane selects, neighbouring lanes of every kind."""
    if "-DTX_POCL=1" not in rt.device_defines:
        pytest.skip("core/builtins.h replaces exp2 and log2 on PoCL only")
    from texray.device.features import compile_options, Features
    n = 1 << 20
    bits = rng.integers(0, 1 << 32, n, dtype=np.uint64).astype(np.uint32).view(np.float32)
    near = rng.uniform(-160, 140, n // 4).astype(np.float32)                 # exp2's range and beyond
    small = rng.uniform(0, 1, n // 4).astype(np.float32)                     # cosines: log2 near 0
    den = rng.integers(1, 0x00800000, n // 8, dtype=np.uint64).astype(np.uint32).view(np.float32)   # denormals
    x = np.concatenate([bits, near, small, den, _SPECIAL, np.float32([-150, -149.5, -149, 127.5, 127.99999, 128,
                                                                      -0.5, 0.5, 1.5, -1.5, 2.5, 1.4142135,
                                                                      1.4142137])])
    x = np.concatenate([x, np.zeros((-len(x)) % width, np.float32)])
    rng.shuffle(x)
    opts = {**compile_options(Features(triangles=True)), "TX_PACKET": width}
    k = build_test_program(rt, (), _PACKET_EXPLOG, [f"-D{a}={b}" for a, b in opts.items()])
    mf = cl.mem_flags
    bx = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
    out = np.zeros((len(x), 4), np.float32)
    bo = cl.Buffer(rt.context, mf.WRITE_ONLY, out.nbytes)
    k.pexplog(rt.queue, (len(x) // width,), None, bx, bx, bo, np.uint32(len(x)))
    cl.enqueue_copy(rt.queue, out, bo)
    for name, mine, theirs in (("exp2", out[:, 0], out[:, 1]), ("log2", out[:, 2], out[:, 3])):
        nan = np.isnan(mine) & np.isnan(theirs)
        bad = np.flatnonzero((mine.view(np.uint32) != theirs.view(np.uint32)) & ~nan)
        assert bad.size == 0, f"{name}: {bad.size} differ, e.g. x = {x[bad[0]]!r}: {mine[bad[0]]!r} against " \
                              f"{theirs[bad[0]]!r}"
    assert np.isnan(out[:, 2]).any() and np.isinf(out[:, 0]).any() and (out[:, 0] == 0).any()
