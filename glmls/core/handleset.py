"""The handles of one deformation, of every kind: points p -> q and segments a-b -> c-d.

The registry of handle kinds (:data:`HANDLE_KINDS`) is what the engine, the files, the command
line and the window iterate over; a kind's moments add to every other kind's in one MLS.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DegenerateHandlesError
from .handles import check_affine_handles, validate_handles
from .segments import validate_segments

__all__ = ["HANDLE_KINDS", "HandleSet"]

#: The handle kinds: points (``src``/``dst``, (N, 2)) and segments (``src_segments``/
#: ``dst_segments``, (S, 2, 2)). Polylines are segments (:func:`glmls.polyline_segments`).
HANDLE_KINDS = ("points", "segments")


def _frozen(array: np.ndarray) -> np.ndarray:
    array = array.copy()  # never freeze the caller's arrays
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class HandleSet:
    """Validated handles, read-only float64: ``src``/``dst`` (N, 2) points and
    ``src_segments``/``dst_segments`` (S, 2, 2) segments (segment s runs from
    ``src_segments[s, 0]`` to ``src_segments[s, 1]``). Build with :meth:`validate`."""

    src: np.ndarray
    dst: np.ndarray
    src_segments: np.ndarray
    dst_segments: np.ndarray

    @classmethod
    def validate(
        cls,
        src: object,
        dst: object,
        src_segments: object = None,
        dst_segments: object = None,
    ) -> HandleSet:
        """Check every kind (``ValueError``/``TypeError`` naming the bad value) and freeze
        copies."""
        p, q = validate_handles(src, dst)
        a, b = validate_segments(src_segments, dst_segments)
        return cls(_frozen(p), _frozen(q), _frozen(a), _frozen(b))

    @property
    def points(self) -> int:
        return len(self.src)

    @property
    def segments(self) -> int:
        return len(self.src_segments)

    def __len__(self) -> int:
        """Handles of every kind."""
        return self.points + self.segments

    def source_points(self) -> np.ndarray:
        """Every source point and segment end, (N + 2 S, 2)."""
        return np.concatenate([self.src, self.src_segments.reshape(-1, 2)])

    def target_points(self) -> np.ndarray:
        """Every target point and segment end, (N + 2 S, 2)."""
        return np.concatenate([self.dst, self.dst_segments.reshape(-1, 2)])

    def swapped(self) -> HandleSet:
        """Sources and targets exchanged (the map the other way)."""
        return HandleSet(self.dst, self.src, self.dst_segments, self.src_segments)

    def check_affine(self) -> None:
        """Affine MLS needs its source handles to span the plane: 3 points not on one line,
        or a segment and a point off its line, or two segments not on one line.
        :class:`glmls.DegenerateHandlesError` otherwise (0 or 1 point alone is fine)."""
        if self.segments == 0:
            check_affine_handles(self.src)
            return
        points = np.unique(self.source_points(), axis=0)
        centred = points - points.mean(axis=0)
        singular = np.linalg.svd(centred, compute_uv=False)
        if singular[1] <= 1e-9 * singular[0]:
            raise DegenerateHandlesError(
                "affine MLS needs source handles that span the plane; every source point and "
                "segment lies on one line. Use transform='similarity' or 'rigid', or add a "
                "handle off that line."
            )
