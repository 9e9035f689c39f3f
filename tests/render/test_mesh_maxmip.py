"""Displaced triangle meshes, method="maxmip" (disp_maxmip_mesh in kernels/geometry/displace.h:
each triangle's prism shell subdivided into sub-prisms bounded by the min-max pyramid over
their uv footprints, traversed front to back, half-texel leaves clipped exactly and searched).

What each test guards against:
* the flat two-triangle mesh against the float64 root finder and the displaced quad's
  (exact) maxmip, rays from 70 down to 4 degrees above the plane: the sub-triangles'
  bounds, the hull slabs, the leaves' exact clip (disp_tri_clip on a sub-triangle) and the
  hand-over between leaves and between the two shells;
* one-texel spikes: the traversal only skips what cannot hold a root, where a coarse
  search misses spikes;
* a fine UV-sphere mesh against the analytic displaced sphere's maxmip: varying vertex
  normals (the sub-prisms' hulls widen, the cubic inversion);
* rays at the shared edges and vertices of a closed mesh: no hole between shells, nor
  between sub-prisms;
* a grazing light: shadow rays traverse the same shells (self-shadowing) as the quad's;
* AOVs; the feature flag compiles the traversal only for scenes that use it; NaN rays.
"""
import numpy as np
import pytest

import texray as tx
from texray.compile import compile_scene
from texray.renderer.trace import Tracer
from disp_reference import CORNERS, one_texel_spikes, height_texture, quad_reference, trace_each
from test_mesh_search import (_flat_mesh, _grazing_rays, _scene, _sines, assert_aovs_as_the_quads,
                              assert_closed_octahedron_has_no_hole, assert_shadows_as_the_quads,
                              assert_uv_sphere_mesh_as_the_sphere)

# Relative hit distance of the mesh's maxmip against the quad's maxmip (an exact quadratic per
# texel cell): measured 5.0e-7 at the 99th percentile from 70 to 4 degrees (1.1e-5 at most, one
# ray at 20 degrees): the leaves' secant step after 4 bisections of a quarter of a half-texel segment.
T_QUAD = 4e-6
# ... and against the float64 root finder (20000 samples per ray, then bisection): measured
# 6.2e-6 at the 99th percentile, the reference's own error (the quad's maxmip is as far from it).
T_REF = 3e-5


def _maxmip(tex, scale=0.2):
    return tx.Displacement(tex, scale=scale, method="maxmip")


@pytest.mark.parametrize("elevation", [70, 45, 20, 10, 4])
def test_a_flat_two_triangle_mesh_is_the_displaced_quads_maxmip(device, elevation):
    """Every ray hits (both methods, and the reference) and the hit distances agree within
    T_QUAD of the quad's maxmip and T_REF of the float64 root on 99% of the rays."""
    d = _maxmip(_sines())
    orgs, dirs = _grazing_rays(elevation)
    tm, b = trace_each(Tracer(_scene(_flat_mesh(d)), device), orgs, dirs)
    tq, _ = trace_each(Tracer(_scene(tx.Quad(*CORNERS, material=tx.Material(displacement=d))), device), orgs, dirs)
    tr, _ = quad_reference(d, orgs, dirs, samples=20000)
    assert np.mean(np.isnan(tm) == np.isnan(tr)) >= 0.99 and np.mean(np.isnan(tm) == np.isnan(tq)) >= 0.99
    assert np.mean(~np.isnan(tm)) > 0.9
    both = ~np.isnan(tm) & ~np.isnan(tq)
    rel = np.abs(tm[both] - tq[both]) / tq[both]
    assert np.mean(rel <= T_QUAD) >= 0.99, (elevation, np.quantile(rel, 0.99))
    both = ~np.isnan(tm) & ~np.isnan(tr)
    rel = np.abs(tm[both] - tr[both]) / tr[both]
    assert np.mean(rel <= T_REF) >= 0.99, (elevation, np.quantile(rel, 0.99))
    assert np.all((b[~np.isnan(tm)] >= 0) & (b[~np.isnan(tm)] <= 1))     # the hits' barycentrics


def test_maxmip_never_misses_one_texel_spikes(device):
    """One-texel spikes on a flat map under the two-triangle mesh; rays at 8 degrees aimed
    just below each spike's top: maxmip hits every one, at the quad maxmip's t (within
    T_QUAD), where a coarse search (N = 4) misses some."""
    a, u, v = one_texel_spikes()
    p = np.column_stack([2 * u - 1, np.zeros_like(u), 1 - 2 * v])
    t = np.array([np.cos(0.3), 0.0, np.sin(0.3)])
    dirs = np.broadcast_to(np.cos(np.radians(8)) * t - np.sin(np.radians(8)) * np.array([0, 1.0, 0]), p.shape).copy()
    orgs = p + [0, 0.09, 0] - 0.8 * dirs
    found = {}
    for method, steps in (("maxmip", 1), ("search", 4)):
        d = tx.Displacement(height_texture(a), scale=0.1, method=method, steps=steps)
        th, _ = trace_each(Tracer(_scene(_flat_mesh(d)), device), orgs, dirs)
        found[method] = ~np.isnan(th)
        if method == "maxmip":
            tq, _ = trace_each(Tracer(_scene(tx.Quad(*CORNERS, material=tx.Material(displacement=d))), device),
                               orgs, dirs)
            assert not np.isnan(tq).any()
            np.testing.assert_allclose(th, tq, rtol=T_QUAD)
    assert found["maxmip"].all()
    assert not found["search"].all()


def test_a_displaced_uv_sphere_mesh_matches_the_displaced_sphere(rng, device):
    """A 128 x 64 UV-sphere mesh from the sphere's own parameterization (uvs = the sphere's
    (u, v), its unit normals) against the analytic sphere, both by maxmip: measured 0.014% of
    the pixels differ in hit/miss (the silhouette), depth within 0.11% at the 99th percentile
    (the chords' sagitta, 3e-4, and N not renormalized, 1e-4 of H: the search's 0.12%);
    tolerances 0.5% and 0.5%."""
    assert_uv_sphere_mesh_as_the_sphere(rng, device, method="maxmip")


def test_the_shared_edges_of_a_closed_mesh_leave_no_hole(rng, device):
    """Rays from the centre and from outside aimed at 97 points of every edge (its ends, the
    vertices, included) and at random directions: every one hits the displaced octahedron
    (vertex normals 55 degrees from the faces' normals: rays from the centre toward an edge
    lie in the side patches of both shells, and of the sub-prisms along it), and from
    outside no nearer than the shell's outer bound allows."""
    assert_closed_octahedron_has_no_hole(rng, device, method="maxmip")


def test_self_shadowing_matches_the_displaced_quad(device):
    """A light 8 degrees above the horizon over the displaced square: the mesh's shadow rays
    traverse its shells (any hit) as the quad's maxmip its slab. The two images agree (below
    0.5% of the pixels off by more than 0.05; measured 0.0%), and the relief does cast
    shadows (over 10% of the lit square's pixels are darker than without shadow rays)."""
    assert_shadows_as_the_quads(device, _maxmip(_sines(24, k=2.0), scale=0.25))


def test_aovs_report_the_displaced_hit(device):
    """Position on the height field over the reported uv, primitive_id the face that holds
    it, object_id the mesh, normal and depth the quad maxmip's."""
    m, q, hit = assert_aovs_as_the_quads(device, _maxmip(_sines()))
    both = hit & np.isfinite(q["depth"][..., 0])
    assert np.array_equal(hit, np.isfinite(q["depth"][..., 0]))
    assert np.quantile(np.abs(m["depth"][both] - q["depth"][both])[..., 0] / q["depth"][both][..., 0], 0.99) < 1e-5


def test_the_traversal_is_compiled_only_where_used_and_nan_rays_miss(device):
    """Features.displaced_mesh_maxmip (TX_DISP_MAXMIP_MESH) is set for a maxmip mesh only
    (a searched mesh and a maxmip quad keep their programs); NaN and zero-direction rays
    miss the maxmip shells."""
    tex = _sines(16)
    mm = compile_scene(_scene(_flat_mesh(_maxmip(tex))))
    assert mm.features.displaced_mesh_maxmip and mm.features.displaced_meshes
    search = compile_scene(_scene(_flat_mesh(tx.Displacement(tex, scale=0.2))))
    quad = compile_scene(_scene(tx.Quad(*CORNERS, material=tx.Material(displacement=_maxmip(tex)))))
    assert not search.features.displaced_mesh_maxmip and not quad.features.displaced_mesh_maxmip
    tracer = Tracer(_scene(_flat_mesh(_maxmip(tex))), device)
    orgs = np.array([[0, 1.0, 0], [np.nan, 1, 0], [0, 1, 0], [0, 1, 0]])
    dirs = np.array([[0, -1.0, 0], [0, -1, 0], [np.nan, -1, 0], [0, 0, 0]])
    t, _ = trace_each(tracer, orgs, dirs)
    assert not np.isnan(t[0]) and np.isnan(t[1:]).all()


def test_flat_topped_shells_of_a_curved_mesh(device):
    """scenes/displacement/torus_search.toml by maxmip against the search (N = 256, M = 10) on
    3000 rays from its camera: hit and miss agree on 99.5%, t within 1e-4 on 99.5% (measured:
    all hit alike, 2 rays of 15000 where maxmip is nearer: a crest the search at N = 512
    skips, N = 4096 finds). Its bricks' tops are flat at the map's maximum, so many shells
    have slo = shi: their leaves' tops and bottoms then lie within rounding of the shell's
    entry A and exit B, and a leaf clipped to the open interval (A, B) lost both crossings
    (6% of the hits fell through to the far side of the tube; the first ray below, which
    hits the top of a brick at t = 2.6417); the leaves are clipped on the ray's (tmin, tmax)."""
    from pathlib import Path
    s = tx.Scene.load(Path(__file__).resolve().parents[2] / "scenes" / "displacement" / "torus_search.toml")
    from texray.bench import sweep
    rng = np.random.default_rng(5)
    eye = np.array(s.camera.eye, float)
    d = rng.uniform([-1, -0.3, -1], [1, 0.3, 1], (3000, 3)) - eye
    d[0] = [-0.29858990092747445, -0.513265258461926, -0.8046134758504442]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(eye, d.shape).copy()
    tm, _ = trace_each(Tracer(sweep.with_displacement(s, "maxmip"), device), o, d)
    ts, _ = trace_each(Tracer(sweep.with_displacement(s, "search", steps=256, refine=10), device), o, d)
    assert abs(tm[0] - 2.6417) < 1e-3
    assert np.mean(np.isnan(tm) == np.isnan(ts)) >= 0.995 and np.mean(~np.isnan(tm)) > 0.5
    both = ~np.isnan(tm) & ~np.isnan(ts)
    assert np.mean(np.abs(tm[both] - ts[both]) <= 1e-4 * ts[both]) >= 0.995
