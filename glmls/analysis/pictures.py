"""The paper's pictures of a deformation and its errors, rendered offscreen (:mod:`.canvas`):
the error field (Fig. 6 right), handles as p -> q arrows (Fig. 6 left), the triangulation of
the reference points (Fig. 7 centre) and its triangles filled with the colour of their error
(Fig. 7 right), the deformed mesh, and the construction error at each reference point.
"""

from __future__ import annotations

from collections.abc import Sequence

import moderngl
import numpy as np

from ..core.handles import as_points
from ..core.segments import validate_segments
from ..gl.context import GLContext
from .canvas import EDGE_COLOR, HANDLE_SOURCE_COLOR, HANDLE_TARGET_COLOR, Canvas, as_rgb8
from .colormaps import NAN_COLOR, apply_colormap
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
    """An (H, W) field, e.g. :meth:`MLS.error_field`, as a colour picture (Fig. 6 right)."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 2:
        raise ValueError(f"values must be an (H, W) array, got shape {array.shape}")
    with Canvas(array.shape, samples=0, ctx=ctx) as canvas:
        canvas.field(
            array, cmap=cmap, vmin=vmin, vmax=vmax, percentile=percentile, nan_color=nan_color
        )
        return canvas.read()


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
    """The handles over ``image``: a disk at each p_i and an arrow p_i -> q_i (Fig. 6 left);
    segments ``src_segments`` -> ``dst_segments`` ((S, 2, 2), as for :class:`glmls.MLS`) as
    the target segment in ``color``, an arrow from each source end to its target end, and
    the source segment over them in ``source_color`` with a disk at each end."""
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
    """The triangles (T, 3) over points (N, 2), edges and vertices drawn over ``image``
    (Fig. 7 centre)."""
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
    """Triangles filled with the colour of their ``which`` error (``"angle"``, eq. 11, or
    ``"distance"``, eq. 10) over ``image`` (Fig. 7 right).

    ``deformed``: draw the triangles at f(r) (over the deformed image, as in the paper) or at
    r (over the input image). ``edge_color`` None leaves the edges out. ``origin``: the
    point that ``image``'s pixel (0, 0) shows (that of a warp's output canvas).
    """
    if which not in ("angle", "distance"):
        raise ValueError(f"which must be 'angle' or 'distance', got {which!r}")
    if not isinstance(errors, TriangleErrors):
        raise TypeError(f"errors must be a TriangleErrors, got {type(errors).__name__}")
    values = errors.angle if which == "angle" else errors.distance
    colors = apply_colormap(
        values, cmap=cmap, vmin=vmin, vmax=vmax, percentile=percentile, nan_color=nan_color
    )
    rgb = as_rgb8(image)
    points = (errors.deformed_points if deformed else errors.points) - _origin(origin)
    with Canvas(rgb.shape[:2], ctx=ctx) as canvas:
        canvas.image(rgb)
        canvas.triangles(points[errors.simplices], colors, opacity=opacity)
        if edge_color is not None:
            a, b = _edges(points, errors.simplices)
            canvas.lines(a, b, color=edge_color, width=width)
        return canvas.read()


def render_mesh(
    image: object,
    deformed: object,
    *,
    color: Sequence[float] = (40, 40, 40),
    width: float = 1.0,
    origin: Sequence[float] = (0.0, 0.0),
    ctx: moderngl.Context | GLContext | None = None,
) -> np.ndarray:
    """The lines of a deformed mesh (rows, columns, 2), e.g. ``MLS.mesh(...)[1]``, over
    ``image``: a picture of f where no warped image is at hand. ``origin``: the point that
    ``image``'s pixel (0, 0) shows."""
    rgb = as_rgb8(image)
    grid = np.asarray(deformed, dtype=np.float64)
    if grid.ndim != 3 or grid.shape[2] != 2 or min(grid.shape[:2]) < 2:
        raise ValueError(f"deformed must be a (rows, columns, 2) mesh, got {grid.shape}")
    grid = grid - _origin(origin)
    a = np.concatenate([grid[:, :-1].reshape(-1, 2), grid[:-1, :].reshape(-1, 2)])
    b = np.concatenate([grid[:, 1:].reshape(-1, 2), grid[1:, :].reshape(-1, 2)])
    with Canvas(rgb.shape[:2], ctx=ctx) as canvas:
        canvas.image(rgb)
        canvas.lines(a, b, color=color, width=width)
        return canvas.read()


#: Sides of the polygons drawn as disks (as :meth:`Canvas.disks` draws them).
_DISK_SIDES = 16


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
    """A disk at each reference point filled with the colour of its construction error
    (:func:`glmls.analysis.construction.construction_errors`) over ``image``.

    ``deformed``: at f(r) over the deformed image (where the error was measured; default) or
    at r over the input. ``radius``: of the disks in pixels (default: the window's half-size
    plus one, at least 4, so a disk covers the window it stands for). ``edge_color``: a ring
    around each disk, so that it shows on any background (None: none). ``origin``: the point
    that ``image``'s pixel (0, 0) shows (default: the canvas the errors were measured on
    when ``deformed``, else (0, 0)). Undefined errors (NaN) are drawn in ``nan_color``.
    The colour scale starts at ``vmin`` = 0, a perfect construction, by default (None: the
    smallest error), and ends at ``vmax`` (None: the largest, or the ``percentile``).
    """
    if not isinstance(errors, ConstructionErrors):
        raise TypeError(f"errors must be a ConstructionErrors, got {type(errors).__name__}")
    size = float(max(4, errors.radius + 1)) if radius is None else float(radius)
    if not size > 0 or not np.isfinite(size):
        raise ValueError(f"radius must be a positive number, got {radius!r}")
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
