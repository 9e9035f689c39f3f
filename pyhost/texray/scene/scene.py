"""The scene: a camera, point lights, an ambient term, a background and objects."""
from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import SceneError
from .. import validate as V
from .camera import Camera
from .cylinder import Cylinder
from .light import PointLight
from .instance import Instance
from .mesh import Mesh
from .quad import Quad
from .sphere import Sphere

SHAPES = (Mesh, Sphere, Cylinder, Quad, Instance)
_SHAPE_NAMES = "a texray Mesh, Sphere, Cylinder, Quad or Instance"


@dataclass
class Scene:
    """A camera, point lights, an ambient term and a list of objects."""
    camera: Camera = field(default_factory=Camera)
    lights: list = field(default_factory=list)
    ambient: tuple = (0.0, 0.0, 0.0)
    background: tuple = (0.0, 0.0, 0.0)
    objects: list = field(default_factory=list)

    def __post_init__(self):
        for name in ("lights", "objects"):
            value = getattr(self, name)
            if not isinstance(value, (list, tuple)):
                raise SceneError(f"scene.{name}: expected a list, got {V.show(value)}")
            setattr(self, name, list(value))
        self.validate()

    def validate(self):
        """Check every field (the lists may have changed since the scene was made); returns
        (ambient, background) as float64 arrays."""
        V.instance(self.camera, Camera, "camera", "scene.")
        self.camera.basis(1.0)
        for name, kinds, what in (("lights", PointLight, "a texray.PointLight"), ("objects", SHAPES, _SHAPE_NAMES)):
            value = getattr(self, name)
            if not isinstance(value, list):
                raise SceneError(f"scene.{name}: expected a list, got {V.show(value)}")
            for i, item in enumerate(value):
                V.instance(item, kinds, f"{name}[{i}]", "scene.", what)
        return V.rgb(self.ambient, "ambient", "scene."), V.rgb(self.background, "background", "scene.")

    def add(self, obj):
        V.instance(obj, SHAPES, "add", "scene.", _SHAPE_NAMES)
        self.objects.append(obj)
        return obj

    @classmethod
    def load(cls, path, camera=None):
        """Read a TOML scene file (see the README's "Scene files") or a whole glTF file
        (.gltf, .glb; ``camera``: the name of its camera to use, default the first); the
        same as :func:`texray.load_scene`."""
        # The one import inside a function in texray: the scene-file reader is built on this
        # module (it makes Scenes), so the model cannot import it at module level.
        from ..io.scenefile import load_scene
        return load_scene(path, camera)
