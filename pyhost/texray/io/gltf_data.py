"""The container layer of the glTF 2.0 reader (texray.io.gltf): the JSON (from a
.gltf file or a .glb's JSON chunk), checked field access that raises SceneError
naming the file, the JSON path and the value, buffers (the GLB's BIN chunk,
``data:`` URIs, files beside the glTF file), buffer views and accessors read with
numpy (every component type, ``normalized``, ``byteStride``, accessors without a
buffer view, sparse accessors).
"""
from __future__ import annotations

import base64
import binascii
import json
import struct
import urllib.parse
import warnings

import numpy as np

from ..errors import SceneError
from .. import validate as V

GLB_MAGIC = b"glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942

# componentType -> little-endian numpy dtype
COMPONENT_TYPES = {5120: np.dtype("<i1"), 5121: np.dtype("<u1"), 5122: np.dtype("<i2"), 5123: np.dtype("<u2"),
                   5125: np.dtype("<u4"), 5126: np.dtype("<f4")}
# type -> (columns, rows): a column of a matrix starts on a 4-byte boundary
ACCESSOR_TYPES = {"SCALAR": (1, 1), "VEC2": (1, 2), "VEC3": (1, 3), "VEC4": (1, 4),
                  "MAT2": (2, 2), "MAT3": (3, 3), "MAT4": (4, 4)}
INDEX_COMPONENT_TYPES = (5121, 5123, 5125)
# Elements of an accessor without a bufferView (zeros, or a sparse accessor's base): its
# count is not bounded by any data, so a bound keeps a corrupt count from allocating terabytes.
MAX_UNBACKED_ELEMENTS = 2 ** 28

_MISSING = object()
_KINDS = {"int": "an integer", "number": "a number", "str": "a string", "list": "an array",
          "dict": "an object", "bool": "true or false"}


def _is(value, kind):
    if kind == "int":
        return isinstance(value, int) and not isinstance(value, bool)
    if kind == "number":
        return isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value)
    return isinstance(value, {"str": str, "list": list, "dict": dict, "bool": bool}[kind])


class GltfDocument:
    """A parsed glTF file: its JSON, its buffers (read on first use) and checked access
    to both. ``label``: the file as error messages name it."""

    def __init__(self, path):
        path = V.file_path(path, "gltf")
        self.path = path
        self.label = str(path)
        self.base = path.parent
        data = path.read_bytes()
        self.glb_bin = None
        if data[:4] == GLB_MAGIC:
            text = self._parse_glb(data)
        else:
            text = data
        try:
            self.json = json.loads(text.decode("utf-8-sig"))
        except UnicodeDecodeError as e:
            raise SceneError(f"{self.label}: not a glTF file: neither UTF-8 JSON nor a binary .glb "
                             f"(byte {text[e.start]:#04x} at offset {e.start})") from None
        except json.JSONDecodeError as e:
            raise SceneError(f"{self.label}: invalid JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None
        if not isinstance(self.json, dict):
            raise SceneError(f"{self.label}: expected a JSON object at the top, got {type(self.json).__name__}")
        self._buffers = {}
        self._accessors = {}
        self._check_asset()

    # --- errors and checked access -----------------------------------------------
    def error(self, jpath, message):
        return SceneError(f"{self.label}: {jpath}: {message}")

    def get(self, obj, key, jpath, kind, default=_MISSING):     # jpath "": the top level
        """obj[key] checked to be of ``kind`` ("int", "number", "str", "list", "dict", "bool");
        ``default`` when absent (no default: the key is required)."""
        if key not in obj:
            if default is _MISSING:
                raise self.error(jpath or "(top level)", f"required {key!r} is missing")
            return default
        value = obj[key]
        if not _is(value, kind):
            raise self.error(_join(jpath, key), f"expected {_KINDS[kind]}, got {V.show(value)}")
        return value

    def number(self, obj, key, jpath, default=_MISSING, lo=None, hi=None):
        """obj[key] as a finite float in [lo, hi]; ``default`` when absent."""
        if key not in obj and default is not _MISSING:
            return default
        value = float(self.get(obj, key, jpath, "number"))
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            a, b = ("-inf" if lo is None else format(lo, "g")), ("inf" if hi is None else format(hi, "g"))
            raise self.error(_join(jpath, key), f"{V.show(value)} is outside [{a}, {b}]")
        return value

    def numbers(self, obj, key, jpath, n, default=_MISSING):
        """obj[key] as a float64 array of ``n`` finite numbers; ``default`` when absent."""
        if key not in obj and default is not _MISSING:
            return default
        value = self.get(obj, key, jpath, "list")
        if len(value) != n or not all(_is(x, "number") for x in value):
            raise self.error(_join(jpath, key), f"expected {n} finite numbers, got {V.show(value)}")
        return np.asarray(value, dtype=np.float64)

    def array(self, name):
        """The top-level array ``name`` ([] when absent)."""
        return self.get(self.json, name, "", "list", [])

    def item(self, name, index, jpath=None):
        """self.json[name][index] as a dict, ``index`` checked (``jpath`` names the reference)."""
        items = self.array(name)
        if not _is(index, "int") or not 0 <= index < len(items):
            where = jpath or f"{name}[{index}]"
            have = f"0..{len(items) - 1}" if items else "none defined"
            raise self.error(where, f"{V.show(index)} is not an index of {name} ({have})")
        obj = items[index]
        if not isinstance(obj, dict):
            raise self.error(f"{name}[{index}]", f"expected an object, got {V.show(obj)}")
        return obj

    def ref(self, obj, key, jpath, name, default=_MISSING):
        """The index obj[key] into the top-level array ``name``, checked; ``default`` if absent."""
        if key not in obj:
            if default is _MISSING:
                raise self.error(jpath or "(top level)", f"required {key!r} is missing")
            return default
        self.item(name, obj[key], _join(jpath, key))
        return obj[key]

    def name_of(self, name, index):
        """``name[index] 'its name'`` for messages."""
        own = self.item(name, index).get("name")
        return f"{name}[{index}]" + (f" {own!r}" if isinstance(own, str) and own else "")

    # --- GLB ---------------------------------------------------------------------
    def _parse_glb(self, data):
        if len(data) < 12:
            raise SceneError(f"{self.label}: truncated GLB header ({len(data)} bytes, expected 12)")
        _, version, length = struct.unpack_from("<4sII", data, 0)
        if version != 2:
            raise SceneError(f"{self.label}: GLB version {version}; texray reads glTF 2.0 (GLB version 2)")
        if length > len(data):
            raise SceneError(f"{self.label}: truncated GLB: its header says {length} bytes, the file has {len(data)}")
        pos, chunks = 12, []
        while pos < length:
            if pos + 8 > length:
                raise SceneError(f"{self.label}: truncated GLB chunk header at byte {pos}")
            clen, ctype = struct.unpack_from("<II", data, pos)
            if pos + 8 + clen > length:
                raise SceneError(f"{self.label}: truncated GLB: chunk {len(chunks)} at byte {pos} holds {clen} "
                                 f"bytes, the file ends {length - pos - 8} bytes after its header")
            chunks.append((ctype, data[pos + 8:pos + 8 + clen]))
            pos += 8 + clen
        if not chunks or chunks[0][0] != CHUNK_JSON:
            raise SceneError(f"{self.label}: GLB without a JSON chunk first")
        if len(chunks) > 1 and chunks[1][0] == CHUNK_BIN:
            self.glb_bin = chunks[1][1]
        return chunks[0][1]

    def _check_asset(self):
        asset = self.get(self.json, "asset", "(top level)", "dict")
        version = self.get(asset, "version", "asset", "str")
        major = version.split(".")[0]
        if major != "2":
            raise self.error("asset.version", f"{version!r}: texray reads glTF 2.0 files")
        minimum = self.get(asset, "minVersion", "asset", "str", "2.0")
        if minimum.split(".")[0] != "2" or minimum.split(".")[1:2] not in (["0"], []):
            raise self.error("asset.minVersion", f"{minimum!r}: texray reads glTF 2.0 files")

    # --- URIs and buffers ----------------------------------------------------------
    def uri_bytes(self, uri, jpath):
        """The bytes a ``uri`` names: a base64 ``data:`` URI or a file relative to the glTF file.
        Returns (bytes, media type or None, the path read or None)."""
        if uri.startswith("data:"):
            head, sep, payload = uri[5:].partition(",")
            if not sep or not head.endswith(";base64"):
                raise self.error(jpath, "a data: URI must be base64 (data:<type>;base64,<data>)")
            try:
                return base64.b64decode(payload, validate=True), head[:-7] or None, None
            except (binascii.Error, ValueError) as e:
                raise self.error(jpath, f"invalid base64 in the data: URI ({e})") from None
        path = self.uri_path(uri, jpath)
        try:
            return path.read_bytes(), None, path
        except OSError as e:
            raise self.error(jpath, f"cannot read {path}: {e.strerror or e}") from None

    def uri_path(self, uri, jpath):
        """The existing, readable file a non-data ``uri`` names (relative to the glTF file,
        percent-decoded)."""
        scheme = urllib.parse.urlsplit(uri).scheme
        if scheme and len(scheme) > 1:              # one letter: a Windows drive
            raise self.error(jpath, f"{V.show(uri)}: only relative file paths and data: URIs are read")
        return V.file_path(self.base / urllib.parse.unquote(uri), "", f"{self.label}: {jpath}")

    def buffer(self, index, jpath):
        """The bytes of buffers[index] (at least its byteLength)."""
        if index in self._buffers:
            return self._buffers[index]
        b = self.item("buffers", index, jpath)
        where = f"buffers[{index}]"
        length = self.get(b, "byteLength", where, "int")
        if length < 1:
            raise self.error(f"{where}.byteLength", f"{length} (expected >= 1)")
        uri = self.get(b, "uri", where, "str", None)
        if uri is None:
            if self.glb_bin is None:
                raise self.error(where, "no uri, and the file has no GLB binary chunk")
            if index != 0:
                raise self.error(where, "no uri: only buffers[0] can be the GLB binary chunk")
            data, shown = self.glb_bin, "the GLB binary chunk"
        else:
            data, _, path = self.uri_bytes(uri, f"{where}.uri")
            shown = str(path) if path is not None else "its data: URI"
        if len(data) < length:
            raise self.error(f"{where}.byteLength", f"{length} bytes, but {shown} holds {len(data)} (truncated)")
        self._buffers[index] = data
        return data

    def buffer_view(self, index, jpath):
        """(bytes of buffers[...], start offset, byteLength, byteStride or None) of bufferViews[index]."""
        v = self.item("bufferViews", index, jpath)
        where = f"bufferViews[{index}]"
        bi = self.ref(v, "buffer", where, "buffers")
        offset = self.get(v, "byteOffset", where, "int", 0)
        length = self.get(v, "byteLength", where, "int")
        stride = self.get(v, "byteStride", where, "int", None)
        if offset < 0:
            raise self.error(f"{where}.byteOffset", f"{offset} (expected >= 0)")
        if length < 1:
            raise self.error(f"{where}.byteLength", f"{length} (expected >= 1)")
        if stride is not None and not (4 <= stride <= 252 and stride % 4 == 0):
            raise self.error(f"{where}.byteStride", f"{stride} (expected a multiple of 4 in 4..252)")
        data = self.buffer(bi, f"{where}.buffer")
        blen = self.item("buffers", bi)["byteLength"]
        if offset + length > blen:
            raise self.error(where, f"bytes {offset}..{offset + length - 1} run past the end of buffers[{bi}] "
                             f"({blen} bytes)")
        return data, offset, length, stride

    # --- accessors ---------------------------------------------------------------
    def accessor(self, index, jpath):
        """accessors[index] as an (count, components) array: float64 for float and normalized
        accessors (normalized integers mapped to [0, 1] or [-1, 1] as the spec says), int64
        for other integers. Cached; do not modify the result."""
        if index not in self._accessors:
            a = self.item("accessors", index, jpath)
            self._accessors[index] = self._read_accessor(a, f"accessors[{index}]")
        return self._accessors[index]

    def accessor_info(self, index, jpath):
        """(componentType, type, normalized) of accessors[index] (checked)."""
        a = self.item("accessors", index, jpath)
        where = f"accessors[{index}]"
        return self._component_type(a, where), self._type(a, where), self.get(a, "normalized", where, "bool", False)

    def _component_type(self, obj, where, allowed=None):
        ct = self.get(obj, "componentType", where, "int")
        if ct not in COMPONENT_TYPES:
            raise self.error(f"{where}.componentType", f"{ct} is not a glTF component type "
                             f"({', '.join(map(str, COMPONENT_TYPES))})")
        if allowed is not None and ct not in allowed:
            raise self.error(f"{where}.componentType", f"{ct}: expected one of {', '.join(map(str, allowed))}")
        return ct

    def _type(self, obj, where):
        t = self.get(obj, "type", where, "str")
        if t not in ACCESSOR_TYPES:
            raise self.error(f"{where}.type", f"{t!r} is not a glTF accessor type ({', '.join(ACCESSOR_TYPES)})")
        return t

    def _read_accessor(self, a, where):
        ct, t, normalized = self._component_type(a, where), self._type(a, where), \
            self.get(a, "normalized", where, "bool", False)
        count = self.get(a, "count", where, "int")
        if count < 1:
            raise self.error(f"{where}.count", f"{count} (expected >= 1)")
        if normalized and ct in (5125, 5126):
            raise self.error(f"{where}.normalized", f"true for componentType {ct} (only 8- and 16-bit integers "
                             "are normalized)")
        dtype = COMPONENT_TYPES[ct]
        cols, rows = ACCESSOR_TYPES[t]
        if "bufferView" in a:
            view = self.ref(a, "bufferView", where, "bufferViews")
            offset = self.get(a, "byteOffset", where, "int", 0)
            if offset < 0:
                raise self.error(f"{where}.byteOffset", f"{offset} (expected >= 0)")
            out = self._elements(view, offset, count, dtype, cols, rows, where, strided=True)
        else:
            if count > MAX_UNBACKED_ELEMENTS:
                raise self.error(f"{where}.count", f"{count} elements without a bufferView (at most "
                                 f"{MAX_UNBACKED_ELEMENTS} are read as zeros)")
            out = np.zeros((count, cols * rows), dtype=dtype)
        out = self._convert(out, dtype, normalized)
        if "sparse" in a:
            out = self._apply_sparse(a, out, count, dtype, cols, rows, normalized, where)
        out.setflags(write=False)
        return out

    def _elements(self, view, offset, count, dtype, cols, rows, where, strided):
        """(count, cols * rows) raw components from bufferViews[view] at ``offset``."""
        data, start, length, stride = self.buffer_view(view, f"{where}.bufferView")
        size = dtype.itemsize
        col_bytes = rows * size
        col_stride = col_bytes if cols == 1 else -(-col_bytes // 4) * 4      # matrix columns: 4-byte aligned
        elem = cols * col_stride if cols > 1 else col_bytes
        step = stride if (strided and stride is not None) else elem
        if step < elem:
            raise self.error(f"bufferViews[{view}].byteStride", f"{step} is smaller than one element of {where} "
                             f"({elem} bytes)")
        end = offset + (count - 1) * step + elem
        if end > length:
            raise self.error(where, f"{count} elements of {elem} bytes{f' every {step}' if step != elem else ''} "
                             f"from byte {offset} need {end} bytes, but bufferViews[{view}] has {length} "
                             "(truncated or wrong count)")
        raw = np.frombuffer(data, dtype=np.uint8, count=end - offset, offset=start + offset)
        rows_u8 = np.lib.stride_tricks.as_strided(raw, shape=(count, elem), strides=(step, 1), writeable=False)
        if cols > 1 and col_stride != col_bytes:
            rows_u8 = np.concatenate([rows_u8[:, c * col_stride:c * col_stride + col_bytes] for c in range(cols)],
                                     axis=1)
        return np.ascontiguousarray(rows_u8).view(dtype).reshape(count, cols * rows)

    @staticmethod
    def _convert(raw, dtype, normalized):
        if dtype.kind == "f":
            return raw.astype(np.float64)
        if normalized:
            bits = dtype.itemsize * 8
            if dtype.kind == "i":
                return np.maximum(raw.astype(np.float64) / (2.0 ** (bits - 1) - 1), -1.0)
            return raw.astype(np.float64) / (2.0 ** bits - 1)
        return raw.astype(np.int64)

    def _apply_sparse(self, a, out, count, dtype, cols, rows, normalized, where):
        s = self.get(a, "sparse", where, "dict")
        sw = f"{where}.sparse"
        n = self.get(s, "count", sw, "int")
        if not 1 <= n <= count:
            raise self.error(f"{sw}.count", f"{n} (expected 1..{count}, the accessor's count)")
        ind = self.get(s, "indices", sw, "dict")
        val = self.get(s, "values", sw, "dict")
        iw, vw = f"{sw}.indices", f"{sw}.values"
        ict = self._component_type(ind, iw, INDEX_COMPONENT_TYPES)
        iview = self.ref(ind, "bufferView", iw, "bufferViews")
        ioff = self.get(ind, "byteOffset", iw, "int", 0)
        vview = self.ref(val, "bufferView", vw, "bufferViews")
        voff = self.get(val, "byteOffset", vw, "int", 0)
        if ioff < 0 or voff < 0:
            raise self.error(iw if ioff < 0 else vw, "byteOffset < 0")
        idx = self._elements(iview, ioff, n, COMPONENT_TYPES[ict], 1, 1, iw, strided=False)[:, 0].astype(np.int64)
        values = self._convert(self._elements(vview, voff, n, dtype, cols, rows, vw, strided=False), dtype,
                               normalized)
        bad = np.flatnonzero(idx >= count)
        if bad.size:
            raise self.error(iw, f"index {int(idx[bad[0]])} (entry {int(bad[0])}) >= the accessor's count {count}")
        out = out.copy()
        out[idx] = values
        return out


class Notes:
    """The warnings of one read, gathered by topic and emitted once each at the end:
    ``add(topic, what, where)`` -> one warning per topic, "FILE: TOPIC: what (where, ...), ...".
    """
    MAX_PLACES = 6

    def __init__(self, label):
        self.label = label
        self.topics = {}

    def add(self, topic, what, where=None):
        places = self.topics.setdefault(topic, {}).setdefault(what, [])
        if where is not None and where not in places:
            places.append(where)

    def messages(self):
        out = []
        for topic, items in self.topics.items():
            parts = []
            for what, places in items.items():
                shown = places[:self.MAX_PLACES] + (["..."] if len(places) > self.MAX_PLACES else [])
                parts.append(what + (f" ({', '.join(shown)})" if shown else ""))
            out.append(f"{self.label}: {topic}: {'; '.join(parts)}")
        return out

    def emit(self, stacklevel=3):
        for message in self.messages():
            warnings.warn(message, stacklevel=stacklevel)


def _join(jpath, key):
    """The JSON path of ``key`` inside ``jpath`` ("" for the top level)."""
    return f"{jpath}.{key}" if jpath else key
