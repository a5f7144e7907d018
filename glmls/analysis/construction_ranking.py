"""Ranking the ways of building a deformed image (``quads``, ``splat``, ``backward``, nearest or
linear) by the construction error at the user's reference points
(:mod:`glmls.analysis.construction`): the choice that section 6 of the paper leaves open, made
the way ``tune`` makes the choice of configuration."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from ..core.handles import as_points
from ..imaging import source
from .construction import DEFAULT_RADIUS, check_radius, construction_errors

__all__ = [
    "construction_label",
    "default_constructions",
    "parse_construction",
    "rank_constructions",
]


#: Default constructions left out where ``m.warp`` refuses them (a method still growing).
_OPTIONAL = ("paper-quads",)


def default_constructions() -> list[tuple[str, str]]:
    """The constructions ranked by default: quads nearest and linear, ``paper-quads`` nearest
    and linear where this build has it, splat, backward nearest and linear (``backward-swap``
    is not f's inverse and is left out; name it to rank it). Asked of
    :data:`glmls.METHODS` at each call, so methods added later are seen."""
    methods = source.METHODS
    pairs = [("quads", "nearest"), ("quads", "linear")]
    if "paper-quads" in methods:
        pairs += [("paper-quads", "nearest"), ("paper-quads", "linear")]
    pairs += [("splat", "nearest"), ("backward", "nearest"), ("backward", "linear")]
    return [pair for pair in pairs if pair[0] in methods]


def parse_construction(spec: object) -> tuple[str, str]:
    """``"method"``, ``"method:interpolation"`` or a (method, interpolation) pair as a
    validated (method, interpolation); ``ValueError`` naming a bad one."""
    if isinstance(spec, str):
        method, _, interpolation = spec.partition(":")
        pair = (method, interpolation or "nearest")
    elif isinstance(spec, Sequence) and len(spec) == 2:
        pair = (spec[0], spec[1])
    else:
        raise ValueError(
            f"a construction is 'method', 'method:interpolation' or a pair, got {spec!r}"
        )
    source.check_options(pair[0], pair[1], 1)
    return pair  # type: ignore[return-value]


def construction_label(method: str, interpolation: str) -> str:
    """``splat`` (which ignores the interpolation), else ``method interpolation``."""
    return method if method == "splat" else f"{method} {interpolation}"


def _sort_key(row: dict) -> tuple:
    mean, median = row["mean"], row["median"]
    undefined = mean is None
    return (undefined, math.inf if undefined else mean, math.inf if undefined else median)


def rank_constructions(
    image: object,
    m: object,
    reference_points: object,
    *,
    methods: Sequence[object] | None = None,
    radius: int = DEFAULT_RADIUS,
    grid: int = 1,
    border: str = "constant",
    background: object = 0,
    repeat: int = 1,
) -> list[dict]:
    """Build ``image`` deformed by ``m`` (a :class:`glmls.MLS`) with each construction and
    rank them by the mean construction error at ``reference_points`` (then the median),
    best first.

    ``methods``: specs for :func:`parse_construction` (default
    :func:`default_constructions`; a ``paper-quads`` default that this build's ``m.warp``
    refuses is left out, anything else refused raises). ``radius``, ``border``: those of
    :func:`~glmls.analysis.construction.construction_errors`; ``grid``, ``background``,
    ``border``: those of :meth:`glmls.MLS.warp`, the same for every construction.

    Returns one JSON-ready dict per construction: ``rank`` (1 = best), ``method``,
    ``interpolation``, ``label``, ``mean`` and ``median`` of the per-point errors (0-1
    intensity units; None where no point is defined), ``stats`` (:func:`glmls.analysis.error_stats`
    of them) and ``time_s``, the fastest of ``repeat`` timed warps after one untimed warm-up
    (shaders compile on first use; the first method would otherwise pay for them).
    Undefined points (NaN) depend on f and the window only, so every construction leaves out
    the same ones. Ties keep the order of ``methods``.
    """
    points = as_points(reference_points, "reference_points")
    check_radius(radius)
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f"repeat must be an integer >= 1, got {repeat!r}")
    named = methods is not None
    pairs = [parse_construction(s) for s in methods] if named else default_constructions()
    if named and not pairs:
        raise ValueError("methods is empty: name at least one construction")
    source.check_options(pairs[0][0], pairs[0][1], grid, border)
    rows = []
    for method, interpolation in pairs:
        options = {
            "method": method,
            "interpolation": interpolation,
            "grid": grid,
            "border": border,
            "background": background,
        }
        try:
            output = m.warp(image, **options)  # type: ignore[attr-defined]
        except ValueError:
            if named or method not in _OPTIONAL:
                raise
            continue  # a newer method this build offers without that interpolation
        best = math.inf
        for _ in range(repeat):
            tick = time.perf_counter()
            output = m.warp(image, **options)  # type: ignore[attr-defined]
            best = min(best, time.perf_counter() - tick)
        errors = construction_errors(image, output, m, points, radius=radius, border=border)
        stats = errors.stats()
        defined = errors.values[~np.isnan(errors.values)]
        rows.append(
            {
                "method": method,
                "interpolation": interpolation,
                "label": construction_label(method, interpolation),
                "mean": stats["mean"],
                "median": float(np.median(defined)) if defined.size else None,
                "stats": stats,
                "time_s": best,
            }
        )
    rows.sort(key=_sort_key)  # stable: ties keep the given order
    return [{"rank": k + 1} | row for k, row in enumerate(rows)]
