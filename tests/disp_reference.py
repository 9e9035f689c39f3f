"""float64 references and a per-ray tracer shared by the displacement tests
(tests/kernels/test_displace.py, tests/render/test_mesh_search.py)."""
import numpy as np
import pyopencl as cl

from texray.device import layout
from texray.scene import heightfield as HF

CORNERS = ((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1))     # u along +x, v along -z, n = +y
TRAPEZOID = ((-1.2, 0, 1), (1.2, 0, 1), (0.6, 0, -1), (-0.5, 0, -1.1))     # planar, convex, no two sides parallel


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


def inverse_bilinear(q, p):
    """float64 (u, v) of the points q (..., 3) on the planar quad p (4, 3) by its bilinear
    patch p0 + u e0 + v e1 + u v g, solved independently of the kernel: Newton on the two
    in-plane equations from the parallelogram's affine guess (NaN where it does not converge)."""
    e0, e1, g = p[1] - p[0], p[3] - p[0], p[0] - p[1] + p[2] - p[3]
    n = np.cross(e0, e1)
    n /= np.linalg.norm(n)
    a1 = e0 / np.linalg.norm(e0)
    a2 = np.cross(n, a1)
    basis = np.stack([a1, a2])                     # in-plane coordinates
    r = (q - p[0]) @ basis.T
    E0, E1, G = e0 @ basis.T, e1 @ basis.T, g @ basis.T
    inv = np.linalg.inv(np.stack([E0, E1]))
    x, y = r[..., 0], r[..., 1]
    u, v = x * inv[0, 0] + y * inv[1, 0], x * inv[0, 1] + y * inv[1, 1]      # the affine guess
    (e0x, e0y), (e1x, e1y), (gx, gy) = E0, E1, G
    with np.errstate(invalid="ignore", divide="ignore"):
        for _ in range(30):                         # until the steps are below 1e-15 (quadratic: a few)
            uvp = u * v
            rx, ry = u * e0x + v * e1x + uvp * gx - x, u * e0y + v * e1y + uvp * gy - y
            jux, juy, jvx, jvy = e0x + v * gx, e0y + v * gy, e1x + u * gx, e1y + u * gy
            det = jux * jvy - juy * jvx
            du, dv = (rx * jvy - ry * jvx) / det, (jux * ry - juy * rx) / det
            u, v = u - du, v - dv
            if not (np.abs(du) > 1e-15).any() and not (np.abs(dv) > 1e-15).any():
                break
    uv = np.stack([u, v], -1)
    res = u[..., None] * E0 + v[..., None] * E1 + (u * v)[..., None] * G - r
    return np.where((np.abs(res) < 1e-9).all(-1)[..., None], uv, np.nan)


def trapezoid_reference(d, corners, org, dirs, samples=4000):
    """float64 (t, uv) of the first crossing of each ray with the displaced planar convex quad
    ``corners`` (f = h - H(u, v), +inf outside the (u, v) domain), as quad_reference: samples
    over the ray's part (t >= 0) in the slab [min H, max H] along the normal over the quad
    (within the half-spaces of its four edges, widened by 1e-9). Rays parallel to the plane
    are not handled."""
    p = np.asarray(corners, np.float64)
    n = np.cross(p[1] - p[0], p[3] - p[0])
    n /= np.linalg.norm(n)
    h = d.heights()
    org = np.broadcast_to(np.asarray(org, np.float64), np.shape(dirs))
    dirs = np.asarray(dirs, np.float64)
    ho, hd = (org - p[0]) @ n, dirs @ n
    t0, t1 = (h.min() - 1e-9 - ho) / hd, (h.max() + 1e-9 - ho) / hd
    tn, tf = np.maximum(np.minimum(t0, t1), 0), np.maximum(t0, t1)
    for i in range(4):                                   # (q - p_i) . (n x edge) >= 0: inside
        m = np.cross(n, p[(i + 1) % 4] - p[i])
        m /= np.linalg.norm(m)
        a, b = (org - p[i]) @ m + 1e-9, dirs @ m
        with np.errstate(divide="ignore", invalid="ignore"):
            te = -a / b
        tn, tf = np.where(b > 0, np.maximum(tn, te), tn), np.where(b < 0, np.minimum(tf, te), tf)
        tf = np.where((b == 0) & (a < 0), -np.inf, tf)   # parallel to the edge, outside it
    tf = np.maximum(tf, tn)                              # an empty part: no samples over the quad, a miss

    def f(t):
        q = org[:, None] + t[..., None] * dirs[:, None]
        uv = inverse_bilinear(q, p)
        u, v = uv[..., 0], uv[..., 1]
        inside = (u >= -1e-12) & (u <= 1 + 1e-12) & (v >= -1e-12) & (v <= 1 + 1e-12)
        hq = (q - p[0]) @ n
        with np.errstate(invalid="ignore"):
            return np.where(inside, hq - HF.height(h, np.clip(np.nan_to_num(u), 0, 1),
                                                    np.clip(np.nan_to_num(v), 0, 1), d.wrap), np.inf), uv

    t = tn[:, None] + np.linspace(0, 1, samples)[None] * (tf - tn)[:, None]
    fv, _ = f(t)
    below = fv < 0
    first = np.argmax(np.isfinite(fv), axis=1)          # the first sample over the quad sets the side
    rows = np.arange(len(t))
    start = below[rows, first]
    change = (below != start[:, None]) & np.isfinite(fv) & (np.arange(samples)[None] > first[:, None])
    ok = change.any(axis=1)
    i = np.argmax(change, axis=1)
    lo_t, hi_t = t[rows, np.maximum(i - 1, 0)], t[rows, i]
    for _ in range(50):
        mid = 0.5 * (lo_t + hi_t)
        fm, _ = f(mid[:, None])
        same = (fm[:, 0] < 0) == start
        lo_t, hi_t = np.where(same, mid, lo_t), np.where(same, hi_t, mid)
    th = 0.5 * (lo_t + hi_t)
    _, uv = f(th[:, None])
    return np.where(ok, th, np.nan), uv[:, 0]


def height_texture(a):
    """A one-channel texture of the 2-D array a (row 0 on top)."""
    import texray as tx
    return tx.Texture.from_array(np.asarray(a, np.float32).reshape(a.shape[0], a.shape[1], 1))


def sines(n=48, a=0.5, k=3.0, rows=np.sin):
    """h = a sin(k x) rows(k y) + a at the texel centres of an n x n map (texture row 0 on top;
    rows=np.cos makes it smooth across the u seam of a sphere or cylinder)."""
    c = (np.arange(n) + 0.5) / n * 2 * np.pi
    return height_texture(a + a * np.sin(k * c)[None, :] * rows(k * c)[:, None])


def one_texel_spikes(n=64, count=40, margin=6, seed=3):
    """An n x n map, 0 but for `count` texels of 1 at least `margin` texels from its border:
    (the array, the spikes' texel-centre u, v)."""
    a = np.zeros((n, n))
    ij = np.random.default_rng(seed).integers(margin, n - margin, (count, 2))
    a[ij[:, 0], ij[:, 1]] = 1.0
    return a, (ij[:, 1] + 0.5) / n, 1 - (ij[:, 0] + 0.5) / n


def first_hits_agree(a, b, rtol):
    """Hit distances a (maxmip) and b (a fine search) of the same rays, NaN for misses: hit and
    miss agree on 99% of the rays, more than half hit, t within rtol on 99% of those."""
    assert (np.isnan(a) == np.isnan(b)).mean() >= 0.99
    both = ~np.isnan(a) & ~np.isnan(b)
    assert both.mean() > 0.5
    assert (np.abs(a[both] - b[both]) / b[both] <= rtol).mean() >= 0.99


def shadows_agree(tracers, pts, nrm, inner, light):
    """Any-hit rays of the "maxmip" and "search" Tracers in ``tracers`` (self-shadowing):
    from just above the surface points pts (2e-4 along their unit normals nrm, so that the
    side a ray starts on is not rounding's) toward lights 0.8 away along the unit vectors
    light, from the points ``inner`` of the shell toward a far light, and from outside
    toward pts. maxmip is occluded where the search is on 99% of the rays (the search's
    own surface differs by its error: a ray grazing a crest can flip), some rays are and
    some are not; rays leaving pts along nrm are never occluded by maxmip, on at most 1%
    by the search (its surface can lie just over a point of maxmip's)."""
    far = 3 * light[0] / np.linalg.norm(light[0])
    occ = {}
    for method, tracer in tracers.items():
        o1 = tracer.occluded(pts + 2e-4 * nrm, 0.8 * light)[0]                       # from the surface
        o2 = tracer.occluded(inner, far - inner)[0]                                  # from within the shell
        o3 = tracer.occluded(np.broadcast_to(2 * far, pts.shape), pts - 2 * far, tmax=0.999)[0]   # from outside
        away = tracer.occluded(pts, 0.05 * nrm)[0]
        occ[method] = (np.concatenate([o1, o2, o3]), away, o1)
    a, b = occ["maxmip"][0], occ["search"][0]
    assert 0.05 < a.mean() < 0.95 and 0.02 < occ["maxmip"][2].mean() < 0.98
    assert (a == b).mean() >= 0.99, (a != b).sum()
    assert not occ["maxmip"][1].any() and occ["search"][1].mean() <= 0.01, occ["search"][1].sum()


def aovs_agree(a, b, uv_wraps=False):
    """Images a (maxmip) and b (a fine search) rendered with the depth, position, uv and
    shading_normal AOVs: the same first hits on 99.5% of the pixels, and where both hit,
    the AOVs (depth, position, uv within 1e-4, shading normal within 1e-3; u modulo 1 where
    uv_wraps) and the colour (within 2e-3) on 99%. The mask of pixels both hit."""
    da, db = a.aov["depth"][..., 0], b.aov["depth"][..., 0]
    assert (np.isnan(da) == np.isnan(db)).mean() >= 0.995
    both = ~np.isnan(da) & ~np.isnan(db)
    for name, tol in (("depth", 1e-4), ("position", 1e-4), ("uv", 1e-4), ("shading_normal", 1e-3)):
        diff = np.abs(a.aov[name] - b.aov[name]).max(axis=-1)[both]
        if name == "uv" and uv_wraps:
            diff = np.minimum(diff, 1 - diff)
        assert np.mean(diff <= tol) >= 0.99, (name, np.percentile(diff, 99))
    diff = np.abs(a.rgb - b.rgb).max(axis=-1)[both]
    assert np.mean(diff <= 2e-3) >= 0.99, ("rgb", np.mean(diff > 2e-3), np.percentile(diff, [99, 100]))
    return both


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


def curved_local(shape, q):
    """float64 (u, v, h) of the points q (..., 3) about a tx.Sphere or tx.Cylinder, in its own
    parameterization (Sphere.surface, Cylinder.surface; written here from those formulas,
    independently of the kernel's): u, v NaN where the shape has no surface (a partial
    cylinder's gap, beyond its z range)."""
    import texray as tx
    w = shape.world()
    c, r, ax, az = w[:4]
    ay = np.cross(az, ax)
    p = np.asarray(q, np.float64) - c
    x, y, z = p @ ax, p @ ay, p @ az
    rho = np.hypot(x, y)
    if isinstance(shape, tx.Sphere):
        u = np.mod(np.arctan2(y, x) / (2 * np.pi), 1.0)
        return u, 1 - np.arctan2(rho, z) / np.pi, np.hypot(rho, z) - r
    (z0, z1), (t0, t1) = w[4], w[5]
    u = np.mod(np.arctan2(y, x) - t0, 2 * np.pi) / (t1 - t0)
    v = (z - z0) / (z1 - z0)
    ok = (u <= 1) & (v >= 0) & (v <= 1)
    return np.where(ok, u, np.nan), np.where(ok, v, np.nan), rho - r


def curved_reference(shape, d, org, dirs, samples=20000, chunk=64):
    """float64 (t, uv) of the first crossing of each ray with the displaced sphere or
    cylinder ``shape`` (displacement ``d``), NaN if none: f = h - H(u, v) sampled at
    ``samples`` points over the ray's part (t >= 0) within the outer shell r + max H (a
    cylinder's within its z range; a sphere's up to where it enters the inner sphere r +
    min H, as the kernel's volume), the first sample with surface setting the side (the
    search's rule: samples without surface neither start nor end a bracket), the first
    sign change after it bisected 50 times."""
    import texray as tx
    hts = d.heights()
    w = shape.world()
    c, r, ax, az = w[:4]
    org = np.broadcast_to(np.asarray(org, np.float64), np.shape(dirs))
    dirs = np.asarray(dirs, np.float64)
    R = r + hts.max() + 1e-9
    if isinstance(shape, tx.Sphere):
        oc, dd = org - c, dirs
    else:                                   # the distance to the axis: drop the axial parts
        oc = (org - c) - ((org - c) @ az)[:, None] * az
        dd = dirs - (dirs @ az)[:, None] * az
    a, b, cc = (dd * dd).sum(1), (oc * dd).sum(1), (oc * oc).sum(1) - R * R
    disc = b * b - a * cc
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.maximum(disc, 0))
        tn, tf = (-b - sq) / a, (-b + sq) / a
        if not isinstance(shape, tx.Sphere):
            (z0, z1) = w[4]
            zo, zd = (org - c) @ az, dirs @ az
            s0, s1 = (z0 - zo) / zd, (z1 - zo) / zd
            tn, tf = np.maximum(tn, np.minimum(s0, s1)), np.minimum(tf, np.maximum(s0, s1))
        if isinstance(shape, tx.Sphere):      # the kernel's volume: cut where the ray enters the inner
            ri = r + hts.min() - 1e-9          # sphere, below the surface everywhere (displace.h disp_clip)
            ci = (oc * oc).sum(1) - ri * ri
            di = b * b - a * ci
            enter = (-b - np.sqrt(np.maximum(di, 0))) / a
            tf = np.where((ri > 0) & (di >= 0) & (enter > np.maximum(tn, 0)), np.minimum(tf, enter), tf)
    tn = np.maximum(tn, 0)
    ok = (disc >= 0) & (tn < tf)
    tn, tf = np.where(ok, tn, 0.0), np.where(ok, tf, 0.0)

    def f(o, dv, t):
        q = o[:, None] + t[..., None] * dv[:, None]
        u, v, h = curved_local(shape, q)
        fin = ~np.isnan(u)
        hv = HF.height(hts, np.clip(np.nan_to_num(u), 0, 1), np.clip(np.nan_to_num(v), 0, 1), d.wrap)
        return np.where(fin, h - hv, np.inf), u, v

    t_out, uv_out = np.full(len(dirs), np.nan), np.full((len(dirs), 2), np.nan)
    lin = np.linspace(0, 1, samples)[None]
    for s in range(0, len(dirs), chunk):
        sl = slice(s, s + chunk)
        o, dv, a0, a1 = org[sl], dirs[sl], tn[sl], tf[sl]
        t = a0[:, None] + lin * (a1 - a0)[:, None]
        fv, _, _ = f(o, dv, t)
        fin = np.isfinite(fv)
        below = fv < 0
        first = np.argmax(fin, axis=1)
        rows = np.arange(len(t))
        start = below[rows, first]
        # the last finite sample before each one: brackets skip samples without surface
        idx = np.where(fin, np.arange(samples)[None], -1)
        prev = np.maximum.accumulate(idx, axis=1)
        prev = np.concatenate([np.full((len(t), 1), -1), prev[:, :-1]], axis=1)
        change = (below != start[:, None]) & fin & (np.arange(samples)[None] > first[:, None]) & fin.any(1)[:, None]
        hit = change.any(axis=1) & ok[sl]
        i = np.argmax(change, axis=1)
        lo_t, hi_t = t[rows, np.maximum(prev[rows, i], 0)], t[rows, i]
        for _ in range(50):
            mid = 0.5 * (lo_t + hi_t)
            fm, _, _ = f(o, dv, mid[:, None])
            same = (fm[:, 0] < 0) == start
            lo_t, hi_t = np.where(same, mid, lo_t), np.where(same, hi_t, mid)
        th = 0.5 * (lo_t + hi_t)
        _, u, v = f(o, dv, th[:, None])
        t_out[sl] = np.where(hit, th, np.nan)
        uv_out[sl] = np.column_stack([u[:, 0], v[:, 0]])
    return t_out, uv_out
