"""A compiled scene's device buffers kept between renders (texray.renderer.uploads) and
the kernels kept per thread (texray.device.Runtime.kernel): the same images as a render
that uploads and makes everything anew, a changed scene uploaded again, no more than
KEEP scenes kept, and an upload that runs out of memory tried again without them."""
import threading

import numpy as np
import pyopencl as cl
import pytest

import texray as tx
from cache_scenes import edited, rich_scene
from texray.compile import compile_scene
from texray.device import runtime
from texray.device.features import compile_options
from texray.renderer import uploads

W, H = 64, 48


@pytest.fixture(autouse=True)
def fresh_uploads():
    uploads.clear()
    yield
    uploads.clear()


def test_a_second_render_keeps_the_upload_and_the_image(cache_env, device):
    first = tx.render(rich_scene(), W, H, 2, device=device)
    again = tx.render(rich_scene(), W, H, 2, device=device)
    off = tx.render(rich_scene(), W, H, 2, device=device, cache=False)
    assert (first.stats["upload_kept"], again.stats["upload_kept"], off.stats["upload_kept"]) == (False, True, False)
    assert first.rgb.std() > 0.01
    np.testing.assert_array_equal(again.rgb, first.rgb)
    np.testing.assert_array_equal(off.rgb, first.rgb)


def test_other_features_and_a_changed_scene_are_uploaded_anew(cache_env, device):
    s = rich_scene()
    base = tx.render(s, W, H, 1, device=device)
    generic = tx.render(s, W, H, 1, device=device, specialize=False)   # the generic object table: another key
    assert not generic.stats["upload_kept"]
    np.testing.assert_array_equal(generic.rgb, base.rgb)
    s = rich_scene()
    m = s.objects[2].material
    m.diffuse = edited(m.diffuse, slice(None), 0.9)          # the ball's texels
    changed = tx.render(s, W, H, 1, device=device)
    assert not changed.stats["upload_kept"]
    assert not np.array_equal(changed.rgb, base.rgb)
    np.testing.assert_array_equal(changed.rgb, tx.render(s, W, H, 1, device=device, cache=False).rgb)


def test_no_more_than_keep_scenes_are_kept(cache_env, device):
    scenes = [rich_scene() for _ in range(uploads.KEEP + 1)]
    for i, s in enumerate(scenes):
        s.ambient = (0.01 * (i + 1),) * 3
        tx.render(s, 16, 16, 1, device=device)
        assert len(uploads._kept) == min(i + 1, uploads.KEEP)
    assert tx.render(scenes[-1], 16, 16, 1, device=device).stats["upload_kept"]
    assert not tx.render(scenes[0], 16, 16, 1, device=device).stats["upload_kept"]   # the oldest went first
    assert uploads.clear() == uploads.KEEP and not uploads._kept


def test_an_upload_out_of_memory_gives_back_the_kept_scenes_and_tries_again(cache_env, device, monkeypatch):
    a, b = rich_scene(), rich_scene()
    b.ambient = (0.2, 0.2, 0.2)
    tx.render(a, W, H, 1, device=device)
    ref = tx.render(b, W, H, 1, device=device, cache=False)
    real, calls = uploads.Uploaded, []

    def scarce(ctx, cs):
        calls.append(len(uploads._kept))
        if len(uploads._kept):
            raise cl.MemoryError("clCreateBuffer", cl.status_code.MEM_OBJECT_ALLOCATION_FAILURE, "out of memory")
        return real(ctx, cs)
    monkeypatch.setattr(uploads, "Uploaded", scarce)
    img = tx.render(b, W, H, 1, device=device)
    assert calls == [1, 0] and len(uploads._kept) == 1
    np.testing.assert_array_equal(img.rgb, ref.rgb)
    uploads.clear()
    monkeypatch.setattr(uploads, "Uploaded", lambda ctx, cs: (_ for _ in ()).throw(
        cl.MemoryError("clCreateBuffer", cl.status_code.MEM_OBJECT_ALLOCATION_FAILURE, "out of memory")))
    with pytest.raises(cl.MemoryError):                     # nothing kept to give back: the error stands
        tx.render(b, W, H, 1, device=device)


def test_kernels_are_kept_per_thread(device):
    rt = runtime(device)
    prg = rt.program(compile_options(compile_scene(rich_scene()).features, rt.kind))
    k = rt.kernel(prg, "render_fused")
    assert rt.kernel(prg, "render_fused") is k and rt.kernel(prg, "shade") is not k
    other = []
    t = threading.Thread(target=lambda: other.append(rt.kernel(prg, "render_fused")))
    t.start()
    t.join()
    assert other[0] is not k and other[0].function_name == "render_fused"
