"""Renders through the scene cache: a hit renders bit for bit the image of the render
that stored it (in this process and in fresh ones), with the scene's current camera;
``render(cache=False)``, ``texray render --no-cache`` and ``texray cache``."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import texray as tx
from cache_scenes import edited, rich_scene
from texray.cli import main

ROOT = Path(__file__).resolve().parents[2]
W, H = 64, 48


@pytest.mark.parametrize("kw", [{}, {"specialize": False, "aovs": ("uv", "object_id")}, {"adaptive": 0.05, "spp": 8},
                                {"shadows": False, "texture_filter": "anisotropic"}],
                         ids=["default", "generic+aovs", "adaptive", "options"])
def test_a_hit_renders_the_stored_image_bit_for_bit(cache_env, device, kw):
    kw = {"spp": 2, **kw}
    spp = kw.pop("spp")
    off = tx.render(rich_scene(), W, H, spp, device=device, cache=False, **kw)
    stored = tx.render(rich_scene(), W, H, spp, device=device, **kw)
    hit = tx.render(rich_scene(), W, H, spp, device=device, **kw)
    assert (off.stats["scene_cache"], stored.stats["scene_cache"], hit.stats["scene_cache"]) == ("off", "stored", "hit")
    assert hit.stats["scene_cache_hash_s"] > 0 and hit.stats["scene_cache_load_s"] > 0
    assert off.rgb.std() > 0.01
    np.testing.assert_array_equal(stored.rgb, off.rgb)
    np.testing.assert_array_equal(hit.rgb, stored.rgb)
    for name in kw.get("aovs", ()):
        np.testing.assert_array_equal(hit.aov[name], off.aov[name])
    assert hit.stats["features"] == stored.stats["features"]


def test_a_kept_scene_renders_the_image_bit_for_bit_with_any_settings(cache_env, device, monkeypatch):
    """Kept in memory: the render's own changes to its copy (AOVs, the generic table, adaptive
    sampling) never reach the next render of the scene."""
    monkeypatch.setenv("TEXRAY_CACHE_MEMORY", "2")
    s = rich_scene()
    first = tx.render(s, W, H, 2, device=device)
    generic = tx.render(s, W, H, 2, device=device, specialize=False, aovs=("uv",))
    adaptive = tx.render(s, W, H, 8, device=device, adaptive=0.05)
    again = tx.render(s, W, H, 2, device=device)
    assert first.stats["scene_cache"] == "stored"
    assert [i.stats["scene_cache"] for i in (generic, adaptive, again)] == ["kept"] * 3
    assert again.stats["features"] == first.stats["features"] and not again.stats["features"].aovs
    np.testing.assert_array_equal(again.rgb, first.rgb)
    np.testing.assert_array_equal(generic.rgb, tx.render(s, W, H, 2, device=device, cache=False,
                                                         specialize=False, aovs=("uv",)).rgb)
    np.testing.assert_array_equal(adaptive.rgb, tx.render(s, W, H, 8, device=device, cache=False, adaptive=0.05).rgb)


def test_a_hit_renders_with_the_scenes_current_camera(cache_env, device):
    tx.render(rich_scene(), W, H, 1, device=device)
    s = rich_scene()
    s.camera = tx.Camera(eye=(-3, 1.5, 3), look_at=(0, 0.5, 0), fov_y=35)
    hit = tx.render(s, W, H, 1, device=device)
    assert hit.stats["scene_cache"] == "hit"
    ref = tx.render(s, W, H, 1, device=device, cache=False)
    np.testing.assert_array_equal(hit.rgb, ref.rgb)
    assert not np.array_equal(hit.rgb, tx.render(rich_scene(), W, H, 1, device=device, cache=False).rgb)


def test_a_changed_scene_renders_its_own_image(cache_env, device):
    tx.render(rich_scene(), W, H, 1, device=device)
    s = rich_scene()
    m = s.objects[2].material
    m.diffuse = edited(m.diffuse, slice(None), 0.9)            # the ball's texels
    img = tx.render(s, W, H, 1, device=device)
    assert img.stats["scene_cache"] == "stored"
    np.testing.assert_array_equal(img.rgb, tx.render(s, W, H, 1, device=device, cache=False).rgb)


CHILD = """
import json, sys
sys.path[:0] = [{tests!r}, {pyhost!r}]
import numpy as np, texray as tx
from cache_scenes import rich_scene
img = tx.render(rich_scene(), {w}, {h}, 2, device={device!r})
np.save(sys.argv[1], img.rgb)
print(json.dumps({{"status": img.stats["scene_cache"], "file": tx.__file__}}))
"""


def test_a_fresh_process_hits_and_renders_the_same_image(cache_env, device, tmp_path):
    code = CHILD.format(tests=str(ROOT / "tests"), pyhost=str(ROOT / "pyhost"), w=W, h=H, device=device)
    runs = []
    for i in range(2):
        out = subprocess.run([sys.executable, "-c", code, str(tmp_path / f"{i}.npy")], capture_output=True,
                             text=True, timeout=300, env=dict(os.environ))
        assert out.returncode == 0, out.stderr
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    assert [r["status"] for r in runs] == ["stored", "hit"]
    assert Path(runs[0]["file"]).parent == ROOT / "pyhost" / "texray"
    first, second = np.load(tmp_path / "0.npy"), np.load(tmp_path / "1.npy")
    np.testing.assert_array_equal(first, second)
    np.testing.assert_array_equal(second, tx.render(rich_scene(), W, H, 2, device=device, cache=False).rgb)


def test_cli_no_cache_and_the_cache_command(cache_env, tmp_path, capsys):
    scene = ROOT / "scenes" / "showcase.toml"
    args = ["render", str(scene), "-o", str(tmp_path / "a.png"), "--width", "40", "--height", "30", "--spp", "1"]
    assert main(args + ["--no-cache"]) == 0
    assert not cache_env.exists() or not list(cache_env.iterdir())
    assert main(args) == 0
    assert len(list(cache_env.iterdir())) == 1
    capsys.readouterr()
    assert main(["cache", "info"]) == 0
    out = capsys.readouterr().out
    assert str(cache_env) in out and "1 compiled scenes" in out and "2048 MiB" in out and "on" in out
    assert main(["cache", "clear"]) == 0
    assert "removed 1 compiled scenes" in capsys.readouterr().out
    assert not list(cache_env.iterdir())


def test_render_cache_argument_is_checked(cache_env):
    with pytest.raises(tx.SceneError, match="render: cache: expected True or False"):
        tx.render(rich_scene(), 8, 8, cache="yes")
