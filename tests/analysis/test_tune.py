"""The automatic choice of configuration: search space, specs, user-like edits, the properties
that set configurations apart, and a ranking that a global fit or a spike cannot win."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import glmls
from glmls.analysis import tuning, tuning_trials
from glmls.core.config import MLSConfig
from glmls.core.handleset import HandleSet

SRC = np.array([[4.0, 4.0], [36.0, 6.0], [20.0, 30.0], [6.0, 26.0]])
DST = SRC + [[2.0, 1.0], [-2.0, 2.0], [4.0, -2.0], [0.0, 0.0]]
REFERENCE = np.array([[10, 10], [30, 10], [20, 25], [12, 22], [28, 22.0]])


def test_default_search_space():
    configs = tuning.search_space((30, 40))
    assert len(configs) == 42  # 3 transforms x (idw: 2 alphas + 4 radius weights x 3 radii)
    radii = {c.radius for c in configs if c.radius is not None}
    assert radii == {12.5, 25.0, 50.0}  # the diagonal (50) among them
    # weights finite at d = 0 enter through their interpolating variant
    assert all(c.infinite_at_zero or c.weight == "idw" for c in configs)
    assert {c.interpolating for c in configs if c.weight == "gaussian"} == {True}
    assert {c.interpolating for c in configs if c.weight in ("idw", "shepard")} == {False}


def test_config_specs():
    assert tuning.parse_config("rigid:idw:alpha=2", (30, 40)) == [
        MLSConfig(transform="rigid", weight="idw", alpha=2.0)
    ]
    assert len(tuning.parse_config("*:gaussian:radius=9", (30, 40))) == 3
    assert len(tuning.parse_config("affine:*", (30, 40))) == 14
    for spec, message in [
        ("rigid", "expected transform:weight"),
        ("rigid:cubic", "unknown weight 'cubic'"),
        ("rigid:idw:beta=2", "name alpha, s, radius, interpolating, got 'beta=2'"),
        ("rigid:idw:alpha=x", "alpha must be a number"),
        ("rigid:idw:alpha=-1", "alpha must be a finite number > 0"),
        ("rigid:idw:alpha=1,alpha=2", "alpha given twice, as 1 and as 2"),
        ("rigid:idw:alpha=1,alpha=1", "alpha given twice"),
    ]:
        with pytest.raises(ValueError, match=message):
            tuning.parse_config(spec, (30, 40))
    # the values MLSConfig refuses name the spec too, as the others do
    for spec, message in [
        ("rigid:idw:alpha=-1", "configuration 'rigid:idw:alpha=-1': alpha must be a finite"),
        ("*:gaussian:radius=0", "configuration '\\*:gaussian:radius=0': radius must be a"),
        ("rigid:idw:s=-1", "configuration 'rigid:idw:s=-1': s must be a finite number >= 0"),
        ("cubic:idw:alpha=1", "configuration 'cubic:idw:alpha=1': unknown transform 'cubic'"),
        ("rigid:cubic:alpha=1", "configuration 'rigid:cubic:alpha=1': unknown weight 'cubic'"),
    ]:
        with pytest.raises(ValueError, match=message):
            tuning.parse_config(spec, (30, 40))


def test_random_edits_are_user_like():
    handles = HandleSet.validate(SRC, DST)
    shape = (300, 400)
    edits = tuning_trials.random_edits(handles, 7, seed=5, shape=shape)
    again = tuning_trials.random_edits(handles, 7, seed=5, shape=shape)
    assert all((a[0] == b[0]).all() for a, b in zip(edits, again, strict=True))
    np.testing.assert_array_equal(edits[0][0], DST)  # trial 0 is the user's own edit
    diagonal = math.hypot(*shape)
    for trial, (dst, _) in enumerate(edits[1:]):
        drag = np.hypot(*(dst - DST).T)
        moved = drag > 0
        assert 1 <= moved.sum() <= 3  # 1 to 3 handles dragged, the others stay
        expected = tuning_trials.MAGNITUDES[trial % len(tuning_trials.MAGNITUDES)] * diagonal
        np.testing.assert_allclose(drag[moved], expected, rtol=1e-12)
    other = tuning_trials.random_edits(handles, 7, seed=6, shape=shape)
    assert any((a[0] != b[0]).any() for a, b in zip(edits, other, strict=True))


def test_known_deformations_are_smooth_and_seeded():
    handles = HandleSet.validate(SRC, DST)
    known = tuning_trials.known_deformations(handles, 3, seed=2, shape=(30, 40))
    for dst, segments, params in known:
        assert segments.shape == (0, 2, 2)
        np.testing.assert_allclose(dst, tuning_trials.apply_known(params, SRC, 50.0))
        np.testing.assert_allclose(np.hypot(*params[:, :2].T), 1.0)


def test_rows_keep_every_statistic_and_a_reason(gl):
    configs = tuning.parse_config("rigid:idw", (32, 40)) + tuning.parse_config(
        "rigid:gaussian:radius=1000", (32, 40)
    )
    result = tuning.tune((32, 40), SRC, DST, REFERENCE, trials=3, configs=configs, ctx=gl)
    for row in result.rows:
        for key in tuning.STATISTICS:
            assert key in row or f"{key}_mean" in row, key
        assert {"config", "label", "rank", "score", "admissible", "set_apart", "pareto"} <= set(row)
        assert row["admissible"] == (not row["set_apart"])
        json.dumps(row)
    # a gaussian does not reach its targets: set apart, with the reason, after the others
    assert result.rows[-1]["label"] == "rigid gaussian R=1000"
    assert "misses its targets" in result.rows[-1]["set_apart"][0]
    assert [row["rank"] for row in result.rows] == [1, 2, 3]
    assert result.best == MLSConfig(**result.rows[0]["config"])


def test_ranking_by_each_measure(gl):
    configs = tuning.parse_config("*:idw", (32, 40))
    for measure in tuning.MEASURES:
        result = tuning.tune((32, 40), SRC, DST, REFERENCE, trials=2, configs=configs,
                           rank_by=measure, ctx=gl)  # fmt: skip
        key = "score" if measure == "rank" else f"{measure}_mean"
        admissible = [row[key] for row in result.rows if row["admissible"]]
        assert admissible == sorted(admissible)
        assert result.rows[: len(admissible)] == [r for r in result.rows if r["admissible"]]


def test_scores_are_ranks_not_ratios(gl):
    """Adding an exact configuration does not blow the other scores up: scores stay mean
    ranks, between 1 and the number of configurations."""
    configs = tuning.parse_config("*:idw", (32, 40))
    result = tuning.tune((32, 40), SRC, DST, REFERENCE, trials=2, configs=configs, ctx=gl)
    for row in result.rows:
        assert 1.0 <= row["score"] <= len(configs)
        for criterion in tuning.CRITERIA:
            assert 1.0 <= row[f"rank_{criterion}"] <= len(configs)


@pytest.fixture(scope="module")
def example_ranking(gl):
    image = glmls.data.astronaut()
    src, dst = glmls.data.astronaut_handles()
    shape = image.shape[:2]
    specs = (
        "similarity:gaussian:radius=100000",  # a global fit: changes no angle, moves no target
        "rigid:idw:alpha=0.05",  # a spike: targets reached, the image does not follow
        "rigid:idw:alpha=1",
        "similarity:idw:alpha=1",
        "rigid:gaussian:radius=362,interpolating=true",
    )
    configs = [c for spec in specs for c in tuning.parse_config(spec, shape)]
    result = tuning.tune(
        shape, src, dst, glmls.data.astronaut_reference_points(), trials=4, configs=configs,
        ctx=gl,
    )  # fmt: skip
    return result, src, dst, shape


def test_global_fit_and_spike_cannot_win(example_ranking):
    result, *_ = example_ranking
    by_label = {row["label"]: row for row in result.rows}
    spike = by_label["rigid idw a=0.05"]
    global_fit = by_label["similarity gaussian R=100000"]
    assert result.rows[0]["label"] not in (spike["label"], global_fit["label"])
    # the global fit has the smallest angular error of all, and is set apart for its misses
    assert global_fit["angle_mean"] == min(row["angle_mean"] for row in result.rows)
    assert not global_fit["admissible"] and global_fit["handle_miss_max"] > 5
    # the spike hides between the reference points, not in the fans around the handles
    assert spike["angle_mean"] < result.rows[0]["angle_mean"]
    assert spike["smoothness_mean"] > 3 * result.rows[0]["smoothness_mean"]
    assert not spike["admissible"] or spike["rank"] > 1


def test_winner_reaches_the_targets_and_performs_the_edit(gl, example_ranking):
    result, src, dst, shape = example_ranking
    best = result.rows[0]
    assert best["admissible"] and best["handle_miss_max"] <= tuning.MISS_LIMIT
    with glmls.MLS.from_config(src, dst, result.best, shape=shape, ctx=gl) as m:
        np.testing.assert_allclose(m(src), dst, atol=0.5)


def test_jobs_give_the_same_ranking(gl):
    configs = tuning.parse_config("rigid:idw", (32, 40))
    one = tuning.tune((32, 40), SRC, DST, REFERENCE, trials=2, configs=configs, ctx=gl)
    two = tuning.tune((32, 40), SRC, DST, REFERENCE, trials=2, configs=configs, jobs=2)
    assert [r["label"] for r in one.rows] == [r["label"] for r in two.rows]
    for a, b in zip(one.rows, two.rows, strict=True):
        assert a["angle_mean"] == pytest.approx(b["angle_mean"], rel=1e-9)


def test_affine_with_collinear_handles_is_skipped(gl):
    src = np.array([[0.0, 0.0], [10.0, 10.0], [20.0, 20.0]])
    configs = tuning.parse_config("affine:idw", (30, 30)) + tuning.parse_config(
        "rigid:idw", (30, 30)
    )
    result = tuning.tune((30, 30), src, src + 1, REFERENCE, trials=1, configs=configs, ctx=gl)
    assert len(result.rows) == 2 and len(result.skipped) == 2
    assert "not on one line" in result.skipped[0]["reason"]


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown rank_by 'speed'"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, rank_by="speed")
    with pytest.raises(ValueError, match="trials must be"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, trials=0)
    for keywords in ({"trials": 1.0}, {"trials": True}, {"grid": 2.0}, {"grid": None}):
        with pytest.raises(TypeError, match=f"{next(iter(keywords))} must be an integer"):
            tuning.tune((30, 40), SRC, DST, REFERENCE, **keywords)
    with pytest.raises(ValueError, match="unknown angle 'cosine'"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, angle="cosine")
    with pytest.raises(TypeError, match="angle must be a string, one of degrees, paper; got 1"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, angle=1)
    with pytest.raises(ValueError, match="seed must be an integer >= 0, got -1"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, seed=-1)
    for seed in (1.5, "0", True):
        with pytest.raises(TypeError, match="seed must be an integer >= 0, got "):
            tuning.tune((30, 40), SRC, DST, REFERENCE, seed=seed)
    with pytest.raises(ValueError, match="magnitudes"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, magnitudes=[2.0])
    with pytest.raises(ValueError, match="jobs"):
        tuning.tune(
            (30, 40), SRC, DST, REFERENCE, jobs=0, configs=tuning.search_space((30, 40))[:1]
        )
    for bad in ([], ()):
        with pytest.raises(ValueError, match="transforms must hold at least one name"):
            tuning.search_space((30, 40), transforms=bad)
        with pytest.raises(ValueError, match="weights must hold at least one name"):
            tuning.search_space((30, 40), weights=bad)
    with pytest.raises(ValueError, match="unknown weight 'idww'"):
        tuning.search_space((30, 40), weights=["idw", "idww"])
    with pytest.raises(TypeError, match="MLSConfig"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, configs=["rigid:idw"])
    with pytest.raises(ValueError, match="at least 3"):
        tuning.tune((30, 40), SRC, DST, REFERENCE[:2])


@pytest.mark.parametrize(
    "keywords, error, text",
    [({"rank_by": 1}, TypeError, "rank_by must be a string, one of rank, .*; got 1"),
     ({"rank_by": None}, TypeError, "rank_by must be a string, .*; got None"),
     ({"scheduler": 3}, TypeError, "scheduler must be a string, .*got 3"),
     ({"scheduler": " "}, ValueError, "scheduler must be 'local' or .*got ' '"),
     ({"jobs": 1.0}, TypeError, r"jobs must be an integer >= 1, got 1\.0"),
     ({"jobs": True}, TypeError, "jobs must be an integer >= 1, got True"),
     ({"magnitudes": [0.1, True]}, TypeError, r"magnitudes must be real .*True is a bool"),
     ({"magnitudes": ["0.1"]}, TypeError, r"magnitudes must be real .*'0\.1' is a str"),
     ({"magnitudes": [1j]}, TypeError, "magnitudes must be real .*1j is a complex"),
     ({"magnitudes": None}, TypeError, "magnitudes must be a sequence of numbers, got None"),
     ({"magnitudes": "0.1"}, TypeError, "magnitudes must be a sequence of numbers, got '0.1'"),
     ({"magnitudes": [np.nan]}, ValueError, r"magnitudes must be fractions .*\[0, 1\]"),
     ({"magnitudes": [-0.1]}, ValueError, r"magnitudes must be fractions .*\[0, 1\]"),
     ({"magnitudes": []}, ValueError, "magnitudes must hold at least one fraction")],
)  # fmt: skip
def test_options_of_a_wrong_type_are_type_errors_and_bad_values_value_errors(keywords, error, text):
    """One rule (``glmls.core.config``): a choice or a real of the wrong type is a
    ``TypeError``, an unknown choice or a value out of range a ``ValueError``, before any
    trial runs."""
    configs = [glmls.MLSConfig(transform="rigid")]
    with pytest.raises(error, match=f"^{text}"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, trials=1, configs=configs, **keywords)


@pytest.mark.parametrize(
    "name, value, text",
    [("transforms", "rigid", r"transform names, got 'rigid'; for one, write \['rigid'\]"),
     ("weights", "idw", r"weight names, got 'idw'; for one, write \['idw'\]"),
     ("transforms", b"rigid", "transform names, got b'rigid'"),
     ("transforms", None, "transform names, got None"),
     ("weights", 3, "weight names, got 3")],
)  # fmt: skip
def test_search_space_names_are_a_sequence_never_read_letter_by_letter(name, value, text):
    with pytest.raises(TypeError, match=f"^{name} must be a sequence of {text}"):
        tuning.search_space((30, 40), **{name: value})
    if isinstance(value, str):  # the one-name list the message offers
        assert tuning.search_space((30, 40), **{name: [value]})


@pytest.mark.parametrize(
    "configs, text",
    [("rigid:idw", r"got 'rigid:idw'; for one, write \['rigid:idw'\]"),
     (MLSConfig(transform="rigid"), r"got MLSConfig\(transform='rigid'"),
     (3, "got 3")],
)  # fmt: skip
def test_tune_configs_are_a_sequence(configs, text):
    with pytest.raises(TypeError, match=f"^configs must be a sequence of MLSConfig values, {text}"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, trials=1, configs=configs)


def test_numpy_integers_are_integers(gl):
    configs = [glmls.MLSConfig(transform="rigid")]
    found = tuning.tune(
        (30, 40), SRC, DST, REFERENCE, trials=np.int64(1), grid=np.array(2), configs=configs
    )
    assert type(found.settings["trials"]) is type(found.settings["grid"]) is int
    json.dumps(found.settings)


def test_a_configuration_given_twice_is_ranked_once(gl):
    """``rigid:idw`` holds ``rigid:idw:alpha=1``: a second row of it would be a tie that
    moves every other configuration's ranks."""
    configs = tuning.parse_config("rigid:idw", (32, 40)) + tuning.parse_config(
        "rigid:idw:alpha=1", (32, 40)
    )
    once = tuning.tune((32, 40), SRC, DST, REFERENCE, trials=1, configs=configs, ctx=gl)
    assert sorted(r["label"] for r in once.rows) == ["rigid idw a=1", "rigid idw a=2"]


@pytest.mark.parametrize("trials", [0, tuning.MAX_TRIALS + 1, 10**9])
def test_trials_are_bounded_before_any_work(trials, monkeypatch):
    """A count beyond MAX_TRIALS would run for hours: refused, naming it, before the edits
    are drawn."""

    def drawn(*args, **kwargs):
        raise AssertionError("the edits were drawn")

    monkeypatch.setattr(tuning, "random_edits", drawn)
    text = f"trials must be an integer from 1 to {tuning.MAX_TRIALS}, got {trials}$"
    with pytest.raises(ValueError, match=text):
        tuning.tune((30, 40), SRC, DST, REFERENCE, trials=trials)


def test_the_largest_trial_count_is_accepted(monkeypatch):
    counts = []

    def drawn(handles, trials, **kwargs):
        counts.append(trials)
        raise RuntimeError("stop here")

    monkeypatch.setattr(tuning, "random_edits", drawn)
    with pytest.raises(RuntimeError, match="stop here"):
        tuning.tune((30, 40), SRC, DST, REFERENCE, trials=tuning.MAX_TRIALS)
    assert counts == [tuning.MAX_TRIALS]
