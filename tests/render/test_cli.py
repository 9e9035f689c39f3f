"""The command line, as a user runs it."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

import texray
from texray.cli import main

ROOT = Path(__file__).resolve().parents[2]


def test_render_command_writes_png_and_exr(tmp_path, capsys):
    png, exr = tmp_path / "out.png", tmp_path / "out.exr"
    scene = ROOT / "scenes" / "showcase.toml"
    assert main(["render", str(scene), "-o", str(png), "--width", "80", "--height", "60", "--spp", "1",
                 "--device", "cpu"]) == 0
    assert main(["render", str(scene), "-o", str(exr), "--width", "80", "--height", "60", "--spp", "1"]) == 0
    a = oiio.ImageBuf(str(png)).get_pixels(oiio.FLOAT)
    b = oiio.ImageBuf(str(exr)).get_pixels(oiio.FLOAT)
    assert a.shape == (60, 80, 3) and b.shape == (60, 80, 3)
    # PNG holds sRGB-encoded, clamped values of the same linear image the EXR holds (as half).
    srgb = np.where(b <= 0.0031308, 12.92 * b, 1.055 * np.clip(b, 0, 1) ** (1 / 2.4) - 0.055)
    assert np.abs(np.clip(srgb, 0, 1) - a).max() <= 1.5 / 255
    assert "80x60, 1 spp" in capsys.readouterr().out


def test_bad_scene_file_is_an_error_not_a_traceback(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[camera]\nfov = 1\n")
    assert main(["render", str(bad), "-o", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert "bad.toml" in err and "camera.fov: unknown key" in err and "Traceback" not in err


def test_devices_command_lists_the_cpu():
    out = subprocess.run([sys.executable, "-c", "import sys; from texray.cli import main; sys.exit(main(['devices']))"],
                         capture_output=True, text=True, timeout=60, cwd=ROOT,
                         env={**__import__("os").environ, "PYTHONPATH": str(ROOT / "pyhost")})
    assert out.returncode == 0 and "cpu" in out.stdout


def test_bench_command_writes_json_report_and_compare(tmp_path, capsys):
    """A tiny full run: ray throughput, one suite scene (specialized and generic, no build
    timing), a sweep, the displacement sweep (terrain: every method against its tessellation),
    the markdown report, and --compare of the run with itself."""
    out, md = tmp_path / "bench.json", tmp_path / "bench.md"
    assert main(["bench", "--device", "cpu", "--triangles", "5000", "--rays", "32", "--repeat", "1",
                 "--scenes", "globe", "--size", "32x24", "--spp", "1", "--no-build",
                 "--sweep", "globe,terrain", "--sweep-size", "24x16", "--ref-spp", "8", "--sweep-spp", "1,2",
                 "--json", str(out), "--report", str(md)]) == 0
    r = json.loads(out.read_text())
    assert abs(r["bvh"]["triangles"] - 5000) <= 50 and r["bvh"]["sah_cost"] > 1
    assert len(r["variants"]) >= 1
    (dev,) = r["devices"].values()
    assert dev["rays"]["primary_mrays_s"]["median"] > 0
    g = dev["scenes"]["globe"]
    assert g["spp"] == 1 and set(g["stages"]["stage_s"]) == {"raygen", "intersect", "surface", "shadow", "shade"}
    assert set(g["specialized"]["stage_s"]) == {"render_fused"} and g["stages_over_fused"] > 0
    assert g["specialized"]["features"]["spheres"] and not g["specialized"]["features"]["cylinders"]
    assert g["generic"]["features"]["cylinders"] and g["generic_over_specialized"] > 0
    sweep = dev["sweeps"]["globe"]["series"]["spp"]
    assert [p["spp"] for p in sweep] == [1, 2]
    # More samples, less error against the reference (8 spp): the 2-spp error is the
    # smaller one unless the sweep is broken (noise falls by sqrt(2) in expectation).
    assert sweep[1]["rmse"] < sweep[0]["rmse"]
    disp = dev["sweeps"]["terrain"]
    from texray.bench.sweep import DISP_STEPS
    assert disp["kind"] == "displacement" and disp["reference"].startswith("tessellate")
    assert set(disp["series"]) == {"search M=0", "search M=4", "search M=8", "search adaptive M=8", "maxmip",
                                   "tessellate"}
    assert [p["steps"] for p in disp["series"]["search M=8"]] == list(DISP_STEPS)
    tess1, tess2 = disp["series"]["tessellate"]
    (mm,) = disp["series"]["maxmip"]
    coarse = disp["series"]["search M=0"][0]
    assert disp["reference"] == "tessellate (4 vertices/texel)" and disp["reference_s"] > 0
    # Against the fine tessellation, the finer of the two compared ones is the closer; the exact
    # traversal misses no spike that the 4-step search finds; the search and maxmip hold one
    # height map and its pyramid, the tessellations a mesh of 2 triangles per vertex and its BVH.
    assert tess2["rmse"] < tess1["rmse"] and 0 < tess1["rmse"] < 0.2
    assert mm["wrong_hit"] <= coarse["wrong_hit"] and 0 < mm["rmse"] < 0.2
    assert mm["device_mib"] < tess1["device_mib"] / 10 and coarse["device_mib"] == mm["device_mib"]
    text = capsys.readouterr().out
    assert "Mrays/s" in text and "generic/spec." in text and "% wrong first hit" in text
    assert "| globe |" in md.read_text() and "against tessellate (4 vertices/texel)" in md.read_text()
    md2 = tmp_path / "again.md"
    assert main(["bench", "--from-json", str(out), "--report", str(md2)]) == 0
    assert md2.read_text() == md.read_text()
    capsys.readouterr()
    assert main(["bench", "--compare", str(out), str(out)]) == 0
    cmp = capsys.readouterr().out
    assert "globe frame ms" in cmp and "1.000" in cmp and "terrain maxmip ms" in cmp


def test_version_prints_the_package_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out == f"texray {texray.__version__}\n" == "texray 0.1.0\n"


# The quickest bench run there is: one frame size of 16x12 at 1 spp, no ray throughput, no
# generic program, no build timing.
TINY_BENCH = ["bench", "--device", "cpu", "--rays", "0", "--repeat", "1", "--size", "16x12", "--spp", "1",
              "--no-build", "--no-generic"]
BALL = """[camera]
eye = [0.0, 0.0, 3.0]

[[lights]]
position = [2.0, 2.0, 3.0]
intensity = [10.0, 10.0, 10.0]

[[objects]]
type = "sphere"
radius = 1.0
"""


def test_bench_runs_anywhere_takes_names_and_paths_and_writes_no_file_unless_asked(tmp_path, monkeypatch, capsys):
    """From a folder with no scenes/ in it: a suite scene by name (found with texray, not in the
    working directory) and a scene file by a path relative to the working directory; without
    --json nothing is written."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ball.toml").write_text(BALL)
    assert main(TINY_BENCH + ["--scenes", "globe,ball.toml"]) == 0
    text = capsys.readouterr().out
    rows = [line.split()[:3] for line in text.splitlines()]
    assert ["globe", "16x12", "1"] in rows and ["ball", "16x12", "1"] in rows
    assert "wrote" not in text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ball.toml"]


def test_bench_names_a_scene_it_cannot_find(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit, match=r"no suite scene 'glob' \(known: .*\bglobe\b.*\bterrain\b"):
        main(TINY_BENCH + ["--scenes", "glob"])
    with pytest.raises(SystemExit, match=r"no scene file missing\.toml .*working directory"):
        main(TINY_BENCH + ["--scenes", "globe,missing.toml"])


def test_the_installed_package_ships_the_scenes(tmp_path):
    """The package as pyproject.toml builds it (setuptools' build_py: what goes into the wheel),
    run from a folder outside the repository: it holds every file of scenes/, the bench finds its
    suite there, and a shipped scene renders with the textures it names relative to itself."""
    pytest.importorskip("setuptools")
    src, lib, run = tmp_path / "src", tmp_path / "site" / "lib", tmp_path / "run"
    keep = shutil.ignore_patterns("__pycache__", "*.egg-info")
    for name in ("pyhost", "kernels", "scenes"):
        shutil.copytree(ROOT / name, src / name, ignore=keep)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    build = subprocess.run([sys.executable, "-c", "from setuptools import setup; setup()", "-q", "build_py",
                            "--build-lib", str(lib)], cwd=src, capture_output=True, text=True, timeout=120)
    assert build.returncode == 0, build.stderr[-2000:]
    shipped = {p.relative_to(lib / "texray" / "scenes") for p in (lib / "texray" / "scenes").rglob("*") if p.is_file()}
    in_repo = {p.relative_to(ROOT / "scenes") for p in (ROOT / "scenes").rglob("*")
               if p.is_file() and "__pycache__" not in p.parts}
    assert shipped == in_repo
    shutil.rmtree(src)
    run.mkdir()
    env = {**os.environ, "PYTHONPATH": str(lib)}
    script = ("import sys, texray; from texray.bench.suite import scenes_dir; from texray.cli import main; "
              "print(texray.__file__); print(scenes_dir()); "
              "sys.exit(main(['render', str(scenes_dir() / 'bench' / 'globe.toml'), '-o', 'globe.png', "
              "'--width', '32', '--height', '24', '--spp', '1', '--device', 'cpu']))")
    out = subprocess.run([sys.executable, "-c", script], cwd=run, env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    where, scenes = out.stdout.splitlines()[:2]
    assert Path(where) == lib / "texray" / "__init__.py" and Path(scenes) == lib / "texray" / "scenes"
    img = oiio.ImageBuf(str(run / "globe.png")).get_pixels(oiio.FLOAT)
    assert img.shape == (24, 32, 3) and img.std() > 0.05          # the textured globe, not a blank frame
    bench = subprocess.run([sys.executable, "-m", "texray.cli"] + TINY_BENCH + ["--scenes", "globe", "--json", "b.json"],
                           cwd=run, env=env, capture_output=True, text=True, timeout=300)
    assert bench.returncode == 0, bench.stderr[-2000:]
    assert sorted(p.name for p in run.iterdir()) == ["b.json", "globe.png"]
    (dev,) = json.loads((run / "b.json").read_text())["devices"].values()
    assert dev["scenes"]["globe"]["width"] == 16
