"""The scene cache (texray.compile.cache, texray.compile.cache_file), host side: a hit gives
the compiled scene that was stored, bad files are removed and rebuilt, concurrent writers
are safe, the size bound evicts the least recently used entries, settings are checked."""
import dataclasses
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import texray as tx
from cache_scenes import edited, rich_scene
from texray.compile import cache, cache_file, compile_scene
from texray.compile.cache_file import CacheFileError, Entry
from texray.compile.scene_hash import scene_key
from texray.errors import CacheError, CacheWarning, SceneError

ROOT = Path(__file__).resolve().parents[2]


def assert_same_compiled(a, b, timed=False):
    """Every field of two CompiledScenes equal: arrays in dtype, shape and bytes; the BVH's
    build time too when ``timed`` (b is a's stored copy), else not (two builds). Not
    ``source_key``: the cache's key of the scene, which compile_scene alone does not know."""
    for f in dataclasses.fields(a):
        if f.name != "source_key":
            _assert_same(getattr(a, f.name), getattr(b, f.name), f.name, timed)


def _assert_same(x, y, where, timed):
    if (where == "bvh.build_seconds" or where.startswith("steps_s[")) and not timed:   # timings of two builds
        assert type(x) is type(y) is float
    elif isinstance(x, np.ndarray):
        assert isinstance(y, np.ndarray) and x.dtype == y.dtype and x.shape == y.shape, where
        assert x.tobytes() == y.tobytes(), where
    elif dataclasses.is_dataclass(x):
        assert type(x) is type(y), where
        for f in dataclasses.fields(x):
            _assert_same(getattr(x, f.name), getattr(y, f.name), f"{where}.{f.name}", timed)
    elif isinstance(x, dict):
        assert x.keys() == y.keys(), where
        for k in x:
            _assert_same(x[k], y[k], f"{where}[{k}]", timed)
    else:
        assert type(x) is type(y) and x == y, where


def entry_path(folder, scene, shadows=True, texture_filter=None):
    return folder / (scene_key(scene, shadows=shadows, texture_filter=texture_filter) + cache_file.SUFFIX)


def test_a_hit_is_the_compiled_scene_that_was_stored(cache_env):
    ref = compile_scene(rich_scene())
    cs, st = cache.compiled(rich_scene())
    assert st["scene_cache"] == "stored" and st["scene_cache_store_s"] > 0
    assert_same_compiled(cs, ref)
    assert ref.source_key is None and cs.source_key == scene_key(rich_scene(), shadows=True, texture_filter=None)
    files = list(cache_env.iterdir())
    assert [p.suffix for p in files] == [".txscene"] and files[0].stat().st_size > cs.texels.nbytes
    hit, st = cache.compiled(rich_scene())
    assert st["scene_cache"] == "hit" and st["scene_cache_hash_s"] > 0 and st["scene_cache_load_s"] > 0
    assert_same_compiled(hit, cs, timed=True)
    assert_same_compiled(hit, ref)
    assert not hit.tri_verts.flags.writeable            # views of the file's mapping, not copies
    same = rich_scene()                                  # one scene rendered twice in one process
    assert cache.compiled(same)[1]["scene_cache"] == "hit"
    assert cache.compiled(same)[1]["scene_cache"] == "hit"


def test_a_hit_takes_the_scenes_current_camera_and_checks_it(cache_env):
    cache.compiled(rich_scene())
    s = rich_scene()
    s.camera = tx.Camera(eye=(3, 1, 2), look_at=(0, 0.5, 0), fov_y=25)
    hit, st = cache.compiled(s)
    assert st["scene_cache"] == "hit"
    assert hit.camera == s.camera and hit.camera is not s.camera
    s.camera.fov_y = 0.0                                 # as compile_scene: the same error
    with pytest.raises(SceneError) as miss_error:
        compile_scene(s)
    with pytest.raises(SceneError) as hit_error:
        cache.compiled(s)
    assert str(hit_error.value) == str(miss_error.value) and "fov_y" in str(hit_error.value)


def test_a_changed_scene_misses_and_options_are_entries_of_their_own(cache_env):
    cache.compiled(rich_scene())
    s = rich_scene()
    m = s.objects[0].material
    m.diffuse = edited(m.diffuse, (0, 0, 1), 0.125)             # one texel
    cs, st = cache.compiled(s)
    assert st["scene_cache"] == "stored"
    assert_same_compiled(cs, compile_scene(s))
    _, st = cache.compiled(rich_scene(), shadows=False)
    assert st["scene_cache"] == "stored"
    cs, st = cache.compiled(rich_scene(), texture_filter="nearest")
    assert st["scene_cache"] == "stored" and not cs.features.filter_bilinear
    assert len(list(cache_env.iterdir())) == 4
    for opts in ({}, {"shadows": False}, {"texture_filter": "nearest"}):
        assert cache.compiled(rich_scene(), **opts)[1]["scene_cache"] == "hit"


def test_off_by_argument_and_by_environment(cache_env, monkeypatch):
    cs, st = cache.compiled(rich_scene(), enabled=False)
    assert st == cache.off_stats() and st["scene_cache"] == "off"
    monkeypatch.setenv("TEXRAY_NO_CACHE", "1")
    monkeypatch.setenv("TEXRAY_CACHE_SIZE", "not read when off")
    assert cache.compiled(rich_scene())[1]["scene_cache"] == "off"
    assert not cache_env.exists()
    monkeypatch.setenv("TEXRAY_NO_CACHE", "0")
    with pytest.raises(CacheError, match="TEXRAY_CACHE_SIZE"):
        cache.compiled(rich_scene())


def test_quick_compiles_uncacheable_scenes_and_oversized_entries_are_not_stored(cache_env, monkeypatch):
    monkeypatch.setenv("TEXRAY_CACHE_MIN_S", "1000")
    assert cache.compiled(rich_scene())[1]["scene_cache"] == "miss"
    monkeypatch.setenv("TEXRAY_CACHE_MIN_S", "0")

    s = rich_scene()
    s.objects[0].material.diffuse._pixels.note = object()     # not a value the hash can vouch for
    assert cache.compiled(s)[1]["scene_cache"] == "miss"
    monkeypatch.setenv("TEXRAY_CACHE_SIZE", "1000")
    assert cache.compiled(rich_scene())[1]["scene_cache"] == "miss"
    assert not cache_env.exists() or not list(cache_env.iterdir())


def test_warnings_of_the_compile_are_given_again_on_a_hit(cache_env):
    def scene():
        p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], float)
        f = np.array([[0, 1, 2], [0, 1, 3]])               # the second has no area
        return tx.Scene(lights=[tx.PointLight((0, 0, 5))], objects=[tx.Mesh(p, f, name="flat")])
    with pytest.warns(UserWarning, match="flat: 1 zero-area triangle"):
        assert cache.compiled(scene())[1]["scene_cache"] == "stored"
    with pytest.warns(UserWarning, match="flat: 1 zero-area triangle"):
        assert cache.compiled(scene())[1]["scene_cache"] == "hit"


def _truncate(p):
    p.write_bytes(p.read_bytes()[:-100])


def _flip(offset):
    def flip(p):
        b = bytearray(p.read_bytes())
        i = offset if offset >= 0 else len(b) + offset
        b[i] ^= 0x10
        p.write_bytes(bytes(b))
    return flip


def _flip_array(name):
    """Flip a bit in the middle of one array's bytes (found from the file's header)."""
    def flip(p):
        b = bytearray(p.read_bytes())
        length = int.from_bytes(b[16:24], "little")
        header = json.loads(b[24:24 + length])
        a = next(a for a in header["arrays"] if a["name"] == name)
        start = (24 + length + cache_file.ALIGN - 1) // cache_file.ALIGN * cache_file.ALIGN
        b[start + a["offset"] + a["nbytes"] // 2] ^= 0x04
        p.write_bytes(bytes(b))
    return flip


def _other_format(p):
    b = bytearray(p.read_bytes())
    b[8:12] = (cache_file.FORMAT + 1).to_bytes(4, "little")
    p.write_bytes(bytes(b))


BAD = {"truncated": _truncate, "empty": lambda p: p.write_bytes(b""), "garbage": lambda p: p.write_bytes(b"x" * 5000),
       "bvh bit": _flip_array("nodes"), "texel bit": _flip_array("texels"), "header bit": _flip(40),
       "other format": _other_format}


@pytest.mark.parametrize("damage", BAD)
def test_a_bad_file_is_removed_with_a_warning_and_the_scene_compiled_again(cache_env, damage):
    ref, _ = cache.compiled(rich_scene())
    path = entry_path(cache_env, rich_scene())
    BAD[damage](path)
    with pytest.raises(CacheFileError):
        cache_file.read(path, scene_key(rich_scene(), shadows=True, texture_filter=None))
    with pytest.warns(CacheWarning, match="removed, the scene is compiled again"):
        cs, st = cache.compiled(rich_scene())
    assert st["scene_cache"] == "stored"                 # rebuilt, and stored whole again
    assert_same_compiled(cs, compile_scene(rich_scene()))
    assert cache.compiled(rich_scene())[1]["scene_cache"] == "hit"


def test_a_file_under_another_key_is_not_read(cache_env):
    cache.compiled(rich_scene())
    other = rich_scene()
    other.ambient = (0.5, 0.5, 0.5)
    os.replace(entry_path(cache_env, rich_scene()), entry_path(cache_env, other))
    with pytest.warns(CacheWarning, match="holds key"):
        cs, st = cache.compiled(other)
    assert st["scene_cache"] == "stored"
    assert_same_compiled(cs, compile_scene(other))


def test_an_unwritable_cache_warns_and_the_compile_goes_on(cache_env, monkeypatch, tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("TEXRAY_CACHE_DIR", str(blocker / "scenes"))
    with pytest.warns(CacheWarning, match="cannot store"):
        cs, st = cache.compiled(rich_scene())
    assert st["scene_cache"] == "miss"
    assert_same_compiled(cs, compile_scene(rich_scene()))


def test_concurrent_writers_of_one_key_and_a_reader(cache_env):
    """Threads storing the same entry over and over while another reads: every read sees a
    whole entry or none, and no temporary file is left."""
    s = rich_scene()
    k = scene_key(s, shadows=True, texture_filter=None)
    entry = Entry(compile_scene(s))
    cache_env.mkdir()
    path = cache_env / (k + cache_file.SUFFIX)
    done, errors, reads = threading.Event(), [], []

    def write():
        try:
            for _ in range(15):
                cache_file.write(path, k, entry, {"warnings": []})
        except Exception as e:          # noqa: BLE001 - reported below
            errors.append(e)

    def read():
        while not done.is_set():
            try:
                cs, _ = cache_file.read(path, k)
                reads.append(len(cs.tri_verts))
            except FileNotFoundError:
                pass
            except Exception as e:      # noqa: BLE001
                errors.append(e)

    writers = [threading.Thread(target=write) for _ in range(3)]
    reader = threading.Thread(target=read)
    reader.start()
    for t in writers:
        t.start()
    for t in writers:
        t.join()
    done.set()
    reader.join()
    assert not errors, errors
    assert reads and set(reads) == {len(entry.arrays["tri_verts"])}
    assert [p.name for p in cache_env.iterdir()] == [path.name]


WRITER = """
import sys
sys.path[:0] = [{tests!r}, {pyhost!r}]
from cache_scenes import rich_scene
from texray.compile import cache_file, compile_scene
from texray.compile.cache_file import Entry
from texray.compile.scene_hash import scene_key
from pathlib import Path
s = rich_scene()
k = scene_key(s, shadows=True, texture_filter=None)
e = Entry(compile_scene(s))
p = Path({folder!r}) / (k + cache_file.SUFFIX)
for _ in range(20):
    cache_file.write(p, k, e, {{"warnings": []}})
print(k)
"""


def test_two_processes_storing_the_same_key_at_once(cache_env):
    cache_env.mkdir()
    # the writers import the texray this test imports (a source tree's, or an installed wheel's as in CI)
    pkg = str(Path(tx.__file__).resolve().parents[1])
    code = WRITER.format(tests=str(ROOT / "tests"), pyhost=pkg, folder=str(cache_env))
    procs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    seen = 0
    while any(p.poll() is None for p in procs):
        for path in cache_env.glob("*" + cache_file.SUFFIX):
            try:
                cache_file.read(path, path.stem)
                seen += 1
            except FileNotFoundError:
                pass
    outs = [p.communicate() for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    keys = {o.strip() for o, _ in outs}
    assert keys == {scene_key(rich_scene(), shadows=True, texture_filter=None)}
    assert [p.name for p in cache_env.iterdir()] == [keys.pop() + cache_file.SUFFIX]
    hit, st = cache.compiled(rich_scene())
    assert st["scene_cache"] == "hit"
    assert_same_compiled(hit, compile_scene(rich_scene()))


def _variant(i):
    s = rich_scene()
    s.lights[0].position = (2.0, 4.0, 3.0 + i)
    return s


def test_the_size_bound_evicts_the_least_recently_used(cache_env, monkeypatch):
    cache.compiled(_variant(0))
    size = entry_path(cache_env, _variant(0)).stat().st_size
    monkeypatch.setenv("TEXRAY_CACHE_SIZE", str(int(2.5 * size)))
    cache.compiled(_variant(1))
    paths = [entry_path(cache_env, _variant(i)) for i in range(3)]
    os.utime(paths[0], (time.time() - 100, time.time() - 100))
    os.utime(paths[1], (time.time() - 50, time.time() - 50))
    assert cache.compiled(_variant(0))[1]["scene_cache"] == "hit"       # touched: now the most recent
    assert cache.compiled(_variant(2))[1]["scene_cache"] == "stored"    # 3 entries > 2.5: the oldest goes
    assert [p.exists() for p in paths] == [True, False, True]
    assert cache.info()["entries"] == 2 and cache.info()["bytes"] <= 2.5 * size


def test_eviction_removes_temporary_files_of_dead_writers_only(cache_env):
    cache_env.mkdir()
    old, new = cache_env / ".abc-1-x.tmp", cache_env / ".abc-2-y.tmp"
    old.write_bytes(b"1")
    new.write_bytes(b"2")
    os.utime(old, (time.time() - 2 * cache.STALE_TEMP_S,) * 2)
    cache.evict(cache_env, 10**9)
    assert not old.exists() and new.exists()


def test_info_and_clear(cache_env):
    cache.compiled(_variant(0))
    cache.compiled(_variant(1))
    i = cache.info()
    assert i["directory"] == str(cache_env) and i["entries"] == 2 and i["bytes"] > 0 and i["enabled"]
    assert i["size_limit"] == cache.DEFAULT_SIZE and i["min_compile_s"] == 0.0
    n, size = cache.clear()
    assert (n, size) == (2, i["bytes"]) and cache.info()["entries"] == 0


def test_a_scene_rendered_again_is_kept_in_memory(cache_env, monkeypatch):
    """The last TEXRAY_CACHE_MEMORY compiled scenes stay in the process: an unchanged scene is
    neither compiled nor read again, each caller gets fields of its own and the scene's
    current camera; a changed scene is compiled again."""
    monkeypatch.setenv("TEXRAY_CACHE_MEMORY", "2")
    monkeypatch.setenv("TEXRAY_CACHE_MIN_S", "1000")          # nothing stored: memory alone
    s = rich_scene()
    first, st = cache.compiled(s)
    assert st["scene_cache"] == "miss" and not list(cache_env.glob("*"))
    first.features = dataclasses.replace(first.features, aovs=True)     # as render() does to its copy
    s.camera = tx.Camera(eye=(3, 1, 2), look_at=(0, 0.5, 0), fov_y=25)
    kept, st = cache.compiled(s)
    assert st["scene_cache"] == "kept" and st["scene_cache_load_s"] == 0.0
    assert kept is not first and kept.nodes is first.nodes and kept.texels is first.texels
    assert not kept.features.aovs and kept.camera == s.camera and kept.camera is not s.camera
    assert kept.source_key == first.source_key
    assert_same_compiled(kept, compile_scene(s))
    assert cache.compiled(rich_scene())[1]["scene_cache"] == "kept"      # an equal scene: the same key
    s.objects[0].positions[0, 1] += 0.5                    # an edit in place of a mesh's array
    changed, st = cache.compiled(s)
    assert st["scene_cache"] == "miss"
    assert_same_compiled(changed, compile_scene(s))
    m = s.objects[2].material
    m.diffuse = edited(m.diffuse, (0, 0, 0), 0.5)          # another texture
    assert cache.compiled(s)[1]["scene_cache"] == "miss"
    # the bound: 2 kept, the least recently used dropped first
    assert cache.compiled(rich_scene())[1]["scene_cache"] == "miss"
    assert cache.compiled(s)[1]["scene_cache"] == "kept"
    monkeypatch.setenv("TEXRAY_CACHE_MEMORY", "0")
    assert cache.compiled(s)[1]["scene_cache"] == "miss"
    monkeypatch.setenv("TEXRAY_CACHE_MEMORY", "1")
    cache.compiled(s)
    assert cache.compiled(s)[1]["scene_cache"] == "kept" and cache.forget() == 1
    assert cache.compiled(s)[1]["scene_cache"] == "miss"
    assert cache.compiled(s, shadows=False)[1]["scene_cache"] == "miss"   # options are part of the key
    cache.clear()
    assert cache.compiled(s, shadows=False)[1]["scene_cache"] == "miss"   # clear() forgets too


def test_a_kept_scene_gives_its_warnings_again(cache_env, monkeypatch):
    monkeypatch.setenv("TEXRAY_CACHE_MEMORY", "2")
    monkeypatch.setenv("TEXRAY_CACHE_MIN_S", "1000")
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], float)
    s = tx.Scene(lights=[tx.PointLight((0, 0, 5))], objects=[tx.Mesh(p, np.array([[0, 1, 2], [0, 1, 3]]), name="flat")])
    with pytest.warns(UserWarning, match="flat: 1 zero-area triangle"):
        assert cache.compiled(s)[1]["scene_cache"] == "miss"
    with pytest.warns(UserWarning, match="flat: 1 zero-area triangle"):
        assert cache.compiled(s)[1]["scene_cache"] == "kept"


def test_a_disk_hit_is_kept_and_a_texture_is_hashed_once(cache_env, monkeypatch):
    cache.compiled(rich_scene())                              # stored
    monkeypatch.setenv("TEXRAY_CACHE_MEMORY", "2")
    s = rich_scene()
    assert cache.compiled(s)[1]["scene_cache"] == "hit"
    for f in cache_env.glob("*"):
        f.unlink()
    assert cache.compiled(s)[1]["scene_cache"] == "kept"      # not read from the folder
    # texture pixels: walked once into a digest kept on them; equal pixels, equal digests
    t = s.objects[0].material.diffuse
    assert t._pixels._digest is not None
    other = rich_scene()
    assert other.objects[0].material.diffuse._pixels._digest is None
    scene_key(other)
    assert t._pixels._digest == other.objects[0].material.diffuse._pixels._digest
    key = scene_key(s)
    t._pixels._digest = b"x" * 32                             # a stale digest would be used...
    assert scene_key(s) != key                                # ...which is why the texels are read-only
    with pytest.raises(ValueError, match="read-only"):
        t.raw[0, 0, 0] = 0.0


def test_settings(tmp_path):
    home = os.path.expanduser("~")
    assert cache.settings({}).directory == Path(home) / ".cache" / "texray" / "scenes"
    assert cache.settings({"XDG_CACHE_HOME": "/x"}).directory == Path("/x/texray/scenes")
    assert cache.settings({"XDG_CACHE_HOME": "/x", "TEXRAY_CACHE_DIR": "/y"}).directory == Path("/y")
    assert cache.settings({}).size == 2 * 2**30 and cache.settings({}).min_seconds == 0.25
    sizes = {"123": 123, "500M": 500 * 2**20, "2G": 2 * 2**30, "1.5gib": int(1.5 * 2**30), "64k": 65536, "0": 0}
    for text, n in sizes.items():
        assert cache.settings({"TEXRAY_CACHE_SIZE": text}).size == n
    assert cache.settings({}).memory == 2 and cache.settings({"TEXRAY_CACHE_MEMORY": "0"}).memory == 0
    assert cache.settings({"TEXRAY_NO_CACHE": "1"}).enabled is False
    assert cache.settings({"TEXRAY_NO_CACHE": "0"}).enabled is True
    for env, match in (({"TEXRAY_CACHE_SIZE": "lots"}, "TEXRAY_CACHE_SIZE: expected a size"),
                       ({"TEXRAY_CACHE_SIZE": "-1"}, "TEXRAY_CACHE_SIZE"),
                       ({"TEXRAY_CACHE_MIN_S": "soon"}, "TEXRAY_CACHE_MIN_S"),
                       ({"TEXRAY_NO_CACHE": "maybe"}, "TEXRAY_NO_CACHE"),
                       ({"TEXRAY_CACHE_MEMORY": "-1"}, "TEXRAY_CACHE_MEMORY: expected a number of scenes"),
                       ({"TEXRAY_CACHE_MEMORY": "two"}, "TEXRAY_CACHE_MEMORY")):
        with pytest.raises(CacheError, match=match):
            cache.settings(env)


def test_every_field_of_a_compiled_scene_survives_the_file(tmp_path):
    """The file format against every CompiledScene field (a new field of an unstorable type
    fails here, not silently)."""
    s = rich_scene()
    cs = compile_scene(s)
    k = scene_key(s, shadows=True, texture_filter=None)
    path = tmp_path / (k + cache_file.SUFFIX)
    size = cache_file.write(path, k, Entry(cs), {"warnings": [], "note": "x"})
    assert size == path.stat().st_size
    back, meta = cache_file.read(path, k)
    assert meta == {"warnings": [], "note": "x"}
    assert back.camera is None
    back.camera = cs.camera
    assert_same_compiled(back, cs, timed=True)
