"""Kernels never trust their input (issue 12, the kernel half): a NaN or degenerate ray is a
miss, never an out-of-range index, a crash or a hang.

Rays the traversal rejects before it reads a node (kernels/core/common.h ray_valid): a NaN or
infinite component of the origin or the direction, a zero direction or one whose every
component is below 2^-100 (zero and denormal-length directions), a component above 2^126,
and a NaN or empty interval (tmin, tmax). They are fired at every primitive kind through
the BVH (texray.trace.Tracer's kernels, closest and any hit) and must miss; valid rays at
the same primitives must still hit (the control). Renders whose compiled arrays carry what
the host would not let through -- a light at inf or NaN, a NaN or infinite intensity, vertex
normals of 1e39 (inf in float32) -- must finish with finite pixels; the hang of the fuzz
campaign (a light at 1e39 over nine coincident quads) runs in a subprocess with a timeout, so
a regression fails instead of hanging the suite.
"""
import subprocess
import sys
import textwrap

import numpy as np
import pyopencl as cl
import pytest

import texray as tx
from texray.device import layout
from texray.compile import compile_scene
from texray.renderer.trace import Tracer

from scenes_for_tests import box

NAN, INF = np.float32(np.nan), np.float32(np.inf)
CORNERS = ((-0.6, 0, 0.6), (0.6, 0, 0.6), (0.6, 0, -0.6), (-0.6, 0, -0.6))   # a quad facing +y


def _height_tex(n=16):
    c = (np.arange(n) + 0.5) / n * 2 * np.pi
    a = 0.5 + 0.5 * np.sin(3 * c)[None, :] * np.sin(3 * c)[:, None]
    return tx.Texture.from_array(a.astype(np.float32).reshape(n, n, 1))


def _shifted(corners, x):
    return tuple((p[0] + x, p[1], p[2]) for p in corners)


def _all_kinds_scene():
    """One primitive of every kind along x, each centred at (x_k, 0, 0); returns (scene, [(kind name,
    layout kind, centre)])."""
    s = tx.Scene(camera=tx.Camera(eye=(0, 3, 6), look_at=(0, 0, 0)),
                 lights=[tx.PointLight(position=(0, 5, 2), intensity=(20, 20, 20))])
    h = _height_tex()

    def disp(method, **kw):
        return tx.Material(displacement=tx.Displacement(h, scale=0.2, method=method, steps=16, **kw))

    kinds = []

    def at(name, kind, x):
        kinds.append((name, kind, np.array([x, 0.0, 0.0])))

    p, f = box((-8.0, 0, 0), (0.5, 0.5, 0.5))
    s.add(tx.Mesh(p, f, name="mesh")); at("triangle", layout.PRIM_TRIANGLE, -8.0)
    s.add(tx.Sphere(center=(-6, 0, 0), radius=0.6)); at("sphere", layout.PRIM_SPHERE, -6.0)
    s.add(tx.Cylinder(radius=0.6, z_range=(-0.6, 0.6), origin=(-4, 0, 0))); at("cylinder", layout.PRIM_CYLINDER, -4.0)
    s.add(tx.Quad(*_shifted(CORNERS, -2))); at("quad", layout.PRIM_QUAD, -2.0)
    s.add(tx.Quad(*_shifted(CORNERS, 0), material=disp("search"))); at("displaced quad search", layout.PRIM_DISPLACED, 0.0)
    s.add(tx.Quad(*_shifted(CORNERS, 2), material=disp("maxmip"))); at("displaced quad maxmip", layout.PRIM_DISPLACED, 2.0)
    s.add(tx.Sphere(center=(4, 0, 0), radius=0.6, material=disp("search")))
    at("displaced sphere", layout.PRIM_DISPLACED, 4.0)
    s.add(tx.Cylinder(radius=0.6, z_range=(-0.6, 0.6), origin=(6, 0, 0), material=disp("search", adaptive=True)))
    at("displaced cylinder", layout.PRIM_DISPLACED, 6.0)
    s.add(tx.Sphere(center=(8, 0, 0), radius=0.6, material=disp("maxmip")))
    at("displaced sphere maxmip", layout.PRIM_DISPLACED, 8.0)
    s.add(tx.Cylinder(radius=0.6, z_range=(-0.6, 0.6), origin=(10, 0, 0), material=disp("maxmip")))
    at("displaced cylinder maxmip", layout.PRIM_DISPLACED, 10.0)
    for x, method in ((12.0, "search"), (14.0, "maxmip")):        # a mesh's prism shells (DISP_TRIANGLE)
        s.add(tx.Mesh(np.array(_shifted(CORNERS, x)), np.array([[0, 1, 2], [0, 2, 3]]),
                      uvs=np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]]), material=disp(method), name=f"mesh {method}"))
        at(f"displaced mesh {method}", layout.PRIM_DISPLACED, x)
    return s, kinds


@pytest.fixture(scope="module")
def all_kinds():
    return _all_kinds_scene()


@pytest.fixture
def tracer(device, all_kinds):
    return Tracer(all_kinds[0], device=device)


def _trace(tracer, org, dirs, tmin, tmax):
    """Closest hit (prim, -1 for a miss; t) and any hit (bool) of rays with per-ray origins,
    directions and intervals."""
    n = len(dirs)
    r = np.zeros(n, layout.RAY)
    r["org"], r["dir"], r["tmin"], r["tmax"] = org, dirs, tmin, tmax
    ctx, q, mf = tracer.rt.context, tracer.rt.queue, cl.mem_flags
    rays = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=r)
    hits = np.zeros(n, layout.HIT)
    hbuf = cl.Buffer(ctx, mf.WRITE_ONLY, hits.nbytes)
    occ = np.zeros(n, np.uint8)
    obuf = cl.Buffer(ctx, mf.WRITE_ONLY, max(n, 16))
    tracer._k_closest(q, (n,), None, rays, hbuf, np.uint32(n), *tracer.up.geom)
    tracer._k_any(q, (n,), None, rays, obuf, np.uint32(n), *tracer.up.geom)
    cl.enqueue_copy(q, hits, hbuf)
    cl.enqueue_copy(q, occ, obuf)
    q.finish()
    prim = hits["prim"].astype(np.int64)
    prim[hits["prim"] == 0xFFFFFFFF] = -1
    return prim, hits["t"], occ.astype(bool)


def _aimed(centre):
    """A ray from above and aside of the primitive at `centre`, reaching 0.1 below its centre
    at t = 1 (every primitive's surface lies before that)."""
    org = centre + np.array([0.3, 3.0, 0.2])
    return org, centre - np.array([0.0, 0.1, 0.0]) - org


def _bad_rays(centre):
    """(name, org, dir, tmin, tmax) of every degenerate variant of the ray aimed at `centre`."""
    org, d = _aimed(centre)
    out = []
    for k in range(3):
        for v, vn in ((NAN, "nan"), (INF, "+inf"), (-INF, "-inf")):
            dd = d.astype(np.float32).copy(); dd[k] = v
            out.append((f"dir[{k}]={vn}", org, dd, 0.0, np.inf))
            oo = org.astype(np.float32).copy(); oo[k] = v
            out.append((f"org[{k}]={vn}", oo, d, 0.0, np.inf))
        huge = np.zeros(3); huge[k] = 1e38                      # a component above 2^126
        out.append((f"dir[{k}]=1e38", org, d + huge, 0.0, np.inf))
    out += [("dir=nan^3", org, np.full(3, NAN), 0.0, np.inf),
            ("dir=inf^3", org, np.full(3, INF), 0.0, np.inf),
            ("dir=-inf^3", org, np.full(3, -INF), 0.0, np.inf),
            ("org=nan^3", np.full(3, NAN), d, 0.0, np.inf),
            ("dir=0", org, np.zeros(3), 0.0, np.inf),
            ("dir=-0", org, -np.zeros(3), 0.0, np.inf),
            ("dir=1e-40 (denormal)", org, d / np.linalg.norm(d) * 1e-40, 0.0, np.inf),
            ("dir=1e-45 (least denormal)", org, np.array([0, -1.4e-45, 0]), 0.0, np.inf),
            ("dir=1e-35 (below 2^-100)", org, d / np.linalg.norm(d) * 1e-35, 0.0, np.inf),
            ("tmin=nan", org, d, NAN, np.inf),
            ("tmax=nan", org, d, 0.0, NAN),
            ("tmin=tmax=nan", org, d, NAN, NAN),
            ("tmin>tmax", org, d, 2.0, 0.5),
            ("tmin=tmax", org, d, 0.9, 0.9),
            ("tmin=+inf", org, d, np.inf, np.inf),
            ("tmax=-inf", org, d, -np.inf, -np.inf)]
    for k in range(3):                                          # from +-1e38, pointing away
        for sgn in (1.0, -1.0):
            oo = np.zeros(3); oo[k] = sgn * 1e38
            dd = np.zeros(3); dd[k] = sgn
            out.append((f"org[{k}]={sgn:+.0e}, away", oo, dd, 0.0, np.inf))
    return out


def test_degenerate_rays_miss_every_primitive_kind(tracer, all_kinds):
    _, kinds = all_kinds
    names, orgs, dirs, tmins, tmaxs, targets = [], [], [], [], [], []
    for kname, _, centre in kinds:
        for name, o, d, t0, t1 in _bad_rays(centre):
            names.append(f"{kname}: {name}")
            orgs.append(o); dirs.append(d); tmins.append(t0); tmaxs.append(t1)
    with np.errstate(invalid="ignore", over="ignore"):
        prim, _, occ = _trace(tracer, np.array(orgs, np.float32), np.array(dirs, np.float32),
                              np.array(tmins, np.float32), np.array(tmaxs, np.float32))
    bad = [n for n, p in zip(names, prim) if p != -1]
    assert not bad, f"degenerate rays reported a hit: {bad}"
    bad = [n for n, o in zip(names, occ) if o]
    assert not bad, f"degenerate rays reported occlusion: {bad}"


def test_valid_rays_still_hit_every_kind(tracer, all_kinds):
    """The control: the same rays, not degenerate, hit the primitive they aim at (closest,
    and any hit with t in (0, 1))."""
    _, kinds = all_kinds
    org, d = zip(*(_aimed(c) for _, _, c in kinds))
    prim, t, occ = _trace(tracer, np.array(org, np.float32), np.array(d, np.float32), 0.0, np.inf)
    kind = np.where(prim >= 0, prim >> layout.HIT_KIND_SHIFT, -1)
    assert kind.tolist() == [k for _, k, _ in kinds], [n for n, *_ in kinds]
    assert np.all((t > 0.5) & (t < 1.0)), t
    _, _, occ = _trace(tracer, np.array(org, np.float32), np.array(d, np.float32), 0.0, 1.0)
    assert occ.all()
    # Short and long directions are valid rays too: the same hits. (Not near the 2^-100 and
    # 2^126 thresholds: the analytic shapes square |d|, which under- or overflows there, and
    # the triangle test's conservative t bound, whose terms mix sheared x, y with z in units
    # of t, rejects every hit once |d| is below about 2^-20 of the distance.)
    for scale in (2.0 ** -8, 2.0 ** 40):
        ds = (np.array(d) / np.linalg.norm(d, axis=1, keepdims=True) * scale).astype(np.float32)
        prim_s, t_s, _ = _trace(tracer, np.array(org, np.float32), ds, 0.0, np.inf)
        assert np.array_equal(prim_s >> layout.HIT_KIND_SHIFT, kind), scale


def test_far_origins_aimed_at_the_scene_do_not_crash(tracer, all_kinds):
    """Rays from +-1e38 aimed exactly at each primitive: valid rays whose arithmetic overflows
    inside the intersection routines. Whatever they report, it is a miss or a real primitive at a
    finite, positive t (no crash, no garbage index)."""
    _, kinds = all_kinds
    orgs, dirs = [], []
    for _, _, c in kinds:
        for k in range(3):
            for sgn in (1.0, -1.0):
                o = c.copy(); o[k] = sgn * 1e38
                orgs.append(o); dirs.append(np.sign(c - o) * (np.abs(c - o) > 1e30))
    prim, t, _ = _trace(tracer, np.array(orgs, np.float32), np.array(dirs, np.float32), 0.0, np.inf)
    cs = tracer.compiled
    counts = {layout.PRIM_TRIANGLE: len(cs.tri_verts), layout.PRIM_SPHERE: len(cs.spheres),
              layout.PRIM_CYLINDER: len(cs.cylinders), layout.PRIM_QUAD: len(cs.quad_verts),
              layout.PRIM_DISPLACED: len(cs.displaced)}
    for p, tt in zip(prim, t):
        if p >= 0:
            kind, idx = p >> layout.HIT_KIND_SHIFT, p & layout.HIT_INDEX_MASK
            assert kind in counts and idx < counts[kind], p
            assert np.isfinite(tt) and tt > 0, tt


def _light_scene():
    s = tx.Scene(camera=tx.Camera(eye=(0, 2.5, 3), look_at=(0, 0, 0)),
                 lights=[tx.PointLight(position=(1, 4, 1), intensity=(15, 15, 15))],
                 ambient=(0.1, 0.1, 0.1), background=(0.2, 0.3, 0.4))
    s.add(tx.Quad((-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)))
    s.add(tx.Sphere(center=(0, 0.5, 0), radius=0.5, material=tx.Material(diffuse=(0.8, 0.3, 0.2), specular=0.5)))
    return s


@pytest.mark.parametrize("pipeline", ["fused", "stages"])
def test_non_finite_lights_add_nothing(device, pipeline):
    """A light whose position or intensity is not finite (compiled arrays, past the host's
    checks) adds nothing: the image is the one without it, finite."""
    s = _light_scene()
    ref = tx.render(s, 24, 16, 1, device=device, pipeline=pipeline).rgb
    assert np.isfinite(ref).all()
    s.lights.append(tx.PointLight(position=(-1, 3, 0), intensity=(5, 5, 5)))
    for field, value in (("position", (INF, INF, INF)), ("position", (NAN, 0, 0)), ("position", (0, -INF, 0)),
                         ("position", (3e38, 3e38, 3e38)), ("intensity", (INF, 1, 1)),
                         ("intensity", (NAN, NAN, NAN))):
        cs = compile_scene(s)
        cs.lights[1][field] = np.asarray(value, np.float32)
        img = tx.render(s, 24, 16, 1, device=device, compiled=cs, pipeline=pipeline).rgb
        assert np.isfinite(img).all(), (field, value)
        np.testing.assert_allclose(img, ref, rtol=1e-6, atol=1e-7, err_msg=f"{field}={value}")


def test_infinite_vertex_normals_shade_flat(device):
    """Vertex normals of 1e39 (inf in float32; compiled arrays, past the host's checks): the
    triangles are shaded flat, with finite pixels."""
    p = np.array([[-2, 0, 2], [2, 0, 2], [2, 0, -2], [-2, 0, -2]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    s = tx.Scene(camera=tx.Camera(eye=(0, 2.5, 3), look_at=(0, 0, 0)),
                 lights=[tx.PointLight(position=(1, 4, 1), intensity=(15, 15, 15))], ambient=(0.1, 0.1, 0.1))
    s.add(tx.Mesh(p, f, normals=np.tile([0.0, 1.0, 0.0], (4, 1))))
    ref = tx.render(s, 24, 16, 1, device=device).rgb
    for bad in (INF, NAN):
        cs = compile_scene(s)
        normals = cs.normals.copy()
        normals[3:6] = bad                     # one vertex of both triangles
        cs.normals = normals
        img = tx.render(s, 24, 16, 1, device=device, compiled=cs).rgb
        assert np.isfinite(img).all(), bad
        np.testing.assert_allclose(img, ref, rtol=1e-5, atol=1e-6)   # flat = the normals' (0, 1, 0)


HANG = textwrap.dedent("""
    import numpy as np, texray as tx
    from texray.compile import compile_scene
    s = tx.Scene(camera=tx.Camera(eye=(0, 2, 3), look_at=(0, 0, 0)),
                 lights=[tx.PointLight(position=(0, 5, 0), intensity=(10, 10, 10))], ambient=(0.1, 0.1, 0.1))
    for i in range(9):
        s.add(tx.Quad((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1), name=f"q{i}"))
    for pipeline in ("fused", "stages"):
        cs = compile_scene(s)
        with np.errstate(over="ignore"):
            cs.lights["position"][0] = np.float32(1e39)  # inf: the host may reject 1e39 itself
        img = tx.render(s, 24, 16, 1, device=DEVICE, compiled=cs, pipeline=pipeline)
        assert np.isfinite(img.rgb).all(), pipeline
    print("ok")
""")


def test_light_at_1e39_over_coincident_quads_finishes(device):
    """The fuzz campaign's hang: a light at 1e39 (inf in float32) over nine coincident quads made
    every shadow ray's direction infinite; the any-hit traversal then took the root node's unused
    lane for entered and pushed the root again, forever. Run in a subprocess: a regression fails
    (timeout or crash) instead of hanging or killing the test session."""
    r = subprocess.run([sys.executable, "-c", HANG.replace("DEVICE", str(device))], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and "ok" in r.stdout, (r.returncode, r.stdout[-2000:], r.stderr[-2000:])


@pytest.mark.parametrize("spp", [1, 4])
def test_radiance_beyond_the_float_range_is_clamped_not_inf(device, spp):
    """Every input finite in float32 (the host's rule), yet intensity / d^2 of a light of 3e38
    half a unit from the surface, and an ambient term of 3e38, exceed FLT_MAX: each sample is
    clamped to TX_MAX_RADIANCE = 2e31 (shade.cl), so 2^24 samples still sum to a finite value;
    both pipelines agree. (Ordinary scenes are far below the clamp: their images are unchanged.)"""
    scene = tx.Scene(camera=tx.Camera(eye=(0, 0, 4)), lights=[tx.PointLight((0, 0, 1.5), 3e38)], ambient=3e38)
    scene.add(tx.Sphere(radius=1, material=tx.Material(diffuse=1, specular=1)))
    fused = tx.render(scene, 16, 12, spp=spp, device=device).rgb
    staged = tx.render(scene, 16, 12, spp=spp, device=device, pipeline="stages").rgb
    assert np.all(np.isfinite(fused)) and np.array_equal(fused, staged)
    lit = fused[6, 8]
    assert np.all(lit == np.float32(2e31)), lit


def test_negative_texels_times_a_huge_tint_stay_finite(device):
    """A linear texture may hold negative texels; times a tint of 3e38 the sample is -inf in
    float32 before the clamp (fuzz seed 7 case 3980): clamped to -TX_MAX_RADIANCE instead."""
    tex = tx.Texture.from_array(np.full((2, 2, 3), -1.0, np.float32))
    scene = tx.Scene(camera=tx.Camera(eye=(0, 0, 4)), ambient=1.0)
    scene.add(tx.Sphere(radius=1, material=tx.Material(diffuse=tex, tint=3e38)))
    rgb = tx.render(scene, 16, 12, device=device).rgb
    assert np.all(np.isfinite(rgb)) and rgb[6, 8, 0] == np.float32(-2e31)


def test_projection_far_from_its_object_gives_finite_tangents(device):
    """A spherical projection whose origin lies 1e17 from the object (the exact scene of fuzz seed
    2027 case 2939, which gave dpdv = (inf, nan, inf)): the Jacobian's inverse overflows float32,
    so dP/du, dP/dv are 0 (texture/mapping.h), never inf or NaN."""
    from texray import procedural
    g = procedural.grid(2, 4)
    m = tx.Mesh(g.positions * 0.274 + np.array((0.464, 0.217, -0.279)), g.faces, uvs=g.uvs,
                material=tx.Material(diffuse=tx.Texture.procedural("checker", size=8)),
                mapping=tx.Projection("spherical", z_axis=(0.971, -0.02, -0.238), x_axis=(0.0, 1.0, 0.0),
                                      scale=2.909, origin=(1e17, 0, 0)))
    scene = tx.Scene(camera=tx.Camera(eye=(-4.918, 1.25, 5.693), look_at=(-0.438, 0.314, 0.083), fov_y=20.162),
                     lights=[tx.PointLight((-2.589, 3.638, -1.253), 13)], objects=[m])
    img = tx.render(scene, 15, 11, 2, device=device, aovs=("dpdu", "dpdv"), specialize=False)
    hit = ~np.isnan(img.aov["dpdv"]).all(-1)
    assert hit.any() and np.all(np.isfinite(img.rgb))
    for name in ("dpdu", "dpdv"):
        assert np.all(np.isfinite(img.aov[name][hit])), name
