"""texray.io.gltf: the glTF 2.0 reader. Files are written by tools/gltf_writer.py; numbers
are checked against numpy evaluations of the glTF spec (nothing is rendered; texture
lookups go through compile_scene's texture table and tests/reference.py)."""
import importlib.util
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import reference as ref
import texray as tx
from texray.compile import compile_scene
from texray.io.colour import srgb_to_linear
from texray.io.gltf import read_gltf
from texray.io.gltf_data import GltfDocument
from texray.io.gltf_materials import (bake_scaled_normals, gltf_uv_transform_apply, metal_rough_to_phong,
                                      phong_exponent, sampler_options, uv_transform_from_gltf)
from texray.io.images import read_texture_bytes

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("gltf_writer", REPO / "tools" / "gltf_writer.py")
gw = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(gw)

QUAD_P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
QUAD_F = np.array([[0, 1, 2], [0, 2, 3]])
QUAD_UV = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], float)     # glTF uvs: the image's top row at +y
QUAD_N = np.tile([0.0, 0.0, 1.0], (4, 1))
RNG = np.random.default_rng(1234)
IMG = RNG.random((4, 6, 3))           # float pixels; the PNG holds round(255 x)
MR_IMG = RNG.random((3, 5, 3))


def png_values(pixels):
    return np.round(np.clip(pixels, 0, 1) * 255) / 255


def read(path, **kw):
    with warnings.catch_warnings(record=True) as ws:
        warnings.simplefilter("always")
        f = read_gltf(path, **kw)
    return f, [str(w.message) for w in ws]


def quad_file(tmp_path, material=None, name="q.glb", uvs=QUAD_UV, normals=QUAD_N, writer=None, **node):
    w = writer or gw.GltfWriter()
    w.scene([w.node(mesh=w.mesh([w.primitive(QUAD_P, QUAD_F, uvs=uvs, normals=normals, material=material)]),
                    **node)])
    return w.write(tmp_path / name)


def textured(w, pixels=IMG, sampler=None, embed="buffer", **pbr):
    tex = w.texture(w.image(pixels, embed=embed), sampler)
    return w.material(name="Tex", pbrMetallicRoughness={"baseColorTexture": {"index": tex}, "metallicFactor": 0.0,
                                                        **pbr})


def texray_sample(material, uvs, slot="diffuse_tex"):
    """What texray's texture role ``slot`` of ``material`` reads at surface uvs (N, 2): through
    compile_scene's texture table (half texels, the texture's transform, wrap and filter)."""
    n = len(uvs)
    p = np.zeros((3 * n, 3))
    p[1::3, 0] = 1.0
    p[2::3, 1] = 1.0
    p += np.repeat(np.arange(n), 3)[:, None] * np.array([0, 0, 1.0])
    uv3 = np.repeat(uvs, 3, axis=0)
    mesh = tx.Mesh(p, np.arange(3 * n).reshape(-1, 3), uvs=uv3, material=material)
    scene = tx.Scene(camera=tx.Camera(eye=(0, 0, -5)), lights=[tx.PointLight(position=(0, 0, -5))], objects=[mesh])
    cs = compile_scene(scene)
    return ref.sample(cs, int(cs.materials[slot][0]), uvs)


# --- accessors ---------------------------------------------------------------------------
@pytest.mark.parametrize("ct", [5120, 5121, 5122, 5123, 5125, 5126])
def test_accessors_of_every_component_type(tmp_path, ct):
    dtype = gw.DTYPES[ct]
    if dtype.kind == "f":
        values = RNG.normal(size=(7, 3)).astype(np.float32)
    else:
        info = np.iinfo(dtype)
        values = RNG.integers(info.min, info.max, size=(7, 3), endpoint=True).astype(dtype)
        values[0] = [info.min, info.max, 0]
    w = gw.GltfWriter()
    plain = w.accessor(values, component_type=ct)
    norm = w.accessor(values, component_type=ct, normalized=True) if ct in (5120, 5121, 5122, 5123) else None
    doc = GltfDocument(w.write(tmp_path / "a.gltf"))
    got = doc.accessor(plain, "test")
    assert got.shape == (7, 3)
    np.testing.assert_array_equal(got, values.astype(np.float64))
    assert got.dtype == (np.float64 if dtype.kind == "f" else np.int64)
    if norm is not None:
        bits = dtype.itemsize * 8
        want = (np.maximum(values / (2.0 ** (bits - 1) - 1), -1.0) if dtype.kind == "i"
                else values / (2.0 ** bits - 1))
        got = doc.accessor(norm, "test")
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
        assert got.min() >= -1 and got.max() <= 1
        assert (got[0, 0], got[0, 1]) == ((-1.0 if dtype.kind == "i" else 0.0), 1.0)


def test_interleaved_strided_accessors_with_offsets(tmp_path):
    pos = RNG.normal(size=(5, 3)).astype(np.float32)
    uv = RNG.random((5, 2)).astype(np.float32)
    w = gw.GltfWriter()
    view = w.buffer_view(b"\xee" * 8 + np.concatenate([pos, uv], axis=1).tobytes(), stride=20)
    w.json["accessors"] = [{"bufferView": view, "byteOffset": 8, "componentType": 5126, "count": 5, "type": "VEC3"},
                           {"bufferView": view, "byteOffset": 20, "componentType": 5126, "count": 5, "type": "VEC2"}]
    # a padded stride through the writer too (12-byte elements every 16 bytes, 4 bytes in)
    padded = w.accessor(pos, stride=16, byte_offset=4)
    doc = GltfDocument(w.write(tmp_path / "s.glb"))
    np.testing.assert_array_equal(doc.accessor(0, "t"), pos)
    np.testing.assert_array_equal(doc.accessor(1, "t"), uv)
    np.testing.assert_array_equal(doc.accessor(padded, "t"), pos)


def test_sparse_accessors_and_accessors_without_a_buffer_view(tmp_path):
    base = RNG.normal(size=(6, 3)).astype(np.float32)
    idx = np.array([1, 4], np.uint16)
    vals = np.array([[9, 8, 7], [6, 5, 4]], np.float32)
    w = gw.GltfWriter()
    a = w.accessor(base)
    iv, vv = w.buffer_view(idx.tobytes()), w.buffer_view(b"\0" * 4 + vals.tobytes())
    sparse = {"count": 2, "indices": {"bufferView": iv, "componentType": 5123},
              "values": {"bufferView": vv, "byteOffset": 4}}
    w.json["accessors"][a]["sparse"] = sparse
    w.json["accessors"].append({"componentType": 5126, "count": 6, "type": "VEC3", "sparse": sparse})
    w.json["accessors"].append({"componentType": 5121, "count": 4, "type": "VEC2", "normalized": True})
    doc = GltfDocument(w.write(tmp_path / "sp.gltf", buffer="data"))
    want = base.astype(np.float64)
    want[idx] = vals
    np.testing.assert_array_equal(doc.accessor(a, "t"), want)
    zeros = np.zeros((6, 3))
    zeros[idx] = vals
    np.testing.assert_array_equal(doc.accessor(a + 1, "t"), zeros)
    np.testing.assert_array_equal(doc.accessor(a + 2, "t"), np.zeros((4, 2)))


def test_matrix_accessors_skip_column_padding(tmp_path):
    # MAT2 of bytes: each 2-byte column starts on a 4-byte boundary (8 bytes an element)
    cols = np.array([[1, 2, 3, 4], [5, 6, 7, 8]], np.uint8)            # two elements, column-major
    raw = np.zeros((2, 8), np.uint8)
    raw[:, [0, 1, 4, 5]] = cols
    w = gw.GltfWriter()
    w.json["accessors"] = [{"bufferView": w.buffer_view(raw.tobytes()), "componentType": 5121, "count": 2,
                            "type": "MAT2"}]
    doc = GltfDocument(w.write(tmp_path / "m.glb"))
    np.testing.assert_array_equal(doc.accessor(0, "t"), cols)


# --- containers -------------------------------------------------------------------------
@pytest.mark.parametrize("name, buffer, embed", [("a.glb", None, "buffer"), ("a.gltf", "file", "file"),
                                                 ("a.gltf", "data", "data"), ("a.gltf", "file", "buffer")])
def test_glb_gltf_external_and_data_uris_read_the_same(tmp_path, name, buffer, embed):
    w = gw.GltfWriter()
    path = quad_file(tmp_path, textured(w, embed=embed), name=name, writer=w)
    if buffer is not None:
        path = w.write(tmp_path / name, buffer=buffer)
    if buffer == "file":
        assert (tmp_path / "a.bin").exists()
    f, msgs = read(path)
    assert not msgs and len(f.meshes) == 1 and f.path == str(path)
    m = f.meshes[0]
    np.testing.assert_array_equal(m.positions, QUAD_P)
    np.testing.assert_array_equal(m.faces, QUAD_F)
    np.testing.assert_array_equal(m.normals, QUAD_N)
    np.testing.assert_allclose(m.uvs, np.column_stack([QUAD_UV[:, 0], 1 - QUAD_UV[:, 1]]))
    tex = m.materials[0].diffuse
    assert tex.colorspace == "srgb"
    np.testing.assert_allclose(tex.raw, png_values(IMG), atol=1e-7)
    assert m.name == f"{path}: nodes[0]"


# --- the node hierarchy -------------------------------------------------------------------
def axis_angle_quaternion(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.append(axis * math.sin(angle / 2), math.cos(angle / 2))


def rodrigues(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx @ kx


def trs(t, axis, angle, s):
    m = np.eye(4)
    m[:3, :3] = rodrigues(axis, angle) @ np.diag(s)
    m[:3, 3] = t
    return m


def test_nested_matrix_and_trs_nodes_compose_parent_times_child(tmp_path):
    root = trs([1, 2, 3], [0, 1, 0], 0.7, [2, 2, 2])
    mid = RNG.normal(size=(4, 4))
    mid[3] = [0, 0, 0, 1]
    if np.linalg.det(mid[:3, :3]) > 0:
        mid[:3, 0] *= -1                      # a mirroring node in the middle of the chain
    leaf = trs([0, -1, 0.5], [1, 1, 0], -1.1, [1, 3, 0.5])
    w = gw.GltfWriter()
    mesh = w.mesh([w.primitive(QUAD_P, QUAD_F, normals=QUAD_N)], name="Quad")
    leaf_n = w.node(mesh=mesh, translation=[0, -1, 0.5], rotation=axis_angle_quaternion([1, 1, 0], -1.1),
                    scale=[1, 3, 0.5])
    mid_n = w.node(matrix=mid, children=[leaf_n])
    other = w.node(mesh=mesh, name="Again")                                  # the same mesh, instanced
    root_n = w.node(translation=[1, 2, 3], rotation=axis_angle_quaternion([0, 1, 0], 0.7), scale=[2, 2, 2],
                    children=[mid_n, other])
    w.scene([root_n])
    f, _ = read(w.write(tmp_path / "h.glb"))
    assert [m.name.split(": ", 1)[1] for m in f.meshes] == ["nodes[0] 'Quad'", "nodes[2] 'Again'"]
    for m, world in zip(f.meshes, (root @ mid @ leaf, root)):
        want = QUAD_P @ world[:3, :3].T + world[:3, 3]
        np.testing.assert_allclose(m.positions, want, atol=1e-12)
        n = QUAD_N @ np.linalg.inv(world[:3, :3])
        np.testing.assert_allclose(m.normals, n / np.linalg.norm(n, axis=1, keepdims=True), atol=1e-12)
        # the triangles' front (vertex order) stays on the normals' side, mirrored or not
        p, fc = m.positions, m.faces
        g = np.cross(p[fc[:, 1]] - p[fc[:, 0]], p[fc[:, 2]] - p[fc[:, 0]])
        assert np.all(np.sum(g * m.normals[fc[:, 0]], axis=1) > 0)
    assert np.linalg.det((root @ mid @ leaf)[:3, :3]) < 0
    np.testing.assert_array_equal(f.meshes[0].faces, QUAD_F[:, [0, 2, 1]])
    np.testing.assert_array_equal(f.meshes[1].faces, QUAD_F)


def test_a_mirroring_node_reverses_the_vertex_order(tmp_path):
    f, _ = read(quad_file(tmp_path, scale=[-1, 1, 1]))
    m = f.meshes[0]
    np.testing.assert_array_equal(m.faces, QUAD_F[:, [0, 2, 1]])
    np.testing.assert_allclose(m.normals, QUAD_N)
    p = m.positions
    g = np.cross(p[m.faces[:, 1]] - p[m.faces[:, 0]], p[m.faces[:, 2]] - p[m.faces[:, 0]])
    assert np.all(g[:, 2] > 0)


def test_the_default_scene_and_root_nodes(tmp_path):
    w = gw.GltfWriter()
    mesh = w.mesh([w.primitive(QUAD_P, QUAD_F)])
    a, b = w.node(mesh=mesh, name="A"), w.node(mesh=mesh, name="B")
    w.json["scenes"] = [{"nodes": [a]}, {"nodes": [b]}]
    w.json["scene"] = 1
    f, _ = read(w.write(tmp_path / "s.glb"))
    assert [m.name.endswith("'B'") for m in f.meshes] == [True]
    del w.json["scene"]
    f, _ = read(w.write(tmp_path / "s.glb"))
    assert [m.name.endswith("'A'") for m in f.meshes] == [True]
    del w.json["scenes"]
    c = w.node(mesh=mesh, name="C")
    w.json["nodes"][a]["children"] = [c]
    f, _ = read(w.write(tmp_path / "s.glb"))                   # no scenes: every root node, depth first
    assert [m.name.split()[-1] for m in f.meshes] == ["'A'", "'C'", "'B'"]


# --- primitives -------------------------------------------------------------------------
def test_strips_fans_sequential_indices_and_skipped_points(tmp_path):
    w = gw.GltfWriter()
    p = RNG.normal(size=(6, 3))
    prims = [w.primitive(p, np.arange(6), mode=5), w.primitive(p, [5, 0, 1, 2, 3], mode=6),
             w.primitive(p[:3]), w.primitive(p, mode=0), w.primitive(p, [0, 1], mode=1)]
    w.scene([w.node(mesh=w.mesh(prims))])
    f, msgs = read(w.write(tmp_path / "p.glb"))
    m = f.meshes[0]
    strip = [[0, 1, 2], [1, 3, 2], [2, 3, 4], [3, 5, 4]]        # the spec: (i, i + 1 + i % 2, i + 2 - i % 2)
    fan = [[0, 1, 5], [1, 2, 5], [2, 3, 5]]
    want = np.array(strip + (np.array(fan) + 6).tolist() + [[12, 13, 14]])
    np.testing.assert_array_equal(m.faces, want)
    np.testing.assert_allclose(m.positions, np.concatenate([p, p, p[:3]]))
    pts = [x for x in msgs if "points and lines skipped" in x]
    assert len(pts) == 1 and "POINTS" in pts[0] and "LINES" in pts[0] and "primitives[3]" in pts[0]
    assert m.uvs is None and m.normals is None


def test_two_primitives_two_materials_and_mixed_attributes(tmp_path):
    w = gw.GltfWriter()
    red = w.material(name="Red", pbrMetallicRoughness={"baseColorFactor": [1, 0, 0, 1], "metallicFactor": 0.0})
    blue = w.material(name="Blue", pbrMetallicRoughness={"baseColorFactor": [0, 0, 1, 1], "metallicFactor": 0.0})
    prims = [w.primitive(QUAD_P, QUAD_F, uvs=QUAD_UV, material=red),
             w.primitive(QUAD_P + 2, QUAD_F[:1], normals=QUAD_N, material=blue),
             w.primitive(QUAD_P + 4, QUAD_F, material=red)]
    mesh = w.mesh(prims)
    w.scene([w.node(mesh=mesh), w.node(mesh=w.mesh([w.primitive(QUAD_P, QUAD_F, material=blue)]))])
    f, _ = read(w.write(tmp_path / "m.glb"))
    m = f.meshes[0]
    np.testing.assert_array_equal(m.material_ids, [0, 0, 1, 0, 0])
    assert [x.diffuse for x in m.materials] == [(1, 0, 0), (0, 0, 1)]
    assert f.meshes[1].materials[0] is m.materials[1]              # one Material per glTF material
    np.testing.assert_array_equal(m.faces, np.concatenate([QUAD_F, QUAD_F[:1] + 4, QUAD_F + 8]))
    # uvs: only the first primitive's, zeros for the others; normals: the second's
    np.testing.assert_allclose(m.uvs[:4], np.column_stack([QUAD_UV[:, 0], 1 - QUAD_UV[:, 1]]))
    assert not m.uvs[4:].any() and m.uvs.shape == (12, 2)
    np.testing.assert_array_equal(m.normals[4:8], QUAD_N)
    assert not m.normals[:4].any() and not m.normals[8:].any()


def test_materials_false_reads_no_image(tmp_path):
    w = gw.GltfWriter()
    path = quad_file(tmp_path, textured(w, embed="file"), writer=w, name="n.gltf")
    (tmp_path / "image0.png").unlink()
    f, _ = read(path, materials=False)
    assert f.meshes[0].materials[0] == tx.Material()
    with pytest.raises(tx.SceneError, match="image0.png"):
        read_gltf(path)


# --- texture coordinates --------------------------------------------------------------------
def test_the_uv_flip_samples_the_texel_gltf_samples(tmp_path):
    """glTF's uv (0, 0) is the image's top-left corner; texray's v = 0 is its bottom row: the
    texel texray reads at the reader's uvs is the one glTF reads at the file's uvs."""
    h, wd = IMG.shape[:2]
    cells = np.stack(np.meshgrid(np.arange(wd), np.arange(h)), axis=-1).reshape(-1, 2)
    gl_uv = ((cells + 0.5 + RNG.uniform(-0.3, 0.3, cells.shape)) / [wd, h]).astype(np.float32)  # inside each texel
    w = gw.GltfWriter()
    nearest = w.sampler(magFilter=9728, minFilter=9728)
    mat = textured(w, sampler=nearest)
    p = RNG.normal(size=(len(gl_uv), 3))
    w.scene([w.node(mesh=w.mesh([w.primitive(p, None, uvs=gl_uv, material=mat, mode=0)]))])
    # points are skipped: read the uvs through a triangle primitive of the same vertices instead
    w.json["meshes"][0]["primitives"][0]["mode"] = 4
    w.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = w.accessor(
        np.repeat(np.eye(3)[None], len(gl_uv) // 3 + 1, axis=0).reshape(-1, 3)[:len(gl_uv)])
    f, _ = read(w.write(tmp_path / "uv.glb"))
    m = f.meshes[0]
    np.testing.assert_array_equal(m.uvs, np.column_stack([gl_uv[:, 0], 1 - gl_uv[:, 1].astype(np.float64)]))
    row, col = np.floor(gl_uv[:, 1] * h).astype(int), np.floor(gl_uv[:, 0] * wd).astype(int)
    want = srgb_to_linear(png_values(IMG))[row, col]
    got = texray_sample(m.materials[0], m.uvs)[:, :3]
    np.testing.assert_allclose(got, want, atol=2e-3)


def test_texture_transform_is_the_same_map_in_flipped_coordinates():
    rng = np.random.default_rng(7)
    flip = np.array([1.0, -1.0]), np.array([0.0, 1.0])
    for _ in range(50):
        offset, rotation = rng.normal(size=2), rng.uniform(-7, 7)
        scale = rng.uniform(0.2, 3, 2) * rng.choice([-1, 1], 2)
        t = uv_transform_from_gltf(offset, rotation, scale)
        y = rng.normal(size=(20, 2))                              # texray coordinates
        x = y * flip[0] + flip[1]                                 # the same points in glTF's
        want = gltf_uv_transform_apply(x, offset, rotation, scale) * flip[0] + flip[1]
        np.testing.assert_allclose(t.apply(y), want, atol=1e-12)
        assert t.rotation == pytest.approx(math.degrees(rotation)) and t.scale == tuple(scale)


def test_the_gltf_transform_follows_the_extensions_example():
    """KHR_texture_transform's example: offset (0, 1), rotation pi/2, scale 0.5 uses 'the lower
    left quadrant of the source image, rotated clockwise 90 degrees' (glTF's v points down)."""
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    out = gltf_uv_transform_apply(corners, (0, 1), math.pi / 2, (0.5, 0.5))
    np.testing.assert_allclose(out.min(axis=0), [0, 0.5], atol=1e-12)
    np.testing.assert_allclose(out.max(axis=0), [0.5, 1], atol=1e-12)
    # u grows along the image's down direction: the image is turned 90 degrees clockwise on the surface
    np.testing.assert_allclose(out[1] - out[0], [0, -0.5], atol=1e-12)


def test_a_transformed_texture_samples_what_gltf_samples(tmp_path):
    offset, rotation, scale = [0.3, -0.2], 0.6, [1.7, -0.8]
    w = gw.GltfWriter()
    mat = textured(w, sampler=w.sampler(magFilter=9728, minFilter=9728))
    w.json["materials"][mat]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = {
        "KHR_texture_transform": {"offset": offset, "rotation": rotation, "scale": scale}}
    w.use_extension("KHR_texture_transform")
    f, _ = read(quad_file(tmp_path, mat, writer=w))
    material = f.meshes[0].materials[0]
    gl_uv = RNG.random((200, 2))
    g = gltf_uv_transform_apply(gl_uv, offset, rotation, scale)
    h, wd = IMG.shape[:2]
    row, col = np.floor(g[:, 1] * h).astype(int) % h, np.floor(g[:, 0] * wd).astype(int) % wd
    gx, gy = g[:, 0] * wd, g[:, 1] * h
    safe = (np.abs(gx - np.round(gx)) > 1e-3) & (np.abs(gy - np.round(gy)) > 1e-3)    # off texel edges
    want = srgb_to_linear(png_values(IMG))[row, col]
    got = texray_sample(material, np.column_stack([gl_uv[:, 0], 1 - gl_uv[:, 1]]))[:, :3]
    np.testing.assert_allclose(got[safe], want[safe], atol=2e-3)


# --- samplers -----------------------------------------------------------------------------
@pytest.mark.parametrize("sampler, want", [
    ({}, ("repeat", "trilinear")),
    ({"wrapS": 33071, "wrapT": 33071, "minFilter": 9729}, ("clamp", "bilinear")),
    ({"wrapS": 33648, "wrapT": 33648, "magFilter": 9728, "minFilter": 9987}, ("mirror", "nearest")),
    ({"magFilter": 9729, "minFilter": 9984}, ("repeat", "trilinear")),
    ({"minFilter": 9728}, ("repeat", "bilinear")),
])
def test_samplers_become_texture_wrap_and_filter(tmp_path, sampler, want):
    w = gw.GltfWriter()
    f, msgs = read(quad_file(tmp_path, textured(w, sampler=w.sampler(**sampler)), writer=w))
    t = f.meshes[0].materials[0].diffuse
    assert (t.wrap, t.filter) == want and not msgs


def test_different_wrap_s_and_t_take_wrap_s_with_a_warning(tmp_path):
    assert sampler_options(33071, 10497, None, None) == ("clamp", "trilinear", True)
    w = gw.GltfWriter()
    f, msgs = read(quad_file(tmp_path, textured(w, sampler=w.sampler(wrapS=33648, wrapT=33071)), writer=w))
    assert f.meshes[0].materials[0].diffuse.wrap == "mirror"
    assert len(msgs) == 1 and "wrapS" in msgs[0] and "samplers[0]" in msgs[0]


def test_one_image_is_one_texture_whatever_its_samplers(tmp_path):
    w = gw.GltfWriter()
    img = w.image(IMG)
    t1, t2 = w.texture(img, w.sampler(wrapS=33071, wrapT=33071)), w.texture(img)
    m1 = w.material(pbrMetallicRoughness={"baseColorTexture": {"index": t1}, "metallicFactor": 0})
    m2 = w.material(pbrMetallicRoughness={"baseColorTexture": {"index": t2}, "metallicFactor": 0})
    m3 = w.material(pbrMetallicRoughness={"baseColorTexture": {"index": t2}, "metallicFactor": 0,
                                          "roughnessFactor": 0.5})
    prims = [w.primitive(QUAD_P, QUAD_F, uvs=QUAD_UV, material=m) for m in (m1, m2, m3)]
    w.scene([w.node(mesh=w.mesh(prims))])
    f, _ = read(w.write(tmp_path / "t.glb"))
    d = [m.diffuse for m in f.meshes[0].materials]
    assert d[0].raw is d[1].raw and d[1] is d[2]
    assert (d[0].wrap, d[1].wrap) == ("clamp", "repeat")


def test_tex_coord_1_uses_tex_coord_0_with_a_warning(tmp_path):
    w = gw.GltfWriter()
    mat = textured(w)
    w.json["materials"][mat]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 1
    f, msgs = read(quad_file(tmp_path, mat, writer=w))
    assert isinstance(f.meshes[0].materials[0].diffuse, tx.Texture)
    assert len(msgs) == 1 and "TEXCOORD_0" in msgs[0] and "texCoord 1" in msgs[0]


# --- the material rule ----------------------------------------------------------------------
def rule(base, m, r):
    """The rule in float64 numpy, written out."""
    base, m, r = np.asarray(base, float), np.asarray(m, float)[..., None], np.asarray(r, float)
    alpha = r ** 2
    with np.errstate(divide="ignore"):
        n = np.clip((2 / alpha ** 2 - 2) / 4, 1, 2048)
    return base * (1 - m), (0.04 * (1 - m) + base * m) * ((2 * n[..., None] + 1) / 4), n


def test_phong_exponent_and_the_rule():
    r = np.array([0.0, 0.05, 0.2, 0.5, 0.9, 1.0])
    np.testing.assert_allclose(phong_exponent(r), [2048, 2048, (2 / 0.2 ** 4 - 2) / 4, 7.5, 1, 1])
    base, m = RNG.random((10, 3)), RNG.random(10)
    rr = RNG.uniform(0.1, 1, 10)
    for got, want in zip(metal_rough_to_phong(base, m, rr), rule(base, m, rr)):
        np.testing.assert_allclose(got, want, rtol=1e-14)


def test_constant_factors_give_constants(tmp_path):
    w = gw.GltfWriter()
    mat = w.material(pbrMetallicRoughness={"baseColorFactor": [0.8, 0.4, 0.2, 0.5], "metallicFactor": 0.3,
                                           "roughnessFactor": 0.4})
    f, _ = read(quad_file(tmp_path, mat, writer=w))
    m = f.meshes[0].materials[0]
    kd, ks, n = rule([0.8, 0.4, 0.2], 0.3, 0.4)
    np.testing.assert_allclose(m.diffuse, kd)
    np.testing.assert_allclose(m.specular, ks)
    assert m.shininess == pytest.approx(float(n)) and m.tint == (1, 1, 1)
    # no material: texray's default grey (glTF's default, a white rough metal, renders as a sheen)
    f, _ = read(quad_file(tmp_path, None, name="d.glb"))
    assert f.meshes[0].materials[0] == tx.Material()


def test_a_base_colour_texture_is_tinted_and_its_metal_baked(tmp_path):
    w = gw.GltfWriter()
    mat = textured(w, baseColorFactor=[0.5, 1, 0.25, 1], metallicFactor=0.0, roughnessFactor=0.5)
    f, _ = read(quad_file(tmp_path, mat, writer=w))
    m = f.meshes[0].materials[0]
    assert m.tint == (0.5, 1, 0.25) and m.shininess == pytest.approx(7.5)
    assert m.specular == pytest.approx(0.04 * (2 * 7.5 + 1) / 4)
    w.json["materials"][mat]["pbrMetallicRoughness"]["metallicFactor"] = 0.75
    f, _ = read(w.write(tmp_path / "b.glb"))
    m = f.meshes[0].materials[0]
    base = srgb_to_linear(png_values(IMG)).astype(np.float64) * [0.5, 1, 0.25]
    kd, ks, _ = rule(base, np.full(base.shape[:2], 0.75), 0.5)
    assert m.tint == pytest.approx((0.125, 0.25, 0.0625))
    np.testing.assert_allclose(m.specular.raw, ks, rtol=1e-6, atol=2e-6)
    assert m.diffuse.raw is f.meshes[0].materials[0].diffuse.raw


def bilinear_ref(img, uv, mode):
    return ref.bilinear_level(img, uv.reshape(-1, 2), mode).reshape(uv.shape[:-1] + (img.shape[2],))


@pytest.mark.parametrize("transforms", [False, True])
def test_metallic_roughness_textures_are_baked_by_the_rule(tmp_path, transforms):
    w = gw.GltfWriter()
    base_t = w.texture(w.image(IMG), w.sampler(wrapS=33071, wrapT=33071))
    mr_t = w.texture(w.image(MR_IMG), w.sampler(wrapS=33648, wrapT=33648, magFilter=9728))
    factor, mf, rf = np.array([0.9, 0.6, 0.3]), 0.8, 0.7
    pbr = {"baseColorTexture": {"index": base_t}, "metallicRoughnessTexture": {"index": mr_t},
           "baseColorFactor": list(factor) + [1], "metallicFactor": mf, "roughnessFactor": rf}
    tb = tm = None
    if transforms:
        xb, xm = ([0.1, 0.2], 0.3, [2, 1.5]), ([-0.4, 0.1], -1.2, [0.7, 1.1])
        for key, x in (("baseColorTexture", xb), ("metallicRoughnessTexture", xm)):
            pbr[key]["extensions"] = {"KHR_texture_transform": dict(zip(("offset", "rotation", "scale"), x))}
        tb, tm = uv_transform_from_gltf(*xb), uv_transform_from_gltf(*xm)
    mat = w.material(pbrMetallicRoughness=pbr)
    f, _ = read(quad_file(tmp_path, mat, writer=w))
    m = f.meshes[0].materials[0]
    mr = png_values(MR_IMG)
    metal, rough = mf * mr[:, :, 2], rf * mr[:, :, 1]
    _, ks, n = rule(factor, metal, rough)
    np.testing.assert_allclose(m.specular.raw, ks, rtol=1e-6, atol=2e-6)
    np.testing.assert_allclose(m.shininess * m.shininess_map.raw[:, :, 0], n, rtol=1e-5)
    assert m.shininess == pytest.approx(n.max()) and m.shininess_map.channels == 1
    assert (m.specular.wrap, m.specular.filter, m.shininess_map.wrap) == ("mirror", "nearest", "mirror")
    # kd on the base texture's grid, m bilinear from the metallic-roughness texture at the same surface point
    h, wd = IMG.shape[:2]
    s = np.stack(np.meshgrid((np.arange(wd) + 0.5) / wd, 1 - (np.arange(h) + 0.5) / h), axis=-1)
    if transforms:
        mb = tb.matrix()
        surface = np.linalg.solve(mb[:, :2], (s - mb[:, 2]).reshape(-1, 2).T).T.reshape(s.shape)
        s_mr = tm.apply(surface)
        assert m.diffuse.uv_transform == tb and m.specular.uv_transform == tm
    else:
        s_mr = s
    m_at = mf * bilinear_ref(mr, s_mr, 2)[:, :, 2]
    kd, _, _ = rule(srgb_to_linear(png_values(IMG)) * factor, m_at, 0.5)
    np.testing.assert_allclose(m.diffuse.raw, kd, atol=2e-6)
    assert (m.diffuse.wrap, m.diffuse.colorspace, m.tint) == ("clamp", "linear", (1, 1, 1))


def test_a_metallic_roughness_texture_without_base_texture_bakes_kd_on_its_grid(tmp_path):
    w = gw.GltfWriter()
    mat = w.material(pbrMetallicRoughness={"metallicRoughnessTexture": {"index": w.texture(w.image(MR_IMG))},
                                           "baseColorFactor": [0.2, 0.4, 0.6, 1]})
    f, _ = read(quad_file(tmp_path, mat, writer=w))
    m = f.meshes[0].materials[0]
    mr = png_values(MR_IMG)
    kd, ks, n = rule([0.2, 0.4, 0.6], mr[:, :, 2], mr[:, :, 1])
    np.testing.assert_allclose(m.diffuse.raw, kd, atol=2e-6)
    np.testing.assert_allclose(m.specular.raw, ks, rtol=1e-6, atol=2e-6)


# --- normal maps --------------------------------------------------------------------------
NORMAL_IMG = np.concatenate([RNG.uniform(0.2, 0.8, (3, 4, 2)), RNG.uniform(0.7, 1, (3, 4, 1))], axis=2)


def normal_file(tmp_path, scale=None, uvs=QUAD_UV, pixels=NORMAL_IMG):
    w = gw.GltfWriter()
    info = {"index": w.texture(w.image(pixels))}
    if scale is not None:
        info["scale"] = scale
    mat = w.material(pbrMetallicRoughness={"metallicFactor": 0}, normalTexture=info)
    return quad_file(tmp_path, mat, writer=w, uvs=uvs)


def test_normal_maps_and_their_scale(tmp_path):
    f, _ = read(normal_file(tmp_path))
    nm = f.meshes[0].materials[0].normal_map
    assert (nm.convention, nm.space) == ("opengl", "tangent")
    np.testing.assert_allclose(nm.texture.raw, png_values(NORMAL_IMG), atol=1e-7)
    f, _ = read(normal_file(tmp_path, scale=0.4))
    nm = f.meshes[0].materials[0].normal_map
    c = (2 * png_values(NORMAL_IMG) - 1) * [0.4, 0.4, 1]
    want = 0.5 * (c / np.linalg.norm(c, axis=2, keepdims=True) + 1)
    np.testing.assert_allclose(nm.texture.raw, want, atol=1e-6)
    assert nm.texture.colorspace == "linear" and nm.convention == "opengl"
    np.testing.assert_allclose(bake_scaled_normals(np.full((1, 1, 3), 0.5), 2.0), [[[0.5, 0.5, 1]]])


def kernel_normal(n, dpdu, dpdv, rgb, directx):
    """kernels/shading/bump.h normal_map_normal, tangent space, in numpy."""
    c = 2 * np.asarray(rgb, float) - 1
    if directx:
        c[1] = -c[1]
    t = dpdu - (dpdu @ n) * n
    t /= np.linalg.norm(t)
    b = np.cross(n, t)
    b = -b if b @ dpdv < 0 else b
    r = c[0] * t + c[1] * b + c[2] * n
    return r / np.linalg.norm(r)


def uv_derivatives(p, uv):
    """(dP/du, dP/dv) of a triangle."""
    e = np.array([p[1] - p[0], p[2] - p[0]])
    d = np.array([uv[1] - uv[0], uv[2] - uv[0]])
    return np.linalg.solve(d, e)


@pytest.mark.parametrize("layout", ["upright", "rotated", "mirrored"])
def test_the_normal_maps_green_points_where_gltfs_does(tmp_path, layout):
    """A texel tilted toward green: glTF's frame (T along dP/du, B toward the image's top row,
    i.e. -dP/dv in glTF's v-down uvs, +Y up) and texray's (opengl convention, its own
    flipped uvs) give the same normal; the directx reading would not."""
    uvs = {"upright": QUAD_UV, "rotated": QUAD_UV[[1, 2, 3, 0]], "mirrored": QUAD_UV[[1, 0, 3, 2]]}[layout]
    f, _ = read(normal_file(tmp_path, uvs=uvs, pixels=np.tile([0.5, 0.8, 0.9], (2, 2, 1))))
    m = f.meshes[0]
    nm = m.materials[0].normal_map
    rgb = nm.texture.raw[0, 0]
    p, n = m.positions[m.faces[0]], np.array([0.0, 0.0, 1.0])
    du_g, dv_g = uv_derivatives(p, uvs[m.faces[0]])
    t = du_g / np.linalg.norm(du_g)
    b = -dv_g - (-dv_g @ t) * t - (-dv_g @ n) * n
    b /= np.linalg.norm(b)
    c = 2 * rgb - 1
    want = c[0] * t + c[1] * b + c[2] * n
    want /= np.linalg.norm(want)
    dpdu, dpdv = uv_derivatives(p, m.uvs[m.faces[0]])
    got = kernel_normal(n, dpdu, dpdv, rgb, directx=nm.convention == "directx")
    np.testing.assert_allclose(got, want, atol=1e-7)
    assert np.linalg.norm(kernel_normal(n, dpdu, dpdv, rgb, directx=True) - want) > 0.3


# --- cameras and lights ---------------------------------------------------------------------
def test_cameras_take_their_node_transforms(tmp_path):
    w = gw.GltfWriter()
    mesh = w.mesh([w.primitive(QUAD_P, QUAD_F)])
    cam = w.camera(yfov=0.6, aspect_ratio=1.5, name="Lens")
    ortho = w._add("cameras", {"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0, "zfar": 9}})
    child = w.node(camera=cam, name="Cam", translation=[0, 0, 2], rotation=axis_angle_quaternion([1, 0, 0], -0.4))
    parent = w.node(children=[child], translation=[1, 2, 3], rotation=axis_angle_quaternion([0, 1, 0], 0.9))
    w.scene([w.node(mesh=mesh), parent, w.node(camera=cam), w.node(camera=ortho)])
    f, msgs = read(w.write(tmp_path / "c.glb"))
    assert [c[0] for c in f.cameras] == ["Cam", "Lens"] and f.cameras[0][2] == 1.5
    world = trs([1, 2, 3], [0, 1, 0], 0.9, [1, 1, 1]) @ trs([0, 0, 2], [1, 0, 0], -0.4, [1, 1, 1])
    c = f.cameras[0][1]
    np.testing.assert_allclose(c.eye, world[:3, 3], atol=1e-12)
    np.testing.assert_allclose(np.subtract(c.look_at, c.eye), -world[:3, 2], atol=1e-12)
    np.testing.assert_allclose(c.up, world[:3, 1], atol=1e-12)
    assert c.fov_y == pytest.approx(math.degrees(0.6))
    assert tuple(f.cameras[1][1].eye) == (0, 0, 0) and np.allclose(f.cameras[1][1].look_at, (0, 0, -1))
    assert len(msgs) == 1 and "orthographic" in msgs[0] and "cameras[1]" in msgs[0]


def test_punctual_lights(tmp_path):
    w = gw.GltfWriter()
    mesh = w.mesh([w.primitive(QUAD_P * 4, QUAD_F)])
    point = w.light("point", color=(1, 0.5, 0.25), intensity=8, name="Bulb", range=5)
    spot = w.light("spot", intensity=3, spot={"innerConeAngle": 0.1, "outerConeAngle": 0.5})
    sun = w.light("directional", color=(1, 1, 0.5), intensity=2)
    ext = lambda i: {"KHR_lights_punctual": {"light": i}}                              # noqa: E731
    sun_dir = axis_angle_quaternion([1, 0, 0], -0.5)
    w.scene([w.node(mesh=mesh), w.node(translation=[1, 2, 3], extensions=ext(point), name="Lamp"),
             w.node(translation=[0, 5, 0], extensions=ext(spot)),
             w.node(rotation=sun_dir, translation=[7, 7, 7], extensions=ext(sun))])
    f, msgs = read(w.write(tmp_path / "l.glb"))
    names = [n for n, _ in f.lights]
    assert names == ["Lamp", "lights[1]", "lights[2]"]
    lamp, spot_l, sun_l = (l for _, l in f.lights)
    assert tuple(lamp.position) == (1, 2, 3) and tuple(lamp.intensity) == (8, 4, 2)
    assert tuple(spot_l.position) == (0, 5, 0) and tuple(spot_l.intensity) == (3, 3, 3)
    centre, radius = np.array([2, 2, 0]), 0.5 * math.sqrt(32)
    d = 1000 * radius
    towards = rodrigues([1, 0, 0], -0.5)[:, 2]           # the sun shines along its node's -Z
    np.testing.assert_allclose(sun_l.position, centre + d * towards, rtol=1e-12)
    np.testing.assert_allclose(sun_l.intensity, np.array([1, 1, 0.5]) * 2 * d * d, rtol=1e-12)
    text = "\n".join(msgs)
    assert len(msgs) == 3 and "range ignored" in text and "spot" in text and "directional" in text
    # irradiance at the scene's centre is the sun's lux
    assert sun_l.intensity[0] / np.sum((np.array(sun_l.position) - centre) ** 2) == pytest.approx(2)


def test_ignored_material_features_are_one_warning(tmp_path):
    w = gw.GltfWriter()
    mat = textured(w)
    w.json["materials"][mat].update(occlusionTexture={"index": 0}, emissiveTexture={"index": 0},
                                    emissiveFactor=[1, 1, 1], extensions={"KHR_materials_clearcoat": {}})
    m2 = w.material(name="Glass", alphaMode="BLEND", extensions={"KHR_materials_transmission": {}})
    w.use_extension("KHR_materials_clearcoat", required=True)
    w.scene([w.node(mesh=w.mesh([w.primitive(QUAD_P, QUAD_F, uvs=QUAD_UV, material=mat),
                                 w.primitive(QUAD_P, QUAD_F, material=m2)]))])
    _, msgs = read(w.write(tmp_path / "i.glb"))
    ignored = [x for x in msgs if "ignored (texray has no equivalent)" in x]
    assert len(ignored) == 1
    for what in ("occlusionTexture", "emissiveTexture", "emissiveFactor", "KHR_materials_clearcoat",
                 "KHR_materials_transmission", "'Tex'", "'Glass'"):
        assert what in ignored[0]
    assert sum("alphaMode BLEND" in x for x in msgs) == 1


# --- errors ---------------------------------------------------------------------------------
ERRORS = [
    ("componentType", lambda w, d: d["accessors"][0].update(componentType=5130),
     r"accessors\[0\]\.componentType: 5130 is not a glTF component type"),
    ("accessor past its view", lambda w, d: d["accessors"][0].update(count=40),
     r"accessors\[0\]: 40 elements .* bufferViews\[1\] has 48 \(truncated"),
    ("view past its buffer", lambda w, d: d["bufferViews"][1].update(byteLength=10 ** 6),
     r"bufferViews\[1\]: bytes .* run past the end of buffers\[0\]"),
    ("normalized float", lambda w, d: d["accessors"][0].update(normalized=True),
     r"accessors\[0\]\.normalized: true for componentType 5126"),
    ("bad stride", lambda w, d: d["bufferViews"][1].update(byteStride=6), r"bufferViews\[1\]\.byteStride: 6"),
    ("index out of range", lambda w, d: d["meshes"][0]["primitives"][0].update(attributes={"POSITION": 0})
     or d["accessors"][0].update(count=3),
     r"primitives\[0\]\.indices: accessors\[3\]\[5\] = 3 indexes past the 3 vertices"),
    ("indices type", lambda w, d: d["meshes"][0]["primitives"][0].update(indices=0),
     r"meshes\[0\]\.primitives\[0\]\.indices: accessors\[0\] is VEC3 of componentType 5126"),
    ("index count", lambda w, d: d["accessors"][3].update(count=5),
     r"meshes\[0\]\.primitives\[0\]: accessors\[3\] holds 5 indices, not a multiple of 3"),
    ("normalized indices", lambda w, d: d["accessors"][3].update(componentType=5121, normalized=True),
     r"primitives\[0\]\.indices: accessors\[3\] is normalized SCALAR of componentType 5121"),
    ("unbacked count", lambda w, d: d["accessors"][0].pop("bufferView") and d["accessors"][0].update(count=2 ** 40),
     r"accessors\[0\]\.count: 1099511627776 elements without a bufferView"),
    ("mode", lambda w, d: d["meshes"][0]["primitives"][0].update(mode=9), r"primitives\[0\]\.mode: 9"),
    ("cycle", lambda w, d: d["nodes"][0].update(children=[0]), r"nodes\[0\] appears twice"),
    ("bad reference", lambda w, d: d["nodes"][0].update(mesh=4), r"nodes\[0\]\.mesh: 4 is not an index of meshes"),
    ("required extension", lambda w, d: d.update(extensionsRequired=["KHR_draco_mesh_compression"]),
     r"extensionsRequired: 'KHR_draco_mesh_compression' is not supported"),
    ("version", lambda w, d: d["asset"].update(version="1.0"), r"asset\.version: '1\.0'"),
    ("top-level type", lambda w, d: d.update(nodes="x"), r": nodes: expected an array, got 'x'"),
    ("sampler", lambda w, d: d.setdefault("samplers", [{"wrapS": 1234}]) and d["textures"][0].update(sampler=0),
     r"samplers\[0\]\.wrapS: 1234 is not a glTF wrapS"),
    ("zero scale", lambda w, d: d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"].update(
        extensions={"KHR_texture_transform": {"scale": [0, 1]}}), r"KHR_texture_transform\.scale: \[0\.0, 1\.0\]"),
    ("huge offset (fuzz)", lambda w, d: d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"].update(
        extensions={"KHR_texture_transform": {"offset": [0.1, 1e39]}}),
     r"baseColorTexture\.extensions\.KHR_texture_transform: offset \[0\.1, 1e\+39\].*uv_transform\.offset"),
    ("metallic", lambda w, d: d["materials"][0]["pbrMetallicRoughness"].update(metallicFactor=1.5),
     r"materials\[0\]\.pbrMetallicRoughness\.metallicFactor: 1\.5 is outside \[0, 1\]"),
    ("no uvs", lambda w, d: d["meshes"][0]["primitives"][0]["attributes"].pop("TEXCOORD_0"),
     r"meshes\[0\]\.primitives\[0\]: materials\[0\] 'Tex' has a texture .* no TEXCOORD_0"),
    ("corrupt image", lambda w, d: d["images"][0].update(bufferView=1),
     r"materials\[0\] 'Tex': images\[0\]\.file: cannot read image images\[0\] \(bufferViews\[1\]\)"),
    ("attribute count", lambda w, d: d["meshes"][0]["primitives"][0]["attributes"].update(NORMAL=1),
     r"attributes\.NORMAL: accessors\[1\] is VEC2; NORMAL is VEC3"),
]


@pytest.mark.parametrize("what, edit, pattern", ERRORS, ids=[e[0] for e in ERRORS])
def test_errors_name_the_file_and_field(tmp_path, what, edit, pattern):
    w = gw.GltfWriter()
    path = quad_file(tmp_path, textured(w), writer=w, name="bad.gltf")
    doc = json.loads(path.read_text())
    edit(w, doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(tx.SceneError, match=pattern) as e:
        read_gltf(path)
    assert str(e.value).startswith(f"{path}: ")
    assert "texray-image" not in str(e.value)          # never the temporary file of an embedded image


def test_missing_and_truncated_files(tmp_path):
    w = gw.GltfWriter()
    path = quad_file(tmp_path, textured(w, embed="file"), writer=w, name="x.gltf")
    png = tmp_path / "image0.png"
    data = png.read_bytes()
    png.unlink()
    with pytest.raises(tx.SceneError, match=rf"^{path}: materials\[0\] 'Tex': images\[0\]\.uri: file not found: "
                                            rf"{tmp_path / 'image0.png'}"):
        read_gltf(path)
    png.write_bytes(data[:40])
    with pytest.raises(tx.SceneError, match=rf"^{path}: materials\[0\] 'Tex': images\[0\]\.file: .*image0\.png"):
        read_gltf(path)
    png.write_bytes(data)
    binf = tmp_path / "x.bin"
    b = binf.read_bytes()
    binf.write_bytes(b[:-9])
    with pytest.raises(tx.SceneError, match=rf"^{path}: buffers\[0\]\.byteLength: {len(b)} bytes, but .*x\.bin "
                                            rf"holds {len(b) - 9} \(truncated\)"):
        read_gltf(path)
    binf.unlink()
    with pytest.raises(tx.SceneError, match=rf"^{path}: buffers\[0\]\.uri: file not found: .*x\.bin"):
        read_gltf(path)
    glb = quad_file(tmp_path, None, name="t.glb")
    g = glb.read_bytes()
    glb.write_bytes(g[:-20])
    with pytest.raises(tx.SceneError, match=rf"^{glb}: truncated GLB: its header says {len(g)} bytes"):
        read_gltf(glb)
    bad = tmp_path / "bad.gltf"
    bad.write_text("{ nope")
    with pytest.raises(tx.SceneError, match=rf"^{bad}: invalid JSON"):
        read_gltf(bad)


def test_read_texture_bytes_names_the_image_not_the_temporary_file():
    with pytest.raises(tx.SceneError, match=r"^x: images\[3\]\.file: cannot read image glTF images\[3\]") as e:
        read_texture_bytes(b"\x89PNG\r\n\x1a\nbroken", ".png", "x: images[3]", "glTF images[3]")
    assert "texray-image" not in str(e.value)
    pixels, _, is_float = read_texture_bytes(gw.png_bytes(IMG), ".png", "x", "y")
    np.testing.assert_allclose(pixels, png_values(IMG), atol=1e-7)
    assert not is_float


def test_files_trimesh_writes_read_as_trimesh_reads_them(tmp_path):
    """An independent writer and reader: a trimesh scene of transformed meshes, exported as
    .glb and .gltf, reads here as trimesh reads it back."""
    trimesh = pytest.importorskip("trimesh")
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=(1, 2, 3)), node_name="Box",
                       transform=trs([1, 2, 3], [1, 2, 0], 0.8, [1, 1, 1]))
    scene.add_geometry(trimesh.creation.icosphere(1), node_name="Ball",
                       transform=trs([-2, 0, 1], [0, 0, 1], -0.3, [2, 0.5, 1]))
    for name in ("t.glb", "t.gltf"):
        path = tmp_path / name
        if name.endswith(".glb"):
            path.write_bytes(scene.export(file_type="glb"))
        else:
            for k, v in scene.export(file_type="gltf").items():
                (tmp_path / k).write_bytes(v)
            path = tmp_path / "model.gltf"
        back = trimesh.load(str(path), process=False)
        want = {}
        for node in back.graph.nodes_geometry:
            m, g = back.graph[node]
            want[node] = np.asarray(back.geometry[g].vertices) @ m[:3, :3].T + m[:3, 3]
        f, _ = read(path)
        got = {m.name.split("'")[1]: m.positions for m in f.meshes}
        assert sorted(got) == sorted(want) == ["Ball", "Box"]
        for k in want:
            np.testing.assert_allclose(got[k], want[k], atol=1e-6)


def test_uris_are_percent_decoded_relative_paths(tmp_path):
    w = gw.GltfWriter()
    mat = textured(w, embed="file")
    w.files = {"my image.png": w.files.pop("image0.png")}
    w.json["images"][0]["uri"] = "my%20image.png"
    sub = tmp_path / "sub dir"
    f, _ = read(quad_file(sub, mat, writer=w, name="u.gltf"))
    np.testing.assert_allclose(f.meshes[0].materials[0].diffuse.raw, png_values(IMG), atol=1e-7)
    w.json["images"][0]["uri"] = "http://example.invalid/x.png"
    with pytest.raises(tx.SceneError, match=r"images\[0\]\.uri: 'http://example\.invalid/x\.png': only relative"):
        read_gltf(w.write(sub / "u.gltf"))


def test_a_bad_vertex_is_reported_as_the_file_stores_it(tmp_path):
    """An identity node does not multiply the positions (NaN x 0 would smear the value)."""
    w = gw.GltfWriter()
    p = QUAD_P.copy()
    p[1, 0] = np.nan
    w.scene([w.node(mesh=w.mesh([w.primitive(p, QUAD_F)]))])
    path = w.write(tmp_path / "nan.glb")
    with pytest.raises(tx.SceneError, match=r"nan\.glb: positions: vertex 1 is \[nan, .*\] \(1 non-finite"):
        tx.Mesh.load(path)
