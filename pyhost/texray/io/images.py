"""Image files through OpenImageIO: reading textures, writing renders."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .colour import linear_to_srgb
from .errors import SceneError
from .validate import file_path, output_path

_LINEAR_FORMATS = {".exr", ".hdr", ".pfm"}


def read_image(path, field="texture"):
    """Pixels of an image file as float32 (H, W, C), row 0 = top row, and its colour-space name.

    8/16-bit integer files come back scaled to [0, 1]. Raises SceneError
    naming the file for a missing, unreadable or empty image.
    """
    import OpenImageIO as oiio
    path = file_path(path, "", field)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise SceneError(f"{field}: cannot read image {path}: {oiio.geterror() or 'unknown format'}")
    try:
        spec = inp.spec()
        if spec.width <= 0 or spec.height <= 0 or spec.nchannels <= 0:
            raise SceneError(f"{field}: image {path} has no pixels ({spec.width}x{spec.height}x{spec.nchannels})")
        pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
        if pixels is None:
            raise SceneError(f"{field}: cannot decode image {path}: {inp.geterror()}")
        colorspace = spec.get_string_attribute("oiio:ColorSpace", "")
    finally:
        inp.close()
    pixels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    return pixels, colorspace


_SRGB_FORMATS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".tga")


def _output_format(path):
    """The pixel format a render is written in: 8-bit sRGB, half (EXR) or float (HDR)."""
    ext = output_path(path).suffix.lower()
    if ext in _LINEAR_FORMATS:
        return "half" if ext == ".exr" else "float"
    if ext in _SRGB_FORMATS:
        return "uint8"
    raise SceneError(f"output: unsupported image extension {ext!r} in {path} (use .png, .jpg, .tif, .exr or .hdr)")


def _encode(rgb, fmt):
    """Linear float RGB in the output format: sRGB-encoded 8-bit (clamped) or as it is."""
    rgb = np.ascontiguousarray(rgb, dtype=np.float32)
    return np.round(linear_to_srgb(rgb) * 255.0).astype(np.uint8) if fmt == "uint8" else rgb


def _open_output(path, width, height, channels, fmt):
    import OpenImageIO as oiio
    out = oiio.ImageOutput.create(str(path))
    if out is None:
        raise SceneError(f"output: cannot create {path}: {oiio.geterror()}")
    spec = oiio.ImageSpec(width, height, channels, fmt)
    if fmt == "uint8":
        spec.attribute("oiio:ColorSpace", "sRGB")
    if not out.open(str(path), spec):
        raise SceneError(f"output: cannot open {path} for writing: {out.geterror()}")
    return out


def write_image(path, rgb):
    """Write linear float RGB (H, W, 3): PNG/JPEG/TIFF as 8-bit sRGB (clamped), EXR/HDR as linear float."""
    path = output_path(path)
    fmt = _output_format(path)
    rgb = np.asarray(rgb, dtype=np.float32)
    if rgb.ndim == 2:
        rgb = rgb[:, :, None]
    h, w, c = rgb.shape
    out = _open_output(path, w, h, c, fmt)
    ok = out.write_image(_encode(rgb, fmt))
    out.close()
    if not ok:
        raise SceneError(f"output: writing {path} failed: {out.geterror()}")


def write_exr_layers(path, rgb, aovs):
    """One float32 EXR holding R, G, B and every AOV as channels named ``name.x``/``.y``/``.z``
    (``uv.u``, ``uv.v``; one-channel AOVs by their name)."""
    import OpenImageIO as oiio
    path = output_path(path)
    names, planes = ["R", "G", "B"], [np.asarray(rgb, np.float32)]
    for name, a in aovs.items():
        a = np.asarray(a, np.float32)
        a = a[:, :, None] if a.ndim == 2 else a
        suffix = {1: [""], 2: [".u", ".v"], 3: [".x", ".y", ".z"]}[a.shape[2]]
        names += [name + sfx for sfx in suffix]
        planes.append(a)
    data = np.ascontiguousarray(np.concatenate(planes, axis=2))
    h, w, c = data.shape
    spec = oiio.ImageSpec(w, h, c, "float")
    spec.channelnames = tuple(names)
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), spec):
        raise SceneError(f"output: cannot open {path} for writing: {oiio.geterror()}")
    ok = out.write_image(data)
    out.close()
    if not ok:
        raise SceneError(f"output: writing {path} failed: {out.geterror()}")


class ScanlineWriter:
    """Writes an image band by band (top to bottom), so an image larger than host
    memory can be saved as it is rendered. Same encodings as :func:`write_image`."""

    def __init__(self, path, width, height, channels=3):
        self.path = output_path(path)
        self.fmt = _output_format(self.path)
        self.out = _open_output(self.path, width, height, channels, self.fmt)
        self.next_row = 0

    def write(self, y0, rgb_rows):
        """Rows y0 .. y0 + len(rgb_rows) - 1 of linear float RGB; bands must come in order."""
        if y0 != self.next_row:
            raise ValueError(f"ScanlineWriter: expected row {self.next_row}, got {y0}")
        data = _encode(rgb_rows, self.fmt)
        if not self.out.write_scanlines(y0, y0 + len(data), 0, data):
            raise SceneError(f"output: writing rows {y0}.. of {self.path} failed: {self.out.geterror()}")
        self.next_row = y0 + len(data)

    def close(self):
        self.out.close()
