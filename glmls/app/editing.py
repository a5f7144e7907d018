"""Editing the handles with the mouse, free of any window: points p -> q, line segments
a-b -> c-d, reference points; picking, drags, deletion, undo and redo.

Positions are image pixels, (x, y) = (column, row), pixel centres at integers. What is dragged
stays on the image (what leaves it would be cut off anyway). A source segment never becomes
shorter than :data:`MIN_SEGMENT` (MLS refuses one of zero length), and a drawing drag shorter
than half the pick radius draws nothing.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.handles import as_points
from ..core.segments import as_segments

__all__ = [
    "MIN_SEGMENT",
    "UNDO_DEPTH",
    "Editor",
    "Handles",
    "pick",
    "segment_distance",
]

UNDO_DEPTH = 100
#: The shortest source segment (image pixels) an edit leaves.
MIN_SEGMENT = 1.0


def pick(points: np.ndarray, x: float, y: float, radius: float) -> int | None:
    """Index of the point nearest to (x, y) if it lies within ``radius``, else ``None``
    (ties: the later point, which is drawn on top)."""
    if len(points) == 0:
        return None
    distance = np.hypot(points[:, 0] - x, points[:, 1] - y)
    best = len(distance) - 1 - int(np.argmin(distance[::-1]))
    return best if distance[best] <= radius else None


def segment_distance(segments: np.ndarray, x: float, y: float) -> np.ndarray:
    """Distance from (x, y) to each segment (S, 2, 2), ends included (a segment of zero
    length is its point)."""
    a, d = segments[:, 0], segments[:, 1] - segments[:, 0]
    length2 = (d**2).sum(axis=1)
    w = np.array([x, y]) - a
    t = np.clip((w * d).sum(axis=1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    return np.hypot(*(w - t[:, None] * d).T)


def _pick_part(
    points: np.ndarray, segments: np.ndarray, x: float, y: float, radius: float
) -> tuple[str, int, int] | None:
    """What of one side (sources or targets) is under (x, y): ``("point", i, 0)``,
    ``("end", s, 0 or 1)`` or ``("segment", s, 0)``. Points and segment ends come first (the
    nearest), then the nearest segment's body."""
    ends = segments.reshape(-1, 2)
    candidates = np.concatenate([points, ends])
    index = pick(candidates, x, y, radius)
    if index is not None:
        if index < len(points):
            return ("point", index, 0)
        index -= len(points)
        return ("end", index // 2, index % 2)
    if len(segments):
        distance = segment_distance(segments, x, y)
        best = len(distance) - 1 - int(np.argmin(distance[::-1]))
        if distance[best] <= radius:
            return ("segment", best, 0)
    return None


@dataclass(frozen=True, eq=False)
class Handles:
    """One state of the handles: points ``src``/``dst`` (N, 2), segments
    ``src_segments``/``dst_segments`` (S, 2, 2) and the ``reference`` points (K, 2)."""

    src: np.ndarray
    dst: np.ndarray
    src_segments: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    dst_segments: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    reference: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @classmethod
    def of(
        cls,
        src: object,
        dst: object,
        src_segments: object = None,
        dst_segments: object = None,
        reference: object = None,
    ) -> Handles:
        """Checked float64 copies (``ValueError`` naming a bad value; ``None`` segments or
        reference: none)."""
        p, q = as_points(src, "src").copy(), as_points(dst, "dst").copy()
        if p.shape != q.shape:
            raise ValueError(f"src and dst must have the same shape, got {p.shape}, {q.shape}")
        empty = np.zeros((0, 2, 2))
        a = empty if src_segments is None else as_segments(src_segments, "src_segments").copy()
        b = empty if dst_segments is None else as_segments(dst_segments, "dst_segments").copy()
        if a.shape != b.shape:
            raise ValueError(
                f"src_segments and dst_segments must have the same shape, got {a.shape}, {b.shape}"
            )
        short = np.hypot(*(a[:, 1] - a[:, 0]).T) == 0 if len(a) else np.zeros(0, bool)
        if short.any():
            raise ValueError(f"src_segments[{int(np.argmax(short))}] has zero length")
        r = np.zeros((0, 2)) if reference is None else as_points(reference, "reference").copy()
        return cls(p, q, a, b, r)

    def copy(self) -> Handles:
        return Handles(*(array.copy() for array in self.arrays()))

    def arrays(self) -> tuple[np.ndarray, ...]:
        return self.src, self.dst, self.src_segments, self.dst_segments, self.reference

    def same_handles(self, other: Handles) -> bool:
        """Whether the points and segments (not the reference points) are equal."""
        pairs = zip(self.arrays()[:4], other.arrays()[:4], strict=True)
        return all(np.array_equal(a, b) for a, b in pairs)


@dataclass
class _Drag:
    kind: str  # "point", "end", "segment", "reference" or "draw"
    side: str  # "target" or "source"
    index: int
    part: int
    start: np.ndarray  # where the press was
    before: Handles
    changed: bool = False


class Editor:
    """The handles being edited (:attr:`state`, replaced on every change), the drag under
    way, and the undo and redo stacks. ``revision`` grows when the points or segments change,
    ``reference_revision`` when the reference points do."""

    def __init__(self, handles: Handles, shape: tuple[int, int]) -> None:
        self.state = handles.copy()
        self.loaded = handles.copy()
        self.shape = (int(shape[0]), int(shape[1]))
        self.revision = 0
        self.reference_revision = 0
        #: The segment being drawn (2, 2), until the button is released.
        self.drawing: np.ndarray | None = None
        self._undo: list[Handles] = []
        self._redo: list[Handles] = []
        self._drag: _Drag | None = None

    # -- state --------------------------------------------------------------------------------

    @property
    def dragging(self) -> bool:
        return self._drag is not None

    @property
    def undo_depth(self) -> int:
        return len(self._undo)

    @property
    def redo_depth(self) -> int:
        return len(self._redo)

    def _set(self, handles: Handles) -> None:
        """Make ``handles`` the state, counting what changed."""
        if not handles.same_handles(self.state):
            self.revision += 1
        if not np.array_equal(handles.reference, self.state.reference):
            self.reference_revision += 1
        self.state = handles

    def _changed(self, **arrays: np.ndarray) -> Handles:
        names = ("src", "dst", "src_segments", "dst_segments", "reference")
        return Handles(**(dict(zip(names, self.state.arrays(), strict=True)) | arrays))

    def _commit(self, before: Handles) -> None:
        """Record ``before`` as one undo step (a new edit forgets what was undone)."""
        self._undo.append(before)
        del self._undo[:-UNDO_DEPTH]
        self._redo.clear()

    def replace(self, handles: Handles) -> None:
        """Every handle at once (undoable), e.g. loaded from a file."""
        self.release()
        before = self.state
        self._set(handles.copy())
        self._commit(before)

    def undo(self) -> bool:
        """Back one edit; False if there is none."""
        self.release()
        if not self._undo:
            return False
        self._redo.append(self.state)
        self._set(self._undo.pop())
        return True

    def redo(self) -> bool:
        """Forward one undone edit; False if there is none."""
        self.release()
        if not self._redo:
            return False
        self._undo.append(self.state)
        self._set(self._redo.pop())
        return True

    def clamp(self, x: float, y: float) -> np.ndarray:
        """Keep dragged points on the image (what leaves it would be cut off anyway)."""
        height, width = self.shape
        return np.array([min(max(x, -0.5), width - 0.5), min(max(y, -0.5), height - 0.5)])

    def near_image(self, x: float, y: float, margin: float) -> bool:
        """Whether (x, y) lies on the image or within ``margin`` of its border: a click
        further off (on the readout beside it, a letterbox margin) adds nothing."""
        height, width = self.shape
        low = -0.5 - margin
        return low <= x <= width - 0.5 + margin and low <= y <= height - 0.5 + margin

    # -- the mouse ----------------------------------------------------------------------------

    def press(self, x: float, y: float, *, source: bool, segments: bool, radius: float) -> None:
        """The left button at (x, y): grab the target (``source``: the source) point, segment
        end or segment there; on empty space add a point handle (p = q, pulled while the
        button is down) or, with ``segments``, start drawing a segment handle; off the image
        (further than ``radius`` from it) nothing."""
        self.release()  # a press while dragging (a lost release) ends the old drag
        s, start = self.state, np.array([x, y], float)
        points, lines = (s.src, s.src_segments) if source else (s.dst, s.dst_segments)
        hit = _pick_part(points, lines, x, y, radius)
        side = "source" if source else "target"
        if hit is not None:
            self._drag = _Drag(hit[0], side, hit[1], hit[2], start, s)
        elif not self.near_image(x, y, radius):
            return
        elif segments:
            end = self.clamp(x, y)
            self.drawing = np.stack([end, end])
            self._drag = _Drag("draw", "target", -1, 1, end, s)
        else:
            point = self.clamp(x, y)[None]
            self._set(self._changed(src=np.concatenate([s.src, point]),
                                    dst=np.concatenate([s.dst, point])))  # fmt: skip
            self._drag = _Drag("point", "target", len(s.src), 0, start, s, changed=True)

    def press_reference(self, x: float, y: float, *, radius: float) -> None:
        """The left button in reference mode: grab a reference point, or add one (on the
        image, or within ``radius`` of it)."""
        self.release()
        s = self.state
        index = pick(s.reference, x, y, radius)
        if index is None and not self.near_image(x, y, radius):
            return
        if index is None:
            added = np.concatenate([s.reference, [self.clamp(x, y)]])
            self._set(self._changed(reference=added))
            self._drag = _Drag("reference", "target", len(added) - 1, 0, np.zeros(2), s, True)
        else:
            self._drag = _Drag("reference", "target", index, 0, np.zeros(2), s)

    def delete(self, x: float, y: float, *, radius: float, reference: bool = False) -> bool:
        """Delete what is under (x, y): a reference point (``reference``), else the handle
        whose target (else source) point or segment is there. False if nothing is."""
        self.release()
        s = self.state
        if reference:
            index = pick(s.reference, x, y, radius)
            if index is None:
                return False
            self._set(self._changed(reference=np.delete(s.reference, index, axis=0)))
            self._commit(s)
            return True
        hit = _pick_part(s.dst, s.dst_segments, x, y, radius)
        if hit is None:
            hit = _pick_part(s.src, s.src_segments, x, y, radius)
        if hit is None:
            return False
        kind, index, _ = hit
        if kind == "point":
            changed = self._changed(src=np.delete(s.src, index, 0), dst=np.delete(s.dst, index, 0))
        else:
            changed = self._changed(
                src_segments=np.delete(s.src_segments, index, 0),
                dst_segments=np.delete(s.dst_segments, index, 0),
            )
        self._set(changed)
        self._commit(s)
        return True

    def move(self, x: float, y: float, *, radius: float) -> None:
        """The cursor at (x, y) while a button is down: move what was grabbed."""
        drag = self._drag
        if drag is None:
            return
        point = self.clamp(x, y)
        if drag.kind == "draw":
            self.drawing = np.stack([drag.start, point])
            return
        s = self.state
        if drag.kind == "reference":
            if not np.array_equal(s.reference[drag.index], point):
                reference = s.reference.copy()
                reference[drag.index] = point
                self._set(self._changed(reference=reference))
                drag.changed = True
            return
        source = drag.side == "source"
        if drag.kind == "point":
            array = (s.src if source else s.dst).copy()
            array[drag.index] = point
        else:
            array = (s.src_segments if source else s.dst_segments).copy()
            if drag.kind == "end":
                array[drag.index, drag.part] = point
            else:
                before = drag.before.src_segments if source else drag.before.dst_segments
                array[drag.index] = self._translated(before[drag.index], point - drag.start)
            length = np.hypot(*(array[drag.index, 1] - array[drag.index, 0]))
            if source and length < MIN_SEGMENT:
                return  # MLS refuses a source segment of zero length: keep the last one
        name = "src" if source else "dst"
        if drag.kind != "point":
            name += "_segments"
        changed = self._changed(**{name: array})
        if not changed.same_handles(s):
            self._set(changed)
            drag.changed = True

    def _translated(self, segment: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """``segment`` moved by ``delta``, as far as both ends stay on the image."""
        height, width = self.shape
        low = np.array([-0.5, -0.5]) - segment.min(axis=0)
        high = np.array([width - 0.5, height - 0.5]) - segment.max(axis=0)
        return segment + np.clip(delta, np.minimum(low, 0), np.maximum(high, 0))

    def release(self, *, radius: float = 0.0) -> None:
        """The button released: the drag ends as one undo step (if it changed anything); a
        drawn segment of at least ``radius`` / 2 (and :data:`MIN_SEGMENT`) is added."""
        drag, self._drag = self._drag, None
        drawing, self.drawing = self.drawing, None
        if drag is None:
            return
        if drag.kind == "draw" and drawing is not None:
            length = np.hypot(*(drawing[1] - drawing[0]))
            if length >= max(MIN_SEGMENT, radius / 2):
                s = self.state
                self._set(self._changed(
                    src_segments=np.concatenate([s.src_segments, drawing[None]]),
                    dst_segments=np.concatenate([s.dst_segments, drawing[None]]),
                ))  # fmt: skip
                self._commit(drag.before)
            return
        if drag.changed:
            self._commit(drag.before)
