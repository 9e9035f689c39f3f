#!/usr/bin/env python3
"""Kernel benchmark: same as ``texray bench`` (see texray/bench/); runs from a source tree."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pyhost"))
from texray.bench import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
