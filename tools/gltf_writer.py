#!/usr/bin/env python3
"""A minimal glTF 2.0 writer: numpy arrays and PNG bytes (through OpenImageIO) to .gltf
(buffer in a .bin file or a data: URI, images in the buffer, data: URIs or files) or .glb.

    w = GltfWriter()
    img = w.image(pixels)                          # float (H, W, C) in [0, 1], row 0 = top
    mat = w.material(pbrMetallicRoughness={"baseColorTexture": {"index": w.texture(img)},
                                           "metallicFactor": 0.0})
    prim = w.primitive(positions, faces, uvs=gltf_uvs(texray_uvs), normals=normals, material=mat)
    w.scene([w.node(mesh=w.mesh([prim]), name="Chair")])
    w.write("chair.glb")          # or "chair.gltf" (buffer="file" or "data")

Nothing is validated: tests build broken files on purpose (edit ``w.json`` before writing).
uvs are glTF's (v = 0 the image's top row): :func:`gltf_uvs` converts texray's.
"""
from __future__ import annotations

import base64
import json
import os
import struct
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

COMPONENT_TYPES = {np.dtype("int8"): 5120, np.dtype("uint8"): 5121, np.dtype("int16"): 5122,
                   np.dtype("uint16"): 5123, np.dtype("uint32"): 5125, np.dtype("float32"): 5126}
DTYPES = {v: k for k, v in COMPONENT_TYPES.items()}
TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


def gltf_uvs(texray_uvs):
    """glTF TEXCOORD_0 of texray uvs: (u, 1 - v) (texray's v = 0 is the image's bottom row)."""
    uv = np.asarray(texray_uvs, dtype=np.float64)
    return np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])


def png_bytes(pixels, bits=8, colorspace=None):
    """PNG file bytes of float (H, W) or (H, W, C) pixels in [0, 1] (row 0 = top), 8 or 16 bits."""
    a = np.asarray(pixels, dtype=np.float64)
    a = a[:, :, None] if a.ndim == 2 else a
    top, dtype, fmt = (255.0, np.uint8, oiio.UINT8) if bits == 8 else (65535.0, np.uint16, oiio.UINT16)
    data = np.ascontiguousarray(np.round(np.clip(a, 0.0, 1.0) * top).astype(dtype))
    h, w, c = data.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    if colorspace:
        spec.attribute("oiio:ColorSpace", colorspace)
    fd, tmp = tempfile.mkstemp(suffix=".png")
    os.close(fd)
    try:
        buf = oiio.ImageBuf(spec)
        buf.set_pixels(oiio.ROI(), data)
        if not buf.write(tmp):
            raise RuntimeError(f"png_bytes: {buf.geterror()}")
        return Path(tmp).read_bytes()
    finally:
        os.unlink(tmp)


class GltfWriter:
    """Builds a glTF document and one binary buffer; see the module docstring."""

    def __init__(self, generator="texray tools/gltf_writer.py"):
        self.json = {"asset": {"version": "2.0", "generator": generator}}
        self.bin = bytearray()
        self.files = {}           # name -> bytes written beside the .gltf (images embed="file")

    def _add(self, key, obj):
        items = self.json.setdefault(key, [])
        items.append(obj)
        return len(items) - 1

    def use_extension(self, name, required=False):
        used = self.json.setdefault("extensionsUsed", [])
        if name not in used:
            used.append(name)
        if required and name not in self.json.setdefault("extensionsRequired", []):
            self.json["extensionsRequired"].append(name)

    # --- binary data ---
    def buffer_view(self, data, stride=None, target=None):
        """A bufferView of ``data`` (bytes) appended to the buffer, 4-byte aligned."""
        self.bin.extend(b"\0" * (-len(self.bin) % 4))
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if stride is not None:
            view["byteStride"] = stride
        if target is not None:
            view["target"] = target
        self.bin.extend(data)
        return self._add("bufferViews", view)

    def accessor(self, array, component_type=None, normalized=False, type=None, target=None, stride=None,
                 byte_offset=0, minmax=None):
        """An accessor of ``array`` ((N,) or (N, k)) in its own bufferView. ``component_type``
        (default: from the dtype; float64 is written as float32), ``stride``: bytes per
        element in the view (padding after each element), ``byte_offset``: padding bytes
        before the first. Float VEC3 accessors get min/max (POSITION needs them)."""
        a = np.asarray(array)
        a = a.reshape(len(a), -1)
        if component_type is None:
            component_type = 5126 if a.dtype.kind == "f" else COMPONENT_TYPES[a.dtype]
        raw = np.ascontiguousarray(a.astype(DTYPES[component_type].newbyteorder("<")))
        elem = raw.shape[1] * raw.itemsize
        rows = raw.view(np.uint8).reshape(len(raw), elem)
        if stride is not None and stride > elem:
            rows = np.concatenate([rows, np.zeros((len(rows), stride - elem), np.uint8)], axis=1)
        data = b"\0" * byte_offset + rows.tobytes()
        view = self.buffer_view(data, stride=stride, target=target)
        acc = {"bufferView": view, "componentType": component_type, "count": len(a),
               "type": type or TYPES[a.shape[1]]}
        if byte_offset:
            acc["byteOffset"] = byte_offset
        if normalized:
            acc["normalized"] = True
        if minmax or (minmax is None and component_type == 5126 and a.shape[1] == 3):
            acc["min"], acc["max"] = a.min(axis=0).tolist(), a.max(axis=0).tolist()
        return self._add("accessors", acc)

    def primitive(self, positions, faces=None, uvs=None, normals=None, material=None, mode=None, index_type=5125):
        """A primitive dict: POSITION (+ TEXCOORD_0, NORMAL) accessors and indices from faces
        ((F, 3), or a flat index list for strips and fans; None: no indices)."""
        prim = {"attributes": {"POSITION": self.accessor(np.asarray(positions, np.float32), target=ARRAY_BUFFER)}}
        if uvs is not None:
            prim["attributes"]["TEXCOORD_0"] = self.accessor(np.asarray(uvs, np.float32), target=ARRAY_BUFFER)
        if normals is not None:
            prim["attributes"]["NORMAL"] = self.accessor(np.asarray(normals, np.float32), target=ARRAY_BUFFER)
        if faces is not None:
            prim["indices"] = self.accessor(np.asarray(faces).reshape(-1), component_type=index_type,
                                            target=ELEMENT_ARRAY_BUFFER)
        if material is not None:
            prim["material"] = material
        if mode is not None:
            prim["mode"] = mode
        return prim

    # --- images, textures, materials ---
    def image(self, pixels=None, png=None, embed="buffer", name=None, filename=None, bits=8):
        """An image from float ``pixels`` (PNG-encoded) or ready ``png`` bytes, stored in the
        buffer (embed="buffer"), as a data: URI ("data") or a file beside the .gltf ("file",
        named ``filename``)."""
        data = png if png is not None else png_bytes(pixels, bits=bits)
        img = {}
        if embed == "buffer":
            img = {"bufferView": self.buffer_view(data), "mimeType": "image/png"}
        elif embed == "data":
            img = {"uri": "data:image/png;base64," + base64.b64encode(data).decode("ascii")}
        elif embed == "file":
            filename = filename or f"image{len(self.json.get('images', []))}.png"
            self.files[filename] = data
            img = {"uri": filename}
        else:
            raise ValueError(f"embed: {embed!r}")
        if name:
            img["name"] = name
        return self._add("images", img)

    def sampler(self, **fields):
        return self._add("samplers", dict(fields))

    def texture(self, image, sampler=None):
        t = {"source": image}
        if sampler is not None:
            t["sampler"] = sampler
        return self._add("textures", t)

    def material(self, **fields):
        return self._add("materials", dict(fields))

    # --- hierarchy ---
    def mesh(self, primitives, name=None):
        m = {"primitives": list(primitives)}
        if name:
            m["name"] = name
        return self._add("meshes", m)

    def node(self, **fields):
        """A node: mesh=, camera=, children=[...], matrix= (16 numbers, column-major, or a
        4x4 array, row-major as numpy writes it), translation=, rotation= (x, y, z, w),
        scale=, name=, extensions=."""
        if "matrix" in fields and np.shape(fields["matrix"]) == (4, 4):
            fields["matrix"] = np.asarray(fields["matrix"], dtype=np.float64).T.ravel().tolist()
        for k in ("translation", "rotation", "scale", "matrix"):
            if k in fields:
                fields[k] = [float(x) for x in np.ravel(fields[k])]
        return self._add("nodes", fields)

    def camera(self, yfov, aspect_ratio=None, znear=0.01, zfar=None, name=None):
        p = {"yfov": yfov, "znear": znear}
        if aspect_ratio is not None:
            p["aspectRatio"] = aspect_ratio
        if zfar is not None:
            p["zfar"] = zfar
        c = {"type": "perspective", "perspective": p}
        if name:
            c["name"] = name
        return self._add("cameras", c)

    def light(self, type, color=(1.0, 1.0, 1.0), intensity=1.0, name=None, **fields):
        """A KHR_lights_punctual light; attach it with node(extensions={"KHR_lights_punctual": {"light": i}})."""
        self.use_extension("KHR_lights_punctual")
        root = self.json.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
        light = {"type": type, "color": list(color), "intensity": intensity, **fields}
        if name:
            light["name"] = name
        root["lights"].append(light)
        return len(root["lights"]) - 1

    def scene(self, nodes):
        self.json["scene"] = self._add("scenes", {"nodes": list(nodes)})
        return self.json["scene"]

    # --- output ---
    def write(self, path, buffer="file"):
        """Write ``path``: .glb (one binary chunk), or .gltf with the buffer in PATH.bin
        (buffer="file") or a data: URI ("data"). Image files go beside it."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        doc = json.loads(json.dumps(self.json))
        data = bytes(self.bin) + b"\0" * (-len(self.bin) % 4)
        if data:
            doc["buffers"] = [{"byteLength": len(self.bin)}]
        for name, content in self.files.items():
            (path.parent / name).write_bytes(content)
        if path.suffix.lower() == ".glb":
            text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
            text += b" " * (-len(text) % 4)
            chunks = struct.pack("<II", len(text), 0x4E4F534A) + text
            if data:
                chunks += struct.pack("<II", len(data), 0x004E4942) + data
            path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)
            return path
        if data:
            if buffer == "data":
                doc["buffers"][0]["uri"] = ("data:application/octet-stream;base64," +
                                            base64.b64encode(bytes(self.bin)).decode("ascii"))
            else:
                bin_name = path.with_suffix(".bin").name
                (path.parent / bin_name).write_bytes(bytes(self.bin))
                doc["buffers"][0]["uri"] = bin_name
        path.write_text(json.dumps(doc, indent=1))
        return path
