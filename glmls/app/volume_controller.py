"""The volume window's interaction logic, free of any window: events in, state and commands out.

The window shows three orthogonal slices through the *slice point* of a D x H x W volume,
laid out on one canvas, the *montage* (``SliceGrid``): the axial slice (constant z; x
to the right, y down) at the top left, the sagittal slice (constant x; z to the right, y
down) at its right, the coronal slice (constant y; x to the right, z down) under it. Events
carry montage pixels, as the 2D window's carry image pixels, so that the window's layout,
replays and recordings work unchanged; :meth:`SliceGrid.locate` says which view a montage
point falls in and where.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..core.config import MLSConfig
from ..core.handles3 import as_volume_spacing
from ..imaging.source import BORDERS, INTERPOLATIONS
from .controller import BINDINGS as IMAGE_BINDINGS
from .controls import Controls, window_bindings
from .events import Press, Scroll
from .settings import ALPHA_RANGE, ALPHA_STEP, RADIUS_FACTOR, bounded_step, cycle

__all__ = [
    "IMAGE_ONLY_KEYS",
    "VIEWS",
    "VOLUME_BINDINGS",
    "VOLUME_COMMANDS",
    "VOLUME_GRIDS",
    "VOLUME_METHODS",
    "VOLUME_OVERLAYS",
    "SliceGrid",
    "VolumeController",
    "VolumeSettings",
]

#: The three views, in the order of :attr:`SliceGrid.axes`.
VIEWS = ("axial", "coronal", "sagittal")
#: Per view: (the axis to the right, the axis down, the normal), 0 = x, 1 = y, 2 = z.
AXES = ((0, 1, 2), (0, 2, 1), (2, 1, 0))
#: What is drawn over the deformed slices: nothing, the error field E_MLS, or folds (det J <= 0).
VOLUME_OVERLAYS = ("none", "error", "folds")
VOLUME_METHODS = ("quads", "backward")
VOLUME_GRIDS = (1, 2, 4, 8, 16)
VOLUME_COMMANDS = ("save_volume", "save_handles", "save_screenshot", "load_handles", "quit")
#: Montage pixels between the views.
GAP = 4
UNDO_DEPTH = 100

#: (keys, action, what it does): the volume window's key bindings (named as the 2D window's).
VOLUME_BINDINGS: tuple[tuple[tuple[str, ...], str, str], ...] = window_bindings(
    (("c",), "method", "cycle construction: quads (cells), backward"),
    (),
    (
        (("e",), "overlay_error", "overlay: MLS error field E_MLS on / off"),
        (("f",), "overlay_folds", "overlay: folds (det J <= 0) on / off"),
        (("h",), "handles", "overlay: handles near the slices on / off"),
        (("1",), "view_axial", "active view: axial (z)"),
        (("2",), "view_coronal", "active view: coronal (y)"),
        (("3",), "view_sagittal", "active view: sagittal (x)"),
        (("Tab",), "view_next", "active view: the next one"),
        (("Up", "PageUp"), "slice_up", "slice point +1 voxel along the active view's normal"),
        (("Down", "PageDown"), "slice_down", "slice point -1 voxel along the active normal"),
        (("Right",), "slice_up8", "slice point +8 voxels along the active normal"),
        (("Left",), "slice_down8", "slice point -8 voxels along the active normal"),
        (("0",), "centre", "slice point back to the volume's centre"),
    ),
    (
        (("s",), "save_volume", "save the deformed volume (the input's format)"),
        (("j",), "save_handles", "save the handles as 3D JSON"),
    ),
)
_ACTIONS = {key: action for keys, action, _ in VOLUME_BINDINGS for key in keys}
#: The image window's keys that have no action here, and what they do there: pressed in the
#: volume window, the readout says so.
IMAGE_ONLY_KEYS = {
    key: what for keys, _, what in IMAGE_BINDINGS for key in keys if key not in _ACTIONS
}


@dataclass(frozen=True, kw_only=True)
class VolumeSettings:
    """What the volume window computes: the MLS configuration and the slices' construction.

    A frozen value: the window's keys replace it with a changed copy.

    Parameters
    ----------
    config : glmls.MLSConfig, optional
        The transform, the weight and its parameter; ``MLSConfig(transform="rigid")`` by
        default.
    method : {"quads", "backward"}, default "quads"
        The construction of the deformed slices (:data:`glmls.volume.VOLUME_METHODS`;
        quads is the cells method).
    grid : {1, 2, 4, 8, 16}, default 4
        The lattice step in voxels.
    border : str, default "edge"
        What lies beyond the volume (:data:`glmls.BORDERS`): the default ``edge`` leaves no
        empty margin where f moves the volume's faces.
    interpolation : {"linear", "nearest"}, default "linear"
        How the volume is sampled: trilinear, or the nearest voxel.

    Raises
    ------
    ValueError
        For a method, grid, border or interpolation outside those.

    See Also
    --------
    VolumeController : what holds it.

    Examples
    --------
    >>> from glmls.app import VolumeSettings
    >>> s = VolumeSettings(config=glmls.MLSConfig(transform="affine"), method="backward")
    >>> s.grid, s.border, s.interpolation
    (4, 'edge', 'linear')
    >>> VolumeSettings(grid=3)
    Traceback (most recent call last):
    ...
    ValueError: grid must be one of (1, 2, 4, 8, 16), got 3
    """

    config: MLSConfig = field(default_factory=lambda: MLSConfig(transform="rigid"))
    method: str = "quads"
    grid: int = 4
    border: str = "edge"
    interpolation: str = "linear"

    def __post_init__(self) -> None:
        if self.method not in VOLUME_METHODS:
            raise ValueError(f"method must be one of {VOLUME_METHODS}, got {self.method!r}")
        if self.grid not in VOLUME_GRIDS:
            raise ValueError(f"grid must be one of {VOLUME_GRIDS}, got {self.grid!r}")
        if self.border not in BORDERS:
            raise ValueError(f"border must be one of {BORDERS}, got {self.border!r}")
        if self.interpolation not in INTERPOLATIONS:
            raise ValueError(
                f"interpolation must be one of {INTERPOLATIONS}, got {self.interpolation!r}"
            )


@dataclass(frozen=True)
class SliceGrid:
    """Where the three views of a volume of ``shape`` (D, H, W) and voxel ``spacing``
    (dz, dy, dx) lie on the montage, and how montage points, voxels and handle units (the
    voxel (i, j, k) sits at (i dx, j dy, k dz), as in :meth:`glmls.MLS.warp`) map onto each
    other.

    Each view is drawn with the physical aspect: an axis of n voxels of size d spans
    ``round(n d / min(spacing))`` montage pixels (n for the smallest voxel size), so a voxel
    of 0.5 x 3.0 is a rectangle of 1 x 6 montage pixels.

    Examples
    --------
    >>> grid = SliceGrid((10, 20, 30))
    >>> grid.montage_shape, grid.offset(2), grid.size(2)
    ((34, 44), (34, 0), (10, 20))
    >>> grid.locate(36.0, 5.0)  # in the sagittal view: z = 2, y = 5
    (2, 2.0, 5.0)
    >>> thick = SliceGrid((10, 20, 30), spacing=(3.0, 1.0, 1.0))  # slices 3 units apart
    >>> thick.montage_shape, thick.size(2), thick.locate(38.0, 5.0)
    ((54, 64), (30, 20), (2, 1.0, 5.0))
    """

    shape: tuple[int, int, int]
    spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "spacing", as_volume_spacing(self.spacing))

    @property
    def scale(self) -> np.ndarray:
        """(dx, dy, dz): handle units per voxel along x, y and z."""
        return np.array(self.spacing[::-1])

    @property
    def isotropic(self) -> bool:
        """Whether handle units are voxels (the spacing is 1, 1, 1)."""
        return self.spacing == (1.0, 1.0, 1.0)

    @property
    def diagonal(self) -> float:
        """The volume's diagonal in handle units."""
        return float(np.linalg.norm(np.array(self.shape[::-1]) * self.scale))

    def pixels(self, axis: int) -> int:
        """Montage pixels along ``axis`` (0 = x, 1 = y, 2 = z)."""
        unit = min(self.spacing)
        return max(1, round(self.extent(axis) * self.spacing[2 - axis] / unit))

    def stretch(self, axis: int) -> float:
        """Montage pixels per voxel along ``axis``."""
        return self.pixels(axis) / self.extent(axis)

    @property
    def montage_shape(self) -> tuple[int, int]:
        """(rows, columns) of the montage."""
        depth, height, width = (self.pixels(axis) for axis in (2, 1, 0))
        return height + GAP + depth, width + GAP + depth

    def extent(self, axis: int) -> int:
        """Voxels along ``axis`` (0 = x, 1 = y, 2 = z)."""
        return self.shape[2 - axis]

    def size(self, view: int) -> tuple[int, int]:
        """(columns, rows) of ``view`` in montage pixels."""
        right, down, _ = AXES[view]
        return self.pixels(right), self.pixels(down)

    def offset(self, view: int) -> tuple[int, int]:
        """The montage point of ``view``'s voxel (0, 0) when voxels are one montage pixel;
        the view spans ``offset - 0.5`` to ``offset + size - 0.5``."""
        height, width = self.pixels(1), self.pixels(0)
        return ((0, 0), (0, height + GAP), (width + GAP, 0))[view]

    def _voxel(self, axis: int, pixel: float) -> float:
        """A montage coordinate along ``axis`` (less the view's offset) in voxels."""
        k = self.stretch(axis)
        return pixel if k == 1 else (pixel + 0.5) / k - 0.5

    def _pixel(self, axis: int, voxel: np.ndarray) -> np.ndarray:
        k = self.stretch(axis)
        return voxel if k == 1 else (voxel + 0.5) * k - 0.5

    def locate(self, x: float, y: float) -> tuple[int, float, float] | None:
        """(view, column, row) of montage point (x, y), in voxels of the view's axes, or
        None between the views."""
        for view in range(3):
            ox, oy = self.offset(view)
            columns, rows = self.size(view)
            u, v = x - ox, y - oy
            if -0.5 <= u < columns - 0.5 and -0.5 <= v < rows - 0.5:
                right, down, _ = AXES[view]
                return view, self._voxel(right, u), self._voxel(down, v)
        return None

    def to_view(self, view: int, x: float, y: float) -> tuple[float, float]:
        """Montage point (x, y) in voxels of ``view``'s axes, cut to its extent."""
        ox, oy = self.offset(view)
        right, down, _ = AXES[view]
        u, v = self._voxel(right, x - ox), self._voxel(down, y - oy)
        last_u, last_v = self.extent(right) - 1.0, self.extent(down) - 1.0
        return min(max(u, 0.0), last_u), min(max(v, 0.0), last_v)

    def to_montage(self, view: int, points: np.ndarray) -> np.ndarray:
        """(K, 3) points (x, y, z) in handle units as montage points (K, 2) of ``view``
        (its normal dropped)."""
        right, down, _ = AXES[view]
        voxels = self.to_voxels(points)
        columns = self._pixel(right, voxels[:, right])
        rows = self._pixel(down, voxels[:, down])
        return np.stack([columns, rows], axis=1) + self.offset(view)

    def to_voxels(self, points: object) -> np.ndarray:
        """(K, 3) points (x, y, z) in handle units as voxels (x / dx, y / dy, z / dz)."""
        return np.asarray(points, np.float64).reshape(-1, 3) / self.scale

    def to_units(self, voxels: object) -> np.ndarray:
        """(K, 3) voxels (x, y, z) in handle units (x dx, y dy, z dz)."""
        return np.asarray(voxels, np.float64).reshape(-1, 3) * self.scale


def _handles3(src: object, dst: object) -> tuple[np.ndarray, np.ndarray]:
    """The handles as two (N, 3) float64 arrays (new ones); ValueError unless alike."""
    p = np.array(src, np.float64).reshape(-1, 3)
    q = np.array(dst, np.float64).reshape(-1, 3)
    if p.shape != q.shape:
        raise ValueError(f"src and dst must be (N, 3) alike, got {p.shape} and {q.shape}")
    return p, q


class VolumeController(Controls):
    """The volume window's interaction, without a window: events in, state and commands out.

    It holds the 3D point handles, the slice point, the active view, the overlay and the
    :class:`VolumeSettings` of the volume window, and :meth:`feed` changes them; events
    carry montage pixels (``SliceGrid``). What only a
    window can do (save or load files, quit) comes back as commands.

    ``revision`` grows whenever the handles or the settings change, ``point_revision`` when
    the slice point moves. A left press on a handle's target (within ``pick_radius`` montage
    pixels, among those within ``near`` voxels of the view's plane) drags it within the
    plane; elsewhere in a view it makes that view active and moves the slice point there
    (the other two planes pass through it); shift + press adds a handle (p = q) there; a
    right press deletes the handle under the cursor; the wheel moves the slice point along
    the normal of the view under the cursor.

    Parameters
    ----------
    src, dst : array_like
        The handles (N, 3) (x, y, z), in handle units: voxel (i, j, k) sits at
        (i dx, j dy, k dz).
    shape : tuple of int
        (D, H, W) of the volume.
    spacing : (float, float, float), optional
        The voxel size (dz, dy, dx); default 1 (handle units are voxels). The views are
        drawn with the physical aspect (``SliceGrid``).
    settings : VolumeSettings, optional
        The MLS configuration and the construction.
    near : float, default 3
        Handles are shown and picked in a view within this many voxels of its plane.
    pick_radius : float, default 3
        Montage pixels (the window sets it from 10 screen pixels).

    Attributes
    ----------
    src, dst : numpy.ndarray
        The handles (N, 3), replaced (never changed in place) by each edit.
    point : tuple of int
        The slice point (x, y, z) in voxels; the three views' planes pass through it.
    active : int
        The active view: 0 axial, 1 coronal, 2 sagittal.
    overlay : str
        ``none``, ``error`` or ``folds``.
    settings : VolumeSettings
        What is computed now.
    grid : glmls.app.volume_controller.SliceGrid
        Where the views lie on the montage.

    Raises
    ------
    ValueError
        For ``src`` and ``dst`` that are not (N, 3) alike.

    See Also
    --------
    VolumeApp : the window around it.
    Controller : the image window's.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.app import Key, Move, Press, Release, VolumeController
    >>> src = np.array([[2.0, 2, 5], [8, 8, 5]])
    >>> c = VolumeController(src, src, (10, 12, 12))
    >>> for event in (Press(2, 2), Move(4, 3), Release(4, 3)):  # drag q_0 in the axial view
    ...     _ = c.feed(event)
    >>> c.dst[0].tolist(), c.point
    ([4.0, 3.0, 5.0], (6, 6, 5))
    >>> c.feed(Key("Up")), c.point  # the slice point one voxel along z
    ([], (6, 6, 6))
    """

    def __init__(
        self,
        src: object,
        dst: object,
        shape: tuple[int, int, int],
        *,
        spacing: tuple[float, float, float] | None = None,
        settings: VolumeSettings | None = None,
        near: float = 3.0,
        pick_radius: float = 3.0,
    ) -> None:
        p, q = _handles3(src, dst)
        self.grid = SliceGrid(
            tuple(int(n) for n in shape),  # type: ignore[arg-type]
            spacing=(1.0, 1.0, 1.0) if spacing is None else tuple(spacing),  # type: ignore[arg-type]
        )
        self.settings = settings or VolumeSettings()
        self.near = float(near)
        self.pick_radius = float(pick_radius)
        self.src, self.dst = p, q
        self.loaded = (p.copy(), q.copy())
        self.point = self.centre
        self.active = 0
        self.overlay = "none"
        self.show_handles = True
        self.help_visible = False
        #: A line for the readout (set by actions, cleared by the window).
        self.message = ""
        self.revision = 0
        self.point_revision = 0
        self._undo: list[tuple[np.ndarray, np.ndarray]] = []
        self._redo: list[tuple[np.ndarray, np.ndarray]] = []
        self._drag: tuple[int, int, tuple[np.ndarray, np.ndarray]] | None = None
        self._wheel = 0.0  # wheel notches not yet taken (fractions of one)
        self._wheel_view = 0  # the view they were turned over

    # -- state --------------------------------------------------------------------------------

    @property
    def centre(self) -> tuple[int, int, int]:
        """The volume's central voxel (x, y, z), where the slice point starts (``0``).

        Examples
        --------
        >>> from glmls.app import Key, VolumeController
        >>> c = VolumeController([[2.0, 2, 5]], [[2.0, 2, 5]], (10, 12, 16))  # (D, H, W)
        >>> c.centre
        (8, 6, 5)
        >>> _ = c.feed(Key("Up")), c.feed(Key("Up"))  # the slice point along z
        >>> c.point
        (8, 6, 7)
        >>> _ = c.feed(Key("0"))
        >>> c.point
        (8, 6, 5)
        """
        return tuple(self.grid.extent(axis) // 2 for axis in range(3))  # type: ignore[return-value]

    @property
    def dragging(self) -> bool:
        """Whether a handle's target is being dragged.

        Examples
        --------
        >>> from glmls.app import Press, Release, VolumeController
        >>> c = VolumeController([[2.0, 2, 5]], [[2.0, 2, 5]], (10, 12, 12))
        >>> _ = c.feed(Press(2.0, 2.0))  # on q_0 in the axial view
        >>> c.dragging
        True
        >>> _ = c.feed(Release(2.0, 2.0))
        >>> c.dragging
        False
        """
        return self._drag is not None

    @property
    def undo_depth(self) -> int:
        """How many handle edits ``u`` can undo.

        Examples
        --------
        >>> from glmls.app import Key, Move, Press, Release, VolumeController
        >>> c = VolumeController([[2.0, 2, 5]], [[2.0, 2, 5]], (10, 12, 12))
        >>> for event in (Press(2.0, 2.0), Move(4.0, 3.0), Release(4.0, 3.0)):
        ...     _ = c.feed(event)  # drag q_0: one edit
        >>> c.undo_depth, c.dst.tolist()
        (1, [[4.0, 3.0, 5.0]])
        >>> _ = c.feed(Key("u"))
        >>> c.undo_depth, c.dst.tolist()
        (0, [[2.0, 2.0, 5.0]])
        """
        return len(self._undo)

    def near_plane(self, view: int) -> np.ndarray:
        """Indices of the handles within ``near`` voxels of ``view``'s plane.

        A handle is near when its source or its target is.

        Parameters
        ----------
        view : int
            0 axial, 1 coronal, 2 sagittal.

        Returns
        -------
        numpy.ndarray
            The indices, ascending.

        Examples
        --------
        >>> from glmls.app import Key, VolumeController
        >>> src = [[2.0, 2, 5], [8, 8, 0]]
        >>> c = VolumeController(src, src, (10, 12, 12))  # the slice point at z = 5
        >>> c.near_plane(0).tolist()  # the axial view
        [0]
        >>> for _ in range(3):
        ...     _ = c.feed(Key("Down"))  # the slice point to z = 2
        >>> c.near_plane(0).tolist()
        [0, 1]
        """
        normal = AXES[view][2]
        at, step = self.point[normal], self.grid.scale[normal]
        close = (np.abs(self.src[:, normal] / step - at) <= self.near) | (
            np.abs(self.dst[:, normal] / step - at) <= self.near
        )
        return np.nonzero(close)[0]

    def set_handles(self, src: object, dst: object) -> None:
        """Replace every handle (undoable), e.g. loaded from a file.

        A drag under way ends first, as its own edit (its index may not survive the change).

        Parameters
        ----------
        src, dst : array_like
            The handles (N, 3) (x, y, z) in handle units.

        Examples
        --------
        >>> from glmls.app import Key, VolumeController
        >>> c = VolumeController([[2.0, 2, 5]], [[2.0, 2, 5]], (10, 12, 12))
        >>> c.set_handles([[2.0, 2, 5], [8, 8, 5]], [[3.0, 2, 5], [8, 9, 5]])
        >>> c.dst.tolist()
        [[3.0, 2.0, 5.0], [8.0, 9.0, 5.0]]
        >>> _ = c.feed(Key("u"))  # undone as one edit
        >>> c.dst.tolist()
        [[2.0, 2.0, 5.0]]
        """
        p, q = _handles3(src, dst)
        self._release()
        self._remember()
        self.src, self.dst = p, q
        self.revision += 1

    def _remember(self, before: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Keep the handles ``before`` an edit (default: as they are) for undo."""
        self._undo.append(before or (self.src.copy(), self.dst.copy()))
        del self._undo[:-UNDO_DEPTH]
        self._redo.clear()

    def _move_point(self, axis: int, value: float) -> None:
        point = list(self.point)
        point[axis] = int(min(max(round(value), 0), self.grid.extent(axis) - 1))
        if tuple(point) != self.point:
            self.point = tuple(point)  # type: ignore[assignment]
            self.point_revision += 1

    # -- events -------------------------------------------------------------------------------

    # feed (Controls): the commands it returns are names in VOLUME_COMMANDS

    def _scroll(self, event: Scroll) -> None:
        found = self.grid.locate(event.x, event.y)
        if found is None:
            return
        # a touchpad's fractions of a notch add up to whole slices; the rest waits, for the
        # view it was turned over only (another view's normal is another axis)
        if found[0] != self._wheel_view:
            self._wheel, self._wheel_view = 0.0, found[0]
        self._wheel += min(max(event.dy, -1e6), 1e6)
        steps = int(self._wheel)
        self._wheel -= steps
        if steps:
            normal = AXES[found[0]][2]
            self._move_point(normal, self.point[normal] + steps)

    def _pick(self, view: int, x: float, y: float) -> int | None:
        candidates = self.near_plane(view)
        if not len(candidates):
            return None
        targets = self.grid.to_montage(view, self.dst[candidates])
        distance = np.hypot(targets[:, 0] - x, targets[:, 1] - y)
        best = int(np.argmin(distance[::-1]))  # a tie goes to the later (drawn on top)
        best = len(distance) - 1 - best
        return int(candidates[best]) if distance[best] <= self.pick_radius else None

    def _press(self, event: Press) -> None:
        self._release()
        found = self.grid.locate(event.x, event.y)
        if found is None:
            return
        view, u, v = found
        self.active = view
        index = self._pick(view, event.x, event.y)
        right, down, _ = AXES[view]
        if event.button == "right":
            if index is not None:
                self._remember()
                self.src = np.delete(self.src, index, axis=0)
                self.dst = np.delete(self.dst, index, axis=0)
                self.revision += 1
        elif event.button != "left":
            return
        elif "shift" in event.mods:
            voxel = np.array(self.point, np.float64)
            voxel[right], voxel[down] = round(u, 2), round(v, 2)
            point = self.grid.to_units(voxel)[0]
            before = (self.src.copy(), self.dst.copy())
            self.src = np.vstack([self.src, point])
            self.dst = np.vstack([self.dst, point])
            self.revision += 1
            self._drag = (len(self.dst) - 1, view, before)
        elif index is not None:
            self._drag = (index, view, (self.src.copy(), self.dst.copy()))
        else:
            self._move_point(right, u)
            self._move_point(down, v)

    def _move(self, x: float, y: float) -> None:
        if self._drag is None:
            return
        index, view, _ = self._drag
        u, v = self.grid.to_view(view, x, y)
        right, down, _ = AXES[view]
        u, v = u * self.grid.scale[right], v * self.grid.scale[down]
        if (self.dst[index, right], self.dst[index, down]) != (u, v):
            self.dst = self.dst.copy()
            self.dst[index, right], self.dst[index, down] = u, v
            self.revision += 1

    def _release(self) -> None:
        if self._drag is None:
            return
        _, _, (src, dst) = self._drag
        self._drag = None
        if not (np.array_equal(src, self.src) and np.array_equal(dst, self.dst)):
            self._remember((src, dst))

    def _key(self, key: str) -> list[str]:
        action = _ACTIONS.get(key)
        if action is None:
            if key in IMAGE_ONLY_KEYS:
                self.message = f"{key}: for images, not volumes ({IMAGE_ONLY_KEYS[key]})"
            return []
        if action in VOLUME_COMMANDS:
            return [action]
        if action.startswith("overlay_"):
            name = action.removeprefix("overlay_")
            self.overlay = "none" if self.overlay == name else name
        elif action.startswith("view_"):
            name = action.removeprefix("view_")
            self.active = (self.active + 1) % 3 if name == "next" else VIEWS.index(name)
        elif action.startswith("slice_"):
            step = {"up": 1, "down": -1, "up8": 8, "down8": -8}[action.removeprefix("slice_")]
            normal = AXES[self.active][2]
            self._move_point(normal, self.point[normal] + step)
        else:
            getattr(self, f"_do_{action}")()
        return []

    # -- key actions --------------------------------------------------------------------------

    def _configure(self, settings: VolumeSettings) -> None:
        self.settings = settings
        self.revision += 1

    def _do_handles(self) -> None:
        self.show_handles = not self.show_handles

    @property
    def radius(self) -> float:
        """The weight's radius R in handle units (by default the volume's diagonal).

        Examples
        --------
        >>> from glmls.app import Key, VolumeController, VolumeSettings
        >>> src, shape = [[2.0, 2, 5]], (10, 12, 12)
        >>> round(VolumeController(src, src, shape).radius, 2)  # the diagonal, unset
        19.7
        >>> config = glmls.MLSConfig(weight="gaussian", radius=20.0)
        >>> c = VolumeController(src, src, shape, settings=VolumeSettings(config=config))
        >>> c.radius
        20.0
        >>> _ = c.feed(Key("+"))  # times 1.25
        >>> c.radius
        25.0
        """
        radius = self.settings.config.radius
        return float(radius) if radius is not None else self.grid.diagonal

    def parameter(self) -> str:
        """The weight's parameter as text, as the readout shows it.

        Returns
        -------
        str
            E.g. ``alpha 1.25``, ``R 111 vox`` (handle units are voxels) or ``R 55.5``.

        Examples
        --------
        >>> from glmls.app import Key, VolumeController
        >>> c = VolumeController([[2.0, 2, 5]], [[2.0, 2, 5]], (10, 12, 12))
        >>> c.parameter()  # idw
        'alpha 1'
        >>> _ = c.feed(Key("w"))  # the next weight: one with a radius
        >>> c.parameter()
        'R 20 vox'
        """
        config = self.settings.config
        if not config.uses_radius:
            return f"alpha {config.alpha:g}"
        return f"R {self.radius:.0f} vox" if self.grid.isotropic else f"R {self.radius:.4g}"

    def _step(self, up: bool) -> None:
        config = self.settings.config
        if config.uses_radius:
            new = self.radius * RADIUS_FACTOR if up else self.radius / RADIUS_FACTOR
            least = min(self.grid.spacing)
            radius = bounded_step(self.radius, new, least, 100 * self.grid.diagonal)
            config = replace(config, radius=radius)
        else:
            new = config.alpha + (ALPHA_STEP if up else -ALPHA_STEP)
            config = replace(config, alpha=bounded_step(config.alpha, new, *ALPHA_RANGE))
        self._configure(replace(self.settings, config=config))

    def _do_raise(self) -> None:
        self._step(True)

    def _do_lower(self) -> None:
        self._step(False)

    def _do_method(self) -> None:
        self._configure(replace(self.settings, method=cycle(VOLUME_METHODS, self.settings.method)))

    def _grid(self, step: int) -> None:
        k = VOLUME_GRIDS.index(self.settings.grid) + step
        if 0 <= k < len(VOLUME_GRIDS):
            self._configure(replace(self.settings, grid=VOLUME_GRIDS[k]))

    def _do_grid_finer(self) -> None:
        self._grid(-1)

    def _do_grid_coarser(self) -> None:
        self._grid(+1)

    def _do_centre(self) -> None:
        for axis, value in enumerate(self.centre):
            self._move_point(axis, value)

    def _do_reset(self) -> None:
        if not np.array_equal(self.src, self.dst):
            self.set_handles(self.src, self.src)

    def _do_restore(self) -> None:
        self._release()  # a drag under way ends first, as its own edit
        src, dst = self.loaded
        if not (np.array_equal(src, self.src) and np.array_equal(dst, self.dst)):
            self.set_handles(src, dst)  # as loaded already: no edit to undo

    def _do_undo(self) -> None:
        self._release()  # a drag under way ends as one edit, the one undone
        if not self._undo:
            self.message = "nothing to undo"
            return
        self._redo.append((self.src, self.dst))
        self.src, self.dst = self._undo.pop()
        self.revision += 1

    def _do_redo(self) -> None:
        self._release()
        if not self._redo:
            self.message = "nothing to redo"
            return
        self._undo.append((self.src, self.dst))
        self.src, self.dst = self._redo.pop()
        self.revision += 1
