"""Many frames: a camera path or turntable over one scene, or a scene that changes
from frame to frame (instances that move), locally or on a Dask cluster."""
from __future__ import annotations

import time
from pathlib import PurePath

from ..compile import CompiledScene, cache as scene_cache
from ..errors import SceneError
from ..scene import Camera, Scene
from .. import validate as V
from . import distributed
from .image import Image
from .render import render, setup

# render()'s keywords that render_frames passes on (sink, rows and compiled are its own business)
OPTIONS = ("device", "seed", "jitter", "shadows", "aovs", "specialize", "local_size", "memory_limit", "tile_pixels",
           "texture_filter", "pipeline", "adaptive", "cache", "light_sampling")


def render_frames(scenes, cameras=None, width=640, height=480, spp=1, *, client=None, paths=None, progress=None,
                  **options):
    """Render one frame per camera, or per scene, in order.

    scenes: a Scene (or CompiledScene) rendered from each of ``cameras``, or a list
    of Scenes, one per frame (each its own camera, unless ``cameras`` gives one per
    frame). A scene is compiled once however many frames show it; the scenes of a
    list are compiled in turn, and an instanced mesh that only moved between them
    keeps its BLAS (only the top level is rebuilt: ``stats["blas_reused"]``).
    client: a dask.distributed.Client or a scheduler address: every frame's bands are
    submitted at once, so the workers never wait between frames (the same frames, bit
    for bit, as without it). paths: None (return the Images) or one output path per
    frame, or a pattern with one ``{}`` field (``"out/frame_{:04d}.png"``) given the
    frame's index: each frame is written (Image.save) when it is done and not kept,
    and the frames' stats are returned instead. progress: callable(fraction of the
    frames done). The other keywords are :func:`texray.render`'s.
    """
    bad = sorted(set(options) - set(OPTIONS))
    if bad:
        raise SceneError(f"render_frames: unknown option {bad[0]!r} (known: {', '.join(OPTIONS)})")
    frames = _frames(scenes, cameras)
    paths = _paths(paths, len(frames))
    V.callable_or_none(progress, "progress", "render_frames: ")
    width, height, spp, _ = V.render_settings(width, height, spp, options.get("seed", 0))
    dask = None if client is None else distributed.connect(client, "render_frames: client")
    out, compiled = [], {}
    per_frame = {k: v for k, v in options.items() if k not in ("texture_filter", "cache")}   # compile's own
    if dask is None:
        for i, (scene, camera) in enumerate(frames):
            t0 = time.perf_counter()
            cs, cache_stats = _compiled_once(compiled, scene, options)
            compile_s = time.perf_counter() - t0
            image = render(scene if isinstance(scene, Scene) else None, width, height, spp, compiled=cs,
                           camera=camera, **per_frame)
            image.stats.update(cache_stats, scene_compile_s=image.stats["scene_compile_s"] + compile_s)
            out.append(_finish(image, paths, i))
            if progress is not None:
                progress((i + 1) / len(frames))
        return out
    pending = []
    for scene, camera in frames:
        t0 = time.perf_counter()
        cs, cache_stats = _compiled_once(compiled, scene, options)
        compile_s = time.perf_counter() - t0
        s = setup(scene if isinstance(scene, Scene) else None, width, height, spp, compiled=cs, camera=camera,
                  **per_frame)
        s.stats.update(cache_stats, scene_compile_s=s.stats["scene_compile_s"] + compile_s)
        pending.append((distributed.submit_bands(dask, s.cs, s.camera, width, height, spp, None, s.options),
                        s.stats))
    for i, (bands, stats) in enumerate(pending):
        got = bands.collect()
        stats.update(got.stats)
        out.append(_finish(Image(rgb=got.rgb, aov=got.aov, stats=stats), paths, i))
        if progress is not None:
            progress((i + 1) / len(frames))
    return out


def _frames(scenes, cameras):
    """[(scene, camera)] per frame."""
    if isinstance(scenes, (Scene, CompiledScene)):
        if cameras is None:
            raise SceneError("render_frames: cameras: expected a list of texray.Camera for one scene, got None")
        scenes = [scenes] * _length(cameras, "cameras")
    elif isinstance(scenes, (list, tuple)):
        for i, s in enumerate(scenes):
            if not isinstance(s, (Scene, CompiledScene)):
                raise SceneError(f"render_frames: scenes[{i}]: expected a texray.Scene, got {V.show(s)}")
        if cameras is not None and _length(cameras, "cameras") != len(scenes):
            raise SceneError(f"render_frames: cameras: {len(cameras)} cameras for {len(scenes)} scenes; "
                             "give one per scene, or none")
    else:
        raise SceneError(f"render_frames: scenes: expected a texray.Scene or a list of them, got {V.show(scenes)}")
    if not scenes:
        raise SceneError("render_frames: no frames: the list of scenes or cameras is empty")
    if cameras is None:
        cameras = [s.camera for s in scenes]
    for i, c in enumerate(cameras):
        if not isinstance(c, Camera):
            raise SceneError(f"render_frames: cameras[{i}]: expected a texray.Camera, got {V.show(c)}")
    return list(zip(scenes, cameras))


def _length(seq, name):
    if not isinstance(seq, (list, tuple)):
        raise SceneError(f"render_frames: {name}: expected a list, got {V.show(seq)}")
    return len(seq)


def _paths(paths, n):
    """One path per frame, or None."""
    if paths is None:
        return None
    if isinstance(paths, (str, PurePath)):
        text = str(paths)
        if "{" not in text:
            raise SceneError(f"render_frames: paths: a single path {text!r} for {n} frames; give a list or a "
                             "pattern with a {} field, e.g. 'frame_{:04d}.png'")
        try:
            return [text.format(i) for i in range(n)]
        except (IndexError, KeyError, ValueError) as e:
            raise SceneError(f"render_frames: paths: bad pattern {text!r}: {e}") from None
    if not isinstance(paths, (list, tuple)) or len(paths) != n:
        raise SceneError(f"render_frames: paths: expected {n} paths (one per frame), got {V.show(paths)}")
    return [str(p) for p in paths]


def _compiled_once(compiled, scene, options):
    """(the compiled form of ``scene``, the scene cache's stats): compiled (or read from
    the scene cache) on the scene's first frame only; later frames of the same scene
    report the cache as "off"."""
    if isinstance(scene, CompiledScene):
        return scene, scene_cache.off_stats()
    got = compiled.get(id(scene))
    if got is None:
        got = compiled[id(scene)] = scene_cache.compiled(scene, shadows=options.get("shadows", True),
                                                         texture_filter=options.get("texture_filter"),
                                                         enabled=options.get("cache", True))
        return got
    return got[0], scene_cache.off_stats()


def _finish(image, paths, i):
    if paths is None:
        return image
    image.save(paths[i])
    return image.stats
