"""Meshes load through trimesh from every supported format, unprocessed, with transforms."""
import numpy as np
import pytest
import trimesh

import texray as tx


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "off", "glb"])
def test_formats_load_the_same_triangles(tmp_path, ext):
    src = trimesh.creation.box(extents=(1, 2, 3))
    path = tmp_path / f"box.{ext}"
    src.export(path)
    mesh = tx.Mesh.load(path)
    tri_src = np.sort(np.asarray(src.vertices)[np.asarray(src.faces)].reshape(-1, 9), axis=0)
    tri = np.sort(mesh.positions[mesh.faces].reshape(-1, 9), axis=0)
    assert tri.shape == tri_src.shape
    np.testing.assert_allclose(np.sort(tri.ravel()), np.sort(tri_src.ravel()), atol=1e-6)


def test_obj_uvs_and_normals_come_through(scenes_dir):
    mesh = tx.Mesh.load(scenes_dir / "meshes" / "vase.obj")
    assert mesh.uvs is not None and mesh.uvs.shape == (len(mesh.positions), 2)
    assert mesh.normals is not None
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1, atol=1e-4)


def test_transform_scales_rotates_then_translates():
    p = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1]])
    m = tx.Mesh(p, np.array([[0, 1, 2]]), normals=np.eye(3),
                transform=tx.Transform(translate=(10, 0, 0), rotate=(0, 90, 0), scale=2))
    pos, nrm = m.world()
    np.testing.assert_allclose(pos, [[10, 0, -2], [10, 2, 0], [12, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(nrm, [[0, 0, -1], [0, 1, 0], [1, 0, 0]], atol=1e-12)
