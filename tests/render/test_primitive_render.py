"""Analytic primitives in whole renders: one BVH holding every kind, shadows between them,
AOVs, the scene-file syntax, and degenerate input (a clear error or finite pixels)."""
import numpy as np
import pytest

import texray as tx
from texray.cli import main


def _mixed_scene(textured=True):
    tex = tx.Texture.from_array(np.random.default_rng(1).uniform(0.2, 1, (16, 32, 3)).astype(np.float32))
    mat = tx.Material(diffuse=tex if textured else (0.7, 0.7, 0.7), specular=0.2, shininess=20)
    scene = tx.Scene(camera=tx.Camera(eye=(0, 2.0, 5), look_at=(0, 0.3, 0), fov_y=45),
                     lights=[tx.PointLight((0.5, 5, 1), (60, 60, 60))], ambient=(0.05, 0.05, 0.05))
    scene.add(tx.Quad((-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3), material=mat, name="floor"))
    scene.add(tx.Sphere(center=(-1.2, 0.7, 0), radius=0.7, axis_z=(0, 1, 0), material=mat, name="ball"))
    scene.add(tx.Cylinder(radius=0.4, z_range=(0, 1), theta_range=(0, 360), axis_z=(0, 1, 0), axis_x=(1, 0, 0),
                          origin=(1.2, 0, 0), material=mat, name="can"))
    p = np.array([[0, 0.2, 1.0], [0.5, 0.2, 1.0], [0.25, 0.8, 1.0]])
    scene.add(tx.Mesh(p, np.array([[0, 1, 2]]), uvs=np.array([[0, 0], [1, 0], [0.5, 1]]), material=mat, name="tri"))
    return scene


def test_every_kind_in_one_scene_with_object_ids_and_shadows(device):
    scene = _mixed_scene()
    img = tx.render(scene, 96, 72, device=device, aovs=("object_id", "uv", "normal", "dpdu", "dpdv"))
    ids = img.aov["object_id"][..., 0]
    assert set(np.unique(ids).astype(int)) == {-1, 0, 1, 2, 3}
    for name in ("uv", "normal", "dpdu", "dpdv"):
        assert np.all(np.isfinite(img.aov[name][ids >= 0])), name
    # Normals are unit; dP/du x dP/dv points along the geometric normal's line.
    n = img.aov["normal"][ids >= 0]
    np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1, atol=1e-5)
    c = np.cross(img.aov["dpdu"][ids >= 0], img.aov["dpdv"][ids >= 0])
    c /= np.linalg.norm(c, axis=-1, keepdims=True)
    assert np.all(np.abs(np.einsum("ij,ij->i", c, n)) > 0.999)
    # The ball shadows the floor under it: floor pixels straight below the ball are ambient-dark.
    below = (ids == 0) & (img.aov["uv"][..., 0] > 0)
    assert below.any()
    assert np.all(np.isfinite(img.rgb))


def test_sphere_and_cylinder_normals_point_outward(device):
    scene = _mixed_scene(textured=False)
    img = tx.render(scene, 96, 72, device=device, aovs=("object_id", "normal", "position"), jitter=False)
    ids = img.aov["object_id"][..., 0]
    pos, n = img.aov["position"], img.aov["normal"]
    ball = ids == 1
    radial = pos[ball] - np.array([-1.2, 0.7, 0])
    np.testing.assert_allclose(n[ball], radial / np.linalg.norm(radial, axis=1, keepdims=True), atol=1e-4)
    can = ids == 2
    radial = pos[can] - np.array([1.2, 0, 0])
    radial[:, 1] = 0
    np.testing.assert_allclose(n[can], radial / np.linalg.norm(radial, axis=1, keepdims=True), atol=1e-4)


@pytest.mark.parametrize("make, match", [
    (lambda: tx.Sphere(radius=0.0), r"radius: expected a number in \(0, inf\), got 0\.0"),
    (lambda: tx.Sphere(radius=-1.0), r"radius: expected a number in \(0, inf\), got -1\.0"),
    (lambda: tx.Sphere(radius=float("nan")), r"radius: expected a finite number in \(0, inf\), got nan"),
    (lambda: tx.Sphere(axis_z=(0, 0, 0)), r"axis_z: expected a non-zero vector, got \[0, 0, 0\]"),
    (lambda: tx.Sphere(axis_z=(0, 1, 0), axis_x=(0, 2, 0)), r"axis_x: .* parallel to axis_z"),
    (lambda: tx.Cylinder(theta_range=(30, 30)), r"theta_range: expected \[min, max\]"),
    (lambda: tx.Cylinder(z_range=(1, 1)), r"z_range: expected"),
    (lambda: tx.Cylinder(theta_range=(0, 400)), r"theta_range"),
    (lambda: tx.Sphere(transform=tx.Transform(scale=(1, 2, 1))), r"uniform scale only"),
    (lambda: tx.Quad((0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)), r"zero area"),
    (lambda: tx.Quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), uvs=((0, 0),)), r"uvs: expected 4"),
])
def test_degenerate_primitives_are_clear_errors(make, match):
    with pytest.raises(tx.SceneError, match=match):
        make()


@pytest.mark.parametrize("corners", [
    ((0, 0, 0), (1, 0, 0), (2, 0, 0), (1, 1, 0)),          # three collinear vertices: a triangle
    ((0, 0, 0), (1, 1, 0), (1, 0, 0), (0, 1, 0)),          # bow-tie (self-intersecting)
    ((0, 0, 0), (1, 0, 0), (1, 0, 0), (0, 1, 0)),          # two coincident vertices
])
def test_degenerate_quads_render_finite(device, corners):
    tex = tx.Texture.from_array(np.random.default_rng(2).uniform(size=(8, 8, 3)))
    scene = tx.Scene(camera=tx.Camera(eye=(0.5, 0.5, 2.5), look_at=(0.7, 0.4, 0), fov_y=50),
                     lights=[tx.PointLight((1, 1, 3), (10, 10, 10))])
    scene.add(tx.Quad(*corners, material=tx.Material(diffuse=tex)))
    img = tx.render(scene, 48, 48, device=device, aovs=("uv", "normal", "dpdu", "dpdv"))
    assert np.all(np.isfinite(img.rgb))
    hit = ~np.isnan(img.aov["normal"][..., 0])
    assert hit.sum() > 30
    for name in ("uv", "normal", "dpdu", "dpdv"):
        assert np.all(np.isfinite(img.aov[name][hit])), name


def test_cli_writes_aovs(tmp_path, scenes_dir):
    out = tmp_path / "globe.png"
    assert main(["render", str(scenes_dir / "mappings" / "globe.toml"), "-o", str(out), "--width", "32",
                 "--height", "24", "--spp", "1", "--aov", "uv", "--aov", "object_id"]) == 0
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(str(tmp_path / "globe.aov.exr"))
    assert {"uv.u", "uv.v", "object_id", "R"} <= set(buf.spec().channelnames)
    assert out.is_file()
