"""Studies over image sets: does one configuration win everywhere? (the paper's "further
studies": evaluate the configurations on different image sets and show that none performs
best on every one).

:func:`study` runs the tune (:func:`glmls.analysis.tuning.tune`, the same configurations, trials
and seed for every image) on each item of a set, one item per job (:func:`run_jobs`: worker
processes or a Dask cluster), and compares the rankings:

- ``winners``: each image's best configuration, and how many distinct ones win;
- ``rank_agreement``: Kendall's tau between the rankings of every pair of images (over the
  configurations ranked on both; 1: the same order, 0: unrelated, -1: reversed), its mean,
  and Kendall's W over all images (over the configurations ranked on all of them; 1: every
  image ranks them alike, 0: no agreement);
- a table (configuration x image: rank and score) and a heat-map of the ranks.

Configurations are matched between images by their place in the list the same specification
makes for each image: the default search space (or a spec without a radius) sizes the
radius of the radius weights by each image's diagonal, so the same configuration has
different radii on images of different sizes; its label then gives the radius as a fraction
of the diagonal (``R=0.25 diag``).
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import re
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..core.config import MLSConfig, check_integer, check_seed, check_sequence, image_diagonal
from ..core.handles import check_reference_points
from ..data.manifest import StudyItem
from ..files.atomic import atomic_write
from ..files.json_out import write_json
from .colormaps import VIRIDIS
from .jobs import check_jobs, run_jobs
from .tuning import MAX_TRIALS, TuneResult, label, parse_config, search_space, tune

__all__ = [
    "STUDY_OUTPUTS",
    "StudyResult",
    "StudyTask",
    "check_item_names",
    "render_heatmap",
    "study",
    "study_label",
    "tune_item",
]

#: The files :meth:`StudyResult.save` writes beside each image's folder.
STUDY_OUTPUTS = ("summary.json", "table.json", "table.csv", "heatmap.png")


def check_item_names(items: Sequence[StudyItem]) -> None:
    """``ValueError`` for item names that repeat, or that name one of the study's own
    files (:data:`STUDY_OUTPUTS`, in any case: an item's folder would take its place)."""
    names = [item.name for item in items]
    if len(set(names)) != len(names):
        repeated = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"item names must differ; repeated: {', '.join(repeated)}")
    for name in names:
        if name.lower() in STUDY_OUTPUTS:
            raise ValueError(
                f"item name {name!r} is the name of one of the study's own files "
                f"({', '.join(STUDY_OUTPUTS)}): rename the item"
            )


@dataclasses.dataclass(frozen=True, eq=False)
class StudyTask:
    """One image's tune, as sent to a worker (picklable)."""

    item: StudyItem
    configs: tuple[MLSConfig, ...]
    trials: int | None  # None: the tune's default
    seed: int


def tune_item(task: StudyTask) -> tuple[TuneResult, float]:
    """The tune of one item and the seconds it took (run in a worker)."""
    start = time.perf_counter()
    handles = task.item.handles
    try:
        result = tune(
            task.item.shape,
            handles.src,
            handles.dst,
            task.item.reference,
            src_segments=handles.src_segments,
            dst_segments=handles.dst_segments,
            configs=list(dict.fromkeys(task.configs)),  # a repeat once, in its first place
            seed=task.seed,
            **({} if task.trials is None else {"trials": task.trials}),
        )
    except ValueError as error:  # the handles or points of this item: say which item
        raise ValueError(f"{task.item.name}: {error}") from None
    return result, time.perf_counter() - start


def _configs_for(shape: tuple[int, int], configs: Sequence[MLSConfig | str] | None):
    """The configurations for an image of ``shape``: the default search space, or each spec
    parsed for this shape (specs without a radius size it by the diagonal), or the
    configurations given. Repeats stay: a configuration's place in this list matches it
    between images, and a spec can repeat one on some images only (an explicit radius equal
    to a fraction of one image's diagonal); the tune meets each once."""
    if configs is None:
        made = search_space(shape)
    else:
        made = []
        for config in check_sequence("configs", configs, "MLSConfig values or spec strings"):
            if isinstance(config, str):
                made += parse_config(config, shape)
            elif isinstance(config, MLSConfig):
                made.append(config)
            else:
                raise TypeError(f"configs: expected MLSConfig or spec strings, got {config!r}")
    return tuple(made)


@dataclasses.dataclass(frozen=True, eq=False)
class StudyResult:
    """The tunes of a study over an image set, as :func:`study` returns them.

    Attributes
    ----------
    names : list of str
        The items' names.
    results : list of TuneResult
        Each item's tune.
    configs : list of tuple of MLSConfig
        Each item's configurations, matched between items by place (a configuration that
        comes twice for an item is tuned once and fills its first place only).
    diagonals : list of float
        Each item's image diagonal in pixels.
    settings : dict
        JSON-ready: trials, seed, the configuration specs, ``rank_by``.
    timings : dict
        JSON-ready: seconds in all and per image, jobs, scheduler.
    inputs : list of str
        Each item's image file (or its name where it has none).

    Examples
    --------
    >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
    >>> pulled, pushed = src.copy(), src.copy()
    >>> pulled[3], pushed[0] = [24.0, 24.0], [8.0, 6.0]
    >>> points = np.array([[8.0, 8.0], [24.0, 8.0], [8.0, 24.0], [24.0, 24.0], [16.0, 16.0]])
    >>> items = [
    ...     glmls.data.StudyItem("pulled", (32, 32), glmls.HandleSet.validate(src, pulled), points),
    ...     glmls.data.StudyItem("pushed", (32, 40), glmls.HandleSet.validate(src, pushed), points),
    ... ]
    >>> result = glmls.analysis.study(items, configs=["rigid:idw", "affine:idw:alpha=1"], trials=1)
    >>> [(row["label"], row["mean_rank"], row["wins"]) for row in result.table()]
    [('affine idw a=1', 1.0, 2), ('rigid idw a=1', 2.0, 0), ('rigid idw a=2', 3.0, 0)]
    >>> result.summary()["answer"]
    '1 distinct winner over 2 images: one configuration wins everywhere; ...'
    >>> result.heatmap().dtype.name
    'uint8'
    """

    names: list[str]
    results: list[TuneResult]
    configs: list[tuple[MLSConfig, ...]]
    diagonals: list[float]
    settings: dict
    timings: dict
    inputs: list[str] = dataclasses.field(default_factory=list)

    def table(self) -> list[dict]:
        """The configurations over the images, one dict per configuration, by mean rank.

        Returns
        -------
        list of dict
            ``label``, ``mean_rank``, ``wins``, ``ranked_on`` and ``images``: name ->
            {rank, tied_rank, winner, score, admissible, handle_miss, config} (absent where
            the configuration could not be built for the image's handles); ``tied_rank`` is
            the rank shared by the configurations the tune cannot tell apart (the same
            score), which the rank agreement uses; ``winner`` whether the configuration is
            first there or ties with the first, and ``wins`` on how many images it is.

        Examples
        --------
        >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
        >>> pulled = src.copy()
        >>> pulled[3] = [24.0, 24.0]
        >>> points = np.array([[8.0, 8.0], [24.0, 8.0], [8.0, 24.0], [24.0, 24.0], [16.0, 16.0]])
        >>> handles = glmls.HandleSet.validate(src, pulled)
        >>> items = [glmls.data.StudyItem("pulled", (32, 32), handles, points)]
        >>> configs = ["rigid:idw", "affine:idw:alpha=1"]
        >>> result = glmls.analysis.study(items, configs=configs, trials=1)
        >>> [(row["label"], row["mean_rank"]) for row in result.table()]
        [('affine idw a=1', 1.0), ('rigid idw a=1', 2.0), ('rigid idw a=2', 3.0)]
        """
        return _table(self)

    def summary(self) -> dict:
        """The JSON-ready summary of the study.

        Returns
        -------
        dict
            ``images``, ``configurations``, ``winners`` (each image's best),
            ``distinct_winners``, ``winner_counts``, ``one_configuration_wins_everywhere``,
            ``best_overall``, ``rank_agreement`` (Kendall's tau per pair of images, and
            Kendall's W), ``answer`` (in words), ``skipped``, ``settings``, ``timings``.

        Examples
        --------
        >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
        >>> pulled = src.copy()
        >>> pulled[3] = [24.0, 24.0]
        >>> points = np.array([[8.0, 8.0], [24.0, 8.0], [8.0, 24.0], [24.0, 24.0], [16.0, 16.0]])
        >>> handles = glmls.HandleSet.validate(src, pulled)
        >>> items = [glmls.data.StudyItem("pulled", (32, 32), handles, points)]
        >>> configs = ["rigid:idw", "affine:idw:alpha=1"]
        >>> result = glmls.analysis.study(items, configs=configs, trials=1)
        >>> summary = result.summary()
        >>> summary["images"], summary["winners"]["pulled"]["label"]
        (['pulled'], 'affine idw a=1')
        """
        return _summary(self, self.table())

    def heatmap(self) -> np.ndarray:
        """The ranks as a picture: configurations x images, coloured by rank.

        Returns
        -------
        numpy.ndarray
            (H, W, 3) uint8 (``render_heatmap``).

        Examples
        --------
        >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
        >>> pulled = src.copy()
        >>> pulled[3] = [24.0, 24.0]
        >>> points = np.array([[8.0, 8.0], [24.0, 8.0], [8.0, 24.0], [24.0, 24.0], [16.0, 16.0]])
        >>> handles = glmls.HandleSet.validate(src, pulled)
        >>> items = [glmls.data.StudyItem("pulled", (32, 32), handles, points)]
        >>> configs = ["rigid:idw", "affine:idw:alpha=1"]
        >>> result = glmls.analysis.study(items, configs=configs, trials=1)
        >>> picture = result.heatmap()
        >>> picture.ndim, picture.shape[2], picture.dtype.name
        (3, 3, 'uint8')
        """
        return render_heatmap(self.table(), self.names, title=self.summary()["answer"])

    def save(self, out_dir: str | Path) -> dict:
        """Write the study's files into a folder.

        ``summary.json``, ``table.csv``, ``table.json``, ``heatmap.png`` and
        ``<name>/ranking.json`` per image (as ``glmls tune --out`` writes it).

        Parameters
        ----------
        out_dir : str or pathlib.Path
            The folder, created if needed.

        Returns
        -------
        dict
            The summary (:meth:`summary`).

        Examples
        --------
        >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
        >>> pulled = src.copy()
        >>> pulled[3] = [24.0, 24.0]
        >>> points = np.array([[8.0, 8.0], [24.0, 8.0], [8.0, 24.0], [24.0, 24.0], [16.0, 16.0]])
        >>> handles = glmls.HandleSet.validate(src, pulled)
        >>> items = [glmls.data.StudyItem("pulled", (32, 32), handles, points)]
        >>> configs = ["rigid:idw", "affine:idw:alpha=1"]
        >>> result = glmls.analysis.study(items, configs=configs, trials=1)
        >>> import pathlib, tempfile
        >>> folder = pathlib.Path(tempfile.mkdtemp()) / "study"
        >>> result.save(folder)["images"]
        ['pulled']
        >>> sorted(path.name for path in folder.iterdir())
        ['heatmap.png', 'pulled', 'summary.json', 'table.csv', 'table.json']
        """
        out = Path(out_dir)
        rows = self.table()
        summary = _summary(self, rows)
        for name, result, source in zip(self.names, self.results, self.inputs, strict=True):
            document = {
                "input": source,
                "rank_by": result.rank_by,
                "settings": result.settings,
                "ranking": result.rows,
                "skipped": result.skipped,
            }
            write_json(out / name / "ranking.json", document)
        write_json(out / "table.json", {"images": self.names, "configurations": rows})
        with atomic_write(out / "table.csv") as tmp:
            tmp.write_text(_csv(rows, self.names), encoding="utf-8")
        picture = render_heatmap(rows, self.names, title=summary["answer"])
        with atomic_write(out / "heatmap.png") as tmp:
            Image.fromarray(picture).save(tmp, format="PNG")
        write_json(out / "summary.json", summary)
        return summary


def study(
    items: Sequence[StudyItem],
    *,
    configs: Sequence[MLSConfig | str] | None = None,
    trials: int | None = None,
    seed: int = 0,
    jobs: int = 1,
    scheduler: str | None = None,
    on_step: Callable[[], None] | None = None,
) -> StudyResult:
    """Tune every image of a set and compare the rankings.

    Does one configuration win everywhere? The paper's "further studies": :func:`tune`,
    with the same configurations, trials and seed, runs on each item, one item per job
    (:func:`run_jobs`); the result compares each image's winner and the agreement of the
    rankings (Kendall's tau and W; see ``glmls.analysis.studies``).

    Parameters
    ----------
    items : sequence of StudyItem
        The images, with distinct names (e.g. :func:`glmls.data.study_set`).
    configs : sequence of MLSConfig or str, optional
        Configurations, or specs such as ``"rigid:*"``
        (``parse_config``, parsed for each image's shape: a spec
        without a radius sizes it by the image diagonal); None for the default search space.
    trials : int, optional
        The tune's trials per configuration, 1 to ``MAX_TRIALS`` (None: the tune's default).
    seed : int, optional
        The seed of the tune's edits.
    jobs : int, optional
        Worker processes.
    scheduler : str, optional
        A Dask scheduler (``"local"`` or an address) instead of ``jobs``.
    on_step : callable, optional
        Called after each item, for progress.

    Returns
    -------
    StudyResult
        The tunes and their comparison.

    Raises
    ------
    ValueError
        For no items, repeated names, trials, seed or jobs out of range, no configurations, or
        an item whose handles or points cannot be tuned (naming the item).
    TypeError
        For items that are not :class:`~glmls.data.StudyItem` values, configurations that
        are neither :class:`~glmls.MLSConfig` values nor specs (or one bare spec string
        instead of a sequence), trials, seed or jobs that are not integers, or a scheduler
        that is no string.

    Examples
    --------
    A full study of the bundled set takes minutes:

    >>> result = glmls.analysis.study(glmls.data.study_set())  # doctest: +SKIP

    Two small images, three configurations (``rigid:idw`` is idw's alpha 1 and 2), one
    trial each:

    >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
    >>> pulled, pushed = src.copy(), src.copy()
    >>> pulled[3], pushed[0] = [24.0, 24.0], [8.0, 6.0]
    >>> points = np.array([[8.0, 8.0], [24.0, 8.0], [8.0, 24.0], [24.0, 24.0], [16.0, 16.0]])
    >>> items = [
    ...     glmls.data.StudyItem("pulled", (32, 32), glmls.HandleSet.validate(src, pulled), points),
    ...     glmls.data.StudyItem("pushed", (32, 40), glmls.HandleSet.validate(src, pushed), points),
    ... ]
    >>> result = glmls.analysis.study(items, configs=["rigid:idw", "affine:idw:alpha=1"], trials=1)
    >>> result.names, [tuned.rows[0]["label"] for tuned in result.results]
    (['pulled', 'pushed'], ['affine idw a=1', 'affine idw a=1'])
    >>> result.summary()["distinct_winners"]
    1
    """
    items = check_sequence("items", items, "StudyItems")
    if not items:
        raise ValueError("a study needs at least one item")
    for item in items:
        if not isinstance(item, StudyItem):
            raise TypeError(f"items must be StudyItems (glmls.data), got {item!r}")
    check_item_names(items)
    names = [item.name for item in items]
    if trials is not None:
        trials = check_integer("trials", trials, 1, MAX_TRIALS)
    seed, jobs = check_seed(seed), check_jobs(jobs)
    for index, item in enumerate(items):  # before any tune: not after hours of the others
        try:
            check_reference_points(item.reference)
        except ValueError as error:
            raise ValueError(f"item {index}: {item.name}: {error}") from None
    per_item = [_configs_for(item.shape, configs) for item in items]
    if not per_item[0]:
        raise ValueError("no configurations to compare")
    tasks = [
        StudyTask(item, made, trials, seed) for item, made in zip(items, per_item, strict=True)
    ]
    start = time.perf_counter()
    outputs = run_jobs(
        tune_item,
        tasks,
        jobs=jobs,
        scheduler=scheduler,
        on_result=(lambda index, result: on_step()) if on_step is not None else None,
    )
    total = time.perf_counter() - start
    specs = None if configs is None else [c if isinstance(c, str) else label(c) for c in configs]
    first = outputs[0][0]
    settings = {
        "trials": first.settings.get("trials", trials),
        "seed": seed,
        "configs": specs,
        "rank_by": first.rank_by,
    }
    timings = {
        "total_s": round(total, 3),
        "jobs": jobs,
        "scheduler": scheduler,
        "per_image_s": {n: round(s, 3) for n, (_, s) in zip(names, outputs, strict=True)},
    }
    return StudyResult(
        names=names,
        results=[result for result, _ in outputs],
        configs=list(per_item),
        diagonals=[image_diagonal(item.shape) for item in items],
        settings=settings,
        timings=timings,
        inputs=[str(item.image_path) if item.image_path else item.name for item in items],
    )


def study_label(configs: list[MLSConfig], diagonals: list[float]) -> str:
    """The label of a configuration matched over images: its own, or with the radius as a
    fraction of the diagonal where the radius differs from image to image.

    Parameters
    ----------
    configs : list of MLSConfig
        The configuration on each image.
    diagonals : list of float
        Each image's diagonal in pixels.

    Returns
    -------
    str
        E.g. ``rigid gaussian R=0.25 diag interp``; ``R=varies`` where the radii are no
        one fraction of the diagonals.
    """
    first = label(configs[0])
    if all(c == configs[0] for c in configs) or configs[0].radius is None:
        return first
    # the search space rounds each radius to 0.1 px: one fraction is within 0.05 px of all
    widest = int(np.argmax(diagonals))
    fraction = configs[widest].radius / diagonals[widest]
    same = all(
        c.radius is not None and abs(c.radius - fraction * d) <= 0.1
        for c, d in zip(configs, diagonals, strict=True)
    )
    text = f"R={fraction:.3g} diag" if same else "R=varies"
    replaced = re.sub(r"R=[0-9.e+-]+", text, first)
    return replaced if replaced != first else f"{first} ({text})"


def _table(result: StudyResult) -> list[dict]:
    entries: dict[tuple, dict] = {}
    for name, tuned, configs in zip(result.names, result.results, result.configs, strict=True):
        tied = _tied_ranks(tuned)
        place: dict[MLSConfig, int] = {}
        for k, config in enumerate(configs):
            place.setdefault(config, k)  # a repeat on this image fills its first place
        for row, tied_rank in zip(tuned.rows, tied, strict=True):
            config = MLSConfig(**row["config"])
            own = label(config)
            # a tune that ranks more than one row per configuration names them apart
            suffix = row["label"][len(own) :] if row["label"].startswith(own) else row["label"]
            key = (place.get(config, len(configs)), suffix)
            entry = entries.setdefault(key, {"images": {}})
            entry["images"][name] = {
                "rank": int(row["rank"]),
                "tied_rank": tied_rank,
                "score": _number(row.get("score", row.get("combined"))),
                "admissible": row.get("admissible"),
                "handle_miss": _number(row.get("handle_miss_mean")),
                "config": row["config"],
            }
    # a configuration the tune cannot tell from the first one wins too: the tune's order
    # of a tie is by name, which says nothing of the image
    first = {
        name: min(c["tied_rank"] for e in entries.values() for n, c in e["images"].items()
                  if n == name)
        for name in result.names
    }  # fmt: skip
    rows = []
    for (_, suffix), entry in entries.items():
        owners = [i for i, n in enumerate(result.names) if n in entry["images"]]
        configs = [MLSConfig(**entry["images"][result.names[i]]["config"]) for i in owners]
        base = study_label(configs, [result.diagonals[i] for i in owners])
        # tied configurations at their shared rank: the order within a tie is by name
        ranks = [cell["tied_rank"] for cell in entry["images"].values()]
        for name, cell in entry["images"].items():
            cell["winner"] = cell["tied_rank"] == first[name]
        rows.append(
            {
                "label": base + suffix,
                "mean_rank": float(np.mean(ranks)),
                "wins": sum(cell["winner"] for cell in entry["images"].values()),
                "ranked_on": len(ranks),
                "images": {n: entry["images"][n] for n in result.names if n in entry["images"]},
            }
        )
    rows.sort(key=lambda r: (-r["ranked_on"], r["mean_rank"], r["label"]))
    return rows


def _tied_ranks(tuned: TuneResult) -> list[float]:
    """Each row's rank, shared (the mean of their places) by the rows the tune cannot tell
    apart: the same group (admissible, folding, missing) and the same score. The tune
    orders those by name, which says nothing of the image (one handle: every configuration
    is the same translation)."""
    ranks: list[float] = []
    start = 0
    for _, group in itertools.groupby(tuned.rows, key=tuned.standing):
        size = len(list(group))
        ranks += [start + (size + 1) / 2] * size
        start += size
    return ranks


def _number(value: object) -> float | None:
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def rank_agreement(rows: list[dict], names: list[str]) -> dict:
    """Kendall's tau between each pair of images (over the configurations ranked on both),
    their mean, and Kendall's W over all images (over the configurations ranked on all)."""
    from scipy.stats import kendalltau  # here: scipy.stats takes ~0.7 s to import

    pairs = []
    matrix = [[1.0 if a == b else None for b in names] for a in names]
    for (i, a), (j, b) in itertools.combinations(enumerate(names), 2):
        common = [r for r in rows if a in r["images"] and b in r["images"]]
        tau = p_value = None
        if len(common) >= 2:
            found = kendalltau(  # tau-b: configurations an image ranks alike are a tie
                [_rank(r, a) for r in common], [_rank(r, b) for r in common]
            )
            if math.isfinite(found.statistic):
                tau, p_value = float(found.statistic), float(found.pvalue)
        pairs.append(
            {"images": [a, b], "tau": tau, "p_value": p_value, "configurations": len(common)}
        )
        matrix[i][j] = matrix[j][i] = tau
    taus = [p["tau"] for p in pairs if p["tau"] is not None]
    everywhere = [r for r in rows if len(r["images"]) == len(names)]
    return {
        "kendall_tau": pairs,
        "tau_matrix": matrix,
        "mean_tau": float(np.mean(taus)) if taus else None,
        "min_tau": float(min(taus)) if taus else None,
        "max_tau": float(max(taus)) if taus else None,
        "kendall_w": _kendall_w(everywhere, names),
        "kendall_w_configurations": len(everywhere),
    }


def _rank(row: dict, name: str) -> float:
    """The configuration's rank on the image, shared with those the tune cannot tell apart."""
    cell = row["images"][name]
    return cell.get("tied_rank", cell["rank"])


def _kendall_w(rows: list[dict], names: list[str]) -> float | None:
    """Kendall's coefficient of concordance W = 12 S / (m² (n³ - n) - m Σ T) of m images
    ranking n configurations (ranked again among these n, ties sharing their mean rank; T =
    Σ (t³ - t) over each image's groups of t tied configurations); None where every image
    ties them all."""
    from scipy.stats import rankdata  # here: scipy.stats takes ~0.7 s to import

    m, n = len(names), len(rows)
    if m < 2 or n < 2:
        return None
    ranks = rankdata([[_rank(r, name) for r in rows] for name in names], axis=1)
    ties = sum(
        float((c**3 - c).sum()) for c in (np.unique(x, return_counts=True)[1] for x in ranks)
    )
    totals = ranks.sum(axis=0)
    spread = float(((totals - totals.mean()) ** 2).sum())
    denominator = m**2 * (n**3 - n) - m * ties
    return 12.0 * spread / denominator if denominator > 0 else None


def _summary(result: StudyResult, rows: list[dict]) -> dict:
    winners = {}
    for name in result.names:
        tied = [r for r in rows if name in r["images"] and r["images"][name]["winner"]]
        # of those tied for first, the one that wins on the most images: a tie broken by
        # name must not make a winner "distinct" where another wins as well
        best = min(tied, key=lambda r: (-r["wins"], r["images"][name]["rank"]))
        cell = best["images"][name]
        winners[name] = {
            "label": best["label"],
            "config": cell["config"],
            "score": cell["score"],
            "admissible": cell["admissible"],  # None from a tune that does not say
            "tied_with": [r["label"] for r in tied if r is not best],
        }
    counts: dict[str, int] = {}
    for winner in winners.values():
        counts[winner["label"]] = counts.get(winner["label"], 0) + 1
    agreement = rank_agreement(rows, result.names)
    overall = rows[0]
    distinct = len(counts)
    everywhere = distinct == 1 and len(result.names) > 1
    tau, w = agreement["mean_tau"], agreement["kendall_w"]
    if len(result.names) == 1:  # its winner wins everywhere, which answers nothing
        answer = (
            f"1 winner over 1 image: {overall['label']}; one image cannot tell whether one "
            "configuration wins everywhere"
        )
    else:
        answer = (
            f"{distinct} distinct winner{'s' * (distinct != 1)} over {len(result.names)} "
            "images: "
            + ("one configuration" if everywhere else "no configuration")
            + " wins everywhere"
            + (f"; mean Kendall tau {tau:.2f}" if tau is not None else "")
            + (f", Kendall W {w:.2f}" if w is not None else "")
        )
    return {
        "images": result.names,
        "configurations": len(rows),
        "winners": winners,
        "distinct_winners": distinct,
        "winner_counts": dict(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))),
        "one_configuration_wins_everywhere": everywhere,
        "best_overall": {
            "label": overall["label"],
            "mean_rank": overall["mean_rank"],
            "wins": overall["wins"],
            "ranks": {n: cell["rank"] for n, cell in overall["images"].items()},
        },
        "rank_agreement": agreement,
        "answer": answer,
        "skipped": {n: len(r.skipped) for n, r in zip(result.names, result.results, strict=True)},
        "settings": result.settings,
        "timings": result.timings,
    }


def _csv(rows: list[dict], names: list[str]) -> str:
    head = ["configuration", "mean_rank", "wins"]
    head += [f"{name}_{what}" for name in names for what in ("rank", "score")]
    lines = [",".join(head)]
    for row in rows:
        cells = [json.dumps(row["label"]), f"{row['mean_rank']:.3f}", str(row["wins"])]
        for name in names:
            cell = row["images"].get(name)
            score = None if cell is None else cell["score"]
            cells.append("" if cell is None else str(cell["rank"]))
            cells.append("" if score is None else f"{score:.6g}")
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def render_heatmap(rows: list[dict], names: list[str], *, title: str = "") -> np.ndarray:
    """Configurations (rows, by mean rank, best on top) x images (columns) and their mean
    rank, each cell coloured by the configuration's rank on that image (viridis: yellow is
    rank 1, dark violet the last) and numbered, with ``*`` where the tune set it apart (not
    admissible); each image's winner (and those tied with it) boxed in red; grey where the
    configuration could not be built. An (H, W, 3) uint8 picture."""
    notes = (
        "rank on each image (yellow: 1, the best); red box: the image's winner or a tie",
        "*: set apart by the tune (misses its targets or folds); rows by mean rank",
    )
    font = ImageFont.load_default(size=12)
    columns = [*names, "mean"]
    left = max(int(font.getlength(r["label"])) for r in rows) + 12
    cell_w = max(44, *(int(font.getlength(c)) + 10 for c in columns))
    cell_h, top, bottom = 16, 44, 42
    text_width = max(int(font.getlength(text)) for text in (title, *notes))
    width = max(left + cell_w * len(columns) + 8, text_width + 16)
    picture = Image.new("RGB", (width, top + cell_h * len(rows) + bottom), "white")
    draw = ImageDraw.Draw(picture)
    draw.text((8, 6), title, fill="black", font=font)
    worst = max(max(c["rank"] for c in r["images"].values()) for r in rows)
    for j, column in enumerate(columns):
        x = left + j * cell_w + cell_w / 2
        draw.text((x, top - 4), column, fill="black", font=font, anchor="md")
    for i, row in enumerate(rows):
        y = top + i * cell_h
        draw.text((left - 6, y + cell_h / 2), row["label"], fill="black", font=font, anchor="rm")
        for j, column in enumerate(columns):
            x = left + j * cell_w
            box = [x + 1, y + 1, x + cell_w - 2, y + cell_h - 2]
            if column == "mean":
                rank, text = row["mean_rank"], f"{row['mean_rank']:.1f}"
            elif column in row["images"]:
                rank = row["images"][column]["rank"]
                set_apart = row["images"][column].get("admissible") is False
                text = f"{rank}*" if set_apart else str(rank)
            else:
                draw.rectangle(box, fill=(170, 170, 170))
                continue
            t = 1.0 - (rank - 1) / (worst - 1) if worst > 1 else 1.0
            colour = tuple(int(v) for v in VIRIDIS[round(t * (len(VIRIDIS) - 1))])
            draw.rectangle(box, fill=colour)
            ink = "black" if t > 0.45 else "white"
            draw.text((x + cell_w / 2, y + cell_h / 2), text, fill=ink, font=font, anchor="mm")
            if column != "mean" and row["images"][column].get("winner", rank == 1):
                draw.rectangle([x, y, x + cell_w - 1, y + cell_h - 1], outline=(230, 0, 0), width=2)
    for k, note in enumerate(notes):
        draw.text((8, top + cell_h * len(rows) + 8 + 15 * k), note, fill=(60, 60, 60), font=font)
    return np.asarray(picture)
