"""The trials of the automatic choice (:mod:`glmls.analysis.tuning`): user-like edits around the
user's handles, known smooth deformations for the predictive measure, and what each trial
measures of one configuration.

Edits. Trial 0 is the user's own edit (p -> q as given). Every other trial starts from it and
drags 1 to 3 of the handles' vertices (points and segment ends; the ends that joined
segments share, and a point there, move together so that polylines stay joined) by a
magnitude taken in turn from ``magnitudes`` (fractions of the image diagonal) in a random
direction; every other vertex stays where the user put it, pinned.

Known deformations. For each trial a smooth map g(x) = x + a (sin(2 pi k1.x / L + phi1),
sin(2 pi k2.x / L + phi2)) (L the diagonal, k random unit directions, a the trial's
magnitude) moves every handle vertex, q = g(p); how far f is from g at the reference points
predicts how well a configuration fills in between the handles (the test of the scattered-data
interpolation literature the paper builds on).

Measures of one trial (:func:`measure_trial`):

- ``angle``: the mean angular error of the reference triangles (``triangle_errors``; degrees
  by default), the paper's main criterion;
- ``smoothness``: the largest mean angular change (degrees) of the fans of small triangles
  around each handle vertex, at radii of 1 % and 4 % of the diagonal: a narrow spike around a
  handle (the image near it does not follow it) hides between reference points, not here;
- ``mesh_angle``: the 99th percentile of the angular change of the triangles of a mesh over
  the image (step about 1/64 of the longer side);
- ``predictive``: mean |f(r) - g(r)| (px) at the reference points for the known map g;
- ``mls``: the mean of E_MLS (eq. 7, px²); ``distance``: the mean of eq. (10);
- ``handle_miss`` / ``handle_miss_max``: mean and largest |f(p_i) - q_i| (px) over the
  handle vertices;
- ``folds``: reference triangles, mesh triangles and fan triangles that f turns over or
  crushes to zero area.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..core.config import MLSConfig, image_diagonal
from ..core.handleset import HandleSet
from ..gl.context import GLContext
from ..mls import MLS
from .stats import error_stats
from .triangles import triangle_errors, triangle_errors_from_points

__all__ = [
    "MAGNITUDES",
    "RING_FRACTIONS",
    "handle_vertices",
    "known_deformations",
    "measure_config",
    "measure_trial",
    "random_edits",
]

#: Drag magnitudes of the random edits, as fractions of the image diagonal (taken in turn).
MAGNITUDES = (0.02, 0.05, 0.1)
#: Radii of the fans around each handle vertex, as fractions of the image diagonal.
RING_FRACTIONS = (0.01, 0.04)
_RING_POINTS = 12
_MESH_CELLS = 64  # mesh steps along the longer side for mesh_angle and folds


def handle_vertices(handles: HandleSet) -> tuple[np.ndarray, np.ndarray]:
    """(vertex of each row of ``source_points()``, vertex count): rows with the same source
    and target (a point at a segment's end, the shared ends of a polyline) are one vertex."""
    pairs = np.concatenate([handles.source_points(), handles.target_points()], axis=1)
    if len(pairs) == 0:
        return np.zeros(0, dtype=np.intp), 0
    _, first, inverse = np.unique(pairs, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.intp)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[inverse.ravel()], len(first)


def _split(handles: HandleSet, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return targets[: handles.points], targets[handles.points :].reshape(-1, 2, 2)


def random_edits(
    handles: HandleSet,
    trials: int,
    *,
    seed: int,
    shape: Sequence[int],
    magnitudes: Sequence[float] = MAGNITUDES,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``trials`` (dst, dst_segments) target sets: the user's own, then user-like edits of it
    (see the module docstring), seeded."""
    vertex, count = handle_vertices(handles)
    q = handles.target_points()
    diagonal = image_diagonal((int(shape[0]), int(shape[1])))
    rng = np.random.default_rng(seed)
    out = [_split(handles, q.copy())]
    for trial in range(1, trials):
        moved = rng.choice(count, size=min(count, int(rng.integers(1, 4))), replace=False)
        angle = rng.uniform(0, 2 * math.pi, len(moved))
        size = magnitudes[(trial - 1) % len(magnitudes)] * diagonal
        offset = np.zeros((count, 2))
        offset[moved] = size * np.stack([np.cos(angle), np.sin(angle)], axis=1)
        out.append(_split(handles, q + offset[vertex]))
    return out


def known_deformations(
    handles: HandleSet,
    trials: int,
    *,
    seed: int,
    shape: Sequence[int],
    magnitudes: Sequence[float] = MAGNITUDES,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``trials`` smooth maps g as (dst, dst_segments, parameters (2, 4): per axis the unit
    direction k, the phase and the amplitude), with q = g(p) (module docstring), seeded."""
    diagonal = image_diagonal((int(shape[0]), int(shape[1])))
    rng = np.random.default_rng([seed, 1])  # a stream apart from the edits'
    p = handles.source_points()
    out = []
    for trial in range(trials):
        theta = rng.uniform(0, 2 * math.pi, 2)
        phase = rng.uniform(0, 2 * math.pi, 2)
        amplitude = magnitudes[trial % len(magnitudes)] * diagonal
        params = np.stack([np.cos(theta), np.sin(theta), phase, np.full(2, amplitude)], axis=1)
        dst, dst_segments = _split(handles, apply_known(params, p, diagonal))
        out.append((dst, dst_segments, params))
    return out


def apply_known(params: np.ndarray, points: np.ndarray, diagonal: float) -> np.ndarray:
    """g(points) for the parameters of :func:`known_deformations`."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    phase = 2 * math.pi * (points @ params[:, :2].T) / diagonal + params[:, 2]
    return points + params[:, 3] * np.sin(phase)


def _fans(handles: HandleSet, diagonal: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (centres, then the ring points) and fan triangles around each handle vertex."""
    centres = np.unique(handles.source_points(), axis=0)
    turn = 2 * math.pi * np.arange(_RING_POINTS) / _RING_POINTS
    unit = np.stack([np.cos(turn), np.sin(turn)], axis=1)
    points, triangles = [centres], []
    start = len(centres)
    for fraction in RING_FRACTIONS:
        radius = max(1.0, fraction * diagonal)
        for c, centre in enumerate(centres):
            points.append(centre + radius * unit)
            ring = start + np.arange(_RING_POINTS)
            triangles.append(np.stack([np.full(_RING_POINTS, c), ring, np.roll(ring, -1)], 1))
            start += _RING_POINTS
    return np.concatenate(points), np.concatenate(triangles)


def _mesh(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """A mesh over the image: points (pixel centres, step ~1/64 of the longer side) and two
    triangles per cell."""
    step = max(1.0, max(shape) / _MESH_CELLS)
    # at least the two edges of a side of two pixels or more: a strip thinner than the step
    # (200 x 3) still has cells to measure
    xs, ys = (_samples(side, step) for side in (shape[1], shape[0]))
    grid = np.stack(np.meshgrid(xs, ys), -1)
    rows, cols = grid.shape[:2]
    index = np.arange(rows * cols).reshape(rows, cols)
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()
    c, d = index[1:, 1:].ravel(), index[1:, :-1].ravel()
    triangles = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return grid.reshape(-1, 2), triangles


def _samples(side: int, step: float) -> np.ndarray:
    """Pixel centres along a side, ``step`` apart, the last centre among them where the step
    would leave a side of two pixels or more with one."""
    samples = np.arange(0.0, side - 1 + 1e-9, step)
    return np.array([0.0, side - 1.0]) if len(samples) < 2 and side > 1 else samples


def measure_trial(
    m: MLS,
    known: MLS,
    known_params: np.ndarray,
    shape: tuple[int, int],
    reference: np.ndarray,
    *,
    grid: int,
    angle: str,
) -> dict[str, float]:
    """The measures of one trial (module docstring): ``m`` the edit's MLS, ``known`` the MLS
    of the known deformation ``known_params``."""
    diagonal = image_diagonal(shape)
    tri = triangle_errors(m, reference, angle=angle)
    fan_points, fan_triangles = _fans(m.handles, diagonal)
    mesh_points, mesh_triangles = _mesh(shape)
    p = m.handles.source_points()
    q = m.handles.target_points()
    # one GPU evaluation for the fans, the mesh and the handles
    cut, end = len(fan_points), len(fan_points) + len(mesh_points)
    deformed = m(np.concatenate([fan_points, mesh_points, p]))
    _, fan_angle, fan_flipped = triangle_errors_from_points(
        fan_points, deformed[:cut], fan_triangles, angle=angle
    )
    _, mesh_angle, mesh_flipped = triangle_errors_from_points(
        mesh_points, deformed[cut:end], mesh_triangles, angle=angle
    )
    fan_angle = fan_angle.reshape(-1, _RING_POINTS)  # one row per fan
    miss = np.hypot(*(deformed[end:] - q).T) if len(p) else np.zeros(1)
    predicted = known(reference)
    truth = apply_known(known_params, reference, diagonal)
    return {
        "angle": _mean(tri.angle),
        "smoothness": _worst_fan(fan_angle),
        "mesh_angle": _percentile(mesh_angle, 99),
        "predictive": float(np.hypot(*(predicted - truth).T).mean()),
        "mls": float(error_stats(m.error_field(shape, grid=grid))["mean"]),
        "distance": _mean(tri.distance),
        "handle_miss": float(miss.mean()),
        "handle_miss_max": float(miss.max()),
        "folds": float(tri.flipped.sum() + fan_flipped.sum() + mesh_flipped.sum()),
    }


def _worst_fan(fan_angle: np.ndarray) -> float:
    """The largest mean angle change of a fan; a fan whose every triangle is undefined (f
    collapsed it, or returned NaN) counts as the worst, infinite."""
    if fan_angle.size == 0:
        return 0.0
    defined = np.isfinite(fan_angle)
    counts = defined.sum(axis=1)
    sums = np.where(defined, fan_angle, 0.0).sum(axis=1)
    means = np.where(counts > 0, sums / np.maximum(counts, 1), math.inf)
    return float(means.max())


def _percentile(values: np.ndarray, q: float) -> float:
    """The ``q``-th percentile of the defined values; no value (an image of one pixel
    across: no triangle) 0, as :func:`_worst_fan` gives no fan; every one undefined (f
    collapsed them) infinite, the worst."""
    if values.size == 0:
        return 0.0
    finite = values[np.isfinite(values)]
    return float(np.percentile(finite, q)) if len(finite) else math.inf


def _mean(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(finite.mean()) if len(finite) else math.inf


def measure_config(
    config: MLSConfig,
    handles: HandleSet,
    shape: tuple[int, int],
    reference: np.ndarray,
    edits: list[tuple[np.ndarray, np.ndarray]],
    known: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
    *,
    grid: int,
    angle: str,
    ctx: GLContext | None = None,
) -> list[dict[str, float]]:
    """:func:`measure_trial` for every trial of one configuration (raises
    ``DegenerateHandlesError`` where the configuration cannot be built)."""
    results = []
    for (dst, dst_segments), (g_dst, g_segments, params) in zip(edits, known, strict=True):
        options = {"shape": shape, "ctx": ctx, "src_segments": handles.src_segments}
        with (
            MLS.from_config(handles.src, dst, config, dst_segments=dst_segments, **options) as m,
            MLS.from_config(handles.src, g_dst, config, dst_segments=g_segments, **options) as g,
        ):
            results.append(measure_trial(m, g, params, shape, reference, grid=grid, angle=angle))
    return results
