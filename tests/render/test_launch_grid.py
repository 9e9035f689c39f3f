"""Launches laid out in rows (texray.device.opencl.launch_size, kernels' TX_GID): on PoCL a
launch wider than GRID_WIDTH work-items runs as rows of at most that width, so that every grid
dimension stays under PoCL's 65535 and each kernel has one work-group function (PoCL builds a
second, generic one for wider grids, and its first launch cost 0.8 s more than the small
grid's on the mixed scene). A kernel's work-item computes what it computed in one dimension:
the images with rows are the images without, bit for bit."""
import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import texray as tx
from texray.device import opencl, runtime
from texray.renderer import render
from texray.renderer.trace import Tracer


@pytest.mark.parametrize("local", [None, 1, 16, 48, 64, 256])
def test_launch_sizes_cover_the_work_items_in_rows_under_the_grid_width(local):
    rt = object.__new__(opencl.Runtime)          # launch_size needs no device, only its kind
    rt.kind = "pocl"
    for n in [0, 1, 63, 64, 65, 4800, 32767, 32768, 32769, 65535, 65536, 196608, 196609,
              307200, 1 << 20, 4096 * 2160, 10 ** 7 + 3]:
        glob, loc = rt.launch_size(n, local)
        total = math.prod(glob)
        assert total >= max(n, 1) and all(g < 65535 for g in glob), (n, local, glob)
        step = local or 1
        assert len(glob) in (1, 2) and (len(glob) == 1) == (-(-max(n, 1) // step) * step <= opencl.GRID_WIDTH)
        if local is None:
            assert loc is None and total - max(n, 1) < glob[-1]
        else:
            assert loc == (local,) + (1,) * (len(glob) - 1) and glob[0] % local == 0
            # fewer idle work-items than a row's work-groups hold, plus the last group's
            assert total - n < (glob[1] if len(glob) == 2 else 1) * local + local
    rt.kind = "intel-cpu"                        # other drivers: one dimension, as before
    for n in [1, 65536, 10 ** 7 + 3]:
        step = local or 1
        assert rt.launch_size(n, local) == ((-(-n // step) * step,), None if local is None else (local,))


SCENE = "bench/mixed.toml"


def _renders(scene, device):
    return {
        "fused16": render(scene, 40, 28, 16, device=device, seed=3).rgb,
        "fused3": render(scene, 40, 28, 3, device=device, seed=3).rgb,
        "staged": render(scene, 40, 28, 2, device=device, seed=3, pipeline="stages").rgb,
        "adaptive": render(scene, 40, 28, 16, device=device, seed=3, adaptive=0.05).rgb,
        "aov": render(scene, 40, 28, 1, device=device, aovs=("depth",)).aov["depth"],    # NaN on misses
    }


def test_rows_render_the_images_of_one_dimension(device, scenes_dir, monkeypatch, rng):
    """GRID_WIDTH at 64: the 40x28 renders' launches (1120 pixels) take rows of one work-group
    of 64 (PoCL's), the adaptive rounds' list loops run over rows, the Tracer's packets too;
    every image and hit the same bits."""
    scene = tx.Scene.load(scenes_dir / SCENE)
    ref = _renders(scene, device)
    org = (rng.uniform(-4, 4, (3000, 3)) * [1, 0, 1] + [0, 0.8, 0]).astype(np.float32)
    dirs = rng.normal(size=(3000, 3)).astype(np.float32)
    tracer = Tracer(scene, device=device)
    hits = tracer.closest(org, dirs)
    occ, _ = tracer.occluded(org, dirs, 0.0, 2.0)
    monkeypatch.setattr(opencl, "GRID_WIDTH", 64)
    rt = runtime(device)
    assert len(rt.launch_size(40 * 28, rt.local_size())[0]) == (2 if rt.kind == "pocl" else 1)
    rows = _renders(scene, device)
    for key in ref:
        finite = np.isfinite(ref[key])
        assert (finite.all() if key != "aov" else finite.mean() > 0.3) and ref[key][finite].max() > 0.01, key
        np.testing.assert_array_equal(rows[key], ref[key], err_msg=key)
    hits2 = tracer.closest(org, dirs)
    for f in ("t", "b1", "b2", "prim"):
        np.testing.assert_array_equal(getattr(hits2, f), getattr(hits, f))
    assert (hits.prim >= 0).sum() > 500 and 100 < occ.sum() < 2900
    np.testing.assert_array_equal(tracer.occluded(org, dirs, 0.0, 2.0)[0], occ)


_PROBE = textwrap.dedent("""
    import glob, os, sys
    import texray as tx
    scene = tx.Scene.load(sys.argv[1])
    tx.render(scene, 16, 16, 16, device="pocl")          # a small grid first (the same program)
    tx.render(scene, 320, 240, 16, device="pocl")        # 76,800 work-items: rows
    cache = os.environ["POCL_CACHE_DIR"]
    print(sorted(os.path.relpath(p, cache) for p in glob.glob(os.path.join(cache, "*", "*", "render_fused", "*"))))
""")


def test_a_large_frame_reuses_the_small_frames_pocl_work_group_function(scenes_dir, tmp_path):
    """PoCL's kernel cache after a 16x16 render and a 320x240 one, both at 16 spp (one program),
    in a fresh process: one render_fused work-group function, the small grid's (before the rows:
    a second, generic one for the 320x240 frame)."""
    try:
        runtime("pocl")
    except Exception as e:                       # pragma: no cover - PoCL always comes with pyopencl[pocl]
        pytest.skip(f"no PoCL device: {e}")
    env = dict(os.environ, POCL_CACHE_DIR=str(tmp_path / "pocl"), XDG_CACHE_HOME=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", _PROBE, str(scenes_dir / "bench/globe.toml")], env=env,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    dirs = eval(out.stdout.strip().splitlines()[-1])
    if not dirs:
        pytest.skip("this PoCL keeps no kernel folders in POCL_CACHE_DIR")
    assert len(dirs) == 1 and dirs[0].endswith("-smallgrid"), dirs      # program/render_fused/variant
