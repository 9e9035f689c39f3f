"""Displaced triangle meshes, method="tessellate" (texray.compile.tessellate_mesh): the
vertices lie on the height field exactly (float64 reference), a flat two-triangle mesh
gives the displaced quad's surface, the tessellation of a closed mesh is closed (every
edge shared by two triangles; rays aimed at the original edges all hit), and what cannot
be displaced is refused by name."""
import numpy as np
import pytest

import texray as tx
from texray.compile.tessellate_mesh import MAX_LEVEL, tessellate_mesh
from texray.renderer.trace import Tracer
from texray.scene.heightfield import height
from disp_reference import uv_sphere_mesh

QUAD = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
QUAD_UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)


def _displacement(rng, size=8, scale=0.2, resolution=1, method="tessellate", wrap="repeat"):
    h = rng.random((size, size)).astype(np.float32)
    return tx.Displacement(tx.Texture(h[:, :, None], name="h", wrap=wrap), scale=scale, method=method,
                           resolution=resolution)


def _edges(faces):
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return counts


def _octahedron():
    p = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    uv = 0.5 + 0.45 * p[:, :2] + 0.05 * p[:, 2:]         # continuous across every edge (shared vertices)
    return p, f, uv


def test_vertices_lie_on_the_height_field_along_the_normals(rng):
    d = _displacement(rng, resolution=2)
    m = tx.Mesh(QUAD, np.array([[0, 1, 2], [0, 2, 3]]), uvs=QUAD_UV, normals=np.tile([0, 0, 1.0], (4, 1)),
                material=tx.Material(displacement=d), name="flat")
    t = tessellate_mesh(m)
    ref = height(d.heights(), t.uvs[:, 0], t.uvs[:, 1], d.wrap)
    np.testing.assert_allclose(t.positions[:, 2], ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(t.positions[:, :2], t.uvs * 2 - 1, rtol=0, atol=1e-12)     # x, y from the uvs
    # 8 texels x resolution 2 along each side: 16 cuts, so 64 boundary edges; 23 (sqrt(2) x 16)
    # cuts on the shared diagonal, whose lattice the sides' snapping does not open
    counts = _edges(t.faces)
    assert set(np.unique(counts)) == {1, 2} and np.sum(counts == 1) == 64


def test_a_flat_two_triangle_mesh_renders_as_the_displaced_quad(rng, device):
    """The same height field on the same square, once as a Quad and once as two
    triangles: the tessellations differ (a grid against two triangle lattices), the
    surfaces agree to the interpolation error of the two meshes."""
    d = _displacement(rng, size=8, scale=0.15, resolution=4)
    mat = tx.Material(diffuse=(0.8, 0.7, 0.6), displacement=d)
    cam = tx.Camera(eye=(0.2, -1.5, 1.6), look_at=(0, 0, 0.05), fov_y=50)
    light = [tx.PointLight((1, -2, 4), (30, 30, 30))]
    quad = tx.Scene(camera=cam, lights=light, objects=[tx.Quad(*QUAD, material=mat, name="q")])
    mesh = tx.Scene(camera=cam, lights=light, objects=[
        tx.Mesh(QUAD, np.array([[0, 1, 2], [0, 2, 3]]), uvs=QUAD_UV, normals=np.tile([0, 0, 1.0], (4, 1)),
                material=mat, name="m")])
    a = tx.render(quad, 64, 48, 1, device=device, jitter=False, aovs=("depth",), cache=False)
    b = tx.render(mesh, 64, 48, 1, device=device, jitter=False, aovs=("depth",), cache=False)
    da, db = a.aov["depth"][..., 0], b.aov["depth"][..., 0]
    hit = np.isfinite(da) & np.isfinite(db)
    assert hit.mean() > 0.5 and np.mean(np.isfinite(da) != np.isfinite(db)) < 0.01
    # depth: within 1% of the quad's tessellation (both are piecewise-linear fits of one surface)
    assert np.quantile(np.abs(da[hit] - db[hit]) / da[hit], 0.99) < 0.01
    assert np.mean(np.abs(a.rgb - b.rgb)) < 0.02


def test_a_closed_mesh_stays_closed(rng, device):
    """Edges of different levels meet without a crack: every edge of the tessellated
    octahedron is shared by two triangles, and rays from inside aimed at the original
    edges, their ends and the faces all hit it."""
    p, f, uv = _octahedron()
    d = _displacement(rng, size=16, scale=0.1, resolution=3)
    mesh = tx.Mesh(p, f, uvs=uv, material=tx.Material(displacement=d), name="octa")
    t = tessellate_mesh(mesh)
    counts = _edges(t.faces)
    assert np.all(counts == 2), np.bincount(counts)
    assert len(np.unique(np.sort(t.faces, 1), axis=0)) == len(t.faces)     # no triangle twice
    assert len(t.faces) > 8 * 16
    # rays from the centre toward every original edge's points and every vertex
    e = np.array([[0, 2], [2, 1], [1, 3], [3, 0], [0, 4], [1, 4], [2, 4], [3, 4], [0, 5], [1, 5], [2, 5], [3, 5]])
    s = np.linspace(0, 1, 97)[:, None, None]
    targets = ((1 - s) * p[e[:, 0]] + s * p[e[:, 1]]).reshape(-1, 3)
    dirs = targets / np.linalg.norm(targets, axis=1, keepdims=True)
    dirs = np.concatenate([dirs, rng.normal(size=(2000, 3))])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    scene = tx.Scene(camera=tx.Camera(), objects=[mesh], ambient=(0.1, 0.1, 0.1))
    hits = Tracer(scene, device).closest(np.zeros(3), dirs.astype(np.float32))
    assert np.all(hits.prim >= 0), f"{np.sum(hits.prim < 0)} rays of {len(dirs)} escaped"


def test_levels_follow_each_triangles_texels(rng):
    """Each triangle is cut to its own texels: a large one finely, a small one of the
    same mesh coarsely (its longest edge's cuts, squared)."""
    d = _displacement(rng, size=32, scale=0.05)
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [3, 0, 0], [3.05, 0, 0], [3, 0.05, 0]], float)
    f = np.array([[0, 1, 2], [3, 4, 5]])
    uv = (p[:, :2] % 3) * 0.9 + 0.05
    m = tx.Mesh(p, f, uvs=uv, normals=np.tile([0, 0, 1.0], (6, 1)), material=tx.Material(displacement=d))
    t = tessellate_mesh(m)
    small = np.all(t.positions[t.faces][..., 0] > 2, axis=1)
    big = int(np.ceil(np.hypot(0.9 * 32, 0.9 * 32)))                  # the large one's hypotenuse: 41 cuts
    little = int(np.ceil(np.hypot(0.045 * 32, 0.045 * 32)))           # the small one's: 3
    assert np.sum(small) <= little ** 2 and np.sum(small) >= little
    assert big ** 2 // 2 < np.sum(~small) <= big ** 2
    assert np.all(_edges(t.faces) <= 2)


def test_mixed_materials_and_errors(rng):
    d = _displacement(rng)
    plain, bumpy = tx.Material(diffuse=(0.5, 0.5, 0.5)), tx.Material(displacement=d)
    m = tx.Mesh(QUAD, np.array([[0, 1, 2], [0, 2, 3]]), uvs=QUAD_UV, material=[plain, bumpy],
                material_ids=np.array([0, 1]), name="half")
    t = tessellate_mesh(m)
    assert set(np.unique(t.material_ids)) == {0, 1}
    flat = t.faces[t.material_ids == 0]
    assert np.all(t.positions[np.unique(flat[~np.isin(flat, t.faces[t.material_ids == 1])]), 2] == 0)
    from texray.compile import compile_scene
    cs = compile_scene(tx.Scene(objects=[m]))               # the undisplaced half stays, the other is cut
    assert len(cs.tri_verts) == len(t.faces)
    with pytest.raises(tx.SceneError, match="nouv: uvs: displacement reads the height texture"):
        tessellate_mesh(tx.Mesh(QUAD, np.array([[0, 1, 2]]), material=bumpy, name="nouv"))
    inst = tx.Instance(tx.Mesh(QUAD, np.array([[0, 1, 2]]), uvs=QUAD_UV, material=bumpy, name="src"),
                       tx.Transform(translate=(0, 0, 1)))
    with pytest.raises(tx.SceneError, match="an instanced mesh is not displaced"):
        compile_scene(tx.Scene(objects=[inst]))
    huge = tx.Displacement(tx.Texture(np.zeros((4096, 4096, 1), np.float32), name="big"), method="tessellate",
                           resolution=4)
    many = tx.Mesh(np.concatenate([QUAD] * 4200), np.arange(12600).reshape(-1, 3),      # 4200 x 256^2 > 2^24
                   uvs=np.concatenate([QUAD_UV] * 4200), material=tx.Material(displacement=huge), name="many")
    with pytest.raises(tx.SceneError, match=r"many: .*more than \d+"):
        tessellate_mesh(many)
    assert MAX_LEVEL == 256


def test_a_displaced_uv_sphere_mesh_matches_the_displaced_sphere(rng, device):
    """A fine UV-sphere mesh made from the sphere's own parameterization (uvs = the
    sphere's (u, v)), displaced by tessellation, against the analytic sphere's exact
    per-pixel search with the same height field: the same first hits (measured: 0.03%
    of the pixels differ in hit/miss at the silhouette, depth within 0.15% at the 99th
    percentile; tolerances 1% and 1%)."""
    h = rng.random((16, 32)).astype(np.float32)[:, :, None]
    cam = tx.Camera(eye=(0, 0.5, 3.5), look_at=(0, 0, 0), fov_y=35)
    sph = tx.Sphere(radius=1.0, name="s", material=tx.Material(
        displacement=tx.Displacement(tx.Texture(h, name="h"), scale=0.08, method="search")))
    mesh = uv_sphere_mesh(sph, tx.Material(displacement=tx.Displacement(tx.Texture(h, name="h"), scale=0.08,
                                                                        method="tessellate", resolution=2)))
    da, db = (tx.render(tx.Scene(camera=cam, objects=[o], ambient=(1, 1, 1)), 96, 72, 1, device=device,
                        jitter=False, aovs=("depth",), cache=False).aov["depth"][..., 0] for o in (sph, mesh))
    hit = np.isfinite(da) & np.isfinite(db)
    assert hit.mean() > 0.3 and np.mean(np.isfinite(da) != np.isfinite(db)) < 0.01
    assert np.quantile(np.abs(da[hit] - db[hit]) / da[hit], 0.99) < 0.01


def test_the_bench_sweeps_a_displaced_mesh_by_its_tessellation():
    """A scene with a displaced triangle mesh gets the tessellation series, the search's
    (tests/render/test_mesh_search.py) and maxmip's (tests/render/test_mesh_maxmip.py); a quad
    scene keeps every method."""
    from texray.bench import sweep
    from texray.bench.suite import suite_paths
    mesh = tx.Scene.load(suite_paths(["mesh_terrain"])["mesh_terrain"])
    quad = tx.Scene.load(suite_paths(["terrain"])["terrain"])
    series = dict(sweep.displacement_series(mesh))
    assert [kw["resolution"] for _, kw in series["tessellate"]] == list(sweep.DISP_TESSELLATIONS)
    assert "maxmip" in series and "search M=8" in series
    assert {n for n, _ in sweep.displacement_series(quad)} >= {"search M=0", "maxmip", "tessellate"}
