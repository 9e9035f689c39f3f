"""A compiled scene's device buffers, uploaded once and kept for the next renders.

A render needs every array of its compiled scene on the device (texray.device.buffers.
Uploaded: the BVH, the primitives, the texels). Uploading them again for each frame of
a camera path, or each of a benchmark's renders, copies the same bytes again (1.4 ms of
a 20 ms frame for the grazing quad's 2 MiB of texels on PoCL). So the buffers of the
KEEP scenes rendered last stay on their device, keyed by the compiled scene's content
(:func:`compiled_key`) and the device: a render of the same scene, camera aside, reuses
them; a changed scene has another key and is uploaded anew. A scene with no content key
(compiled without the scene cache's hash: ``cache=False``, ``TEXRAY_NO_CACHE=1``, or
a CompiledScene made by ``compile_scene`` and passed in) is uploaded for its render only,
since its arrays could change in place between renders without a key to tell.
:func:`clear` gives the kept buffers back (they are freed when nothing renders with them).

Dask workers keep the scenes their tasks render the same way (texray.renderer.
distributed), keyed by the key the client computed.
"""
from __future__ import annotations

import dataclasses
import hashlib
import threading
from collections import OrderedDict

import numpy as np
import pyopencl as cl

from ..device.buffers import Uploaded

KEEP = 2               # scenes whose device buffers a process keeps between renders (newest first)

# Fields of a CompiledScene that only the host reads (the binary BVH, the camera, the compile's
# timings): not part of what a device renders from.
CLIENT_ONLY = ("bvh", "camera", "steps_s", "blas_reused", "objects_generic", "source_key")

_kept: "OrderedDict" = OrderedDict()       # (key, device) -> Uploaded
_lock = threading.RLock()       # clear() runs within uploaded() on a failed upload


def compiled_key(cs) -> str:
    """Content hash of what a device renders from: every field of the compiled scene but
    those only the host reads (CLIENT_ONLY). A scene compiled through the scene cache has
    the cache's key of what it was compiled from: that with what a render changes (the
    features; the generic object table) is the key, and its arrays are not hashed again
    (40 ms for the showcase's 20 MiB)."""
    h = hashlib.blake2b(digest_size=20)
    if cs.source_key is not None:
        h.update(f"{cs.source_key}|{cs.features!r}|{cs.objects is cs.objects_generic}".encode())
        return h.hexdigest()
    for f in dataclasses.fields(cs):
        if f.name in CLIENT_ONLY:
            continue
        v = getattr(cs, f.name)
        h.update(f.name.encode() + b"\0")
        if isinstance(v, np.ndarray):
            a = np.ascontiguousarray(v)
            h.update(f"{a.dtype.descr}{a.shape}".encode())
            h.update(memoryview(a.reshape(-1)).cast("B") if a.size else b"")
        else:
            h.update(repr(v).encode())
    return h.hexdigest()


def local_key(cs) -> str | None:
    """The key a local render keeps ``cs``'s buffers under: its :func:`compiled_key` where
    the scene cache vouches for its content (``cs.source_key``), else None (not kept)."""
    return compiled_key(cs) if cs.source_key is not None else None


def uploaded(rt, cs, key) -> tuple[Uploaded, bool]:
    """(``cs``'s device buffers on ``rt``'s device, whether they were kept from an earlier
    render). ``key``: :func:`compiled_key` of ``cs`` (None: uploaded for this render only).
    When the device runs out of memory for the upload, the kept buffers of other scenes
    are given back and the upload is tried once more."""
    if key is None:
        return _upload(rt, cs), False
    k = (key, rt.device.int_ptr)
    with _lock:
        up = _kept.get(k)
        if up is not None:
            _kept.move_to_end(k)
            return up, True
        while len(_kept) >= KEEP:          # room first: at most KEEP scenes on the device at once
            _kept.popitem(last=False)
        up = _kept[k] = _upload(rt, cs)
        return up, False


def _upload(rt, cs) -> Uploaded:
    try:
        return Uploaded(rt.context, cs)
    except cl.MemoryError:
        if not _kept:
            raise
    clear()
    return Uploaded(rt.context, cs)


def clear() -> int:
    """Give back every kept scene's device buffers; returns how many scenes were kept."""
    with _lock:
        n = len(_kept)
        _kept.clear()
        return n
