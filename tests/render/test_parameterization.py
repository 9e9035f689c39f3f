"""Each shape's parameterization is written once (kernels/geometry/*.h) and every stage
that needs it calls it: a displaced surface reports the texture coordinates and the
tangents dP/du, dP/dv of its base shape.

The regression it guards against: a displaced quad (Displacement "search" or "maxmip")
interpolated its corner uvs itself and reported dP/du, dP/dv with respect to the
patch's own (u, v), not to those texture coordinates. With uvs scaled x2 a flat
(scale = 0) displaced quad reported dpdu (2, 0, 0) where the plain quad reports
(1, 0, 0), and the ray differentials made from it read a MIP level one too fine.
"""
import numpy as np
import pytest

import texray as tx

CORNERS = ((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1))     # u along +x, v along -z, n = +y
UVS_X2 = ((0, 0), (2, 0), (2, 2), (0, 2))
W, H = 48, 36


def _checker(n=64, cells=16):
    i = np.arange(n) // (n // cells)
    a = ((i[:, None] + i[None, :]) % 2).astype(np.float32)
    return np.repeat(a[..., None], 3, axis=-1)


def _scene(displacement, uvs, diffuse=(0.7, 0.7, 0.7)):
    s = tx.Scene(camera=tx.Camera(eye=(0.2, 1.5, 2.5), look_at=(0, 0, 0)),
                 lights=[tx.PointLight(position=(1, 4, 2), intensity=(20, 20, 20))])
    s.add(tx.Quad(*CORNERS, uvs=uvs, material=tx.Material(diffuse=diffuse, displacement=displacement)))
    return s


def _flat(method):
    heights = tx.Texture.from_array(np.random.default_rng(1).random((8, 8, 1)).astype(np.float32))
    return tx.Displacement(heights, scale=0.0, method=method)


@pytest.mark.parametrize("method", ["search", "maxmip"])
def test_flat_displaced_quad_reports_the_plain_quads_tangents_and_uv(device, method):
    aovs = ("dpdu", "dpdv", "uv")
    plain = tx.render(_scene(None, UVS_X2), W, H, device=device, aovs=aovs, jitter=False).aov
    disp = tx.render(_scene(_flat(method), UVS_X2), W, H, device=device, aovs=aovs, jitter=False).aov
    both = ~np.isnan(plain["uv"][..., 0]) & ~np.isnan(disp["uv"][..., 0])
    assert both.sum() > 0.3 * W * H
    # The plain quad: uv = 2 (u, v), so dP/ds = (P1 - P0) / 2 = (1, 0, 0), dP/dt = (P3 - P0) / 2.
    np.testing.assert_array_equal(plain["dpdu"][both], np.broadcast_to([1.0, 0.0, 0.0], (both.sum(), 3)))
    np.testing.assert_array_equal(plain["dpdv"][both], np.broadcast_to([0.0, 0.0, -1.0], (both.sum(), 3)))
    # Exactly the same tangents (this corner-aligned quad's edges are exact in float32) ...
    np.testing.assert_array_equal(disp["dpdu"][both], plain["dpdu"][both])
    np.testing.assert_array_equal(disp["dpdv"][both], plain["dpdv"][both])
    # ... and uv interpolated by the same function from the hit's (u, v), which the two
    # intersections (Reshetov's patch test; the displaced surface's dual basis) find to
    # float32 rounding: measured within 1.5 ulp of 2 (3.6e-7), allowed 4 ulp.
    np.testing.assert_allclose(disp["uv"][both], plain["uv"][both], rtol=0, atol=1e-6)


@pytest.mark.parametrize("method", ["search", "maxmip"])
def test_flat_displaced_quad_reads_the_plain_quads_mip_level(device, method):
    """Trilinear filtering picks its level from dP/du, dP/dv: with the tangents of the
    patch's (u, v) the displaced quad read a level one too fine (a sharper checker)."""
    tex = tx.Texture.from_array(_checker(), filter="trilinear")
    plain = tx.render(_scene(None, UVS_X2, tex), W, H, device=device, jitter=False).rgb
    disp = tx.render(_scene(_flat(method), UVS_X2, tex), W, H, device=device, jitter=False).rgb
    # Same level, texels and weights up to the hit point's float32 rounding (measured
    # 4e-6; one level off differed by 0.37).
    np.testing.assert_allclose(disp, plain, rtol=0, atol=1e-4)


def test_unit_uvs_keep_the_patch_tangents(device):
    """With the default uvs (uv = (u, v)) the texture tangents are the patch's own:
    the displaced quad's edges, exactly, as before."""
    aovs = ("dpdu", "dpdv")
    unit = ((0, 0), (1, 0), (1, 1), (0, 1))
    disp = tx.render(_scene(_flat("maxmip"), unit), W, H, device=device, aovs=aovs, jitter=False).aov
    hit = ~np.isnan(disp["dpdu"][..., 0])
    assert hit.sum() > 0.3 * W * H
    np.testing.assert_array_equal(disp["dpdu"][hit], np.broadcast_to([2.0, 0.0, 0.0], (hit.sum(), 3)))
    np.testing.assert_array_equal(disp["dpdv"][hit], np.broadcast_to([0.0, 0.0, -2.0], (hit.sum(), 3)))


def _curved_scene(shape, displacement):
    s = tx.Scene(camera=tx.Camera(eye=(0.4, -3.0, 1.2), look_at=(0, 0, 0.3)),
                 lights=[tx.PointLight(position=(2, -4, 3), intensity=(20, 20, 20))])
    material = tx.Material(displacement=displacement)
    if shape == "sphere":
        s.add(tx.Sphere(center=(0, 0, 0.3), radius=0.8, axis_x=(0.6, 0.8, 0.0), material=material))
    else:
        s.add(tx.Cylinder(radius=0.7, z_range=(-0.4, 1.0), theta_range=(-30.0, 300.0), material=material))
    return s


@pytest.mark.parametrize("shape", ["sphere", "cylinder"])
def test_flat_displaced_curved_shapes_report_their_base_parameterization(device, shape):
    """The displaced sphere and cylinder take uv (the search's (u, v)) and dP/du, dP/dv
    (at the displaced radius, here the base radius) from sphere.h's and cylinder.h's
    functions: with scale = 0 they match the plain shape's AOVs to the float32 rounding
    of the two hit points (the displaced one is found by a search), away from the
    silhouette and the u = 0 / 1 seam. Measured: uv within 1.0e-6, the tangents within
    7e-6 of their length; allowed 10x that."""
    aovs = ("dpdu", "dpdv", "uv", "normal")
    heights = tx.Texture.from_array(np.random.default_rng(2).random((8, 8, 1)).astype(np.float32))
    disp = tx.Displacement(heights, scale=0.0, method="search", steps=64, refine=16)
    plain = tx.render(_curved_scene(shape, None), W, H, device=device, aovs=aovs, jitter=False).aov
    flat = tx.render(_curved_scene(shape, disp), W, H, device=device, aovs=aovs, jitter=False).aov
    both = ~np.isnan(plain["uv"][..., 0]) & ~np.isnan(flat["uv"][..., 0])
    facing = np.abs(np.sum(plain["normal"] * np.array([0.4, -3.0, 0.9]) / 3.2, axis=-1)) > 0.3
    inner = (plain["uv"][..., 0] > 0.02) & (plain["uv"][..., 0] < 0.98)
    sel = both & np.nan_to_num(facing) & np.nan_to_num(inner)
    assert sel.sum() > 0.1 * W * H
    np.testing.assert_allclose(flat["uv"][sel], plain["uv"][sel], rtol=0, atol=1e-5)
    for k in ("dpdu", "dpdv"):
        length = np.linalg.norm(plain[k][sel], axis=-1, keepdims=True)
        np.testing.assert_allclose(flat[k][sel] / length, plain[k][sel] / length, rtol=0, atol=7e-5)
