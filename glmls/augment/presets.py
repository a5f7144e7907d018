"""The random deformations of :class:`glmls.augment.Augment`: each preset is a frozen
dataclass of its options with a ``draw(rng, shape, landmarks)`` method that returns one
sample's handles p (``src``) and q (``dst``), (K, 2) float arrays in pixels (x, y).

The text-line presets follow Luo et al., "Learn to Augment: Joint Data Augmentation and
Network Optimization for Text Recognition" (CVPR 2020): the image is cut into ``segments``
patches along its width, with 2 (segments + 1) fiducial points on its top and bottom edges,
and the fiducial points are moved at random within a radius R. Each mode moves them as the
authors' toolkit does (https://github.com/Canjie-Luo/Text-Image-Augmentation,
``src/Augment.cpp``), with its defaults of R: W / segments / 3 for distortion,
4/5 W / segments for stretching, H / 2 for perspective. The offsets are continuous where the
toolkit's are whole pixels, the points evenly spaced on the image's outer pixel edges, and the
perspective keeps the points between the corners (the toolkit moves the corners alone):
:doc:`/augment` says why.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..core.config import check_choice, check_flag, check_integer, check_real

__all__ = [
    "MAX_HANDLES",
    "PRESETS",
    "GridPreset",
    "LandmarksPreset",
    "TextDistortPreset",
    "TextPerspectivePreset",
    "TextStretchPreset",
    "preset_from",
]

UNITS = ("fraction", "pixels")

#: The most handles a ``grid`` or text preset draws per image (``rows * cols``,
#: ``2 (segments + 1)``): 2**20, a 1024 x 1024 grid. Its points cost 16 bytes each several
#: times over as they are drawn, and a count in the billions would exhaust the memory before
#: :func:`glmls.warp_batch` could refuse it.
MAX_HANDLES = 1 << 20


def _check_count(preset: object, name: str, low: int) -> None:
    """``preset``'s ``name``, an integer >= ``low``, stored as an int."""
    object.__setattr__(preset, name, check_integer(name, getattr(preset, name), low))


def _check_handles(count: int, spelled: str) -> None:
    """``ValueError`` for a preset whose ``count`` handles (``spelled`` out from its options)
    exceed :data:`MAX_HANDLES`."""
    if count > MAX_HANDLES:
        raise ValueError(
            f"{spelled} = {count:,} handles per image; at most {MAX_HANDLES:,}: use fewer"
        )


#: Handles along an axis that a preset may draw whatever the image's size (a few handles
#: cost little even on a tiny image): beyond, at most one per pixel (:func:`_check_spacing`).
_FEW_HANDLES = 64


def _check_spacing(name: str, count: int, gaps: int, length: int, axis: str) -> None:
    """``ValueError`` where ``count`` handles along an image ``length`` pixels long (its
    ``axis``), more than :data:`_FEW_HANDLES`, leave ``gaps`` gaps narrower than a pixel:
    finer than the pixels they move, and a cost that grows with their number for nothing
    (a text crop 128 wide cut into 500,000 segments warps for minutes)."""
    most = max(length + count - gaps, _FEW_HANDLES)
    if count > most:
        raise ValueError(
            f"{name} = {count:,} is more than one per pixel of the image's {axis} "
            f"({length}): at most {most:,} for this image"
        )


def _check_length(preset: object, name: str, *, optional: bool = False) -> None:
    """``preset``'s ``name``, a magnitude (a real option,
    :func:`~glmls.core.config.check_real`), stored as a float: ``TypeError`` naming ``name``
    and the value for one that is no real number (a bool, a string, None where it is not
    ``optional``), ``ValueError`` for one that is not finite or negative."""
    value = getattr(preset, name)
    if not (optional and value is None):
        object.__setattr__(preset, name, check_real(name, value, low=0))


def _check_units(units: object) -> None:
    check_choice("units", units, UNITS)


def _edges(shape: tuple[int, int]) -> tuple[float, float, float, float]:
    """The image's outer edges (left, top, right, bottom): pixel centres sit at integers."""
    height, width = shape
    return -0.5, -0.5, width - 0.5, height - 0.5


#: Landmarks closer than this many float32 steps of the handles' extent move as one.
_MERGE_STEPS = 16


def _first_near(points: np.ndarray, near: float) -> np.ndarray:
    """(P,) for each of the (P, 2) ``points`` the first of the points linked to it by
    steps of at most ``near`` on each axis (itself where none is that near)."""
    count = len(points)
    first = np.arange(count)
    if count < 2:
        return first
    xs = np.sort(points[:, 0])
    if np.diff(xs).min() > near:  # the usual case: no two points that near
        return first
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(near, p=np.inf, output_type="ndarray")
    if not len(pairs):
        return first
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(count, count))
    _, group = connected_components(graph, directed=False)
    lowest = np.full(group.max() + 1, count)
    np.minimum.at(lowest, group, first)
    return lowest[group]


def _fiducials(shape: tuple[int, int], segments: int) -> tuple[np.ndarray, np.ndarray]:
    """The x of the segments + 1 fiducial columns and the (top, bottom) edges' y."""
    left, top, right, bottom = _edges(shape)
    return np.linspace(left, right, segments + 1), np.array([top, bottom])


@lru_cache(maxsize=16)  # a batch's images share a few shapes: each sample draws its copy
def _grid(shape: tuple[int, int], rows: int, cols: int) -> np.ndarray:
    """(rows * cols, 2): the grid of handles spread evenly over the image, edges included."""
    left, top, right, bottom = _edges(shape)
    xs, ys = np.meshgrid(np.linspace(left, right, cols), np.linspace(top, bottom, rows))
    grid = np.stack([xs.ravel(), ys.ravel()], axis=1)
    grid.flags.writeable = False
    return grid


def _jitter(rng, size, shape: tuple[int, int], displacement: float, units: str) -> np.ndarray:
    """Random offsets within +-``displacement`` per axis, in pixels or fractions of the
    image's (W, H)."""
    return rng.uniform(-1.0, 1.0, size=size) * _largest_offset(shape, displacement, units)


def _largest_offset(shape: tuple[int, int], displacement: float, units: str) -> np.ndarray:
    """The largest offset (x, y) of :func:`_jitter`, in pixels."""
    scale = np.array([shape[1], shape[0]], np.float64) if units == "fraction" else 1.0
    return displacement * scale * np.ones(2)


def _pairs(xs_top, ys_top, xs_bottom, ys_bottom) -> np.ndarray:
    """(2 (S + 1), 2) points: the top edge's, then the bottom edge's, left to right."""
    top = np.stack([xs_top, ys_top], axis=1)
    bottom = np.stack([xs_bottom, ys_bottom], axis=1)
    return np.concatenate([top, bottom]).astype(np.float64)


@dataclass(frozen=True, kw_only=True)
class GridPreset:
    """A jittered control grid of ``rows`` x ``cols`` handles over the image.

    The handles are spread evenly over the image, its edges included, each moved by a random
    offset within +-``displacement`` per axis.

    Parameters
    ----------
    rows, cols : int, default 4
        The grid's size (>= 2 each; ``rows * cols`` at most :data:`MAX_HANDLES`, 2**20;
        and, beyond 64, at most H + 1 rows and W + 1 columns on an H x W image, handles a
        pixel apart: a draw on a smaller image raises ``ValueError``).
    displacement : float, default 0.03
        The largest offset per axis: a fraction of the image's width (x) and height (y)
        with ``units="fraction"``, pixels with ``units="pixels"``.
    units : {"fraction", "pixels"}, default "fraction"
        The unit of ``displacement``.

    Raises
    ------
    ValueError
        For a value out of range, naming it.
    TypeError
        For a value of the wrong type (a float count, a bool or string magnitude), naming it.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment import GridPreset
    >>> src, dst = GridPreset(rows=3, cols=3).draw(np.random.default_rng(0), (20, 30))
    >>> src.shape, bool(np.abs(dst - src).max() <= 0.03 * 30)
    ((9, 2), True)
    """

    name = "grid"
    #: the quads' mesh step it warps with by default (glmls.augment.DEFAULT_WARP_OPTIONS)
    warp_grid = 4
    warp_transform = "similarity"
    rows: int = 4
    cols: int = 4
    displacement: float = 0.03
    units: str = "fraction"

    def __post_init__(self) -> None:
        _check_count(self, "rows", 2)
        _check_count(self, "cols", 2)
        _check_handles(self.rows * self.cols, f"rows * cols = {self.rows} * {self.cols}")
        _check_length(self, "displacement")
        _check_units(self.units)

    def draw(self, rng: np.random.Generator, shape: tuple[int, int], landmarks=None):
        """One sample's handles.

        Parameters
        ----------
        rng : numpy.random.Generator
            The sample's random numbers.
        shape : (int, int)
            The image's (H, W).
        landmarks : None
            Not used.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            src and dst, (rows * cols, 2).

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment import GridPreset
        >>> src, dst = GridPreset(displacement=0).draw(np.random.default_rng(1), (8, 8))
        >>> bool((src == dst).all()), src[0].tolist(), src[-1].tolist()
        (True, [-0.5, -0.5], [7.5, 7.5])
        """
        _check_spacing("rows", self.rows, self.rows - 1, shape[0], "height")
        _check_spacing("cols", self.cols, self.cols - 1, shape[1], "width")
        src = _grid(tuple(shape), self.rows, self.cols).copy()
        return src, src + _jitter(rng, src.shape, shape, self.displacement, self.units)

    def reach(self, shape: tuple[int, int], landmarks=None) -> float:
        """The largest ``|x|`` or ``|y|`` that a draw can give a handle (a bound).

        Parameters
        ----------
        shape : (int, int)
            The image's (H, W).
        landmarks : None
            Not used.

        Returns
        -------
        float
            Pixels: the image's far edge plus the largest offset, per axis.

        Examples
        --------
        >>> from glmls.augment import GridPreset
        >>> GridPreset(displacement=3, units="pixels").reach((8, 20))
        22.5
        """
        dx, dy = _largest_offset(shape, self.displacement, self.units)
        return float(max(shape[1] - 0.5 + dx, shape[0] - 0.5 + dy))


@dataclass(frozen=True, kw_only=True)
class _TextPreset:
    """The options and the draw of Luo et al.'s text-line presets: ``segments`` patches,
    fiducial points moved within ``radius``; each preset says its default radius and how
    the points move."""

    segments: int = 4
    radius: float | None = None
    #: the quads' mesh step it warps with by default (glmls.augment.DEFAULT_WARP_OPTIONS):
    #: a text crop's strong bends on a few dozen rows want a finer mesh than grid 4
    warp_grid = 2
    #: the MLS it warps with by default: the similarity MLS, as Luo et al.
    warp_transform = "similarity"

    def __post_init__(self) -> None:
        _check_count(self, "segments", 1)
        _check_handles(2 * (self.segments + 1), f"2 (segments + 1) = 2 ({self.segments} + 1)")
        _check_length(self, "radius", optional=True)

    def _default_radius(self, shape: tuple[int, int]) -> float:
        raise NotImplementedError

    def _move(self, rng, xs, top, bottom, radius, src) -> np.ndarray:
        """dst from the fiducial columns ``xs``, the edges' y and the points ``src``."""
        raise NotImplementedError

    def draw(self, rng: np.random.Generator, shape: tuple[int, int], landmarks=None):
        """One sample's handles.

        Parameters
        ----------
        rng : numpy.random.Generator
            The sample's random numbers.
        shape : (int, int)
            The image's (H, W).
        landmarks : None
            Not used.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            src and dst, (2 (segments + 1), 2): the top edge's points, then the bottom's.

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment import TextDistortPreset
        >>> src, _ = TextDistortPreset(segments=2).draw(np.random.default_rng(0), (4, 10))
        >>> src.tolist()
        [[-0.5, -0.5], [4.5, -0.5], [9.5, -0.5], [-0.5, 3.5], [4.5, 3.5], [9.5, 3.5]]
        """
        _check_spacing("segments", self.segments, self.segments, shape[1], "width")
        xs, (top, bottom) = _fiducials(shape, self.segments)
        radius = self._default_radius(shape) if self.radius is None else float(self.radius)
        count = len(xs)
        src = _pairs(xs, np.full(count, top), xs, np.full(count, bottom))
        return src, self._move(rng, xs, top, bottom, radius, src)

    def reach(self, shape: tuple[int, int], landmarks=None) -> float:
        """The largest ``|x|`` or ``|y|`` that a draw can give a handle (a bound).

        Parameters
        ----------
        shape : (int, int)
            The image's (H, W).
        landmarks : None
            Not used.

        Returns
        -------
        float
            Pixels: the image's far edge plus the radius R (no point moves further).

        Examples
        --------
        >>> from glmls.augment import TextDistortPreset
        >>> TextDistortPreset(radius=4).reach((32, 120))
        123.5
        """
        radius = self._default_radius(shape) if self.radius is None else float(self.radius)
        return float(max(shape) - 0.5 + radius)


@dataclass(frozen=True, kw_only=True)
class TextDistortPreset(_TextPreset):
    """Luo et al.'s distortion of a text line: fiducial points moved within a radius.

    Every fiducial point moves at random: a corner by up to ``radius`` inwards along each
    axis, any other point by up to ``radius / 2`` either way along each axis.

    Parameters
    ----------
    segments : int, default 4
        The patches along the width (2 (segments + 1) fiducial points, at most
        :data:`MAX_HANDLES`; and, beyond 64, at most W, patches a pixel wide, on an image W
        wide: a draw on a narrower image raises ``ValueError``).
    radius : float or None, default None
        R in pixels; None: W / segments / 3.

    Raises
    ------
    ValueError
        For a value out of range, naming it.
    TypeError
        For a value of the wrong type (a float count, a bool or string magnitude), naming it.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment import TextDistortPreset
    >>> src, dst = TextDistortPreset().draw(np.random.default_rng(0), (32, 120))
    >>> src.shape, bool(np.abs(dst - src).max() <= 10)
    ((10, 2), True)
    """

    name = "text-distort"
    draw = _TextPreset.draw  # listed among this preset's own methods
    reach = _TextPreset.reach

    def _default_radius(self, shape: tuple[int, int]) -> float:
        return shape[1] / self.segments / 3

    def _move(self, rng, xs, top, bottom, radius, src) -> np.ndarray:
        count = len(xs)
        offset = rng.uniform(-0.5, 0.5, size=src.shape) * radius
        inwards = rng.uniform(0.0, 1.0, size=(4, 2)) * radius
        corners = [0, count - 1, count, 2 * count - 1]  # top left, top right, bottom left, right
        signs = np.array([[1, 1], [-1, 1], [1, -1], [-1, -1]], np.float64)
        offset[corners] = inwards * signs
        return src + offset


@dataclass(frozen=True, kw_only=True)
class TextStretchPreset(_TextPreset):
    """Luo et al.'s stretching of a text line: fiducial pairs moved horizontally.

    The inner fiducial points move horizontally by up to ``radius / 2`` either way, each top
    point with the bottom point below it (the pair stays aligned); the corners stay.

    Parameters
    ----------
    segments : int, default 4
        The patches along the width (2 (segments + 1) fiducial points, at most
        :data:`MAX_HANDLES`; and, beyond 64, at most W, patches a pixel wide, on an image W
        wide: a draw on a narrower image raises ``ValueError``).
    radius : float or None, default None
        R in pixels; None: 4/5 W / segments.

    Raises
    ------
    ValueError
        For a value out of range, naming it.
    TypeError
        For a value of the wrong type (a float count, a bool or string magnitude), naming it.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment import TextStretchPreset
    >>> src, dst = TextStretchPreset().draw(np.random.default_rng(0), (32, 120))
    >>> bool((dst[:, 1] == src[:, 1]).all()), bool((dst[:5, 0] == dst[5:, 0]).all())
    (True, True)
    >>> src, dst = TextStretchPreset(segments=1).draw(np.random.default_rng(0), (4, 10))
    >>> bool((src == dst).all())
    True
    """

    name = "text-stretch"
    draw = _TextPreset.draw  # listed among this preset's own methods
    reach = _TextPreset.reach

    def _default_radius(self, shape: tuple[int, int]) -> float:
        return shape[1] * 4 / 5 / self.segments

    def _move(self, rng, xs, top, bottom, radius, src) -> np.ndarray:
        count = len(xs)
        move = rng.uniform(-0.5, 0.5, size=count) * radius
        move[[0, -1]] = 0.0
        return _pairs(xs + move, np.full(count, top), xs + move, np.full(count, bottom))


@dataclass(frozen=True, kw_only=True)
class TextPerspectivePreset(_TextPreset):
    """Luo et al.'s perspective change of a text line: its edges moved vertically.

    The top and bottom edges move vertically and independently, each corner by up to
    ``radius`` inwards; the fiducial points between stay on the straight edge between their
    corners. It warps with the affine MLS by default (the other presets: the similarity
    MLS, as Luo et al.): handles moved vertically along two lines are a trapezoid's, which
    the similarity MLS follows only by bending the plane between them, folding it in about
    half of the draws at R = H / 2; the affine MLS keeps the moved edges straight within a
    fraction of a pixel and folds in about 1 % of them (``warp_options={"transform":
    "similarity"}`` gives the authors' MLS).

    Parameters
    ----------
    segments : int, default 4
        The patches along the width (2 (segments + 1) fiducial points, at most
        :data:`MAX_HANDLES`; and, beyond 64, at most W, patches a pixel wide, on an image W
        wide: a draw on a narrower image raises ``ValueError``).
    radius : float or None, default None
        R in pixels; None: H / 2.

    Raises
    ------
    ValueError
        For a value out of range, naming it.
    TypeError
        For a value of the wrong type (a float count, a bool or string magnitude), naming it.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment import TextPerspectivePreset
    >>> src, dst = TextPerspectivePreset().draw(np.random.default_rng(0), (32, 120))
    >>> bool((dst[:, 0] == src[:, 0]).all()), bool(np.abs(dst - src).max() <= 16)
    (True, True)
    >>> _, dst = TextPerspectivePreset(radius=0).draw(np.random.default_rng(0), (4, 10))
    >>> dst[:, 1].tolist()
    [-0.5, -0.5, -0.5, -0.5, -0.5, 3.5, 3.5, 3.5, 3.5, 3.5]
    """

    name = "text-perspective"
    draw = _TextPreset.draw  # listed among this preset's own methods
    reach = _TextPreset.reach
    warp_transform = "affine"

    def _default_radius(self, shape: tuple[int, int]) -> float:
        return shape[0] / 2

    def _move(self, rng, xs, top, bottom, radius, src) -> np.ndarray:
        inwards = rng.uniform(0.0, 1.0, size=4) * radius  # top left, top right, bottom l, r
        t = (xs - xs[0]) / (xs[-1] - xs[0])
        ys_top = top + inwards[0] + t * (inwards[1] - inwards[0])
        ys_bottom = bottom - inwards[2] - t * (inwards[3] - inwards[2])
        return _pairs(xs, ys_top, xs, ys_bottom)


@dataclass(frozen=True, kw_only=True)
class LandmarksPreset:
    """Each image's own landmarks moved at random, the image's corners pinned.

    The landmarks are the ``keypoints`` given with the image, each moved by up to
    +-``displacement`` per axis (equal landmarks, as datasets mark missing ones, and those
    within 16 float32 steps of the handles' extent, which the GPU would not tell apart, to
    one target); with ``pin_corners`` the image's four corners are handles that stay, so that
    the frame holds (and a landmark on a corner stays too).

    Parameters
    ----------
    displacement : float, default 0.03
        The largest offset per axis: a fraction of the image's width (x) and height (y)
        with ``units="fraction"``, pixels with ``units="pixels"``.
    units : {"fraction", "pixels"}, default "fraction"
        The unit of ``displacement``.
    pin_corners : bool, default True
        Add the four corners as fixed handles.

    Raises
    ------
    ValueError
        For a value out of range, naming it.
    TypeError
        For a value of the wrong type (a float count, a bool or string magnitude), naming it.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment import LandmarksPreset
    >>> landmarks = np.array([[10.0, 12.0], [20.0, 8.0]])
    >>> src, dst = LandmarksPreset().draw(np.random.default_rng(0), (32, 32), landmarks)
    >>> src.shape, bool((src[:2] == landmarks).all()), bool((src[2:] == dst[2:]).all())
    ((6, 2), True, True)
    """

    name = "landmarks"
    #: grid 1: each landmark lands next to its drawn target (a tenth of a pixel; a coarser
    #: mesh departs further from f, which bends most at the handles)
    warp_grid = 1
    warp_transform = "similarity"
    displacement: float = 0.03
    units: str = "fraction"
    pin_corners: bool = True

    def __post_init__(self) -> None:
        _check_length(self, "displacement")
        _check_units(self.units)
        object.__setattr__(self, "pin_corners", check_flag("pin_corners", self.pin_corners))

    def draw(self, rng: np.random.Generator, shape: tuple[int, int], landmarks=None):
        """One sample's handles.

        Parameters
        ----------
        rng : numpy.random.Generator
            The sample's random numbers.
        shape : (int, int)
            The image's (H, W).
        landmarks : array_like
            The image's (P, 2) landmarks (P >= 1, or P >= 0 with ``pin_corners``).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray)
            src and dst: the landmarks, then the four corners where pinned.

        Raises
        ------
        ValueError
            Without landmarks.

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment import LandmarksPreset
        >>> preset = LandmarksPreset(displacement=2, units="pixels", pin_corners=False)
        >>> src, dst = preset.draw(np.random.default_rng(0), (9, 9), [[4.0, 4.0]])
        >>> src.tolist(), bool(np.abs(dst - src).max() <= 2)
        ([[4.0, 4.0]], True)
        """
        points = np.zeros((0, 2)) if landmarks is None else np.asarray(landmarks, np.float64)
        if landmarks is None or (len(points) == 0 and not self.pin_corners):
            raise ValueError("the landmarks preset needs each image's landmarks (keypoints)")
        offsets = _jitter(rng, points.shape, shape, self.displacement, self.units)
        # equal landmarks (a dataset's mark of a missing one) move as one, and so do those
        # that float32 on the GPU would not tell apart (a float32 copy of a float64 point)
        extent = max(shape) + np.abs(points).max(initial=0.0) + np.abs(offsets).max(initial=0.0)
        near = _MERGE_STEPS * float(np.finfo(np.float32).eps) * extent
        first = _first_near(points, near)
        src, dst = points, points[first] + offsets[first]  # one target each: the GPU's too
        if self.pin_corners:
            left, top, right, bottom = _edges(shape)
            corners = np.array([[left, top], [right, top], [left, bottom], [right, bottom]])
            gap = np.abs(points[:, None] - corners[None]).max(axis=2)
            pinned = (gap <= near).any(axis=1)
            dst = np.where(pinned[:, None], points, dst)  # a landmark on a corner stays
            src, dst = np.concatenate([src, corners]), np.concatenate([dst, corners])
        return src, dst

    def reach(self, shape: tuple[int, int], landmarks=None) -> float:
        """The largest ``|x|`` or ``|y|`` that a draw can give a handle (a bound).

        Parameters
        ----------
        shape : (int, int)
            The image's (H, W).
        landmarks : array_like or None
            The image's (P, 2) landmarks.

        Returns
        -------
        float
            Pixels: the farthest landmark (or pinned corner) plus the largest offset.

        Examples
        --------
        >>> from glmls.augment import LandmarksPreset
        >>> LandmarksPreset(displacement=2, units="pixels").reach((8, 8), [[30.0, 4.0]])
        32.0
        """
        points = np.zeros((0, 2)) if landmarks is None else np.asarray(landmarks, np.float64)
        far = float(np.abs(points).max(initial=0.0))
        if self.pin_corners:
            far = max(far, shape[0] - 0.5, shape[1] - 0.5)
        return far + float(_largest_offset(shape, self.displacement, self.units).max())


#: The presets by name.
PRESETS = {
    cls.name: cls
    for cls in (
        GridPreset,
        TextDistortPreset,
        TextStretchPreset,
        TextPerspectivePreset,
        LandmarksPreset,
    )
}


def preset_from(preset: object, options: dict) -> object:
    """A preset object from a name and its options, or a preset object as it is (no options
    then); ``ValueError`` listing the valid names, ``TypeError`` for an unknown option."""
    if dataclasses.is_dataclass(preset) and type(preset) in PRESETS.values():
        if options:
            raise TypeError(f"options {sorted(options)} given with a preset object")
        return preset
    if not isinstance(preset, str):
        raise TypeError(
            f"preset must be a name ({', '.join(PRESETS)}) or a preset object, got "
            f"{type(preset).__name__}"
        )
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; expected one of {', '.join(PRESETS)}")
    cls = PRESETS[preset]  # type: ignore[index]
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(options) - known)
    if unknown:
        raise TypeError(
            f"preset {preset!r} has no option {', '.join(unknown)}; its options: "
            f"{', '.join(sorted(known))}"
        )
    return cls(**options)


def preset_defaults(preset: object, options: dict) -> dict:
    """The preset's own warp defaults: ``{"transform": preset.warp_transform}``, and
    ``{"grid": preset.warp_grid}``, the preset's step of the ``quads`` mesh, where the warp
    ``options`` keep the regular mesh (not for the adaptive mesh, a ``tolerance``, nor
    ``paper-quads``, which take grid 1)."""
    regular = options.get("tolerance") is None and options.get("method") != "paper-quads"
    own = {"transform": preset.warp_transform}  # type: ignore[attr-defined]
    return own | ({"grid": preset.warp_grid} if regular else {})  # type: ignore[attr-defined]
