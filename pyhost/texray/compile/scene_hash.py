"""The content hash of a scene: the key of its compiled form in the scene cache
(texray.compile.cache).

The key covers everything :func:`texray.compile.compile_scene` reads: the scene's
lights, ambient, background and objects (every field of every shape, transform,
material, mapping, bump or normal map and displacement; textures by their pixels,
colour space and options), the compile options, and a fingerprint of texray's own
host code (:func:`code_fingerprint`), so that a code change never reads an entry
made by other code. The camera is left out: a compiled scene does not depend on it
(the renderer takes the scene's current one).

The scene is walked generically, not from a list of fields: a dataclass is its
fields, any other texray object its instance attributes except those its class
names in ``DERIVED`` (caches of values made from the others), numpy arrays their
dtype, shape and bytes, and lists, tuples, dicts and numbers their values with
their types. The compiler tells textures, materials and pixel arrays apart by
identity (a material shared by two meshes is one table entry, two equal ones are
two), so an object met a second time hashes as a reference to its first visit:
two scenes hash alike only when their object graphs are the same shape with the
same values. An object of a class marked ``HASH_ONCE`` (a texture's pixels, read-only)
is walked into a digest of its own once, which later walks reuse (the digest is kept
on the object). Anything else (user subclasses, objects of other libraries) makes
the scene uncacheable (:func:`scene_key` raises :class:`Uncacheable`), never a key
that could match a scene compiling differently.
"""
from __future__ import annotations

import dataclasses
import hashlib
import struct
import sys
from pathlib import Path, PurePath

import numpy as np

from ..device.opencl import KERNEL_DIR

PACKAGE = "texray"
ROOT = Path(__file__).resolve().parents[1]        # the package's folder
# The subpackages and modules that run after a scene is compiled: the import graph has
# no cycles and each of them imports texray.compile (or imports what does), so no code
# of the compiler can be in them. Every other module of the package is fingerprinted.
AFTER_COMPILE = ("renderer", "bench", "cli.py")
# Data packages an installed wheel holds inside texray/ (the source tree keeps them beside
# pyhost/): not host code, and where they sit must not change the key.
DATA_PACKAGES = ("kernels", "scenes")
# Kernel sources whose output is compiled scene data (the cell BVH builder's tree).
COMPILE_KERNELS = ("accel/build.cl",)
# The scene fields a compiled scene does not depend on.
LEFT_OUT = {"texray.scene.scene.Scene": ("camera",)}

_code = None


class Uncacheable(Exception):
    """The scene holds something the hash cannot vouch for; the message says what."""


def code_fingerprint() -> bytes:
    """sha256 of numpy's and Python's versions, the source of every module of texray that
    can take part in compiling a scene (texray/__init__.py, with ``__version__``, among
    them) and of the kernels whose output is scene data (COMPILE_KERNELS); the same for a
    source tree and an installed wheel of the same code. Computed once per process."""
    global _code
    if _code is None:
        h = hashlib.sha256()
        for part in (np.__version__, sys.version, sys.byteorder):
            _token(h, b"v", part.encode())
        for path in sorted(ROOT.rglob("*.py")):
            rel = path.relative_to(ROOT)
            if rel.parts[0] in AFTER_COMPILE or rel.parts[0] in DATA_PACKAGES:
                continue
            _token(h, b"p", rel.as_posix().encode())
            _token(h, b"c", path.read_bytes())
        for name in COMPILE_KERNELS:
            _token(h, b"k", name.encode())
            _token(h, b"c", (KERNEL_DIR / name).read_bytes())
        _code = h.digest()
    return _code


def scene_key(scene, **options) -> str:
    """Hex sha256 of ``scene`` and the compile ``options`` (keyword arguments of
    compile_scene); raises :class:`Uncacheable` when the scene holds something the hash
    cannot vouch for."""
    h = hashlib.sha256()
    _token(h, b"k", code_fingerprint())
    walker = _Walker(h)
    walker.walk(sorted(options.items()), "options")
    walker.walk(scene)
    return h.hexdigest()


def _token(h, tag, payload: bytes):
    h.update(tag + struct.pack("<Q", len(payload)))
    h.update(payload)


class _Walker:
    """Feeds a value into the hash as tagged, length-prefixed tokens (unambiguous: two
    different walks never give the same byte stream)."""

    def __init__(self, h):
        self.h, self.seen, self.alive = h, {}, []   # alive: ids stay unique during the walk

    def walk(self, v, where="scene"):
        h = self.h
        t = type(v)
        if v is None:
            h.update(b"N")
        elif t is bool:
            h.update(b"T" if v else b"F")
        elif t is int:
            _token(h, b"i", str(v).encode())
        elif t is float:
            _token(h, b"f", struct.pack("<d", v))
        elif t is str:
            _token(h, b"s", v.encode("utf-8", "surrogatepass"))
        elif t is bytes:
            _token(h, b"y", v)
        elif isinstance(v, np.generic) and v.dtype.kind in "biufc":
            _token(h, b"g", v.dtype.str.encode() + b":" + v.tobytes())
        elif t is tuple:
            _token(h, b"(", str(len(v)).encode())
            for i, x in enumerate(v):
                self.walk(x, f"{where}[{i}]")
        elif isinstance(v, PurePath):
            _token(h, b"P", str(v).encode("utf-8", "surrogatepass"))
        elif self._ref(v):
            return
        elif t is np.ndarray or t is np.memmap:
            self._array(v, where)
        elif t is list:
            _token(h, b"[", str(len(v)).encode())
            for i, x in enumerate(v):
                self.walk(x, f"{where}[{i}]")
        elif t is dict:
            keys = list(v)
            if not all(type(k) in (str, int) for k in keys):
                raise Uncacheable(f"{where}: a dict with keys other than strings and integers")
            _token(h, b"{", str(len(keys)).encode())
            for k in sorted(keys, key=lambda k: (type(k).__name__, k)):
                self.walk(k, where)
                self.walk(v[k], f"{where}[{k!r}]")
        else:
            self._object(v, where)

    def _ref(self, v) -> bool:
        """True (and a reference token) for a mutable object walked before; else remember it."""
        i = self.seen.get(id(v))
        if i is not None:
            _token(self.h, b"@", str(i).encode())
            return True
        self.seen[id(v)] = len(self.seen)
        self.alive.append(v)
        return False

    def _array(self, a, where):
        if a.dtype.hasobject:
            raise Uncacheable(f"{where}: an array of Python objects")
        header = f"{a.dtype.descr!r}|{a.shape!r}".encode()
        _token(self.h, b"a", header)
        data = np.ascontiguousarray(a)
        self.h.update(struct.pack("<Q", data.nbytes))
        self.h.update(memoryview(data.reshape(-1)).cast("B") if data.size else b"")

    def _object(self, v, where):
        cls = type(v)
        module = getattr(cls, "__module__", "") or ""
        if not (module == PACKAGE or module.startswith(PACKAGE + ".")):
            raise Uncacheable(f"{where}: {module}.{cls.__qualname__} is not a texray type")
        name = f"{module}.{cls.__qualname__}"
        _token(self.h, b"o", name.encode())
        if dataclasses.is_dataclass(v):
            names = [f.name for f in dataclasses.fields(v) if f.name not in LEFT_OUT.get(name, ())]
        else:
            try:
                state = vars(v)
            except TypeError:
                raise Uncacheable(f"{where}: {cls.__qualname__} has no instance dictionary") from None
            derived = getattr(cls, "DERIVED", ())
            names = sorted(n for n in state if n not in derived)
        if getattr(cls, "HASH_ONCE", False):
            # Content that cannot change once made (a texture's read-only pixels): walked into
            # a hash of its own once, kept on the object as ``_digest`` (one of its DERIVED).
            digest = getattr(v, "_digest", None)
            if digest is None:
                sub = _Walker(hashlib.sha256())
                for n in names:
                    _token(sub.h, b".", n.encode())
                    sub.walk(getattr(v, n), f"{where}.{n}")
                digest = v._digest = sub.h.digest()
            _token(self.h, b"d", digest)
            return
        for n in names:
            _token(self.h, b".", n.encode())
            self.walk(getattr(v, n), f"{where}.{n}")
