"""Analytic primitives (kernels/sphere.h, cylinder.h, quad.h): intersection and hit
geometry through a test kernel on the device, against the float64 references of
tests/prim_reference.py.
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl

from texray import layout
from texray.device import KERNEL_DIR

import prim_reference as ref

_KERNELS = r"""
#include "common.h"
#include "geom.h"
#include "sphere.h"
#include "cylinder.h"
#include "quad.h"

#define OUT_FLOATS 24   /* hit, t, uv[2], p[3], ng[3], dpdu[3], dpdv[3], perr[3], param[2], pad[3] */

inline void store(__global float* o, float t, const Geom* g, float2 param)
{
    o[0] = 1.0f;
    o[1] = t;
    vstore2(g->uv, 0, o + 2);
    vstore3(g->p, 0, o + 4);
    vstore3(g->ng, 0, o + 7);
    vstore3(g->dpdu, 0, o + 10);
    vstore3(g->dpdv, 0, o + 13);
    vstore3(g->perr, 0, o + 16);
    vstore2(param, 0, o + 19);
}

inline __global float* cleared(__global float* out, uint i)
{
    __global float* o = out + (size_t)i * OUT_FLOATS;
    for (int k = 0; k < OUT_FLOATS; ++k) o[k] = 0.0f;
    return o;
}

__kernel void trace_sphere(__global const Sphere* s, __global const Ray* rays, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    __global const Ray* r = rays + i;
    float3 org = ray_org(r), dir = ray_dir(r);
    __global float* o = cleared(out, i);
    float t;
    if (sphere_intersect(s, org, dir, r->tmin, r->tmax, &t)) {
        Geom g;
        sphere_geom(s, org, dir, t, &g);
        store(o, t, &g, (float2)(0.0f));
    }
}

__kernel void trace_cylinder(__global const Cylinder* c, __global const Ray* rays, __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    __global const Ray* r = rays + i;
    float3 org = ray_org(r), dir = ray_dir(r);
    __global float* o = cleared(out, i);
    float t;
    if (cylinder_intersect(c, org, dir, r->tmin, r->tmax, &t)) {
        Geom g;
        cylinder_geom(c, org, dir, t, &g);
        store(o, t, &g, (float2)(0.0f));
    }
}

__kernel void trace_quad(__global const QuadVerts* q, __global const QuadShade* qs, __global const Ray* rays,
                         __global float* out, uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    __global const Ray* r = rays + i;
    float3 org = ray_org(r), dir = ray_dir(r);
    __global float* o = cleared(out, i);
    float t;
    float2 uv;
    if (quad_intersect(q, org, dir, r->tmin, r->tmax, &t, &uv)) {
        Geom g;
        quad_geom(q, qs, uv, &g);
        store(o, t, &g, uv);
    }
}
"""

OUT = np.dtype([("hit", "<f4"), ("t", "<f4"), ("uv", "<f4", (2,)), ("p", "<f4", (3,)), ("ng", "<f4", (3,)),
                ("dpdu", "<f4", (3,)), ("dpdv", "<f4", (3,)), ("perr", "<f4", (3,)), ("param", "<f4", (2,)),
                ("pad", "<f4", (3,))])
_HEADERS = ("common.h", "geom.h", "sphere.h", "cylinder.h", "quad.h")
_programs = {}


class _Kernels:
    """A built program's kernels, each retrieved once."""

    def __init__(self, prg):
        self.sphere = prg.trace_sphere
        self.cylinder = prg.trace_cylinder
        self.quad = prg.trace_quad


def _program(rt):
    heads = "".join((KERNEL_DIR / h).read_text() for h in _HEADERS)
    key = (rt.context.int_ptr, hash(heads))
    prg = _programs.get(key)
    if prg is None:
        # the headers' hash in the source: pyopencl's binary cache must not serve stale includes
        src = f"/* {key[1]} */\n" + layout.opencl_declarations() + _KERNELS
        built = cl.Program(rt.context, src).build(options=["-I", str(KERNEL_DIR)])
        prg = _programs[key] = _Kernels(built)
    return prg


def _buf(rt, a):
    mf = cl.mem_flags
    return cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))


def _rays(org, dirs, tmin=0.0, tmax=np.inf):
    r = np.zeros(len(dirs), layout.RAY)
    r["org"], r["dir"], r["tmin"], r["tmax"] = org, dirs, tmin, tmax
    return r


def _trace(rt, kernel, prims, rays):
    n = len(rays)
    out = np.zeros(n, OUT)
    ob = cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, max(out.nbytes, 16))
    kernel(rt.queue, (max(n, 1),), None, *[_buf(rt, p) for p in prims], _buf(rt, rays), ob, np.uint32(n))
    cl.enqueue_copy(rt.queue, out, ob)
    res = {k: out[k].astype(np.float64) for k in OUT.names if k != "pad"}
    res["hit"] = out["hit"] == 1.0
    return res


def trace_sphere(rt, s, rays):
    return _trace(rt, _program(rt).sphere, [s], rays)


def trace_cylinder(rt, c, rays):
    return _trace(rt, _program(rt).cylinder, [c], rays)


def trace_quad(rt, q, qs, rays):
    return _trace(rt, _program(rt).quad, [q, qs], rays)


# --- primitives --------------------------------------------------------------

def make_sphere(center, radius, axis_x=(1, 0, 0), axis_z=(0, 0, 1)):
    s = np.zeros(1, layout.SPHERE)
    s["center"], s["radius"], s["axis_x"], s["axis_z"] = center, radius, axis_x, axis_z
    return s


def make_cylinder(origin, radius, z_range, theta_range, axis_x=(1, 0, 0), axis_z=(0, 0, 1)):
    c = np.zeros(1, layout.CYLINDER)
    c["origin"], c["radius"], c["axis_x"], c["axis_z"] = origin, radius, axis_x, axis_z
    c["z_min"], c["z_max"] = z_range
    c["theta_min"], c["theta_max"] = theta_range
    return c


def make_quad(P, tex_uv=(0, 0, 1, 0, 1, 1, 0, 1)):
    q = np.zeros(1, layout.QUAD_VERTS)
    P = np.asarray(P, np.float64)
    q["p0"], q["p1"], q["p2"], q["p3"] = P
    qs = np.zeros(1, layout.QUAD_SHADE)
    qs["uv"] = tex_uv
    return q, qs


def quad_vertices(q):
    return np.stack([q[k][0] for k in ("p0", "p1", "p2", "p3")]).astype(np.float64)


def sphere_ref(s, org, dirs, **kw):
    return ref.sphere_intersect(s["center"][0], s["radius"][0], s["axis_x"][0], s["axis_z"][0],
                                org.astype(np.float64), dirs.astype(np.float64), **kw)


def cylinder_ref(c, org, dirs, **kw):
    return ref.cylinder_intersect(c["origin"][0], c["radius"][0], c["axis_x"][0], c["axis_z"][0],
                                  c["z_min"][0], c["z_max"][0], c["theta_min"][0], c["theta_max"][0],
                                  org.astype(np.float64), dirs.astype(np.float64), **kw)


def quad_ref(q, qs, org, dirs, **kw):
    return ref.quad_intersect(quad_vertices(q), org.astype(np.float64), dirs.astype(np.float64),
                              tex_uv=qs["uv"][0].astype(np.float64), **kw)


def random_frame(rng):
    """Float32 axis_x, axis_z of a random rotation."""
    m, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return m[:, 0].astype(np.float32), m[:, 2].astype(np.float32)
