"""Image files through OpenImageIO (all of texray's image I/O): reading textures,
writing renders."""
from __future__ import annotations

import os
import tempfile

import numpy as np

import OpenImageIO as oiio

from ..errors import SceneError
from ..validate import file_path, output_path
from .colour import linear_to_srgb

_LINEAR_FORMATS = {".exr", ".hdr", ".pfm"}


def read_image(path, field="texture"):
    """Pixels of an image file as float32 (H, W, C), row 0 = top row, and its colour-space name.

    8/16-bit integer files come back scaled to [0, 1]. Raises SceneError
    naming the file for a missing, unreadable or empty image.
    """
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


def read_texture_file(path, field):
    """(raw float32 (H, W, C) with straight alpha, the file's colour-space name, whether the
    pixels are half/float)."""
    field = f"{field}.file"
    path = file_path(path, "", field)
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)       # the file's own colour values, not premultiplied
    inp = oiio.ImageInput.open(str(path), config)
    if inp is None:
        raise SceneError(f"{field}: cannot read image {path} (corrupt, truncated or not an image): "
                         f"{_first_line(oiio.geterror()) or 'unknown format'}")
    try:
        spec = inp.spec()
        if spec.width <= 0 or spec.height <= 0 or spec.nchannels <= 0:
            raise SceneError(f"{field}: image {path} has no pixels ({spec.width}x{spec.height}x{spec.nchannels})")
        if spec.nchannels > 4:
            raise SceneError(f"{field}: {path} has {spec.nchannels} channels; textures take 1 to 4")
        pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
        if pixels is None or inp.has_error:
            raise SceneError(f"{field}: cannot decode image {path} (corrupt or truncated): "
                             f"{_first_line(inp.geterror()) or 'read failed'}")
        colorspace = spec.get_string_attribute("oiio:ColorSpace", "")
        is_float = spec.format.basetype in (oiio.HALF, oiio.FLOAT, oiio.DOUBLE)
        associated = spec.alpha_channel >= 0 and not spec.get_int_attribute("oiio:UnassociatedAlpha", 0)
    finally:
        inp.close()
    pixels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    if not np.all(np.isfinite(pixels)):
        bad = np.argwhere(~np.isfinite(pixels))[0]
        raise SceneError(f"{field}: {path}: non-finite texel {pixels[tuple(bad)]} at row {bad[0]}, "
                         f"column {bad[1]}, channel {bad[2]}")
    if associated:
        # EXR (and any file whose alpha OIIO reports associated) stores colour premultiplied:
        # divide it out so that every texture holds straight alpha; a = 0 keeps colour 0.
        a = pixels[:, :, spec.alpha_channel:spec.alpha_channel + 1]
        colour = [c for c in range(spec.nchannels) if c != spec.alpha_channel]
        with np.errstate(divide="ignore", invalid="ignore"):
            pixels[:, :, colour] = np.where(a > 0, pixels[:, :, colour] / a, 0.0)
    return pixels, colorspace, is_float


def read_texture_bytes(data, suffix, field, name):
    """:func:`read_texture_file` of an image held in memory (an image embedded in a glTF
    file): ``data`` the encoded bytes, ``suffix`` the extension OpenImageIO picks the
    decoder by (".png", ".jpg"), ``name`` what error messages call the image (they never
    name the temporary file the bytes are decoded from)."""
    fd, tmp = tempfile.mkstemp(suffix=suffix, prefix="texray-image-")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        try:
            return read_texture_file(tmp, field)
        except SceneError as e:
            raise SceneError(str(e).replace(tmp, name)) from None
    finally:
        os.unlink(tmp)


def _first_line(msg):
    return (msg or "").strip().splitlines()[0] if (msg or "").strip() else ""


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
