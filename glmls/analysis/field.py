"""The MLS error field (paper eq. 7) as a function of a deformation."""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator, Sequence
from typing import Protocol

import numpy as np

from ..core.config import MLSConfig
from ..core.handleset import HandleSet
from ..core.mesh import as_shape
from ..gl.context import forked_from_gl
from ..mls import MLS

__all__ = ["check_deformation", "error_field", "image_deformation", "target_offset"]


class HasErrorField(Protocol):
    def error_field(
        self, shape: Sequence[int], *, grid: int = 1, tolerance: float | None = None
    ) -> np.ndarray: ...


def check_deformation(m: object, method: str) -> None:
    """``TypeError`` naming ``m`` unless it has the method ``method`` (a :class:`glmls.MLS`
    has them all), before anything of it is called."""
    if not callable(getattr(m, method, None)):
        raise TypeError(
            f"m must be a glmls.MLS (anything with the method {method}), got {type(m).__name__}"
        )


def error_field(
    m: HasErrorField, shape: Sequence[int], *, grid: int = 1, tolerance: float | None = None
) -> np.ndarray:
    """The MLS error E_MLS (eq. 7) at every pixel of an image, on the GPU.

    E_MLS(v) = sum_i |p_i M_v + T_v - q_i|^2, unweighted: how far the affine fit at v misses
    the handles (segment handles add their integral per pixel of length). This is
    :meth:`glmls.MLS.error_field` as a function.

    Parameters
    ----------
    m : MLS
        The deformation (anything with an ``error_field`` method of this signature).
    shape : sequence of int
        (H, W), or (H, W, C) of which (H, W) is used.
    grid : int, optional
        Evaluate the mesh every ``grid`` pixels and interpolate bilinearly (1: every pixel).
    tolerance : float, optional
        Evaluate at the vertices of the adaptive mesh of that tolerance (pixels) and
        interpolate on its leaves, instead of a regular grid (``grid`` must then stay 1).

    Returns
    -------
    numpy.ndarray
        (H, W) float64, in square pixels.

    Raises
    ------
    ValueError
        For a shape that is not (H, W) with H, W >= 1, a grid that is not an integer from 1
        on, a tolerance that is not a finite number > 0, or both a grid other than 1 and a
        tolerance.
    TypeError
        For an ``m`` without an ``error_field`` method, a shape that is not integers, or a
        tolerance that is not a number.

    See Also
    --------
    glmls.reference.mls_error : the same error in float64 at given points.
    error_stats : its statistics (eqs. 8, 9).

    Examples
    --------
    >>> src = np.array([[2.0, 2.0], [13.0, 2.0], [2.0, 13.0], [13.0, 13.0]])
    >>> dst = src.copy()
    >>> dst[3] = [10.0, 10.0]  # one corner pulled in: no rigid map fits every handle
    >>> with glmls.MLS(src, dst) as m:
    ...     field = glmls.analysis.error_field(m, (16, 16))
    ...     coarse = glmls.analysis.error_field(m, (16, 16), grid=4)
    >>> field.shape, field.dtype.name, round(float(field.max()), 1)
    ((16, 16), 'float64', 54.0)
    >>> coarse.shape
    (16, 16)
    """
    check_deformation(m, "error_field")
    return m.error_field(shape, grid=grid, tolerance=tolerance)


@contextlib.contextmanager
def image_deformation(m: object, shape: Sequence[int]) -> Iterator[object]:
    """``m`` as its warp of an image of ``shape`` (H, W) evaluates f at points: a radius
    weight given no radius takes that image's diagonal (as ``m.warp(image)``,
    ``m.error_field(shape)`` and ``m.mesh(shape)`` do), whatever ``shape`` the
    :class:`glmls.MLS` was made with (or none). A new MLS of that radius for the duration of
    the block, released after it; ``m`` itself where that changes nothing (another weight,
    an explicit radius, the image ``m`` was made for) or where ``m`` is not a 2D
    :class:`glmls.MLS`."""
    config = getattr(m, "config", None)
    size = as_shape(shape)
    if (
        not isinstance(m, MLS)
        or not isinstance(config, MLSConfig)
        or not config.uses_radius
        or config.radius is not None
        or m.dimension != 2
        or m.shape == size
    ):
        yield m
        return
    fixed = dataclasses.replace(config, radius=config.resolve_radius(size))
    ctx = None if forked_from_gl() else m.ctx
    segments = {"src_segments": m.src_segments, "dst_segments": m.dst_segments}
    with MLS.from_config(m.src, m.dst, fixed, shape=size, ctx=ctx, **segments) as warped:
        yield warped


def frame_centre(m: object) -> np.ndarray:
    """(2,) float64: the centre of the GPU's frame of a 2D :class:`glmls.MLS` (its
    :attr:`~glmls.MLS.scaling`'s), about which its float32 holds f's points: their rounding,
    which the analyses' flatness tolerances count, grows with the distance from it, not from
    the origin. Zeros for other functions (float64 about the origin). In a process forked
    from one that used GL, whose kernel lives in a helper process, the same rule on the same
    handles (:meth:`~glmls.core.handleset.HandleSet.gpu_scaling` of the near targets)."""
    if not isinstance(m, MLS) or m.dimension != 2:
        return np.zeros(2)
    if not forked_from_gl():
        return np.array(m.scaling.center, dtype=np.float64)
    handles = HandleSet.validate(m.src, m.dst, m.src_segments, m.dst_segments)
    bounded = m.config.weight_entry.support == "radius"
    near = handles.near_targets(m.shape, bounded=bounded)[0]
    return np.array(near.gpu_scaling(m.shape).center, dtype=np.float64)


def target_offset(m: object) -> np.ndarray:
    """(2,) float64: the whole-pixel translation of the targets that the GPU kernel of a 2D
    :class:`glmls.MLS` computes f without, adding it back in float64
    (:attr:`~glmls.engine.kernel.MLSKernel.offset`, for targets far from their sources): f -
    offset has the float32 rounding of a map near its sources, which the analyses' flatness
    tolerances count. Zeros for other functions and 3D handles. In a process forked from one
    that used GL, whose kernel lives in a helper process, the same rule on the same handles
    (:meth:`~glmls.core.handleset.HandleSet.near_targets`)."""
    if not isinstance(m, MLS) or m.dimension != 2:
        return np.zeros(2)
    if not forked_from_gl():
        return np.array(m.kernel.offset, dtype=np.float64)
    handles = HandleSet.validate(m.src, m.dst, m.src_segments, m.dst_segments)
    bounded = m.config.weight_entry.support == "radius"
    return np.array(handles.near_targets(m.shape, bounded=bounded)[1], dtype=np.float64)
