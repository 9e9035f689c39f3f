"""float64 references and a per-ray tracer shared by the displacement tests
(tests/kernels/test_displace.py, tests/render/test_mesh_search.py)."""
import numpy as np
import pyopencl as cl

from texray.device import layout
from texray.scene import heightfield as HF

CORNERS = ((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1))     # u along +x, v along -z, n = +y


def quad_reference(d, org, dirs, samples=4000):
    """float64 (t, uv) of the first crossing of each ray with the displaced CORNERS quad; NaN if none."""
    p = np.asarray(CORNERS, np.float64)
    e0, e1 = p[1] - p[0], p[3] - p[0]
    n = np.cross(e0, e1)
    n /= np.linalg.norm(n)
    m = np.linalg.inv(np.stack([e0, e1, n], 1))
    h = d.heights()
    ld = np.asarray(dirs, np.float64) @ m.T
    lo = np.broadcast_to((np.asarray(org, np.float64) - p[0]) @ m.T, ld.shape)
    a, b = np.array([0, 0, h.min() - 1e-9]), np.array([1, 1, h.max() + 1e-9])
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (a - lo) / ld, (b - lo) / ld
        tn = np.max(np.where(ld != 0, np.minimum(t0, t1), np.where((lo >= a) & (lo <= b), -np.inf, np.inf)), 1)
        tf = np.min(np.where(ld != 0, np.maximum(t0, t1), np.where((lo >= a) & (lo <= b), np.inf, -np.inf)), 1)
    tn = np.maximum(tn, 0)
    ok = tn < tf
    tf = np.where(ok, tf, tn)

    def f(t):
        q = lo[:, None] + t[..., None] * ld[:, None]
        u, v = q[..., 0], q[..., 1]
        inside = (u >= -1e-12) & (u <= 1 + 1e-12) & (v >= -1e-12) & (v <= 1 + 1e-12)
        return np.where(inside, q[..., 2] - HF.height(h, np.clip(u, 0, 1), np.clip(v, 0, 1), d.wrap), np.inf)

    tn, tf = np.where(ok, tn, 0.0), np.where(ok, tf, 0.0)     # misses: an empty interval, no inf - inf
    t = tn[:, None] + np.linspace(0, 1, samples)[None] * (tf - tn)[:, None]
    below = f(t) < 0
    change = below != below[:, :1]
    ok &= change.any(axis=1)
    i = np.argmax(change, axis=1)
    rows = np.arange(len(t))
    lo_t, hi_t, b0 = t[rows, np.maximum(i - 1, 0)], t[rows, i], below[:, 0]
    for _ in range(50):
        mid = 0.5 * (lo_t + hi_t)
        same = (f(mid[:, None])[:, 0] < 0) == b0
        lo_t, hi_t = np.where(same, mid, lo_t), np.where(same, hi_t, mid)
    th = 0.5 * (lo_t + hi_t)
    uv = (lo + th[:, None] * ld)[:, :2]
    return np.where(ok, th, np.nan), uv


def trace_each(tracer, orgs, dirs):
    """Closest hits of rays with per-ray origins (Tracer takes one origin per batch):
    (t, NaN for a miss; the primitive's (u, v))."""
    n = len(dirs)
    r = np.zeros(n, layout.RAY)
    r["org"], r["dir"], r["tmin"], r["tmax"] = orgs, dirs, 0.0, np.inf
    mf = cl.mem_flags
    ctx = tracer.rt.context
    rays = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=r)
    out = np.zeros(n, layout.HIT)
    hits = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes)
    tracer._k_closest(tracer.rt.queue, (n,), None, rays, hits, np.uint32(n), *tracer.up.geom)
    cl.enqueue_copy(tracer.rt.queue, out, hits)
    miss = out["prim"] == 0xFFFFFFFF
    t = np.where(miss, np.nan, out["t"]).astype(np.float64)
    return t, np.column_stack([out["b1"], out["b2"]])


def uv_sphere_mesh(sphere, material, nu=128, nv=64):
    """A tx.Mesh of ``sphere``'s own parameterization: an (nu x nv)-cell lattice of its
    surface(u, v), uvs = (u, v), its normals, zero-area faces at the poles left out."""
    import texray as tx
    u, v = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1))
    p, n = sphere.surface(u, v)
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nv + 1, nu + 1)
    a, b, c, e = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, e], 1)])
    pts = p.reshape(-1, 3)
    area = np.linalg.norm(np.cross(pts[faces[:, 1]] - pts[faces[:, 0]], pts[faces[:, 2]] - pts[faces[:, 0]]), axis=1)
    return tx.Mesh(pts, faces[area > 1e-12], np.stack([u.ravel(), v.ravel()], 1), n.reshape(-1, 3), name="m",
                   material=material)
