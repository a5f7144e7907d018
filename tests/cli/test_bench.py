"""glmls bench: the plan, the table, the files and the runners (tiny cases; no timing)."""

from __future__ import annotations

import argparse
import csv

import numpy as np
import pytest

import glmls
from glmls.cli.bench import runner as bench
from glmls.cli.bench.cases import (
    Case,
    available,
    make_inputs,
    mismatch_percent,
    random_inputs,
    run_case,
)


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    bench.configure(parser)
    return parser.parse_args(argv)


def test_quick_plan_covers_glmls_and_each_peer():
    cases = bench.plan(bench.QUICK, ["glmls", "reference", "molesq", "skimage-pwa"])
    tools = [(c.tool, c.mode, c.grid, c.transform) for c in cases]
    assert ("glmls", "e2e", 1, "rigid") in tools and ("glmls", "frame", 4, "rigid") in tools
    assert ("molesq", "e2e", 1, "affine") in tools  # molesq has affine only
    assert ("skimage-pwa", "e2e", 0, "-") in tools  # no grid, no transform
    assert len(cases) == 2 * (4 + 2 + 2 + 1)  # both workloads
    assert {c.workload for c in cases} == {"lattice", "random"}


def test_full_plan_size():
    cases = bench.plan(bench.FULL, ["glmls"])
    assert len(cases) == 2 * 3 * 3 * 3 * 3 * 2


def test_tolerances_add_adaptive_glmls_cases_only():
    settings = bench.QUICK | {"tolerances": [0.05, 0.25], "workloads": ["random"]}
    cases = bench.plan(settings, ["glmls", "reference"])
    adaptive = [c for c in cases if c.tolerance]
    assert {(c.tool, c.tolerance) for c in adaptive} == {("glmls", 0.05), ("glmls", 0.25)}
    assert len(adaptive) == 2 * 2  # e2e and frame
    assert all(c.grid == 0 and c.warp_options() == {"tolerance": c.tolerance} for c in adaptive)
    assert parse("--tolerances", "0.05,0.25").tolerances == [0.05, 0.25]
    with pytest.raises(SystemExit):
        parse("--tolerances", "-1")


def rows():
    case = dict(size=64, handles=4, transform="rigid", status="ok", runs=3, peak_mb=100.0)
    return [
        case | dict(tool="glmls", mode="e2e", grid=1, median_s=0.01, min_s=0.009, max_s=0.02),
        case | dict(tool="glmls", mode="frame", grid=1, median_s=0.005, min_s=0.004, max_s=0.006),
        case
        | dict(tool="skimage-pwa", mode="e2e", grid=0, transform="-")
        | dict(median_s=0.5, min_s=0.4, max_s=0.7),
        dict(tool="molesq", mode="e2e", size=64, handles=4, grid=1, transform="affine")
        | dict(status="timeout after 1 s"),
        case
        | dict(tool="glmls", mode="e2e", grid=0, tolerance=0.05, workload="random")
        | dict(median_s=0.002, min_s=0.002, max_s=0.003, error_percent=0.25),
    ]


def test_table_csv_and_plot(tmp_path):
    table_rows = rows()
    bench.add_ratios(table_rows)
    assert table_rows[1]["ratio"] == pytest.approx(0.5)
    assert table_rows[2]["ratio"] == pytest.approx(50)
    text = bench.format_table(table_rows)
    assert "timeout after 1 s" in text and "50.00" in text
    assert "t0.05" in text and "0.25" in text  # the adaptive mesh and its error column
    assert "ratio" not in table_rows[4]  # no glmls grid-1 random row to compare with
    bench.write_csv(table_rows, tmp_path / "b.csv")
    with open(tmp_path / "b.csv") as handle:
        read = list(csv.DictReader(handle))
    assert [r["tool"] for r in read] == ["glmls", "glmls", "skimage-pwa", "molesq", "glmls"]
    assert read[3]["median_s"] == ""
    assert read[4]["tolerance"] == "0.05" and read[4]["error_percent"] == "0.25"
    bench.plot(table_rows, tmp_path / "b.png")
    assert (tmp_path / "b.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_usage_errors_exit_2_with_one_line(capsys, monkeypatch):
    monkeypatch.setattr(bench, "_spawn", lambda *a: pytest.fail("no case may run"))
    assert bench.run(parse("--repeat", "0")) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["glmls bench: --repeat must be >= 1, got 0"]
    assert bench.main(["--sizes", "a,b"]) == 2
    assert bench.run(parse("--tools", "molesq")) == 2
    assert "glmls must be among --tools" in capsys.readouterr().err


@pytest.mark.parametrize("timeout", ["inf", "1e10", "nan", "-1", "0"])
def test_a_timeout_the_wait_cannot_take_is_refused(capsys, monkeypatch, timeout):
    """inf and 1e10 s overflowed the child's wait (a traceback, after the first case began)."""
    monkeypatch.setattr(bench, "_spawn", lambda *a: pytest.fail("no case may run"))
    assert bench.run(parse("--timeout", timeout)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--timeout must be > 0 and at most 604800 s" in err[0], err
    assert bench.MAX_TIMEOUT == 7 * 86400


@pytest.mark.parametrize(
    ("option", "value", "words"),
    [
        ("--sizes", "64,,64", "expected integers separated by commas"),
        ("--sizes", "64,", "expected integers separated by commas"),
        ("--sizes", "64,32,64", "64 given twice"),
        ("--handles", "16, 16", "16 given twice"),
        ("--tolerances", "0.05,0.05", "0.05 given twice"),
        ("--tools", "glmls,,molesq", "expected names separated by commas"),
        ("--tools", "glmls,glmls", "glmls given twice"),
    ],
)
def test_lists_with_an_empty_or_repeated_item_are_refused(capsys, option, value, words):
    """A repeated size ran twice, and the table compared a case with its own second run."""
    with pytest.raises(SystemExit) as stopped:
        parse(option, value)
    assert stopped.value.code == 2
    assert words in capsys.readouterr().err
    assert parse(option, value.replace(",,", ",").rstrip(",").split(",")[0])  # one item: fine


def test_inputs_are_reproducible():
    a = make_inputs(64, 10)
    b = make_inputs(64, 10)
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x, y)
    image, src, dst = a
    assert image.shape == (64, 64, 3) and image.dtype == np.uint8
    assert src.shape == dst.shape == (10, 2)
    assert np.abs(dst - src).max() <= 0.04 * 64


@pytest.mark.parametrize(
    ("tool", "mode"), [("glmls", "e2e"), ("glmls", "frame"), ("reference", "e2e")]
)
def test_runners(gl, tool, mode):
    result = run_case(Case(tool, mode, 48, 5, 4, "similarity"), repeat=2)
    assert len(result["times"]) == 2 and min(result["times"]) > 0
    assert result["peak_mb"] > 10
    if mode == "frame":
        assert result["error_percent"] is None  # a frame is not read back
    else:
        assert 0 <= result["error_percent"] <= 100


def test_random_workload_folds_and_the_error_column(gl):
    image, src, dst = random_inputs(128, 12)
    again = random_inputs(128, 12)
    assert all(np.array_equal(a, b) for a, b in zip((image, src, dst), again, strict=True))
    assert np.abs(dst - src).max() <= 35 / 1024 * 128
    assert ((src >= 0.05 * 128) & (src <= 0.95 * 128)).all()
    with glmls.MLS(src, dst, transform="rigid", shape=image.shape, ctx=gl) as m:
        exact = m.warp(image, method="backward", grid=1)
        coarse = m.warp(image, grid=8)
    assert mismatch_percent(image, src, dst, "rigid", exact) == 0.0
    assert 0 < mismatch_percent(image, src, dst, "rigid", coarse) < 100
    assert mismatch_percent(image, src, dst, "rigid", None) is None
    result = run_case(Case("glmls", "e2e", 64, 8, 1, "rigid", "random"), repeat=1)
    assert result["error_percent"] < 5  # per-pixel quads: nearly f's exact inverse


def test_availability_is_a_reason_or_none():
    assert available("glmls") is None
    reason = available("opencv-tps")
    assert reason is None or "OpenCV" in reason or "cv2" in reason


@pytest.mark.parametrize("existing", [False, True])
def test_a_stopped_run_leaves_no_empty_out_folder(tmp_path, monkeypatch, existing):
    """Ctrl-C during the first case: the --out folder the run made goes with it; one the
    user had stays."""

    def interrupted(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(bench, "_spawn", interrupted)
    out = tmp_path / "runs" / "bench"
    if existing:
        out.mkdir(parents=True)
    with pytest.raises(KeyboardInterrupt):
        bench.run(parse("--quick", "--tools", "glmls", "--out", str(out)))
    assert out.exists() == existing
    assert (tmp_path / "runs").exists() == existing


def test_a_folder_in_the_place_of_an_output_is_refused_before_the_runs(
    tmp_path, capsys, monkeypatch
):
    monkeypatch.setattr(bench, "_spawn", lambda *a: pytest.fail("no case may run"))
    (tmp_path / "bench.png").mkdir()
    assert bench.run(parse("--quick", "--tools", "glmls", "--out", str(tmp_path))) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"glmls bench: {tmp_path / 'bench.png'}: an output's name, but it exists and is not a file"
    ]
