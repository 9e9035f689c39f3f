"""The one validation layer of the Python API and scene files.

Every check raises :class:`texray.SceneError` worded the same way,
``WHERE FIELD: expected WHAT, got VALUE``, with VALUE written as plain numbers
(``1e+39``, ``[0, 0, 0]``, never ``np.float64(0.0)``). ``where`` is the prefix
naming the object (``"camera."``, ``"objects[2]: "``); scene files add their
path in front (texray.scenefile).

Numbers the device sees must be finite in float32 (|x| <= 3.4e38), and point
coordinates must stay within :data:`COORD_LIMIT`, so that differences and
squares of coordinates computed on the device in float32 stay finite.
"""
from __future__ import annotations

import math
import os
import stat
from pathlib import Path

import numpy as np

from .errors import SceneError

FLT_MAX = float(np.finfo(np.float32).max)
# |coordinate| bound of points the device sees: the square of a difference of two such
# coordinates, summed over three axes, is 3 (2e18)^2 = 1.2e37, below FLT_MAX.
COORD_LIMIT = 1e18
NAME_MAX = 255          # bytes in one path component (POSIX NAME_MAX on Linux, macOS, Windows)
PATH_MAX = 4096         # bytes in a whole path (Linux PATH_MAX)


def show(value, limit=80) -> str:
    """``value`` as plain text: numpy scalars and arrays as Python numbers and lists,
    floats as repr (1e+39, nan), long values cut at ``limit`` characters."""
    def plain(v):
        if isinstance(v, np.ndarray):
            return plain(v.tolist()) if v.size <= 64 else f"<array of shape {v.shape}, dtype {v.dtype}>"
        if isinstance(v, np.generic):
            return v.item()
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        return v
    p = plain(value)
    text = repr(p) if not isinstance(p, (float, int)) or isinstance(p, bool) else _num(p)
    if isinstance(p, list):
        text = "[" + ", ".join(_num(x) if isinstance(x, (int, float)) and not isinstance(x, bool)
                               else show(x, limit) for x in p) + "]"
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _num(x) -> str:
    return repr(float(x)) if isinstance(x, float) else str(x)


def fail(where, field, expected, value):
    raise SceneError(f"{where}{field}: expected {expected}, got {show(value)}")


def _bound(x):
    return str(x) if isinstance(x, (int, np.integer)) else f"{x:g}"


def _range_text(lo, hi, lo_open, hi_open):
    if lo is None and hi is None:
        return ""
    a = "-inf" if lo is None else _bound(lo)
    b = "inf" if hi is None else _bound(hi)
    return f" in {'(' if lo_open or lo is None else '['}{a}, {b}{')' if hi_open or hi is None else ']'}"


def _limit_text(limit):
    why = (" (finite in float32)" if limit == FLT_MAX
           else " (the device computes in float32)" if limit == COORD_LIMIT else "")
    return f" of magnitude <= {limit:.3g}{why}"


def _is_real(value):
    return (not isinstance(value, (bool, np.bool_))
            and isinstance(value, (int, float, np.integer, np.floating)))


def number(value, field, where="", lo=None, hi=None, lo_open=False, hi_open=False, limit=FLT_MAX) -> float:
    """A real number (not a bool), finite, |x| <= ``limit`` (float32's largest by
    default), in the range given. Returns a Python float."""
    what = "a number" + _range_text(lo, hi, lo_open, hi_open)
    if not _is_real(value):
        fail(where, field, what, value)
    v = float(value) if not isinstance(value, int) or abs(value) < 2 ** 1023 else math.inf
    if not math.isfinite(v):
        fail(where, field, "a finite number" + _range_text(lo, hi, lo_open, hi_open), value)
    if abs(v) > limit:
        fail(where, field, "a number" + _limit_text(limit), value)
    if (lo is not None and (v <= lo if lo_open else v < lo)) or (hi is not None and (v >= hi if hi_open else v > hi)):
        fail(where, field, what, value)
    return v


def integer(value, field, where="", lo=None, hi=None) -> int:
    """An integer (Python or numpy, not a bool) in [lo, hi]."""
    what = "an integer" + _range_text(lo, hi, False, False)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        fail(where, field, what, value)
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        fail(where, field, what, value)
    return v


def vector(value, n, field, where="", *, broadcast=False, nonneg=False, nonzero=False, positive=False,
           limit=FLT_MAX) -> np.ndarray:
    """``n`` real numbers as a float64 array (a single number when ``broadcast``), each finite
    with |x| <= ``limit``; ``nonneg``: all >= 0; ``nonzero``: none 0; ``positive``: all > 0."""
    count = f"{n} numbers" if not broadcast else f"a number or {n} numbers"
    qual = " >= 0" if nonneg else " > 0" if positive else ""
    what = count + qual
    items = value if isinstance(value, (list, tuple, np.ndarray)) else None
    if items is None:
        if not (broadcast and _is_real(value)):
            fail(where, field, what, value)
        items = [value] * n
    if isinstance(items, np.ndarray):
        if items.ndim != 1 or items.dtype.kind not in "iuf":
            fail(where, field, what, value)
        items = list(items)
    if len(items) != n or not all(_is_real(x) for x in items):
        fail(where, field, what, value)
    v = np.array([float(x) if not isinstance(x, int) or abs(x) < 2 ** 1023 else math.inf for x in items])
    if not np.all(np.isfinite(v)):
        fail(where, field, f"{count} finite" + qual, value)
    if np.any(np.abs(v) > limit):
        fail(where, field, count + _limit_text(limit), value)
    if (nonneg and np.any(v < 0)) or (positive and np.any(v <= 0)):
        fail(where, field, what, value)
    if nonzero and np.any(v == 0):
        fail(where, field, f"{count}, none of them zero", value)
    return v


def point(value, field, where="") -> np.ndarray:
    """A 3-D point the device sees: 3 finite numbers within +-COORD_LIMIT."""
    return vector(value, 3, field, where, limit=COORD_LIMIT)


def rgb(value, field, where="") -> np.ndarray:
    """A colour or intensity: a number or 3 numbers, each >= 0 and finite in float32."""
    return vector(value, 3, field, where, broadcast=True, nonneg=True)


def array(value, field, where, width, *, integer_values=False) -> np.ndarray:
    """An (N, width) array of real numbers (float64, or int64 with ``integer_values``): a numpy
    array or nested lists; ragged, non-numeric, boolean and complex input are errors."""
    shape = f"(N, {width})"
    what = f"an {shape} array of {'integers' if integer_values else 'numbers'}"
    if isinstance(value, (str, bytes)) or value is None:
        fail(where, field, what, value)
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):        # ragged nested sequences
        fail(where, field, what + " (equal-length rows)", value)
    if a.dtype == object:
        try:
            a = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            fail(where, field, what + " (equal-length rows of numbers)", value)
    if a.dtype.kind not in ("iu" if integer_values else "iuf") and not (a.size == 0 and a.dtype.kind == "f"):
        raise SceneError(f"{where}{field}: expected {what}, got an array of {a.dtype}"
                         + (f" values (e.g. {show(a.flat[0])})" if a.size else ""))
    if a.ndim != 2 or a.shape[1] != width:
        raise SceneError(f"{where}{field}: expected shape {shape}, got {a.shape}")
    return a.astype(np.int64 if integer_values else np.float64)


def one_of(value, options, field, where=""):
    """``value`` if it is one of ``options`` (strings, compared exactly)."""
    if not isinstance(value, str) or value not in options:
        fail(where, field, f"one of {', '.join(options)}", value)
    return value


def instance(value, types, field, where="", what=None):
    """``value`` if it is an instance of ``types``; ``what`` names them in the message."""
    if not isinstance(value, types):
        names = what or " or ".join(f"a texray.{t.__name__}" for t in (types if isinstance(types, tuple) else (types,)))
        raise SceneError(f"{where}{field}: expected {names}, got {_type_and_value(value)}")
    return value


def callable_or_none(value, field, where=""):
    if value is not None and not callable(value):
        raise SceneError(f"{where}{field}: expected None or a callable, got {_type_and_value(value)}")
    return value


def _type_and_value(value):
    text = show(value, 60)
    name = type(value).__name__
    return text if text.startswith(("<", name)) else f"{name} {text}"


def file_path(value, field, where="") -> Path:
    """An existing, readable regular file: a str or os.PathLike. Too-long names, directories,
    FIFOs and devices are errors naming the path (a FIFO or /dev/zero would block or never end)."""
    if not isinstance(value, (str, os.PathLike)) or isinstance(value, bytes):
        raise SceneError(f"{where}{field}: expected a file path, got {_type_and_value(value)}")
    path = Path(value)
    text = os.fsencode(path)
    if not text:
        raise SceneError(f"{where}{field}: expected a file path, got ''")
    if b"\0" in text:
        raise SceneError(f"{where}{field}: the path holds a NUL character: {show(str(path))}")
    long_part = max((len(os.fsencode(p)) for p in path.parts), default=0)
    if len(text) > PATH_MAX or long_part > NAME_MAX:
        raise SceneError(f"{where}{field}: path too long ({len(text)} bytes, longest name {long_part}; "
                         f"at most {PATH_MAX} and {NAME_MAX}): {show(str(path), 120)}")
    try:
        st = path.stat()
    except FileNotFoundError:
        raise SceneError(f"{where}{field}: file not found: {path}") from None
    except OSError as e:
        raise SceneError(f"{where}{field}: cannot access {path}: {e.strerror or e}") from None
    if not stat.S_ISREG(st.st_mode):
        kind = ("a directory" if stat.S_ISDIR(st.st_mode) else "a FIFO" if stat.S_ISFIFO(st.st_mode)
                else "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
                else "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
        raise SceneError(f"{where}{field}: expected a regular file, got {kind}: {path}")
    if not os.access(path, os.R_OK):
        raise SceneError(f"{where}{field}: file not readable: {path}")
    return path


# Image sides and samples the kernels index with 32-bit integers: a pixel's index
# y * width + x must fit (width * height < 2^32), and the float32 accumulator of a pixel
# stops resolving one more sample beyond 2^24 of them.
MAX_IMAGE_SIDE = 1 << 20
MAX_SPP = 1 << 24
MAX_SEED = 2**32 - 1          # the sampler's seed is 32-bit: larger seeds would repeat images


def render_settings(width, height, spp, seed, where="render: "):
    """(width, height, spp, seed) as ints, or SceneError naming the field (``where`` prefixes
    it: the API's "render: ", a scene file's "render.")."""
    w = integer(width, "width", where, 1, MAX_IMAGE_SIDE)
    h = integer(height, "height", where, 1, MAX_IMAGE_SIDE)
    if w * h >= 2**32:
        raise SceneError(f"{where}width, height: {w} x {h} is {w * h} pixels; at most 2^32 - 1")
    return w, h, integer(spp, "spp", where, 1, MAX_SPP), integer(seed, "seed", where, 0, MAX_SEED)


def output_path(value, field="output", where="") -> Path:
    """A path an image can be written to: a str or os.PathLike whose names fit NAME_MAX, in an
    existing directory, and not itself a directory."""
    if not isinstance(value, (str, os.PathLike)) or isinstance(value, bytes):
        raise SceneError(f"{where}{field}: expected a file path, got {_type_and_value(value)}")
    path = Path(value)
    text = os.fsencode(path)
    long_part = max((len(os.fsencode(p)) for p in path.parts), default=0)
    if not text or b"\0" in text or len(text) > PATH_MAX or long_part > NAME_MAX:
        raise SceneError(f"{where}{field}: expected a file path of at most {PATH_MAX} bytes and {NAME_MAX} a name, "
                         f"got {show(str(path), 120)}")
    parent = path.parent
    if not parent.is_dir():
        raise SceneError(f"{where}{field}: the directory {parent} does not exist")
    if path.is_dir():
        raise SceneError(f"{where}{field}: {path} is a directory")
    return path
