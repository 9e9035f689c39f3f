"""The scene cache: compiled scenes stored on disk by content hash, so that rendering
a scene compiled before (in any process) skips the BVH build and the packing.

* Where: ``TEXRAY_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/texray/scenes``, else
  ``~/.cache/texray/scenes``; one file per scene (texray.compile.cache_file).
* Key: texray.compile.scene_hash (every field the compiler reads, the compile
  options and texray's host code; not the camera).
* What: scenes whose compile took at least ``TEXRAY_CACHE_MIN_S`` seconds (default
  0.25): smaller ones compile faster than a file round trip is worth.
* Size: at most ``TEXRAY_CACHE_SIZE`` bytes (default 2 GiB; suffixes K, M, G), the least
  recently used entries removed after each store (a hit touches its file).
* In memory: the last ``TEXRAY_CACHE_MEMORY`` compiled scenes (default 2, 0: none) are also
  kept in the process, whatever their compile time, so that rendering an unchanged scene
  again (another camera, spp or size) neither compiles it nor reads its file: the scene is
  still hashed (that is how a change is seen), but textures hash once (their texels are
  read-only). ``forget()`` drops them.
* Off: ``TEXRAY_NO_CACHE=1``, ``render(..., cache=False)``, ``texray render --no-cache``.

A file that is truncated, corrupt or of another format is removed with a
CacheWarning and the scene compiled again; a cache that cannot be written warns and
the render goes on. Warnings the compile gave are stored with the entry and given
again on a hit.
"""
from __future__ import annotations

import builtins
import copy
import dataclasses
import os
import threading
import time
import warnings
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

from ..errors import CacheError, CacheWarning
from ..scene import Scene
from . import cache_file
from .cache_file import CacheFileError, Entry
from .scene import CompiledScene, compile_scene
from .scene_hash import Uncacheable, scene_key

ENV_DIR, ENV_SIZE, ENV_OFF, ENV_MIN = "TEXRAY_CACHE_DIR", "TEXRAY_CACHE_SIZE", "TEXRAY_NO_CACHE", "TEXRAY_CACHE_MIN_S"
ENV_MEMORY = "TEXRAY_CACHE_MEMORY"
DEFAULT_SIZE = 2 * 2**30
DEFAULT_MIN_S = 0.25
DEFAULT_MEMORY = 2              # as texray.renderer.uploads.KEEP: the scenes whose buffers stay on the device
STALE_TEMP_S = 3600.0           # a temporary file this old is a writer's that died
STATUSES = ("kept", "hit", "miss", "stored", "off")
_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}
_registries = {}                # warn_explicit's once-per-location registries, by file
_kept = OrderedDict()           # key -> (CompiledScene, warning records), least recently used first
_kept_lock = threading.Lock()


@dataclass(frozen=True)
class Settings:
    directory: Path
    size: int               # bytes
    min_seconds: float      # compile time from which a scene is stored
    enabled: bool
    memory: int = DEFAULT_MEMORY    # compiled scenes kept in the process


def settings(environ=None) -> Settings:
    """The cache's settings from the environment (``os.environ`` by default); CacheError
    names a variable with a bad value."""
    env = os.environ if environ is None else environ
    if env.get(ENV_DIR):
        directory = Path(env[ENV_DIR]).expanduser()
    else:
        base = env.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        directory = Path(base) / "texray" / "scenes"
    return Settings(directory, _size(env.get(ENV_SIZE)), _seconds(env.get(ENV_MIN)), not _off(env),
                    _count(env.get(ENV_MEMORY)))


def _off(env) -> bool:
    """TEXRAY_NO_CACHE: 1 (true, yes, on) turns the cache off; unset, empty or 0 (false, no, off) not."""
    text = env.get(ENV_OFF, "").strip().lower()
    if text not in ("", "0", "1", "false", "true", "no", "yes", "off", "on"):
        raise CacheError(f"{ENV_OFF}: expected 1 (no scene cache) or 0, got {env[ENV_OFF]!r}")
    return text in ("1", "true", "yes", "on")


def _size(text):
    if text is None or not text.strip():
        return DEFAULT_SIZE
    t = text.strip().upper().removesuffix("B").removesuffix("I")
    unit = t[-1:] if t[-1:] in _UNITS else ""
    try:
        value = float(t[:-1] if unit else t) * _UNITS[unit]
    except ValueError:
        value = -1.0
    if not 0 <= value < 2**63:
        raise CacheError(f"{ENV_SIZE}: expected a size in bytes (e.g. 2000000000, 500M, 2G), got {text!r}")
    return int(value)


def _count(text):
    if text is None or not text.strip():
        return DEFAULT_MEMORY
    t = text.strip()
    if not (t.isdigit() and int(t) < 2**31):
        raise CacheError(f"{ENV_MEMORY}: expected a number of scenes >= 0 (0: none kept in memory), got {text!r}")
    return int(t)


def _seconds(text):
    if text is None or not text.strip():
        return DEFAULT_MIN_S
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0 <= value < float("inf"):
        raise CacheError(f"{ENV_MIN}: expected a number of seconds >= 0, got {text!r}")
    return value


def compiled(scene, shadows=True, texture_filter=None, enabled=True) -> tuple[CompiledScene, dict]:
    """``compile_scene(scene, shadows, texture_filter)`` through the cache: (the compiled
    scene, with the scene's current camera; stats). ``stats["scene_cache"]`` is "kept" (held
    in memory since a render before), "hit"
    (read from the cache), "stored" (compiled and stored), "miss" (compiled, not stored:
    too quick to compile, too big for the cache, or a scene the hash cannot vouch for),
    or "off" (``enabled`` False or TEXRAY_NO_CACHE); ``scene_cache_hash_s``,
    ``scene_cache_load_s`` and ``scene_cache_store_s`` time the cache's own work."""
    stats = off_stats()
    conf = settings() if enabled and not _off(os.environ) else None     # off: no other setting is read
    if conf is None or not conf.enabled or not isinstance(scene, Scene):
        return compile_scene(scene, shadows=shadows, texture_filter=texture_filter), stats
    t0 = time.perf_counter()
    try:
        key = scene_key(scene, shadows=shadows, texture_filter=texture_filter)
    except Uncacheable:
        key = None
    t1 = time.perf_counter()
    stats["scene_cache_hash_s"] = t1 - t0
    kept = _take(key) if key is not None and conf.memory > 0 else None
    if kept is not None:
        cs, records = kept
        stats["scene_cache"] = "kept"
    else:
        path = None if key is None else conf.directory / (key + cache_file.SUFFIX)
        hit = None if path is None else _load(path, key)
        stats["scene_cache_load_s"] = time.perf_counter() - t1
        if hit is not None:
            cs, meta = hit
            records = meta.get("warnings", ())
            _keep(key, cs, records, conf.memory)
            stats["scene_cache"] = "hit"
    if stats["scene_cache"] in ("kept", "hit"):
        scene.validate()                       # the camera is not in the key: check it as compile_scene does
        cs.camera = copy.deepcopy(scene.camera)
        cs.source_key = key
        _replay(records)
        return cs, stats
    t2 = time.perf_counter()
    cs, caught = _compile_recording(scene, shadows, texture_filter)
    cs.source_key = key
    t3 = time.perf_counter()
    stats["scene_cache"] = "miss"
    if path is not None and t3 - t2 >= conf.min_seconds:
        if store(path, key, cs, caught, t3 - t2, conf.size):
            stats["scene_cache"] = "stored"
        stats["scene_cache_store_s"] = time.perf_counter() - t3
    if key is not None:
        records = [_record(w) for w in caught]
        if all(r is not None for r in records):      # as store(): warnings that can be given again
            _keep(key, cs, records, conf.memory)
    return cs, stats


def _take(key):
    """(a copy of the compiled scene kept under ``key``, its warning records), or None. The
    copy shares the arrays (no caller writes into them) and has fields of its own (callers
    set features, objects and the camera)."""
    with _kept_lock:
        got = _kept.get(key)
        if got is None:
            return None
        _kept.move_to_end(key)
    return dataclasses.replace(got[0]), got[1]


def _keep(key, cs, records, limit):
    """Keep a copy of ``cs`` under ``key``, the ``limit`` most recent only."""
    with _kept_lock:
        _kept[key] = (dataclasses.replace(cs), list(records))
        _kept.move_to_end(key)
        while len(_kept) > limit:
            _kept.popitem(last=False)


def forget() -> int:
    """Drop the compiled scenes kept in memory; how many there were."""
    with _kept_lock:
        n = len(_kept)
        _kept.clear()
    return n


def off_stats() -> dict:
    """The stats of a render that did not use the cache."""
    return {"scene_cache": "off", "scene_cache_hash_s": 0.0, "scene_cache_load_s": 0.0, "scene_cache_store_s": 0.0}


def store(path: Path, key: str, cs: CompiledScene, caught, compile_s, limit) -> bool:
    """Write the entry (unless it alone exceeds ``limit`` bytes, or its warnings cannot be
    stored), then evict the least recently used entries beyond ``limit``. False when
    nothing was stored; file-system errors are warned about, never raised."""
    records = [_record(w) for w in caught]
    if any(r is None for r in records):
        return False
    try:
        entry = Entry(cs)
    except CacheFileError:
        return False
    if entry.nbytes > limit:
        return False
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        cache_file.write(path, key, entry, {"warnings": records, "compile_s": compile_s})
        evict(path.parent, limit, keep=path)
    except OSError as e:
        warnings.warn(f"scene cache: cannot store in {path.parent} ({e}); the render goes on without it",
                      CacheWarning, stacklevel=5)
        return False
    return True


def _load(path, key):
    """(cs, meta) of the entry at ``path``, or None (absent; unreadable or bad: warned, and a
    bad file removed)."""
    try:
        hit = cache_file.read(path, key)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except CacheFileError as e:
        warnings.warn(f"scene cache: {path}: {e}; removed, the scene is compiled again", CacheWarning, stacklevel=5)
        _remove_if_same(path, e.stat)
        return None
    except OSError as e:
        warnings.warn(f"scene cache: cannot read {path} ({e}); the scene is compiled again", CacheWarning,
                      stacklevel=5)
        return None
    try:
        os.utime(path)                  # recently used: evicted last
    except OSError:
        pass
    return hit


def _remove_if_same(path, st):
    """Remove ``path`` if it is still the file that was read (another process may have
    stored a good one since)."""
    try:
        now = os.stat(path)
        if st is None or (now.st_ino, now.st_dev) == (st.st_ino, st.st_dev):
            os.unlink(path)
    except OSError:
        pass


def _compile_recording(scene, shadows, texture_filter):
    """compile_scene with its warnings recorded, then given again as they were (also when it
    raises), so that they can be stored with the entry."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            cs = compile_scene(scene, shadows=shadows, texture_filter=texture_filter)
        finally:
            recorded = list(caught)
    for w in recorded:
        _warn(w.category, str(w.message), w.filename, w.lineno)
    return cs, recorded


def _record(w):
    """[category name, message, filename, line] of a caught warning; None for a category that
    cannot be named again in another process (not a builtin warning class)."""
    name = w.category.__name__
    if getattr(builtins, name, None) is not w.category:
        return None
    return [name, str(w.message), str(w.filename), int(w.lineno)]


def _replay(records):
    for name, message, filename, lineno in records:
        _warn(getattr(builtins, name), message, filename, lineno)


def _warn(category, message, filename, lineno):
    warnings.warn_explicit(message, category, filename, lineno, registry=_registries.setdefault(filename, {}))


# --- the folder -----------------------------------------------------------------------
def entries(directory: Path):
    """[(mtime, bytes, path)] of the cache's entries, oldest first."""
    out = []
    try:
        with os.scandir(directory) as it:
            for e in it:
                if e.name.endswith(cache_file.SUFFIX) and not e.name.startswith("."):
                    try:
                        st = e.stat()
                    except OSError:
                        continue
                    out.append((st.st_mtime, st.st_size, Path(e.path)))
    except FileNotFoundError:
        return []
    return sorted(out)


def evict(directory: Path, limit: int, keep=None) -> int:
    """Remove the least recently used entries until the rest take at most ``limit`` bytes
    (``keep`` stays), and temporary files of writers that died; returns the bytes removed."""
    removed = 0
    _remove_stale_temps(directory, STALE_TEMP_S)
    found = entries(directory)
    total = sum(size for _, size, _ in found)
    for _, size, path in found:
        if total <= limit:
            break
        if path == keep:
            continue
        try:
            os.unlink(path)
            removed += size
        except FileNotFoundError:       # another process evicted it
            pass
        except OSError:
            continue
        total -= size
    return removed


def _remove_stale_temps(directory, age):
    now = time.time()
    try:
        with os.scandir(directory) as it:
            for e in it:
                if e.name.startswith(".") and e.name.endswith(cache_file.TEMP_SUFFIX):
                    try:
                        if now - e.stat().st_mtime >= age:
                            os.unlink(e.path)
                    except OSError:
                        pass
    except FileNotFoundError:
        pass


def info(environ=None) -> dict:
    """The cache's folder, whether it is on, its entries and bytes, and its bound."""
    conf = settings(environ)
    found = entries(conf.directory)
    return {"directory": str(conf.directory), "enabled": conf.enabled, "entries": len(found),
            "bytes": sum(s for _, s, _ in found), "size_limit": conf.size, "min_compile_s": conf.min_seconds}


def clear(environ=None) -> tuple[int, int]:
    """Remove every entry (and temporary file), and forget the scenes kept in memory; (entries
    removed, bytes)."""
    conf = settings(environ)
    forget()
    _remove_stale_temps(conf.directory, 0.0)
    n = size = 0
    for _, s, path in entries(conf.directory):
        try:
            os.unlink(path)
            n, size = n + 1, size + s
        except OSError:
            pass
    return n, size
