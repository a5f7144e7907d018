"""demos/before_after.py, the README's picture: it runs, every handle lands on its target, and
it writes the two panels side by side."""

from __future__ import annotations

from helpers import run_demo

import glmls


def test_the_before_after_demo_runs(tmp_path):
    out = tmp_path / "before_after.png"
    done = run_demo("before_after", "--out", str(out), "--scale", "0.25")
    assert done.returncode == 0, done.stderr
    assert "largest distance of f(p) from q: 0.0000 px" in done.stdout
    picture = glmls.imread(out)
    assert picture.ndim == 3 and picture.shape[1] > 2 * 128 and picture.shape[0] > 128
