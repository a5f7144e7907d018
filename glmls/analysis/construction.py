"""The construction error: how well the deformed image's colours follow the input's around the
user's reference points, the metric that section 6 of "Extensions to the MLS method for image
deformation" asks for ("use the user reference points ... as indicators of how much the color
field has changed around them").

The two measures of section 5 judge f alone; this one judges the last step, building the
deformed image from f (``quads``, ``splat``, ``backward``, nearest or linear sampling). Around
each reference point r, the output's own pixels are compared with what an ideal construction
would put there: the input, bilinearly interpolated, at the preimage of each pixel under the
local linear map of f at r. The deformation itself is thereby factored out; what remains is
resampling (nearest's blocks, splat's holes, a construction's misplaced pixels, quantisation).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..core.config import check_choice, check_integer, check_real, check_result_bytes
from ..core.handles import as_points
from ..imaging.source import BORDERS, check_image
from .field import image_deformation
from .stats import error_stats
from .volume_lattice import real_values

__all__ = [
    "ALIGNMENTS",
    "DEFAULT_RADIUS",
    "SNAP",
    "STEP",
    "ConstructionErrors",
    "check_radius",
    "check_window_memory",
    "construction_errors",
    "local_maps",
]

#: Half-size of the window in output pixels: (2 radius + 1)² pixels around f(r).
DEFAULT_RADIUS = 2
#: Finite-difference step (pixels) of the Jacobian of f. Central differences are exact for
#: maps up to quadratic; half a pixel keeps the GPU's float32 noise (~1e-6 px) 1e-6 of the
#: slope, while the window sees f's curvature over a few pixels anyway.
STEP = 0.5
#: A source position this close (pixels, per axis) to a pixel centre is taken as that centre.
#: f comes from the GPU in float32 (about 1e-6 of the coordinates in error: up to 1e-3 px on
#: the largest images); dropping a bilinear weight below 1e-3 changes a colour by < 1e-3 of
#: its local contrast (a quarter of an 8-bit level), while it lets the identity and integer
#: shifts score exactly 0 instead of float32 noise.
SNAP = 1e-3
#: How the window is aligned: ``jacobian`` (Df(r), the tangent map of f) or ``matrix`` (the
#: MLS's own M(r), the paper's l_r; needs ``m.matrices``).
ALIGNMENTS = ("jacobian", "matrix")
#: ``border`` -> scipy.ndimage mode of the same rule (``constant``: windows that leave the
#: image are undefined, inside it the edge is clamped as GL's bilinear sampling clamps it).
_MODES = {
    "constant": "nearest",
    "edge": "nearest",
    "symmetric": "reflect",
    "reflect": "mirror",
    "wrap": "grid-wrap",
}
#: Above this condition number, f is taken as singular at r (the window's preimage would be
#: a needle many pixels long, not a neighbourhood).
_CONDITION_LIMIT = 1e6


@dataclass(frozen=True, eq=False)
class ConstructionErrors:
    """The construction error at each reference point, as :func:`construction_errors` finds it.

    The arrays are read-only.

    Attributes
    ----------
    values : numpy.ndarray
        (N,) float64: the RMS colour difference over the window and the channels, in
        intensity units scaled to 0-1 (uint8 / 255, uint16 / 65535, floats as they are); NaN
        where undefined (the window leaves the output canvas, or its preimage leaves the
        source with ``border="constant"``, or f is singular at r), in the order of ``points``.
    points : numpy.ndarray
        The reference points r, (N, 2).
    deformed_points : numpy.ndarray
        f(r), (N, 2).
    matrices : numpy.ndarray
        (N, 2, 2): the linear part of the local map used to align each window (Df(r) for
        ``alignment="jacobian"``, the MLS's M(r) for ``"matrix"``; row vectors,
        ``l_r(v) = f(r) + (v - r) @ matrices[k]``).
    centres : numpy.ndarray
        (N, 2) int: the output pixel (column, row) at the centre of each window (the pixel
        containing f(r), in the output array's indices).
    radius : int
        The window's half-size: (2 radius + 1)² output pixels.
    alignment : str
        ``"jacobian"`` or ``"matrix"``.
    border : str
        The warp's border mode.
    origin : tuple of float
        (x0, y0) of the output canvas.
    scale : float
        The intensity that counts as 1: 255, 65535 or 1.0.

    Examples
    --------
    >>> image = np.arange(256, dtype=np.uint8).reshape(16, 16)
    >>> with glmls.MLS([[2, 2], [13, 2], [2, 13]], [[3, 2], [14, 2], [3, 13]]) as m:
    ...     errors = glmls.analysis.construction_errors(image, m.warp(image), m, [[8, 8]])
    >>> errors.values.tolist(), errors.centres.tolist()  # a shift by a whole pixel: exact
    ([0.0], [[9, 8]])
    >>> errors.units
    'RMS colour difference, intensity / 255 (0-1)'
    >>> errors.settings()["window"], errors.stats()["count"]
    (5, 1)
    """

    values: np.ndarray
    points: np.ndarray
    deformed_points: np.ndarray
    matrices: np.ndarray
    centres: np.ndarray
    radius: int
    alignment: str
    border: str
    origin: tuple[float, float]
    scale: float

    @property
    def units(self) -> str:
        """What ``values`` measure, in words.

        Examples
        --------
        >>> image = np.arange(256, dtype=np.uint8).reshape(16, 16)
        >>> points = [[8, 8], [4, 4]]
        >>> with glmls.MLS([[2, 2], [13, 2], [2, 13]], [[3, 2], [14, 2], [3, 13]]) as m:
        ...     errors = glmls.analysis.construction_errors(image, m.warp(image), m, points)
        >>> errors.units
        'RMS colour difference, intensity / 255 (0-1)'
        """
        return f"RMS colour difference, intensity / {self.scale:g} (0-1)"

    def stats(self) -> dict[str, object]:
        """JSON-ready statistics of ``values``.

        Returns
        -------
        dict
            :func:`glmls.analysis.error_stats` of ``values`` (eqs. 8, 9), the undefined
            points counted in ``nan_count``.

        Examples
        --------
        >>> image = np.arange(256, dtype=np.uint8).reshape(16, 16)
        >>> points = [[8, 8], [4, 4]]
        >>> with glmls.MLS([[2, 2], [13, 2], [2, 13]], [[3, 2], [14, 2], [3, 13]]) as m:
        ...     errors = glmls.analysis.construction_errors(image, m.warp(image), m, points)
        >>> stats = errors.stats()
        >>> stats["count"], stats["nan_count"], stats["max"]  # a whole-pixel shift: exact
        (2, 0, 0.0)
        """
        return error_stats(self.values)

    def settings(self) -> dict[str, object]:
        """JSON-ready description of how the values were measured.

        Returns
        -------
        dict
            ``points``, ``radius``, ``window`` (2 radius + 1), ``alignment``, ``border``,
            ``origin`` and ``units``.

        Examples
        --------
        >>> image = np.arange(256, dtype=np.uint8).reshape(16, 16)
        >>> points = [[8, 8], [4, 4]]
        >>> with glmls.MLS([[2, 2], [13, 2], [2, 13]], [[3, 2], [14, 2], [3, 13]]) as m:
        ...     errors = glmls.analysis.construction_errors(image, m.warp(image), m, points)
        >>> settings = errors.settings()
        >>> settings["points"], settings["window"]
        (2, 5)
        """
        return {
            "points": len(self.values),
            "radius": self.radius,
            "window": 2 * self.radius + 1,
            "alignment": self.alignment,
            "border": self.border,
            "origin": list(self.origin),
            "units": self.units,
        }


def _image(array: object, name: str) -> np.ndarray:
    """An image as (H, W, C) of its own dtype; ``TypeError``/``ValueError`` naming it."""
    data = check_image(array, name)
    if data.dtype.kind == "f" and not np.isfinite(data).all():
        raise ValueError(f"{name} holds NaN or infinite values")
    return data.reshape(*data.shape[:2], -1)


def _scale(dtype: np.dtype) -> float:
    return float(np.iinfo(dtype).max) if dtype.kind == "u" else 1.0


def _check_pair(image: np.ndarray, output: np.ndarray, raw: tuple, out_raw: tuple) -> None:
    if len(raw) != len(out_raw) or image.shape[2] != output.shape[2]:
        raise ValueError(f"output must have the image's channels: image {raw}, output {out_raw}")
    if image.dtype != output.dtype and not (image.dtype.kind == output.dtype.kind == "f"):
        raise TypeError(
            f"output dtype {output.dtype} does not match the image's {image.dtype} "
            "(m.warp returns the input's dtype)"
        )


def _origin(origin: object, image_shape: tuple, output_shape: tuple) -> tuple[float, float]:
    if origin is None:
        if image_shape != output_shape:
            raise ValueError(
                f"output is {output_shape[0]} x {output_shape[1]} but the image "
                f"{image_shape[0]} x {image_shape[1]}: for a warp on another canvas pass its "
                "origin= (e.g. Bounds.origin)"
            )
        return (0.0, 0.0)
    point = np.asarray(origin, dtype=np.float64) if _is_numbers(origin) else None
    if point is None or point.shape != (2,) or not np.isfinite(point).all():
        raise ValueError(f"origin must be two finite numbers (x0, y0), got {origin!r}")
    return float(point[0]), float(point[1])


def _is_numbers(value: object) -> bool:
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        return False
    return array.dtype.kind in "iuf"


def check_radius(radius: object, name: str = "radius") -> int:
    """``radius`` as an int, an integer >= 0 (glmls's integer rule,
    :func:`glmls.core.config.check_integer`): ``TypeError`` naming ``name`` and the value for
    another type (a float, a bool, None), ``ValueError`` for a negative one."""
    return check_integer(name, radius, 0, what="an integer >= 0 (output pixels)")


def check_window_memory(radius: int, points: int, channels: int) -> None:
    """``ValueError`` (:func:`~glmls.core.config.check_result_bytes`'s) where the windows of
    ``radius`` around ``points`` points of an image of ``channels`` channels would need more
    than this machine's memory: what :func:`construction_errors` checks, for a caller that
    can check before other work."""
    check_result_bytes(
        f"construction_errors' windows of radius {radius} at {points} points",
        points * (2 * radius + 1) ** 2 * (96 + 16 * channels),
    )


def _options(radius: object, alignment: object, border: object, snap: object) -> None:
    check_radius(radius)
    check_choice("alignment", alignment, ALIGNMENTS)
    check_choice("border", border, BORDERS)
    check_real(
        "snap", snap, low=0, high=0.5, high_open=True, what="a finite number in [0, 0.5) (pixels)"
    )


def _evaluate(f: Callable[[np.ndarray], object], points: np.ndarray, name: str) -> np.ndarray:
    values = real_values(f(points), f"{name}(points)")
    if values.shape != points.shape:
        raise ValueError(f"{name}(points) returned shape {values.shape}, expected {points.shape}")
    return values


def local_maps(
    m: object, points: np.ndarray, *, alignment: str = "jacobian", step: float = STEP
) -> tuple[np.ndarray, np.ndarray]:
    """(f(r) (N, 2), linear part (N, 2, 2)) of the local linear map of ``m`` at each point.

    ``jacobian``: central differences of f with ``step`` pixels, one call of ``m`` on 5N
    points (exact for maps up to quadratic); ``matrix``: ``m.matrices(points)``, f(r) =
    r @ M + T. Row vectors: the matrix's row i is the derivative along axis i (x, then y).
    """
    if alignment == "matrix":
        if not callable(getattr(m, "matrices", None)):
            raise TypeError(
                f"alignment='matrix' needs an m with matrices(points), got {type(m).__name__}"
            )
        big_m, t = m.matrices(points)  # type: ignore[attr-defined]
        big_m = real_values(big_m, "m.matrices")
        t = real_values(t, "m.matrices")
        if big_m.shape != (len(points), 2, 2) or t.shape != points.shape:
            raise ValueError(f"m.matrices returned shapes {big_m.shape} and {t.shape}")
        return np.einsum("ki,kij->kj", points, big_m) + t, big_m
    n = len(points)
    dx, dy = np.array([step, 0.0]), np.array([0.0, step])
    stacked = np.concatenate([points, points + dx, points - dx, points + dy, points - dy])
    f = _evaluate(m, stacked, "m")  # type: ignore[arg-type]
    parts = [f[k * n : (k + 1) * n] for k in range(5)]
    jacobian = np.stack([parts[1] - parts[2], parts[3] - parts[4]], axis=1) / (2 * step)
    return parts[0], jacobian


def _inverse(matrices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(inverses, defined) of (N, 2, 2) matrices; undefined where not finite or singular."""
    finite = np.isfinite(matrices).all(axis=(1, 2))
    safe = np.where(finite[:, None, None], matrices, np.eye(2))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        defined = finite & (np.linalg.cond(safe) < _CONDITION_LIMIT)
    safe = np.where(defined[:, None, None], safe, np.eye(2))
    return np.linalg.inv(safe), defined


def _sample(image: np.ndarray, xy: np.ndarray, mode: str) -> np.ndarray:
    """Bilinear samples (..., C) of (H, W, C) float64 ``image`` at (x, y) points (..., 2)."""
    from scipy import ndimage  # here: scipy's import takes most of ``import glmls``'s time

    coordinates = [xy[..., 1].ravel(), xy[..., 0].ravel()]
    channels = [
        ndimage.map_coordinates(image[..., c], coordinates, order=1, mode=mode, prefilter=False)
        for c in range(image.shape[2])
    ]
    return np.stack(channels, axis=-1).reshape(*xy.shape[:-1], image.shape[2])


def construction_errors(
    image: object,
    output: object,
    m: object,
    points: object,
    *,
    radius: int = DEFAULT_RADIUS,
    alignment: str = "jacobian",
    border: str = "constant",
    origin: Sequence[float] | None = None,
    snap: float = SNAP,
) -> ConstructionErrors:
    """The construction error of ``output`` (a deformed ``image``) at each reference point.

    It judges the last step of a deformation, building the deformed image from f, the metric
    that section 6 of the paper asks for. For each r, with l_r(v) = f(r) + (v - r) J the
    local linear map of f at r:

    - c = the output pixel containing f(r); the window is the (2 ``radius`` + 1)² output
      pixels u = c + o, o in {-radius..radius}², at their centres;
    - the ideal colour of u is the input at its preimage s = r + (u - f(r)) J⁻¹, bilinearly
      interpolated in float64 (the input's own pixel where s is one, within ``snap`` px);
    - the error is sqrt(mean over the window's pixels and the channels of (output(u) -
      input(s))²), in intensity units scaled to 0-1 (uint8 / 255, uint16 / 65535, floats as
      they are).

    So the deformation is factored out and only the construction is measured: an ideal
    construction (the input sampled bilinearly at f⁻¹(u)) scores the window's deviation from
    linearity and the output's quantisation; nearest sampling, misplaced pixels, holes and
    pixels left to the background (they count as errors) score more. The output's pixels are
    read as they are, not resampled, so that nothing the construction did is smoothed away.

    The identity (and any integer translation) built by a construction that copies pixels
    gives exactly 0: every s is then a pixel centre. NaN: a window that leaves the output, a
    window whose preimage leaves the image with ``border="constant"``, and a point where f is
    singular or not finite.

    Parameters
    ----------
    image : array_like
        The input, (H, W) or (H, W, C): uint8, uint16, float32 or float64.
    output : array_like
        The deformed image as ``m.warp(image, ...)`` returns it: the image's dtype (floats
        may differ in width) and channels.
    m : callable
        The deformation f, a :class:`glmls.MLS` or any function from (K, 2) points to (K, 2)
        points.
    points : array_like
        The reference points r, (N, 2) (x, y) = (column, row), pixel centres at integers.
    radius : int, optional
        The window's half-size in output pixels (>= 0).
    alignment : {"jacobian", "matrix"}, optional
        ``"jacobian"`` J = Df(r), by central differences of ``m`` (``STEP``);
        ``"matrix"`` J = the MLS's own M(r) (``m.matrices``), the paper's l_r. M(r) is not
        the derivative of f: on an ordinary edit they differ by 0.05-0.35, which misaligns
        the window's corners by up to a pixel and counts the deformation as a construction
        error (:doc:`/construction` has the numbers), hence the Jacobian by default.
    border : str, optional
        The warp's border mode (:data:`glmls.BORDERS`). With ``constant`` a point whose
        window's preimage leaves the image (beyond its pixels' edges) is undefined (NaN);
        with the others the input beyond its border follows the rule, as in the warp.
    origin : sequence of float, optional
        (x0, y0) of the canvas of a warp with ``output_shape``/``origin`` (output pixel
        (i, j) shows the point origin + (i, j)); None: the input's frame, and then ``output``
        must have the input's shape.
    snap : float, optional
        A preimage this close (pixels, per axis, in [0, 0.5)) to a pixel centre is taken as
        that centre (``SNAP``).

    Returns
    -------
    ConstructionErrors
        The errors per point, and how they were measured.

    Raises
    ------
    TypeError
        For unsupported or mismatched dtypes, an ``m`` that is not callable or returns values
        that are not real numbers (complex, bool), or an option of the wrong type (a float
        ``radius``, a string ``snap``, an ``alignment`` or ``border`` that is no string),
        naming the value.
    ValueError
        For bad shapes, channel counts, NaN or infinite points or pixels, and bad options,
        naming the value, or windows (``radius``) whose arrays need more than this
        machine's physical memory (about 100 bytes a window pixel a point; the message
        says both, in bytes).

    See Also
    --------
    rank_constructions : the constructions ranked by this error.

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
    ...     nearest = m.warp(image, interpolation="nearest")
    ...     linear = m.warp(image, interpolation="linear")
    ...     worse = glmls.analysis.construction_errors(image, nearest, m, points)
    ...     better = glmls.analysis.construction_errors(image, linear, m, points)
    >>> worse.values.shape, bool((better.values < worse.values).all())
    ((3,), True)
    >>> round(worse.stats()["mean"], 2), round(better.stats()["mean"], 3)
    (0.02, 0.001)
    """
    source, result = _image(image, "image"), _image(output, "output")
    _check_pair(source, result, np.shape(image), np.shape(output))
    canvas = _origin(origin, source.shape[:2], result.shape[:2])
    _options(radius, alignment, border, snap)
    if not callable(m):
        raise TypeError(f"m must be an MLS or a function of points, got {type(m).__name__}")
    r = as_points(points, "points")
    scale = _scale(source.dtype)
    k = int(radius)
    n = len(r)
    channels = source.shape[2] if source.ndim == 3 else 1
    # each window pixel's indices, preimage and samples (float64 and int64 pairs), per point
    check_window_memory(k, n, channels)
    if n:
        # f as m.warp(image) evaluates it: a radius weight's default radius is the image's
        with image_deformation(m, source.shape[:2]) as warp:
            f, linear = local_maps(warp, r, alignment=alignment)
        values, centres = _window_errors(source, result, r, f, linear, k, border, canvas, snap)
        values /= scale
    else:
        f, linear = np.zeros((0, 2)), np.zeros((0, 2, 2))
        values, centres = np.zeros(0), np.zeros((0, 2), np.int64)
    for array in (values, r, f, linear, centres):
        array.flags.writeable = False
    return ConstructionErrors(values, r, f, linear, centres, k, alignment, border, canvas, scale)


def _window_errors(
    source: np.ndarray,
    result: np.ndarray,
    r: np.ndarray,
    f: np.ndarray,
    linear: np.ndarray,
    k: int,
    border: str,
    origin: tuple[float, float],
    snap: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(RMS errors in raw intensity units (N,), window centres (N, 2)) -- see
    :func:`construction_errors`."""
    inverse, defined = _inverse(linear)
    finite_f = np.isfinite(f).all(axis=1)
    defined &= finite_f
    plane = np.where(finite_f[:, None], f, 0.0) - np.asarray(origin)
    # clipped far outside so that the integer conversion cannot overflow; those are undefined
    centres = np.rint(np.clip(plane, -1e9, 1e9)).astype(np.int64)
    offsets = np.stack(np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1)), -1).reshape(-1, 2)
    pixels = centres[:, None, :] + offsets[None]  # (N, P, 2) output indices (column, row)
    height, width = result.shape[:2]
    inside = (pixels >= 0).all(-1) & (pixels[..., 0] < width) & (pixels[..., 1] < height)
    defined &= inside.all(axis=1)
    # the preimage under l_r of each output pixel centre, in the input's pixels
    delta = pixels + np.asarray(origin) - np.where(finite_f[:, None], f, 0.0)[:, None, :]
    s = r[:, None, :] + np.einsum("npi,nij->npj", delta, inverse)
    nearest = np.rint(s)
    s = np.where(np.abs(s - nearest) <= snap, nearest, s)
    if border == "constant":
        low, high = -0.5, np.array([source.shape[1], source.shape[0]]) - 0.5
        defined &= ((s >= low) & (s <= high)).all(axis=(1, 2))
    s = np.where(defined[:, None, None], s, 0.0)
    ideal = _sample(source.astype(np.float64), s, _MODES[border])
    safe = np.clip(pixels, 0, [width - 1, height - 1])
    got = result[safe[..., 1], safe[..., 0]].astype(np.float64)
    errors = np.sqrt(np.mean((got - ideal) ** 2, axis=(1, 2)))
    return np.where(defined, errors, math.nan), centres
