"""What the window computes, free of drawing: the MLS of the controller's handles and settings
(kept in step with them) and the analysis overlays' numbers and geometry, redone only when
their inputs change."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import moderngl
import numpy as np

from ..analysis.colormaps import apply_colormap, format_number, picture_limits
from ..analysis.folding import folded_cells
from ..analysis.stats import error_stats
from ..analysis.triangles import triangle_errors
from ..gl.context import GLContext
from ..imaging.frame import Bounds, Frame
from ..imaging.pipeline import WarpPipeline
from ..mls import MLS
from .controller import Controller
from .overlays import adaptive_lines, fold_geometry, mesh_lines, triangle_geometry
from .settings import Settings

__all__ = ["Analysis", "Session", "number"]


def number(value: object) -> str:
    """A statistic for the readout ("-" for none)."""
    return "-" if value is None else format_number(float(value))  # type: ignore[arg-type]


@dataclass
class Analysis:
    """The analysis overlays of one handle revision: readout lines, geometry to draw (vertex
    rows, GL mode), and the error field's colours (H, W, 3) uint8 when it is shown."""

    key: tuple = ()
    lines: list[str] = field(default_factory=list)
    geometry: list[tuple[np.ndarray, int]] = field(default_factory=list)
    field_colours: np.ndarray | None = None


class Session:
    """The MLS on the window's context ``gl`` for ``controller``'s handles and settings, for
    an image of ``shape`` (H, W)."""

    def __init__(self, gl: GLContext, controller: Controller, shape: tuple[int, int]) -> None:
        self.gl = gl
        self.controller = controller
        self.shape = shape
        self.mls: MLS | None = None
        #: The controller revision the MLS is of, and why the last change failed ("" if not).
        self.revision = -1
        self.error = ""
        self.analysis = Analysis()
        self.timings: dict[str, float] = {}
        self._config_key: object = None
        self._reference: tuple[tuple, np.ndarray] = ((), np.zeros((0, 2)))
        #: What the view shows: the input's frame, or with ``fit`` the deformed image's
        #: bounds joined with the input's frame (so that the handles stay in view).
        self.canvas = Frame(shape)
        self._identity: MLS | None = None
        # (revision, tolerance) where the adaptive mesh gave up (its build's budget)
        self._adaptive_failed: tuple[int, float | None] | None = None

    def construction(self, settings: Settings) -> Settings:
        """``settings``, or on the regular grid where the adaptive mesh of its tolerance
        failed for the current handles (:meth:`adaptive_failed`)."""
        if settings.adaptive is not None and self._adaptive_failed == (
            self.revision,
            settings.tolerance,
        ):
            return replace(settings, tolerance=None)
        return settings

    def adaptive_failed(self, settings: Settings, error: ValueError) -> str:
        """Remember that the adaptive mesh of ``settings`` failed for these handles (until
        they or the tolerance change, :meth:`construction` gives the grid); the message."""
        self._adaptive_failed = (self.revision, settings.tolerance)
        return f"adaptive mesh: {error}; drawn on the grid"

    def sync(self) -> None:
        """Bring the MLS up to the controller's revision: a new MLS when the configuration
        changed, else new handles for the same one. On invalid handles the last valid f
        stays and :attr:`error` says why."""
        c = self.controller
        if c.revision == self.revision and self.mls is not None:
            return
        config = c.settings.config
        start = time.perf_counter()
        try:
            segments = {"src_segments": c.src_segments, "dst_segments": c.dst_segments}
            if self.mls is None or config != self._config_key:
                mls = MLS.from_config(
                    c.src, c.dst, config, **segments, shape=self.shape, ctx=self.gl
                )
                if self.mls is not None:
                    self.mls.release()
                self.mls, self._config_key = mls, config
            else:
                self.mls.set_handles(c.src, c.dst, **segments)
            self.error = ""
        except ValueError as error:  # includes DegenerateHandlesError: keep the last valid f
            self.error = str(error)
        self.revision = c.revision
        self.canvas = self._canvas()
        self.timings["handles"] = time.perf_counter() - start

    @property
    def drawn(self) -> MLS:
        """The MLS the view draws: the last valid one, else (the handles and settings were
        never valid together, e.g. affine with every source on one line) the identity, so
        that the input is shown as it is rather than nothing."""
        if self.mls is not None:
            return self.mls
        if self._identity is None:
            none = np.zeros((0, 2))
            self._identity = MLS(none, none, shape=self.shape, ctx=self.gl)
        return self._identity

    def _canvas(self) -> Frame:
        s, m = self.controller.settings, self.mls
        if not s.fit or m is None:
            return Frame(self.shape)
        b = m.bounds(self.shape, grid=s.grid)
        height, width = self.shape
        limit = WarpPipeline.of(self.gl).max_image_size
        joined = Bounds(
            min(b.x0, -0.5), min(b.y0, -0.5), max(b.x1, width - 0.5), max(b.y1, height - 0.5)
        )
        try:
            frame = joined.frame
        except ValueError:  # f blows the image up past the coordinate range
            return Frame(self.shape)
        if max(frame.shape) > limit:  # or past the GL limit
            return Frame(self.shape)
        return frame

    def analyse(self, scale: float) -> Analysis:
        """The analysis overlays that are on, for the view's ``scale`` (framebuffer pixels
        per image pixel, which thins the mesh lines)."""
        c, m = self.controller, self.mls
        settings = self.construction(c.settings)
        grid = settings.grid
        tolerance = settings.adaptive
        wanted = tuple(name for name in ("mesh", "error", "angle", "folds") if c.overlays[name])
        key = (self.revision, c.reference_revision, wanted, scale)
        if key == self.analysis.key or m is None:
            return self.analysis
        start = time.perf_counter()
        result = Analysis(key=key)
        if "mesh" in wanted and tolerance is not None:  # the adaptive mesh's leaves
            try:
                adaptive = m.mesh(self.shape, tolerance=tolerance)
            except ValueError as error:  # its build's budget: the grid's mesh below
                c.message = self.adaptive_failed(settings, error)
                settings = self.construction(settings)
                tolerance = None
            else:
                result.geometry.append((adaptive_lines(adaptive), moderngl.LINES))  # type: ignore[arg-type]
                result.lines.append(f"adaptive mesh: {len(adaptive.leaves)} cells")  # type: ignore[union-attr]
        if ("mesh" in wanted and tolerance is None) or "folds" in wanted:
            _, deformed = m.mesh(self.shape, grid=grid)
            if "folds" in wanted:
                folded = folded_cells(deformed)
                result.geometry.append((fold_geometry(deformed, folded), moderngl.TRIANGLES))
                result.lines.append(f"fold-overs: {int(folded.sum())} of {folded.size} cells")
            if "mesh" in wanted and tolerance is None:
                stride = max(1, math.ceil(6.0 / (grid * scale)))
                result.geometry.append((mesh_lines(deformed, stride), moderngl.LINES))
        if "error" in wanted:
            try:
                values = m.error_field(self.shape, **settings.mesh_options)  # type: ignore[arg-type]
            except ValueError as error:  # the adaptive mesh's budget
                c.message = self.adaptive_failed(settings, error)
                values = m.error_field(self.shape, grid=grid)
            stats = error_stats(values)
            low, high = picture_limits("E_MLS", values, percentile=99.0)
            result.field_colours = apply_colormap(values, cmap="linear", vmin=low, vmax=high)
            within = " ".join(f"{100 * w:.0f}%" for w in stats["within"] or [])  # type: ignore[union-attr]
            result.lines += [
                f"E_MLS px^2: mean {number(stats['mean'])} std {number(stats['std'])}",
                f"  min {number(stats['min'])} max {number(stats['max'])}",
                f"  within 1/2/3 std: {within}",
            ]
        if "angle" in wanted:
            result.lines += self._triangles(m, result)
        self.analysis = result
        self.timings["analysis"] = time.perf_counter() - start
        return result

    def _triangles(self, m: MLS, result: Analysis) -> list[str]:
        points = self.controller.reference
        if len(points) < 3:
            return [f"angle error: needs 3 reference points ({len(points)}; key p)"]
        try:
            tri = triangle_errors(m, points)
        except ValueError as error:
            return [f"angle error: {error}"]
        fill, edges, _ = triangle_geometry(tri.deformed_points, tri.simplices, tri.angle)
        result.geometry += [(fill, moderngl.TRIANGLES), (edges, moderngl.LINES)]
        angle, distance = error_stats(tri.angle), error_stats(tri.distance)
        return [
            f"angle err (deg): median {number(angle['median'])} mean {number(angle['mean'])}",
            f"  max {number(angle['max'])}  distance mean {number(distance['mean'])}",
            f"  {len(tri.simplices)} triangles, {int(tri.flipped.sum())} flipped",
        ]

    def deformed_reference(self) -> np.ndarray:
        """f(r) of the reference points (cached per handle and reference revision)."""
        c = self.controller
        key = (self.revision, c.reference_revision)
        if self._reference[0] != key:
            points = self.mls(c.reference) if self.mls is not None else c.reference
            self._reference = (key, points)
        return self._reference[1]

    def release(self) -> None:
        for mls in (self.mls, self._identity):
            if mls is not None:
                mls.release()
        self.mls = self._identity = None
