"""The A/B tool's own checks (``python -m pytest tools``; not part of the test suite, whose
paths are ``tests/``): tools/ab_trees.py on this checkout twice, under two names."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

TOOLS = Path(__file__).resolve().parent
ROOT = str(TOOLS.parent)


def run_script(
    name: str, *arguments: str, timeout: int = 300, returncode: int = 0
) -> subprocess.CompletedProcess:
    """tools/``name`` with ``arguments``; it must exit with ``returncode``."""
    run = subprocess.run(
        [sys.executable, str(TOOLS / name), *arguments],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert run.returncode == returncode, run.stderr
    return run


def ab_trees(trees: str, cases: str, *options: str) -> subprocess.CompletedProcess:
    """tools/ab_trees.py with ``trees`` and ``cases``, one round, and ``options``."""
    return run_script("ab_trees.py", "--trees", trees, "--cases", cases, "--rounds", "1", *options)


def assert_ratio_line(line: str, spec: str) -> None:
    """``line`` reports ``spec``'s ratio: its median within its quartiles, all positive."""
    assert line.startswith(f"{spec}: ") and line.endswith("]")
    low, high = (float(v) for v in line.split("[")[1].rstrip("]").split("-"))
    assert 0 < low <= float(line.split(": ")[1].split("x")[0]) <= high


def test_ab_trees_alternates_trees_and_reports_each_case():
    """tools/ab_trees.py on this checkout twice: a row per case, a cell per tree, and "-"
    where a tree lacks the option (here none does)."""
    run = ab_trees(f"a={ROOT},b={ROOT}", "W3:grid=8,W3:tolerance=0.25", "--repeat", "1")
    lines = run.stdout.splitlines()
    assert lines[0] == "case | a | b"
    assert lines[1].startswith("W3:grid=8 | ") and lines[2].startswith("W3:tolerance=0.25 | ")
    assert "-" not in lines[1].split(" | ")[1:]
    times = json.loads(lines[-1])
    assert set(times) == {f"W3:{o}|{t}" for o in ("grid=8", "tolerance=0.25") for t in "ab"}


@pytest.mark.parametrize("mode", ["--paired", "--together"])
def test_ab_trees_pairs_calls_across_trees_and_cases(mode):
    """--paired: a worker process per case and tree; --together: the trees imported side by
    side into one process (this checkout twice, under two names). Either way one call of each
    case and tree in turn; --ratios reports the ratio of the calls made in turn (the checkout
    against itself: about 1, its quartiles around it), a case a tree lacks is "-", and the
    frame case runs the tree's own bench code."""
    spec = "W3:grid=8|a/W3:grid=8|b"
    ratios = f"{spec},W3:nothing=1|a/W3:grid=8|b"
    cases = "W3:grid=8,W3:nothing=1,W3:frame=8"
    run = ab_trees(f"a={ROOT},b={ROOT}", cases, "--repeat", "3", mode, "--ratios", ratios)
    lines = run.stdout.splitlines()
    assert lines[0] == "case | a | b"
    assert lines[1].startswith("W3:grid=8 | ") and "-" not in lines[1].split(" | ")[1:]
    assert lines[2] == "W3:nothing=1 | - | -"
    assert lines[3].startswith("W3:frame=8 | ") and "-" not in lines[3].split(" | ")[1:]
    assert_ratio_line(lines[4], spec)
    assert lines[5] == "W3:nothing=1|a/W3:grid=8|b: -"
    times = json.loads(lines[-1])
    assert set(times) == {f"W3:{c}|{t}" for c in ("grid=8", "frame=8") for t in "ab"}
    assert all(len(v) == 3 for v in times.values())


def test_ab_trees_pairs_calls_one_way_only():
    """--paired and --together exclude each other: a usage error (exit 2) naming it."""
    run = run_script(
        "ab_trees.py",
        "--trees",
        "a=.",
        "--cases",
        "W3:grid=8",
        "--paired",
        "--together",
        timeout=60,
        returncode=2,
    )
    assert "choose one" in run.stderr


def test_ab_trees_paired_survives_a_worker_that_dies(tmp_path):
    """A worker whose tree crashes mid-run is reported and left out (its calls no longer
    pair); the other trees' calls go on."""
    fake = tmp_path / "crashing" / "glmls"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text(
        "import os\n"
        "calls = 0\n"
        "class MLS:\n"
        "    def __init__(self, *args, **kwargs): pass\n"
        "    def __enter__(self): return self\n"
        "    def __exit__(self, *exc): return False\n"
        "    def warp(self, image, **options):\n"
        "        global calls\n"
        "        calls += 1\n"
        "        if calls == 5:\n"
        "            os._exit(3)\n"
    )

    run = ab_trees(
        f"good={ROOT},bad={fake.parent}",
        "W3:grid=8",
        *("--repeat", "4", "--warmup", "0", "--paired"),
        *("--ratios", "W3:grid=8|bad/W3:grid=8|good"),
    )
    assert "failed: bad W3:grid=8" in run.stderr
    lines = run.stdout.splitlines()
    assert lines[1].startswith("W3:grid=8 | ") and lines[1].endswith(" | -")
    assert lines[2] == "W3:grid=8|bad/W3:grid=8|good: -"


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (("--cases", "W9:grid=8"), "the workload is one of W1, W2, W3"),
        (("--cases", "W3:grid"), "expected WORKLOAD:OPTION=VALUE"),
        (("--cases", "W3:grid=8.5"), "grid takes an integer"),
        (("--cases", "W3:tolerance=small"), "tolerance takes a number"),
        (("--cases", "W3:grid=8", "--repeat", "0"), "--rounds and --repeat must be >= 1"),
        (("--cases", "W3:grid=8", "--rounds", "0"), "--rounds and --repeat must be >= 1"),
    ],
)
def test_ab_trees_refuses_a_case_or_count_it_cannot_time(arguments, message):
    """A malformed case, an unknown workload or no calls to time: a usage error (exit 2)
    before any tree runs, not a table of "-" or a crash part way."""
    run = run_script("ab_trees.py", "--trees", "a=.", *arguments, timeout=60, returncode=2)
    assert message in run.stderr
