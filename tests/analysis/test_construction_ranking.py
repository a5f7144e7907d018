"""Ranking constructions by the construction error: the order follows the metric, the defaults
follow glmls.METHODS, and bad specs are named."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.analysis import construction_ranking
from glmls.analysis.construction import construction_errors
from glmls.analysis.construction_ranking import (
    default_constructions,
    parse_construction,
    rank_constructions,
)
from glmls.imaging import source

SHAPE = (64, 96)


def smooth_image():
    yy, xx = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]].astype(np.float64)
    channels = [np.sin(xx / 6 + yy / 10), np.cos(yy / 5), np.sin((xx - yy) / 8)]
    return np.round(127.5 + 120 * np.stack(channels, -1)).astype(np.uint8)


def magnifying(gl):
    """A similarity map that scales by 1.6 about the centre: splat leaves holes."""
    centre = np.array([SHAPE[1] - 1, SHAPE[0] - 1]) / 2
    src = centre + np.array([[-20.0, -20.0], [20.0, -20.0], [20.0, 20.0], [-20.0, 20.0]])
    return glmls.MLS(src, centre + 1.6 * (src - centre), transform="similarity", ctx=gl)


def test_ranking_follows_the_metric(gl, rng):
    image = smooth_image()
    centre = np.array([SHAPE[1] - 1, SHAPE[0] - 1]) / 2
    points = centre + rng.uniform(-14, 14, (20, 2))
    with magnifying(gl) as m:
        rows = rank_constructions(image, m, points)
        recomputed = {}
        for row in rows:
            output = m.warp(image, method=row["method"], interpolation=row["interpolation"])
            recomputed[row["label"]] = construction_errors(image, output, m, points).stats()
    labels = [row["label"] for row in rows]
    expected = {f"{m} {i}" if m != "splat" else m for m, i in default_constructions()}
    assert set(labels) == expected
    assert [row["rank"] for row in rows] == list(range(1, len(rows) + 1))
    means = [row["mean"] for row in rows]
    assert means == sorted(means)
    for row in rows:
        assert row["stats"] == recomputed[row["label"]]  # the warp is deterministic
        assert row["mean"] == row["stats"]["mean"] and row["time_s"] > 0
    assert labels[-1] == "splat"
    assert labels.index("quads linear") < labels.index("quads nearest")
    assert labels.index("backward linear") < labels.index("backward nearest")


def test_named_methods_and_bad_specs(gl, rng):
    image = smooth_image()
    points = rng.uniform(20, 44, (8, 2))
    with magnifying(gl) as m:
        rows = rank_constructions(
            image, m, points, methods=["splat", ("quads", "linear")], radius=1, repeat=2
        )
        assert [row["label"] for row in rows] == ["quads linear", "splat"]
        for methods, message in (
            (["fold"], "unknown method"),
            (["quads:cubic"], "unknown interpolation"),
            ([3], "a construction is"),
            ([], "methods is empty"),
        ):
            with pytest.raises(ValueError, match=message):
                rank_constructions(image, m, points, methods=methods)
        with pytest.raises(ValueError, match="repeat"):
            rank_constructions(image, m, points, repeat=0)
        with pytest.raises(ValueError, match="radius"):
            rank_constructions(image, m, points, radius=-1)
        with pytest.raises(ValueError, match="border"):
            rank_constructions(image, m, points, border="mirror")
    assert parse_construction("backward") == ("backward", "nearest")
    assert parse_construction("quads:linear") == ("quads", "linear")


class RefusingPaperQuads:
    """An MLS whose warp does not offer ``paper-quads`` with linear interpolation."""

    def __init__(self, m):
        self.m = m

    def __call__(self, points):
        return self.m(points)

    def warp(self, image, **options):
        if options["method"] == "paper-quads" and options["interpolation"] == "linear":
            raise ValueError("paper-quads has no linear interpolation")
        if options["method"] == "paper-quads":
            options = options | {"method": "quads"}  # a stand-in where the build lacks it
        return self.m.warp(image, **options)


def test_defaults_follow_methods_at_call_time(gl, rng, monkeypatch):
    base = tuple(m for m in source.METHODS if m != "paper-quads")
    monkeypatch.setattr(source, "METHODS", base)
    assert ("paper-quads", "nearest") not in default_constructions()
    assert ("backward-swap", "nearest") not in default_constructions()
    monkeypatch.setattr(source, "METHODS", (*base, "paper-quads"))
    assert ("paper-quads", "nearest") in construction_ranking.default_constructions()
    image = smooth_image()
    points = rng.uniform(20, 44, (8, 2))
    with magnifying(gl) as m:
        rows = rank_constructions(image, RefusingPaperQuads(m), points)
        labels = [row["label"] for row in rows]
        assert "paper-quads nearest" in labels and "paper-quads linear" not in labels
        with pytest.raises(ValueError, match="no linear"):  # named: the refusal is reported
            rank_constructions(image, RefusingPaperQuads(m), points, methods=["paper-quads:linear"])
