"""tools/ab.py: its --base-env/--new-env settings reach each side's render processes (a bad
TEXRAY_PACKET on one side fails that side with the renderer's message), and malformed ones are
named."""
import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _ab():
    spec = importlib.util.spec_from_file_location("texray_ab_tool", ROOT / "tools" / "ab.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_env_settings_reach_one_side_only(capsys):
    ab = _ab()
    scene = str(ROOT / "scenes" / "bench" / "grazing_quad.toml")
    args = [str(ROOT), str(ROOT), scene, "--size", "16x12", "--spp", "1", "--rounds", "1", "--frames", "1"]
    assert ab.main(args + ["--base-env", "TEXRAY_PACKET=0", "--new-env", "TEXRAY_PACKET=8"]) == 0
    assert "median new/base" in capsys.readouterr().out
    with pytest.raises(SystemExit, match="TEXRAY_PACKET: expected 0, 8 or 16, got '12'"):
        ab.main(args + ["--new-env", "TEXRAY_PACKET=12"])


def test_malformed_env_settings_are_named(capsys):
    with pytest.raises(SystemExit):
        _ab().main([str(ROOT), str(ROOT), "--base-env", "TEXRAY_PACKET"])
    assert "--base-env: expected K=V, got 'TEXRAY_PACKET'" in capsys.readouterr().err


def test_light_sampling_reaches_the_render_calls(capsys):
    """--light-sampling one renders both sides with render(light_sampling="one"); the value
    is what render receives (a bad one fails with render's message)."""
    ab = _ab()
    scene = ROOT / "scenes" / "bench" / "textured_meshes.toml"
    with pytest.raises(SystemExit, match="light_sampling: expected one of all, one, got 'bogus'"):
        ab.frame_time(ROOT, scene, (8, 6), 1, 1, "Portable Computing Language", light_sampling="bogus")
    args = [str(ROOT), str(ROOT), str(scene), "--size", "16x12", "--spp", "2", "--rounds", "1", "--frames", "1"]
    assert ab.main(args + ["--light-sampling", "one"]) == 0
    assert "median new/base" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        ab.main(args + ["--light-sampling", "some"])
    assert "--light-sampling: invalid choice: 'some'" in capsys.readouterr().err
