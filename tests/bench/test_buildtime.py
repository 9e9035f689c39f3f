"""texray.bench.buildtime.measure: cold and warm builds in fresh processes, each pair of runs
with a fresh cache of its own, and the medians over `repeat` pairs (subprocesses faked)."""
import json
from types import SimpleNamespace

import pytest

from texray.bench import buildtime


def test_cold_builds_are_medians_of_fresh_caches(monkeypatch):
    caches, times = [], iter([3.0, 0.1, 1.0, 0.3, 2.0, 0.2])     # (cold, warm) per pair

    def fake_run(cmd, env, capture_output, text, timeout):
        caches.append(env["POCL_CACHE_DIR"])
        t = next(times)
        return SimpleNamespace(returncode=0, stdout=json.dumps({"build_s": t, "program_s": t / 2,
                                                                "first_launch_s": t / 2}), stderr="")

    monkeypatch.setattr(buildtime.subprocess, "run", fake_run)
    out = buildtime.measure("scene.toml", repeat=3)
    assert out["cold_runs"] == [3.0, 1.0, 2.0] and out["warm_runs"] == [0.1, 0.3, 0.2]
    assert out["cold_s"] == 2.0 and out["warm_s"] == 0.2 and out["cold_program_s"] == 1.0
    assert caches[0] == caches[1] != caches[2] == caches[3] != caches[4]   # a cache per pair, warm shares it


def test_bench_refuses_a_build_repeat_below_one(capsys):
    from texray.bench.cli import main
    with pytest.raises(SystemExit):
        main(["--build-repeat", "0", "--scenes", "globe"])
    assert "--build-repeat must be >= 1" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["globe", "brick_wall"])
def test_the_timed_program_is_the_one_the_scene_renders_with(scenes_dir, name, monkeypatch):
    """The build and the probe's first launch are of the program a render at the scene file's
    settings asks for (16 spp for the globe, whose program takes one pixel per work-item; 4 for
    the brick wall): the timing asks for one program, and the render for no other."""
    import texray as tx
    from texray.device import opencl
    asked, program = [], opencl.Runtime.program

    def spy(self, defines, extra_options=()):
        asked.append(tuple(sorted(defines.items())))
        return program(self, defines, extra_options)

    monkeypatch.setattr(opencl.Runtime, "program", spy)
    scene_path = scenes_dir / f"bench/{name}.toml"
    out = buildtime._time_build(scene_path, "pocl", True)
    timed = set(asked)
    settings = tx.Scene.load(scene_path).render_settings
    assert out["spp"] == settings["spp"] and out["program_s"] > 0 and out["build_s"] >= out["program_s"]
    assert len(timed) == 1, "the probe launched a program other than the one timed"
    asked.clear()
    img = tx.render(tx.Scene.load(scene_path), settings["width"], settings["height"], settings["spp"], device="pocl")
    assert set(asked) == timed, "the render asked for a program the bench did not time"
    assert img.rgb.mean() > 0.02
