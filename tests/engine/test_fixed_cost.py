"""The benchmarks run: benchmarks/fixed_cost.py names every stage, adaptive_stages.py splits a
warp into its stages, guarantee.py reports its table (no timings are checked: performance is
the benchmarks' business)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "fixed_cost.py"


def test_fixed_cost_names_every_stage():
    arguments = ("--size", "64", "--handles", "9", "--repeat", "2")
    run = run_script("fixed_cost.py", *arguments, timeout=120)
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
    arguments = ("--size", "128", "--lattice", "32", "--weight", "linear", "--radius", "12")
    run = run_script("fixed_cost.py", *arguments, "--repeat", "2", timeout=120)
    assert "1024 handles" in run.stdout


def run_script(
    name: str, *arguments: str, timeout: int = 300, returncode: int = 0
) -> subprocess.CompletedProcess:
    """benchmarks/``name`` with ``arguments``; it must exit with ``returncode``."""
    run = subprocess.run(
        [sys.executable, str(SCRIPT.parent / name), *arguments],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert run.returncode == returncode, run.stderr
    return run


def test_adaptive_stages_splits_a_warp_into_its_stages():
    """benchmarks/adaptive_stages.py: the build (f, tests, bookkeeping), the draw and the
    rest, which add up to the call, and the mesh's counts."""
    run = run_script(
        "adaptive_stages.py", "--workload", "W3", "--tolerance", "0.25", "--repeat", "2"
    )
    lines = run.stdout.splitlines()
    values = {line.split()[0]: float(line.split()[1]) for line in lines[1:8]}
    assert set(values) == {"total", "build", "f", "test", "bookkeeping", "draw", "rest"}
    assert all(value > 0 for value in values.values())
    assert abs(values["f"] + values["test"] + values["bookkeeping"] - values["build"]) < 0.05
    assert abs(values["build"] + values["draw"] + values["rest"] - values["total"]) < 0.05
    assert lines[8].strip().startswith("evaluations ") and "triangles" in lines[8]


def test_guarantee_reports_each_case_and_the_worst_per_weight():
    """benchmarks/guarantee.py on one weight, map and tolerance: a line for the case and the
    summary, the default weight's errors within the tolerance where its leaves vouch; with
    --margins, its leaves' errors over their misses, within SAFETY (the test's miss) and no
    smaller than with the miss at the 16 test points alone."""
    run = run_script(
        "guarantee.py",
        "--weights",
        "[{}]",
        "--maps",
        "smooth",
        "--tolerances",
        "0.25",
        "--margins",
    )
    case, summary = (line for line in run.stdout.splitlines() if line.startswith(("{", "  {")))
    assert case.startswith("{}") and "smooth" in case and "0 over" in case
    assert 0 < float(summary.split()[-1]) <= 1.0
    inset, at_tests = (float(case.split()[k].strip(",")) for k in (-6, -1))
    assert 0.5 < inset <= at_tests and inset < 1.25


def test_volume_bench_prints_each_measurement():
    """benchmarks/volume_bench.py, small: both methods, the peers (a line that says a peer is
    not installed where it is not) and the memory case, each with its seconds and peak."""
    run = run_script(
        "volume_bench.py", "--size", "16", "--handles", "4", "--grid", "4", "--memory", "16"
    )
    rows = {line[:32].strip(): line[32:].split() for line in run.stdout.splitlines()[1:]}
    assert list(rows) == [
        "glmls quads",
        "glmls backward",
        "scipy tps (every voxel)",
        "molesq affine (scaled)",
        "glmls quads 16^3 uint16",
    ]
    for name, words in rows.items():
        if words[0] == "skipped:":
            assert name.endswith(")") and words[-2:] == ["not", "installed"]
        else:
            assert words[1:] == ["s", words[2], "MiB", "peak"] and float(words[0]) > 0


def test_volume_bench_exits_1_when_a_measurement_fails():
    run = run_script("volume_bench.py", "--size", "16", "--grid", "0", "--skip-peers", returncode=1)
    assert run.stdout.count("failed: ValueError: grid") == 2


def test_handle_reads_times_each_storage():
    """benchmarks/handle_reads.py, small: nanoseconds per handle and point for each place the
    handles can live (raw moderngl calls on glmls's context)."""
    run = run_script("handle_reads.py", "--points", "1024", "--handles", "64")
    names = [line[:20].strip() for line in run.stdout.splitlines()]
    assert {"storage buffer", "uniform block", "texture", "shared tile"} <= set(names)
    assert all(float(line.split()[-6]) > 0 for line in run.stdout.splitlines())
