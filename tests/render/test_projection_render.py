"""Projection mappings, UV transforms and wrap modes through the whole renderer:
the uv AOV against the float64 projection of the reference hit point, and texel
colours against the wrap rules."""
import numpy as np
import pytest
import trimesh

import texray as tx
from texray.scene.mapping import UVTransform, project_numpy
from reference import scene_hits
from scenes_for_tests import quad

W, H = 64, 48


def _hits(scene):
    _, org, d, t, b1, b2, tri = scene_hits(scene, W, H)
    hit = tri >= 0
    with np.errstate(invalid="ignore"):
        p = org + t[:, None] * d
    margin = np.minimum(np.minimum(b1, b2), 1 - b1 - b2)
    return hit & (margin > 1e-3), p


@pytest.mark.parametrize("kind", ["planar", "cylindrical", "spherical"])
def test_projection_uvs_of_a_mesh_without_uvs(device, kind):
    ico = trimesh.creation.icosphere(subdivisions=3)
    tf = tx.Transform(translate=(0.3, -0.2, 0.1), rotate=(20, 35, 0), scale=1.3)
    proj = tx.Projection(kind, origin=(0.1, 0, 0), x_axis=(1, 0.2, 0), z_axis=(0, 1, 0), scale=2.0)
    tex = tx.Texture.from_array(np.ones((4, 4, 3)))
    scene = tx.Scene(camera=tx.Camera(eye=(0, 0.5, 4), look_at=(0, 0, 0), fov_y=45))
    mesh = tx.Mesh(np.asarray(ico.vertices), np.asarray(ico.faces), material=tx.Material(diffuse=tex),
                   transform=tf, mapping=proj, name="ico")
    scene.add(mesh)
    img = tx.render(scene, W, H, device=device, aovs=("uv",))
    ok, p_world = _hits(scene)
    # The reference: the same projection of the object-space point.
    m = tf.matrix()
    p_obj = (np.where(ok[:, None], p_world, 0.0) - m[:3, 3]) @ np.linalg.inv(m[:3, :3]).T
    ref = project_numpy(proj, np.where(ok[:, None], p_obj, 0.0))
    got = img.aov["uv"].reshape(-1, 2)
    du = np.abs(got[ok] - ref[ok])
    if kind != "planar":                       # u wraps at the seam: compare on the circle
        du[:, 0] = np.minimum(du[:, 0], 1 - du[:, 0])
    assert ok.sum() > 300
    assert du.max() < 1e-4, f"worst uv error {du.max():.3g}"


def _floor_scene(texture, uv_repeat=3.0):
    p, f, uv = quad(0.0, 2.0, uv_repeat=uv_repeat)
    scene = tx.Scene(camera=tx.Camera(eye=(0, 5, 0.0001), look_at=(0, 0, 0), fov_y=50), ambient=(1, 1, 1))
    scene.add(tx.Mesh(p, f, uvs=uv, material=tx.Material(diffuse=texture), name="floor"))
    return scene


def _wrap(i, n, mode):
    if mode == "repeat":
        return i % n
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    i = i % (2 * n)
    return np.where(i < n, i, 2 * n - 1 - i)


@pytest.mark.parametrize("mode", ["repeat", "clamp", "mirror"])
def test_wrap_modes_and_uv_transform_in_a_render(device, mode):
    """A one-row texture of 5 texels: each pixel's colour is the float64 linear interpolation
    of the two texels around u' (the transformed u), indices wrapped by the mode's rule."""
    values = np.array([0.1, 0.3, 0.5, 0.7, 0.9])
    tf = UVTransform(scale=(1.5, 1.0), offset=(-1.2, 0.0))
    tex = tx.Texture.from_array(np.repeat(values[None, :, None], 3, axis=2), wrap=mode, uv_transform=tf)
    scene = _floor_scene(tex)
    img = tx.render(scene, W, H, device=device, aovs=("uv",), jitter=False)   # colour at the AOV's pixel centres
    uv = img.aov["uv"].reshape(-1, 2).astype(np.float64)
    hit = ~np.isnan(uv[:, 0])
    u = tf.apply(uv[hit])[:, 0]
    if mode == "clamp":
        u = np.clip(u, -1.0, 2.0)       # beyond the texture the clamped colour is constant anyway
    x = u * len(values) - 0.5
    i0 = np.floor(x).astype(int)
    a = x - i0
    expect = (1 - a) * values[_wrap(i0, 5, mode)] + a * values[_wrap(i0 + 1, 5, mode)]
    got = img.rgb.reshape(-1, 3)[hit, 0]
    assert hit.sum() > 1000
    # Texels are stored as half floats (0.9 -> 0.89990); 1e-3 covers that and float32 weights.
    np.testing.assert_allclose(got, expect, atol=1e-3)


def test_with_options_shares_the_texels():
    tex = tx.Texture.from_array(np.random.default_rng(0).uniform(size=(8, 8, 3)))
    other = tex.with_options(wrap="mirror", uv_transform=UVTransform(scale=(2, 2)))
    scene = _floor_scene(tex)
    scene.add(tx.Mesh(*quad(1.0, 1.0)[:2], uvs=quad(1.0, 1.0)[2], material=tx.Material(diffuse=other), name="b"))
    from texray.compile import compile_scene
    cs = compile_scene(scene)
    assert len(cs.textures) == 2 and cs.texels.size == 8 * 8 * 4
    assert list(cs.textures["wrap"]) == [0, 2] and cs.textures["offset"][0] == cs.textures["offset"][1]


def test_projection_in_scene_file(tmp_path):
    (tmp_path / "ball.obj").write_text(trimesh.exchange.obj.export_obj(trimesh.creation.icosphere(2)))
    tx.Image(np.full((4, 8, 3), 0.5, np.float32)).save(tmp_path / "t.png")
    (tmp_path / "s.toml").write_text(
        '[textures.t]\nfile = "t.png"\nwrap = "mirror"\nuv_transform = { scale = [2, 1], rotation = 90 }\n'
        '[materials.m]\ndiffuse = "t"\n'
        '[[objects]]\nmesh = "ball.obj"\nmaterial = "m"\nmapping = { kind = "spherical", z_axis = [0, 1, 0] }\n')
    scene = tx.Scene.load(tmp_path / "s.toml")
    obj = scene.objects[0]
    assert obj.mapping.kind == "spherical" and obj.material.diffuse.wrap == "mirror"
    assert obj.material.diffuse.uv_transform.rotation == 90
    (tmp_path / "bad.toml").write_text('[[objects]]\nmesh = "ball.obj"\nmapping = { kind = "conical" }\n')
    with pytest.raises(tx.SceneError, match=r"bad\.toml: objects\[0\]\.mapping\..*conical"):
        tx.Scene.load(tmp_path / "bad.toml")
