"""Displaced triangle meshes, method="search" (texray.compile.shells, the DISP_TRIANGLE
shells of kernels/geometry/displace.h): per pixel, without tessellation.

What each test guards against:
* the flat two-triangle mesh against the displaced quad and a float64 root finder on
  the same height field, rays from 70 down to 4 degrees above the plane: the shell's
  (b1, b2, h) inversion, its clip and the search's hand-over between two shells;
* a fine UV-sphere mesh against the analytic displaced sphere: the cubic inversion
  with varying vertex normals (N interpolated, not renormalized);
* rays at the shared edges and vertices of a closed mesh: no hole between shells;
* a grazing light: shadow rays search the same shells (self-shadowing) as the quad's;
* AOVs, the bench sweep, and what is refused or handled conservatively
(method="maxmip" on the same shells: tests/render/test_mesh_maxmip.py).
"""
import warnings
from pathlib import Path

import numpy as np
import pytest

import texray as tx
from texray.compile import compile_scene
from texray.compile import shells as S
from texray.device import layout
from texray.renderer.trace import Tracer
from disp_reference import CORNERS, quad_reference, trace_each, uv_sphere_mesh

P = np.array(CORNERS, float)                                 # the y = 0 square, n = +y
UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)       # the quad's (u, v) at its corners
TWO = np.array([[0, 1, 2], [0, 2, 3]])

# Relative hit distance of the mesh's search against the float64 root finder (N = 128, M = 8):
# measured 6e-6 at the 99th percentile from 70 to 4 degrees; the bracket (B - A) / (N 2^M)
# with the secant step (tests/kernels/test_displace.py T_SEARCH: 2e-3) bounds it far above.
T_FLAT = 2e-4


def _sines(n=48, a=0.5, k=3.0):
    """h = a sin(k x) sin(k y) + a at the texel centres (as tests/kernels/test_displace.py)."""
    c = (np.arange(n) + 0.5) / n * 2 * np.pi
    return tx.Texture.from_array((a + a * np.sin(k * c)[None, :] * np.sin(k * c)[:, None]).astype(np.float32)[..., None])


def _flat_mesh(d, name="m"):
    return tx.Mesh(P, TWO, uvs=UV, normals=np.tile([0, 1.0, 0], (4, 1)), material=tx.Material(displacement=d),
                   name=name)


def _scene(*objects, lights=()):
    return tx.Scene(camera=tx.Camera(eye=(0, 2, 3), look_at=(0, 0, 0)), objects=list(objects), lights=list(lights),
                    ambient=(0.2, 0.2, 0.2))


def _grazing_rays(elevation_deg, n=400):
    """A parallel bundle at elevation_deg above the plane toward random points at height 0.1
    over the square's inner part, from 0.4 / sin(elevation) back along the ray."""
    rng = np.random.default_rng(elevation_deg)
    a = np.radians(90 - elevation_deg)
    d = np.array([np.sin(a) * np.cos(0.3), -np.cos(a), np.sin(a) * np.sin(0.3)])
    target = np.column_stack([rng.uniform(-0.8, 0.8, n), np.full(n, 0.1), rng.uniform(-0.8, 0.8, n)])
    return target - (0.4 / np.cos(a)) * d, np.broadcast_to(d, (n, 3)).copy()


@pytest.mark.parametrize("elevation", [70, 45, 20, 10, 4])
def test_a_flat_two_triangle_mesh_is_the_displaced_quad(device, elevation):
    """Hit distances of the two shells against the float64 root finder (within T_FLAT on
    99% of the rays, hit/miss on 99%) and against the quad's own search (the same on 98%:
    both may skip a crest between two samples, at different samples)."""
    d = tx.Displacement(_sines(), scale=0.2, method="search", steps=128, refine=8)
    orgs, dirs = _grazing_rays(elevation)
    tm, b = trace_each(Tracer(_scene(_flat_mesh(d)), device), orgs, dirs)
    tq, _ = trace_each(Tracer(_scene(tx.Quad(*CORNERS, material=tx.Material(displacement=d))), device), orgs, dirs)
    tr, _ = quad_reference(d, orgs, dirs, samples=20000)
    assert np.mean(np.isnan(tm) == np.isnan(tr)) >= 0.99 and np.mean(~np.isnan(tm)) > 0.9
    both = ~np.isnan(tm) & ~np.isnan(tr)
    rel = np.abs(tm[both] - tr[both]) / tr[both]
    assert np.mean(rel <= T_FLAT) >= 0.99, (elevation, np.quantile(rel, 0.99))
    same = ~np.isnan(tm) & ~np.isnan(tq)
    assert np.mean(np.abs(tm[same] - tq[same]) <= T_FLAT * tq[same]) >= 0.98
    assert np.all((b[~np.isnan(tm)] >= 0) & (b[~np.isnan(tm)] <= 1))     # the hits' barycentrics


def test_a_displaced_uv_sphere_mesh_matches_the_displaced_sphere(rng, device):
    """A 128 x 64 UV-sphere mesh from the sphere's own parameterization (uvs = the
    sphere's (u, v), its unit normals), both searched (N = 64, M = 8) with one height field:
    measured 0.03% of the pixels differ in hit/miss (the silhouette), depth within 0.12% at
    the 99th percentile (the chords' sagitta, 3e-4, and N not renormalized, 1e-4 of H);
    tolerances 0.5% and 0.5%."""
    assert_uv_sphere_mesh_as_the_sphere(rng, device, method="search", steps=64, refine=8)


def assert_uv_sphere_mesh_as_the_sphere(rng, device, **displacement):
    """The test above for the displacement's method and knobs (test_mesh_maxmip.py's maxmip)."""
    h = rng.random((16, 32)).astype(np.float32)[:, :, None]

    def disp():
        return tx.Displacement(tx.Texture(h, name="h"), scale=0.08, **displacement)
    sph = tx.Sphere(radius=1.0, name="s", material=tx.Material(displacement=disp()))
    mesh = uv_sphere_mesh(sph, tx.Material(displacement=disp()))
    cam = tx.Camera(eye=(0, 0.5, 3.5), look_at=(0, 0, 0), fov_y=35)
    da, db = (tx.render(tx.Scene(camera=cam, objects=[o], ambient=(1, 1, 1)), 96, 72, 1, device=device,
                        jitter=False, aovs=("depth",), cache=False).aov["depth"][..., 0] for o in (sph, mesh))
    hit = np.isfinite(da) & np.isfinite(db)
    assert hit.mean() > 0.3 and np.mean(np.isfinite(da) != np.isfinite(db)) < 0.005
    assert np.quantile(np.abs(da[hit] - db[hit]) / da[hit], 0.99) < 0.005


def _octahedron():
    p = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    uv = 0.5 + 0.45 * p[:, :2] + 0.05 * p[:, 2:]         # continuous across every edge (shared vertices)
    return p, f, uv


def test_the_shared_edges_of_a_closed_mesh_leave_no_hole(rng, device):
    """Rays from the centre and from outside aimed at 97 points of every edge (its ends, the
    vertices, included) and at random directions: every one hits the displaced octahedron
    (area-weighted vertex normals, 55 degrees from the faces' normals), and from outside
    no nearer than the shell's outer bound allows."""
    assert_closed_octahedron_has_no_hole(rng, device, method="search", steps=32, refine=8)


def assert_closed_octahedron_has_no_hole(rng, device, **displacement):
    """The test above for the octahedron displaced by ``displacement`` (tx.Displacement's
    method and knobs; test_mesh_maxmip.py's maxmip too)."""
    p, f, uv = _octahedron()
    d = tx.Displacement(tx.Texture(rng.random((16, 16)).astype(np.float32)[..., None], name="h"), scale=0.1,
                        **displacement)
    mesh = tx.Mesh(p, f, uvs=uv, material=tx.Material(displacement=d), name="octa")
    e = np.array([[0, 2], [2, 1], [1, 3], [3, 0], [0, 4], [1, 4], [2, 4], [3, 4], [0, 5], [1, 5], [2, 5], [3, 5]])
    s = np.linspace(0, 1, 97)[:, None, None]
    targets = ((1 - s) * p[e[:, 0]] + s * p[e[:, 1]]).reshape(-1, 3)
    dirs = np.concatenate([targets, rng.normal(size=(2000, 3))])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    tracer = Tracer(tx.Scene(camera=tx.Camera(), objects=[mesh], ambient=(0.1, 0.1, 0.1)), device)
    hits = tracer.closest(np.zeros(3), dirs.astype(np.float32))
    assert np.all(hits.prim >= 0), f"{np.sum(hits.prim < 0)} rays of {len(dirs)} escaped from inside"
    orgs = 3.0 * dirs + 0.01 * rng.normal(size=dirs.shape)       # from outside, toward the same points
    t, _ = trace_each(tracer, orgs, -orgs / np.linalg.norm(orgs, axis=1, keepdims=True))
    assert np.all(~np.isnan(t)), f"{np.sum(np.isnan(t))} rays of {len(t)} passed through from outside"
    # |P + H N| <= 1 + 0.1: no hit before the surface's largest radius
    assert np.all(t >= np.linalg.norm(orgs, axis=1) - 1.1 - 1e-4)


def test_no_ray_escapes_a_displaced_closed_torus(device):
    """20000 rays from the tube's core circle of scenes/meshes/torus.obj (3072 triangles, uv
    seams with duplicated vertices; a repeat-wrapped random height field, H in [-0.05, 0.05]
    on a tube of radius 0.25, N = 16, M = 6) all leave through the surface. A shell whose
    clip lost a crossing to rounding once searched its box's segment with its thin share of
    the samples, all outside the shell: the first ray below escaped (a literal from that run)."""
    s = tx.Scene.load(Path(__file__).resolve().parents[2] / "scenes" / "displacement" / "torus_search.toml")
    mesh = s.objects[0]
    rng = np.random.default_rng(2)
    tex = tx.Texture(rng.random((32, 32)).astype(np.float32)[..., None], name="h", wrap="repeat")
    mesh.material = tx.Material(displacement=tx.Displacement(tex, scale=0.1, offset=-0.05, steps=16, refine=6))
    tracer = Tracer(tx.Scene(camera=tx.Camera(), objects=[mesh], ambient=(1, 1, 1)), device)
    n = 20000
    phi = rng.uniform(0, 2 * np.pi, n)
    orgs = np.stack([0.7 * np.cos(phi), np.zeros(n), 0.7 * np.sin(phi)], 1)
    dirs = rng.normal(size=(n, 3))
    orgs[0] = [0.04668797180056572, 0.0, -0.6984412670135498]
    dirs[0] = [0.5227548480033875, 0.5060126185417175, 0.6860601902008057]
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t, _ = trace_each(tracer, orgs, dirs)
    assert not np.isnan(t).any(), f"{np.isnan(t).sum()} of {n} escaped, first ray {np.flatnonzero(np.isnan(t))[0]}"
    assert np.all((t > 0.25 - 0.05 - 1e-3) & (t < 0.25 + 0.05 + 0.7 * 2 + 1e-3))


def test_self_shadowing_matches_the_displaced_quad(device):
    """A light 8 degrees above the horizon over the displaced square: the mesh's shadow rays
    search its shells (any hit) as the quad's search its slab. The two images agree (below
    0.5% of the pixels off by more than 0.05), and the relief does cast shadows (over 10%
    of the lit square's pixels are darker than without shadow rays)."""
    assert_shadows_as_the_quads(device, tx.Displacement(_sines(24, k=2.0), scale=0.25, method="search", steps=64,
                                                          refine=8))


def assert_shadows_as_the_quads(device, d):
    """The test above for the displacement d (test_mesh_maxmip.py's maxmip too)."""
    light = [tx.PointLight((-40.0, 40.0 * np.tan(np.radians(8)), -5.0), (2500.0, 2500.0, 2500.0))]
    cam = tx.Camera(eye=(0, 2.6, 1.2), look_at=(0, 0, 0), fov_y=50)
    q = tx.Scene(camera=cam, lights=light, objects=[tx.Quad(*CORNERS, material=tx.Material(displacement=d))])
    m = tx.Scene(camera=cam, lights=light, objects=[_flat_mesh(d)])
    a, b = (tx.render(s, 80, 60, 1, device=device, jitter=False, cache=False).rgb for s in (q, m))
    unshadowed = tx.render(m, 80, 60, 1, device=device, jitter=False, cache=False, shadows=False).rgb
    diff = np.abs(a - b).max(axis=2)
    assert np.mean(diff > 0.05) < 0.005, np.mean(diff > 0.05)
    lit = unshadowed.max(axis=2) > 0.05
    assert np.mean((unshadowed - b).max(axis=2)[lit] > 0.05) > 0.1


def test_aovs_report_the_displaced_hit(device):
    """Position on the ray at the reported depth, on the height field over its uv (the
    flat square: x = 2u - 1, z = 1 - 2v, y = H(u, v)); primitive_id the face that holds it,
    object_id the mesh; normal the quad's (one gradient, one bump formula)."""
    assert_aovs_as_the_quads(device, tx.Displacement(_sines(), scale=0.2, method="search", steps=64, refine=8))


def assert_aovs_as_the_quads(device, d):
    """The test above for the displacement d; (the mesh's AOVs, the quad's, the mesh's hit
    mask) for more checks (test_mesh_maxmip.py's maxmip)."""
    plain = tx.Sphere(center=(5, 0, 0), radius=0.1, name="other")
    aovs = ("position", "uv", "normal", "depth", "primitive_id", "object_id")
    m = tx.render(_scene(plain, _flat_mesh(d)), 64, 48, 1, device=device, jitter=False, aovs=aovs, cache=False).aov
    q = tx.render(_scene(plain, tx.Quad(*CORNERS, material=tx.Material(displacement=d))), 64, 48, 1, device=device,
                  jitter=False, aovs=aovs, cache=False).aov
    hit = np.isfinite(m["depth"][..., 0])
    assert hit.mean() > 0.2
    pos, uv = m["position"][hit], m["uv"][hit]
    np.testing.assert_allclose(pos[:, 0], 2 * uv[:, 0] - 1, atol=1e-5)
    np.testing.assert_allclose(pos[:, 2], 1 - 2 * uv[:, 1], atol=1e-5)
    from texray.scene.heightfield import height
    np.testing.assert_allclose(pos[:, 1], height(d.heights(), uv[:, 0], uv[:, 1]), atol=2e-4)
    face = np.where(uv[:, 1] <= uv[:, 0], 0, 1)                # TWO: face 0 below the diagonal u = v
    off_diagonal = np.abs(uv[:, 0] - uv[:, 1]) > 1e-3
    assert np.array_equal(m["primitive_id"][hit][:, 0][off_diagonal], face[off_diagonal])
    assert np.all(m["object_id"][hit] == 1)
    both = hit & np.isfinite(q["depth"][..., 0])
    assert np.quantile(np.abs(m["normal"][both] - q["normal"][both]).max(axis=1), 0.99) < 1e-3
    return m, q, hit


def test_the_bench_sweeps_the_search_on_a_mesh_against_its_tessellation():
    """texray bench --sweep mesh_terrain: the search's N x M series, the adaptive search,
    maxmip (tests/render/test_mesh_maxmip.py) and the tessellation. The shells take less
    device memory than the tessellation at 1 vertex per texel."""
    from texray.bench import sweep
    from texray.bench.suite import suite_paths
    mesh = tx.Scene.load(suite_paths(["mesh_terrain"])["mesh_terrain"])
    assert sweep.search_applies(mesh) and sweep.maxmip_applies(mesh)
    series = dict(sweep.displacement_series(mesh))
    assert {"search M=0", "search M=8", "search adaptive M=8", "maxmip", "tessellate"} <= set(series)
    mm = compile_scene(sweep.with_displacement(mesh, "maxmip"))
    assert len(mm.displaced) == 128 and mm.features.displaced_mesh_maxmip
    search = compile_scene(sweep.with_displacement(mesh, "search", steps=32, refine=8))
    tess = compile_scene(sweep.with_displacement(mesh, "tessellate", resolution=1))
    assert len(search.displaced) == 128 and search.features.displaced_meshes
    assert sum(search.device_bytes().values()) < 0.25 * sum(tess.device_bytes().values())


def test_refusals_and_conservative_fallbacks(rng):
    d = tx.Displacement(tx.Texture(rng.random((8, 8)).astype(np.float32)[..., None], name="h"), scale=0.1)
    with pytest.raises(tx.SceneError, match="nouv: uvs: displacement reads the height texture"):
        compile_scene(_scene(tx.Mesh(P, TWO, material=tx.Material(displacement=d), name="nouv")))
    nan = rng.random((8, 8)).astype(np.float32)
    nan[3, 4] = np.nan
    with pytest.raises(tx.SceneError, match="nanmap: non-finite texel nan at row 3, column 4"):
        tx.Displacement(tx.Texture(nan[..., None], name="nanmap"), method="search")
    with pytest.raises(tx.SceneError, match="one method for all its materials"):
        tx.Mesh(P, TWO, uvs=UV, material=[tx.Material(displacement=d),
                                          tx.Material(displacement=tx.Displacement(d.texture, method="tessellate"))],
                material_ids=np.array([0, 1]), name="mixed")
    # a zero-area triangle has no surface: skipped, the rest renders without NaN
    pts = np.concatenate([P, [[0.5, 0, -0.5]]])                 # on the diagonal P0 P2
    sliver = tx.Mesh(pts, np.array([[0, 1, 2], [0, 2, 3], [0, 4, 2]]), uvs=np.concatenate([UV, [[0.75, 0.75]]]),
                     normals=np.tile([0, 1.0, 0], (5, 1)), material=tx.Material(displacement=d), name="sliver")
    with pytest.warns(UserWarning, match=r"sliver: 1 zero-area triangle\(s\) skipped \(faces \[2\]\)"):
        cs = compile_scene(_scene(sliver))
    assert len(cs.displaced) == 2 and sorted(cs.displaced["prim"]) == [0, 1]
    with pytest.raises(tx.SceneError, match="flat0: faces: all 1 displaced triangles have zero area"):
        compile_scene(_scene(tx.Mesh(pts, np.array([[0, 4, 2]]), uvs=sliver.uvs, material=sliver.material,
                                     name="flat0")))
    img = tx.render(_scene(sliver, lights=[tx.PointLight((0, 3, 0), (9, 9, 9))]), 32, 24, 1, cache=False)
    assert np.all(np.isfinite(img.rgb))
    # vertex normals 88 degrees off the face normal: no true bound, tessellated with a warning
    tilted = np.tile([np.cos(np.radians(2.0)), np.sin(np.radians(2.0)), 0], (4, 1))
    bad = tx.Mesh(P, TWO, uvs=UV, normals=tilted, material=tx.Material(displacement=d), name="bent")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        cs = compile_scene(_scene(bad))
    assert any("bent: material.displacement: 2 triangle(s)" in str(x.message) and "tessellated instead"
               in str(x.message) for x in w)
    assert cs.displaced is None and len(cs.tri_verts) > 2


def test_undisplaced_faces_stay_plain_triangles(rng):
    d = tx.Displacement(tx.Texture(rng.random((8, 8)).astype(np.float32)[..., None], name="h"), scale=0.1)
    m = tx.Mesh(P, TWO, uvs=UV, material=[tx.Material(), tx.Material(displacement=d)], material_ids=np.array([0, 1]),
                name="half")
    cs = compile_scene(_scene(m))
    assert len(cs.displaced) == 1 and cs.displaced["prim"][0] == 1 and len(cs.tri_verts) == 1
    # its neighbour is no shell: a ray entering through their shared side comes from outside
    assert cs.displaced["shape"][0] == layout.DISP_TRIANGLE and cs.displaced["edges"][0] == 0
    both = compile_scene(_scene(_flat_mesh(d)))
    assert sorted(np.unpackbits(both.displaced["edges"].astype(np.uint8)[:, None], axis=1).sum(axis=1)) == [1, 1]


def test_footprint_bounds_hold_the_interpolant(rng):
    """Each triangle's [slo, shi] from the min-max pyramid holds the device's interpolant (of
    the quantized heights) at dense points of its uv box, boxes anywhere in uv (repeat),
    and is near the true range over the box (measured: 1.8x at the median, boxes up to 3
    texels wide on a smooth field; at most 4 x 4 cells of one pyramid level per box)."""
    c = (np.arange(32) + 0.5) / 32 * 2 * np.pi
    smooth = np.sin(2 * c)[None, :] * np.cos(3 * c)[:, None] + 0.05 * rng.random((32, 32))
    d = tx.Displacement(tx.Texture(smooth.astype(np.float32)[..., None], name="h"), scale=0.3)
    from texray.scene.heightfield import height
    lo_uv = rng.uniform(-1.5, 1.5, (300, 2))
    hi_uv = lo_uv + rng.uniform(0, 0.1, (300, 2))
    lo, hi = S.footprint_bounds(S.world_pyramid(d), lo_uv, hi_uv, (32, 32), "repeat")
    s = rng.random((300, 400, 2))
    uv = lo_uv[:, None] + s * (hi_uv - lo_uv)[:, None]
    hmin, hmax = d.bounds()
    hq = hmin + np.round((d.heights() - hmin) / (hmax - hmin) * 65535) * (hmax - hmin) / 65535
    val = height(hq, uv[..., 0] % 1.0, uv[..., 1] % 1.0, "repeat")
    assert np.all(val >= lo[:, None] - 1e-12) and np.all(val <= hi[:, None] + 1e-12)
    assert np.median((hi - lo) / np.ptp(val, axis=1)) < 3.0
