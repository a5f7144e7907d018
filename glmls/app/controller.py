"""The window's interaction logic, free of any window: events in, state and commands out.

Positions are image pixels, (x, y) = (column, row), pixel centres at integers; the window
converts the cursor (see :mod:`glmls.app.layout`), and a replay file gives them directly.
The controller changes its own state (handles, reference points, settings, overlays) and
returns *commands* for what only the window can do (save files, load handles, quit).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.config import MLSConfig, image_diagonal
from ..core.handles import as_points
from ..core.weights import WEIGHTS
from ..imaging.source import BORDERS, check_options
from .events import BUTTONS, Event, Key, Move, Press, Release

__all__ = [
    "BINDINGS",
    "COMMANDS",
    "CONSTRUCTIONS",
    "GRIDS",
    "OVERLAYS",
    "Controller",
    "Settings",
    "pick",
]

#: The image constructions the window cycles through: (method, interpolation).
CONSTRUCTIONS = (
    ("quads", "nearest"),
    ("quads", "linear"),
    ("splat", "nearest"),
    ("backward", "linear"),
)
GRIDS = (1, 2, 4, 8, 16, 32)
#: The transforms in the order ``t`` cycles them (from the most rigid).
TRANSFORM_ORDER = ("rigid", "similarity", "affine")
OVERLAYS = ("handles", "mesh", "error", "angle", "folds")
COMMANDS = ("save_image", "save_handles", "save_screenshot", "load_handles", "quit")
#: Smallest and largest idw alpha, and the step of + / -.
ALPHA_RANGE = (0.25, 4.0)
ALPHA_STEP = 0.25
#: + / - multiply or divide the radius by this.
RADIUS_FACTOR = 1.25
UNDO_DEPTH = 100

#: (keys, action, what it does): the key bindings, in the order the help overlay lists them.
#: Printable keys are the characters typed; others are named ("F1", "Escape", "Ctrl+Z").
BINDINGS: tuple[tuple[tuple[str, ...], str, str], ...] = (
    (("F1", "?"), "help", "show / hide this help"),
    (("t",), "transform", "cycle transform: rigid, similarity, affine"),
    (("w",), "weight", f"cycle weight: {', '.join(WEIGHTS)}"),
    (("+", "="), "raise", "raise the weight's parameter (idw alpha, else radius)"),
    (("-",), "lower", "lower the weight's parameter"),
    (("c",), "construction", "cycle construction: quads nearest/linear, splat, backward"),
    (("g",), "grid_finer", "finer grid (step / 2)"),
    (("G",), "grid_coarser", "coarser grid (step x 2)"),
    (("b",), "border", f"cycle border: {', '.join(BORDERS)}"),
    (("o",), "fit", "fit view: the whole deformed image / the input's frame"),
    (("h",), "overlay_handles", "overlay: handles (p -> q arrows)"),
    (("m",), "overlay_mesh", "overlay: deformed mesh wireframe"),
    (("e",), "overlay_error", "overlay: MLS error field (eq. 7)"),
    (("a",), "overlay_angle", "overlay: triangle angular error (eq. 11)"),
    (("f",), "overlay_folds", "overlay: fold-overs"),
    (("p",), "reference_mode", "reference-point mode on / off"),
    (("r",), "reset", "reset: every q back to its p"),
    (("R",), "restore", "restore the handles as loaded"),
    (("u", "Ctrl+Z", "Backspace"), "undo", "undo the last handle edit"),
    (("s",), "save_image", "save the deformed image (full resolution)"),
    (("j",), "save_handles", "save the handles as JSON"),
    (("S",), "save_screenshot", "save a screenshot of the window"),
    (("l",), "load_handles", "load the handles file"),
    (("q", "Escape"), "quit", "quit"),
)
_ACTIONS = {key: action for keys, action, _ in BINDINGS for key in keys}


# -- settings ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Settings:
    """What the window shows: the MLS configuration, the image construction, and whether
    the view fits the whole deformed image (``fit``) or shows the input's frame."""

    config: MLSConfig = field(default_factory=MLSConfig)
    method: str = "quads"
    interpolation: str = "nearest"
    grid: int = 4
    border: str = "constant"
    fit: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.config, MLSConfig):
            raise TypeError(f"config must be an MLSConfig, got {type(self.config).__name__}")
        check_options(self.method, self.interpolation, self.grid, self.border)
        if not isinstance(self.fit, bool):
            raise TypeError(f"fit must be True or False, got {self.fit!r}")

    def parameter(self, shape: tuple[int, int]) -> str:
        """The weight's parameter as text, e.g. ``alpha 1.25`` or ``R 362 px``."""
        config = self.config
        if config.uses_radius:
            return f"R {config.resolve_radius(shape):.0f} px"
        return f"alpha {config.alpha:g}"


def _next(values: Sequence, value, step: int = 1):
    return values[(list(values).index(value) + step) % len(values)]


def pick(points: np.ndarray, x: float, y: float, radius: float) -> int | None:
    """Index of the point nearest to (x, y) if it lies within ``radius``, else ``None``
    (ties: the later point, which is drawn on top)."""
    if len(points) == 0:
        return None
    distance = np.hypot(points[:, 0] - x, points[:, 1] - y)
    best = len(distance) - 1 - int(np.argmin(distance[::-1]))
    return best if distance[best] <= radius else None


@dataclass
class _Drag:
    kind: str  # "q", "p" or "reference"
    index: int
    before: tuple[np.ndarray, np.ndarray, np.ndarray]
    changed: bool = False


@dataclass
class Controller:
    """Handles, reference points, settings and overlays, changed by :meth:`feed`.

    ``revision`` grows whenever the handles or the settings change (the window then
    re-uploads the handles); ``reference_revision`` when the reference points change.
    ``pick_radius`` (image pixels) is how near a click must be to grab a point; the window
    keeps it at a fixed size on screen.
    """

    src: np.ndarray
    dst: np.ndarray
    shape: tuple[int, int]
    reference: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    settings: Settings = field(default_factory=Settings)
    pick_radius: float = 8.0
    overlays: dict[str, bool] = field(default_factory=lambda: {"handles": True})
    reference_mode: bool = False
    help_visible: bool = False
    message: str = ""
    revision: int = 0
    reference_revision: int = 0

    def __post_init__(self) -> None:
        self.src = as_points(self.src, "src").copy()
        self.dst = as_points(self.dst, "dst").copy()
        if self.src.shape != self.dst.shape:
            raise ValueError(
                f"src and dst must have the same shape, got {self.src.shape}, {self.dst.shape}"
            )
        self.reference = as_points(self.reference, "reference").copy()
        self.shape = (int(self.shape[0]), int(self.shape[1]))
        self.overlays = {name: bool(self.overlays.get(name, False)) for name in OVERLAYS}
        self._loaded = (self.src.copy(), self.dst.copy())
        self._undo: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._drag: _Drag | None = None

    # -- state helpers ------------------------------------------------------------------------

    def _snapshot(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.src.copy(), self.dst.copy(), self.reference.copy()

    def _push(self, snapshot: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        self._undo.append(snapshot)
        del self._undo[:-UNDO_DEPTH]

    def _restore(self, snapshot: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        src, dst, reference = snapshot
        if not np.array_equal(reference, self.reference):
            self.reference_revision += 1
        self.src, self.dst, self.reference = src.copy(), dst.copy(), reference.copy()
        self.revision += 1

    def _clamp(self, x: float, y: float) -> np.ndarray:
        """Keep dragged points on the image (what leaves it would be cut off anyway)."""
        height, width = self.shape
        return np.array([min(max(x, -0.5), width - 0.5), min(max(y, -0.5), height - 0.5)])

    def set_handles(self, src: object, dst: object) -> None:
        """Replace every handle (undoable), e.g. loaded from a file."""
        src, dst = as_points(src, "src"), as_points(dst, "dst")
        if src.shape != dst.shape:
            raise ValueError(f"src and dst must have the same shape, got {src.shape}, {dst.shape}")
        self._push(self._snapshot())
        self.src, self.dst = src.copy(), dst.copy()
        self.revision += 1

    @property
    def dragging(self) -> bool:
        return self._drag is not None

    @property
    def undo_depth(self) -> int:
        return len(self._undo)

    # -- events -------------------------------------------------------------------------------

    def feed(self, event: Event) -> list[str]:
        """Apply one event; returns the commands for the window (names in :data:`COMMANDS`)."""
        if isinstance(event, Press):
            self._press(event)
        elif isinstance(event, Move):
            self._move(event.x, event.y)
        elif isinstance(event, Release):
            self._release()
        elif isinstance(event, Key):
            return self._key(event.key)
        else:
            raise TypeError(f"unknown event {event!r}")
        return []

    def _press(self, event: Press) -> None:
        if event.button not in BUTTONS:
            raise ValueError(f"unknown mouse button {event.button!r}; use left or right")
        self._release()  # a press while dragging (a lost release) ends the old drag
        x, y, r = event.x, event.y, self.pick_radius
        before = self._snapshot()
        if self.reference_mode:
            index = pick(self.reference, x, y, r)
            if event.button == "right":
                if index is not None:
                    self._push(before)
                    self.reference = np.delete(self.reference, index, axis=0)
                    self.reference_revision += 1
                return
            if index is None:
                self.reference = np.concatenate([self.reference, [self._clamp(x, y)]])
                self.reference_revision += 1
                index = len(self.reference) - 1
                self._drag = _Drag("reference", index, before, changed=True)
            else:
                self._drag = _Drag("reference", index, before)
            return
        if event.button == "right":
            index = pick(self.dst, x, y, r)
            if index is None:
                index = pick(self.src, x, y, r)
            if index is not None:
                self._push(before)
                self.src = np.delete(self.src, index, axis=0)
                self.dst = np.delete(self.dst, index, axis=0)
                self.revision += 1
            return
        kind = "p" if "shift" in event.mods else "q"
        index = pick(self.src if kind == "p" else self.dst, x, y, r)
        if index is None:
            point = self._clamp(x, y)[None]
            self.src = np.concatenate([self.src, point])
            self.dst = np.concatenate([self.dst, point])
            self.revision += 1
            self._drag = _Drag("q", len(self.src) - 1, before, changed=True)
        else:
            self._drag = _Drag(kind, index, before)

    def _move(self, x: float, y: float) -> None:
        drag = self._drag
        if drag is None:
            return
        point = self._clamp(x, y)
        target = {"q": self.dst, "p": self.src, "reference": self.reference}[drag.kind]
        if np.array_equal(target[drag.index], point):
            return
        target[drag.index] = point
        drag.changed = True
        if drag.kind == "reference":
            self.reference_revision += 1
        else:
            self.revision += 1

    def _release(self) -> None:
        drag, self._drag = self._drag, None
        if drag is not None and drag.changed:
            self._push(drag.before)

    def _key(self, key: str) -> list[str]:
        action = _ACTIONS.get(key)
        if action is None:
            return []
        if action in COMMANDS:
            return [action]
        if action.startswith("overlay_"):
            name = action.removeprefix("overlay_")
            self.overlays[name] = not self.overlays[name]
            return []
        getattr(self, f"_do_{action}")()
        return []

    # -- key actions --------------------------------------------------------------------------

    def _configure(self, **changes: object) -> None:
        self.settings = replace(self.settings, **changes)
        self.revision += 1

    def _reconfigure(self, **changes: object) -> None:
        self._configure(config=replace(self.settings.config, **changes))

    def _do_help(self) -> None:
        self.help_visible = not self.help_visible

    def _do_transform(self) -> None:
        self._reconfigure(transform=_next(TRANSFORM_ORDER, self.settings.config.transform))

    def _do_weight(self) -> None:
        self._reconfigure(weight=_next(WEIGHTS, self.settings.config.weight))

    def _parameter(self, up: bool) -> None:
        config = self.settings.config
        if config.uses_radius:
            radius = config.resolve_radius(self.shape)
            radius = radius * RADIUS_FACTOR if up else radius / RADIUS_FACTOR  # type: ignore[operator]
            self._reconfigure(radius=min(max(radius, 1.0), 100 * image_diagonal(self.shape)))
        else:
            alpha = config.alpha + (ALPHA_STEP if up else -ALPHA_STEP)
            self._reconfigure(alpha=min(max(alpha, ALPHA_RANGE[0]), ALPHA_RANGE[1]))

    def _do_raise(self) -> None:
        self._parameter(up=True)

    def _do_lower(self) -> None:
        self._parameter(up=False)

    def _do_construction(self) -> None:
        pair = (self.settings.method, self.settings.interpolation)
        index = CONSTRUCTIONS.index(pair) if pair in CONSTRUCTIONS else -1
        method, interpolation = CONSTRUCTIONS[(index + 1) % len(CONSTRUCTIONS)]
        self._configure(method=method, interpolation=interpolation)

    def _grid(self, step: int) -> None:
        index = GRIDS.index(self.settings.grid) if self.settings.grid in GRIDS else 2
        self._configure(grid=GRIDS[min(max(index + step, 0), len(GRIDS) - 1)])

    def _do_grid_finer(self) -> None:
        self._grid(-1)

    def _do_grid_coarser(self) -> None:
        self._grid(+1)

    def _do_border(self) -> None:
        self._configure(border=_next(BORDERS, self.settings.border))

    def _do_fit(self) -> None:
        self._configure(fit=not self.settings.fit)

    def _do_reference_mode(self) -> None:
        self._release()
        self.reference_mode = not self.reference_mode

    def _do_reset(self) -> None:
        if not np.array_equal(self.dst, self.src):
            self.set_handles(self.src, self.src)

    def _do_restore(self) -> None:
        self.set_handles(*self._loaded)

    def _do_undo(self) -> None:
        self._release()
        if self._undo:
            self._restore(self._undo.pop())
        else:
            self.message = "nothing to undo"
