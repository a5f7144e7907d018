"""demos/window_benchmark.py and demos/volume_window_benchmark.py: a short scripted drag under
``xvfb-run`` reports its frame times; counts that leave nothing to measure are refused before
any window opens."""

from __future__ import annotations

import json
import runpy
import shutil
import subprocess
import sys

import pytest
from helpers import ROOT, child_env

XVFB = shutil.which("xvfb-run")
needs_xvfb = pytest.mark.skipif(
    XVFB is None, reason="xvfb-run is not installed (scripts/setup.sh installs xvfb xauth)"
)


def benchmark_main(name: str, monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "demos"))  # as when run: its folder on the path
    return runpy.run_path(str(ROOT / "demos" / f"{name}.py"))["main"]


@pytest.mark.parametrize(
    ("name", "arguments"),
    [
        ("window_benchmark", ["--frames", "0"]),
        ("window_benchmark", ["--warmup", "-1"]),
        ("window_benchmark", ["--construction", "4"]),
        ("window_benchmark", ["--construction", "-1"]),
        ("volume_window_benchmark", ["--frames", "0"]),
        ("volume_window_benchmark", ["--steps", "0"]),
        ("volume_window_benchmark", ["--warmup", "-1"]),
    ],
)
def test_counts_that_measure_nothing_are_refused(name, arguments, capsys, monkeypatch):
    main = benchmark_main(name, monkeypatch)
    with pytest.raises(SystemExit) as stop:
        main(arguments)
    assert stop.value.code == 2
    assert f"{arguments[0]} must be" in capsys.readouterr().err


@needs_xvfb
@pytest.mark.parametrize(
    ("name", "arguments", "keys"),
    [
        ("window_benchmark", ["--frames", "1", "--warmup", "0"], {"fps", "ms_per_frame"}),
        (
            "volume_window_benchmark",
            ["--frames", "1", "--warmup", "0", "--steps", "1", "--grid", "8"],
            {"drag_ms_median", "slice_point_ms_median"},
        ),
    ],
)
def test_a_short_run_reports_its_frame_times(name, arguments, keys):
    command = [XVFB, "-a", sys.executable, f"demos/{name}.py", *arguments]
    done = subprocess.run(
        command, cwd=ROOT, capture_output=True, text=True, timeout=120, env=child_env()
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.splitlines()[-1])
    assert all(result[key] > 0 for key in keys)
