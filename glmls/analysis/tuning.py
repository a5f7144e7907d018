"""Choosing the configuration automatically (the paper's section 6), by what users want.

Every configuration of a search space meets the same seeded trials (:mod:`.tune_trials`):
the user's own edit, user-like edits of it (1 to 3 handles dragged by several magnitudes, the
others pinned) and known smooth deformations. A configuration must first have the properties
the paper asks of MLS (section 2); those that do not are **set apart**, with the reason:

- interpolation: every handle within ``MISS_LIMIT`` (0.5 px) of its target in every
  trial;
- no fold-overs: no reference, mesh or fan triangle turned over or crushed to zero area in
  any trial.

The rest are ranked by several criteria at once (``CRITERIA``): in each trial every
criterion ranks the configurations (1 = best, ties share the mean rank), and a configuration's
``score`` is the weighted mean of its ranks over the criteria and trials. The angular error of
the reference triangles is the main criterion (weight 0.4), as the paper recommends; the
smoothness around the handles (a spike cannot hide there), the predictive error on known
deformations, E_MLS and the distance error share the rest. Ranks, not ratios: no value is
ever divided by the run's best, so one exact configuration cannot blow the others' scores up.
``pareto`` marks the admissible configurations that no other admissible one beats on every
criterion's mean (a set-apart one is never marked, and beats none).

Set-apart configurations follow the ranked ones (those that only fold before those that miss
their targets), ranked the same way among themselves.

``rank_by`` a single criterion instead of ``"rank"`` orders each group by that criterion's
mean over the trials.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np

from ..core.config import (
    RADIUS_WEIGHTS,
    TRANSFORMS,
    WEIGHTS,
    MLSConfig,
    check_choice,
    check_integer,
    check_real,
    check_seed,
    check_sequence,
    image_diagonal,
)
from ..core.handleset import HandleSet
from ..core.mesh import as_shape, check_grid
from ..errors import DegenerateHandlesError
from ..gl.context import GLContext
from .jobs import check_jobs, check_scheduler, run_jobs
from .triangles import check_angle_measure, check_reference_points
from .tuning_trials import MAGNITUDES, known_deformations, measure_config, random_edits

__all__ = [
    "CRITERIA",
    "MAX_TRIALS",
    "MEASURES",
    "MISS_LIMIT",
    "TuneResult",
    "label",
    "parse_config",
    "search_space",
    "tune",
]

#: The ranking criteria and their weights in the score (lower is better for each).
CRITERIA = {"angle": 0.4, "smoothness": 0.2, "predictive": 0.2, "mls": 0.1, "distance": 0.1}
#: What ``rank_by`` accepts: the weighted rank, or one criterion alone.
MEASURES = ("rank", *CRITERIA)
#: Largest distance (px) between f(p_i) and q_i for a configuration that interpolates.
MISS_LIMIT = 0.5
#: Most trials per configuration: each is a warp and its analysis (~0.08 s on a CPU
#: renderer), so 1,000 over the default 42 configurations is already an hour, and a mean
#: rank over that many trials no longer moves; a larger count is a typing slip.
MAX_TRIALS = 1000
#: Every statistic measured in a trial (see :mod:`.tune_trials`).
STATISTICS = (
    "angle",
    "smoothness",
    "mesh_angle",
    "predictive",
    "mls",
    "distance",
    "handle_miss",
    "handle_miss_max",
    "folds",
)
#: The parameters a configuration spec may set (every MLSConfig field but the names), with
#: their defaults.
_PARAMETERS = {
    f.name: f.default
    for f in dataclasses.fields(MLSConfig)
    if f.name not in ("transform", "weight")
}
IDW_ALPHAS = (1.0, 2.0)
RADIUS_FRACTIONS = (0.25, 0.5, 1.0)  # of the image diagonal


def search_space(
    shape: Sequence[int],
    *,
    transforms: Sequence[str] = TRANSFORMS,
    weights: Sequence[str] = WEIGHTS,
) -> list[MLSConfig]:
    """The default configurations: each transform x each weight x a small parameter grid
    (idw alpha 1 and 2; radius a quarter, half and all of the image diagonal). Weights that
    are finite at d = 0 (cressman, gaussian, linear) do not reach their targets: they enter
    through their ``interpolating=True`` variant, which does. ``ValueError`` for an empty
    list of names or an unknown name; ``TypeError`` for a bare name (``"rigid"``, not
    ``["rigid"]``), another value that is no sequence, or a name that is no string."""
    transforms = check_sequence("transforms", transforms, "transform names")
    weights = check_sequence("weights", weights, "weight names")
    for name, values in (("transforms", transforms), ("weights", weights)):
        if not values:
            raise ValueError(f"{name} must hold at least one name, got {values!r}")
    diagonal = image_diagonal(as_shape(shape))
    configs = []
    for transform in transforms:
        for weight in weights:
            if weight in RADIUS_WEIGHTS:
                for f in RADIUS_FRACTIONS:
                    config = MLSConfig(
                        transform=transform, weight=weight, radius=round(f * diagonal, 1)
                    )
                    if not config.infinite_at_zero:
                        config = dataclasses.replace(config, interpolating=True)
                    configs.append(config)
            else:
                configs += [
                    MLSConfig(transform=transform, weight=weight, alpha=a) for a in IDW_ALPHAS
                ]
    return configs


def parse_config(spec: str, shape: Sequence[int]) -> list[MLSConfig]:
    """``transform:weight[:name=value,...]``; ``*`` for all transforms or weights; without
    parameters, the default grid of ``search_space``. E.g. ``rigid:idw:alpha=2``,
    ``*:gaussian:radius=300``, ``affine:*``."""
    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise ValueError(f"configuration {spec!r}: expected transform:weight[:name=value,...]")
    transforms = TRANSFORMS if parts[0] == "*" else (parts[0],)
    weights = WEIGHTS if parts[1] == "*" else (parts[1],)
    if len(parts) == 2:
        for name, choices in (("transform", TRANSFORMS), ("weight", WEIGHTS)):
            value = parts[0] if name == "transform" else parts[1]
            if value != "*" and value not in choices:
                raise ValueError(
                    f"configuration {spec!r}: unknown {name} {value!r}; "
                    f"choose one of {', '.join(choices)} or *"
                )
        return search_space(shape, transforms=transforms, weights=weights)
    options: dict[str, object] = {}
    given: dict[str, str] = {}
    for item in parts[2].split(","):
        name, _, value = item.partition("=")
        if name not in _PARAMETERS or not value:
            raise ValueError(
                f"configuration {spec!r}: expected name=value with name "
                f"{', '.join(_PARAMETERS)}, got {item!r}"
            )
        if name in given:  # which one was meant is the user's to say
            raise ValueError(
                f"configuration {spec!r}: {name} given twice, as {given[name]} and as {value}"
            )
        given[name] = value
        if isinstance(_PARAMETERS[name], bool):
            if value not in ("true", "false"):
                raise ValueError(f"configuration {spec!r}: {name}=true or false")
            options[name] = value == "true"
        else:
            try:
                options[name] = float(value)
            except ValueError:
                raise ValueError(f"configuration {spec!r}: {name} must be a number") from None
    try:
        return [MLSConfig(transform=t, weight=w, **options) for t in transforms for w in weights]
    except ValueError as error:  # an unknown name or a value out of range: say which spec
        raise ValueError(f"configuration {spec!r}: {error}") from None


def label(config: MLSConfig) -> str:
    """A short name such as ``rigid idw a=2``, ``affine gaussian R=362`` or ``rigid gaussian
    R=362 interp a=2`` (the power of the interpolating factor, where it is not 1)."""
    if config.weight == "idw":
        parameter = f"a={config.alpha:g}" + (f" s={config.s:g}" if config.s != 1e-8 else "")
    else:
        parameter = f"R={config.radius:g}" if config.radius is not None else "R=diag"
    extra = " interp" if config.interpolating else ""
    if config.interpolating and config.weight != "idw" and config.alpha != 1.0:
        extra += f" a={config.alpha:g}"  # the interpolating factor's power, 1 / d^(2 alpha)
    return f"{config.transform} {config.weight} {parameter}{extra}"


@dataclasses.dataclass(frozen=True)
class TuneResult:
    """What :func:`tune` found: the configurations ranked, best first.

    Attributes
    ----------
    rows : list of dict
        One dict per configuration, best first, with ``config`` (the
        :class:`~glmls.MLSConfig`'s fields), ``label``, ``rank``, ``score``, ``admissible``,
        ``set_apart`` (the reasons, empty when admissible), ``pareto``, each criterion's mean
        rank ``rank_<criterion>``, and every statistic's mean over the trials
        ``<statistic>_mean`` and spread ``<statistic>_spread`` (population std;
        ``handle_miss_max`` is the largest over the trials, ``fold_trials`` counts the
        trials with folds).
    skipped : list of dict
        Configurations that cannot be built for these handles: ``config`` and ``reason``.
    rank_by : str
        ``"rank"`` or the criterion the rows are ordered by.
    settings : dict
        JSON-ready: trials, seed, grid, magnitudes, angle, criteria and their weights, the
        miss limit and the image diagonal.

    Examples
    --------
    >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
    >>> dst = src.copy()
    >>> dst[3] = [24.0, 24.0]
    >>> points = [[8, 8], [24, 8], [8, 24], [24, 24], [16, 16]]
    >>> configs = [glmls.MLSConfig(transform="rigid"), glmls.MLSConfig(transform="affine")]
    >>> result = glmls.analysis.tune((32, 32), src, dst, points, trials=1, configs=configs)
    >>> [(row["rank"], row["label"], row["admissible"]) for row in result.rows]
    [(1, 'affine idw a=1', True), (2, 'rigid idw a=1', True)]
    >>> result.best.transform, result.skipped, result.settings["trials"]
    ('affine', [], 1)
    """

    rows: list[dict]
    skipped: list[dict]
    rank_by: str
    settings: dict

    @property
    def best(self) -> MLSConfig:
        """The first row's configuration, as an :class:`~glmls.MLSConfig`.

        Examples
        --------
        >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
        >>> dst = src.copy()
        >>> dst[3] = [24.0, 24.0]
        >>> configs = [glmls.MLSConfig(transform="rigid"), glmls.MLSConfig(transform="affine")]
        >>> result = glmls.analysis.tune((32, 32), src, dst, [[8, 8], [24, 8], [16, 20]],
        ...                              trials=1, configs=configs)
        >>> result.rows[0]["label"], result.best.transform, result.best.weight
        ('affine idw a=1', 'affine', 'idw')
        >>> result.best == glmls.MLSConfig(**result.rows[0]["config"])
        True
        """
        return MLSConfig(**self.rows[0]["config"])

    def standing(self, row: dict) -> tuple:
        """What orders ``row`` among the rows; the tune orders rows of one standing by label.

        Rows of equal standing it cannot tell apart (one handle: every configuration is the
        same translation).

        Parameters
        ----------
        row : dict
            One of ``rows``.

        Returns
        -------
        tuple
            Its group (admissible, and whether it misses its targets), its value of
            ``rank_by`` and its score.

        Examples
        --------
        >>> configs = [glmls.MLSConfig(transform=t) for t in ("rigid", "similarity")]
        >>> result = glmls.analysis.tune((32, 32), [[8.0, 8.0]], [[10.0, 9.0]],
        ...                              [[4, 4], [28, 4], [16, 28]], trials=1, configs=configs)
        >>> result.standing(result.rows[0]) == result.standing(result.rows[1])
        True
        """
        key = "score" if self.rank_by == "rank" else f"{self.rank_by}_mean"
        missing = row.get("handle_miss_max", 0.0) > MISS_LIMIT
        score = row.get("score", row.get("combined"))
        return (row.get("admissible"), missing, row.get(key, score), score)

    @property
    def tied_with_best(self) -> list[str]:
        """The labels of the rows tied with the first, put after it by label only.

        Ties are rows of the first's :meth:`standing`.

        Examples
        --------
        >>> configs = [glmls.MLSConfig(transform=t) for t in ("rigid", "similarity")]
        >>> result = glmls.analysis.tune((32, 32), [[8.0, 8.0]], [[10.0, 9.0]],
        ...                              [[4, 4], [28, 4], [16, 28]], trials=1, configs=configs)
        >>> result.rows[0]["label"], result.tied_with_best
        ('rigid idw a=1', ['similarity idw a=1'])
        """
        if not self.rows:
            return []
        first = self.standing(self.rows[0])
        return [row["label"] for row in self.rows[1:] if self.standing(row) == first]


def _summarise(config: MLSConfig, trials: list[dict[str, float]]) -> dict:
    row: dict = {"config": dataclasses.asdict(config), "label": label(config)}
    for key in STATISTICS:
        values = np.array([t[key] for t in trials])
        if key == "handle_miss_max":
            row[f"{key}"] = float(values.max())
            continue
        row[f"{key}_mean"] = float(values.mean())
        row[f"{key}_spread"] = float(values.std()) if np.isfinite(values).all() else math.inf
    folds = np.array([t["folds"] for t in trials])
    row["fold_trials"] = int(np.count_nonzero(folds))
    reasons = []
    if not row["handle_miss_max"] <= MISS_LIMIT:
        reasons.append(
            f"misses its targets by up to {row['handle_miss_max']:.3g} px (> {MISS_LIMIT})"
        )
    if row["fold_trials"]:
        reasons.append(f"folds over in {row['fold_trials']} of {len(trials)} trials")
    row["set_apart"] = reasons
    row["admissible"] = not reasons
    row["_trials"] = trials
    return row


def _tier(row: dict) -> int:
    """0: admissible; 1: only folds; 2: misses its targets."""
    if row["admissible"]:
        return 0
    return 2 if row["handle_miss_max"] > MISS_LIMIT else 1


def _score_group(rows: list[dict]) -> None:
    """Each criterion's ranks per trial among ``rows``, and the weighted mean rank."""
    from scipy.stats import rankdata  # here: scipy.stats takes ~0.7 s to import

    if not rows:
        return
    trials = len(rows[0]["_trials"])
    for criterion in CRITERIA:
        values = np.array([[r["_trials"][t][criterion] for r in rows] for t in range(trials)])
        values = np.where(np.isnan(values), np.inf, values)  # undefined counts as worst
        ranks = rankdata(values, axis=1, method="average").mean(axis=0)
        for row, rank in zip(rows, ranks, strict=True):
            row[f"rank_{criterion}"] = float(rank)
    for row in rows:
        row["score"] = float(sum(w * row[f"rank_{c}"] for c, w in CRITERIA.items()))
    means = np.array([[r[f"{c}_mean"] for c in CRITERIA] for r in rows])
    for i, row in enumerate(rows):
        beaten = np.all(means <= means[i], axis=1) & np.any(means < means[i], axis=1)
        row["pareto"] = bool(row["admissible"] and not beaten.any())


def _rank(rows: list[dict], rank_by: str) -> None:
    groups: dict[int, list[dict]] = {}
    for row in rows:
        groups.setdefault(_tier(row), []).append(row)
    for group in groups.values():
        _score_group(group)
    key = "score" if rank_by == "rank" else f"{rank_by}_mean"
    rows.sort(key=lambda r: (_tier(r), r[key], r["score"], r["label"]))
    for rank, row in enumerate(rows, 1):
        row["rank"] = rank
        del row["_trials"]


@dataclasses.dataclass(frozen=True)
class _Job:
    """One configuration's trials, as sent to a worker."""

    config: MLSConfig
    handles: HandleSet
    shape: tuple[int, int]
    reference: np.ndarray
    edits: list
    known: list
    grid: int
    angle: str


def _run_job(job: _Job, ctx: GLContext | None = None) -> list[dict] | str:
    """The trials' measures, or why the configuration cannot be built."""
    try:
        return measure_config(
            job.config,
            job.handles,
            job.shape,
            job.reference,
            job.edits,
            job.known,
            grid=job.grid,
            angle=job.angle,
            ctx=ctx,
        )
    except DegenerateHandlesError as error:
        return str(error)


def _check_magnitudes(magnitudes: object) -> tuple[float, ...]:
    """``magnitudes`` as a non-empty tuple of fractions in [0, 1], each one by
    :func:`~glmls.core.config.check_real`: ``TypeError`` for a value that is no sequence of
    real numbers (a string, None, a bool or a complex in it), ``ValueError`` for an empty
    one or a fraction that is NaN, infinite or outside [0, 1]; both name the value."""
    message = f"magnitudes must be a sequence of numbers, got {magnitudes!r}"
    if isinstance(magnitudes, (str, bytes)):
        raise TypeError(message)
    try:
        given = list(magnitudes)  # type: ignore[call-overload]
    except TypeError:  # None, a number, a 0-d array
        raise TypeError(message) from None
    values = []
    for value in given:
        try:
            values.append(check_real("magnitudes", value, low=0.0, high=1.0))
        except TypeError:
            raise TypeError(
                f"magnitudes must be real numbers, got {magnitudes!r} ({value!r} is a "
                f"{type(value).__name__})"
            ) from None
        except ValueError:
            raise ValueError(
                f"magnitudes must be fractions of the diagonal in [0, 1], got {magnitudes!r}"
            ) from None
    if not values:
        raise ValueError(f"magnitudes must hold at least one fraction, got {magnitudes!r}")
    return tuple(values)


def tune(
    shape: Sequence[int],
    src: object,
    dst: object,
    reference_points: object,
    *,
    src_segments: object = None,
    dst_segments: object = None,
    trials: int = 6,
    seed: int = 0,
    configs: Sequence[MLSConfig] | None = None,
    grid: int = 4,
    magnitudes: Sequence[float] = MAGNITUDES,
    angle: str = "degrees",
    rank_by: str = "rank",
    jobs: int = 1,
    scheduler: str | None = None,
    ctx: GLContext | None = None,
    on_step: Callable[[], None] | None = None,
) -> TuneResult:
    """Choose the configuration automatically (the paper's section 6): rank configurations.

    Every configuration meets the same seeded trials: the user's edit, user-like edits of
    it and known smooth deformations (``glmls.analysis.tuning``). Those that miss their
    targets (by more than ``MISS_LIMIT``) or fold over are set apart; the rest are
    ranked by the weighted mean of their ranks over the criteria (``CRITERIA``: the
    angular error of the reference triangles, eq. 11, first) and the trials.

    Parameters
    ----------
    shape : sequence of int
        (H, W) of the image.
    src, dst : array_like
        Point handles, (N, 2) each.
    reference_points : array_like
        The points of the reference triangles, (K, 2) with K >= 3.
    src_segments, dst_segments : array_like, optional
        Segment handles, (S, 2, 2) each, as for :class:`~glmls.MLS`.
    trials : int, optional
        The user's edit and ``trials - 1`` edits of it, 1 to ``MAX_TRIALS``.
    seed : int, optional
        The seed of the edits.
    configs : sequence of MLSConfig, optional
        The configurations compared (default ``search_space``); one given twice is
        compared once.
    grid : int, optional
        The error field's mesh step in pixels.
    magnitudes : sequence of float, optional
        The drags of the edits, as fractions of the image diagonal in [0, 1].
    angle : {"degrees", "paper"}, optional
        The angular measure of :func:`triangle_errors`.
    rank_by : str, optional
        ``"rank"`` (the weighted rank) or one of ``CRITERIA`` alone.
    jobs : int, optional
        Worker processes sharing the configurations (:func:`run_jobs`).
    scheduler : str, optional
        A Dask scheduler (``"local"`` or an address) instead of ``jobs``.
    ctx : GLContext, optional
        The context for the work done in this process.
    on_step : callable, optional
        Called once per configuration and trial, for progress.

    Returns
    -------
    TuneResult
        The configurations ranked, best first, and those that could not be built.

    Raises
    ------
    ValueError
        For a bad shape, handles (or none at all), reference points, trials (< 1 or more
        than ``MAX_TRIALS``), seed
        (< 0), grid (out of range), jobs (< 1), magnitudes (none, or one that is not a
        finite fraction in [0, 1]), an unknown angle or ``rank_by``, a blank scheduler, no
        configurations, or none that can be built for these handles.
    TypeError
        For configurations that are not :class:`~glmls.MLSConfig` values, trials, seed,
        grid or jobs that are not integers (2.0 is none), magnitudes that are not real
        numbers (a bool is none), or an angle, ``rank_by`` or scheduler that is no string.

    See Also
    --------
    study : the same tune over a set of images.

    Examples
    --------
    >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
    >>> dst = src.copy()
    >>> dst[3] = [24.0, 24.0]
    >>> points = [[8, 8], [24, 8], [8, 24], [24, 24], [16, 16]]
    >>> configs = [glmls.MLSConfig(transform="rigid"), glmls.MLSConfig(transform="affine")]
    >>> result = glmls.analysis.tune((32, 32), src, dst, points, trials=1, configs=configs)
    >>> [row["label"] for row in result.rows]
    ['affine idw a=1', 'rigid idw a=1']
    >>> round(result.rows[0]["score"], 2), result.rows[0]["set_apart"]
    (1.4, [])
    """
    shape = as_shape(shape)
    rank_by = check_choice("rank_by", rank_by, MEASURES)
    angle = check_angle_measure(angle)
    trials, grid = check_integer("trials", trials, 1, MAX_TRIALS), check_grid(grid)
    seed, jobs, scheduler = check_seed(seed), check_jobs(jobs), check_scheduler(scheduler)
    magnitudes = _check_magnitudes(magnitudes)
    if configs is None:
        configs = search_space(shape)
    configs = check_sequence("configs", configs, "MLSConfig values")
    if not configs:
        raise ValueError("no configurations to compare")
    for config in configs:
        if not isinstance(config, MLSConfig):
            raise TypeError(f"configs must be MLSConfig values, got {config!r}")
    configs = list(dict.fromkeys(configs))  # a repeat would tie with itself, moving the others
    handles = HandleSet.validate(src, dst, src_segments, dst_segments)
    if not len(handles):  # every configuration is the identity: nothing to compare
        raise ValueError("tune needs at least one handle (a point or a segment), got none")
    reference = check_reference_points(reference_points)
    edits = random_edits(handles, trials, seed=seed, shape=shape, magnitudes=magnitudes)
    known = known_deformations(handles, trials, seed=seed, shape=shape, magnitudes=magnitudes)
    work = [_Job(c, handles, shape, reference, edits, known, grid, angle) for c in configs]

    def advance(_index: int, _result: object) -> None:
        for _ in range(trials):
            if on_step is not None:
                on_step()

    if jobs == 1 and scheduler is None:
        results = []
        for job in work:
            results.append(_run_job(job, ctx))
            advance(0, None)
    else:
        results = run_jobs(_run_job, work, jobs=jobs, scheduler=scheduler, on_result=advance)
    rows, skipped = [], []
    for config, result in zip(configs, results, strict=True):
        if isinstance(result, str):
            skipped.append({"config": dataclasses.asdict(config), "reason": result})
        else:
            rows.append(_summarise(config, result))
    if not rows:
        raise ValueError("no configuration could be evaluated: " + skipped[0]["reason"])
    _rank(rows, rank_by)
    settings = {
        "trials": trials,
        "seed": seed,
        "grid": grid,
        "magnitudes": list(magnitudes),
        "angle": angle,
        "criteria": dict(CRITERIA),
        "miss_limit_px": MISS_LIMIT,
        "diagonal_px": image_diagonal(shape),
    }
    return TuneResult(rows, skipped, rank_by, settings)
