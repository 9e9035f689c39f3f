"""texray: a ray tracer whose OpenCL kernels do texture, bump and displacement mapping.

    import texray as tx
    scene = tx.Scene(camera=tx.Camera(eye=(0, 1, 4), look_at=(0, 0, 0), fov_y=40),
                     lights=[tx.PointLight(position=(3, 4, 5), intensity=(40, 40, 40))])
    scene.add(tx.Mesh.load("scenes/meshes/vase.obj", material=tx.Material(diffuse=(0.8, 0.2, 0.2))))
    tx.render(scene, width=640, height=480, spp=4).save("out.png")
"""
from .bump import Bump, NormalMap
from .displace import Displacement
from .device import DeviceInfo, devices
from .errors import BuildError, DeviceError, SceneError, TexrayError
from .mapping import Projection, UVTransform
from .render import Image, render, render_to_file
from .scene import Camera, Cylinder, Material, Mesh, PointLight, Quad, Scene, Sphere, Texture
from .texture import Label
from .transform import Transform

__all__ = ["Bump", "Displacement", "NormalMap", "BuildError", "Camera", "Cylinder", "DeviceError", "DeviceInfo", "Image", "Label", "Material", "Mesh",
           "PointLight", "Projection", "Quad", "Scene", "SceneError", "Sphere", "TexrayError", "Texture", "Transform", "UVTransform", "devices",
           "render", "render_to_file"]
__version__ = "0.1.0"
