"""The README's Python examples run as written (from the repository root), so the
documented API cannot drift from the code. Files they write go to a temporary folder."""
import re

import pytest

from conftest import ROOT

BLOCKS = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(encoding="utf-8"), re.S)


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_python_example_runs(index, tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    code = BLOCKS[index].replace('"out.png"', repr(str(tmp_path / "out.png")))
    # an excerpt that adds to a scene the reader already has
    prelude = "import texray as tx\nscene = tx.Scene(camera=tx.Camera())\n"
    exec(compile(prelude + code, f"README.md python block {index}", "exec"), {})


def test_readme_has_examples():
    assert len(BLOCKS) >= 3
