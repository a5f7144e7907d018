"""tools/fork_probe.py's own check (``python -m pytest tools``): every case runs and, on this
machine's driver, the parent's context survives each way its child ends."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

TOOL = Path(__file__).resolve().parent / "fork_probe.py"


def test_every_case_reports_the_parents_warp_and_exit():
    done = subprocess.run(
        [sys.executable, str(TOOL), "--timeout", "120"], capture_output=True, text=True
    )
    lines = done.stdout.splitlines()
    assert len(lines) == 3, done.stdout + done.stderr
    for line in lines:
        assert line.startswith("ok   "), line
        assert "parent exit status 0" in line and "warps after it: same" in line, line
    assert done.returncode == 0
