"""Procedural content: meshes (:mod:`.meshes`) and textures (:mod:`.textures`), pure numpy."""
from .meshes import *        # noqa: F401,F403
from .meshes import __all__ as _meshes
from .textures import *      # noqa: F401,F403
from .textures import __all__ as _textures

__all__ = _meshes + _textures
