"""maxmip on displaced trapezoids, planar convex quads that are no parallelogram
(kernels/geometry/displace.h disp_maxmip_bisect with the trapezoid's (u, v, h) from
disp_inverse_bilinear), against float64 references (tests/disp_reference.py
trapezoid_reference: f = h - H sampled densely along the ray's part over the quad, the
first sign change bisected, (u, v) by an independent Newton inverse) and against a fine
search.

Three quads: a trapezoid with no two sides parallel, a tilted kite and a strongly
tapered trapezoid (top edge 1/15 of the bottom). Tolerances: the traversal brackets each
root exactly and polishes it in float32 with regula falsi on (u, v) from the inverse
bilinear: hit distances agree with the float64 root to a few 1e-6 relatively (T_TRAP,
relative; absolute below t = 0.1, for rays from inside the shell that meet the surface at
once). Hit and miss disagree only where a ray grazes a crest within the reference's sample
spacing, or runs exactly along an edge, where float32 rounding decides which side of it
the ray lies (<= 1% of the rays)."""
import numpy as np
import pytest
import texray as tx
from texray.renderer.trace import Tracer
from disp_reference import TRAPEZOID, aovs_agree, first_hits_agree, height_texture as _tex, inverse_bilinear, \
    one_texel_spikes, shadows_agree, sines as _sines, trace_each, trapezoid_reference

T_TRAP = 1e-4        # relative t error of maxmip against the float64 root (module docstring)
T_FINE = 1e-3        # relative t difference of maxmip and the search at N = 1024, M = 12
SCALE = 0.2


def _tilt(corners, angle=25.0):
    """The corners turned by angle degrees about the axis (1, 0, 1) through the origin."""
    a, k = np.radians(angle), np.array([1.0, 0.0, 1.0]) / np.sqrt(2)
    c = np.asarray(corners, np.float64)
    return c * np.cos(a) + np.cross(k, c) * np.sin(a) + np.outer(c @ k, k) * (1 - np.cos(a))


QUADS = {
    "trapezoid": np.asarray(TRAPEZOID, np.float64),
    "kite": _tilt(((0, 0, 1.2), (0.8, 0, 0), (0, 0, -0.6), (-0.8, 0, 0))),
    "tapered": _tilt(((-1.2, 0, 1), (1.2, 0, 1), (0.08, 0, -1), (-0.08, 0, -1)), -15.0),
}


def _quad(kind, d):
    return tx.Quad(*QUADS[kind], material=tx.Material(displacement=d))


def _tracer(*objects, device="pocl"):
    s = tx.Scene(camera=tx.Camera(eye=(0, 2, 3), look_at=(0, 0, 0)), ambient=(0.1, 0.1, 0.1))
    for o in objects:
        s.add(o)
    return Tracer(s, device)


def _frame(quad, u, v, seed=0):
    """Points of the patch at (u, v), its plane's unit normal and random unit tangents in
    its plane ((u, v) may lie outside [0, 1]^2, where the patch's own normal can flip)."""
    rng = np.random.default_rng(seed)
    p = quad.surface(u, v)[0]
    n = np.broadcast_to(quad.surface(0.5, 0.5)[1], p.shape)
    a = np.cross(n, [0.3, 0.5, 0.7])
    a /= np.linalg.norm(a, axis=1)[:, None]
    b = np.cross(n, a)
    ang = rng.uniform(0, 2 * np.pi, len(u))[:, None]
    return p, n, np.cos(ang) * a + np.sin(ang) * b


def _grazing_rays(quad, elev_deg, u, v, back=1.5, seed=0):
    """Rays at elev_deg (a number or one per ray) above the quad's plane toward mid-height
    points over (u, v)."""
    p, n, t = _frame(quad, u, v, seed)
    e = np.radians(np.broadcast_to(elev_deg, len(u)))[:, None]
    d = np.cos(e) * t - np.sin(e) * n
    target = p + 0.5 * SCALE * n
    return target - back * d, d


def _compare(tracer, quad, d, orgs, dirs, agree_min=0.99, good_min=0.99, samples=4000):
    t, uv = trace_each(tracer, orgs, dirs)
    tr, uvr = trapezoid_reference(d, quad.world().corners, orgs, dirs, samples=samples)
    agree = np.isnan(t) == np.isnan(tr)
    assert agree.mean() >= agree_min, (agree.mean(), np.flatnonzero(~agree)[:5], t[~agree][:5], tr[~agree][:5])
    both = ~np.isnan(t) & ~np.isnan(tr)
    rel = np.abs(t[both] - tr[both]) / np.maximum(tr[both], 0.1)    # relative, absolute below t = 0.1
    assert (rel <= T_TRAP).mean() >= good_min, ((rel <= T_TRAP).mean(), np.sort(rel)[-5:])
    if both.any():
        du = np.abs(uv[both] - uvr[both]).max(1)
        assert np.percentile(du, 99) <= 1e-3, np.sort(du)[-5:]
    return t, tr


@pytest.mark.parametrize("kind", sorted(QUADS))
@pytest.mark.parametrize("elev", [70, 40, 15, 4])
def test_maxmip_matches_float64_root_finder(device, kind, elev):
    d = tx.Displacement(_sines(), scale=SCALE, method="maxmip")
    quad = _quad(kind, d)
    rng = np.random.default_rng(elev)
    u, v = rng.uniform(0.05, 0.95, 300), rng.uniform(0.05, 0.95, 300)
    orgs, dirs = _grazing_rays(quad, elev, u, v, seed=elev)
    t, tr = _compare(_tracer(quad, device=device), quad, d, orgs, dirs)
    assert (~np.isnan(tr)).mean() > 0.5


@pytest.mark.parametrize("kind", sorted(QUADS))
def test_u_v_monotone_along_rays_and_near_normal_rays(device, kind):
    """The traversal's premise (displace.h: a trapezoid's segment is one piece): along rays at
    0 to 90 degrees from the normal, the float64 (u, v) of the ray's points over the quad
    are monotone (to the Newton inverse's rounding), also along iso-u and iso-v lines; and
    the device's hits of rays within 2 degrees of the normal (u, v nearly constant: their
    changes are at rounding level) as the reference's."""
    quad = _quad(kind, tx.Displacement(_sines(), scale=SCALE, method="maxmip"))
    p = quad.world().corners
    rng = np.random.default_rng(1)
    n = 200
    u, v = rng.uniform(0, 1, n), rng.uniform(0, 1, n)
    base, nrm, tang = _frame(quad, u, v, seed=2)
    ang = np.radians(np.concatenate([rng.uniform(0, 90, n - 40), np.zeros(10), np.full(10, 90.0),
                                     rng.uniform(0, 1e-3, 20)]))[:, None]
    dirs = np.cos(ang) * -nrm + np.sin(ang) * tang
    iso = p[1] - p[0] + v[:20, None] * (p[2] - p[3] - p[1] + p[0])       # along iso-v lines
    dirs[:20] = iso / np.linalg.norm(iso, axis=1)[:, None]
    s = np.linspace(-4, 4, 4001)
    q = base[:, None] + s[None, :, None] * dirs[:, None]
    uv = inverse_bilinear(q, p)
    for i in range(n):
        ok = np.all((uv[i] >= 0) & (uv[i] <= 1), axis=1)
        for k in range(2):
            w = np.diff(uv[i, ok, k])
            assert (w >= -1e-12).all() or (w <= 1e-12).all(), (kind, i, k, w.min(), w.max())
    d = tx.Displacement(_sines(), scale=SCALE, method="maxmip")
    quad = _quad(kind, d)
    u, v = rng.uniform(0.02, 0.98, (2, 300))
    orgs, dirs = _grazing_rays(quad, 90 - 2 * rng.random(300), u, v, seed=3)
    _compare(_tracer(quad, device=device), quad, d, orgs, dirs)


@pytest.mark.parametrize("kind", sorted(QUADS))
def test_maxmip_from_inside_the_shell(device, kind):
    """Origins inside the shell (above and below the surface) with random directions."""
    d = tx.Displacement(_sines(), scale=SCALE, method="maxmip")
    quad = _quad(kind, d)
    rng = np.random.default_rng(7)
    n = 400
    p, nrm, _ = _frame(quad, rng.uniform(0, 1, n), rng.uniform(0, 1, n))
    orgs = p + rng.uniform(0.0, SCALE, n)[:, None] * nrm
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    _compare(_tracer(quad, device=device), quad, d, orgs, dirs, samples=8000)


def _edge_rays(quad, c, along_u, rng, n=20):
    """Rays at 4 to 60 degrees above the plane whose foot runs along the iso line u = c
    (along_u False) or v = c (True), either way, through random heights in the shell."""
    nrm = quad.surface(0.5, 0.5)[1]
    a = rng.uniform(0.1, 0.9, n)
    u0, v0 = (np.zeros(n), np.full(n, c)) if along_u else (np.full(n, c), np.zeros(n))
    u1, v1 = (np.ones(n), np.full(n, c)) if along_u else (np.full(n, c), np.ones(n))
    s0, s1 = quad.surface(u0, v0)[0], quad.surface(u1, v1)[0]
    line = (s1 - s0) / np.linalg.norm(s1 - s0, axis=1)[:, None]
    line *= np.where(rng.random(n) < 0.5, 1, -1)[:, None]
    e = np.radians(rng.uniform(4, 60, n))[:, None]
    dd = np.cos(e) * line - np.sin(e) * nrm
    target = s0 + a[:, None] * (s1 - s0) + rng.uniform(0, SCALE, n)[:, None] * nrm
    return target - dd, dd


@pytest.mark.parametrize("kind", sorted(QUADS))
def test_maxmip_along_edges_and_at_corners(device, kind):
    """Rays whose foot runs along an edge's iso line 1e-3 inside it (u or v constant on the
    whole ray: the traversal's degenerate one-piece case) and rays toward the four corners
    from above at 60 to 4 degrees, from every side, as the reference; rays exactly along an
    edge, where float32 rounding puts the foot on either side of it (the clip to the edges'
    half-spaces, as for the search): a hit where the reference has one, at its t."""
    d = tx.Displacement(_sines(), scale=SCALE, method="maxmip")
    quad = _quad(kind, d)
    tracer = _tracer(quad, device=device)
    p = quad.world().corners
    nrm = quad.surface(0.5, 0.5)[1]
    rng = np.random.default_rng(9)
    rays = [_edge_rays(quad, c, along_u, rng) for c in (1e-3, 1 - 1e-3) for along_u in (True, False)]
    a = np.cross(nrm, [0.3, 0.5, 0.7])
    a /= np.linalg.norm(a)
    b = np.cross(nrm, a)
    for corner in p:
        ang = rng.uniform(0, 2 * np.pi, 40)[:, None]
        e = np.radians(rng.uniform(4, 60, 40))[:, None]
        dd = np.cos(e) * (np.cos(ang) * a + np.sin(ang) * b) - np.sin(e) * nrm
        rays.append((corner + rng.uniform(0, SCALE, 40)[:, None] * nrm - 1.0 * dd, dd))
    orgs, dirs = (np.concatenate(x) for x in zip(*rays))
    t, _ = _compare(tracer, quad, d, orgs, dirs, samples=8000)
    assert (~np.isnan(t[:80])).mean() > 0.5
    rays = [_edge_rays(quad, c, along_u, rng) for c in (0.0, 1.0) for along_u in (True, False)]
    orgs, dirs = (np.concatenate(x) for x in zip(*rays))
    t, uv = trace_each(tracer, orgs, dirs)
    tr, _ = trapezoid_reference(d, p, orgs, dirs, samples=8000)
    hit = ~np.isnan(t)
    assert hit.mean() > 0.3 and not np.isnan(uv).any()
    assert not np.isnan(tr[hit]).any()
    np.testing.assert_allclose(t[hit], tr[hit], rtol=T_TRAP)


@pytest.mark.parametrize("kind", sorted(QUADS))
def test_maxmip_never_misses_one_texel_spikes(device, kind):
    """One-texel spikes on a flat map; rays at 8 degrees aimed just below each spike's top:
    maxmip hits every one (its traversal skips only intervals that cannot hold a root),
    where the reference does, and a coarse search (N = 4) misses some."""
    a, u, v = one_texel_spikes()
    found = {}
    for method, steps in (("maxmip", 1), ("search", 4)):
        d = tx.Displacement(_tex(a), scale=0.1, method=method, steps=steps)
        quad = _quad(kind, d)
        p, nrm, t = _frame(quad, u, v, seed=4)
        dirs = np.cos(np.radians(8)) * t - np.sin(np.radians(8)) * nrm
        orgs = p + 0.09 * nrm - 0.8 * dirs
        th, _ = trace_each(_tracer(quad, device=device), orgs, dirs)
        found[method] = ~np.isnan(th)
        if method == "maxmip":
            tr, _ = trapezoid_reference(d, quad.world().corners, orgs, dirs, samples=40000)
            assert not np.isnan(tr).any()
            np.testing.assert_allclose(th, tr, rtol=T_TRAP)
    assert found["maxmip"].all()
    assert not found["search"].all()


@pytest.mark.parametrize("kind", sorted(QUADS))
def test_maxmip_agrees_with_a_fine_search(device, kind):
    """maxmip against the search at N = 1024, M = 12 on the same rays (70 to 4 degrees)."""
    hits = {}
    for method in ("maxmip", "search"):
        d = tx.Displacement(_sines(), scale=SCALE, method=method, steps=1024, refine=12)
        quad = _quad(kind, d)
        tracer = _tracer(quad, device=device)
        ts = []
        for elev in (70, 30, 10, 4):
            r = np.random.default_rng(elev)
            orgs, dirs = _grazing_rays(quad, elev, r.uniform(0.05, 0.95, 300), r.uniform(0.05, 0.95, 300), seed=elev)
            ts.append(trace_each(tracer, orgs, dirs)[0])
        hits[method] = np.concatenate(ts)
    first_hits_agree(hits["maxmip"], hits["search"], T_FINE)


@pytest.mark.parametrize("kind", sorted(QUADS))
def test_maxmip_shadows_as_the_search(device, kind):
    """Any-hit rays (self-shadowing) from points just above maxmip's hits (2e-4 along the
    normal, so that the side a ray starts on is not rounding's) toward lights 3 to 60 degrees
    above the plane, from points in the shell and from outside: occluded exactly where the
    fine search says so but for rays grazing a crest (<= 1%); rays leaving maxmip's hit
    points along the normal are never occluded by the surface they start on."""
    r = np.random.default_rng(4)
    tracers = {}
    for method in ("maxmip", "search"):
        d = tx.Displacement(_sines(), scale=SCALE, method=method, steps=1024, refine=12)
        quad = _quad(kind, d)
        tracers[method] = _tracer(quad, device=device)
    u, v = r.uniform(0.05, 0.95, 400), r.uniform(0.05, 0.95, 400)
    orgs, dirs = _grazing_rays(quad, 30, u, v)
    t, _ = trace_each(tracers["maxmip"], orgs, dirs)
    keep = ~np.isnan(t)
    assert keep.mean() > 0.9
    pts = orgs[keep] + t[keep, None] * dirs[keep]
    nrm = np.broadcast_to(quad.surface(0.5, 0.5)[1], pts.shape)
    side = np.cross(nrm, r.normal(size=(len(pts), 3)))
    side /= np.linalg.norm(side, axis=1)[:, None]
    elev = np.radians(r.uniform(3, 60, len(pts)))[:, None]
    light = np.cos(elev) * side + np.sin(elev) * nrm
    q, qn, _ = _frame(quad, r.uniform(0, 1, 400), r.uniform(0, 1, 400))
    shadows_agree(tracers, pts, nrm, q + r.uniform(0, SCALE, 400)[:, None] * qn, light)


@pytest.mark.parametrize("heights", ["zero", "one", "single"])
def test_maxmip_constant_maps_are_planes_at_their_height(device, heights):
    """All-zero and all-one maps and a 1x1 texture (a pyramid of one level) on the tapered
    trapezoid: the plane at H, hit where the plane's point lies over the quad, from above
    (80 to 5 degrees) and from inside the shell below the surface, upward."""
    a = {"zero": np.zeros((4, 4)), "one": np.ones((4, 4)), "single": np.full((1, 1), 0.7)}[heights]
    d = tx.Displacement(_tex(a), scale=0.3, offset=0.05, method="maxmip")
    level = 0.05 + 0.3 * float(a.flat[0])
    quad = _quad("tapered", d)
    tracer = _tracer(quad, device=device)
    corners = quad.world().corners
    rng = np.random.default_rng(1)
    p, n, tang = _frame(quad, rng.uniform(-0.1, 1.1, 300), rng.uniform(-0.1, 1.1, 300))
    for elev in (80, 30, 5, -60):
        e = np.radians(abs(elev))
        if elev > 0:
            dirs = np.cos(e) * tang - np.sin(e) * n
            orgs = p + level * n - 1.0 * dirs
        else:
            dirs = np.cos(e) * tang + np.sin(e) * n
            orgs = p + 0.5 * level * n
        t, _ = trace_each(tracer, orgs, dirs)
        te = ((p + level * n - orgs) * n).sum(1) / (dirs * n).sum(1)
        uv = inverse_bilinear(orgs + te[:, None] * dirs - level * n, corners)
        margin = np.minimum(uv, 1 - uv).min(1)
        hit, sure = margin > 0, np.abs(margin) > 1e-4
        assert 0.3 < hit.mean() < 0.95, elev
        np.testing.assert_array_equal(np.isnan(t[sure]), ~hit[sure])
        np.testing.assert_allclose(t[hit & sure], te[hit & sure], rtol=1e-5, atol=1e-6)


def test_maxmip_degenerate_rays_miss(device):
    """NaN and infinite origins and directions, and the zero direction (from outside, and from
    inside the shell above and below the surface, where the clip leaves it the whole (0, inf)
    range), toward the displaced trapezoid: misses for closest-hit and any-hit rays."""
    d = tx.Displacement(_sines(), scale=SCALE, method="maxmip")
    quad = _quad("trapezoid", d)
    tracer = _tracer(quad, device=device)
    good_o, good_d = np.array([0.1, 1.0, 0.2]), np.array([0.05, -1.0, 0.1])
    nan, inf = np.nan, np.inf
    orgs = np.array([good_o, [nan, 1, 0], good_o, good_o, [inf, 1, 0], good_o, good_o])
    dirs = np.array([good_d, good_d, [nan, -1, 0], [0, 0, 0], good_d, [0, -inf, 0], [nan, nan, nan]])
    rng = np.random.default_rng(2)
    p, n, _ = _frame(quad, rng.uniform(0.1, 0.9, 16), rng.uniform(0.1, 0.9, 16))
    inside = p + np.repeat([0.02, 0.18], 8)[:, None] * n             # below and above the surface
    orgs, dirs = np.concatenate([orgs, inside]), np.concatenate([dirs, np.zeros_like(inside)])
    t, uv = trace_each(tracer, orgs, dirs)
    assert not np.isnan(t[0])                   # the reference ray hits
    assert np.isnan(t[1:]).all(), t
    occ = tracer.occluded(orgs[1:], dirs[1:])[0]
    assert not occ.any(), occ


def test_maxmip_aovs_silhouettes_and_shading_as_the_search(device):
    """The three quads rendered by maxmip and by a fine search (N = 512, M = 12), the tilted
    ones seen at grazing angles: the same first hits, silhouettes included (pixels where the
    displaced surface stands out of the plain quad's outline), and the AOVs that report the
    displaced hit (depth, position, uv, shading normal) and the shaded colour agree on 99%
    of the pixels."""
    out = {}
    for method in ("maxmip", "search", None):
        s = tx.Scene(camera=tx.Camera(eye=(0.1, 2.4, 2.0), look_at=(0, 0, -0.6), fov_y=48),
                     lights=[tx.PointLight((2, 3, 3), (20, 20, 20))], ambient=(0.05, 0.05, 0.05))
        for k, (kind, shift) in enumerate((("trapezoid", (-1.3, 0, -0.8)), ("kite", (1.3, 0, 0)),
                                          ("tapered", (0, 0, -2.0)))):
            d = tx.Displacement(_sines(24, a=0.5, k=2.0), scale=0.15, method=method, steps=512, refine=12) \
                if method else None
            s.add(tx.Quad(*(QUADS[kind] + shift), material=tx.Material(displacement=d)))
        out[method] = tx.render(s, 96, 72, 1, device=device, jitter=False,
                                aovs=("depth", "position", "uv", "shading_normal"))
    both = aovs_agree(out["maxmip"], out["search"])
    assert both.mean() > 0.2
    da, db, dp = (out[m].aov["depth"][..., 0] for m in ("maxmip", "search", None))
    sil = ~np.isnan(da) & np.isnan(dp)            # over the plain quads' outline
    assert sil.sum() >= 10 and (~np.isnan(db[sil])).mean() >= 0.9, sil.sum()
