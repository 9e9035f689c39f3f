"""Bad input: each a clear SceneError naming the file, field and value; never a crash,
a hang or NaN pixels."""

import numpy as np
import pytest

import texray as tx
from texray.device import runtime
from texray.errors import BuildError, SceneError
from scenes_for_tests import quad

SCENE = """
[camera]
eye = [0, 1, 3]
look_at = [0, 0, 0]
[[lights]]
position = [1, 3, 2]
intensity = [10, 10, 10]
[textures.t]
file = "tex.png"
[materials.m]
diffuse = "t"
[[objects]]
mesh = "quad.obj"
material = "m"
"""
QUAD_OBJ = "v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"


@pytest.fixture
def scene_dir(tmp_path):
    (tmp_path / "quad.obj").write_text(QUAD_OBJ)
    tx.Image(np.full((4, 4, 3), 0.5, np.float32)).save(tmp_path / "tex.png")
    (tmp_path / "scene.toml").write_text(SCENE)
    return tmp_path


def _expect(match, fn, *a, **kw):
    with pytest.raises(SceneError, match=match):
        fn(*a, **kw)


def test_valid_scene_file_loads_and_renders(scene_dir):
    scene = tx.Scene.load(scene_dir / "scene.toml")
    img = tx.render(scene, 16, 12, spp=1, device="cpu")
    assert np.all(np.isfinite(img.rgb)) and img.rgb.max() > 0


def test_missing_texture_file(scene_dir):
    (scene_dir / "tex.png").unlink()
    _expect(r"scene\.toml.*textures\.t\.file.*not found.*tex\.png", tx.Scene.load, scene_dir / "scene.toml")


def test_corrupt_texture_file(scene_dir):
    (scene_dir / "tex.png").write_bytes(b"\x89PNG\r\n\x1a\nthis is not a png")
    _expect(r"textures\.t\.file.*tex\.png", tx.Scene.load, scene_dir / "scene.toml")


def test_missing_mesh_file(scene_dir):
    (scene_dir / "quad.obj").unlink()
    _expect(r"objects\[0\]\.mesh.*not found.*quad\.obj", tx.Scene.load, scene_dir / "scene.toml")


def test_unreadable_mesh_file(scene_dir):
    (scene_dir / "quad.obj").write_text("this is not an obj file\n")
    _expect(r"objects\[0\]\.mesh.*quad\.obj", tx.Scene.load, scene_dir / "scene.toml")


def test_textured_mesh_without_uvs(scene_dir):
    (scene_dir / "quad.obj").write_text("v -1 0 1\nv 1 0 1\nv 1 0 -1\nf 1 2 3\n")
    _expect(r"quad\.obj.*uvs.*texture", tx.Scene.load, scene_dir / "scene.toml")


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_non_finite_vertex_in_file(scene_dir, bad):
    (scene_dir / "quad.obj").write_text(QUAD_OBJ.replace("v 1 0 -1", f"v 1 {bad} -1"))
    _expect(r"quad\.obj.*positions: vertex 2", tx.Scene.load, scene_dir / "scene.toml")


def test_non_finite_vertex_in_array():
    p, f, uv = quad()
    p[1, 0] = np.nan
    _expect(r"ground-nan.*positions: vertex 1", tx.Mesh, p, f, uvs=uv, name="ground-nan")


def test_face_index_out_of_range():
    p, f, _ = quad()
    f[1, 2] = 7
    _expect(r"faces: face 1 .* outside 0\.\.3", tx.Mesh, p, f)


def test_zero_area_triangles_are_skipped_without_nan(device):
    p, f, _ = quad()
    p = np.vstack([p, [[0, 0.5, 0], [1, 0.5, 0], [2, 0.5, 0]]])     # collinear: zero area
    f = np.vstack([f, [[4, 5, 6], [4, 4, 5]]])
    scene = tx.Scene(camera=tx.Camera(eye=(0, 3, 0.01)), lights=[tx.PointLight((0, 2, 0), (5, 5, 5))])
    scene.add(tx.Mesh(p, f, name="with-degenerates"))
    with pytest.warns(UserWarning, match=r"with-degenerates: 2 zero-area triangle\(s\) skipped \(faces \[2, 3\]\)"):
        img = tx.render(scene, 32, 32, spp=2, device=device)
    assert np.all(np.isfinite(img.rgb)) and img.rgb.max() > 0


def test_only_zero_area_triangles():
    scene = tx.Scene()
    scene.add(tx.Mesh(np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2]], float), np.array([[0, 1, 2]]), name="flat"))
    _expect(r"flat: faces: all 1 triangles have zero area", tx.render, scene, 8, 8)


@pytest.mark.parametrize("snippet, match", [
    ("[camera]\nfov = 40\n", r"camera\.fov: unknown key"),
    ("colour = 1\n", r"colour: unknown top-level key"),
    ("[camera]\neye = \"here\"\n", r"camera\.eye: expected array, got 'here'"),
    ("[camera]\nfov_y = 0\n", r"camera\.fov_y: expected a number in \(0, 179\], got 0"),
    ("[camera]\neye = [0, 0, 0]\nlook_at = [0, 0, 0]\n", r"camera\.look_at: equals eye"),
    ("[[lights]]\nintensity = [1, 1, 1]\n", r"lights\[0\]: missing required key 'position'"),
    ("[[lights]]\nposition = [1, 2]\n", r"lights\[0\]\.position: expected 3 numbers"),
    ("[[lights]]\nposition = [0, 1, 0]\nintensity = [1, -1, 1]\n", r"lights\[0\]\.intensity: expected a number or 3 numbers >= 0, got \[1, -1, 1\]"),
    ("[materials.m]\ndiffuse = \"nope\"\n", r"materials\.m\.diffuse: no texture named 'nope'"),
    ("[materials.m]\nshininess = -3\n", r"materials\.m\.shininess: expected a number in \[0, inf\), got -3"),
    ("[materials.m]\nspecular = true\n", r"materials\.m\.specular: expected"),
    ("[[objects]]\nmesh = \"quad.obj\"\nmaterial = \"zz\"\n", r"objects\[0\]\.material: no material named 'zz'"),
    ("[[objects]]\nmesh = \"quad.obj\"\nscale = 0\n", r"objects\[0\]\.scale: a scale of zero"),
    ("[render]\nspp = 2.5\n", r"render\.spp: expected int"),
    ("[camera\n", r"not valid TOML"),
])
def test_scene_file_errors_name_file_and_field(tmp_path, snippet, match):
    (tmp_path / "quad.obj").write_text(QUAD_OBJ)
    path = tmp_path / "bad.toml"
    path.write_text(snippet)
    _expect(r"bad\.toml: .*" + match, tx.Scene.load, path)


@pytest.mark.parametrize("kw, match", [
    (dict(width=0), r"render: width: expected an integer in \[1, 1048576\], got 0"),
    (dict(height=-5), r"render: height: expected an integer in \[1, 1048576\], got -5"),
    (dict(spp=0), r"render: spp: expected an integer in \[1, 16777216\], got 0"),
    (dict(spp=1.5), r"render: spp: expected an integer in \[1, 16777216\], got 1\.5"),
])
def test_render_size_and_samples_must_be_positive(kw, match):
    args = dict(width=8, height=8, spp=1) | kw
    _expect(match, tx.render, tx.Scene(), **args)


def test_build_error_carries_compiler_log():
    rt = runtime("cpu")
    with pytest.raises(BuildError) as e:
        rt.program({"TX_STACK_SIZE": 32, "cmj_sample": 1})     # redefines a function name
    assert "cmj_sample" in str(e.value) and "error" in str(e.value).lower()


def test_unknown_device_is_named():
    with pytest.raises(tx.DeviceError, match=r"no device matches 'no-such-device'"):
        tx.render(tx.Scene(), 4, 4, device="no-such-device")


@pytest.mark.parametrize("make, message", [
    (lambda: tx.Bump(tx.Texture.from_array(np.ones((2, 2))), height=float("nan")),
     r"bump\.height: expected a finite number, got nan"),
    (lambda: tx.Bump(tx.Texture.from_array(np.ones((2, 2))), height=0.1, delta=0.7),
     r"bump\.delta: expected a number in \(0, 0\.5\], got 0\.7"),
    (lambda: tx.Material(shininess=-1.0).validate(), r"shininess: expected a number in \[0, inf\), got -1\.0"),
    (lambda: tx.Sphere(radius=float("inf")), r"radius"),
])
def test_number_errors_name_field_value_and_range(make, message):
    with pytest.raises(SceneError, match=message):
        make()
