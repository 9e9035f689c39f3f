"""Displacement mapping (texray.displace, kernels/geometry/displace.h) against float64 references.

The reference for a displaced quad is a dense float64 root finder on the same height
field (the bilinear interpolant of the texels, texray.displace.height): f(t) = h - H
sampled at 4000 points between the volume's entry and exit, the first sign change
bisected 50 times. Tolerances: float32 rays over a unit-sized quad give hit distances
to a few 1e-7; the maxmip traversal solves the cell's quadratic in float32, whose
conditioning near grazing incidence costs up to ~1e-4 of t (T_EXACT); the search
brackets the root to (B - A) / (N 2^M) and then takes a secant step (T_SEARCH).
"""
from pathlib import Path

import numpy as np
import pytest
import texray as tx
from texray.compile import heights as H
from texray.compile import tessellate as T
from texray.scene import heightfield as HF
from texray.renderer.trace import Tracer
from disp_reference import CORNERS, TRAPEZOID, quad_reference, trapezoid_reference, trace_each as _trace_each

T_EXACT = 2e-4       # relative t error of maxmip: the cell quadratic in float32 (module docstring)
T_SEARCH = 2e-3      # relative t error of N = 128, M = 8 at up to 80 degrees


def _tex(a):
    return tx.Texture.from_array(np.asarray(a, np.float32).reshape(a.shape[0], a.shape[1], 1))


def _sines(n=48, a=0.5, k=3.0):
    """h = a sin(k x) sin(k y) + a at the texel centres (texture row 0 on top)."""
    c = (np.arange(n) + 0.5) / n * 2 * np.pi
    return _tex(a + a * np.sin(k * c)[None, :] * np.sin(k * c)[:, None])


def _quad_scene(d, extra=()):
    s = tx.Scene(camera=tx.Camera(eye=(0, 2, 3), look_at=(0, 0, 0)),
                 lights=[tx.PointLight(position=(0, 5, 0), intensity=(10, 10, 10))])
    s.add(tx.Quad(*CORNERS, material=tx.Material(displacement=d)))
    for o in extra:
        s.add(o)
    return s


def _view_rays(angle_deg, n=400, seed=0):
    """Rays toward random points at mid-height over the quad's inner part, all at angle_deg
    from its normal (a parallel bundle), from 0.5 above the quad's plane."""
    rng = np.random.default_rng(seed)
    a = np.radians(angle_deg)
    d = np.array([np.sin(a) * np.cos(0.3), -np.cos(a), np.sin(a) * np.sin(0.3)])
    target = np.column_stack([rng.uniform(-0.8, 0.8, n), np.full(n, 0.1), rng.uniform(-0.8, 0.8, n)])
    return target - (0.4 / np.cos(a)) * d, np.broadcast_to(d, (n, 3)).copy()


@pytest.mark.parametrize("method", ["maxmip", "search"])
def test_analytic_sines_match_float64_root_finder(device, method):
    d = tx.Displacement(_sines(), scale=0.2, method=method, steps=128, refine=8)
    tracer = Tracer(_quad_scene(d), device)
    angles = (0, 30, 60, 80, 89) if method == "maxmip" else (0, 30, 60, 80)
    for ang in angles:
        orgs, dirs = _view_rays(ang)
        t, uv = _trace_each(tracer, orgs, dirs)
        tr, uvr = quad_reference(d, orgs, dirs)
        both = ~np.isnan(t) & ~np.isnan(tr)
        agree = np.isnan(t) == np.isnan(tr)
        tol = T_EXACT if method == "maxmip" else T_SEARCH
        # The search may pick another crossing where the ray grazes a crest between two samples.
        assert agree.mean() >= (1.0 if method == "maxmip" else 0.98), (method, ang, np.flatnonzero(~agree)[:5])
        rel = np.abs(t[both] - tr[both]) / tr[both]
        good = rel <= tol
        assert good.mean() >= (0.995 if method == "maxmip" else 0.97), (method, ang, rel.max())
        assert np.abs(uv[both][good] - uvr[both][good]).max() <= 20 * tol, (method, ang)


CHECKER = Path(__file__).resolve().parents[2] / "scenes" / "textures" / "checker.png"
@pytest.mark.parametrize("angle", [20, 50, 70, 86])
def test_trapezoid_search_matches_float64_root_finder(device, angle):
    """A planar convex quad that is no parallelogram: the search inverts its bilinear patch
    in the plane (kernels/geometry/displace.h disp_inverse_bilinear); hits, distances and
    the patch's (u, v) against a float64 root finder with an independent (Newton) inverse."""
    d = tx.Displacement(_sines(), scale=0.2, method="search", steps=128, refine=8)
    s = tx.Scene(camera=tx.Camera(eye=(0, 2, 3), look_at=(0, 0, 0)))
    s.add(tx.Quad(*TRAPEZOID, material=tx.Material(displacement=d)))
    tracer = Tracer(s, device)
    rng = np.random.default_rng(angle)
    a = np.radians(angle)
    dirs = np.array([np.sin(a) * np.cos(0.3), -np.cos(a), np.sin(a) * np.sin(0.3)])
    # targets at mid-height over the patch's inner part: P(u, v) for u, v in [0.1, 0.9]
    u, v = rng.uniform(0.1, 0.9, (2, 400))
    p = np.asarray(TRAPEZOID, np.float64)
    target = ((1 - u) * (1 - v))[:, None] * p[0] + (u * (1 - v))[:, None] * p[1] + (u * v)[:, None] * p[2] \
        + ((1 - u) * v)[:, None] * p[3] + np.array([0, 0.1, 0])
    orgs = target - (0.4 / np.cos(a)) * dirs
    dirs = np.broadcast_to(dirs, orgs.shape).copy()
    t, uv = _trace_each(tracer, orgs, dirs)
    tr, uvr = trapezoid_reference(d, p, orgs, dirs)
    agree = np.isnan(t) == np.isnan(tr)
    assert agree.mean() >= 0.98, (angle, np.flatnonzero(~agree)[:5])
    both = ~np.isnan(t) & ~np.isnan(tr)
    assert both.mean() >= 0.9
    rel = np.abs(t[both] - tr[both]) / tr[both]
    good = rel <= T_SEARCH
    assert good.mean() >= 0.97, (angle, rel.max())
    assert np.abs(uv[both][good] - uvr[both][good]).max() <= 20 * T_SEARCH, angle


def test_trapezoid_search_renders_as_its_tessellation(device):
    """Depth and colour of a displaced trapezoid, searched on the device, against its own
    tessellation (4 vertices per texel): the same surface, the same shading normals and
    texture coordinates (a checker across the patch) within the tessellation's error."""
    out = {}
    for method in ("search", "tessellate"):
        d = tx.Displacement(_sines(24, a=0.5, k=2.0), scale=0.2, method=method, steps=64, refine=8, resolution=4)
        s = tx.Scene(camera=tx.Camera(eye=(0, 1.2, 2.6), look_at=(0, 0, 0), fov_y=45),
                     lights=[tx.PointLight((2, 3, 2), (12, 12, 12))], ambient=(0.05, 0.05, 0.05))
        s.add(tx.Quad(*TRAPEZOID, uvs=((0, 0), (2, 0), (2, 1), (0, 1)),
                      material=tx.Material(diffuse=tx.Texture.load(CHECKER), displacement=d)))
        img = tx.render(s, 96, 72, 1, device=device, aovs=("depth",), jitter=False)
        assert not np.isnan(img.rgb).any()
        out[method] = img
    a, b = out["search"].aov["depth"][..., 0], out["tessellate"].aov["depth"][..., 0]
    assert (np.isnan(a) == np.isnan(b)).mean() > 0.995
    both = ~np.isnan(a) & ~np.isnan(b)
    assert both.mean() > 0.2                 # the quad covers about a quarter of the image
    assert np.median(np.abs(a[both] - b[both]) / b[both]) < 1e-3
    diff = np.abs(out["search"].rgb - out["tessellate"].rgb)[both]
    assert np.sqrt(np.mean(diff ** 2)) < 0.02 and np.percentile(diff, 95) < 0.02


def test_quads_the_search_cannot_displace_are_refused():
    tex = _sines(4)
    search, maxmip = (tx.Material(displacement=tx.Displacement(tex, method=m)) for m in ("search", "maxmip"))
    with pytest.raises(tx.SceneError, match=r"bent: material.displacement.method: 'search' displaces planar quads "
                                            r"only; p2 lies 0.5 off"):
        tx.Quad((0, 0, 0), (1, 0, 0), (1, 0.5, 1), (0, 0, 1), material=search, name="bent")
    for name, m in (("search", search), ("maxmip", maxmip)):
        with pytest.raises(tx.SceneError, match=rf"dart: material.displacement.method: '{name}' displaces convex "
                                                rf"quads only.*\[0.3, 0.0, 0.3\].*use method = \"tessellate\""):
            tx.Quad((0, 0, 0), (1, 0, 0), (0.3, 0, 0.3), (0, 0, 1), material=m, name="dart")
    with pytest.raises(tx.SceneError, match=r"bent: material.displacement.method: 'maxmip' displaces planar quads"):
        tx.Quad((0, 0, 0), (1, 0, 0), (1, 0.5, 1), (0, 0, 1), material=maxmip, name="bent")
    tx.Quad(*TRAPEZOID, material=search, name="trapezoid")                   # accepted
    tx.Quad(*TRAPEZOID, material=maxmip, name="trapezoid")                   # accepted (issue 17)
    tx.Quad(*TRAPEZOID, material=tx.Material(displacement=tx.Displacement(tex, method="tessellate")))


def test_zero_height_renders_the_undisplaced_quad(device):
    tex = _sines()
    wood = tx.Texture.from_array(np.random.default_rng(0).random((8, 8, 3)).astype(np.float32))

    def scene(disp):
        s = tx.Scene(camera=tx.Camera(eye=(0.3, 2, 3), look_at=(0, 0, 0)),
                     lights=[tx.PointLight(position=(1, 4, 2), intensity=(20, 20, 20))])
        s.add(tx.Quad(*CORNERS, material=tx.Material(diffuse=wood, displacement=disp)))
        return s
    aovs = ("depth", "uv", "normal")
    plain = tx.render(scene(None), 64, 48, device=device, aovs=aovs, jitter=False)
    for method in ("search", "maxmip"):
        img = tx.render(scene(tx.Displacement(tex, scale=0.0, method=method)), 64, 48, device=device, aovs=aovs,
                        jitter=False)
        assert not np.isnan(img.rgb).any()
        np.testing.assert_array_equal(np.isnan(img.aov["depth"]), np.isnan(plain.aov["depth"]))
        np.testing.assert_allclose(img.aov["depth"], plain.aov["depth"], rtol=1e-5, atol=0)
        np.testing.assert_allclose(img.aov["uv"], plain.aov["uv"], atol=1e-5)
        np.testing.assert_allclose(img.aov["normal"], plain.aov["normal"], atol=1e-6)
        np.testing.assert_allclose(img.rgb, plain.rgb, atol=2e-3)


@pytest.mark.parametrize("method", ["search", "maxmip"])
@pytest.mark.parametrize("heights", ["zero", "one", "single"])
def test_constant_maps_are_planes_at_their_height(device, method, heights):
    """All-zero and all-one maps and a 1x1 texture: a plane at H, hit where the plane is."""
    a = {"zero": np.zeros((4, 4)), "one": np.ones((4, 4)), "single": np.full((1, 1), 0.7)}[heights]
    d = tx.Displacement(_tex(a), scale=0.3, offset=0.05, method=method, steps=4, refine=4)
    level = 0.05 + 0.3 * float(a.flat[0])
    tracer = Tracer(_quad_scene(d), device)
    for ang in (0, 45, 85):
        orgs, dirs = _view_rays(ang, n=64, seed=ang)
        t, _ = _trace_each(tracer, orgs, dirs)
        t_plane = (orgs[:, 1] - level) / -dirs[:, 1]
        p = orgs + t_plane[:, None] * dirs
        inside = (np.abs(p[:, 0]) < 0.999) & (np.abs(p[:, 2]) < 0.999)
        assert not np.isnan(t[inside]).any(), (ang, heights)
        np.testing.assert_allclose(t[inside], t_plane[inside], rtol=1e-5)


@pytest.mark.parametrize("method", ["search", "maxmip"])
def test_edge_rays(device, method):
    """From inside the volume, parallel to the quad (inside and outside the slab), through
    the volume past the surface: the float64 reference's answer, never NaN."""
    d = tx.Displacement(_sines(16), scale=0.2, method=method, steps=256, refine=8)
    tracer = Tracer(_quad_scene(d), device)
    orgs = np.array([[0.1, 0.199, 0.2],      # inside the slab, above the surface: look down
                     [0.1, 0.199, 0.2],      # inside, parallel to the quad
                     [-3.0, 0.25, 0.3],      # parallel, above the slab: misses
                     [-3.0, 0.12, 0.3],      # parallel through the slab: meets a bump (not at h = 0.1,
                                             # the field's mean, where H - h has a zero set along the
                                             # ray's whole entry: any rounding of H flips its sign)
                     [-3.0, 0.3, 0.0],       # through the volume's corner region, over every bump
                     [0.0, 3.0, 0.0]])
    dirs = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0],
                     [1.0, -0.02, 0.0], [0.0, 1.0, 0.0]])     # last: points away
    t, uv = _trace_each(tracer, orgs, dirs)
    tr, _ = quad_reference(d, orgs, dirs, samples=20000)
    assert not np.isnan(uv).any()
    np.testing.assert_array_equal(np.isnan(t), np.isnan(tr))
    both = ~np.isnan(tr)
    np.testing.assert_allclose(t[both], tr[both], rtol=T_SEARCH)


def test_self_shadowing_behind_a_ridge(device):
    """A ridge along v at u = 0.5, 0.3 high; light low on the -x side: a point behind the
    ridge (+x) is in shadow, one in front (-x) is lit, for both methods."""
    n = 32
    a = np.zeros((n, n))
    a[:, 15:17] = 1.0
    light = np.array([-3.0, 0.5, 0.0])
    for method in ("search", "maxmip"):
        d = tx.Displacement(_tex(a), scale=0.3, method=method, steps=64)
        tracer = Tracer(_quad_scene(d), device)
        pts = np.array([[0.3, 0.0, 0.0], [-0.3, 0.0, 0.0]]) + np.array([0, 1e-4, 0])
        occ = [tracer.occluded(p, (light - p)[None])[0][0] for p in pts]
        assert occ == [True, False], method


def test_maxmip_never_misses_one_texel_spikes(device):
    """One-texel spikes on a flat terrain, rays aimed at points just below each spike's top
    from grazing directions: maxmip hits every one (conservative skipping); a coarse
    linear search misses some (README's table counts them)."""
    n = 64
    a = np.zeros((n, n))
    rng = np.random.default_rng(3)
    ij = rng.integers(4, n - 4, (40, 2))
    a[ij[:, 0], ij[:, 1]] = 1.0
    targets = np.column_stack([-1 + 2 * (ij[:, 1] + 0.5) / n, np.full(len(ij), 0.2 * 0.9),
                               1 - 2 * (1 - (ij[:, 0] + 0.5) / n)])     # v = 1 - (row + 0.5)/n, z = 1 - 2 v
    dirs = np.tile([1.0, -0.12, 0.35], (len(ij), 1))
    orgs = targets - 0.8 * dirs
    tr, _ = quad_reference(tx.Displacement(_tex(a), scale=0.2), orgs, dirs, samples=40000)
    assert not np.isnan(tr).any()
    found = {}
    for method, steps in (("maxmip", 1), ("search", 4)):
        d = tx.Displacement(_tex(a), scale=0.2, method=method, steps=steps)
        t, _ = _trace_each(Tracer(_quad_scene(d), device), orgs, dirs)
        found[method] = ~np.isnan(t)
    assert found["maxmip"].all()
    assert not found["search"].all()


def test_curved_shapes_match_their_tessellation(device):
    """Displaced sphere and cylinder, searched on the device, against their tessellation
    (4 vertices per texel): first hits and depths agree on nearly every pixel."""
    tex = _sines(24, a=0.5, k=2.0)
    depth = {}
    for method in ("search", "tessellate"):
        d = tx.Displacement(tex, scale=0.15, method=method, steps=64, refine=8, resolution=4)
        s = tx.Scene(camera=tx.Camera(eye=(0, 0.5, 4), look_at=(0, 0, 0), fov_y=45))
        s.add(tx.Sphere(center=(-0.8, 0, 0), radius=0.6, axis_z=(0, 1, 0), material=tx.Material(displacement=d)))
        s.add(tx.Cylinder(radius=0.5, z_range=(-0.8, 0.8), origin=(0.8, 0, 0), axis_z=(0, 1, 0),
                          material=tx.Material(displacement=d)))
        img = tx.render(s, 64, 48, device=device, aovs=("depth",), jitter=False)
        assert not np.isnan(img.rgb).any()
        depth[method] = img.aov["depth"][..., 0]
    a, b = depth["search"], depth["tessellate"]
    same = np.isnan(a) == np.isnan(b)
    assert same.mean() > 0.97
    both = ~np.isnan(a) & ~np.isnan(b)
    assert np.median(np.abs(a[both] - b[both]) / b[both]) < 2e-3


def test_host_height_field_and_pyramid():
    rng = np.random.default_rng(1)
    h = rng.random((5, 7))
    # Texel centres return the texels (row 0 on top, v = 0 at the bottom).
    u = (np.arange(7) + 0.5) / 7
    v = 1 - (np.arange(5) + 0.5) / 5
    np.testing.assert_allclose(HF.height(h, u[None, :], v[:, None]), h)
    # The pyramid bounds the interpolant everywhere, for every wrap mode.
    for wrap in ("repeat", "clamp", "mirror"):
        pyr = H.minmax_pyramid(h, wrap)
        assert pyr[-1].shape == (1, 1, 2)
        uu, vv = rng.random(20000), rng.random(20000)
        val = HF.height(h, uu, vv, wrap)
        cx = np.floor(uu * 7 + 0.5).astype(int)
        cy = np.floor((1 - vv) * 5 + 0.5).astype(int)
        for lv in pyr:
            assert np.all(val >= lv[cy, cx, 0] - 1e-12) and np.all(val <= lv[cy, cx, 1] + 1e-12), wrap
            cx, cy = cx // 2, cy // 2
    # Gradient: central differences of the interpolant inside a cell.
    gu, gv = HF.height_gradient(h, 0.41, 0.37)
    e = 1e-6
    np.testing.assert_allclose(gu, (HF.height(h, 0.41 + e, 0.37) - HF.height(h, 0.41 - e, 0.37)) / (2 * e), rtol=1e-5)
    np.testing.assert_allclose(gv, (HF.height(h, 0.41, 0.37 + e) - HF.height(h, 0.41, 0.37 - e)) / (2 * e), rtol=1e-5)


def test_tessellation_lies_on_the_displaced_surface():
    tex = _sines(8)
    d = tx.Displacement(tex, scale=0.1, method="tessellate", resolution=2)
    shapes = [tx.Quad(*CORNERS, material=tx.Material(displacement=d)),
              tx.Sphere(radius=0.5, material=tx.Material(displacement=d)),
              tx.Cylinder(radius=0.5, theta_range=(0, 270), material=tx.Material(displacement=d))]
    for s in shapes:
        m = T.tessellate(s)
        assert m.faces.shape[0] > 0 and np.all(np.isfinite(m.positions))
        uv = m.uvs if not isinstance(s, tx.Quad) else None
        if uv is not None:
            p, _ = T.displaced_point(s, uv[:, 0], uv[:, 1])
            np.testing.assert_allclose(m.positions, p, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1, atol=1e-12)


def test_bad_input_names_the_field():
    tex = _sines(4)
    for kw, field in (({"method": "parallax"}, "method"), ({"steps": 0}, "steps"), ({"refine": -1}, "refine"),
                      ({"scale": float("nan")}, "scale"), ({"adaptive": "yes"}, "adaptive"),
                      ({"resolution": 99}, "resolution")):
        with pytest.raises(tx.SceneError, match=field):
            tx.Displacement(tex, **kw)
    # Shape rules are checked when the object is made, not at render time.
    d = tx.Displacement(tex, scale=0.1)
    with pytest.raises(tx.SceneError, match="kite: material.displacement.method: .*planar quads only"):
        tx.Quad((0, 0, 0), (1, 0, 0), (1.5, 0.3, 1), (0, 0, 1), material=tx.Material(displacement=d), name="kite")
    tx.Sphere(material=tx.Material(displacement=tx.Displacement(tex, method="maxmip")), name="ball")   # accepted
    tx.Cylinder(material=tx.Material(displacement=tx.Displacement(tex, method="maxmip")), name="can")  # (issue 17)
    with pytest.raises(tx.SceneError, match="can: material.displacement.offset: .*below the axis"):
        tx.Cylinder(radius=0.5, material=tx.Material(displacement=tx.Displacement(tex, method="maxmip", offset=-1.0)),
                    name="can")
    with pytest.raises(tx.SceneError, match="ball: material.displacement.offset: .*below the centre"):
        tx.Sphere(radius=0.5, material=tx.Material(displacement=tx.Displacement(tex, offset=-1.0)), name="ball")
    tx.Mesh(np.eye(3), np.array([[0, 1, 2]]), material=tx.Material(displacement=tx.Displacement(tex, method="maxmip")),
            name="tri")                                                                    # accepted (its shells)
    from texray.compile import compile_scene
    s = tx.Scene(camera=tx.Camera())       # a material changed after the mesh was made: refused at compile (no uvs)
    s.add(tx.Mesh(np.eye(3), np.array([[0, 1, 2]]), name="tri"))
    s.objects[0].material = tx.Material(displacement=d)
    with pytest.raises(tx.SceneError, match="tri.*displacement"):
        compile_scene(s)
    with pytest.raises(tx.SceneError, match="displacement"):
        tx.Material(displacement="height.png").validate()


_SCENE_FILE = """
[camera]
eye = [0.0, 1.5, 2.5]
look_at = [0.0, 0.0, 0.0]

[[lights]]
position = [0.0, 5.0, 1.0]
intensity = [10.0, 10.0, 10.0]

[textures.h]
procedural = "bricks_height"
params = {{ size = 32 }}

[materials.m]
diffuse = [0.6, 0.5, 0.4]
displacement = {{ texture = "h", {disp} }}

[[objects]]
type = "quad"
p0 = [-1, 0, 1]
p1 = [1, 0, 1]
p2 = [1, 0, -1]
p3 = [-1, 0, -1]
material = "m"
"""


@pytest.mark.parametrize("disp, kw", [
    ('scale = 0.1, offset = -0.02, method = "search", steps = 16, refine = 4, adaptive = true',
     {"scale": 0.1, "offset": -0.02, "method": "search", "steps": 16, "refine": 4, "adaptive": True}),
    ('scale = 0.1, method = "maxmip"', {"scale": 0.1, "method": "maxmip"}),
    ('scale = 0.1, method = "tessellate", resolution = 2', {"scale": 0.1, "method": "tessellate", "resolution": 2}),
])
def test_scene_file_displacement_renders_as_the_api_scene(device, tmp_path, disp, kw):
    """materials.NAME.displacement in a scene file builds the same Displacement as the API:
    the two scenes render identical images (same program, same buffers)."""
    path = tmp_path / "d.toml"
    path.write_text(_SCENE_FILE.format(disp=disp))
    from_file = tx.Scene.load(path)
    d = tx.Displacement(tx.Texture.procedural("bricks_height", size=32), **kw)
    api = tx.Scene(camera=tx.Camera(eye=(0, 1.5, 2.5), look_at=(0, 0, 0)),
                   lights=[tx.PointLight(position=(0, 5, 1), intensity=(10, 10, 10))])
    api.add(tx.Quad(*CORNERS, material=tx.Material(diffuse=(0.6, 0.5, 0.4), displacement=d)))
    a = tx.render(from_file, 48, 32, 1, device=device, jitter=False).rgb
    b = tx.render(api, 48, 32, 1, device=device, jitter=False).rgb
    assert np.isfinite(a).all() and a.max() > 0
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("disp, message", [
    ('scale = 0.1, method = "parallax"',
     "materials.m.displacement.method: expected one of search, maxmip, tessellate, got 'parallax'"),
    ("steps = 0", r"materials.m.displacement.steps: expected an integer in \[1, 4096\], got 0"),
    ("steps = 8.5", "materials.m.displacement.steps: expected int, got 8.5"),
    ("refine = 33", r"materials.m.displacement.refine: expected an integer in \[0, 32\], got 33"),
    ('scale = "big"', "materials.m.displacement.scale: expected int or float, got 'big'"),
    ("scale = nan", "materials.m.displacement.scale"),
    ("adaptive = 1", "materials.m.displacement.adaptive: expected true or false, got 1"),
    ("resolution = 99", r"materials.m.displacement.resolution: expected an integer in \[1, 16\], got 99"),
    ("height = 0.1", "materials.m.displacement.height: unknown key"),
])
def test_scene_file_displacement_errors_name_file_field_and_value(tmp_path, disp, message):
    path = tmp_path / "bad.toml"
    path.write_text(_SCENE_FILE.format(disp=disp))
    with pytest.raises(tx.SceneError, match="bad.toml: " + message):
        tx.Scene.load(path)
    path.write_text(_SCENE_FILE.format(disp="scale = 0.1").replace('texture = "h"', 'texture = "nope"'))
    with pytest.raises(tx.SceneError, match="bad.toml: materials.m.displacement.texture: no texture named 'nope'"):
        tx.Scene.load(path)


def test_bench_scene_files_and_their_height_maps():
    """scenes/bench/{terrain,displaced_wall,planet}.toml load, their 16-bit height maps are
    tools/make_assets.py's (to one 16-bit step), and the sweep's factory swaps the method
    and knobs while keeping texture, scale and offset."""
    import importlib.util
    from pathlib import Path

    from texray.bench import sweep as B
    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("make_assets", root / "tools" / "make_assets.py")
    assets = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(assets)
    made = assets.displacement_heights()
    scenes = B.displacement_scenes()
    assert set(scenes) == set(B.DISP_SCENES)
    files = {"terrain": "disp_terrain.png", "displaced_wall": "disp_wall.png", "planet": "disp_planet.png"}
    for name, (scene, make) in scenes.items():
        (d,) = [o.material.displacement for o in scene.objects if o.material.displacement is not None]
        assert d.texture.shape == (256, 256)
        np.testing.assert_allclose(d.texture.raw[:, :, 0], made[files[name]][:, :, 0], atol=0.5 / 65535 + 1e-7)
        s = make("search", steps=4, refine=2, adaptive=True)
        (d2,) = [o.material.displacement for o in s.objects if o.material.displacement is not None]
        assert (d2.method, d2.steps, d2.refine, d2.adaptive) == ("search", 4, 2, True)
        assert d2.texture is d.texture and (d2.scale, d2.offset) == (d.scale, d.offset)
        assert scene.objects[0].material.displacement is d        # the loaded scene is unchanged
    assert B.maxmip_applies(scenes["terrain"][0]) and B.maxmip_applies(scenes["planet"][0])   # spheres too


def test_stored_heights_are_unorm16_and_the_pyramid_stays_conservative():
    """The device holds q = round((H - hmin) / (hmax - hmin) 65535) as uint16: dequantized, within
    half a step of H; the pyramid is built from q itself, so after the device's (monotone)
    dequantization it bounds the interpolant of the stored heights with no rounding slack."""
    rng = np.random.default_rng(3)
    h = rng.random((9, 13)) * 0.37 - 0.05
    d = tx.Displacement(_tex(h), scale=1.0)
    buf, index = H.pack_heights([d])
    assert buf.dtype == np.uint16
    hoff, moff, levels = next(iter(index.values()))
    q = buf[hoff:hoff + h.size].reshape(h.shape).astype(np.float64)
    lo, hi = d.bounds()
    step = (hi - lo) / 65535
    hq = lo + q * step
    assert np.abs(hq - d.heights()).max() <= 0.5 * step + 1e-12
    pyr = H.minmax_pyramid(q, d.wrap)
    assert len(pyr) == levels
    np.testing.assert_array_equal(buf[moff:moff + pyr[0].size], pyr[0].ravel())
    uu, vv = rng.random(20000), rng.random(20000)
    val = HF.height(hq, uu, vv, d.wrap)
    cx, cy = np.floor(uu * 13 + 0.5).astype(int), np.floor((1 - vv) * 9 + 0.5).astype(int)
    for lv in pyr:
        assert np.all(val >= lo + lv[cy, cx, 0] * step - 1e-12) and np.all(val <= lo + lv[cy, cx, 1] * step + 1e-12)
        cx, cy = cx // 2, cy // 2
    assert H.quantize(np.full((2, 2), 0.3)).tolist() == [[0, 0], [0, 0]]
