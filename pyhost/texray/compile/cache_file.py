"""One file per cached compiled scene (texray.compile.cache): a CompiledScene's arrays,
uncompressed, and a JSON header for the rest, with no pickle anywhere.

Layout: a 24-byte prefix (magic ``TEXRAYSC``, format number, CRC-32 of the header,
header length), the UTF-8 JSON header, then, from the next multiple of 64 bytes, each
array's raw bytes at a 64-byte aligned offset. The header holds the entry's key, the
data's length, each array's dtype (numpy's ``.npy`` description, read back with
``ast.literal_eval``), shape, offset and CRC-32, and the non-array fields (the
feature set, the BVH's statistics, names) as tagged JSON. :func:`read` maps the file and checks everything before
returning: a truncated, corrupt, foreign or other-format file raises
:class:`CacheFileError` and is never half-used. The arrays it returns are read-only
views of the mapping (no copy; the mapping stays valid if the file is replaced or
removed meanwhile).

:func:`write` is atomic: the file is written under a temporary name in the same
folder and moved into place with ``os.replace``, so readers see the old file, the
new one or none, and two processes storing the same key at once each replace it
with a whole (and identical) file.
"""
from __future__ import annotations

import ast
import dataclasses
import json
import mmap
import os
import secrets
import struct
import zlib
from pathlib import Path

import numpy as np

from ..accel.scene_bvh import SceneBVH
from ..device.features import Features
from .scene import CompiledScene

MAGIC = b"TEXRAYSC"
FORMAT = 2          # 2: CompiledScene.scale, arrays in device units (texray.compile.units)
SUFFIX = ".txscene"
TEMP_SUFFIX = ".tmp"
ALIGN = 64
MAX_HEADER = 64 * 2**20
# The CompiledScene field that is not stored: the renderer takes the scene's current camera.
NOT_STORED = ("camera",)
# The dataclasses a CompiledScene holds besides itself, by the name the header gives them.
DATACLASSES = {cls.__name__: cls for cls in (Features, SceneBVH)}
_PREFIX = struct.Struct("<8sIIQ")          # magic, format, header CRC-32, header length


class CacheFileError(Exception):
    """The file is not a usable entry for the key asked; the message says why. ``stat``:
    the file's os.stat_result (to remove that file and not one stored since)."""

    def __init__(self, message, stat=None):
        super().__init__(message)
        self.stat = stat


class Entry:
    """A CompiledScene taken apart for storing: the JSON of its fields and its arrays by name.
    Raises CacheFileError for a field of a type it cannot store."""

    def __init__(self, cs: CompiledScene):
        self.arrays = {}
        self.fields = {f.name: _encode(getattr(cs, f.name), f.name, self.arrays)
                       for f in dataclasses.fields(cs) if f.name not in NOT_STORED}
        self.arrays = {n: np.ascontiguousarray(a) for n, a in self.arrays.items()}
        self.nbytes = sum(_aligned(a.nbytes) for a in self.arrays.values())


def write(path: Path, key: str, entry: Entry, meta: dict) -> int:
    """Store ``entry`` and the JSON-able ``meta`` at ``path``, atomically; returns the
    file's size. Raises OSError for the file system's errors (no temporary file is left
    behind)."""
    table, offset = [], 0
    for name, a in entry.arrays.items():
        table.append({"name": name, "descr": repr(np.lib.format.dtype_to_descr(a.dtype)), "shape": list(a.shape),
                      "offset": offset, "nbytes": int(a.nbytes), "crc32": zlib.crc32(_bytes(a))})
        offset += _aligned(a.nbytes)
    header = {"format": FORMAT, "key": key, "fields": entry.fields, "arrays": table, "data_bytes": offset,
              "meta": meta}
    body = json.dumps(header, separators=(",", ":")).encode()
    start = _data_start(len(body))
    tmp = path.with_name(f".{path.stem[:16]}-{os.getpid()}-{secrets.token_hex(4)}{TEMP_SUFFIX}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(_PREFIX.pack(MAGIC, FORMAT, zlib.crc32(body), len(body)))
            f.write(body)
            f.write(b"\0" * (start - _PREFIX.size - len(body)))
            for a in entry.arrays.values():
                f.write(_bytes(a))
                f.write(b"\0" * (_aligned(a.nbytes) - a.nbytes))
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return start + offset


def read(path: Path, key: str) -> tuple[CompiledScene, dict]:
    """(the CompiledScene stored at ``path``, camera None; its meta). Raises
    FileNotFoundError when there is no file, CacheFileError when it is not a whole,
    intact entry of this format for ``key``, OSError when it cannot be read."""
    with open(path, "rb") as f:
        st = os.fstat(f.fileno())
        try:
            return _read(f, st, key)
        except CacheFileError as e:
            e.stat = st
            raise


def _read(f, st, key):
    prefix = f.read(_PREFIX.size)
    if len(prefix) < _PREFIX.size:
        raise CacheFileError(f"truncated: {len(prefix)} bytes")
    magic, fmt, crc, length = _PREFIX.unpack(prefix)
    if magic != MAGIC:
        raise CacheFileError("not a texray scene cache file")
    if fmt != FORMAT:
        raise CacheFileError(f"format {fmt}, this texray reads format {FORMAT}")
    if length > min(MAX_HEADER, st.st_size):
        raise CacheFileError(f"truncated or corrupt: a {length}-byte header in a {st.st_size}-byte file")
    body = f.read(length)
    if len(body) != length or zlib.crc32(body) != crc:
        raise CacheFileError("corrupt header (CRC mismatch)")
    try:
        header = json.loads(body)
        if header["key"] != key:
            raise CacheFileError(f"holds key {str(header['key'])[:16]}..., not {key[:16]}...")
        start = _data_start(length)
        if start + header["data_bytes"] != st.st_size:
            raise CacheFileError(f"truncated: {st.st_size} bytes, expected {start + header['data_bytes']}")
        mapping = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) if st.st_size > start else b""
        arrays = {a["name"]: _array(mapping, start, a) for a in header["arrays"]}
        fields = {name: _decode(v, arrays) for name, v in header["fields"].items()}
        cs = CompiledScene(**fields, camera=None)
    except CacheFileError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError, SyntaxError, IndexError) as e:
        raise CacheFileError(f"corrupt header ({type(e).__name__}: {e})") from None
    return cs, header.get("meta", {})


def _array(mapping, start, entry):
    dtype = np.lib.format.descr_to_dtype(ast.literal_eval(entry["descr"]))
    shape, nbytes, offset = tuple(int(n) for n in entry["shape"]), int(entry["nbytes"]), start + int(entry["offset"])
    if dtype.hasobject or int(np.prod(shape)) * dtype.itemsize != nbytes or offset + nbytes > len(mapping):
        raise CacheFileError(f"array {entry['name']}: its size does not match its dtype and shape, or the file")
    if nbytes == 0:
        return np.zeros(shape, dtype)
    a = np.frombuffer(mapping, dtype=dtype, count=nbytes // dtype.itemsize, offset=offset).reshape(shape)
    if zlib.crc32(_bytes(a)) != entry["crc32"]:
        raise CacheFileError(f"array {entry['name']}: corrupt (CRC mismatch)")
    return a


def _encode(v, name, arrays):
    """JSON for a field's value; arrays go to ``arrays`` under their path and are named."""
    t = type(v)
    if v is None or t in (bool, int, float, str):
        return v
    if t is np.ndarray or t is np.memmap:
        arrays[name] = v
        return {"array": name}
    if isinstance(v, np.generic) and v.dtype.kind in "biuf":
        return {"scalar": [v.dtype.str, v.item()]}
    if t in (tuple, list):
        return {t.__name__: [_encode(x, f"{name}[{i}]", arrays) for i, x in enumerate(v)]}
    if t is dict and all(type(k) in (str, int) for k in v):
        return {"dict": [[k, _encode(x, f"{name}[{k!r}]", arrays)] for k, x in v.items()]}
    if dataclasses.is_dataclass(v) and DATACLASSES.get(t.__name__) is t:
        return {"dataclass": [t.__name__, {f.name: _encode(getattr(v, f.name), f"{name}.{f.name}", arrays)
                                           for f in dataclasses.fields(v)}]}
    raise CacheFileError(f"{name}: cannot store a {t.__module__}.{t.__qualname__}")


def _decode(v, arrays):
    if v is None or type(v) in (bool, int, float, str):
        return v
    (tag, x), = v.items()
    if tag == "array":
        return arrays[x]
    if tag == "scalar":
        return np.dtype(x[0]).type(x[1])
    if tag in ("tuple", "list"):
        items = [_decode(i, arrays) for i in x]
        return tuple(items) if tag == "tuple" else items
    if tag == "dict":
        return {k: _decode(i, arrays) for k, i in x}
    if tag == "dataclass":
        return DATACLASSES[x[0]](**{n: _decode(i, arrays) for n, i in x[1].items()})
    raise CacheFileError(f"unknown value tag {tag!r}")


def _bytes(a):
    """The bytes of a C-contiguous array, any dtype, without a copy."""
    return a.reshape(-1).view(np.uint8)


def _data_start(header_length):
    return _aligned(_PREFIX.size + header_length)


def _aligned(n):
    return (n + ALIGN - 1) // ALIGN * ALIGN
