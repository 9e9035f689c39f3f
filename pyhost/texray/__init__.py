"""texray: a ray tracer whose OpenCL kernels do texture, bump and displacement mapping.

    import texray as tx
    scene = tx.Scene(camera=tx.Camera(eye=(0, 1.4, 3.6), look_at=(0, 0.7, 0), fov_y=32),
                     lights=[tx.PointLight(position=(3, 4, 5), intensity=(40, 40, 40))],
                     background=(0.55, 0.62, 0.72))
    scene.add(tx.Mesh.load("scenes/meshes/vase.obj", material=tx.Material(diffuse=(0.8, 0.2, 0.2)),
                           transform=tx.Transform(scale=1.5)))
    tx.render(scene, width=640, height=480, spp=16).save("out.png")

The package by role (the README's "Architecture" follows a scene through them):
``scene`` (what users build), ``io`` (files), ``procedural`` (generated meshes and
textures), ``compile`` (a Scene to flat arrays), ``accel`` (the BVH), ``device``
(OpenCL, the shared structs, the buffer manifest), ``renderer`` (tiles, launches,
images) and ``bench`` (``texray bench``).
"""
from .device import DeviceInfo, devices
from .errors import BuildError, DeviceError, SceneError, TexrayError
from .io.scenefile import load_scene
from .renderer import Image, render, render_frames, render_to_file
from .scene import (Bump, Camera, Cylinder, Displacement, Instance, Label, Material, Mesh, NormalMap, PointLight,
                    Projection, Quad, Scene, Sphere, Texture, Transform, UVTransform)

__all__ = ["Bump", "Displacement", "NormalMap", "BuildError", "Camera", "Cylinder", "DeviceError", "DeviceInfo",
           "Image", "Instance", "Label", "Material", "Mesh", "PointLight", "Projection", "Quad", "Scene", "SceneError",
           "Sphere", "TexrayError", "Texture", "Transform", "UVTransform", "devices", "load_scene", "render",
           "render_frames", "render_to_file"]
__version__ = "0.1.0"
