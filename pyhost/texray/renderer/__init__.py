"""Rendering a compiled scene on a device or a Dask cluster: :func:`render` (the image
in memory), :func:`render_to_file` (band by band), :func:`render_frames` (a camera path,
frames that change), :class:`Image`, the launches (:mod:`.frame`), the tiling
(:mod:`.tiling`), the cluster's bands (:mod:`.distributed`) and the ray tracer for given
rays (:mod:`.trace`)."""
from .frames import render_frames
from .image import Image
from .render import render, render_to_file

__all__ = ["Image", "render", "render_frames", "render_to_file"]
