"""benchmarks/fixed_cost.py runs and names every stage (no timings are checked: performance
is the benchmarks' business)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "fixed_cost.py"


def test_fixed_cost_names_every_stage():
    run = subprocess.run(
        [sys.executable, str(SCRIPT), "--size", "64", "--handles", "9", "--repeat", "2"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    for stage in (
        "validation",
        "upload (storage, bins)",
        "program lookup + bind",
        "texture upload",
        "mesh pass",
        "render (mesh + quads)",
        "read-back",
        "release",
        "glmls.warp (end to end)",
        "frame (no read-back)",
    ):
        assert stage in run.stdout


def test_fixed_cost_many_handles_case():
    run = subprocess.run(
        [sys.executable, str(SCRIPT), "--size", "128", "--lattice", "32", "--weight", "linear"]
        + ["--radius", "12", "--repeat", "2"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    assert "1024 handles" in run.stdout
