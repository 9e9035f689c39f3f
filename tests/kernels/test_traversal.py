"""Closest-hit and any-hit traversal on the device against float64 brute force,
and watertightness of the ray/triangle test on shared edges and vertices."""
import numpy as np
import pytest
import trimesh

import texray as tx
from texray.renderer.trace import Tracer
from reference import intersect


def _soup_scene(rng, n=2000):
    centers = rng.uniform(-1, 1, (n, 1, 3))
    pts = centers + rng.normal(0, 0.08, (n, 3, 3))
    scene = tx.Scene()
    scene.add(tx.Mesh(pts.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3), name="soup"))
    return scene


def _sphere_scene(subdivisions=4):
    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    scene = tx.Scene()
    scene.add(tx.Mesh(np.asarray(s.vertices), np.asarray(s.faces), name="icosphere"))
    return scene, s


def _random_rays(rng, n):
    org = rng.uniform(-2.5, 2.5, (n, 3))
    target = rng.uniform(-1, 1, (n, 3))
    return org, target - org


def _check_against_brute_force(tracer, org, d):
    cs = tracer.compiled
    p0, p1, p2 = (cs.tri_verts[k].astype(np.float64) for k in ("p0", "p1", "p2"))
    ref_t, rb1, rb2, ref_prim = intersect(org, d, p0, p1, p2)
    hits = tracer.closest(org.astype(np.float32), d.astype(np.float32))
    got_hit, ref_hit = hits.prim >= 0, ref_prim >= 0
    # Disagreement about hitting at all is only allowed within float32 rounding of an edge.
    margin = np.minimum(np.minimum(rb1, rb2), 1 - rb1 - rb2)
    disagree = got_hit != ref_hit
    assert np.all(np.abs(margin[disagree]) < 1e-4), \
        f"{disagree.sum()} rays disagree on hit/miss away from edges, e.g. ray {np.flatnonzero(disagree)[:3]}"
    both = got_hit & ref_hit
    # t: float32 ray/triangle arithmetic against float64; relative 1e-5 of the ray length scale.
    scale = np.linalg.norm(d, axis=1) * (np.linalg.norm(org, axis=1) + 2)
    t_err = np.abs(hits.t[both] - ref_t[both]) * np.linalg.norm(d[both], axis=1)
    assert np.all(t_err <= 1e-5 * scale[both]), f"worst t error {t_err.max():.3g}"
    same = hits.prim[both] == ref_prim[both]
    # A different primitive is fine only when it is at the same distance (a tie on a shared edge).
    assert np.all(same | (t_err <= 1e-5 * scale[both])), "closest hit is not the closest"
    assert both.sum() > 1000, "too few hits to test anything"
    return hits


def test_closest_hit_matches_brute_force_on_random_soup(device, rng):
    scene = _soup_scene(rng)
    org, d = _random_rays(rng, 10_000)
    _check_against_brute_force(Tracer(scene, device), org, d)


def test_closest_hit_matches_brute_force_on_closed_mesh(device, rng):
    scene, _ = _sphere_scene(3)
    org, d = _random_rays(rng, 10_000)
    _check_against_brute_force(Tracer(scene, device), org, d)


def test_closest_hit_matches_brute_force_on_real_mesh(device, rng, scenes_dir):
    scene = tx.Scene()
    scene.add(tx.Mesh.load(scenes_dir / "meshes" / "vase.obj", transform=tx.Transform(translate=(0, -0.5, 0))))
    org, d = _random_rays(rng, 10_000)
    _check_against_brute_force(Tracer(scene, device), org, d)


def test_any_hit_agrees_with_closest_hit(device, rng):
    scene = _soup_scene(rng, 1000)
    tracer = Tracer(scene, device)
    org, d = _random_rays(rng, 10_000)
    closest = tracer.closest(org.astype(np.float32), d.astype(np.float32))
    occ, _ = tracer.occluded(org.astype(np.float32), d.astype(np.float32), 0.0, 1.0)
    np.testing.assert_array_equal(occ, (closest.prim >= 0) & (closest.t < 1.0))


def test_rays_at_shared_edges_and_vertices_never_pass_through(device, rng):
    """Woop et al.'s guarantee: a ray aimed exactly at a shared edge or vertex of a closed
    mesh, which enters the solid there, hits one of the triangles that share it.

    From outside, only targets whose every adjacent face faces the ray count: at a
    silhouette vertex or edge the ray merely grazes the solid and may legitimately
    pass beside it by the rounding of the target itself."""
    scene, mesh = _sphere_scene(4)
    tracer = Tracer(scene, device)
    v = np.asarray(mesh.vertices, np.float32)
    faces = np.asarray(mesh.faces)
    fn = np.asarray(mesh.face_normals)
    # Faces around each vertex (valence padded by repeating a face) and on each interior edge.
    vert_of = faces.ravel()
    face_of = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(vert_of, kind="stable")
    valence = np.bincount(vert_of, minlength=len(v))
    start = np.concatenate([[0], np.cumsum(valence)[:-1]])
    k = valence.max()
    cols = np.minimum(np.arange(k)[None, :], valence[:, None] - 1) + start[:, None]
    vertex_faces = face_of[order][cols]
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, inverse = np.unique(e, axis=0, return_inverse=True)
    by_edge = np.argsort(inverse.ravel(), kind="stable").reshape(-1, 2)     # closed mesh: 2 faces per edge
    edge_faces = face_of[by_edge]
    edges = e[by_edge[:, 0]]
    # Edge points 1% of the edge or more from its ends: nearer, the rounded target may lie
    # beyond a silhouette vertex, which only the vertex's own faces test covers.
    lam = rng.uniform(0.01, 0.99, (len(edges), 1)).astype(np.float32)
    on_edges = v[edges[:, 0]] + lam * (v[edges[:, 1]] - v[edges[:, 0]])
    targets = np.concatenate([v, on_edges]).astype(np.float32)
    adjacent = np.concatenate([vertex_faces, edge_faces[:, [0, 1] * (k // 2) + [0] * (k % 2)]])
    for name, org in (("outside", rng.uniform(-4, 4, (len(targets), 3)).astype(np.float32)),
                      ("centre", np.zeros((len(targets), 3), np.float32)),
                      ("inside", rng.uniform(-0.3, 0.3, (len(targets), 3)).astype(np.float32))):
        d = targets - org
        hits = tracer.closest(org, d)
        cosines = np.einsum("rk,rak->ra", d / np.linalg.norm(d, axis=1, keepdims=True), fn[adjacent])
        enters = np.all(cosines < -1e-3, axis=1) if name == "outside" else np.ones(len(d), bool)
        assert enters.sum() > 0.3 * len(d)
        missed = np.flatnonzero((hits.prim < 0) & enters)
        assert missed.size == 0, (f"{name}: {missed.size} rays slipped through, e.g. org "
                                  f"{org[missed[0]].tolist()} dir {d[missed[0]].tolist()}")


def test_axis_aligned_rays_with_zero_direction_components(device):
    """Directions like (0, -1, 0) and (-0.0, 0, 1): the slab test must not produce NaN."""
    p = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], float)
    scene = tx.Scene()
    scene.add(tx.Mesh(p, np.array([[0, 2, 1], [0, 3, 2]]), name="floor"))
    tracer = Tracer(scene, device)
    org = np.array([[0.25, 1, 0.5], [0.25, -1, 0.5], [0, 1, 0], [1, 1, 1]], np.float32)
    d = np.array([[0, -1, 0], [-0.0, 1, 0.0], [0, -2, 0], [0, -1, 0]], np.float32)
    hits = tracer.closest(org, d)
    np.testing.assert_allclose(hits.t, [1, 1, 0.5, 1], rtol=1e-6)
    assert np.all(hits.prim >= 0)


def test_empty_scene_misses_everything(device):
    tracer = Tracer(tx.Scene(), device)
    hits = tracer.closest(np.zeros((4, 3), np.float32), np.eye(4, 3, dtype=np.float32) + 0.1)
    assert np.all(hits.prim == -1) and np.all(np.isinf(hits.t))


def _lattice_squares(rng, n, size=4):
    """n unit squares (two triangles each) in the planes x, y or z = integer, on an integer lattice."""
    axis = rng.integers(0, 3, n)
    corner = rng.integers(0, size, (n, 3)).astype(float)
    quad = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    pts = np.zeros((n, 4, 3))
    for a in range(3):                       # three axes, not per square
        u, v = [k for k in range(3) if k != a]
        sel = axis == a
        pts[sel] = corner[sel, None, :]
        pts[sel, :, u] += quad[:, 0]
        pts[sel, :, v] += quad[:, 1]
    faces = np.arange(4 * n).reshape(n, 4)[:, [[0, 1, 2], [0, 2, 3]]].reshape(-1, 3)
    return pts.reshape(-1, 3), faces


@pytest.mark.parametrize("n", [1, 2, 3, 40])
def test_axis_parallel_rays_through_wide_nodes_match_brute_force(device, n):
    """Rays along the axes, with zero direction components of either sign, into wide
    nodes with empty lanes (n = 1, 2, 3 squares: 2-6 triangles) and full ones. The
    other two coordinates of the origin are integers or half-integers: an integer one
    lies exactly on box faces of the tree along an axis the ray is parallel to, the
    case the slab test's exact parallel-ray path decides. Such a ray meets squares on
    their edges, which the watertight test includes, as the float64 brute force does
    (integer coordinates: every edge function is exactly 0 in both); which of two
    squares sharing the edge is hit is left open, so squares are compared only for
    rays through square interiors.
    """
    rng = np.random.default_rng(n)
    p, f = _lattice_squares(rng, n)
    scene = tx.Scene()
    scene.add(tx.Mesh(p, f, name="squares"))
    tracer = Tracer(scene, device)
    g = np.arange(-1, 6)
    h = np.concatenate([g, g + 0.5])
    org, d = [], []
    for a in range(3):
        u, v = [k for k in range(3) if k != a]
        for s in (1.0, -1.0):
            o = np.stack(np.meshgrid(g, h, h, indexing="ij"), -1).reshape(-1, 3)
            o = o[:, np.argsort([a, u, v])]
            dd = np.zeros_like(o)
            dd[:, a] = s
            signs = rng.choice([-1.0, 1.0], (len(o), 3))
            dd = np.where(dd == 0, 0.0 * signs, dd)          # +0.0 and -0.0
            org.append(o)
            d.append(dd)
    org, d = np.concatenate(org), np.concatenate(d)
    assert np.signbit(d[d == 0]).any() and (~np.signbit(d[d == 0])).any()
    cs = tracer.compiled
    p0, p1, p2 = (cs.tri_verts[k].astype(np.float64) for k in ("p0", "p1", "p2"))
    ref_t, _, _, ref_prim = intersect(org, d, p0, p1, p2)
    hits = tracer.closest(org.astype(np.float32), d.astype(np.float32))
    np.testing.assert_array_equal(hits.prim >= 0, ref_prim >= 0)
    hit = ref_prim >= 0
    assert hit.sum() >= 3 * n, hit.sum()
    np.testing.assert_allclose(hits.t[hit], ref_t[hit], rtol=1e-6)
    # Same square where the ray meets its interior (at its centre, on the diagonal its
    # two triangles share, so either triangle is right); faces 2k, 2k + 1 make square k.
    interior = hit & np.all(np.abs(org - np.round(org)) == 0.5, axis=1, where=d == 0)
    assert interior.any()
    face = cs.tri_shade["prim"].astype(np.int64)
    np.testing.assert_array_equal(face[hits.prim[interior]] // 2, face[ref_prim[interior]] // 2)
    occ, _ = tracer.occluded(org.astype(np.float32), d.astype(np.float32), 0.0, 2.5)
    np.testing.assert_array_equal(occ, hit & (ref_t < 2.5))
