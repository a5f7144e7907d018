"""glmls bench: the plan, the table, the files and the runners (tiny cases; no timing)."""

from __future__ import annotations

import argparse
import csv

import numpy as np
import pytest

from glmls.cli.bench import runner as bench
from glmls.cli.bench.cases import Case, available, make_inputs, run_case


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
    assert len(cases) == 4 + 2 + 2 + 1


def test_full_plan_size():
    cases = bench.plan(bench.FULL, ["glmls"])
    assert len(cases) == 3 * 3 * 3 * 3 * 2


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
    ]


def test_table_csv_and_plot(tmp_path):
    table_rows = rows()
    bench.add_ratios(table_rows)
    assert table_rows[1]["ratio"] == pytest.approx(0.5)
    assert table_rows[2]["ratio"] == pytest.approx(50)
    text = bench.format_table(table_rows)
    assert "timeout after 1 s" in text and "50.00" in text
    bench.write_csv(table_rows, tmp_path / "b.csv")
    with open(tmp_path / "b.csv") as handle:
        read = list(csv.DictReader(handle))
    assert [r["tool"] for r in read] == ["glmls", "glmls", "skimage-pwa", "molesq"]
    assert read[3]["median_s"] == ""
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


def test_availability_is_a_reason_or_none():
    assert available("glmls") is None
    reason = available("opencv-tps")
    assert reason is None or "OpenCV" in reason or "cv2" in reason
