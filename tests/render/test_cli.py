"""The command line, as a user runs it."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

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
    import json
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
