"""Projection mappings, UV transforms and wrap modes (kernels/texture/mapping.h, wrap.h,
texray.mapping): device results against float64 numpy references.

* each projection on random points: uv within 1e-5 (u compared on the circle, so
  the seam does not count), derivatives within 1e-3 (relative, per derivative
  vector) of central differences of the float64 reference;
* points on / within 1e-6 of the cylinder axis and the sphere poles: finite,
  0 derivative exactly on the axis;
* derivatives continuous across the u = 0 / 1 seam;
* uv_transform / texcoord_transform against UVTransform.matrix();
* wrap_index, wrap_coord, wrap_nearest, wrap_reduce against exact (Fraction)
  references, for indices in [-3n, 3n], extreme ints, huge / negative / NaN /
  infinite coordinates;
* a hypothesis property: a point of the unit sphere at (theta, phi) maps to
  (phi / 2pi, 1 - theta / pi);
* host validation errors name the field.
"""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pyopencl as cl
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from texray.errors import SceneError
from kernel_harness import build_test_program
from texray.scene.mapping import (PROJECTION_KINDS, WRAP_MODES, Projection, UVTransform,
                            project_numpy)

KINDS = ("planar", "cylindrical", "spherical")
MODES = ("repeat", "clamp", "mirror")

_KERNELS = r"""
#include "core/common.h"
#include "texture/mapping.h"
#include "texture/wrap.h"

__kernel void consts(__global int* out)
{
    out[0] = TX_WRAP_REPEAT; out[1] = TX_WRAP_CLAMP; out[2] = TX_WRAP_MIRROR;
    out[3] = TX_MAP_PLANAR; out[4] = TX_MAP_CYLINDRICAL; out[5] = TX_MAP_SPHERICAL;
}

/* out: 6 floats per point: u, v, du/dx, dv/dx, du/dy, dv/dy */
__kernel void eval_map(int kind, __global const float* fr, __global const float* p,
                       __global const float* dpdx, __global const float* dpdy, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    Frame f;
    f.origin = vload3(0, fr); f.x = vload3(1, fr); f.y = vload3(2, fr); f.z = vload3(3, fr);
    float3 q = vload3(i, p), dx = vload3(i, dpdx), dy = vload3(i, dpdy);
    TexCoord t = kind == TX_MAP_PLANAR ? map_planar(f, q, dx, dy)
               : (kind == TX_MAP_CYLINDRICAL ? map_cylindrical(f, q, dx, dy) : map_spherical(f, q, dx, dy));
    TexCoord d = map_projection(kind, f, q, dx, dy);
    int same = d.uv.x == t.uv.x && d.uv.y == t.uv.y && d.duv_dx.x == t.duv_dx.x && d.duv_dy.y == t.duv_dy.y;
    vstore2(t.uv, 3 * i, out);
    vstore2(t.duv_dx, 3 * i + 1, out);
    vstore2(same ? t.duv_dy : (float2)(NAN), 3 * i + 2, out);
}

/* in: 6 floats per TexCoord; out: 8 floats: uv_transform(uv), then texcoord_transform(...) */
__kernel void eval_uvt(__global const float* m, __global const float* in, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    float4 m0 = vload4(0, m);
    float2 m1 = vload2(2, m);
    TexCoord t;
    t.uv = vload2(3 * i, in); t.duv_dx = vload2(3 * i + 1, in); t.duv_dy = vload2(3 * i + 2, in);
    TexCoord r = texcoord_transform(t, m0, m1);
    vstore2(uv_transform(t.uv, m0, m1), 4 * i, out);
    vstore2(r.uv, 4 * i + 1, out);
    vstore2(r.duv_dx, 4 * i + 2, out);
    vstore2(r.duv_dy, 4 * i + 3, out);
}

__kernel void eval_wrap_index(__global const int* idx, int n, int mode, __global int* out, uint count)
{
    uint i = get_global_id(0);
    if (i < count) out[i] = wrap_index(idx[i], n, mode);
}

/* Per u: wrap_coord, wrap_reduce, wrap_nearest, and a 1-D bilinear lookup of texels[0..n-1]
 * through wrap_reduce + wrap_index (how texture.h would use them). */
__kernel void eval_wrap_float(__global const float* u, int n, int mode, __global const float* texels,
                              __global float* coord, __global float* reduced, __global int* nearest,
                              __global float* bilerp, uint count)
{
    uint i = get_global_id(0);
    if (i >= count) return;
    float x = u[i];
    coord[i] = wrap_coord(x, mode);
    float r = wrap_reduce(x, mode);
    reduced[i] = r;
    nearest[i] = wrap_nearest(x, n, mode);
    float s = r * (float)n - 0.5f;
    float fs = floor(s), a = s - fs;
    int i0 = (int)fs;
    bilerp[i] = texels[wrap_index(i0, n, mode)] * (1.0f - a) + texels[wrap_index(i0 + 1, n, mode)] * a;
}
"""

def _program(rt):
    return build_test_program(rt, ("core/common.h", "texture/mapping.h", "texture/wrap.h"), _KERNELS)


def _buf(rt, a):
    mf = cl.mem_flags
    a = np.ascontiguousarray(a)
    if a.nbytes == 0:
        a = np.zeros(1, a.dtype)
    return cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a)


def _out(rt, n, dtype):
    host = np.zeros(n, dtype)
    return host, cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, max(host.nbytes, 16))


def device_map(rt, projection, p, dpdx=None, dpdy=None, frame=None):
    """(N, 6) float64: u, v, du/dx, dv/dx, du/dy, dv/dy from the device for float32 points."""
    p = np.asarray(p, np.float32).reshape(-1, 3)
    n = len(p)
    dpdx = np.zeros_like(p) if dpdx is None else np.asarray(dpdx, np.float32)
    dpdy = np.zeros_like(p) if dpdy is None else np.asarray(dpdy, np.float32)
    fr = (projection.device_frame() if frame is None else frame).astype(np.float32)
    out, ob = _out(rt, 6 * n, np.float32)
    _program(rt).eval_map(rt.queue, (n,), None, np.int32(projection.kind_id), _buf(rt, fr), _buf(rt, p),
                          _buf(rt, dpdx), _buf(rt, dpdy), ob, np.uint32(n))
    cl.enqueue_copy(rt.queue, out, ob)
    return out.reshape(n, 6).astype(np.float64)


def _circ(a, b):
    """Distance of u values on the unit circle (u = 0 and 1 are the same)."""
    d = np.mod(np.asarray(a) - np.asarray(b), 1.0)
    return np.minimum(d, 1.0 - d)


def _fd(projection, p, dp, h=1e-3):
    """Central difference of the float64 reference along dp (u differenced on the circle)."""
    a = project_numpy(projection, p + h * dp)
    b = project_numpy(projection, p - h * dp)
    d = a - b
    if projection.kind != "planar":
        d[:, 0] = np.mod(d[:, 0] + 0.5, 1.0) - 0.5
    return d / (2 * h)


PROJECTIONS = {
    "identity": dict(),
    "rotated": dict(origin=(0.3, -1.2, 2.0), x_axis=(1.0, 2.0, -0.5), z_axis=(0.2, -0.3, 1.0)),
    "scaled": dict(origin=(-4.0, 0.5, 1.0), x_axis=(0.0, 1.0, 0.0), z_axis=(1.0, 1.0, 1.0), scale=1.7),
}


def _random_local_points(rng, n, kind, min_rho=0.2):
    """Frame coordinates in [-2, 2]^3, at least min_rho off the z axis for cylinder / sphere."""
    q = rng.uniform(-2, 2, (4 * n, 3))
    if kind != "planar":
        q = q[np.hypot(q[:, 0], q[:, 1]) > min_rho]
    return q[:n]


def _to_object(projection, q):
    o, x, y, z = projection.frame()
    return o + q[:, :1] * x + q[:, 1:2] * y + q[:, 2:3] * z


# --- the reference itself -----------------------------------------------------------------

def test_reference_conventions():
    pl = Projection("planar", origin=(1, 2, 3), scale=2.0)
    np.testing.assert_allclose(project_numpy(pl, [[1.5, 2.25, 7.0]]), [[1.0, 0.5]])
    cy = Projection("cylindrical", scale=0.5)
    np.testing.assert_allclose(project_numpy(cy, [[1, 0, 4], [0, 2, -2], [-1, 0, 0], [0, -1, 1]]),
                               [[0, 2], [0.25, -1], [0.5, 0], [0.75, 0.5]], atol=1e-15)
    sp = Projection("spherical", scale=3.0)
    np.testing.assert_allclose(project_numpy(sp, [[0, 0, 2], [0, 0, -1], [0, 3, 0], [1, 0, 1]]),
                               [[0, 1], [0, 0], [0.25, 0.5], [0, 0.75]], atol=1e-15)
    u = project_numpy(cy, [[1, -1e-300, 0], [1, 1e-300, 0]])[:, 0]
    assert 0 <= u.min() and u.max() < 1
    assert project_numpy(sp, np.zeros((2, 5, 3))).shape == (2, 5, 2)


def test_frame_is_orthonormal_right_handed_gram_schmidt():
    p = Projection("planar", origin=(1, 2, 3), x_axis=(2, 0, 1), z_axis=(0, 0, 5), scale=2.5)
    o, x, y, z = p.frame()
    np.testing.assert_array_equal(o, [1, 2, 3])
    np.testing.assert_allclose(z, [0, 0, 1])
    np.testing.assert_allclose(x, [1, 0, 0])           # x_axis made orthogonal to z
    np.testing.assert_allclose(y, [0, 1, 0])           # y = z cross x
    f = Projection(**PROJECTIONS["rotated"]).frame()
    np.testing.assert_allclose(f[1:] @ f[1:].T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(np.cross(f[3], f[1]), f[2], atol=1e-15)
    np.testing.assert_allclose(p.device_frame()[1:], 2.5 * p.frame()[1:])
    np.testing.assert_array_equal(p.device_frame()[0], o)


# --- device mappings ----------------------------------------------------------------------

def test_kernel_constants_match_host(rt):
    out, ob = _out(rt, 6, np.int32)
    _program(rt).consts(rt.queue, (1,), None, ob)
    cl.enqueue_copy(rt.queue, out, ob)
    assert out.tolist() == [WRAP_MODES[m] for m in MODES] + [PROJECTION_KINDS[k] for k in KINDS]


@pytest.mark.parametrize("frame", sorted(PROJECTIONS))
@pytest.mark.parametrize("kind", KINDS)
def test_projection_matches_reference(rt, rng, kind, frame):
    proj = Projection(kind, **PROJECTIONS[frame])
    q = _random_local_points(rng, 2000, kind)
    p = _to_object(proj, q).astype(np.float32)
    dpdx = rng.normal(0, 0.01, p.shape).astype(np.float32)
    dpdy = rng.normal(0, 0.01, p.shape).astype(np.float32)
    got = device_map(rt, proj, p, dpdx, dpdy)
    assert np.all(np.isfinite(got))
    p64 = p.astype(np.float64)
    ref = project_numpy(proj, p64)
    if kind == "planar":
        assert np.abs(got[:, 0] - ref[:, 0]).max() <= 1e-5
    else:
        assert np.all((got[:, 0] >= 0) & (got[:, 0] < 1))
        assert _circ(got[:, 0], ref[:, 0]).max() <= 1e-5
    assert np.abs(got[:, 1] - ref[:, 1]).max() <= 1e-5
    for cols, dp in (((2, 3), dpdx), ((4, 5), dpdy)):
        fd = _fd(proj, p64, dp.astype(np.float64))
        err = np.linalg.norm(got[:, cols] - fd, axis=1)
        rel = err / np.linalg.norm(fd, axis=1)
        assert rel.max() <= 1e-3, (kind, frame, rel.max(), np.argmax(rel))


@pytest.mark.parametrize("kind", KINDS)
def test_zero_differentials_give_zero_derivatives(rt, rng, kind):
    proj = Projection(kind, **PROJECTIONS["rotated"])
    p = _to_object(proj, _random_local_points(rng, 100, kind))
    got = device_map(rt, proj, p)
    assert np.all(got[:, 2:] == 0)


@pytest.mark.parametrize("frame", ["identity", "rotated"])
@pytest.mark.parametrize("kind", ["cylindrical", "spherical"])
def test_axis_and_poles_are_finite(rt, rng, kind, frame):
    proj = Projection(kind, **PROJECTIONS[frame])
    rhos = np.array([0.0, 1e-30, 1e-20, 1e-12, 1e-9, 1e-7, 5e-7, 1e-6])
    zs = np.array([-1.5, -1e-7, 0.0, 1e-7, 0.8])
    ang = rng.uniform(0, 2 * np.pi, (len(rhos), len(zs)))
    R, Z = np.meshgrid(rhos, zs, indexing="ij")
    q = np.stack([R * np.cos(ang), R * np.sin(ang), Z], axis=-1).reshape(-1, 3)
    p = _to_object(proj, q)
    dpdx = rng.normal(0, 0.01, p.shape)
    dpdy = rng.normal(0, 0.01, p.shape)
    got = device_map(rt, proj, p, dpdx, dpdy)
    assert np.all(np.isfinite(got)), q[~np.all(np.isfinite(got), axis=1)]
    assert np.all((got[:, 0] >= 0) & (got[:, 0] < 1))
    if frame == "identity":     # exactly on the axis in float32 as well: documented 0 derivatives
        on_axis = (q[:, 0] == 0) & (q[:, 1] == 0)
        assert on_axis.sum() == len(zs)
        assert np.all(got[on_axis][:, [2, 4]] == 0)
        qa = q[on_axis]
        if kind == "spherical":     # at the poles (and the origin) dv is 0 too; v = 1 at +z, 0 at -z
            assert np.all(got[on_axis][:, [3, 5]] == 0)
            np.testing.assert_allclose(got[on_axis, 1], np.where(qa[:, 2] >= 0, 1.0, 0.0), atol=1e-6)
        else:                       # dv = dz_l is regular on the axis
            dz = np.stack([dpdx[on_axis, 2], dpdy[on_axis, 2]], axis=-1).astype(np.float32)
            np.testing.assert_allclose(got[on_axis][:, [3, 5]], dz, rtol=1e-6)
    # the pole's v is still accurate (atan2, not acos)
    if kind == "spherical":
        ref = project_numpy(proj, p.astype(np.float32).astype(np.float64))
        near = np.hypot(q[:, 0], q[:, 1]) <= 1e-6
        big = np.abs(q[:, 2]) > 0.5
        assert np.abs(got[near & big, 1] - ref[near & big, 1]).max() <= 1e-5


@pytest.mark.parametrize("frame", ["identity", "rotated"])
@pytest.mark.parametrize("kind", ["cylindrical", "spherical"])
def test_derivatives_continuous_across_seam(rt, rng, kind, frame):
    proj = Projection(kind, **PROJECTIONS[frame])
    n = 50
    z = rng.uniform(-0.8, 0.8, n)
    dpdx = rng.normal(0, 0.01, (n, 3))
    dpdy = rng.normal(0, 0.01, (n, 3))
    rows = {}
    for delta in (-1e-4, -1e-6, -1e-12, 0.0, 1e-6, 1e-4):
        q = np.stack([np.full(n, np.cos(delta)), np.full(n, np.sin(delta)), z], axis=-1)
        rows[delta] = device_map(rt, proj, _to_object(proj, q), dpdx, dpdy)
    base = rows[0.0]
    scale = np.linalg.norm(base[:, 2:], axis=1, keepdims=True)
    for delta, got in rows.items():
        assert np.all(np.abs(got[:, 2:] - base[:, 2:]) <= 1e-3 * scale), delta
        assert np.all((got[:, 0] >= 0) & (got[:, 0] < 1)), delta     # phi -> 2pi- must not give u = 1
    # u itself wraps: just below 1 on one side, just above 0 on the other
    assert np.all(rows[-1e-4][:, 0] > 0.99) and np.all(rows[1e-4][:, 0] < 0.01)
    assert np.abs(rows[-1e-4][:, 0] - (1 - 1e-4 / (2 * np.pi))).max() < 2e-6
    assert np.abs(rows[1e-4][:, 0] - 1e-4 / (2 * np.pi)).max() < 2e-6


SPHERE_PROJ = Projection("spherical")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.floats(0.0, math.pi), st.floats(0.0, 2 * math.pi, exclude_max=True)),
                min_size=1, max_size=32))
def test_sphere_angles_property(rt, angles):
    th = np.array([a[0] for a in angles])
    ph = np.array([a[1] for a in angles])
    p = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1).astype(np.float32)
    got = device_map(rt, SPHERE_PROJ, p)
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got[:, 1], 1 - th / np.pi, rtol=0, atol=1e-6)
    assert np.all((got[:, 0] >= 0) & (got[:, 0] < 1))
    # phi is defined where the float32 point is off the axis (normal x or y: no flush to zero)
    off_axis = np.maximum(np.abs(p[:, 0]), np.abs(p[:, 1])) >= 1e-37
    assert np.all(_circ(got[off_axis, 0], ph[off_axis] / (2 * np.pi)) <= 1e-6)


# --- UV transforms ------------------------------------------------------------------------

TRANSFORMS = [
    UVTransform(),
    UVTransform(scale=(2.0, 3.0)),
    UVTransform(rotation=30.0),
    UVTransform(offset=(0.25, -1.5)),
    UVTransform(scale=(-1.0, 0.5), offset=(3.0, 0.1), rotation=-450.0),
    UVTransform(scale=(4.0, 4.0), offset=(-0.3, 0.7), rotation=123.4),
]


def test_uv_transform_host_semantics():
    # rotation about the pivot (0.5, 0.5), counter-clockwise in (u, v)
    r90 = UVTransform(rotation=90)
    np.testing.assert_array_equal(r90.apply([[0.5, 0.5], [1.0, 0.5], [0.5, 1.0]]),
                                  [[0.5, 0.5], [0.5, 1.0], [0.0, 0.5]])
    # rotation 0: S uv + offset
    t = UVTransform(scale=(2, 3), offset=(0.5, -1))
    np.testing.assert_array_equal(t.matrix(), [[2, 0, 0.5], [0, 3, -1]])
    # general: R (S uv - c) + c + offset
    rng = np.random.default_rng(1)
    uv = rng.uniform(-3, 3, (20, 2))
    for t in TRANSFORMS:
        a = math.radians(t.rotation)
        R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        c = np.array([0.5, 0.5])
        want = (uv * t.scale - c) @ R.T + c + t.offset
        np.testing.assert_allclose(t.apply(uv), want, atol=1e-12)
        m0, m1 = t.device_args()
        np.testing.assert_allclose(m0, t.matrix()[:, :2].ravel(), rtol=1e-7)
        np.testing.assert_allclose(m1, t.matrix()[:, 2], rtol=1e-7)


@pytest.mark.parametrize("index", range(len(TRANSFORMS)))
def test_uv_transform_matches_matrix(rt, rng, index):
    t = TRANSFORMS[index]
    n = 500
    tc = np.concatenate([rng.uniform(-3, 3, (n, 2)), rng.normal(0, 0.1, (n, 4))], axis=1).astype(np.float32)
    m0, m1 = t.device_args()
    out, ob = _out(rt, 8 * n, np.float32)
    _program(rt).eval_uvt(rt.queue, (n,), None, _buf(rt, np.concatenate([m0, m1])), _buf(rt, tc), ob, np.uint32(n))
    cl.enqueue_copy(rt.queue, out, ob)
    out = out.reshape(n, 4, 2).astype(np.float64)
    m = t.matrix()
    tc64 = tc.astype(np.float64).reshape(n, 3, 2)
    want_uv = tc64[:, 0] @ m[:, :2].T + m[:, 2]
    tol = 1e-6 * (1 + np.abs(m).sum())
    assert np.abs(out[:, 0] - want_uv).max() <= tol * 4
    np.testing.assert_array_equal(out[:, 1], out[:, 0])
    for k in (1, 2):
        want = tc64[:, k] @ m[:, :2].T
        assert np.abs(out[:, k + 1] - want).max() <= tol


# --- wrap modes ---------------------------------------------------------------------------

def ref_wrap_index(i, n, mode):
    """Exact reference on Python ints."""
    if n <= 1:
        return 0
    if mode == "clamp":
        return min(max(i, 0), n - 1)
    if mode == "mirror":
        r = i % (2 * n)
        return r if r < n else 2 * n - 1 - r
    return i % n


def ref_wrap_coord(u, mode):
    """Exact (Fraction) wrapped coordinate in [0, 1]; NaN -> 0."""
    if math.isnan(u):
        return Fraction(0)
    if mode == "clamp":
        return Fraction(0) if u <= 0 else (Fraction(1) if u >= 1 else Fraction(u))
    if math.isinf(u):
        return Fraction(0)
    f = Fraction(u)
    if mode == "mirror":
        t = f - 2 * math.floor(f / 2)
        return t if t <= 1 else 2 - t
    return f - math.floor(f)


def ref_nearest(u, n, mode):
    """Texel containing u: wrap_index(floor(u n)) exactly; NaN -> 0, inf -> 0 / edge."""
    if math.isnan(u):
        return 0
    if math.isinf(u):
        return (n - 1 if u > 0 else 0) if mode == "clamp" else 0
    return ref_wrap_index(math.floor(Fraction(u) * n), n, mode)


def ref_bilerp(u, n, mode, texels):
    """1-D linear interpolation of texel centres (i + 0.5) / n through the wrap, exactly."""
    if math.isnan(u):
        u = 0.0
    if math.isinf(u):
        u = (2.0 if u > 0 else -1.0) if mode == "clamp" else 0.0
    x = Fraction(u) * n - Fraction(1, 2)
    i0 = math.floor(x)
    a = float(x - i0)
    return texels[ref_wrap_index(i0, n, mode)] * (1 - a) + texels[ref_wrap_index(i0 + 1, n, mode)] * a


I32 = np.iinfo(np.int32)


@pytest.mark.parametrize("mode", MODES)
def test_wrap_index(rt, mode):
    prg = _program(rt)
    for n in (1, 2, 3, 5, 8, 1000):
        idx = np.concatenate([np.arange(-3 * n, 3 * n + 1),
                              [I32.min, I32.min + 1, I32.max, I32.max - 1, -(2 ** 30), 2 ** 30, 123456789]]
                             ).astype(np.int32)
        out, ob = _out(rt, len(idx), np.int32)
        prg.eval_wrap_index(rt.queue, (len(idx),), None, _buf(rt, idx), np.int32(n), np.int32(WRAP_MODES[mode]),
                            ob, np.uint32(len(idx)))
        cl.enqueue_copy(rt.queue, out, ob)
        want = [ref_wrap_index(int(i), n, mode) for i in idx]
        assert out.tolist() == want, (n, mode)
    # the documented sequences, n = 3
    seq = [ref_wrap_index(i, 3, mode) for i in range(-4, 7)]
    assert seq == {"repeat": [2, 0, 1, 2, 0, 1, 2, 0, 1, 2, 0],
                   "clamp": [0, 0, 0, 0, 0, 1, 2, 2, 2, 2, 2],
                   "mirror": [2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0]}[mode]


def _wrap_inputs(rng):
    f32 = np.finfo(np.float32)
    special = [0.0, -0.0, 1.0, -1.0, 2.0, 3.0, -3.0, 0.5, -0.5, 1e-30, -1e-30, -1e-9, 1e-9,
               1 - 2 ** -24, -(1 - 2 ** -24), 16777216.0, -16777216.0, 1e9, -1e9, 1e20, -1e20,
               float(f32.max), float(-f32.max), np.inf, -np.inf, np.nan]
    rand = rng.uniform(-5, 5, 400)
    return np.concatenate([special, rand, np.arange(-6, 7)]).astype(np.float32)


@pytest.mark.parametrize("mode", MODES)
def test_wrap_coord_nearest_and_bilinear(rt, rng, mode):
    prg = _program(rt)
    u = _wrap_inputs(rng)
    m = len(u)
    for n in (1, 3, 8, 256):
        texels = rng.uniform(0, 1, n).astype(np.float32)
        coord, cb = _out(rt, m, np.float32)
        red, rb = _out(rt, m, np.float32)
        near, nb = _out(rt, m, np.int32)
        bil, bb = _out(rt, m, np.float32)
        prg.eval_wrap_float(rt.queue, (m,), None, _buf(rt, u), np.int32(n), np.int32(WRAP_MODES[mode]),
                            _buf(rt, texels), cb, rb, nb, bb, np.uint32(m))
        for h, b in ((coord, cb), (red, rb), (near, nb), (bil, bb)):
            cl.enqueue_copy(rt.queue, h, b)
        uf = [float(x) for x in u]
        # wrap_coord: in [0, 1], within float32 rounding of the exact wrapped coordinate
        assert np.all((coord >= 0) & (coord <= 1))
        want = np.array([float(ref_wrap_coord(x, mode)) for x in uf])
        err = np.abs(coord - want)
        assert err.max() <= 2.5e-7, (mode, n, u[np.argmax(err)])
        # wrap_reduce stays in its documented range and never NaN
        lo, hi = {"repeat": (0, 1), "mirror": (0, 2), "clamp": (-1, 2)}[mode]
        assert np.all((red >= lo) & (red <= hi))
        # wrap_nearest: the texel containing u, away from texel boundaries (exact for the specials)
        frac = np.array([float((Fraction(x) * n) % 1) if math.isfinite(x) else 0.5 for x in uf])
        clear = np.minimum(frac, 1 - frac) > 1e-3
        clear[:26] = True
        want_i = np.array([ref_nearest(x, n, mode) for x in uf])
        assert np.all((near >= 0) & (near < n))
        bad = clear & (near != want_i)
        assert not bad.any(), (mode, n, u[bad], near[bad], want_i[bad])
        # bilinear through wrap_reduce + wrap_index equals the unreduced footprint
        want_b = np.array([ref_bilerp(x, n, mode, texels.astype(np.float64)) for x in uf])
        assert np.abs(bil - want_b).max() <= 1e-5 * n + 1e-6, (mode, n, u[np.argmax(np.abs(bil - want_b))])
    assert near[25] == 0 and coord[25] == 0      # NaN (index 25 of the specials) -> texel 0


# --- host validation ----------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, field", [
    (dict(scale=(0.0, 1.0)), "uv_transform.scale"),
    (dict(scale=(1.0, float("nan"))), "uv_transform.scale"),
    (dict(scale=(float("inf"), 1.0)), "uv_transform.scale"),
    (dict(scale=(1.0, 2.0, 3.0)), "uv_transform.scale"),
    (dict(scale="big"), "uv_transform.scale"),
    (dict(offset=(0.0, float("inf"))), "uv_transform.offset"),
    (dict(rotation=float("nan")), "uv_transform.rotation"),
    (dict(rotation="left"), "uv_transform.rotation"),
])
def test_uv_transform_validation(kwargs, field):
    with pytest.raises(SceneError, match=field.replace(".", r"\.")):
        UVTransform(**kwargs)


def test_uv_transform_validation_after_mutation():
    t = UVTransform()
    t.scale = (1.0, 0.0)
    with pytest.raises(SceneError, match=r"uv_transform\.scale"):
        t.matrix()


@pytest.mark.parametrize("kwargs, field", [
    (dict(kind="conical"), "projection.kind"),
    (dict(kind=None), "projection.kind"),
    (dict(origin=(0.0, float("nan"), 0.0)), "projection.origin"),
    (dict(origin=(0.0, 0.0)), "projection.origin"),
    (dict(x_axis=(0.0, 0.0, 0.0)), "projection.x_axis"),
    (dict(x_axis=(0.0, 0.0, 2.0)), "projection.x_axis"),          # parallel to z
    (dict(x_axis=(1e-9, 0.0, -1.0)), "projection.x_axis"),        # nearly parallel
    (dict(z_axis=(0.0, 0.0, 0.0)), "projection.z_axis"),
    (dict(z_axis=(float("inf"), 0.0, 1.0)), "projection.z_axis"),
    (dict(scale=0.0), "projection.scale"),
    (dict(scale=-1.0), "projection.scale"),
    (dict(scale=float("nan")), "projection.scale"),
])
def test_projection_validation(kwargs, field):
    with pytest.raises(SceneError, match=field.replace(".", r"\.")):
        Projection(**kwargs)


def test_project_numpy_rejects_bad_points():
    with pytest.raises(ValueError):
        project_numpy(Projection(), np.zeros((4, 2)))
