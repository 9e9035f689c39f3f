"""OBJ files' own materials: the MTL statements texray reads (texray.io.mtl's rule), per-face
materials from usemtl groups, and the errors and warnings for what it cannot use."""
import re
import warnings

import numpy as np
import pytest

import texray as tx
from texray.io.images import write_image
from texray.io.mtl import BUMP_UNIT

QUADS = """mtllib {lib}
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 2 0 0
v 2 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
usemtl {a}
f 1/1 2/2 3/3
f 1/1 3/3 4/4
usemtl {b}
f 2/1 5/2 6/3
f 2/1 6/3 3/4
"""


def _obj(tmp_path, mtl, a="left", b="right", lib="m.mtl", vt=True):
    text = QUADS.format(lib=lib, a=a, b=b)
    if not vt:
        text = "\n".join(line for line in text.splitlines() if not line.startswith("vt"))
        text = text.replace("/1", "").replace("/2", "").replace("/3", "").replace("/4", "")
    (tmp_path / "q.obj").write_text(text)
    (tmp_path / lib).write_text(mtl)
    return tmp_path / "q.obj"


def _png(path, rgb):
    write_image(path, np.asarray(rgb, np.float32))
    return path


def _by_x(mesh):
    """The material of the faces left (x < 1) and right (x > 1) of the middle."""
    cx = mesh.positions[mesh.faces].mean(axis=1)[:, 0]
    left = {int(i) for i in mesh.face_materials()[cx < 1]}
    right = {int(i) for i in mesh.face_materials()[cx > 1]}
    assert len(left) == len(right) == 1
    return mesh.materials[left.pop()], mesh.materials[right.pop()]


def test_colours_shininess_and_illum(tmp_path):
    path = _obj(tmp_path, "newmtl left\nKd 0.1 0.2 0.3\nKs 0.4 0.5 0.6\nNs 77\nillum 2\n"
                          "newmtl right\nKd 0.5\nKs 1 1 1\nNs 10\nillum 1\n")
    left, right = _by_x(tx.Mesh.load(path))
    assert left.diffuse == (0.1, 0.2, 0.3) and left.specular == (0.4, 0.5, 0.6) and left.shininess == 77
    assert right.diffuse == (0.5, 0.5, 0.5)
    assert right.specular == (0.0, 0.0, 0.0)          # illum 1: no highlight


def test_map_kd_with_its_options(tmp_path):
    _png(tmp_path / "c.png", np.random.default_rng(1).random((4, 8, 3)))
    path = _obj(tmp_path, "newmtl left\nKd 1 0.5 0.25\nmap_Kd -s 2 3 1 -o 0.5 0.25 -clamp on c.png\n"
                          "newmtl right\nmap_Kd c.png\n")
    left, right = _by_x(tx.Mesh.load(path))
    ref = tx.Texture.load(tmp_path / "c.png")
    assert isinstance(left.diffuse, tx.Texture) and left.tint == (1.0, 0.5, 0.25)
    np.testing.assert_array_equal(left.diffuse.raw, ref.raw)
    assert left.diffuse.colorspace == "srgb" and left.diffuse.wrap == "clamp"
    np.testing.assert_allclose(left.diffuse.uv_transform.apply([[0.1, 0.2]]), [[0.1 * 2 + 0.5, 0.2 * 3 + 0.25]])
    assert right.diffuse.wrap == "repeat" and right.diffuse.uv_transform is None
    assert right.tint == (0.8, 0.8, 0.8)                # Kd's default multiplies the map
    # one texture read once, the two materials' variants share its pixels
    assert left.diffuse._pixels is right.diffuse._pixels


def test_specular_and_shininess_maps(tmp_path):
    ks = np.random.default_rng(2).random((4, 4, 3))
    _png(tmp_path / "ks.png", ks)
    _png(tmp_path / "ns.png", np.full((2, 2, 3), 0.5))
    path = _obj(tmp_path, "newmtl left\nKs 0.5 0.25 1\nmap_Ks ks.png\nNs 100\nmap_Ns ns.png\n"
                          "newmtl right\nKs 1 1 1\nmap_Ks ks.png\n")
    left, right = _by_x(tx.Mesh.load(path))
    ref = tx.Texture.load(tmp_path / "ks.png").rgba[:, :, :3]
    np.testing.assert_allclose(left.specular.raw, ref * np.array([0.5, 0.25, 1.0], np.float32), rtol=1e-6)
    assert left.specular.colorspace == "linear"       # baked: already decoded
    assert right.specular.colorspace == "srgb"        # Ks = 1: the map itself
    assert left.shininess == 100 and left.shininess_map.channels == 1
    stored = tx.Texture.load(tmp_path / "ns.png").raw[:, :, :1]       # the file's values, not decoded
    np.testing.assert_array_equal(left.shininess_map.raw, stored)
    assert left.shininess_map.colorspace == "linear"


def test_bump_and_normal_maps(tmp_path):
    _png(tmp_path / "h.png", np.linspace(0, 1, 16).reshape(4, 4))
    _png(tmp_path / "n.png", np.tile([0.5, 0.5, 1.0], (4, 4, 1)))
    path = _obj(tmp_path, "newmtl left\nmap_Bump -bm 2.5 h.png\nnewmtl right\nnorm n.png\n")
    left, right = _by_x(tx.Mesh.load(path))
    assert left.bump.height == pytest.approx(2.5 * BUMP_UNIT)
    assert left.bump.texture.colorspace == "linear"
    assert right.normal_map.space == "tangent" and right.normal_map.convention == "opengl"


def test_unknown_and_unrenderable_statements_warn_once_each(tmp_path):
    path = _obj(tmp_path, "newmtl left\nKd 1 0 0\nPr 0.5\nfoo 1\nd 0.5\nKe 1 1 1\ndisp h.png\n"
                          "newmtl right\nKa 1 1 1\nNi 1.5\n")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        mesh = tx.Mesh.load(path)
    msgs = [str(x.message) for x in w]
    unknown = [m for m in msgs if "does not use" in m]
    assert len(unknown) == 1 and "Pr" in unknown[0] and "foo" in unknown[0] and "Ka" not in unknown[0]
    cannot = [m for m in msgs if "cannot render" in m]
    assert len(cannot) == 1 and all(k in cannot[0] for k in ("d/Tr/map_d", "Ke", "disp"))
    assert _by_x(mesh)[0].diffuse == (1.0, 0.0, 0.0)


def test_missing_texture_names_obj_material_and_path(tmp_path):
    path = _obj(tmp_path, "newmtl left\nmap_Kd nowhere.png\nnewmtl right\n")
    with pytest.raises(tx.SceneError) as e:
        tx.Mesh.load(path)
    msg = str(e.value)
    assert "q.obj" in msg and "'left'" in msg and "map_Kd" in msg and "nowhere.png" in msg
    assert msg.endswith("map_Kd " + str(tmp_path / "nowhere.png") + ": file not found"), msg


def test_missing_library_and_undefined_material(tmp_path):
    (tmp_path / "q.obj").write_text(QUADS.format(lib="absent.mtl", a="x", b="y"))
    with warnings.catch_warnings(record=True) as w:       # the geometry loads, grey, with one warning
        warnings.simplefilter("always")
        mesh = tx.Mesh.load(tmp_path / "q.obj")
    msgs = [str(x.message) for x in w]
    assert len(msgs) == 1 and re.search(r"q\.obj: mtllib: .*absent\.mtl does not exist", msgs[0]), msgs
    assert all(m == tx.Material() for m in mesh.materials) and len(mesh.faces) == 4
    path = _obj(tmp_path, "newmtl left\nKd 0 1 0\n", b="undefined")
    with pytest.warns(UserWarning, match="usemtl 'undefined': not defined"):
        mesh = tx.Mesh.load(path)
    left, right = _by_x(mesh)
    assert left.diffuse == (0.0, 1.0, 0.0) and right.diffuse == tx.Material().diffuse


def test_textured_material_without_vt_is_an_error(tmp_path):
    _png(tmp_path / "c.png", np.ones((2, 2, 3)))
    path = _obj(tmp_path, "newmtl left\nmap_Kd c.png\nnewmtl right\n", vt=False)
    with pytest.raises(tx.SceneError, match=r"q\.obj: material 'left' has a texture .* no texture coordinates"):
        tx.Mesh.load(path)


def test_bad_numbers_name_the_line(tmp_path):
    path = _obj(tmp_path, "newmtl left\nKd 1 zero 0\n")
    with pytest.raises(tx.SceneError, match=r"m\.mtl:2: Kd: expected numbers"):
        tx.Mesh.load(path)


def test_material_argument_replaces_the_files(tmp_path):
    path = _obj(tmp_path, "newmtl left\nKd 1 0 0\nnewmtl right\nKd 0 0 1\n")
    mine = tx.Material(diffuse=(0.2, 0.3, 0.4))
    mesh = tx.Mesh.load(path, material=mine)
    assert mesh.materials == (mine,) and mesh.material_ids is None


def test_material_ids_are_validated():
    p = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    f = np.array([[0, 1, 2], [1, 3, 2]])
    a, b = tx.Material(), tx.Material(diffuse=(1, 0, 0))
    with pytest.raises(tx.SceneError, match="material_ids: required with a list of 2"):
        tx.Mesh(p, f, material=[a, b])
    with pytest.raises(tx.SceneError, match=r"material_ids: face 1 has 2, outside 0\.\.1"):
        tx.Mesh(p, f, material=[a, b], material_ids=[0, 2])
    with pytest.raises(tx.SceneError, match=r"material_ids: expected shape \(2,\)"):
        tx.Mesh(p, f, material=[a, b], material_ids=[0, 1, 1])
    with pytest.raises(tx.SceneError, match=r"material\[1\]: expected a texray.Material"):
        tx.Mesh(p, f, material=[a, "red"], material_ids=[0, 1])
    m = tx.Mesh(p, f, material=[a, b], material_ids=np.array([1, 0], np.int32))
    assert m.face_materials().tolist() == [1, 0]
