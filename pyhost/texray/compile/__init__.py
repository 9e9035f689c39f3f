"""Scene compilation: a Scene becomes the flat arrays, BVH and feature set the device
renders (:func:`compile_scene`, :class:`CompiledScene`); the scene cache keeps them on
disk by content hash (:mod:`.cache`, its files :mod:`.cache_file`, its key
:mod:`.scene_hash`)."""
from .scene import CompiledScene, compile_scene

__all__ = ["CompiledScene", "compile_scene"]
