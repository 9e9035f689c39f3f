"""Small scenes built in code, shared by several tests."""
import numpy as np

import texray as tx


def quad(y=0.0, size=2.0, uv_repeat=1.0):
    """Two triangles spanning [-size, size]^2 in the plane y, facing +y, with uvs."""
    s = size
    p = np.array([[-s, y, s], [s, y, s], [s, y, -s], [-s, y, -s]], float)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float) * uv_repeat
    return p, np.array([[0, 1, 2], [0, 2, 3]]), uv


def box(center, half):
    """A closed axis-aligned box with outward winding and no uvs."""
    c, h = np.asarray(center, float), np.asarray(half, float)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * h + c
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return corners, faces


def checker_texture(n=8, size=64):
    i, j = np.meshgrid(np.arange(size), np.arange(size), indexing="ij")
    c = ((i * n // size + j * n // size) % 2).astype(np.float32)
    rgb = np.stack([0.2 + 0.7 * c, 0.3 + 0.2 * c, 0.9 - 0.6 * c], axis=-1)
    return tx.Texture.from_array(rgb, colorspace="linear", name="checker")


def textured_box_scene(lights=2):
    tex = checker_texture()
    ground = tx.Material(diffuse=tex, tint=(0.9, 0.9, 0.9))
    p, f, uv = quad(0.0, 2.0, uv_repeat=2.0)
    scene = tx.Scene(camera=tx.Camera(eye=(0.3, 2.2, 3.5), look_at=(0, 0.3, 0), fov_y=45),
                     lights=[tx.PointLight((2.0, 3.0, 2.0), (12, 11, 10)),
                             tx.PointLight((-2.5, 2.0, 0.5), (3, 4, 6))][:lights],
                     ambient=(0.05, 0.05, 0.05), background=(0.1, 0.1, 0.15))
    scene.add(tx.Mesh(p, f, uvs=uv, material=ground, name="ground"))
    bp, bf = box((0.0, 0.5, 0.0), (0.4, 0.5, 0.4))
    scene.add(tx.Mesh(bp, bf, material=tx.Material(diffuse=(0.7, 0.3, 0.2), specular=0.4, shininess=20),
                      name="box"))
    return scene
