"""demos/before_after.py, the README's picture: it runs, every handle lands on its target, and
it writes the two panels side by side."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from helpers import child_env

import glmls

ROOT = Path(__file__).resolve().parent.parent.parent


def test_the_before_after_demo_runs(tmp_path):
    out = tmp_path / "before_after.png"
    done = subprocess.run(
        [sys.executable, "demos/before_after.py", "--out", str(out), "--scale", "0.25"],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
        env=child_env(),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "largest distance of f(p) from q: 0.0000 px" in done.stdout
    picture = glmls.imread(out)
    assert picture.ndim == 3 and picture.shape[1] > 2 * 128 and picture.shape[0] > 128
