"""One call that analyses a deformation of one image: statistics, timings and pictures."""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image

from ..core.config import check_choice, check_flag
from ..core.mesh import check_grid
from ..files.atomic import atomic_write
from ..files.json_out import strict_json
from ..forking import renderer
from ..imaging.frame import Frame
from ..imaging.options import WarpOptions, default
from . import colormaps
from .canvas import as_rgb8, rgb8_intensities
from .construction import (
    DEFAULT_RADIUS,
    ConstructionErrors,
    check_radius,
    construction_errors,
)
from .field import check_deformation, error_field, image_deformation
from .folding import foldovers
from .pictures import (
    render_construction_errors,
    render_field,
    render_handles,
    render_mesh,
    render_triangle_errors,
    render_triangulation,
)
from .stats import error_stats
from .triangles import check_angle_measure, check_eps, triangle_errors

if TYPE_CHECKING:
    from ..mls import MLS


class StageClock:
    """The seconds of a report's stages, each told to ``on_stage`` (its name) as it begins:
    :meth:`begin` a stage, :meth:`end` it under a key of :attr:`timings`, :meth:`finish` all
    (``timings["total"]``)."""

    def __init__(self, on_stage: Callable[[str], None] | None = None) -> None:
        self.timings: dict[str, float] = {}
        self._on_stage = on_stage
        self._start = self._tick = time.perf_counter()

    def begin(self, name: str) -> None:
        self._tick = time.perf_counter()
        if self._on_stage is not None:
            self._on_stage(name)

    def end(self, key: str) -> None:
        self.timings[key] = time.perf_counter() - self._tick

    def finish(self) -> None:
        self.timings["total"] = time.perf_counter() - self._start


class SavedReport:
    """``to_json`` and ``save`` of a report of a ``summary`` (JSON-ready) and ``images``
    (picture name -> (H, W, 3) uint8); each report lists them as its own methods."""

    summary: dict
    images: dict[str, np.ndarray]

    def to_json(self, **options: object) -> str:
        """The summary as standard JSON text (a value that is not finite as ``null``).

        Parameters
        ----------
        **options
            ``json.dumps``'s keywords (default ``indent=2``).

        Returns
        -------
        str
            The JSON text.

        Examples
        --------
        >>> y, x = np.mgrid[0:32, 0:32]
        >>> image = (127 + 60 * np.sin(x / 3.0) + 60 * np.cos(y / 4.0)).astype(np.uint8)
        >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
        >>> points = [[8, 8], [24, 8], [8, 24], [24, 24], [16, 16]]
        >>> with glmls.MLS(src, src + [1.0, 0.0]) as m:
        ...     found = glmls.analysis.report(image, m, points, mesh_grid=8)
        >>> import json
        >>> json.loads(found.to_json())["image"]
        {'height': 32, 'width': 32}
        >>> found.to_json(indent=None).startswith('{"image": {"height": 32, "width": 32}')
        True
        """
        keywords = {"indent": 2, "allow_nan": False} | options
        return json.dumps(strict_json(self.summary), **keywords)  # type: ignore[arg-type]

    def save(self, folder: str | Path) -> list[Path]:
        """Write ``report.json`` and one PNG per picture into a folder.

        Each file is written whole or not at all.

        Parameters
        ----------
        folder : str or pathlib.Path
            The folder, created if needed.

        Returns
        -------
        list of pathlib.Path
            The paths written, ``report.json`` first.

        Examples
        --------
        >>> y, x = np.mgrid[0:32, 0:32]
        >>> image = (127 + 60 * np.sin(x / 3.0) + 60 * np.cos(y / 4.0)).astype(np.uint8)
        >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
        >>> points = [[8, 8], [24, 8], [8, 24], [24, 24], [16, 16]]
        >>> with glmls.MLS(src, src + [1.0, 0.0]) as m:
        ...     found = glmls.analysis.report(image, m, points, mesh_grid=8)
        >>> import pathlib, tempfile
        >>> paths = found.save(pathlib.Path(tempfile.mkdtemp()) / "report")
        >>> [path.name for path in paths][:3]
        ['report.json', 'input_handles.png', 'deformed.png']
        """
        out = Path(folder)
        paths = [out / "report.json"]
        with atomic_write(paths[0]) as tmp:  # each file whole or not at all
            tmp.write_text(self.to_json() + "\n", encoding="utf-8")
        for name, picture in self.images.items():
            path = out / f"{name}.png"
            with atomic_write(path) as tmp:
                Image.fromarray(picture).save(tmp, format="PNG")
            paths.append(path)
        return paths


def picture_names(*, triangle_error: str = "angle", construction: bool = True) -> list[str]:
    """The pictures :func:`report` draws with these options, in its order; ``save`` writes
    each as ``NAME.png``, so that a caller can check, before any work, that none of them
    would replace a file it keeps.

    Parameters
    ----------
    triangle_error : {"angle", "distance"}, optional
        The error the triangle picture shows, as for :func:`report`.
    construction : bool, optional
        Whether the report measures the construction error (its picture and colour bar).

    Returns
    -------
    list of str
        The names, without ``.png``.

    Examples
    --------
    >>> glmls.analysis.reporting.picture_names(construction=False)[-2:]
    ['triangle_angle', 'triangle_angle_colorbar']
    """
    triangles = f"triangle_{triangle_error}"
    names = ["input_handles", "deformed", "deformed_mesh", "error_field"]
    names += ["error_field_colorbar", "triangulation", triangles, f"{triangles}_colorbar"]
    if construction:
        names += ["construction_errors", "construction_errors_colorbar"]
    return names


def cmap_name(cmap: object) -> object:
    """A colour map as the summaries record it: its name, or its colours as lists."""
    return cmap if isinstance(cmap, str) else np.asarray(cmap).tolist()


@dataclasses.dataclass(frozen=True, eq=False)
class AnalysisReport(SavedReport):
    """What :func:`report` found: statistics, timings and pictures of one deformation.

    Attributes
    ----------
    summary : dict
        JSON-ready: the image's size, the configuration and handles, the analysis settings,
        timings in seconds, the statistics of the error field, the triangles and the
        construction error, the fold-over count, the warp's settings, the GL renderer.
    images : dict of str to numpy.ndarray
        Picture name -> (H, W, 3) uint8 picture.
    field : numpy.ndarray
        The MLS error field (eq. 7), (H, W) float64.
    triangles : TriangleErrors
        The reference triangles' errors (eqs. 10, 11).
    construction : ConstructionErrors or None
        The construction error of the warp at the reference points (None unless asked for).

    Examples
    --------
    >>> y, x = np.mgrid[0:32, 0:32]
    >>> image = (127 + 60 * np.sin(x / 3.0) + 60 * np.cos(y / 4.0)).astype(np.uint8)
    >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
    >>> dst = src.copy()
    >>> dst[3] = [24.0, 24.0]
    >>> points = [[8, 8], [24, 8], [8, 24], [24, 24], [16, 16]]
    >>> with glmls.MLS(src, dst) as m:
    ...     found = glmls.analysis.report(image, m, points, mesh_grid=8)
    >>> found.summary["image"], found.summary["triangles"]["triangles"]
    ({'height': 32, 'width': 32}, 4)
    >>> found.field.shape, found.images["deformed"].shape, found.construction.values.shape
    ((32, 32), (32, 32, 3), (5,))
    >>> found.to_json().splitlines()[:2]
    ['{', '  "image": {']
    """

    summary: dict
    images: dict[str, np.ndarray]
    field: np.ndarray
    triangles: object
    construction: ConstructionErrors | None = None

    to_json = SavedReport.to_json  # listed among this class's methods
    save = SavedReport.save


def report(
    image: object,
    m: MLS,
    reference_points: object,
    *,
    grid: int = 1,
    angle: str = "degrees",
    eps: float = 1e-6,
    cmap: object = "viridis",
    percentile: float | None = None,
    triangle_error: str = "angle",
    triangle_percentile: float | None = 95.0,
    mesh_grid: int = 32,
    method: str = default("quads"),
    interpolation: str = default("nearest"),
    warp_grid: int = default(1),
    warp_tolerance: float | None = default(None),
    border: str = default("constant"),
    fit: bool = False,
    warp_options: WarpOptions | None = None,
    construction: bool = True,
    construction_radius: int = DEFAULT_RADIUS,
    out_dir: str | Path | None = None,
    on_stage: Callable[[str], None] | None = None,
) -> AnalysisReport:
    """Analyse the deformation ``m`` of ``image`` as in section 5 of the paper.

    The handles are ``m``'s: points ``m.src`` -> ``m.dst`` and segments ``m.src_segments``
    -> ``m.dst_segments``, drawn in the pictures and listed in the summary. Computes the MLS
    error field (eq. 7) and its statistics (eqs. 8, 9), the Delaunay triangulation of
    ``reference_points`` with its distance and angular errors (eqs. 10, 11) and their
    statistics, the fold-over count of the warp's mesh, optionally the construction error,
    and draws: ``input_handles`` (Fig. 6 left), ``deformed`` (the warp, Fig. 6 centre),
    ``deformed_mesh`` (the mesh every ``mesh_grid`` pixels), ``error_field`` (Fig. 6 right),
    ``triangulation`` (Fig. 7 centre), ``triangle_angle`` or ``triangle_distance`` (Fig. 7
    right: over the deformed image at f(r)), ``construction_errors`` (a disk at each f(r)
    over the deformed image), and a ``*_colorbar`` for each colour picture.

    Parameters
    ----------
    image : array_like
        (H, W) or (H, W, C) with C in 1..4: uint8, uint16, or floats, finite. The report
        pictures, warps and measures (the construction error) its 8-bit RGB copy: uint16
        scaled by 255 / 65535, floats in [0, 1] by 255, floats of any other range from their
        least to their greatest value (``summary["image"]["intensities"]``), not clipped.
    m : MLS
        The deformation.
    reference_points : array_like
        The points r of the triangles, (N, 2) with N >= 3.
    grid : int, optional
        The error field at every pixel (1), or on a mesh every ``grid`` pixels.
    angle : {"degrees", "paper"}, optional
        The angular measure of :func:`triangle_errors`.
    eps : float, optional
        Eq. (11)'s epsilon.
    cmap : str or array_like, optional
        The colour map of the pictures (:func:`apply_colormap`).
    percentile : float, optional
        Robust upper bound of the error field's colour scale (None: the maximum).
    triangle_error : {"angle", "distance"}, optional
        The error the triangle picture shows.
    triangle_percentile : float, optional
        Robust upper bound of the triangles' colour scale; 95 by default, since eq. (11)
        (``angle="paper"``) explodes near right angles.
    mesh_grid : int, optional
        The step of the ``deformed_mesh`` picture's mesh, in pixels.
    method, interpolation : str, optional
        The warp's construction (:meth:`glmls.MLS.warp`).
    warp_grid : int, optional
        The warp's mesh step, also that of the fold-over count.
    warp_tolerance : float, optional
        The warp on the adaptive mesh of that tolerance (``warp_grid`` must stay 1).
    border : str, optional
        The warp's border mode.
    fit : bool, optional
        Draw the deformed pictures on the canvas that shows the whole deformed image
        (:meth:`glmls.MLS.bounds`) instead of the input's frame.
    warp_options : glmls.WarpOptions, optional
        The warp's options as one value; ``method``, ``interpolation``, ``warp_grid``,
        ``warp_tolerance`` and ``border`` given as keywords override its fields. Its canvas
        (``output_shape``, ``origin``; default the input's frame) is the pictures' canvas,
        unless ``fit`` asks for the whole deformed image.
    construction : bool, optional
        Also measure the construction error of the warp at the reference points
        (:func:`construction_errors`; :doc:`/construction`): its statistics in
        ``summary["construction"]``, its settings and colour limits in
        ``summary["analysis"]["construction"]``.
    construction_radius : int, optional
        Its windows' half-size: windows of (2 ``construction_radius`` + 1)² output pixels.
    out_dir : str or pathlib.Path, optional
        Also write ``report.json`` and the PNGs there (:meth:`AnalysisReport.save`).
    on_stage : callable, optional
        Called with each stage's name as it begins (error field, triangles, warp,
        construction, fold-overs, pictures), for progress.

    Returns
    -------
    AnalysisReport
        The summary, the pictures, the error field and the errors.

    Raises
    ------
    ValueError
        For an unknown ``triangle_error``, warp option or angle measure, bad reference
        points, radius or image; checked before the long stages where possible.
    TypeError
        For an image of an unsupported dtype, an ``m`` that is not an MLS, or an option of
        the wrong type (a float ``grid``, a ``triangle_error`` or ``angle`` that is no string).

    Examples
    --------
    >>> y, x = np.mgrid[0:32, 0:32]
    >>> image = (127 + 60 * np.sin(x / 3.0) + 60 * np.cos(y / 4.0)).astype(np.uint8)
    >>> src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
    >>> dst = src.copy()
    >>> dst[3] = [24.0, 24.0]
    >>> points = [[8, 8], [24, 8], [8, 24], [24, 24], [16, 16]]
    >>> with glmls.MLS(src, dst) as m:
    ...     found = glmls.analysis.report(image, m, points, mesh_grid=8)
    >>> sorted(found.images)[:4]
    ['construction_errors', 'construction_errors_colorbar', 'deformed', 'deformed_mesh']
    >>> found.summary["foldovers"], found.summary["triangles"]["flipped"]
    ({'grid': 1, 'cells': 0}, 0)
    """
    fit = check_flag("fit", fit)
    construction = check_flag("construction", construction)
    rgb, limits = rgb8_intensities(image)
    shape = rgb.shape[:2]
    described = {"height": shape[0], "width": shape[1]}
    if limits is not None:  # a float image beyond [0, 1]: measured as scaled from there
        described["intensities"] = list(limits)
    for method_of_m in ("error_field", "mesh", "warp", "bounds"):
        check_deformation(m, method_of_m)
    triangle_error = check_choice("triangle_error", triangle_error, ("angle", "distance"))
    options = WarpOptions.of(  # checked before the long stages
        warp_options,
        method=method,
        interpolation=interpolation,
        grid=warp_grid,
        tolerance=warp_tolerance,
        border=border,
    )
    if construction:
        check_radius(construction_radius, "construction_radius")
    # plain numbers and names now, as the summary holds them (a numpy integer is no JSON)
    grid, angle, eps = check_grid(grid), check_angle_measure(angle), check_eps(eps)
    if percentile is not None:
        percentile = colormaps.check_percentile("percentile", percentile)
    if triangle_percentile is not None:
        triangle_percentile = colormaps.check_percentile("triangle_percentile", triangle_percentile)
    clock = StageClock(on_stage)

    clock.begin("error field")
    field = error_field(m, shape, grid=grid)  # far targets in float32 of near ones
    clock.end("error_field")

    clock.begin("triangles")
    # f at points as the warp of this image evaluates it (a radius weight's default radius)
    with image_deformation(m, shape) as f:
        triangles = triangle_errors(f, reference_points, angle=angle, eps=eps)
    clock.end("triangle_errors")

    clock.begin("warp")
    if fit:
        canvas = m.bounds(shape, grid=options.grid).frame
    else:
        canvas = Frame(options.output_shape or shape, options.origin or (0.0, 0.0))
    output_shape, origin = canvas.shape, canvas.origin
    options = dataclasses.replace(options, output_shape=output_shape, origin=origin)
    deformed = as_rgb8(m.warp(rgb, options=options), "m.warp(image)")
    clock.end("warp")

    built = None
    if construction:
        clock.begin("construction")
        built = construction_errors(
            rgb,
            deformed,
            m,
            triangles.points,
            radius=construction_radius,
            border=options.border,
            origin=origin,
        )
        clock.end("construction_errors")

    clock.begin("fold-overs")
    folds = foldovers(m, shape, grid=options.grid).count
    clock.end("foldovers")

    clock.begin("pictures")
    a, b = m.src_segments, m.dst_segments
    images: dict[str, np.ndarray] = {
        "input_handles": render_handles(rgb, m.src, m.dst, src_segments=a, dst_segments=b)
    }
    images["deformed"] = deformed
    _, mesh = m.mesh(shape, grid=mesh_grid)
    blank = np.full((*output_shape, 3), 255, np.uint8)
    images["deformed_mesh"] = render_handles(
        render_mesh(blank, mesh, origin=origin),
        m.src - origin,
        m.dst - origin,
        src_segments=a - origin,
        dst_segments=b - origin,
    )
    lo, hi = colormaps.picture_limits("E_MLS", field, percentile=percentile)
    images["error_field"] = render_field(field, cmap=cmap, vmin=lo, vmax=hi)
    images["error_field_colorbar"] = colormaps.colorbar(
        cmap, lo, hi, length=max(64, shape[0] - 40), label="E_MLS (px^2)"
    )
    images["triangulation"] = render_triangulation(rgb, triangles.points, triangles.simplices)
    values = getattr(triangles, triangle_error)
    t_lo, t_hi = colormaps.picture_limits(triangle_error, values, percentile=triangle_percentile)
    images[f"triangle_{triangle_error}"] = render_triangle_errors(
        deformed,
        triangles,
        which=triangle_error,
        deformed=True,
        cmap=cmap,
        vmin=t_lo,
        vmax=t_hi,
        origin=origin,
    )
    images[f"triangle_{triangle_error}_colorbar"] = colormaps.colorbar(
        cmap, t_lo, t_hi, length=max(64, shape[0] - 40), label=f"{triangle_error} error"
    )
    if built is not None:
        c_lo, c_hi = colormaps.picture_limits("construction", built.values)
        images["construction_errors"] = render_construction_errors(
            deformed, built, cmap=cmap, vmin=c_lo, vmax=c_hi
        )
        images["construction_errors_colorbar"] = colormaps.colorbar(
            cmap, c_lo, c_hi, length=max(64, shape[0] - 40), label="construction RMS (0-1)"
        )
    clock.end("render")
    clock.finish()

    config = dataclasses.asdict(m.config)
    summary = {
        "image": described,
        "configuration": config
        | {
            "radius_used": m.config.resolve_radius(shape),
            "handles": len(m.src),
            "src": m.src.tolist(),
            "dst": m.dst.tolist(),
            "segments": len(a),
            "src_segments": a.tolist(),
            "dst_segments": b.tolist(),
        },
        "analysis": {
            "grid": grid,
            "angle": angle,
            "eps": eps,
            "reference_points": len(triangles.points),
            "cmap": cmap_name(cmap),
            "percentile": percentile,
            "triangle_error": triangle_error,
            "triangle_percentile": triangle_percentile,
            "error_field_limits": [lo, hi],
            "triangle_limits": [t_lo, t_hi],
        },
        "timings_s": clock.timings,
        "error_field": error_stats(field) | {"unit": "px^2"},
        "triangles": triangles.stats(),
        "foldovers": {"grid": options.grid, "cells": folds},
        **({} if built is None else {"construction": built.stats()}),
        "warp": {
            "method": options.method,
            "interpolation": options.interpolation,
            "grid": options.grid,
            "tolerance": options.tolerance,
            "border": options.border,
            "output_shape": list(output_shape),
            "origin": list(origin),
        },
        "gl_renderer": renderer(m),
    }
    if built is not None:
        summary["analysis"]["construction"] = built.settings() | {"limits": [c_lo, c_hi]}
    result = AnalysisReport(summary, images, field, triangles, built)
    if out_dir is not None:
        result.save(out_dir)
    return result


def compose(pictures: Sequence[np.ndarray], *, gap: int = 8, background: int = 255) -> np.ndarray:
    """Pictures side by side, top-aligned, on a ``background`` grey level: (H, W, 3) uint8."""
    pictures = [as_rgb8(p) for p in pictures]
    height = max(p.shape[0] for p in pictures)
    width = sum(p.shape[1] for p in pictures) + gap * (len(pictures) - 1)
    out = np.full((height, width, 3), background, np.uint8)
    x = 0
    for picture in pictures:
        out[: picture.shape[0], x : x + picture.shape[1]] = picture
        x += picture.shape[1] + gap
    return out
