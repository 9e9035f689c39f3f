"""Scene compilation: a Scene becomes the flat arrays, BVH and feature set the device
renders (:func:`compile_scene`, :class:`CompiledScene`)."""
from .scene import CompiledScene, compile_scene

__all__ = ["CompiledScene", "compile_scene"]
