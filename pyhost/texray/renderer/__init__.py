"""Rendering a compiled scene on a device: :func:`render` (the image in memory),
:func:`render_to_file` (band by band), :class:`Image`, the tiling (:mod:`.tiling`) and
the ray tracer for given rays (:mod:`.trace`)."""
from .image import Image
from .render import render, render_to_file

__all__ = ["Image", "render", "render_to_file"]
