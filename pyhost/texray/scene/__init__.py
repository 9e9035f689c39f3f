"""The scene description users build: camera, lights, textures, materials, shapes.

Units are arbitrary but consistent (world units); angles are degrees; colours
and intensities are linear RGB. Validation happens here, when an object is made
(and again when a scene is compiled, since fields may change), so bad input fails
early with the file, field and value (texray.validate).
"""
from .bump import Bump, NormalMap
from .camera import Camera
from .cylinder import Cylinder
from .displacement import Displacement
from .instance import Instance
from .light import PointLight
from .mapping import Projection, UVTransform
from .material import Material
from .mesh import Mesh
from .quad import Quad
from .scene import SHAPES, Scene
from .sphere import Sphere
from .texture import Label, Texture
from .transform import Transform

__all__ = ["Bump", "Camera", "Cylinder", "Displacement", "Instance", "Label", "Material", "Mesh", "NormalMap",
           "PointLight", "Projection", "Quad", "SHAPES", "Scene", "Sphere", "Texture", "Transform", "UVTransform"]
