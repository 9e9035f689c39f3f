"""Whole renders at the numerical extremes: far from the origin, huge and tiny scales,
grazing views, texture seams. No holes, no NaN, and texture colours that match the uv
the surface stage reports."""
import numpy as np
import pytest
import trimesh

import texray as tx
from reference import bilinear

W, H = 64, 48


def _ball_scene(kind, offset, scale, texture=None):
    """A unit ball (mesh or sphere) moved by offset and scaled, the camera moved with it."""
    c = np.array([offset, offset * 0.5, -offset * 0.25])
    mat = tx.Material(diffuse=texture) if texture is not None else tx.Material()
    scene = tx.Scene(camera=tx.Camera(eye=tuple(c + np.array([0, 0.5, 3.0]) * scale), look_at=tuple(c), fov_y=40),
                     lights=[tx.PointLight(tuple(c + np.array([2, 3, 4]) * scale), (30 * scale ** 2,) * 3)],
                     ambient=(0.05, 0.05, 0.05))
    if kind == "mesh":
        ico = trimesh.creation.icosphere(subdivisions=3)
        scene.add(tx.Mesh(np.asarray(ico.vertices), np.asarray(ico.faces), material=mat,
                          uvs=np.zeros((len(ico.vertices), 2)) if texture is not None else None,
                          transform=tx.Transform(translate=tuple(c), scale=scale), name="ball"))
    else:
        scene.add(tx.Sphere(center=tuple(c), radius=scale, material=mat, axis_z=(0, 1, 0), name="ball"))
    return scene, c


@pytest.mark.parametrize("kind", ["mesh", "sphere"])
@pytest.mark.parametrize("offset, scale", [(0.0, 1.0), (1e4, 1.0), (1e5, 1.0), (0.0, 1e-3), (0.0, 1e3),
                                           (1e2, 1e-3), (1e5, 1e3)])
def test_no_holes_no_nan_far_away_and_at_any_scale(device, kind, offset, scale):
    """Coordinates are float32 on the device: an object must span many float32 steps of its
    own position. A 1e-3 ball at 1e4 is one step (6e-4) across and cannot be rendered; the
    documented bound is size / distance from the origin >= 1e-5 (the (1e2, 1e-3) case)."""
    scene, c = _ball_scene(kind, offset, scale)
    img = tx.render(scene, W, H, device=device, aovs=("depth", "normal", "position"), jitter=False)
    assert np.all(np.isfinite(img.rgb))
    depth = img.aov["depth"][..., 0]
    hit = ~np.isnan(depth)
    # The ball's silhouette from the reference geometry: pixel-centre rays within the sphere
    # (for the mesh, within its inscribed sphere, well inside the silhouette).
    from reference import camera_rays
    org, d = camera_rays(scene, W, H)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    oc = org - c
    b = np.einsum("ij,ij->i", oc, d)
    dist2 = np.einsum("ij,ij->i", oc, oc) - b * b
    inscribed = 0.95 if kind == "mesh" else 0.99
    inside = (dist2 < (inscribed * scale) ** 2).reshape(H, W)
    assert inside.sum() > 100
    holes = inside & ~hit
    assert not holes.any(), f"{holes.sum()} holes"
    # Lit side is lit (no self-shadowing acne): normals facing the light get more than ambient.
    lit = hit & (img.rgb[..., 0] > 0.05 * 0.8 + 1e-3)
    n = img.aov["normal"][hit].astype(np.float64)
    to_light = np.asarray(scene.lights[0].position) - img.aov["position"][hit]
    to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
    facing = np.einsum("ij,ij->i", n, to_light) > 0.1
    assert lit[hit][facing].mean() > 0.99, f"{(~lit[hit][facing]).sum()} dark pixels facing the light"


def test_sphere_seam_colours_match_their_uv(device):
    """Across the phi = 0/2pi seam the colour is the texture at the reported uv, not a
    blend of the whole row (the failure of naive derivative-based filtering)."""
    rng = np.random.default_rng(3)
    pixels = rng.uniform(0, 1, (16, 32, 3)).astype(np.float32)
    tex = tx.Texture.from_array(pixels)
    scene = tx.Scene(camera=tx.Camera(eye=(3, 0.3, 0.0), look_at=(0, 0, 0), fov_y=35), ambient=(1, 1, 1))
    # axis_x = (1, 0, 0) puts phi = 0 on the side facing the camera: the seam runs down the middle.
    scene.add(tx.Sphere(radius=1.0, axis_z=(0, 1, 0), axis_x=(1, 0, 0), material=tx.Material(diffuse=tex)))
    img = tx.render(scene, 96, 96, device=device, aovs=("uv",), jitter=False)
    uv = img.aov["uv"].reshape(-1, 2)
    hit = ~np.isnan(uv[:, 0])
    near_seam = hit & ((uv[:, 0] < 0.05) | (uv[:, 0] > 0.95))
    assert near_seam.sum() > 50
    expect = bilinear(tex.rgba, uv[near_seam].astype(np.float64))[:, :3]
    np.testing.assert_allclose(img.rgb.reshape(-1, 3)[near_seam], expect, atol=2e-3)


@pytest.mark.parametrize("angle", [85.0, 88.0, 89.0, 89.9])
def test_grazing_views_of_a_textured_quad(device, angle):
    """A textured floor seen at a grazing angle: every pixel below the horizon hits, the uv is
    the exact planar uv of the hit point, and the colour is the texture at that uv."""
    rng = np.random.default_rng(4)
    tex = tx.Texture.from_array(rng.uniform(0, 1, (8, 8, 3)).astype(np.float32))
    s = 1000.0
    scene = tx.Scene(camera=tx.Camera(eye=(0, 1, 0), look_at=(0, 1 - np.cos(np.radians(angle)),
                                                               -np.sin(np.radians(angle))), fov_y=0.5),
                     ambient=(1, 1, 1))
    scene.add(tx.Quad((-s, 0, s), (s, 0, s), (s, 0, -s), (-s, 0, -s), material=tx.Material(diffuse=tex)))
    img = tx.render(scene, 32, 32, device=device, aovs=("uv", "position"), jitter=False)
    pos = img.aov["position"].reshape(-1, 3).astype(np.float64)
    uv = img.aov["uv"].reshape(-1, 2).astype(np.float64)
    hit = ~np.isnan(pos[:, 0])
    assert hit.mean() > 0.3
    np.testing.assert_allclose(pos[hit, 1], 0.0, atol=1e-3)
    ref_uv = np.stack([(pos[hit, 0] + s) / (2 * s), (s - pos[hit, 2]) / (2 * s)], axis=1)
    np.testing.assert_allclose(uv[hit], ref_uv, atol=1e-4)
    expect = bilinear(tex.rgba, uv[hit])[:, :3]
    np.testing.assert_allclose(img.rgb.reshape(-1, 3)[hit], expect, atol=2e-3)
