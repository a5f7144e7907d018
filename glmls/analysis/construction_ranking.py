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
    "parse_constructions",
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
    validated (method, interpolation); ``ValueError`` naming a bad one, an empty
    interpolation (``"quads:"``) or one given to ``splat``, which ignores it (``"splat"`` and
    ``"splat:linear"`` would rank one construction twice)."""
    if isinstance(spec, str):
        method, colon, interpolation = spec.partition(":")
        if colon and not interpolation:
            raise ValueError(
                f"an empty interpolation after {method + colon!r}: name one "
                f"({', '.join(source.INTERPOLATIONS)}) or leave out the ':'"
            )
        pair = (method, interpolation or "nearest")
        suffix = interpolation if colon else None
    elif isinstance(spec, Sequence) and len(spec) == 2:
        pair = (spec[0], spec[1])
        suffix = None if pair[1] == "nearest" else pair[1]
    else:
        raise ValueError(
            f"a construction is 'method', 'method:interpolation' or a pair, got {spec!r}"
        )
    source.check_options(pair[0], pair[1], 1)
    if pair[0] == "splat" and suffix is not None:
        raise ValueError(f"splat takes no interpolation, got {suffix!r}: name it 'splat' alone")
    return pair  # type: ignore[return-value]


def parse_constructions(specs: Sequence[object]) -> list[tuple[str, str]]:
    """Each of ``specs`` as :func:`parse_construction` reads it; ``ValueError`` naming one that
    is the same construction as an earlier one (``"quads"`` is ``"quads:nearest"``), which
    would be ranked twice."""
    seen: dict[tuple[str, str], object] = {}
    for spec in specs:
        pair = parse_construction(spec)
        if pair in seen:
            first = seen[pair]
            what = (
                "is named twice"
                if first == spec
                else f"is the same construction as {first!r} ({construction_label(*pair)})"
            )
            raise ValueError(f"{spec!r} {what}: name each construction once")
        seen[pair] = spec
    return list(seen)


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
    """Rank the ways of building the deformed image by their construction error.

    ``image`` is deformed by ``m`` with each construction (method and interpolation), and the
    constructions are ranked by the mean construction error at ``reference_points`` (then
    the median), best first. Undefined points (NaN) depend on f and the window only, so every
    construction leaves out the same ones. Ties keep the order of ``methods``.

    Parameters
    ----------
    image : array_like
        The input image, as :meth:`glmls.MLS.warp` takes it.
    m : MLS
        The deformation.
    reference_points : array_like
        The points r, (N, 2).
    methods : sequence, optional
        Constructions as ``parse_construction`` reads them (``"method"``,
        ``"method:interpolation"`` or a pair), each once; default ``default_constructions`` (a
        ``paper-quads`` default that ``m.warp`` refuses is left out; anything else refused
        raises).
    radius : int, optional
        The window's half-size of :func:`construction_errors`.
    grid : int, optional
        The warp's mesh step, the same for every construction.
    border : str, optional
        The warp's border mode, also used by :func:`construction_errors`.
    background : optional
        The warp's background colour.
    repeat : int, optional
        Timed warps per construction (>= 1), after one untimed warm-up (shaders compile on
        first use; the first method would otherwise pay for them).

    Returns
    -------
    list of dict
        One JSON-ready dict per construction, best first: ``rank`` (1 = best), ``method``,
        ``interpolation``, ``label``, ``mean`` and ``median`` of the per-point errors (0-1
        intensity units; None where no point is defined), ``stats``
        (:func:`glmls.analysis.error_stats` of them) and ``time_s``, the fastest of
        ``repeat`` timed warps.

    Raises
    ------
    ValueError
        For bad points, radius, repeat, an empty ``methods``, an unknown construction or
        option, a construction named twice, or one that ``m.warp`` refuses.

    See Also
    --------
    construction_errors : the error ranked.

    Examples
    --------
    >>> y, x = np.mgrid[0:32, 0:32]
    >>> image = (127 + 60 * np.sin(x / 3.0) + 60 * np.cos(y / 4.0)).astype(np.uint8)
    >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
    >>> turn = np.radians(10.0)
    >>> rotation = np.array([[np.cos(turn), np.sin(turn)], [-np.sin(turn), np.cos(turn)]])
    >>> dst = (src - 15.5) @ rotation + 15.5  # turned by 10 degrees about the centre
    >>> points = [[10, 10], [20, 12], [16, 20]]
    >>> with glmls.MLS(src, dst) as m:
    ...     rows = glmls.analysis.rank_constructions(
    ...         image, m, points, methods=["quads:nearest", "backward:linear", "splat"]
    ...     )
    >>> [(row["rank"], row["label"]) for row in rows]
    [(1, 'backward linear'), (2, 'quads nearest'), (3, 'splat')]
    """
    points = as_points(reference_points, "reference_points")
    check_radius(radius)
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f"repeat must be an integer >= 1, got {repeat!r}")
    named = methods is not None
    pairs = parse_constructions(methods) if named else default_constructions()
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
