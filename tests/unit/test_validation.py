"""Regressions of issue 12's fuzz findings on the host side, each with its exact input:
every bad value is a SceneError (or DeviceError) when the object is made, worded
'FIELD: expected ..., got VALUE' with plain numbers; a scene file's errors name the file.
The kernel side (NaN and degenerate rays are misses) is tests/kernels/test_ray_robustness.py."""
import os
import warnings

import numpy as np
import pytest

import texray as tx
from texray import validate as V
from texray.errors import DeviceError, SceneError
from scenes_for_tests import quad


def _raises(match, fn, *a, **kw):
    with pytest.raises(SceneError, match=match):
        fn(*a, **kw)


# --- 1. degenerate cameras (NaN camera rays crashed the traversal) --------------------
@pytest.mark.parametrize("kw, match", [
    (dict(up=(0, 0, 0)), r"camera\.up: expected a non-zero vector, got \[0, 0, 0\]"),
    (dict(up=(0, 1, 4)), r"camera\.up: \[0, 1, 4\] is parallel to the viewing direction"),
    (dict(eye=(1e308, 1, 4)), r"camera\.eye: expected 3 numbers of magnitude <= 1e\+18 .*got \[1e\+308, 1, 4\]"),
    (dict(look_at=(-1e308, 0, 0)), r"camera\.look_at: expected 3 numbers of magnitude <= 1e\+18"),
    (dict(fov_y=float("nan")), r"camera\.fov_y: expected a finite number in \(0, 179\], got nan"),
])
def test_degenerate_cameras_are_refused_when_made(kw, match):
    _raises(match, tx.Camera, **(dict(eye=(0, 1, 4), look_at=(0, 0, 0)) | kw))


def test_tiny_up_vector_is_a_direction_not_a_degenerate_case(device):
    """up = (0, 1e-300, 0) is a valid direction: the camera normalizes it before the parallel test
    and renders the same image as up = (0, 1, 0)."""
    def scene(up):
        s = tx.Scene(camera=tx.Camera(eye=(0, 1, 4), look_at=(0, 0, 0), up=up),
                     lights=[tx.PointLight((2, 3, 3), (20, 20, 20))])
        s.add(tx.Sphere(radius=0.8))
        return s
    a = tx.render(scene((0, 1e-300, 0)), 16, 12, device=device).rgb
    b = tx.render(scene((0, 1, 0)), 16, 12, device=device).rgb
    assert np.all(np.isfinite(a)) and np.array_equal(a, b)


def test_camera_up_zero_in_a_scene_file_names_the_file(tmp_path):
    p = tmp_path / "cam.toml"
    p.write_text("[camera]\neye = [0, 1, 4]\nup = [0, 0, 0]\n")
    _raises(r"cam\.toml: camera\.up: expected a non-zero vector", tx.Scene.load, p)


# --- 3. values finite in float64 but not in float32 ----------------------------------
@pytest.mark.parametrize("make, match", [
    (lambda: tx.PointLight((1e39, 1e39, 1e39)), r"light\.position: expected 3 numbers of magnitude <= 1e\+18"),
    (lambda: tx.PointLight((0, 1, 0), (1e39, 1, 1)), r"light\.intensity: .*finite in float32.*got \[1e\+39, 1, 1\]"),
    (lambda: tx.PointLight((0, 1, 0), 1e308), r"light\.intensity: .*got 1e\+308"),
    (lambda: tx.PointLight((0, 1, 0), (1, -1, 1)), r"light\.intensity: expected a number or 3 numbers >= 0"),
    (lambda: tx.Scene(ambient=(1e39, 0, 0)), r"scene\.ambient: .*finite in float32"),
    (lambda: tx.Scene(background=1e308), r"scene\.background: .*got 1e\+308"),
    (lambda: tx.Material(diffuse=1e39), r"material\.diffuse: .*finite in float32.*got 1e\+39"),
    (lambda: tx.Material(specular=(1e39, 0, 0)), r"material\.specular: .*finite in float32"),
    (lambda: tx.Material(tint=(1, 1, 1e308)), r"material\.tint: .*finite in float32"),
    (lambda: tx.Material(diffuse=3e38, tint=2), r"material\.diffuse, tint: their product .* overflows float32"),
    (lambda: tx.Material(shininess=1e39), r"material\.shininess: expected a number of magnitude <= 3\.4e\+38"),
])
def test_values_beyond_float32_are_refused(make, match):
    _raises(match, make)


@pytest.mark.parametrize("snippet, match", [
    ("[[lights]]\nposition = [1e39, 1e39, 1e39]\n", r"lights\[0\]\.position: expected 3 numbers of magnitude"),
    ("[[lights]]\nposition = [0, 1, 0]\nintensity = [1e308, 1, 1]\n", r"lights\[0\]\.intensity: .*1e\+308"),
    ("[scene]\nambient = [1e39, 0, 0]\n", r"scene\.ambient: .*finite in float32"),
    ("[scene]\nbackground = [0, 0, -1]\n", r"scene\.background: expected a number or 3 numbers >= 0"),
    ("[materials.m]\ntint = [1e39, 1, 1]\n", r"materials\.m\.tint: .*finite in float32"),
    ("[materials.m]\ndiffuse = [1, 1, 1e308]\n", r"materials\.m\.diffuse: "),
    ("[render]\nwidth = 0\n", r"render\.width: expected an integer in \[1, 1048576\], got 0"),
    ("[render]\nspp = 4294967296\n", r"render\.spp: expected an integer in \[1, 16777216\], got 4294967296"),
    ("[render]\nseed = -1\n", r"render\.seed: expected an integer in \[0, 4294967295\], got -1"),
    ("[[objects]]\ntype = \"cylinder\"\nz_range = [\"a\", \"b\"]\n", r"objects\[0\]: z_range: expected 2 numbers"),
    ("[[objects]]\ntype = \"quad\"\np0 = [0, 0, 0]\np1 = [1, 0, 0]\np2 = [1, 1, 0]\np3 = [0, 1, 0]\n"
     "uvs = [[0, 0], [1, 0], [1]]\n", r"objects\[0\]: uvs: expected an \(N, 2\) array of numbers"),
    ("[[objects]]\ntype = \"sphere\"\ncenter = [1e30, 0, 0]\n", r"objects\[0\]: center: .*magnitude <= 1e\+18"),
    ("[[objects]]\ntype = \"sphere\"\ncenter = [1e17, 0, 0]\nscale = 100\n",
     r"objects\[0\]: center, radius: coordinates up to 1e\+19 after the transform"),
    ("[textures.t]\nprocedural = \"checker\"\nparams = { size = -1 }\n", r"textures\.t\.procedural: checker: size"),
])
def test_scene_file_values_are_checked_at_load_and_name_the_file(tmp_path, snippet, match):
    p = tmp_path / "bad.toml"
    p.write_text(snippet)
    _raises(r"bad\.toml: " + match, tx.Scene.load, p)


# --- 4. paths ------------------------------------------------------------------------
def test_paths_too_long_directories_fifos_and_devices(tmp_path):
    long = tmp_path / ("x" * 300 + ".png")
    _raises(r"texture\.file: path too long \(\d+ bytes, longest name 304; at most 4096 and 255\)",
            tx.Texture.load, long)
    _raises(r"mesh: path too long", tx.Mesh.load, tmp_path / ("m" * 256 + ".obj"))
    _raises(r"scene: path too long", tx.Scene.load, "s" * 5000)
    _raises(r"texture\.file: expected a regular file, got a directory: ", tx.Texture.load, tmp_path)
    _raises(r"mesh: expected a regular file, got a device: /dev/zero", tx.Mesh.load, "/dev/zero")
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    _raises(r"scene: expected a regular file, got a FIFO: .*pipe\.toml", tx.Scene.load, fifo)
    _raises(r"texture\.file: expected a file path, got NoneType None", tx.Texture.load, None)


# --- 5. ragged and non-numeric arrays -----------------------------------------------------
@pytest.mark.parametrize("make, match", [
    (lambda: tx.Mesh([[0, 0, 0], [1, 0], [0, 1, 0]], [[0, 1, 2]]), r"positions: expected an \(N, 3\) array"),
    (lambda: tx.Mesh([["a", "b", "c"]] * 3, [[0, 1, 2]]), r"positions: expected an \(N, 3\) array of numbers, got "
                                                          r"an array of <U1"),
    (lambda: tx.Mesh(np.eye(3), [[0, 1, 2]], normals=[[0, 0, 1], [0, 1], [1, 0, 0]]), r"normals: expected an"),
    (lambda: tx.Mesh(np.eye(3), [[0, 1, 2]], uvs="uv"), r"uvs: expected an \(N, 2\) array of numbers, got 'uv'"),
    (lambda: tx.Mesh(np.eye(3), [[0.0, 1.0, 2.0]]), r"faces: expected an \(N, 3\) array of integers"),
    (lambda: tx.Mesh(np.eye(3), [[0, 1, 2]], normals=np.full((3, 3), 1e39)),
     r"normals: vertex 0 is \[1e\+39, 1e\+39, 1e\+39\] \(expected finite values of magnitude <= 3\.4e\+38\)"),
    (lambda: tx.Cylinder(z_range=("a", "b")), r"<cylinder>: z_range: expected 2 numbers, got \['a', 'b'\]"),
    (lambda: tx.Quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), uvs=[[0, 0], [1, 0], [1]]),
     r"<quad>: uvs: expected an \(N, 2\) array of numbers \(equal-length rows\)"),
    (lambda: tx.Sphere(center="origin"), r"<sphere>: center: expected 3 numbers, got 'origin'"),
])
def test_ragged_and_non_numeric_arrays(make, match):
    _raises(match, make)


def test_huge_vertex_normals_are_made_unit_and_render_finite(device):
    p, f, _ = quad()
    n = np.tile([0.0, 1e30, 0.0], (len(p), 1))
    mesh = tx.Mesh(p, f, normals=n)
    np.testing.assert_allclose(mesh.normals, np.tile([0.0, 1.0, 0.0], (len(p), 1)))
    scene = tx.Scene(camera=tx.Camera(eye=(0, 2, 2)), lights=[tx.PointLight((0, 3, 0), (9, 9, 9))])
    scene.add(mesh)
    assert np.all(np.isfinite(tx.render(scene, 16, 12, device=device).rgb))


# --- 6. procedural texture parameters ---------------------------------------------------------
@pytest.mark.parametrize("kind, kw, match", [
    ("checker", dict(size=-1), r"checker: size: expected a number or 2 numbers > 0, got -1"),
    ("checker", dict(size=100000), r"checker: size: expected at most 8192 texels a side"),
    ("checker", dict(size=1e-9), r"checker: size: expected an integer or \(height, width\) integers >= 1"),
    ("bricks", dict(n_rows=0), r"bricks: n_rows: expected an integer in \[1, 1024\], got 0"),
    ("tiles", dict(n=0), r"tiles: n: expected an integer in \[1, 1024\], got 0"),
    ("noise", dict(size=16, cells=-3), r"noise: cells: expected an integer or a pair of integers in \[1, 1024\]"),
    ("noise", dict(size=16, octaves=40), r"noise: octaves: expected an integer in \[1, 16\], got 40"),
    ("bricks", dict(bevel=0), r"bricks: bevel: expected a number in \(0, 1\], got 0"),
    ("checker", dict(c0=(2, 0, 0)), r"checker: c0: expected an RGB colour"),
    (["checker"], {}, r"texture\.procedural: expected one of checker"),
])
def test_procedural_texture_parameters(kind, kw, match):
    _raises(match, tx.Texture.procedural, kind, **kw)


def test_from_array_refuses_texels_no_half_float_holds():
    _raises(r"texel 1000000\.0 at row 0, column 0, channel 0 is beyond 65504", tx.Texture.from_array,
            np.full((2, 2), 10**6, np.int64))
    _raises(r"expected an array of numbers, got an array of bool", tx.Texture.from_array, np.ones((2, 2), bool))
    assert tx.Texture.from_array(np.full((2, 2), 65504.0)).raw.max() == 65504.0


# --- 7. devices --------------------------------------------------------------------------------------
@pytest.mark.parametrize("value", ["7", "abc", "0:5"])
def test_bad_pyopencl_ctx_is_a_device_error(monkeypatch, value):
    monkeypatch.setenv("PYOPENCL_CTX", value)
    from texray.device import select_device
    with pytest.raises(DeviceError, match=rf"PYOPENCL_CTX='{value}' names no device"):
        select_device(None)


def test_empty_device_name_is_refused():
    with pytest.raises(DeviceError, match=r"device: expected a device index, 'cpu', 'gpu' or a name, got ''"):
        tx.render(tx.Scene(), 4, 4, device="")


# --- 8. render arguments ---------------------------------------------------------------------------------
@pytest.mark.parametrize("args, kw, match", [
    ((4, 4), dict(spp=2**32), r"render: spp: expected an integer in \[1, 16777216\], got 4294967296"),
    ((1, 2**32), {}, r"render: height: expected an integer in \[1, 1048576\], got 4294967296"),
    ((2**20, 2**20), {}, r"render: width, height: 1048576 x 1048576 is 1099511627776 pixels; at most 2\^32 - 1"),
    ((65536, 65535), {}, r"render: width, height: a 65536 x 65535 image needs 64\.0 GiB of host memory"),
    ((4, 4), dict(seed=2**32), r"render: seed: expected an integer in \[0, 4294967295\], got 4294967296"),
    ((4, 4), dict(seed=-1), r"render: seed: expected an integer in \[0, 4294967295\], got -1"),
    ((4, 4), dict(progress=1), r"render: progress: expected None or a callable, got int 1"),
    ((4, 4), dict(sink=1), r"render: sink: expected None or a callable, got int 1"),
    ((4, 4), dict(jitter="no"), r"render: jitter: expected True or False, got 'no'"),
    ((4, 4), dict(aovs=7), r"render: aovs: expected a list of AOV names, got 7"),
])
def test_render_arguments(args, kw, match):
    _raises(match, tx.render, tx.Scene(), *args, **kw)


# --- 9. API types -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("make, match", [
    (lambda: tx.Scene(lights=None), r"scene\.lights: expected a list, got None"),
    (lambda: tx.Scene(camera=None), r"scene\.camera: expected a texray\.Camera, got NoneType None"),
    (lambda: tx.Scene(objects=["x"]), r"scene\.objects\[0\]: expected a texray Mesh, Sphere, Cylinder, Quad or Instance, "
                                      r"got str 'x'"),
    (lambda: tx.Scene(lights=[(0, 1, 0)]), r"scene\.lights\[0\]: expected a texray\.PointLight"),
    (lambda: tx.Scene().add(None), r"scene\.add: expected a texray Mesh"),
    (lambda: tx.Sphere(transform={"scale": 2}), r"<sphere>: transform: expected a texray\.Transform, got dict"),
    (lambda: tx.Sphere(material="red"), r"<sphere>: material: expected a texray\.Material, got str 'red'"),
])
def test_api_types_fail_early_with_scene_errors(make, match):
    _raises(match, make)


def test_lists_changed_after_creation_are_checked_at_render():
    scene = tx.Scene()
    scene.lights.append("lamp")
    _raises(r"scene\.lights\[0\]: expected a texray\.PointLight, got str 'lamp'", tx.render, scene, 4, 4)


# --- 10. plain numbers in messages ---------------------------------------------------------------------------
def test_messages_show_plain_numbers():
    assert V.show(np.float64(0.0)) == "0.0" and V.show(np.array([1.0, 2.5])) == "[1.0, 2.5]"
    assert V.show((np.int64(3), np.float32(0.5))) == "[3, 0.5]" and V.show(float("nan")) == "nan"
    with pytest.raises(SceneError) as e:
        tx.Sphere(radius=np.float64(0.0))
    assert "np.float64" not in str(e.value) and str(e.value).endswith("got 0.0")


# --- 11. the newcomer's trial ------------------------------------------------------------------------------------
QUAD = "v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\n"


def test_cli_refuses_zero_sizes(tmp_path, capsys):
    from texray.cli import main
    scene = tmp_path / "s.toml"
    scene.write_text("[render]\nwidth = 8\nheight = 8\n")
    for flag in ("--width", "--height", "--spp"):
        with pytest.raises(SystemExit) as e:
            main(["render", str(scene), "-o", str(tmp_path / "o.png"), flag, "0"])
        assert e.value.code == 2
        assert f"argument {flag}: expected a positive integer, got 0" in capsys.readouterr().err


def test_mesh_files_the_newcomer_tried(tmp_path):
    (tmp_path / "noise.obj").write_bytes(bytes(np.random.default_rng(1).integers(0, 256, 3000, dtype=np.uint8)))
    _raises(r"mesh: cannot read .*noise\.obj: not UTF-8 text", tx.Mesh.load, tmp_path / "noise.obj")
    (tmp_path / "far.obj").write_text(QUAD + "f 1 2 9\n")
    _raises(r"mesh: cannot read .*far\.obj: a face refers to a vertex", tx.Mesh.load, tmp_path / "far.obj")
    (tmp_path / "cut.obj").write_text(QUAD + "f 1 2 3\nf 1 3 4\nf 1 2/")
    with pytest.warns(UserWarning, match=r"cut\.obj: 3 face lines but 2 triangles loaded"):
        assert len(tx.Mesh.load(tmp_path / "cut.obj").faces) == 2
    (tmp_path / "whole.obj").write_text(QUAD + "f 1 2 3 4\n")          # a quad face: two triangles
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(tx.Mesh.load(tmp_path / "whole.obj").faces) == 2


def test_scene_without_lights_warns():
    scene = tx.Scene()
    scene.add(tx.Sphere())
    with pytest.warns(UserWarning, match=r"scene: no lights and no ambient light: every object renders black"):
        from texray.compile import compile_scene
        compile_scene(scene)
    scene.ambient = (0.1, 0.1, 0.1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        compile_scene(scene)


# --- found by the fuzz suite: fields changed after an object was made ------------------------------------------
def _mesh_scene():
    p, f, uv = quad()
    mesh = tx.Mesh(p, f, uvs=uv, normals=np.tile([0.0, 1.0, 0.0], (len(p), 1)),
                   material=tx.Material(diffuse=tx.Texture.from_array(np.ones((2, 2)))), name="floor")
    scene = tx.Scene(camera=tx.Camera(eye=(0, 2, 2)), lights=[tx.PointLight((0, 3, 0))])
    scene.add(mesh)
    return scene, mesh


@pytest.mark.parametrize("edit, match", [
    (lambda m: m.faces.__setitem__((0, 0), -1), r"floor: faces: face 0 = \[-1, .*indexes outside 0\.\.3"),
    (lambda m: setattr(m, "uvs", m.uvs[:1]), r"floor: uvs: expected shape \(4, 2\), got \(1, 2\)"),
    (lambda m: setattr(m, "normals", np.full((4, 3), np.nan)), r"floor: normals: vertex 0 is \[nan, nan, nan\]"),
    (lambda m: setattr(m, "faces", np.full((2, 3), 10**6)), r"floor: faces: face 0 .* indexes outside"),
    (lambda m: setattr(m, "positions", "abc"), r"floor: positions: expected an \(N, 3\) array"),
    (lambda m: setattr(m, "material", "red"), r"floor: material: expected a texray\.Material, got str 'red'"),
    (lambda m: setattr(m, "mapping", "planar"), r"floor: mapping: expected a texray\.Projection"),
    (lambda m: setattr(m.material.diffuse, "filter", "abc"), r"texture\.filter: <array>: expected one of nearest"),
    (lambda m: setattr(m.material.diffuse, "wrap", "abc"), r"texture\.wrap: expected one of repeat, clamp, mirror"),
    (lambda m: setattr(m.material.diffuse, "uv_transform", "x"), r"texture\.uv_transform: <array>: expected a "
                                                                 r"texray\.UVTransform"),
])
def test_objects_changed_after_creation_are_checked_again_at_render(edit, match):
    scene, mesh = _mesh_scene()
    edit(mesh)
    _raises(match, tx.render, scene, 8, 8)


def test_output_paths_are_checked():
    _raises(r"output: expected a file path, got NoneType None", tx.render_to_file, tx.Scene(), None, 4, 4)
    _raises(r"output: the directory /nonexistent-dir does not exist", tx.Image(np.zeros((2, 2, 3), np.float32)).save,
            "/nonexistent-dir/x.png")


def test_texture_coordinates_whose_interpolation_overflows_are_refused():
    corners = ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0))
    _raises(r"<quad>: uvs: expected 4 \(u, v\) pairs of numbers of magnitude <= 1e\+18", tx.Quad, *corners,
            uvs=((3e38, 0), (-3e38, 0), (3e38, 1), (0, 1)))
    p, f, _ = quad()
    _raises(r"uvs: vertex 0 is \[3e\+38, 0\.0\]", tx.Mesh, p, f, uvs=np.array([[3e38, 0]] * 4))


def test_later_fuzz_findings(tmp_path):
    """render_to_file checked the sizes only after the file was opened (TypeError from the image
    writer, fuzz seed 2026 case 992); random bytes as an STL blamed a missing module (case 10102)."""
    _raises(r"render: width: expected an integer in \[1, 1048576\], got 4294967296", tx.render_to_file,
            tx.Scene(), str(tmp_path / "o.jpg"), 2**32, 4)
    assert not (tmp_path / "o.jpg").exists()
    (tmp_path / "m.stl").write_bytes(bytes(np.random.default_rng(3).integers(0, 256, 999, dtype=np.uint8)))
    with pytest.raises(SceneError, match=r"mesh: cannot read .*m\.stl") as e:
        tx.Mesh.load(tmp_path / "m.stl")
    assert "No module named" not in str(e.value)
