"""The registry of distance weights (Table 1 of "Extensions to the MLS method for image
deformation"): everything glmls knows about each weight, in one table.

Configuration, shaders, spatial bins, the float64 reference, the command line and the window
all read :data:`REGISTRY`; none of them names an individual weight. Adding a weight is one
:class:`Weight` entry here and one GLSL function ``float mls_weight_<name>(float d2, float m,
float inv_m, float sigma)`` in ``glmls/shaders/mls/weights.glsl`` (the README's "Adding a
weight" says how).

Distances: d is the distance from the evaluated point to a source handle, R the influence
radius, alpha and s the idw parameters (all in pixels here; the shaders get them scaled).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..errors import DtypeError

#: Where a weight reaches: every handle (no spatial bins), exactly 0 from d = R on
#: ("radius"), or never 0 but cut where its tail is negligible ("gaussian": against the
#: nearest handles apart from the nearest one's place, whose moments about it decide M).
SUPPORTS = ("everywhere", "radius", "gaussian")
#: The gaussian cut leaves out weights summing to less than this share of the total
#: (float32's unit roundoff; see :func:`reach` and ``glmls/engine/bins.py``).
GAUSSIAN_TOLERANCE = 2.0**-24
#: The gaussian's weights are taken relative to those of the nearest handles apart from the
#: nearest one's place (:func:`gaussian_excess`), the nearer ones' at most e^GAUSSIAN_CAP.
GAUSSIAN_CAP = 60.0


class WeightParameters(Protocol):
    """What a weight may depend on (an :class:`~glmls.MLSConfig` has these)."""

    @property
    def alpha(self) -> float: ...
    @property
    def s(self) -> float: ...


@dataclass(frozen=True)
class Weight:
    """One distance weight.

    - ``name``: as users spell it (``weight="cressman"``);
    - ``formula``: w(d) as text, for help and documentation;
    - ``needs_radius``: it has an influence radius R (``radius=``, default the image
      diagonal);
    - ``support``: one of :data:`SUPPORTS`;
    - ``infinite_at_zero``: whether w(0) is infinite for these parameters, so that MLS
      interpolates the handles exactly (f(p_i) = q_i);
    - ``pole``: the power p of w ~ 1 / d^p at d = 0 for these parameters (0 where w(0) is
      finite): a segment handle's weight, integrated along it, is infinite on it only where
      p >= 1 (:func:`glmls.core.segments.segments_interpolate`);
    - ``uses_s``: the shaders compute idw's scaled s per point (``MLS_WEIGHT_USES_S``);
    - ``reference``: the float64 formula, w for squared distances ``d2`` (K, N) with +inf
      where infinite, a common factor per row allowed (MLS ignores it);
    - ``segment_closed_form``: whether, for these parameters, the integrals of the weight
      along a segment handle have the closed form of ``glmls/shaders/mls/segments.glsl``
      (w = 1 / (s + d^2)); else the shaders integrate numerically;
    - ``edge64``: a radius weight whose float64 GLSL function ``mls_weight64_<name>``
      (:attr:`glsl_function64`) exists: the GPU takes it for the handles near d = R, where the
      weight is a difference of nearly equal numbers that float32 rounds badly
      (``glmls/shaders/mls/weighting.glsl``); without it those handles keep the float32 one.
    - ``slope``: its slope dw/d(d^2) has the GLSL function ``mls_slope_<name>``
      (:attr:`glsl_slope`), from which the 3D Jacobian differentiates the moments; without
      it the shaders differentiate ``mls_weight_<name>`` numerically
      (``glmls/shaders/mls/weighting.glsl``).

    The GLSL function is ``mls_weight_<name>`` (:attr:`glsl_function`).
    """

    name: str
    formula: str
    needs_radius: bool
    support: str
    infinite_at_zero: Callable[[WeightParameters], bool]
    reference: Callable[[np.ndarray, WeightParameters, float | None], np.ndarray]
    uses_s: bool = False
    pole: Callable[[WeightParameters], float] = lambda params: 0.0
    segment_closed_form: Callable[[WeightParameters], bool] = lambda params: False
    edge64: bool = False
    slope: bool = False

    def __post_init__(self) -> None:
        if self.support not in SUPPORTS:
            raise ValueError(f"support must be one of {', '.join(SUPPORTS)}, got {self.support}")
        if self.needs_radius == (self.support == "everywhere"):
            raise ValueError(f"weight {self.name!r}: a radius and a bounded reach go together")
        if self.edge64 and self.support != "radius":
            raise ValueError(f"weight {self.name!r}: edge64 is for radius weights (w = 0 at R)")

    @property
    def glsl_function(self) -> str:
        """The GLSL function of ``glmls/shaders/mls/weights.glsl`` that computes it."""
        return f"mls_weight_{self.name}"

    @property
    def glsl_function64(self) -> str | None:
        """Its float64 GLSL function near d = R, ``mls_weight64_<name>`` (None without
        :attr:`edge64`)."""
        return f"mls_weight64_{self.name}" if self.edge64 else None

    @property
    def glsl_slope(self) -> str | None:
        """Its slope's GLSL function, ``mls_slope_<name>`` (None without :attr:`slope`)."""
        return f"mls_slope_{self.name}" if self.slope else None

    def reach(self, radius: float, count: int) -> float | None:
        """How far (in the units of ``radius``) a point looks for handles among ``count``:
        None for every handle; R where the weight is 0 from R on; R sqrt(ln(N / tau)) for the
        gaussian, whose weights below tau / N of the nearest handle's apart from the nearest
        one's place (tau = :data:`GAUSSIAN_TOLERANCE`) are left out. With a margin against
        rounding at the edges.
        """
        if self.support == "everywhere":
            return None
        factor = math.sqrt(gaussian_cut(count)) if self.support == "gaussian" else 1.0
        return radius * factor * (1.0 + 1e-5)


def gaussian_cut(count: int) -> float:
    """ln(N / tau) for N = ``count`` handles: the gaussian cut's exponent (see bins)."""
    return math.log(max(count, 1) / GAUSSIAN_TOLERANCE)


def squared_distances(d2: object) -> np.ndarray:
    """``d2`` as a (K, N) array of squared distances; ``DtypeError`` for values that are not
    real numbers, ``ValueError`` for another shape, a NaN or a negative value (a weight of
    NaN, or a negative weight: idw's 1 / d2)."""
    array = np.asarray(d2)
    if array.dtype.kind not in "iuf":
        raise DtypeError(f"d2 must be real numbers, got dtype {array.dtype}")
    if array.ndim != 2:  # the Gaussian's factor is per point: a row each
        raise ValueError(f"d2 must be (K, N) squared distances, got shape {array.shape}")
    if not (array >= 0).all():  # NaN fails the comparison too
        raise ValueError("d2 must be squared distances, >= 0 and not NaN")
    return array


def nearest_apart(d2: np.ndarray) -> np.ndarray:
    """(K, 1): per row of squared distances ``d2`` (K, N), the least above the row's least
    (the nearest handles apart from the nearest one's place), or the least where none is
    above it: the gaussian's offset (:func:`gaussian_excess`)."""
    low = d2.min(axis=1, keepdims=True, initial=np.inf)
    above = np.where(d2 > low, d2, np.inf).min(axis=1, keepdims=True, initial=np.inf)
    return np.where(np.isfinite(above), above, low)


def gaussian_excess(d2: np.ndarray, radius: float) -> np.ndarray:
    """(d^2 - g) / R^2 for squared distances ``d2`` (K, N), g per row the least squared
    distance above the row's least (the nearest handles apart from the nearest one's place;
    the least where no distance is above it), at least -:data:`GAUSSIAN_CAP`: how far a
    handle's gaussian exponent is beyond theirs (its weight relative to theirs is exp of minus
    this). Relative to them, not to the nearest, because their moments about the nearest
    decide M in the gaussian's far tail, where the nearest outweighs them by e^30 and more,
    and relative to the nearest their weights would underflow (float32 from ~e^-87, float64
    from ~e^-745); the cap bounds the nearer handles' weights (e^60: their share of the
    others' moments there is far below float64's precision). Finite for any R."""
    offset = nearest_apart(d2)
    with np.errstate(invalid="ignore"):
        shifted = np.where(d2 > offset, d2 - offset, 0.0)
        nearer = np.where(d2 < offset, offset - d2, 0.0)
    return np.maximum(_ratio(shifted, radius) - _ratio(nearer, radius), -GAUSSIAN_CAP)


# -- the float64 formulas ------------------------------------------------------------------------


# Written with d^2 / R^2 rather than R^2 (the same weights up to a common factor), so that a
# radius whose square overflows (1e300) or underflows (1e-200) still gives finite weights.


def _ratio(d2: np.ndarray, radius: float) -> np.ndarray:
    """d^2 / R^2, bounded by 1e300; 0 where d = 0 (also when R^2 underflows)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        t = d2 / (radius * radius) if radius * radius > 0 else np.where(d2 > 0, np.inf, 0.0)
    return np.minimum(np.nan_to_num(t, nan=0.0, posinf=1e300), 1e300)


def _idw(d2: np.ndarray, params: WeightParameters, radius: float | None) -> np.ndarray:
    # times max(s, 1), a factor common to every point and handle: with a large s (1e300) the
    # weights (1e-300) would make the affine moments' determinant underflow to 0
    scale = max(params.s, 1.0)
    return 1.0 / (params.s / scale + d2**params.alpha / scale)


def _cressman(d2: np.ndarray, params: WeightParameters, radius: float | None) -> np.ndarray:
    t = _ratio(d2, radius)  # type: ignore[arg-type]
    return np.maximum(0.0, (1.0 - t) / (1.0 + t))  # (R^2 - d^2) / (R^2 + d^2)


def _shepard(d2: np.ndarray, params: WeightParameters, radius: float | None) -> np.ndarray:
    d = np.sqrt(d2)
    return np.where(d < radius, (1.0 - d / radius) / d, 0.0)  # type: ignore[operator]


def _gaussian(d2: np.ndarray, params: WeightParameters, radius: float | None) -> np.ndarray:
    # divided by its value at the nearest handles apart from the nearest one's place, so that
    # it does not underflow far away (gaussian_excess)
    return np.exp(-gaussian_excess(d2, radius))  # type: ignore[arg-type]


def _linear(d2: np.ndarray, params: WeightParameters, radius: float | None) -> np.ndarray:
    return np.maximum(0.0, 1.0 - np.sqrt(_ratio(d2, radius)))  # type: ignore[arg-type]


def _never(params: WeightParameters) -> bool:
    return False


#: Every weight, in the order users cycle through them.
REGISTRY: dict[str, Weight] = {
    w.name: w
    for w in (
        Weight(
            "idw",
            "1 / (s + d^(2 alpha))",
            needs_radius=False,
            support="everywhere",
            infinite_at_zero=lambda params: params.s == 0.0,
            reference=_idw,
            uses_s=True,
            pole=lambda params: 2.0 * params.alpha if params.s == 0.0 else 0.0,
            segment_closed_form=lambda params: params.alpha == 1.0,
            slope=True,
        ),
        Weight(
            "cressman",
            "max(0, (R^2 - d^2) / (R^2 + d^2))",
            needs_radius=True,
            support="radius",
            infinite_at_zero=_never,
            reference=_cressman,
            edge64=True,
            slope=True,
        ),
        Weight(
            "shepard",
            "max(0, (R - d) / (R d))",
            needs_radius=True,
            support="radius",
            infinite_at_zero=lambda params: True,
            reference=_shepard,
            edge64=True,
            slope=True,
            pole=lambda params: 1.0,
        ),
        Weight(
            "gaussian",
            "exp(-d^2 / R^2)",
            needs_radius=True,
            support="gaussian",
            infinite_at_zero=_never,
            reference=_gaussian,
            slope=True,
        ),
        Weight(
            "linear",
            "max(0, R - d)",
            needs_radius=True,
            support="radius",
            infinite_at_zero=_never,
            reference=_linear,
            edge64=True,
            slope=True,
        ),
    )
}

#: The weights' names.
WEIGHTS = tuple(REGISTRY)
#: Weights with an influence radius R.
RADIUS_WEIGHTS = tuple(name for name, w in REGISTRY.items() if w.needs_radius)


def weight(name: str) -> Weight:
    """The registry entry of ``name``; ``ValueError`` naming the choices if unknown."""
    try:
        return REGISTRY[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown weight {name!r}; choose one of {', '.join(WEIGHTS)}") from None
