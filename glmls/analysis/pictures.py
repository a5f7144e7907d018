"""The paper's pictures of a deformation and its errors, rendered offscreen (:mod:`.canvas`):
the error field (Fig. 6 right), handles as p -> q arrows (Fig. 6 left), the triangulation of
the reference points (Fig. 7 centre) and its triangles filled with the colour of their error
(Fig. 7 right), the deformed mesh, and the construction error at each reference point.
"""

from __future__ import annotations

from collections.abc import Sequence

import moderngl
import numpy as np

from ..core.config import check_flag
from ..core.handles import as_points
from ..core.segments import validate_segments
from ..gl.context import GLContext
from ..gl.helper import when_forked
from .canvas import (
    EDGE_COLOR,
    HANDLE_SOURCE_COLOR,
    HANDLE_TARGET_COLOR,
    Canvas,
    as_rgb8,
    check_size,
)
from .colormaps import NAN_COLOR, apply_colormap, real_values
from .construction import ConstructionErrors
from .shapes import disk_triangles
from .triangles import TriangleErrors

__all__ = [
    "render_construction_errors",
    "render_field",
    "render_handles",
    "render_mesh",
    "render_triangle_errors",
    "render_triangulation",
]


@when_forked
def render_field(
    values: object,
    *,
    cmap: object = "viridis",
    vmin: float | None = None,
    vmax: float | None = None,
    percentile: float | None = None,
    nan_color: Sequence[float] = NAN_COLOR,
    ctx: moderngl.Context | GLContext | None = None,
) -> np.ndarray:
    """A field, e.g. :meth:`glmls.MLS.error_field`, as a colour picture (Fig. 6 right).

    Parameters
    ----------
    values : array_like
        (H, W), finite or NaN.
    cmap : str or array_like, optional
        A colour map, as :func:`apply_colormap` takes it (default viridis).
    vmin, vmax, percentile : float, optional
        The colour limits, as :func:`color_limits` takes them.
    nan_color : sequence of float, optional
        The (r, g, b) colour of undefined (NaN) values.
    ctx : moderngl.Context or GLContext, optional
        The context to draw with (default: glmls's shared headless one).

    Returns
    -------
    numpy.ndarray
        The picture, (H, W, 3) uint8.

    Raises
    ------
    ValueError
        For values that are not (H, W) or hold infinities, or a bad colour map or limits.

    Examples
    --------
    >>> field = np.zeros((8, 8))
    >>> field[7, 7], field[0, 0] = 1.0, np.nan
    >>> picture = glmls.analysis.render_field(field)
    >>> picture.shape, picture[0, 0].tolist(), picture[1, 1].tolist(), picture[7, 7].tolist()
    ((8, 8, 3), [128, 128, 128], [68, 1, 84], [253, 231, 37])
    """
    array = real_values(values)
    if array.ndim != 2:
        raise ValueError(f"values must be an (H, W) array, got shape {array.shape}")
    with Canvas(array.shape, samples=0, ctx=ctx) as canvas:
        canvas.field(
            array, cmap=cmap, vmin=vmin, vmax=vmax, percentile=percentile, nan_color=nan_color
        )
        return canvas.read()


@when_forked
def render_handles(
    image: object,
    src: object,
    dst: object,
    *,
    src_segments: object = None,
    dst_segments: object = None,
    source_color: Sequence[float] = HANDLE_SOURCE_COLOR,
    color: Sequence[float] = HANDLE_TARGET_COLOR,
    radius: float = 4.0,
    width: float = 2.0,
    head: float = 10.0,
    ctx: moderngl.Context | GLContext | None = None,
) -> np.ndarray:
    """The handles drawn over an image (Fig. 6 left).

    A disk at each p_i and an arrow p_i -> q_i; a segment handle as the target segment in
    ``color``, an arrow from each source end to its target end, and the source segment over
    them in ``source_color`` with a disk at each end.

    Parameters
    ----------
    image : array_like
        The picture's background: (H, W) or (H, W, C) with C in 1..4, uint8, uint16 or
        floats (in [0, 1], or scaled from their least to their greatest value); its size
        is the picture's.
    src, dst : array_like
        Point handles, (N, 2) each.
    src_segments, dst_segments : array_like, optional
        Segment handles, (S, 2, 2) each, as for :class:`glmls.MLS`.
    source_color, color : sequence of float, optional
        (r, g, b) colours, 0-255, of the sources and of the targets and arrows.
    radius : float, optional
        The source disks' radius in pixels.
    width : float, optional
        The lines' width in pixels.
    head : float, optional
        The arrow heads' length in pixels.
    ctx : moderngl.Context or GLContext, optional
        The context to draw with (default: glmls's shared headless one).

    Returns
    -------
    numpy.ndarray
        The picture, (H, W, 3) uint8.

    Raises
    ------
    ValueError
        For a bad image, handles, colour or size.
    TypeError
        For an image of an unsupported dtype.

    Examples
    --------
    >>> image = np.zeros((32, 32), np.uint8)
    >>> picture = glmls.analysis.render_handles(image, [[8, 8]], [[20, 16]])
    >>> picture.shape, picture[8, 8].tolist()  # the source disk
    ((32, 32, 3), [30, 144, 255])
    """
    rgb = as_rgb8(image)
    a, b = validate_segments(src_segments, dst_segments)
    ends = a.reshape(-1, 2)
    with Canvas(rgb.shape[:2], ctx=ctx) as canvas:
        canvas.image(rgb)
        canvas.lines(b[:, 0], b[:, 1], color=color, width=width)
        canvas.arrows(ends, b.reshape(-1, 2), color=color, width=width, head=head)
        canvas.arrows(src, dst, color=color, width=width, head=head)
        canvas.lines(a[:, 0], a[:, 1], color=source_color, width=width)
        disks = np.concatenate([as_points(src, "src"), ends])
        canvas.disks(disks, color=source_color, radius=radius)
        return canvas.read()


@when_forked
def render_triangulation(
    image: object,
    points: object,
    simplices: object,
    *,
    color: Sequence[float] = EDGE_COLOR,
    width: float = 1.5,
    radius: float = 3.0,
    ctx: moderngl.Context | GLContext | None = None,
) -> np.ndarray:
    """A triangulation's edges and vertices drawn over an image (Fig. 7 centre).

    Parameters
    ----------
    image : array_like
        The picture's background: (H, W) or (H, W, C) with C in 1..4, uint8, uint16 or
        floats (in [0, 1], or scaled from their least to their greatest value); its size
        is the picture's.
    points : array_like
        The vertices, (N, 2).
    simplices : array_like
        (T, 3) integer indices into ``points``.
    color : sequence of float, optional
        (r, g, b), 0-255.
    width : float, optional
        The edges' width in pixels.
    radius : float, optional
        The vertices' disks' radius in pixels.
    ctx : moderngl.Context or GLContext, optional
        The context to draw with (default: glmls's shared headless one).

    Returns
    -------
    numpy.ndarray
        The picture, (H, W, 3) uint8.

    Raises
    ------
    ValueError
        For bad points, simplices that are not (T, 3) integers or refer to missing points,
        or a bad image, colour or size.

    Examples
    --------
    >>> square = [[4, 4], [28, 4], [4, 28], [28, 28]]
    >>> errors = glmls.analysis.triangle_errors(lambda r: r, square)
    >>> picture = glmls.analysis.render_triangulation(
    ...     np.zeros((32, 32), np.uint8), errors.points, errors.simplices
    ... )
    >>> picture.shape, picture[4, 4].tolist()  # a vertex, in yellow
    ((32, 32, 3), [255, 255, 0])
    """
    rgb = as_rgb8(image)
    pts = as_points(points, "points")
    a, b = _edges(pts, simplices)
    with Canvas(rgb.shape[:2], ctx=ctx) as canvas:
        canvas.image(rgb)
        canvas.lines(a, b, color=color, width=width)
        canvas.disks(pts, color=color, radius=radius)
        return canvas.read()


def _origin(origin: object) -> np.ndarray:
    point = np.asarray(origin, dtype=np.float64)
    if point.shape != (2,) or not np.all(np.isfinite(point)):
        raise ValueError(f"origin must be two finite numbers (x0, y0), got {origin!r}")
    return point


def _edges(points: np.ndarray, simplices: object) -> tuple[np.ndarray, np.ndarray]:
    """The distinct edges of the triangles, as endpoint arrays."""
    tri = np.asarray(simplices)
    if tri.ndim != 2 or tri.shape[1] != 3 or not np.issubdtype(tri.dtype, np.integer):
        raise ValueError(f"simplices must be (T, 3) integers, got {tri.shape} {tri.dtype}")
    if tri.size and (tri.min() < 0 or tri.max() >= len(points)):
        raise ValueError("simplices refer to points that do not exist")
    pairs = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    pairs = np.unique(np.sort(pairs, axis=1), axis=0)
    return points[pairs[:, 0]], points[pairs[:, 1]]


@when_forked
def render_triangle_errors(
    image: object,
    errors: TriangleErrors,
    *,
    which: str = "angle",
    deformed: bool = True,
    cmap: object = "viridis",
    vmin: float | None = None,
    vmax: float | None = None,
    percentile: float | None = None,
    nan_color: Sequence[float] = NAN_COLOR,
    opacity: float = 0.7,
    edge_color: Sequence[float] | None = (0, 0, 0),
    width: float = 1.0,
    origin: Sequence[float] = (0.0, 0.0),
    ctx: moderngl.Context | GLContext | None = None,
) -> np.ndarray:
    """The reference triangles filled with the colour of their error (Fig. 7 right).

    Parameters
    ----------
    image : array_like
        The picture's background: (H, W) or (H, W, C) with C in 1..4, uint8, uint16 or
        floats (in [0, 1], or scaled from their least to their greatest value); its size
        is the picture's.
    errors : TriangleErrors
        As :func:`triangle_errors` returns them.
    which : {"angle", "distance"}, optional
        The error shown: the angular one (eq. 11) or the distance one (eq. 10).
    deformed : bool, optional
        Draw the triangles at f(r) (over the deformed image, as in the paper) or at r (over
        the input image).
    cmap : str or array_like, optional
        A colour map, as :func:`apply_colormap` takes it (default viridis).
    vmin, vmax, percentile : float, optional
        The colour limits, as :func:`color_limits` takes them.
    nan_color : sequence of float, optional
        The (r, g, b) colour of undefined (NaN) values.
    opacity : float, optional
        The fill's opacity, in [0, 1].
    edge_color : sequence of float or None, optional
        The edges' (r, g, b) colour; None leaves the edges out.
    width : float, optional
        The edges' width in pixels.
    origin : sequence of float, optional
        The point that ``image``'s pixel (0, 0) shows (that of a warp's output canvas).
    ctx : moderngl.Context or GLContext, optional
        The context to draw with (default: glmls's shared headless one).

    Returns
    -------
    numpy.ndarray
        The picture, (H, W, 3) uint8.

    Raises
    ------
    ValueError
        For an unknown ``which``, a bad origin, image, colour map or limits, or ``errors``
        whose simplices refer to missing points or whose errors are not one per triangle.
    TypeError
        For ``errors`` that are not a :class:`TriangleErrors`.

    Examples
    --------
    >>> square = [[4, 4], [28, 4], [4, 28], [28, 28]]
    >>> errors = glmls.analysis.triangle_errors(lambda r: r * [1.0, 0.9] + 1.0, square)
    >>> errors.angle.round(2).tolist()
    [2.01, 2.01]
    >>> picture = glmls.analysis.render_triangle_errors(
    ...     np.zeros((32, 32), np.uint8), errors, opacity=1.0, edge_color=None
    ... )
    >>> picture[20, 8].tolist()  # equal errors: the colour map's first colour
    [68, 1, 84]
    """
    deformed = check_flag("deformed", deformed)
    if which not in ("angle", "distance"):
        raise ValueError(f"which must be 'angle' or 'distance', got {which!r}")
    if not isinstance(errors, TriangleErrors):
        raise TypeError(f"errors must be a TriangleErrors, got {type(errors).__name__}")
    values = errors.angle if which == "angle" else errors.distance
    points = (errors.deformed_points if deformed else errors.points) - _origin(origin)
    a, b = _edges(points, errors.simplices)  # checks the simplices against the points
    if np.shape(values) != (len(errors.simplices),):
        raise ValueError(
            f"errors.{which} has shape {np.shape(values)}, expected one value per triangle "
            f"({len(errors.simplices)},)"
        )
    colors = apply_colormap(
        values, cmap=cmap, vmin=vmin, vmax=vmax, percentile=percentile, nan_color=nan_color
    )
    rgb = as_rgb8(image)
    with Canvas(rgb.shape[:2], ctx=ctx) as canvas:
        canvas.image(rgb)
        canvas.triangles(points[errors.simplices], colors, opacity=opacity)
        if edge_color is not None:
            canvas.lines(a, b, color=edge_color, width=width)
        return canvas.read()


@when_forked
def render_mesh(
    image: object,
    deformed: object,
    *,
    color: Sequence[float] = (40, 40, 40),
    width: float = 1.0,
    origin: Sequence[float] = (0.0, 0.0),
    ctx: moderngl.Context | GLContext | None = None,
) -> np.ndarray:
    """The lines of a deformed mesh over an image: a picture of f where no warped image is at hand.

    Parameters
    ----------
    image : array_like
        The picture's background: (H, W) or (H, W, C) with C in 1..4, uint8, uint16 or
        floats (in [0, 1], or scaled from their least to their greatest value); its size
        is the picture's.
    deformed : array_like
        The deformed mesh's vertices, (rows, columns, 2), e.g. ``MLS.mesh(...)[1]``.
    color : sequence of float, optional
        (r, g, b), 0-255.
    width : float, optional
        The lines' width in pixels.
    origin : sequence of float, optional
        The point that ``image``'s pixel (0, 0) shows.
    ctx : moderngl.Context or GLContext, optional
        The context to draw with (default: glmls's shared headless one).

    Returns
    -------
    numpy.ndarray
        The picture, (H, W, 3) uint8.

    Raises
    ------
    ValueError
        For a mesh that is not (rows, columns, 2) with at least 2 of each, a bad origin,
        image or colour.

    Examples
    --------
    >>> with glmls.MLS([[4, 4], [28, 4], [4, 28]], [[5, 4], [29, 4], [5, 28]]) as m:
    ...     source, deformed = m.mesh((32, 32), grid=8)  # cell corners, shifted by 1
    >>> deformed.shape
    (5, 5, 2)
    >>> picture = glmls.analysis.render_mesh(
    ...     np.zeros((32, 32), np.uint8), deformed, color=(255, 255, 255), width=3
    ... )
    >>> picture[4, 9].tolist(), picture[4, 12].tolist()  # on the line x = 8.5, and off it
    ([255, 255, 255], [0, 0, 0])
    """
    rgb = as_rgb8(image)
    grid = real_values(deformed, "deformed")
    if grid.ndim != 3 or grid.shape[2] != 2 or min(grid.shape[:2]) < 2:
        raise ValueError(f"deformed must be a (rows, columns, 2) mesh, got {grid.shape}")
    # checked here, where the lines' ends (a, b) would name themselves in the message
    as_points(grid.reshape(-1, 2), "deformed (its vertices row by row)")
    grid = grid - _origin(origin)
    a = np.concatenate([grid[:, :-1].reshape(-1, 2), grid[:-1, :].reshape(-1, 2)])
    b = np.concatenate([grid[:, 1:].reshape(-1, 2), grid[1:, :].reshape(-1, 2)])
    with Canvas(rgb.shape[:2], ctx=ctx) as canvas:
        canvas.image(rgb)
        canvas.lines(a, b, color=color, width=width)
        return canvas.read()


#: Sides of the polygons drawn as disks (as :meth:`Canvas.disks` draws them).
_DISK_SIDES = 16


@when_forked
def render_construction_errors(
    image: object,
    errors: ConstructionErrors,
    *,
    deformed: bool = True,
    cmap: object = "viridis",
    vmin: float | None = 0.0,
    vmax: float | None = None,
    percentile: float | None = None,
    nan_color: Sequence[float] = NAN_COLOR,
    radius: float | None = None,
    edge_color: Sequence[float] | None = (0, 0, 0),
    origin: Sequence[float] | None = None,
    ctx: moderngl.Context | GLContext | None = None,
) -> np.ndarray:
    """The construction error at each reference point, as coloured disks over an image.

    Parameters
    ----------
    image : array_like
        The picture's background: (H, W) or (H, W, C) with C in 1..4, uint8, uint16 or
        floats (in [0, 1], or scaled from their least to their greatest value); its size
        is the picture's.
    errors : ConstructionErrors
        As :func:`construction_errors` returns them.
    deformed : bool, optional
        At f(r) over the deformed image (where the error was measured) or at r over the
        input.
    cmap : str or array_like, optional
        A colour map, as :func:`apply_colormap` takes it (default viridis).
    vmin, vmax, percentile : float, optional
        The colour limits. The scale starts at ``vmin`` = 0, a perfect construction, by
        default (None: the smallest error), and ends at ``vmax`` (None: the largest, or the
        ``percentile``).
    nan_color : sequence of float, optional
        The (r, g, b) colour of undefined (NaN) errors.
    radius : float, optional
        The disks' radius in pixels (default: the window's half-size plus one, at least 4,
        so that a disk covers the window it stands for).
    edge_color : sequence of float or None, optional
        A ring around each disk, so that it shows on any background (None: none).
    origin : sequence of float, optional
        The point that ``image``'s pixel (0, 0) shows (default: the canvas the errors were
        measured on when ``deformed``, else (0, 0)).
    ctx : moderngl.Context or GLContext, optional
        The context to draw with (default: glmls's shared headless one).

    Returns
    -------
    numpy.ndarray
        The picture, (H, W, 3) uint8.

    Raises
    ------
    TypeError
        For ``errors`` that are not a :class:`ConstructionErrors`.
    ValueError
        For a radius that is not positive, a bad origin, image, colour map or limits.
    TypeError
        Also for a ``radius``, ``vmin``, ``vmax`` or ``percentile`` that is no real number
        (``glmls.core.config.check_real``).

    Examples
    --------
    >>> image = np.zeros((32, 32), np.uint8)
    >>> with glmls.MLS([[4, 4], [28, 4], [4, 28]], [[5, 4], [29, 4], [5, 28]]) as m:
    ...     errors = glmls.analysis.construction_errors(image, m.warp(image), m, [[16, 16]])
    >>> picture = glmls.analysis.render_construction_errors(image, errors)
    >>> errors.values.tolist(), picture[16, 17].tolist()  # at f(r): an error of 0
    ([0.0], [68, 1, 84])
    """
    deformed = check_flag("deformed", deformed)
    if not isinstance(errors, ConstructionErrors):
        raise TypeError(f"errors must be a ConstructionErrors, got {type(errors).__name__}")
    size = float(max(4, errors.radius + 1)) if radius is None else check_size("radius", radius)
    if origin is None:
        origin = errors.origin if deformed else (0.0, 0.0)
    colors = apply_colormap(
        errors.values, cmap=cmap, vmin=vmin, vmax=vmax, percentile=percentile, nan_color=nan_color
    )
    rgb = as_rgb8(image)
    where = errors.deformed_points if deformed else errors.points
    keep = np.isfinite(where).all(axis=1)  # f may be undefined at a point: nothing to draw
    centres, colors = where[keep] - _origin(origin), colors[keep]
    with Canvas(rgb.shape[:2], ctx=ctx) as canvas:
        canvas.image(rgb)
        if edge_color is not None:
            canvas.disks(centres, color=edge_color, radius=size + 1.5)
        fill = disk_triangles(centres, size, _DISK_SIDES).reshape(-1, 3, 2)
        canvas.triangles(fill, np.repeat(colors, _DISK_SIDES, axis=0))
        return canvas.read()
