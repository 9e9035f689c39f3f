"""Scenes for the scene cache's tests: one of every kind of field the compiler reads, each
call building fresh objects (so that two calls give equal, unshared scenes)."""
import numpy as np

import texray as tx
from scenes_for_tests import box, quad


def texture(seed=0, size=16, channels=3, **kw):
    rgb = np.random.default_rng(seed).random((size, size, channels)).astype(np.float32)
    return tx.Texture.from_array(rgb, name=f"noise{seed}", **kw)


def edited(t, index, value):
    """A texture like ``t`` with ``raw[index] = value`` (a texture's texels are read-only)."""
    raw = t.raw.copy()
    raw[index] = value
    return tx.Texture(raw, t.name, t.colorspace, t.wrap, t.uv_transform, t.filter, t.field, t.max_aniso)


def rich_scene():
    """A multi-material mesh with uvs, normals, a transform and a projection; a textured,
    MIP-mapped sphere with a label and maps; a bumped quad; a normal-mapped cylinder; a
    displaced quad; two lights, ambient and background."""
    scene = tx.Scene(camera=tx.Camera(eye=(0.5, 2.5, 5.0), look_at=(0, 0.4, 0), fov_y=50),
                     lights=[tx.PointLight((2.0, 4.0, 3.0), (30, 28, 26)), tx.PointLight((-3, 2, 1), (4, 5, 8))],
                     ambient=(0.04, 0.05, 0.06), background=(0.1, 0.12, 0.2))
    p, f, uv = quad(0.0, 3.0, uv_repeat=3.0)
    scene.add(tx.Mesh(p, f, uvs=uv, material=tx.Material(diffuse=texture(1, filter="trilinear")), name="ground"))
    bp, bf = box((0.0, 0.5, 0.0), (0.4, 0.5, 0.4))
    normals = bp - bp.mean(axis=0)
    mats = [tx.Material(diffuse=(0.7, 0.3, 0.2), specular=0.4, shininess=20),
            tx.Material(diffuse=texture(2, wrap="mirror"), specular=texture(3))]
    scene.add(tx.Mesh(bp, bf, normals=normals, material=mats, material_ids=np.arange(len(bf)) % 2,
                      transform=tx.Transform(translate=(-1.2, 0, 0), rotate=(0, 30, 0), scale=0.8),
                      mapping=tx.Projection("planar", scale=2.0), name="box"))
    label = tx.Label(texture(4, channels=4), tx.UVTransform(scale=(3, 3), offset=(-1, -1)))
    shiny = texture(5, channels=1)
    scene.add(tx.Sphere((1.2, 0.6, 0.3), 0.6, name="ball",
                      material=tx.Material(diffuse=texture(6, filter="anisotropic", max_aniso=8,
                                                           uv_transform=tx.UVTransform(rotation=30)),
                                           specular=0.3, shininess=40, shininess_map=shiny, label=label)))
    scene.add(tx.Quad((-3, 0, -2), (3, 0, -2), (3, 3, -2), (-3, 3, -2), name="wall",
                      material=tx.Material(diffuse=(0.6, 0.6, 0.5), bump=tx.Bump(texture(7, channels=1), 0.02))))
    scene.add(tx.Cylinder(0.3, (0.0, 1.0), origin=(2.2, 0, -1), axis_z=(0, 1, 0), name="post",
                          material=tx.Material(normal_map=tx.NormalMap(texture(8), convention="directx"))))
    scene.add(tx.Quad((-1, 0.01, 1), (0, 0.01, 1), (0, 0.01, 2), (-1, 0.01, 2), name="tiles",
                      material=tx.Material(displacement=tx.Displacement(texture(9, channels=1), scale=0.1,
                                                                        steps=16))))
    return scene
