"""maxmip on displaced spheres and cylinders (kernels/geometry/displace.h disp_maxmip_curved)
against float64 references (tests/disp_reference.py curved_reference: f = h - H sampled
densely along the ray, the first sign change bisected) and against a fine search.

Tolerances: the traversal brackets each root exactly (a cell is skipped only when it
cannot hold one) and polishes it in float32 with regula falsi on (u, v, h) from atan2
and hypot: hit distances agree with the float64 root to about 1e-6 relatively, up to a
few 1e-5 at 4 degrees above the surface (T_CURVED, relative; absolute 1e-5 below t = 0.1,
for rays from inside the shell meeting the surface at once). Hit and miss disagree only where a ray
grazes a crest within the reference's sample spacing (<= 1% of the rays)."""
import numpy as np
import pytest
import texray as tx
from texray.renderer.trace import Tracer
from disp_reference import aovs_agree, curved_reference, first_hits_agree, height_texture as _tex, \
    one_texel_spikes, shadows_agree, trace_each
from disp_reference import sines as _plain_sines

T_CURVED = 1e-4       # relative t error of maxmip against the float64 root (module docstring)
T_FINE = 1e-3         # relative t difference of maxmip and the search at N = 1024, M = 12
SCALE = 0.15


def _sines(n=48, a=0.5, k=3.0):
    """h = a sin(k x) cos(k y) + a at the texel centres (periodic in x: the seam is smooth)."""
    return _plain_sines(n, a, k, rows=np.cos)


def _shape(kind, d, partial=False):
    m = tx.Material(displacement=d)
    if kind == "sphere":
        return tx.Sphere(center=(0.1, -0.05, 0.02), radius=0.6, axis_z=(0.2, 1, 0.1), axis_x=(1, 0, 0), material=m)
    return tx.Cylinder(radius=0.5, z_range=(-0.8, 0.8), origin=(0.05, 0.0, -0.1), axis_z=(0.1, 1, 0.2),
                       axis_x=(1, 0, 0), theta_range=(30, 280) if partial else (0, 360), material=m)


def _tracer(shape, device):
    s = tx.Scene(camera=tx.Camera(eye=(0, 0.5, 4), look_at=(0, 0, 0)), ambient=(0.1, 0.1, 0.1))
    s.add(shape)
    return Tracer(s, device)


def _frame(shape, u, v):
    """Surface points, unit normals and unit tangents (random mix of dP/du, dP/dv) at (u, v)."""
    rng = np.random.default_rng(len(u))
    p, n = shape.surface(u, v)
    e = 1e-6
    pu = (shape.surface(u + e, v)[0] - shape.surface(u - e, v)[0])
    pv = (shape.surface(u, np.clip(v + e, 0, 1))[0] - shape.surface(u, np.clip(v - e, 0, 1))[0])
    pu /= np.linalg.norm(pu, axis=1)[:, None]
    pv /= np.linalg.norm(pv, axis=1)[:, None]
    a = rng.uniform(0, 2 * np.pi, len(u))[:, None]
    t = np.cos(a) * pu + np.sin(a) * pv
    t -= (t * n).sum(1)[:, None] * n
    return p, n, t / np.linalg.norm(t, axis=1)[:, None]


def _grazing_rays(shape, elev_deg, u, v, back=1.5):
    """Rays at elev_deg above the base surface's tangent plane toward mid-height points over (u, v)."""
    p, n, t = _frame(shape, u, v)
    e = np.radians(elev_deg)
    d = np.cos(e) * t - np.sin(e) * n
    target = p + 0.5 * SCALE * n
    return target - back * d, d


def _compare(tracer, shape, d, orgs, dirs, agree_min=0.99, good_min=0.99, samples=20000):
    t, uv = trace_each(tracer, orgs, dirs)
    tr, uvr = curved_reference(shape, d, orgs, dirs, samples=samples)
    agree = np.isnan(t) == np.isnan(tr)
    assert agree.mean() >= agree_min, (agree.mean(), np.flatnonzero(~agree)[:5], t[~agree][:5], tr[~agree][:5])
    both = ~np.isnan(t) & ~np.isnan(tr)
    rel = np.abs(t[both] - tr[both]) / np.maximum(tr[both], 0.1)    # relative, absolute below t = 0.1
    good = rel <= T_CURVED
    assert good.mean() >= good_min, (good.mean(), np.sort(rel)[-5:])
    du = np.abs(uv[both] - uvr[both])
    du[:, 0] = np.minimum(du[:, 0], 1 - du[:, 0])             # u wraps at the seam
    assert np.percentile(du.max(1), 99) <= 1e-3, np.sort(du.max(1))[-5:]
    return t, tr


@pytest.mark.parametrize("kind", ["sphere", "cylinder"])
@pytest.mark.parametrize("elev", [70, 40, 15, 4])
def test_maxmip_matches_float64_root_finder(kind, elev, device):
    d = tx.Displacement(_sines(), scale=SCALE, method="maxmip")
    shape = _shape(kind, d)
    rng = np.random.default_rng(elev)
    u, v = rng.uniform(0, 1, 300), rng.uniform(0.1, 0.9, 300)
    orgs, dirs = _grazing_rays(shape, elev, u, v)
    t, tr = _compare(_tracer(shape, device), shape, d, orgs, dirs)
    assert (~np.isnan(tr)).mean() > 0.5


@pytest.mark.parametrize("kind", ["sphere", "cylinder"])
def test_maxmip_from_inside_the_shell_at_the_seam_and_the_poles(kind, device):
    """Origins inside the shell (above and below the surface) with random directions; rays at
    grazing and steep angles toward points within 0.01 of the seam u = 0 / 1; for the
    sphere, toward points within 3 degrees of either pole and rays through the axis."""
    d = tx.Displacement(_sines(), scale=SCALE, method="maxmip")
    shape = _shape(kind, d)
    tracer = _tracer(shape, device)
    rng = np.random.default_rng(7)
    n = 300
    u, v = rng.uniform(0, 1, n), rng.uniform(0.05, 0.95, n)
    p, nrm, _ = _frame(shape, u, v)
    orgs = p + rng.uniform(0.0, SCALE, n)[:, None] * nrm
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    _compare(tracer, shape, d, orgs, dirs, agree_min=0.98, good_min=0.98)
    us = np.mod(rng.uniform(-0.01, 0.01, n), 1)
    for elev in (60, 10):
        orgs, dirs = _grazing_rays(shape, elev, us, rng.uniform(0.1, 0.9, n))
        _compare(tracer, shape, d, orgs, dirs)
    if kind == "sphere":
        vp = np.where(rng.random(n) < 0.5, rng.uniform(0, 3 / 180, n), rng.uniform(1 - 3 / 180, 1, n))
        for elev in (60, 20):
            orgs, dirs = _grazing_rays(shape, elev, rng.uniform(0, 1, n), vp)
            _compare(tracer, shape, d, orgs, dirs)
        c, _, _, az = shape.world()                # through the axis, from outside and from the centre
        side = np.cross(az, [1.0, 0.0, 0.0])
        side /= np.linalg.norm(side)
        ang = rng.uniform(0, np.pi, 64)[:, None]
        dirs = np.cos(ang) * az + np.sin(ang) * side
        _compare(tracer, shape, d, c - 2 * dirs, dirs)
        _compare(tracer, shape, d, np.broadcast_to(c, dirs.shape), dirs)


@pytest.mark.parametrize("kind", ["sphere", "cylinder"])
def test_maxmip_agrees_with_a_fine_search(kind, device):
    """maxmip against the search at N = 1024, M = 12 on the same rays (70 to 4 degrees)."""
    rng = np.random.default_rng(11)
    hits = {}
    for method in ("maxmip", "search"):
        d = tx.Displacement(_sines(), scale=SCALE, method=method, steps=1024, refine=12)
        shape = _shape(kind, d)
        tracer = _tracer(shape, device)
        ts = []
        for elev in (70, 30, 10, 4):
            r = np.random.default_rng(elev)
            orgs, dirs = _grazing_rays(shape, elev, r.uniform(0, 1, 300), r.uniform(0.1, 0.9, 300))
            ts.append(trace_each(tracer, orgs, dirs)[0])
        hits[method] = np.concatenate(ts)
    first_hits_agree(hits["maxmip"], hits["search"], T_FINE)


def test_maxmip_on_a_partial_cylinder(device):
    """theta_range (30, 280): rays through the gap see no surface there; hits as the reference."""
    d = tx.Displacement(_sines(), scale=SCALE, method="maxmip")
    shape = _shape("cylinder", d, partial=True)
    rng = np.random.default_rng(5)
    for elev in (60, 10):
        orgs, dirs = _grazing_rays(shape, elev, rng.uniform(0, 1, 300), rng.uniform(0.1, 0.9, 300), back=2.0)
        _compare(_tracer(shape, device), shape, d, orgs, dirs)


@pytest.mark.parametrize("kind", ["sphere", "cylinder"])
def test_maxmip_never_misses_one_texel_spikes(kind, device):
    """One-texel spikes on a flat map; grazing rays aimed just below each spike's top: maxmip
    hits every one (its traversal skips only cells that cannot hold a root), the reference
    agrees, and a coarse search (N = 4) misses some."""
    a, u, v = one_texel_spikes()
    found = {}
    for method, steps in (("maxmip", 1), ("search", 4)):
        d = tx.Displacement(_tex(a), scale=0.1, method=method, steps=steps)
        shape = _shape(kind, d)
        p, nrm, t = _frame(shape, u, v)
        dirs = np.cos(np.radians(8)) * t - np.sin(np.radians(8)) * nrm
        orgs = p + 0.09 * nrm - 0.8 * dirs
        th, _ = trace_each(_tracer(shape, device), orgs, dirs)
        found[method] = ~np.isnan(th)
        if method == "maxmip":
            tr, _ = curved_reference(shape, d, orgs, dirs, samples=100000)
            assert not np.isnan(tr).any()
            np.testing.assert_allclose(th, tr, rtol=T_CURVED)
    assert found["maxmip"].all()
    assert not found["search"].all()


@pytest.mark.parametrize("kind", ["sphere", "cylinder"])
def test_maxmip_shadows_as_the_search(kind, device):
    """Any-hit rays (self-shadowing) from points just above the displaced surface (maxmip's
    hits, 2e-4 up the radius, so that the side the ray starts on is not rounding's) toward
    lights 3 to 60 degrees above the base surface's tangent plane, from points in the shell and from outside: occluded exactly where the fine search says
    so, except rays grazing a crest (<= 1%); rays leaving maxmip's hit points along the radius
    (u, v fixed) are never occluded by the surface they start on."""
    r = np.random.default_rng(4)
    tracers = {}
    for method in ("maxmip", "search"):
        d = tx.Displacement(_sines(), scale=SCALE, method=method, steps=1024, refine=12)
        shape = _shape(kind, d)
        tracers[method] = _tracer(shape, device)
    u, v = r.uniform(0, 1, 400), r.uniform(0.1, 0.9, 400)
    orgs, dirs = _grazing_rays(shape, 30, u, v)
    t, _ = trace_each(tracers["maxmip"], orgs, dirs)
    keep = ~np.isnan(t)
    assert keep.mean() > 0.9
    pts = orgs[keep] + t[keep, None] * dirs[keep]
    w = shape.world()
    nrm = pts - w[0]
    if kind == "cylinder":
        nrm -= (nrm @ w[3])[:, None] * w[3]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    side = np.cross(nrm, r.normal(size=(len(pts), 3)))
    side /= np.linalg.norm(side, axis=1)[:, None]
    elev = np.radians(r.uniform(3, 60, len(pts)))[:, None]
    light = np.cos(elev) * side + np.sin(elev) * nrm                 # 3 to 60 degrees above the base plane
    q, qn = shape.surface(r.uniform(0, 1, 400), r.uniform(0.1, 0.9, 400))
    shadows_agree(tracers, pts, nrm, q + r.uniform(0, SCALE, 400)[:, None] * qn, light)


@pytest.mark.parametrize("kind", ["sphere", "cylinder"])
@pytest.mark.parametrize("heights", ["zero", "one", "single"])
def test_maxmip_constant_maps_are_the_shape_at_their_height(kind, heights, device):
    """All-zero and all-one maps and a 1x1 texture (a pyramid of one level): the sphere or
    cylinder of radius r + H, hit where the analytic shape is, from outside (80 to 5 degrees
    above it) and from inside the shell, below the surface, outward."""
    a = {"zero": np.zeros((4, 4)), "one": np.ones((4, 4)), "single": np.full((1, 1), 0.7)}[heights]
    d = tx.Displacement(_tex(a), scale=0.1, offset=0.02, method="maxmip")
    level = 0.02 + 0.1 * float(a.flat[0])
    shape = _shape(kind, d)
    tracer = _tracer(shape, device)
    rng = np.random.default_rng(1)
    p, n, tang = _frame(shape, rng.uniform(0, 1, 200), rng.uniform(0.1, 0.9, 200))
    c, r, _, az = shape.world()[:4]
    for elev in (80, 30, 5, -60):
        e = np.radians(abs(elev))
        if elev > 0:                                   # from outside toward the surface's point over p
            dirs = np.cos(e) * tang - np.sin(e) * n
            orgs = p + level * n - 1.0 * dirs
        else:                                          # from inside the shell, outward
            dirs = np.cos(e) * tang + np.sin(e) * n
            orgs = p + 0.5 * level * n
        t, _ = trace_each(tracer, orgs, dirs)
        oc, dd = orgs - c, dirs
        if kind == "cylinder":
            oc = oc - (oc @ az)[:, None] * az
            dd = dirs - (dirs @ az)[:, None] * az
        A, B, C = (dd * dd).sum(1), (oc * dd).sum(1), (oc * oc).sum(1) - (r + level) ** 2
        roots = np.stack([(-B - np.sqrt(B * B - A * C)) / A, (-B + np.sqrt(B * B - A * C)) / A])
        te = np.where(roots[0] > 1e-6, roots[0], roots[1])   # the first root ahead: every ray meets the shape
        z = (orgs + te[:, None] * dirs - c) @ az
        sure = np.abs(np.abs(z) - 0.8) > 1e-4 if kind == "cylinder" else np.ones(len(te), bool)
        hit = (np.abs(z) < 0.8) if kind == "cylinder" else np.ones(len(te), bool)
        assert hit.mean() > 0.5, elev
        np.testing.assert_array_equal(np.isnan(t[sure]), ~hit[sure])
        np.testing.assert_allclose(t[hit & sure], te[hit & sure], rtol=1e-5, atol=1e-6)


def test_maxmip_aovs_and_shading_as_the_search(device):
    """A displaced sphere and cylinder rendered by maxmip and by a fine search (N = 512,
    M = 12): the same first hits, and the AOVs that report the displaced hit (depth,
    position, uv, shading normal) and the shaded colour agree on 99% of the pixels."""
    out = {}
    for method in ("maxmip", "search"):
        d = tx.Displacement(_sines(24, a=0.5, k=2.0), scale=0.15, method=method, steps=512, refine=12)
        s = tx.Scene(camera=tx.Camera(eye=(0, 0.5, 4), look_at=(0, 0, 0), fov_y=45),
                     lights=[tx.PointLight((2, 3, 3), (20, 20, 20))], ambient=(0.05, 0.05, 0.05))
        s.add(tx.Sphere(center=(-0.8, 0, 0), radius=0.6, axis_z=(0, 1, 0), material=tx.Material(displacement=d)))
        s.add(tx.Cylinder(radius=0.5, z_range=(-0.8, 0.8), origin=(0.8, 0, 0), axis_z=(0, 1, 0),
                          material=tx.Material(displacement=d)))
        out[method] = tx.render(s, 96, 72, 1, device=device, jitter=False,
                                aovs=("depth", "position", "uv", "shading_normal"))
    both = aovs_agree(out["maxmip"], out["search"], uv_wraps=True)          # u wraps at the seam
    assert both.mean() > 0.2                     # the two shapes cover a quarter of the image
