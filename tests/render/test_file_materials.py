"""Mesh files' own materials through the whole renderer: each file format against the same
mesh with its texture given explicitly, the texture's orientation (v = 0 is the image's
bottom row), and meshes with several materials against separate meshes."""
import importlib.util
import warnings
from pathlib import Path

import numpy as np
import pytest

import texray as tx
from texray.io.images import write_image

W, H = 64, 48

OBJ = """mtllib m.mtl
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
v 2 -1 0
v 2 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
usemtl {a}
f 1/1 2/2 3/3 4/4
usemtl {b}
f 2/1 5/2 6/3
f 2/1 6/3 3/4
"""


def _scene(background=(0.05, 0.1, 0.2)):
    return tx.Scene(camera=tx.Camera(eye=(0.5, 0, 4), look_at=(0.5, 0, 0), fov_y=45),
                    lights=[tx.PointLight((0.5, 0.5, 4), (16, 16, 16))], background=background)


def _render(device, *objects, background=(0.05, 0.1, 0.2), **kw):
    s = _scene(background)
    for o in objects:
        s.add(o)
    return tx.render(s, W, H, spp=2, device=device, **kw)


def _two_rows(tmp_path):
    """A 2x2 texture whose top row (row 0 of the file) is red and bottom row blue."""
    path = tmp_path / "rows.png"
    write_image(path, np.array([[[1, 0, 0], [1, 0, 0]], [[0, 0, 1], [0, 0, 1]]], np.float32))
    return path


def test_obj_map_kd_equals_the_texture_given_explicitly_and_is_upright(device, tmp_path):
    tex = _two_rows(tmp_path)
    (tmp_path / "q.obj").write_text(OBJ.format(a="rows", b="rows"))
    (tmp_path / "m.mtl").write_text("newmtl rows\nKd 1 1 1\nmap_Kd -clamp on rows.png\n")
    own = _render(device, tx.Mesh.load(tmp_path / "q.obj"), background=(0, 0, 0), aovs=("uv",))
    given = tx.Material(diffuse=tx.Texture.load(tex, wrap="clamp"), tint=(1, 1, 1))
    explicit = _render(device, tx.Mesh.load(tmp_path / "q.obj", material=given), background=(0, 0, 0))
    np.testing.assert_array_equal(own.rgb, explicit.rgb)
    # upright: where the uv AOV says v > 0.75 the pixel is red, v < 0.25 blue
    v = own.aov["uv"][:, :, 1]
    top, bottom = own.rgb[v > 0.75], own.rgb[v < 0.25]
    assert len(top) > 50 and len(bottom) > 50
    assert np.all(top[:, 0] > 5 * top[:, 2]) and np.all(bottom[:, 2] > 5 * bottom[:, 0])
    # and v grows upward on screen (the OBJ's vt 0 1 is the quad's top)
    col = v[:, W // 3]
    rows = np.flatnonzero(np.isfinite(col))
    assert col[rows[0]] > col[rows[-1]]


def test_usemtl_groups_equal_separate_meshes(device, tmp_path):
    (tmp_path / "q.obj").write_text(OBJ.format(a="warm", b="cool"))
    (tmp_path / "m.mtl").write_text("newmtl warm\nKd 0.9 0.4 0.1\nKs 0.5 0.5 0.5\nNs 20\n"
                                    "newmtl cool\nKd 0.1 0.5 0.9\n")
    mesh = tx.Mesh.load(tmp_path / "q.obj")
    assert len(mesh.materials) == 2 and len(set(mesh.face_materials().tolist())) == 2
    one = _render(device, mesh, aovs=("object_id",))
    parts = []
    for k, m in enumerate(mesh.materials):
        keep = mesh.face_materials() == k
        parts.append(tx.Mesh(mesh.positions, mesh.faces[keep], mesh.uvs, mesh.normals,
                             material=tx.Material(diffuse=m.diffuse, specular=m.specular, shininess=m.shininess)))
    sep = _render(device, *parts)
    assert np.all(one.aov["object_id"][np.isfinite(one.rgb[:, :, 0])] >= -1)
    # The same surfaces and shading; the BVHs differ, so only pixels on the shared edge may
    # take the other triangle (watertight ties): compare all but a handful of pixels exactly.
    diff = np.abs(one.rgb - sep.rgb).max(axis=2)
    assert (diff > 1e-6).sum() <= 4, f"{(diff > 1e-6).sum()} pixels differ"
    warm = one.rgb[:, : W // 3]       # left of the camera: the warm quad
    assert warm[..., 0].max() > 2 * warm[..., 2].max()


def test_scene_file_keeps_a_mesh_files_materials(tmp_path, device):
    (tmp_path / "q.obj").write_text(OBJ.format(a="warm", b="cool"))
    (tmp_path / "m.mtl").write_text("newmtl warm\nKd 0.9 0.4 0.1\nnewmtl cool\nKd 0.1 0.5 0.9\n")
    (tmp_path / "s.toml").write_text(
        '[camera]\neye = [0.5, 0, 4]\nlook_at = [0.5, 0, 0]\nfov_y = 45\n'
        '[[lights]]\nposition = [0.5, 0.5, 4]\nintensity = [16, 16, 16]\n'
        '[materials.grey]\ndiffuse = [0.5, 0.5, 0.5]\n'
        '[[objects]]\nmesh = "q.obj"\nrotate = [0, 0, 10]\n'
        '[[objects]]\nmesh = "q.obj"\nmaterial = "grey"\ntranslate = [0, 0, -5]\n')
    scene = tx.load_scene(tmp_path / "s.toml")
    own, over = scene.objects
    assert [m.diffuse for m in own.materials] == [(0.9, 0.4, 0.1), (0.1, 0.5, 0.9)]
    assert own.transform.rotate == [0, 0, 10]
    assert [list(m.diffuse) for m in over.materials] == [[0.5, 0.5, 0.5]]
    img = tx.render(scene, W, H, spp=1, device=device)
    assert img.rgb[..., 0].max() > 0.3 and img.rgb[..., 2].max() > 0.3


# --- glTF ------------------------------------------------------------------------------------------------
_spec = importlib.util.spec_from_file_location("gltf_writer", Path(__file__).resolve().parents[2] / "tools"
                                               / "gltf_writer.py")
gw = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(gw)

P = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [2, -1, 0], [2, 1, 0]], np.float64)
UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [1, 0], [1, 1]], np.float64)      # texray's (v = 0 at the bottom)
N = np.tile([0.0, 0.0, 1.0], (6, 1))
LEFT, RIGHT = np.array([[0, 1, 2], [0, 2, 3]]), np.array([[1, 4, 5], [1, 5, 2]])


def _rows_png():
    return gw.png_bytes(np.array([[[1, 0, 0], [1, 0, 0]], [[0, 0, 1], [0, 0, 1]]], np.float64))


def test_gltf_base_colour_texture_equals_the_texture_given_explicitly_and_is_upright(device, tmp_path):
    w = gw.GltfWriter()
    tex = w.texture(w.image(png=_rows_png()), w.sampler(wrapS=33071, wrapT=33071))
    mat = w.material(pbrMetallicRoughness={"baseColorTexture": {"index": tex}, "metallicFactor": 0.0,
                                           "roughnessFactor": 1.0})
    faces = np.concatenate([LEFT, RIGHT])
    w.scene([w.node(mesh=w.mesh([w.primitive(P, faces, uvs=gw.gltf_uvs(UV), normals=N, material=mat)]))])
    path = w.write(tmp_path / "q.glb")
    (tmp_path / "rows.png").write_bytes(_rows_png())
    own = _render(device, tx.Mesh.load(path), background=(0, 0, 0), aovs=("uv",))
    # the rule at metallic 0, roughness 1: n = 1 (clamped), ks = 0.04 (2 n + 1) / 4
    given = tx.Material(diffuse=tx.Texture.load(tmp_path / "rows.png", wrap="clamp", filter="trilinear"),
                        tint=(1, 1, 1), specular=0.04 * 3 / 4, shininess=1.0)
    explicit = _render(device, tx.Mesh(P, faces, UV, N, material=given), background=(0, 0, 0))
    np.testing.assert_array_equal(own.rgb, explicit.rgb)
    v = own.aov["uv"][:, :, 1]
    top, bottom = own.rgb[v > 0.75], own.rgb[v < 0.25]
    assert len(top) > 50 and len(bottom) > 50
    assert np.all(top[:, 0] > 5 * top[:, 2]) and np.all(bottom[:, 2] > 5 * bottom[:, 0])


def test_gltf_primitives_with_two_materials_are_one_mesh(device, tmp_path):
    w = gw.GltfWriter()
    warm = w.material(pbrMetallicRoughness={"baseColorFactor": [0.9, 0.4, 0.1, 1], "metallicFactor": 0.0})
    cool = w.material(pbrMetallicRoughness={"baseColorFactor": [0.1, 0.5, 0.9, 1], "metallicFactor": 0.0})
    prims = [w.primitive(P, f, normals=N, material=m) for f, m in ((LEFT, warm), (RIGHT, cool))]
    w.scene([w.node(mesh=w.mesh(prims))])
    mesh = tx.Mesh.load(w.write(tmp_path / "two.gltf"))
    assert len(mesh.materials) == 2 and len(mesh.faces) == 4
    one = _render(device, mesh)
    parts = [tx.Mesh(mesh.positions, mesh.faces[mesh.face_materials() == k], None, mesh.normals, material=m)
             for k, m in enumerate(mesh.materials)]
    sep = _render(device, *parts)
    diff = np.abs(one.rgb - sep.rgb).max(axis=2)
    assert (diff > 1e-6).sum() <= 4, f"{(diff > 1e-6).sum()} pixels differ"
    assert one.rgb[:, : W // 3, 0].max() > 2 * one.rgb[:, : W // 3, 2].max()


def test_gltf_scene_with_its_camera_and_point_light(device, tmp_path):
    """A node hierarchy, a camera node and a KHR_lights_punctual light: the same image as the
    scene built explicitly from the numbers the file means."""
    w = gw.GltfWriter()
    mat = w.material(pbrMetallicRoughness={"baseColorFactor": [0.8, 0.7, 0.6, 1], "metallicFactor": 0.0,
                                           "roughnessFactor": 0.6})
    quad = w.node(mesh=w.mesh([w.primitive(P, np.concatenate([LEFT, RIGHT]), normals=N, material=mat)]),
                  translation=[0.0, 0.0, -1.0])
    group = w.node(children=[quad], rotation=[0.0, np.sin(np.radians(10)), 0.0, np.cos(np.radians(10))],
                   scale=[1.5, 1.5, 1.5])
    cam = w.node(camera=w.camera(np.radians(50.0), aspect_ratio=1.5), translation=[0.5, 0.2, 4.0], name="cam")
    lamp = w.node(translation=[1.0, 1.0, 3.0],
                  extensions={"KHR_lights_punctual": {"light": w.light("point", (1.0, 0.9, 0.8), 20.0)}})
    w.scene([group, cam, lamp])
    scene = tx.Scene.load(w.write(tmp_path / "s.glb"))
    assert scene.render_settings["width"] == 640 and scene.render_settings["height"] == round(640 / 1.5)
    assert np.allclose(scene.camera.eye, [0.5, 0.2, 4.0]) and scene.camera.fov_y == pytest.approx(50.0)
    assert np.allclose(scene.lights[0].position, [1, 1, 3]) and np.allclose(scene.lights[0].intensity, [20, 18, 16])
    img = tx.render(scene, 72, 48, spp=2, device=device)
    # the same scene from numbers: world = R_y(20 deg half-angle 10) S(1.5) T(0, 0, -1)
    c, s = np.cos(np.radians(20)), np.sin(np.radians(20))
    m = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) * 1.5
    pw = (P + [0, 0, -1]) @ m.T
    kd, ks, n = [0.8, 0.7, 0.6], None, (2 / 0.6 ** 4 - 2) / 4
    ks = 0.04 * (2 * n + 1) / 4
    ref = tx.Scene(camera=tx.Camera(eye=(0.5, 0.2, 4.0), look_at=(0.5, 0.2, 3.0), fov_y=50.0),
                   lights=[tx.PointLight((1, 1, 3), (20, 18, 16))])
    ref.add(tx.Mesh(pw, np.concatenate([LEFT, RIGHT]), normals=N @ m.T / 1.5,
                    material=tx.Material(diffuse=kd, specular=ks, shininess=n)))
    want = tx.render(ref, 72, 48, spp=2, device=device)
    assert want.rgb.max() > 0.2
    np.testing.assert_allclose(img.rgb, want.rgb, atol=2e-5)


def test_the_shipped_gltf_scene_loads_with_its_cameras_and_lights(scenes_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error")            # the showcase file needs no approximation
        scene = tx.Scene.load(scenes_dir / "gltf" / "still_life.glb")
    assert len(scene.objects) == 4 and len(scene.lights) == 2
    top = tx.Scene.load(scenes_dir / "gltf" / "still_life.glb", camera="Camera top")
    assert top.camera.eye[1] == pytest.approx(5.0)
    with pytest.raises(tx.SceneError, match=r"camera: no camera named 'x' \(the file has: 'Camera', 'Camera top'\)"):
        tx.Scene.load(scenes_dir / "gltf" / "still_life.glb", camera="x")


def test_a_scene_file_places_a_gltf_file_with_its_materials(tmp_path):
    w = gw.GltfWriter()
    warm = w.material(pbrMetallicRoughness={"baseColorFactor": [0.9, 0.4, 0.1, 1], "metallicFactor": 0.0})
    cool = w.material(pbrMetallicRoughness={"baseColorFactor": [0.1, 0.5, 0.9, 1], "metallicFactor": 0.0})
    w.scene([w.node(mesh=w.mesh([w.primitive(P, f, normals=N, material=m) for f, m in ((LEFT, warm), (RIGHT, cool))]),
                    translation=[0.0, 5.0, 0.0])])
    w.write(tmp_path / "two.glb")
    (tmp_path / "s.toml").write_text('[[objects]]\nmesh = "two.glb"\ntranslate = [1, 0, 0]\nscale = 2\n')
    mesh = tx.load_scene(tmp_path / "s.toml").objects[0]
    assert [tuple(m.diffuse) for m in mesh.materials] == [pytest.approx((0.9, 0.4, 0.1)), pytest.approx((0.1, 0.5, 0.9))]
    p, _ = mesh.world()                    # the file's node transform, then the scene file's
    np.testing.assert_allclose(p[mesh.faces[0]], (P[LEFT[0]] + [0, 5, 0]) * 2 + [1, 0, 0], atol=1e-12)


def test_gltf_nodes_sharing_a_mesh_are_instances(device, tmp_path):
    """Three nodes place one glTF mesh (one mirrored): two become Instances of one Mesh (its
    triangles stored once), the mirrored one a copy; the image equals the all-copies scene
    within float rounding of the moved rays (1e-4; at most 0.2% of pixels, silhouettes, more)."""
    from texray.io.gltf_scene import load_gltf_scene
    w = gw.GltfWriter()
    mat = w.material(pbrMetallicRoughness={"baseColorFactor": [0.8, 0.5, 0.3, 1], "metallicFactor": 0.0,
                                           "roughnessFactor": 0.7})
    mesh = w.mesh([w.primitive(P, np.concatenate([LEFT, RIGHT]), normals=N, material=mat)])
    nodes = [w.node(mesh=mesh, translation=[-1.5, 0.5, -1.0], scale=[0.5, 0.5, 0.5]),
             w.node(mesh=mesh, translation=[1.0, -0.5, -0.5], rotation=[0, 0.3826834, 0, 0.9238795]),
             w.node(mesh=mesh, translation=[0.0, 1.2, -2.0], scale=[-0.6, 0.6, 0.6])]
    cam = w.node(camera=w.camera(np.radians(55.0), aspect_ratio=1.5), translation=[0.0, 0.3, 4.0])
    lamp = w.node(translation=[1.0, 2.0, 3.0],
                  extensions={"KHR_lights_punctual": {"light": w.light("point", (1, 1, 1), 25.0)}})
    w.scene(nodes + [cam, lamp])
    path = w.write(tmp_path / "shared.glb")
    inst, copies = load_gltf_scene(path), load_gltf_scene(path, instances=False)
    kinds = [type(o).__name__ for o in inst.objects]
    assert kinds == ["Instance", "Instance", "Mesh"] and inst.objects[0].mesh is inst.objects[1].mesh
    assert [type(o).__name__ for o in copies.objects] == ["Mesh"] * 3
    a = tx.render(inst, 72, 48, spp=1, device=device, cache=False)
    b = tx.render(copies, 72, 48, spp=1, device=device, cache=False)
    assert a.stats["triangles"] == 2 * 4 and b.stats["triangles"] == 3 * 4      # one stored copy + the mirrored one
    assert b.rgb.max() > 0.2
    diff = np.abs(a.rgb - b.rgb).max(axis=2)
    assert (diff > 1e-4).mean() <= 0.002 and diff.max() < 0.5, (diff.max(), (diff > 1e-4).sum())
