"""``glmls tune --construction``'s work, called as a function: the table, construction.json and
construction.csv, options that sit beside tune's own, and mistakes as usage errors."""

from __future__ import annotations

import argparse
import csv
import json

import numpy as np
import pytest

import glmls
from glmls.analysis.construction_ranking import (
    parse_construction,
    parse_constructions,
    rank_constructions,
)
from glmls.cli import tune
from glmls.cli.main import main
from glmls.cli.options import UsageError
from glmls.cli.tune_construction import configure_construction, run_construction
from glmls.core.handleset import HandleSet

SHAPE = (64, 80)


def namespace(tmp_path, *argv, quiet=True):
    parser = argparse.ArgumentParser()
    configure_construction(parser)
    args = parser.parse_args(list(argv))
    args.out, args.quiet, args.command = str(tmp_path / "out"), quiet, "tune"
    return args


def inputs(rng):
    yy, xx = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]].astype(np.float64)
    image = np.round(127.5 + 120 * np.sin(xx / 6 + yy / 9)).astype(np.uint8)
    src = np.array([[15.0, 12.0], [65.0, 12.0], [40.0, 32.0], [15.0, 52.0], [65.0, 52.0]])
    handles = HandleSet.validate(src, src + rng.uniform(-4, 4, src.shape))
    reference = rng.uniform(12, [68, 52], (10, 2))
    return image, handles, reference


def test_writes_the_ranking(gl, rng, tmp_path, capsys):
    image, handles, reference = inputs(rng)
    args = namespace(tmp_path, "--construction-radius", "1")
    config = glmls.MLSConfig(transform="similarity")
    assert run_construction(args, image, handles, reference, "wave.png", config) == 0
    out = tmp_path / "out"
    document = json.loads((out / "construction.json").read_text())
    assert document["input"] == "wave.png"
    assert document["config"]["transform"] == "similarity"
    assert document["settings"] == {"radius": 1, "window": 3, "points": 10}
    ranking = document["ranking"]
    assert [row["rank"] for row in ranking] == list(range(1, len(ranking) + 1))
    assert {"quads nearest", "quads linear", "splat", "backward linear"} <= {
        row["label"] for row in ranking
    }
    means = [row["mean"] for row in ranking]
    assert means == sorted(means)
    with (out / "construction.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["label"] for row in rows] == [row["label"] for row in ranking]
    assert float(rows[0]["mean"]) == pytest.approx(ranking[0]["mean"])
    printed = capsys.readouterr().out
    assert printed.startswith("rank  construction")
    assert ranking[0]["label"] in printed.splitlines()[1]


def test_named_methods_and_the_handles_as_reference(gl, rng, tmp_path, capsys):
    image, handles, _ = inputs(rng)
    args = namespace(tmp_path, "--construction-methods", "splat", "quads:linear", quiet=False)
    run_construction(args, image, handles, None, "wave.png", glmls.MLSConfig())
    document = json.loads((tmp_path / "out" / "construction.json").read_text())
    assert [row["label"] for row in document["ranking"]] == ["quads linear", "splat"]
    assert document["settings"]["points"] == len(handles.src)
    assert "the source handles are the reference points" in capsys.readouterr().err


def test_mistakes_are_usage_errors(gl, rng, tmp_path):
    image, handles, reference = inputs(rng)
    args = namespace(tmp_path, "--construction-methods", "quads:cubic")
    with pytest.raises(UsageError, match="unknown interpolation"):
        run_construction(args, image, handles, reference, "wave.png", glmls.MLSConfig())
    assert not (tmp_path / "out" / "construction.json").exists()
    parser = argparse.ArgumentParser()
    configure_construction(parser)
    with pytest.raises(SystemExit):
        parser.parse_args(["--construction-radius", "-1"])


def test_options_sit_beside_tunes_own():
    parser = argparse.ArgumentParser()
    tune.configure(parser)  # adds the construction options beside its own, no clash
    args = parser.parse_args(["--example", "--out", "x", "--construction-radius", "3"])
    assert args.construction_radius == 3 and args.construction_methods is None


@pytest.mark.parametrize(
    "methods, fault",
    [
        (["quads", "quads"], "--construction-methods: 'quads' is named twice"),
        (
            ["quads", "backward", "quads:nearest"],
            "--construction-methods: 'quads:nearest' is the same construction as 'quads' "
            "(quads nearest): name each construction once",
        ),
        (["splat:linear"], "--construction-methods splat:linear: splat takes no interpolation"),
        (["splat:nearest"], "--construction-methods splat:nearest: splat takes no interpolation"),
        (["quads:"], "--construction-methods quads:: an empty interpolation after 'quads:'"),
        (["backward", ":linear"], "--construction-methods :linear: unknown method ''"),
    ],
)
def test_repeated_or_malformed_methods_are_refused_before_any_work(
    tmp_path, capsys, methods, fault
):
    args = ["tune", "--example", "--out", str(tmp_path / "out"), "--trials", "1"]
    assert main([*args, "--construction", "--construction-methods", *methods]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1, captured
    assert lines[0].startswith(f"glmls tune: {fault}"), lines
    assert not (tmp_path / "out").exists()


def test_windows_beyond_the_memory_are_refused_before_the_tune(tmp_path, capsys, monkeypatch):
    """The ranking runs after the whole tune: windows it could not hold were refused only
    then, with the tune's outputs written. Now before any work, naming the option."""
    monkeypatch.setattr(tune, "tune", lambda *a, **k: pytest.fail("the tune may not run"))
    args = ["tune", "--example", "--out", str(tmp_path / "out"), "--trials", "1"]
    assert main([*args, "--construction", "--construction-radius", "100000"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("glmls tune: --construction-radius 100000: ")
    assert "construction_errors' windows of radius 100000" in lines[0]
    assert "more than this machine's memory" in lines[0]
    assert not (tmp_path / "out").exists()


def test_the_library_refuses_them_too():
    assert parse_construction("splat") == ("splat", "nearest")
    assert parse_construction(("splat", "nearest")) == ("splat", "nearest")
    for spec, message in (
        ("splat:linear", "splat takes no interpolation, got 'linear'"),
        (("splat", "linear"), "splat takes no interpolation, got 'linear'"),
        ("quads:", "an empty interpolation after 'quads:'"),
    ):
        with pytest.raises(ValueError, match=message):
            parse_construction(spec)
    assert parse_constructions(["quads", "quads:linear", "splat"]) == [
        ("quads", "nearest"),
        ("quads", "linear"),
        ("splat", "nearest"),
    ]
    for methods, message in (
        (["quads", ("quads", "nearest")], r"\('quads', 'nearest'\) is the same construction"),
        (["backward:linear", "backward:linear"], "'backward:linear' is named twice"),
    ):
        with pytest.raises(ValueError, match=message):
            parse_constructions(methods)
        # refused before the first warp: no MLS is needed to see it
        with pytest.raises(ValueError, match=message):
            rank_constructions(np.zeros((8, 8), np.uint8), None, [[1, 1]], methods=methods)
