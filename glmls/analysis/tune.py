"""Choosing the best configuration automatically (the paper's section 6).

For every configuration of a search space, apply the same seeded random deformations around
the user's handles, measure both error measures of section 5 for each, and rank:

- ``mls``: the mean of the MLS error field E_MLS (eq. 7, px²) over the image;
- ``angle``: the mean angular error (eq. 11) of the reference triangles;
- ``distance``: the mean distance error (eq. 10) of the reference triangles;
- ``combined`` (default): 0.5 * mls / best_mls + 0.5 * angle / best_angle, each measure
  divided by the best configuration's value in this run, so that both count alike whatever
  their units; 1.0 means best in both. The paper recommends the angular error for shape
  (distance errors mostly report scaling), hence angle rather than distance here.

``handle_miss`` (mean |f(p_i) - q_i| in pixels over the point handles and the segments' ends,
not ranked) shows how far a configuration stays from interpolating the handles: low errors
bought by not reaching the targets show there.

The random deformations drag the handles' vertices: every point and every segment end whose
target differs from its source moves by its own seeded Gaussian offset, so the two ends of a
segment move independently (the segment turns and stretches as well as shifts), while ends
shared by joined segments (a polyline's vertices), and a point handle at such an end, move
together and the polyline stays joined. Handles left in place (q = p) stay: they pin the image.

Each statistic is averaged over the trials (``*_mean``) with its spread over the trials
(``*_spread``, the population standard deviation).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np

from ..core.config import RADIUS_WEIGHTS, TRANSFORMS, WEIGHTS, MLSConfig, image_diagonal
from ..core.handleset import HandleSet
from ..core.mesh import as_shape
from ..errors import DegenerateHandlesError
from ..gl.context import GLContext
from ..mls import MLS
from .stats import error_stats
from .triangles import triangle_errors

MEASURES = ("combined", "angle", "mls", "distance")
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
    (idw alpha 1 and 2; radius a quarter, half and all of the image diagonal)."""
    diagonal = image_diagonal(as_shape(shape))
    configs = []
    for transform in transforms:
        for weight in weights:
            if weight in RADIUS_WEIGHTS:
                configs += [
                    MLSConfig(transform=transform, weight=weight, radius=round(f * diagonal, 1))
                    for f in RADIUS_FRACTIONS
                ]
            else:
                configs += [
                    MLSConfig(transform=transform, weight=weight, alpha=a) for a in IDW_ALPHAS
                ]
    return configs


def parse_config(spec: str, shape: Sequence[int]) -> list[MLSConfig]:
    """``transform:weight[:name=value,...]``; ``*`` for all transforms or weights; without
    parameters, the default grid of :func:`search_space`. E.g. ``rigid:idw:alpha=2``,
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
    for item in parts[2].split(","):
        name, _, value = item.partition("=")
        if name not in _PARAMETERS or not value:
            raise ValueError(
                f"configuration {spec!r}: expected name=value with name "
                f"{', '.join(_PARAMETERS)}, got {item!r}"
            )
        if isinstance(_PARAMETERS[name], bool):
            if value not in ("true", "false"):
                raise ValueError(f"configuration {spec!r}: {name}=true or false")
            options[name] = value == "true"
        else:
            try:
                options[name] = float(value)
            except ValueError:
                raise ValueError(f"configuration {spec!r}: {name} must be a number") from None
    return [MLSConfig(transform=t, weight=w, **options) for t in transforms for w in weights]


def random_handle_targets(
    handles: HandleSet, trials: int, *, seed: int, jitter: float
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``trials`` (dst, dst_segments) target sets: every vertex of the handles (a point or a
    segment end, with its target) moved by isotropic Gaussian noise of ``jitter`` pixels
    (standard deviation per axis), seeded. One vertex is one (source, target) pair: the ends
    that joined segments share, and a point there, move together; vertices the user left in
    place (q = p) stay there, since they pin the image. For points alone, the same targets
    as :func:`random_targets`."""
    p, q = handles.source_points(), handles.target_points()
    pairs = np.concatenate([p, q], axis=1)
    _, first, inverse = np.unique(pairs, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.intp)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    vertex = rank[inverse.ravel()]  # each row's vertex, numbered by first appearance
    moved = np.any(p != q, axis=1)[:, None]
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(trials):
        target = q + moved * rng.normal(0.0, jitter, (len(first), 2))[vertex]
        out.append((target[: handles.points], target[handles.points :].reshape(-1, 2, 2)))
    return out


def random_targets(
    src: np.ndarray, dst: np.ndarray, trials: int, *, seed: int, jitter: float
) -> list[np.ndarray]:
    """``trials`` target sets for point handles: the user's targets moved by isotropic
    Gaussian noise of ``jitter`` pixels (standard deviation per axis), seeded; handles the
    user left in place (q = p) stay there, since they pin the image. With segments:
    :func:`random_handle_targets`."""
    handles = HandleSet.validate(src, dst)
    return [t for t, _ in random_handle_targets(handles, trials, seed=seed, jitter=jitter)]


def default_jitter(src: np.ndarray, dst: np.ndarray, shape: Sequence[int]) -> float:
    """A quarter of the median displacement of the moved handles, at least 1% of the
    diagonal."""
    moves = np.hypot(*(dst - src).T)
    moves = moves[moves > 0]
    typical = float(np.median(moves)) if len(moves) else 0.0
    return max(0.25 * typical, 0.01 * image_diagonal(as_shape(shape)))


@dataclasses.dataclass(frozen=True)
class TuneResult:
    """``rows``: one dict per configuration, best first (see :data:`MEASURES`); ``skipped``:
    configurations that cannot be built for these handles, with the reason."""

    rows: list[dict]
    skipped: list[dict]
    rank_by: str
    settings: dict

    @property
    def best(self) -> MLSConfig:
        return MLSConfig(**self.rows[0]["config"])


def _handle_miss(m: MLS) -> float:
    """Mean |f(p) - q| over the point handles and the segments' ends."""
    p = np.concatenate([m.src, m.src_segments.reshape(-1, 2)])
    q = np.concatenate([m.dst, m.dst_segments.reshape(-1, 2)])
    return float(np.hypot(*(m(p) - q).T).mean()) if len(p) else 0.0


def _measure(m: MLS, shape, reference: np.ndarray, grid: int) -> dict[str, float]:
    field = error_stats(m.error_field(shape, grid=grid))
    tri = triangle_errors(m, reference)
    return {
        "mls": field["mean"],
        "angle": float(np.mean(tri.angle)),
        "distance": float(np.mean(tri.distance)),
        "flipped": float(tri.flipped.sum()),
        # not ranked, but telling: weights finite at d = 0 do not reach their targets
        "handle_miss": _handle_miss(m),
    }


def _summarise(config: MLSConfig, trials: list[dict[str, float]]) -> dict:
    row: dict = {"config": dataclasses.asdict(config), "label": label(config)}
    for key in trials[0]:
        values = np.array([t[key] for t in trials])
        row[f"{key}_mean"] = float(values.mean())
        row[f"{key}_spread"] = float(values.std())
    return row


def label(config: MLSConfig) -> str:
    """A short name such as ``rigid idw a=2`` or ``affine gaussian R=362``."""
    if config.weight == "idw":
        parameter = f"a={config.alpha:g}" + (f" s={config.s:g}" if config.s != 1e-8 else "")
    else:
        parameter = f"R={config.radius:g}" if config.radius is not None else "R=diag"
    extra = " interp" if config.interpolating else ""
    return f"{config.transform} {config.weight} {parameter}{extra}"


def _rank(rows: list[dict], rank_by: str) -> None:
    best_mls = min(r["mls_mean"] for r in rows)
    best_angle = min(r["angle_mean"] for r in rows)
    for row in rows:
        mls = (
            row["mls_mean"] / best_mls
            if best_mls > 0
            else (1.0 if row["mls_mean"] == 0 else math.inf)
        )
        angle = (
            row["angle_mean"] / best_angle
            if best_angle > 0
            else (1.0 if row["angle_mean"] == 0 else math.inf)
        )
        row["combined"] = 0.5 * mls + 0.5 * angle
    key = "combined" if rank_by == "combined" else f"{rank_by}_mean"
    rows.sort(key=lambda r: (r[key], r["label"]))
    for rank, row in enumerate(rows, 1):
        row["rank"] = rank


def tune(
    shape: Sequence[int],
    src: object,
    dst: object,
    reference_points: object,
    *,
    src_segments: object = None,
    dst_segments: object = None,
    trials: int = 5,
    seed: int = 0,
    configs: Sequence[MLSConfig] | None = None,
    grid: int = 4,
    jitter: float | None = None,
    rank_by: str = "combined",
    ctx: GLContext | None = None,
    on_step: Callable[[], None] | None = None,
) -> TuneResult:
    """Rank configurations for an image of ``shape`` by random deformations around the
    handles: points ``src`` -> ``dst`` and segments ``src_segments`` -> ``dst_segments``
    ((S, 2, 2), as for :class:`~glmls.MLS`; see the module docstring). ``grid``: the error
    field's mesh step (pixels)."""
    shape = as_shape(shape)
    if rank_by not in MEASURES:
        raise ValueError(f"unknown measure {rank_by!r}; choose one of {', '.join(MEASURES)}")
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise ValueError(f"trials must be an integer >= 1, got {trials!r}")
    configs = list(configs) if configs is not None else search_space(shape)
    if not configs:
        raise ValueError("no configurations to compare")
    handles = HandleSet.validate(src, dst, src_segments, dst_segments)
    reference = np.asarray(reference_points, dtype=float)
    if jitter is None:
        jitter = default_jitter(handles.source_points(), handles.target_points(), shape)
    jitter = float(jitter)
    if not (math.isfinite(jitter) and jitter >= 0):
        raise ValueError(f"jitter must be a finite number >= 0, got {jitter}")
    targets = random_handle_targets(handles, trials, seed=seed, jitter=jitter)
    rows, skipped = [], []
    for config in configs:
        results = []
        for target, segment_target in targets:
            try:
                with MLS.from_config(
                    handles.src,
                    target,
                    config,
                    shape=shape,
                    ctx=ctx,
                    src_segments=handles.src_segments,
                    dst_segments=segment_target,
                ) as m:
                    results.append(_measure(m, shape, reference, grid))
            except DegenerateHandlesError as error:
                skipped.append({"config": dataclasses.asdict(config), "reason": str(error)})
                break
            finally:
                if on_step is not None:
                    on_step()
        if len(results) == trials:
            rows.append(_summarise(config, results))
    if not rows:
        raise ValueError("no configuration could be evaluated: " + skipped[0]["reason"])
    _rank(rows, rank_by)
    settings = {"trials": trials, "seed": seed, "grid": grid, "jitter_px": jitter}
    return TuneResult(rows, skipped, rank_by, settings)
