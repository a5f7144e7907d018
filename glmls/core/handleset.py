"""The handles of one deformation, of every kind: points p -> q and segments a-b -> c-d.

The registry of handle kinds (:data:`HANDLE_KINDS`) is what the engine, the files, the command
line and the window iterate over; a kind's moments add to every other kind's in one MLS.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DegenerateHandlesError
from .handles import (
    Scaling,
    check_affine_handles,
    check_gpu_distinct,
    check_gpu_spread,
    fit_offset,
    point_bounds,
    validate_handles,
)
from .segments import check_on_segments, validate_segments

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
    """Validated handles of every kind, read-only float64 copies.

    Build with :meth:`validate`, which checks the arrays; the constructor takes them as they
    are. ``len()`` counts the handles of every kind.

    Parameters
    ----------
    src, dst : numpy.ndarray
        Point handles p_i -> q_i, (N, 2) (x, y) rows.
    src_segments, dst_segments : numpy.ndarray
        Segment handles, (S, 2, 2): segment s runs from ``src_segments[s, 0]`` to
        ``src_segments[s, 1]`` and maps onto ``dst_segments[s]``.

    See Also
    --------
    polyline_segments : segments from a polyline's vertices.

    Examples
    --------
    >>> handles = glmls.HandleSet.validate(
    ...     [[0, 0], [10, 0]], [[1, 1], [11, 2]], [[[0, 5], [10, 5]]], [[[0, 6], [10, 7]]]
    ... )
    >>> len(handles), handles.points, handles.segments
    (3, 2, 1)
    >>> handles.src.dtype.name, handles.src.flags.writeable, handles.source_points().shape
    ('float64', False, (4, 2))
    >>> handles.swapped().src.tolist()
    [[1.0, 1.0], [11.0, 2.0]]
    """

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
        """Check the handles of every kind and freeze copies.

        Parameters
        ----------
        src, dst : array_like
            Point handles, (N, 2) each; N may be 0.
        src_segments, dst_segments : array_like, optional
            Segment handles, (S, 2, 2) each; none when omitted.

        Returns
        -------
        HandleSet
            The validated handles.

        Raises
        ------
        ValueError
            Naming the bad value: a wrong shape, different lengths, a value that is not
            finite, a source segment of zero length or shorter than float32 on the GPU
            tells apart at the handles' extent, a source point with two targets (two
            point handles, a point handle on a segment, segments sharing a point).
        TypeError
            For arrays that are not numeric.

        Examples
        --------
        >>> handles = glmls.HandleSet.validate([[0, 0], [4, 0]], [[1, 0], [5, 0]])
        >>> handles.src.tolist(), handles.segments
        ([[0.0, 0.0], [4.0, 0.0]], 0)
        >>> glmls.HandleSet.validate([[0, 0]], [[1, 0], [2, 0]])
        Traceback (most recent call last):
            ...
        ValueError: ...
        """
        p, q = validate_handles(src, dst)
        a, b = validate_segments(src_segments, dst_segments)
        check_on_segments(p, q, a, b)
        return cls(_frozen(p), _frozen(q), _frozen(a), _frozen(b))

    @property
    def points(self) -> int:
        """The number of point handles, N.

        Examples
        --------
        >>> glmls.HandleSet.validate([[0, 0], [4, 0]], [[1, 0], [5, 0]]).points
        2
        """
        return len(self.src)

    @property
    def segments(self) -> int:
        """The number of segment handles, S.

        Examples
        --------
        >>> glmls.HandleSet.validate([], [], [[[0, 0], [8, 0]]], [[[0, 1], [8, 1]]]).segments
        1
        """
        return len(self.src_segments)

    def __len__(self) -> int:
        """Handles of every kind."""
        return self.points + self.segments

    def source_points(self) -> np.ndarray:
        """Every source point and segment end, (N + 2 S, 2).

        Returns
        -------
        numpy.ndarray
            The point handles' rows, then each segment's two ends.

        Examples
        --------
        >>> segment, moved = [[[0, 0], [8, 0]]], [[[0, 1], [8, 1]]]
        >>> handles = glmls.HandleSet.validate([[5, 5]], [[6, 5]], segment, moved)
        >>> handles.source_points().tolist()
        [[5.0, 5.0], [0.0, 0.0], [8.0, 0.0]]
        """
        return np.concatenate([self.src, self.src_segments.reshape(-1, 2)])

    def target_points(self) -> np.ndarray:
        """Every target point and segment end, (N + 2 S, 2).

        Returns
        -------
        numpy.ndarray
            The point handles' rows, then each segment's two ends.

        Examples
        --------
        >>> segment, moved = [[[0, 0], [8, 0]]], [[[0, 1], [8, 1]]]
        >>> handles = glmls.HandleSet.validate([[5, 5]], [[6, 5]], segment, moved)
        >>> handles.target_points().tolist()
        [[6.0, 5.0], [0.0, 1.0], [8.0, 1.0]]
        """
        return np.concatenate([self.dst, self.dst_segments.reshape(-1, 2)])

    def gpu_scaling(self, shape: tuple[int, int] | None) -> Scaling:
        """The GPU's scaling of these handles with an image of ``shape``.

        Coordinates go to the GPU as float32 ``(x - center) / scale`` about the box of the
        handles and the image (``Scaling``); two source points
        that float32 merges there must not have different targets.

        Parameters
        ----------
        shape : tuple of int or None
            (H, W) of the image the MLS deforms, or None for the handles' box alone.

        Returns
        -------
        Scaling
            The centre and scale.

        Raises
        ------
        ValueError
            For two source points float32 cannot tell apart at that scale, with different
            targets (``check_gpu_distinct``), or source handles that
            spread over less than 1e-12 of the scale
            (``check_gpu_spread``).

        Examples
        --------
        >>> handles = glmls.HandleSet.validate([[0.0, 0.0], [100.0, 50.0]], [[1, 0], [99, 52]])
        >>> handles.gpu_scaling((60, 120)).center
        (59.5, 29.5)
        """
        sources = self.source_points()
        scaling = Scaling.fit(sources, self.target_points(), shape)
        if len(sources):
            lo, hi = point_bounds(sources)
            check_gpu_spread(float((hi - lo).max()), scaling.scale)
        dst = self.dst
        check_gpu_distinct(
            self.src, dst, scaling.to_gpu(self.src), lambda: scaling.to_gpu(dst), scaling.scale
        )
        return scaling

    def near_targets(
        self, shape: tuple[int, int] | None, *, bounded: bool = False
    ) -> tuple[HandleSet, np.ndarray]:
        """These handles with their targets moved back near the sources, and the translation.

        The targets (segment ends too) less a whole-pixel translation t ((2,) float64): the
        handles the GPU holds, whose f - t float32 keeps to the precision of the sources' box
        where the targets lie far from them (``fit_offset``). MLS
        moves with its targets wherever every weight is positive, so f = (f - t) + t; a
        weight of bounded reach (``bounded``), whose f is the identity beyond the handles,
        gets t = 0.

        Parameters
        ----------
        shape : tuple of int or None
            (H, W) of the image, whose box the GPU's scale takes in as well.
        bounded : bool, default False
            The weight reaches only so far (``support`` ``"radius"``).

        Returns
        -------
        (HandleSet, numpy.ndarray)
            The handles (these where t = 0) and t.

        Examples
        --------
        >>> handles = glmls.HandleSet.validate([[0, 0], [8, 0]], [[1e5, 0], [1e5 + 8, 1]])
        >>> near, t = handles.near_targets(None)
        >>> t.tolist(), near.dst.tolist()
        ([100000.0, 0.0], [[0.0, 0.0], [8.0, 1.0]])
        >>> handles.near_targets(None, bounded=True)[1].tolist()
        [0.0, 0.0]
        """
        offset = np.zeros(2)
        if not bounded:
            offset = fit_offset(self.source_points(), self.target_points(), shape)
        if not offset.any():
            return self, offset
        moved = (_frozen(self.dst - offset), _frozen(self.dst_segments - offset))
        return HandleSet(self.src, moved[0], self.src_segments, moved[1]), offset

    def swapped(self) -> HandleSet:
        """Sources and targets exchanged (the map the other way).

        Returns
        -------
        HandleSet
            ``src`` and ``dst`` (and the segments) trade places.

        Examples
        --------
        >>> handles = glmls.HandleSet.validate([[0, 0]], [[1, 2]]).swapped()
        >>> handles.src.tolist(), handles.dst.tolist()
        ([[1.0, 2.0]], [[0.0, 0.0]])
        """
        return HandleSet(self.dst, self.src, self.dst_segments, self.src_segments)

    def check_affine(self) -> None:
        """Check that the source handles span the plane, as affine MLS needs.

        That is 3 points not on one line, or a segment and a point off its line, or two
        segments not on one line (0 or 1 point alone is fine).

        Raises
        ------
        DegenerateHandlesError
            When every source handle lies on one line.

        Examples
        --------
        >>> triangle, line = [[0, 0], [4, 0], [0, 4]], [[0, 0], [4, 0], [8, 0]]
        >>> glmls.HandleSet.validate(triangle, triangle).check_affine()  # spans the plane
        >>> glmls.HandleSet.validate(line, line).check_affine()
        Traceback (most recent call last):
            ...
        glmls.errors.DegenerateHandlesError: affine MLS needs ...
        """
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
