"""The automatic choice of configuration: search space, specs, random deformations, ranking."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.analysis import tune
from glmls.core.config import MLSConfig

SRC = np.array([[4.0, 4.0], [36.0, 6.0], [20.0, 30.0], [6.0, 26.0]])
DST = SRC + [[2.0, 1.0], [-2.0, 2.0], [4.0, -2.0], [0.0, 0.0]]
REFERENCE = np.array([[10, 10], [30, 10], [20, 25], [12, 22], [28, 22.0]])


def test_default_search_space():
    configs = tune.search_space((30, 40))
    assert len(configs) == 42  # 3 transforms x (idw: 2 alphas + 4 radius weights x 3 radii)
    radii = {c.radius for c in configs if c.radius is not None}
    assert radii == {12.5, 25.0, 50.0}  # the diagonal (50) among them


def test_config_specs():
    assert tune.parse_config("rigid:idw:alpha=2", (30, 40)) == [
        MLSConfig(transform="rigid", weight="idw", alpha=2.0)
    ]
    assert len(tune.parse_config("*:gaussian:radius=9", (30, 40))) == 3
    assert len(tune.parse_config("affine:*", (30, 40))) == 14
    for spec, message in [
        ("rigid", "expected transform:weight"),
        ("rigid:cubic", "unknown weight 'cubic'"),
        ("rigid:idw:beta=2", "name alpha, s, radius, interpolating, got 'beta=2'"),
        ("rigid:idw:alpha=x", "alpha must be a number"),
        ("rigid:idw:alpha=-1", "alpha must be > 0"),
    ]:
        with pytest.raises(ValueError, match=message):
            tune.parse_config(spec, (30, 40))


def test_random_targets_are_seeded_and_keep_pinned_handles():
    a = tune.random_targets(SRC, DST, 3, seed=5, jitter=2.0)
    b = tune.random_targets(SRC, DST, 3, seed=5, jitter=2.0)
    assert all((x == y).all() for x, y in zip(a, b, strict=True))
    assert all((t[3] == DST[3]).all() for t in a)  # q = p: pinned
    assert not (a[0][:3] == DST[:3]).any()


def test_ranking_by_each_measure(gl):
    configs = tune.parse_config("*:idw", (32, 40))
    for measure in tune.MEASURES:
        result = tune.tune((32, 40), SRC, DST, REFERENCE, trials=2, configs=configs,
                           rank_by=measure, ctx=gl)  # fmt: skip
        key = "combined" if measure == "combined" else f"{measure}_mean"
        values = [row[key] for row in result.rows]
        assert values == sorted(values)
        assert result.best == MLSConfig(**result.rows[0]["config"])
    assert min(row["combined"] for row in result.rows) >= 1.0


def test_affine_with_collinear_handles_is_skipped(gl):
    src = np.array([[0.0, 0.0], [10.0, 10.0], [20.0, 20.0]])
    configs = tune.parse_config("affine:idw", (30, 30)) + tune.parse_config("rigid:idw", (30, 30))
    result = tune.tune((30, 30), src, src + 1, REFERENCE, trials=1, configs=configs, ctx=gl)
    assert len(result.rows) == 2 and len(result.skipped) == 2
    assert "not on one line" in result.skipped[0]["reason"]


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown measure"):
        tune.tune((30, 40), SRC, DST, REFERENCE, rank_by="speed")
    with pytest.raises(ValueError, match="trials must be"):
        tune.tune((30, 40), SRC, DST, REFERENCE, trials=0)
