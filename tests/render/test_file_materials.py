"""Mesh files' own materials through the whole renderer: each file format against the same
mesh with its texture given explicitly, the texture's orientation (v = 0 is the image's
bottom row), and meshes with several materials against separate meshes."""
import numpy as np

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
