"""The real-time window (the paper's interactive IDS): glfw, a GL 4.3 core context, and the
same :class:`~glmls.WarpPipeline` as headless use, drawing straight into the window.

Per frame: controller events -> (if the handles or settings changed) one handle upload ->
``WarpPipeline.render(..., flip_y=True)`` into the window's framebuffer, letterboxed -> the
overlays and the text -> swap. ``splat`` and ``backward`` build an image of the source's size
(``backward`` needs that viewport; a 1-pixel splat would leave gaps when scaled up), rendered
offscreen by the same call and drawn as one textured quad. Nothing is read back except what
the analysis overlays need on the CPU (their statistics) and screenshots.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import moderngl
import numpy as np

from ..analysis import error_field, error_stats, triangle_errors
from ..colormaps import apply_colormap, format_number
from ..context import GLContext, get_context
from ..files import atomic_write, read_handles, write_handles
from ..io import imwrite
from ..mls import MLS
from ..pipeline import WarpPipeline, prepare_image
from ..render import as_rgb8
from .controller import BINDINGS, OVERLAYS, Controller, Key, Move, Press, Release, Settings
from .events import Wait
from .layout import layout
from .overlays import (
    GeometryDrawer,
    PictureDrawer,
    fold_geometry,
    folded_cells,
    handle_geometry,
    mesh_lines,
    reference_geometry,
    triangle_geometry,
)
from .text import GlyphAtlas, TextRenderer

__all__ = ["App", "NoDisplayError", "display_image"]

#: Text size (points at a content scale of 1), panel width (characters), pick radius (window
#: units), and how long messages stay.
TEXT_SIZE = 13
PANEL_CHARS = 44
PICK_RADIUS = 10.0
MESSAGE_SECONDS = 5.0
FIELD_OPACITY = 0.7
BACKGROUND = (0.13, 0.13, 0.14)
NO_DISPLAY_HINT = (
    "no display for the window ({why}); run it under a display or `xvfb-run -a glmls demo`, "
    "or use the headless commands instead (`glmls --help`; in Python glmls.warp, glmls.report)"
)


class NoDisplayError(RuntimeError):
    """No window could be opened (no display, no glfw, or no GL 4.3 core context on it)."""


def display_image(image: np.ndarray) -> np.ndarray:
    """An image as float32 RGB in [0, 1] for the window's 8-bit framebuffer: the pipeline
    writes the texture's raw values, so 0-255 values would all show white."""
    array = np.asarray(image)
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or not 1 <= array.shape[2] <= 4:
        raise ValueError(f"image must be H x W or H x W x C with C in 1..4, got {array.shape}")
    if np.issubdtype(array.dtype, np.integer):
        values = array.astype(np.float32) / float(np.iinfo(array.dtype).max)
    elif np.issubdtype(array.dtype, np.floating):
        values = np.clip(array.astype(np.float32), 0.0, 1.0)
    else:
        raise TypeError(f"image dtype must be integer or float, got {array.dtype}")
    colour = values[..., :3] if values.shape[2] >= 3 else np.repeat(values[..., :1], 3, axis=2)
    return np.ascontiguousarray(colour)


# -- the glfw window --------------------------------------------------------------------------


class _GlfwWindow:
    """A glfw window with a current GL 4.3 core context; :class:`NoDisplayError` if none."""

    def __init__(self, size: tuple[int, int], title: str, *, vsync: bool) -> None:
        try:
            import glfw
        except ImportError as error:  # the glfw shared library is missing
            raise NoDisplayError(NO_DISPLAY_HINT.format(why=f"glfw: {error}")) from None
        self.glfw = glfw
        self._errors: list[str] = []
        glfw.set_error_callback(lambda code, text: self._errors.append(_text(text)))
        if not glfw.init():
            raise NoDisplayError(NO_DISPLAY_HINT.format(why=self._why("glfw could not start")))
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 4)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.SCALE_TO_MONITOR, True)
        glfw.window_hint(glfw.SAMPLES, 0)
        self.handle = glfw.create_window(size[0], size[1], title, None, None)
        if not self.handle:
            why = self._why("no OpenGL 4.3 core context")
            glfw.terminate()
            raise NoDisplayError(NO_DISPLAY_HINT.format(why=why))
        glfw.make_context_current(self.handle)
        glfw.swap_interval(1 if vsync else 0)

    def _why(self, default: str) -> str:
        return self._errors[-1] if self._errors else default

    @property
    def framebuffer_size(self) -> tuple[int, int]:
        return tuple(self.glfw.get_framebuffer_size(self.handle))  # type: ignore[return-value]

    @property
    def pixel_ratio(self) -> float:
        """Framebuffer pixels per window unit (2 on a Retina-type screen)."""
        width = self.glfw.get_window_size(self.handle)[0]
        return self.framebuffer_size[0] / width if width else 1.0

    @property
    def content_scale(self) -> float:
        return float(max(self.glfw.get_window_content_scale(self.handle)))

    def close(self) -> None:
        self.glfw.destroy_window(self.handle)
        self.glfw.terminate()


def _text(value: object) -> str:
    return value.decode(errors="replace") if isinstance(value, bytes) else str(value)


# -- the application --------------------------------------------------------------------------


@dataclass
class _Analysis:
    """Cached results of the analysis overlays for one handle revision."""

    key: tuple = ()
    lines: list[str] = field(default_factory=list)
    geometry: list[tuple[np.ndarray, int]] = field(default_factory=list)
    field_ready: bool = False


class App:
    """The window: one image, its handles and reference points, and a :class:`Controller`.

    ``out_dir``: where ``s``/``j``/``S`` save; ``handles_path``: the file ``l`` loads (else
    the last one saved). Open with :meth:`run`.
    """

    def __init__(
        self,
        image: np.ndarray,
        src: np.ndarray,
        dst: np.ndarray,
        *,
        reference: np.ndarray | None = None,
        settings: Settings | None = None,
        name: str = "image",
        out_dir: str | Path = ".",
        handles_path: str | Path | None = None,
        window_size: tuple[int, int] | None = None,
    ) -> None:
        self.image = np.asarray(image)
        self.display = display_image(self.image)
        self.shape = (self.display.shape[0], self.display.shape[1])
        self.name = name
        self.out_dir = Path(out_dir)
        self.handles_path = Path(handles_path) if handles_path is not None else None
        self.window_size = window_size
        self.controller = Controller(
            src,
            dst,
            self.shape,
            reference=np.zeros((0, 2)) if reference is None else reference,
            settings=settings or Settings(),
        )
        self.timings: dict[str, float] = {}
        self.frame_times: deque[float] = deque(maxlen=240)
        self.frames = 0
        self._messages: list[tuple[float, str]] = []
        self._mls: MLS | None = None
        self._mls_key: tuple = ()
        self._mls_revision = -1
        self._mls_error = ""
        self._analysis = _Analysis()
        self._reference_cache: tuple[tuple, np.ndarray] = ((), np.zeros((0, 2)))
        self._field_texture: moderngl.Texture | None = None
        self._last_view: tuple = ()
        self._want_screenshot: Path | None = None
        self._quit = False

    # -- window set-up ----------------------------------------------------------------------

    def _default_size(self) -> tuple[int, int]:
        height, width = self.shape
        scale = min(1.0, 1000 / width, 760 / height)
        panel = PANEL_CHARS * 8 + 24
        return panel + round(width * scale), max(round(height * scale), 480)

    def _open(self, *, vsync: bool) -> None:
        size = self.window_size or self._default_size()
        title = f"glmls demo - {self.name}"
        self.window = _GlfwWindow(size, title, vsync=vsync)
        try:
            mgl = moderngl.create_context(require=430)
        except Exception as error:  # glcontext raises bare Exception
            self.window.close()
            raise NoDisplayError(NO_DISPLAY_HINT.format(why=f"OpenGL: {error}")) from None
        self.mgl = mgl
        self.gl: GLContext = get_context(mgl)  # glmls adopts the window's context
        self.pipeline = WarpPipeline(self.gl)
        # 8-bit, as the framebuffer: nearest quads then take the pipeline's fused path
        self.source = self.pipeline.upload(
            prepare_image(as_rgb8(self.display), self.pipeline.max_image_size, normalized=True)
        )
        self.geometry = GeometryDrawer(self.gl, self.shape)
        self.picture = PictureDrawer(self.gl, self.shape)
        self.field_picture = PictureDrawer(self.gl, self.shape)
        self._atlas_scale = 0.0
        self.text: TextRenderer | None = None
        # Two sets of timer queries, used in turn: a frame reads the set of the frame before,
        # whose GPU work is done by then, so reading never stalls the frame being drawn.
        self._query_sets = [
            {name: mgl.query(time=True) for name in ("warp", "overlays", "text")} for _ in (0, 1)
        ]
        self._queries = self._query_sets[0]
        self._install_callbacks()

    def _ensure_text(self) -> TextRenderer:
        scale = self.window.content_scale * self.window.pixel_ratio
        if self.text is None or scale != self._atlas_scale:
            if self.text is not None:
                self.text.release()
            size = max(8, round(TEXT_SIZE * scale))
            self.text = TextRenderer(self.gl, GlyphAtlas(size))
            self._atlas_scale = scale
        return self.text

    def _install_callbacks(self) -> None:
        glfw, handle = self.window.glfw, self.window.handle

        def mods_of(bits: int) -> frozenset[str]:
            names = ((glfw.MOD_SHIFT, "shift"), (glfw.MOD_CONTROL, "ctrl"), (glfw.MOD_ALT, "alt"))
            return frozenset(name for bit, name in names if bits & bit)

        def cursor(window) -> tuple[float, float]:
            x, y = glfw.get_cursor_pos(window)
            return self.layout.to_image(x, y, self.window.pixel_ratio)

        def on_button(window, button, action, mods) -> None:
            names = {glfw.MOUSE_BUTTON_LEFT: "left", glfw.MOUSE_BUTTON_RIGHT: "right"}
            if button not in names:
                return
            x, y = cursor(window)
            if action == glfw.PRESS:
                self.feed(Press(x, y, names[button], mods_of(mods)))
            elif action == glfw.RELEASE:
                self.feed(Release(x, y, names[button]))

        def on_move(window, _x, _y) -> None:
            if self.controller.dragging:
                self.feed(Move(*cursor(window)))

        def on_char(window, codepoint) -> None:
            self.feed(Key(chr(codepoint)))

        special = {
            glfw.KEY_F1: "F1",
            glfw.KEY_ESCAPE: "Escape",
            glfw.KEY_BACKSPACE: "Backspace",
        }

        def on_key(window, key, scancode, action, mods) -> None:
            if action not in (glfw.PRESS, glfw.REPEAT):
                return
            if key in special:
                self.feed(Key(special[key]))
            elif mods & glfw.MOD_CONTROL and glfw.KEY_A <= key <= glfw.KEY_Z:
                self.feed(Key(f"Ctrl+{chr(key)}"))

        glfw.set_mouse_button_callback(handle, on_button)
        glfw.set_cursor_pos_callback(handle, on_move)
        glfw.set_char_callback(handle, on_char)
        glfw.set_key_callback(handle, on_key)

    # -- events and commands ----------------------------------------------------------------

    def feed(self, event) -> None:
        """One event through the controller, then the commands it returned."""
        self.controller.pick_radius = PICK_RADIUS * self.window.pixel_ratio / self.layout.scale
        for command in self.controller.feed(event):
            self._command(command)
        if self.controller.message:
            self.say(self.controller.message)
            self.controller.message = ""

    def say(self, text: str) -> None:
        self._messages.append((time.perf_counter(), text))
        del self._messages[:-4]

    def _path(self, suffix: str) -> Path:
        return self.out_dir / f"{self.name}-{suffix}"

    def _command(self, command: str) -> None:
        c = self.controller
        try:
            if command == "quit":
                self._quit = True
            elif command == "save_image":
                path = self._path("warped.png")
                self._save_image(path)
                self.say(f"saved {path}")
            elif command == "save_handles":
                path = self._path("handles.json")
                write_handles(path, c.src, c.dst)
                self.handles_path = self.handles_path or path
                self.say(f"saved {path}")
            elif command == "save_screenshot":
                self._want_screenshot = self._path("screenshot.png")
            elif command == "load_handles":
                path = self.handles_path or self._path("handles.json")
                c.set_handles(*read_handles(path))
                self.say(f"loaded {len(c.src)} handles from {path}")
        except (OSError, ValueError) as error:
            self.say(f"{command.replace('_', ' ')} failed: {error}")

    def _save_image(self, path: Path) -> None:
        if self._mls is None:
            raise ValueError("no valid deformation to save")
        s = self.controller.settings
        image = self.image if self.image.dtype in (np.uint8, np.uint16) else self.display
        # MLS.warp's own pipeline: this one's "source" texture holds the display image
        out = self._mls.warp(image, method=s.method, interpolation=s.interpolation, grid=s.grid)
        if out.dtype not in (np.uint8, np.uint16):
            out = np.round(np.clip(out, 0, 1) * 255).astype(np.uint8)
        with atomic_write(path) as tmp:  # creates the folder; whole file or none
            imwrite(tmp, out)

    # -- per-frame work ---------------------------------------------------------------------

    def _sync_mls(self) -> None:
        c = self.controller
        if c.revision == self._mls_revision and self._mls is not None:
            return
        s = c.settings
        key = (s.transform, s.weight, s.alpha, s.radius)
        start = time.perf_counter()
        try:
            if self._mls is None or key != self._mls_key:
                mls = MLS(
                    c.src,
                    c.dst,
                    transform=s.transform,
                    weight=s.weight,
                    alpha=s.alpha,
                    radius=s.radius,
                    shape=self.shape,
                    ctx=self.gl,
                )
                if self._mls is not None:
                    self._mls.release()
                self._mls, self._mls_key = mls, key
            else:
                self._mls.set_handles(c.src, c.dst)
            self._mls_error = ""
        except ValueError as error:  # includes DegenerateHandlesError: keep the last valid f
            self._mls_error = str(error)
        self._mls_revision = c.revision
        self.timings["handles"] = time.perf_counter() - start

    def _analyse(self) -> None:
        """The analysis overlays' numbers and geometry, redone when f or the overlays change."""
        c, m = self.controller, self._mls
        s = c.settings
        wanted = tuple(name for name in ("mesh", "error", "angle", "folds") if c.overlays[name])
        key = (self._mls_revision, c.reference_revision, wanted, self.layout.scale)
        if key == self._analysis.key or m is None:
            return
        start = time.perf_counter()
        result = _Analysis(key=key)
        if "mesh" in wanted or "folds" in wanted:
            _, deformed = m.mesh(self.shape, grid=s.grid)
            if "folds" in wanted:
                folded = folded_cells(deformed)
                result.geometry.append((fold_geometry(deformed, folded), moderngl.TRIANGLES))
                result.lines.append(f"fold-overs: {int(folded.sum())} of {folded.size} cells")
            if "mesh" in wanted:
                stride = max(1, math.ceil(6.0 / (s.grid * self.layout.scale)))
                result.geometry.append((mesh_lines(deformed, stride), moderngl.LINES))
        if "error" in wanted:
            values = error_field(m, self.shape, grid=s.grid)
            stats = error_stats(values)
            colours = apply_colormap(values, cmap="linear", percentile=99.0)
            texture = prepare_image(colours.astype(np.float32) / 255.0, 1 << 30)
            self._field_texture = self.pipeline.upload(texture, role="field")
            result.field_ready = True
            shares = stats["within"] or []
            within = " ".join(f"{100 * w:.0f}%" for w in shares)  # type: ignore[union-attr]
            result.lines += [
                f"E_MLS px^2: mean {_num(stats['mean'])} std {_num(stats['std'])}",
                f"  min {_num(stats['min'])} max {_num(stats['max'])}",
                f"  within 1/2/3 std: {within}",
            ]
        if "angle" in wanted:
            result.lines += self._triangles(m, result)
        self._analysis = result
        self.timings["analysis"] = time.perf_counter() - start

    def _triangles(self, m: MLS, result: _Analysis) -> list[str]:
        points = self.controller.reference
        if len(points) < 3:
            return [f"angle error: needs 3 reference points ({len(points)}; key p)"]
        try:
            tri = triangle_errors(m, points)
        except ValueError as error:
            return [f"angle error: {error}"[:80]]
        fill, edges, _ = triangle_geometry(tri.deformed_points, tri.simplices, tri.angle)
        result.geometry += [(fill, moderngl.TRIANGLES), (edges, moderngl.LINES)]
        angle, distance = error_stats(tri.angle), error_stats(tri.distance)
        return [
            f"angle err (eq.11): mean {_num(angle['mean'])} std {_num(angle['std'])}",
            f"  max {_num(angle['max'])}  distance mean {_num(distance['mean'])}",
            f"  {len(tri.simplices)} triangles, {int(tri.flipped.sum())} flipped",
        ]

    def _deformed_reference(self) -> np.ndarray:
        """f(r) of the reference points (cached per handle and reference revision)."""
        c = self.controller
        key = (self._mls_revision, c.reference_revision)
        if self._reference_cache[0] != key:
            points = self._mls(c.reference) if self._mls is not None else c.reference
            self._reference_cache = (key, points)
        return self._reference_cache[1]

    def _view_key(self) -> tuple:
        c = self.controller
        return (
            c.revision,
            c.reference_revision,
            tuple(c.overlays.values()),
            c.help_visible,
            c.reference_mode,
            self.window.framebuffer_size,
            len(self._messages),
        )

    def render(self) -> None:
        """Draw one frame into the window's back buffer."""
        mgl = self.mgl
        self.gl.make_current()
        fb = self.window.framebuffer_size
        text = self._ensure_text()
        panel = round(PANEL_CHARS * text.atlas.advance["M"]) + 24
        self.layout = layout(fb, self.shape, panel)
        self._sync_mls()
        self._analyse()
        c, s = self.controller, self.controller.settings
        screen = mgl.screen
        screen.use()
        screen.viewport = (0, 0, *fb)
        screen.clear(*BACKGROUND, 1.0)
        screen.clear(0.0, 0.0, 0.0, 1.0, viewport=self.layout.viewport)
        with self._queries["warp"]:
            if self._mls is not None:
                self._draw_image(screen, s)
        with self._queries["overlays"]:
            screen.viewport = self.layout.viewport
            if self._mls is not None and c.overlays["error"] and self._analysis.field_ready:
                self._render_offscreen(self.field_picture, self._field_texture, s)
                screen.use()
                screen.viewport = self.layout.viewport
                self.field_picture.draw(opacity=FIELD_OPACITY, linear=True)
            for vertices, mode in self._analysis.geometry:
                self.geometry.draw(vertices, mode)
            scale = self.layout.scale
            if c.overlays["handles"] or c.reference_mode:
                self.geometry.draw(handle_geometry(c.src, c.dst, scale))
            if (c.reference_mode or c.overlays["angle"]) and len(c.reference):
                self.geometry.draw(reference_geometry(self._deformed_reference(), scale))
        with self._queries["text"]:
            screen.viewport = (0, 0, *fb)
            text.draw(self._text_quads(text.atlas), fb)

    def _draw_image(self, screen: moderngl.Framebuffer, s: Settings) -> None:
        if s.method == "quads" and s.interpolation == "linear":
            # drawn at the screen's resolution: bilinear detail where the window magnifies.
            # Nearest quads go through the picture: the compute scan conversion writes it
            # directly (an image-sized RGBA8 target), 2-3x faster than the rasterizer here.
            screen.viewport = self.layout.viewport
            self.pipeline.render(
                self._mls,
                self.source,
                screen,
                method="quads",
                interpolation=s.interpolation,
                grid=s.grid,
                flip_y=True,
            )
            return
        self._render_offscreen(self.picture, self.source, s)
        screen.use()
        screen.viewport = self.layout.viewport
        self.picture.draw(opacity=1.0, linear=False)

    def _render_offscreen(self, picture: PictureDrawer, source, s: Settings) -> None:
        picture.framebuffer.use()
        picture.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
        self.pipeline.render(
            self._mls,
            source,
            picture.framebuffer,
            method=s.method,
            interpolation=s.interpolation,
            grid=s.grid,
            flip_y=False,
        )

    # -- text -------------------------------------------------------------------------------

    def readout(self) -> list[str]:
        """The lines of the on-screen readout."""
        c, s = self.controller, self.controller.settings
        times = list(self.frame_times)
        recent = [t for t in times if t >= times[-1] - 1.0] if times else []
        fps = (len(recent) - 1) / (recent[-1] - recent[0]) if len(recent) > 2 else 0.0
        frame_ms = 1000 * (recent[-1] - recent[-2]) if len(recent) > 1 else 0.0
        ms = {k: 1000 * v for k, v in self.timings.items()}
        on = [name for name in OVERLAYS if c.overlays[name]]
        height, width = self.shape
        lines = [
            f"glmls  {self.name}  {width}x{height}",
            f"fps {fps:5.1f}   frame {frame_ms:5.1f} ms",
            f"ms: handles {ms.get('handles', 0):.2f}  warp {ms.get('warp', 0):.2f}",
            f"    analysis {ms.get('analysis', 0):.1f}  overlays {ms.get('overlays', 0):.2f}"
            f"  text {ms.get('text', 0):.2f}",
            "",
            f"transform  {s.transform}   (t)",
            f"weight     {s.weight}, {s.parameter(self.shape)}   (w, +/-)",
            f"construct  {s.method} {s.interpolation}   (c)",
            f"grid       {s.grid} px   (g/G)",
            f"handles    {len(c.src)}   reference {len(c.reference)}",
            f"mode       {'REFERENCE POINTS' if c.reference_mode else 'handles'}   (p)",
            f"overlays   {' '.join(on) or 'none'}",
            "",
        ]
        if self._mls_error:
            lines += _wrap(f"! {self._mls_error}", PANEL_CHARS) + ["  (showing the last valid f)"]
        lines += self._analysis.lines
        if not any(c.overlays[n] for n in ("error", "angle", "folds")):
            lines.append("errors: e field, a angles, f folds")
        lines += ["", "F1 or ?: help"]
        now = time.perf_counter()
        for stamp, message in self._messages:
            if now - stamp < MESSAGE_SECONDS:
                lines += _wrap(message, PANEL_CHARS)
        return lines

    def _text_quads(self, atlas: GlyphAtlas) -> list[np.ndarray]:
        pad = atlas.cell[1] // 2
        lines = self.readout()
        width = max(atlas.width(line) for line in lines) + 2 * pad
        height = len(lines) * atlas.line_height + 2 * pad
        parts = [
            atlas.rectangle(0, 0, width, height, (0.0, 0.0, 0.0, 0.55)),
            atlas.quads("\n".join(lines), pad, pad, (0.95, 0.95, 0.95, 1.0)),
        ]
        if self.controller.help_visible:
            parts += self._help_quads(atlas)
        return parts

    def _help_quads(self, atlas: GlyphAtlas) -> list[np.ndarray]:
        column = max(len(", ".join(keys)) for keys, _, _ in BINDINGS)
        lines = [
            "Mouse",
            "  click empty space    add a handle (p = q)",
            "  drag a handle        move its target q",
            "  shift + drag         move its source p",
            "  right-click          delete a handle",
            "  in reference mode (p): click adds, drag moves,",
            "  right-click deletes reference points",
            "Keys",
            *(f"  {', '.join(keys):<{column}} {text}" for keys, _, text in BINDINGS),
        ]
        fb_w, fb_h = self.window.framebuffer_size
        pad = atlas.cell[1]
        width = max(atlas.width(line) for line in lines) + 2 * pad
        height = len(lines) * atlas.line_height + 2 * pad
        # beside the readout when there is room, else centred over everything
        left = self.layout.panel if self.layout.panel + width <= fb_w else (fb_w - width) / 2
        x, y = max(left, 0), max((fb_h - height) / 2, 0)
        return [
            atlas.rectangle(x, y, width, height, (0.05, 0.05, 0.08, 0.88)),
            atlas.quads("\n".join(lines), x + pad, y + pad, (1.0, 0.92, 0.6, 1.0)),
        ]

    # -- main loop --------------------------------------------------------------------------

    def run(
        self,
        *,
        events: Sequence | None = None,
        frames: int | None = None,
        screenshot: str | Path | None = None,
        on_frame: Callable[[App], None] | None = None,
    ) -> None:
        """Open the window and run until closed, or for ``frames`` frames when given.

        ``events`` (replay) are fed one per frame before it is drawn (``Wait(n)`` skips n
        frames); ``screenshot`` saves the last frame drawn. Raises :class:`NoDisplayError`.
        """
        scripted = frames is not None
        self._open(vsync=not scripted)
        queue = deque(events or ())
        waiting = 0
        try:
            glfw = self.window.glfw
            self.layout = layout(self.window.framebuffer_size, self.shape, 0)
            while not glfw.window_should_close(self.window.handle) and not self._quit:
                if scripted or self._view_key() != self._last_view or self._want_screenshot:
                    glfw.poll_events()
                else:
                    glfw.wait_events_timeout(0.5)
                if waiting:
                    waiting -= 1
                elif queue:
                    event = queue.popleft()
                    if isinstance(event, Wait):
                        waiting = max(event.frames - 1, 0)
                    else:
                        self.feed(event)
                idle = self._view_key() == self._last_view and self._want_screenshot is None
                if not scripted and idle:
                    continue
                self._frame(on_frame)
                last = scripted and self.frames >= frames  # type: ignore[operator]
                if last and screenshot is not None:
                    self._want_screenshot = Path(screenshot)
                if self._want_screenshot is not None:
                    self._save_screenshot(self._want_screenshot, quiet=last)
                glfw.swap_buffers(self.window.handle)
                if last:
                    break
        finally:
            self.close()

    def _frame(self, on_frame: Callable[[App], None] | None) -> None:
        self._last_view = self._view_key()
        self.render()
        self.frames += 1
        self.frame_times.append(time.perf_counter())
        # the set the next frame uses holds the times of the frame before this one
        self._queries = self._query_sets[self.frames % 2]
        if self.frames >= 2:
            for name, query in self._queries.items():
                self.timings[name] = query.elapsed / 1e9
        if on_frame is not None:
            on_frame(self)

    def screenshot(self) -> np.ndarray:
        """What the window shows (the back buffer just drawn), (H, W, 3) uint8, top row first."""
        width, height = self.window.framebuffer_size
        data = self.mgl.screen.read(viewport=(0, 0, width, height), components=3, alignment=1)
        return np.frombuffer(data, np.uint8).reshape(height, width, 3)[::-1].copy()

    def _save_screenshot(self, path: Path, *, quiet: bool) -> None:
        self._want_screenshot = None
        try:
            with atomic_write(path) as tmp:
                imwrite(tmp, self.screenshot())
            if not quiet:
                self.say(f"saved {path}")
        except (OSError, ValueError) as error:
            if quiet:
                raise
            self.say(f"screenshot failed: {error}")

    def close(self) -> None:
        """Release every GL object, glmls's programs for this context, and the window."""
        if getattr(self, "window", None) is None:
            return
        self.gl.make_current()
        if self._mls is not None:
            self._mls.release()
        for obj in (self.pipeline, self.geometry, self.picture, self.field_picture, self.text):
            if obj is not None:
                obj.release()
        self._query_sets.clear()  # moderngl's Query has no release(); the context frees them
        self.gl.release()  # before the context goes: glmls's exit hook must find nothing
        self.window.close()
        self.window = None  # type: ignore[assignment]


def _num(value: object) -> str:
    return "-" if value is None else format_number(float(value))  # type: ignore[arg-type]


def _wrap(text: str, width: int) -> list[str]:
    """Lines of at most ``width`` characters (long words, e.g. paths, are cut)."""
    words, lines, line = [], [], ""
    for word in text.split():
        words += [word[i : i + width - 2] for i in range(0, len(word), width - 2)]
    for word in words:
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = "  " + word
        else:
            line = f"{line} {word}" if line else word
    return [*lines, line] if line else lines
