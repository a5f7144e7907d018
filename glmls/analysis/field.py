"""The MLS error field (paper eq. 7) as a function of a deformation."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

__all__ = ["error_field"]


class HasErrorField(Protocol):
    def error_field(
        self, shape: Sequence[int], *, grid: int = 1, tolerance: float | None = None
    ) -> np.ndarray: ...


def error_field(
    m: HasErrorField, shape: Sequence[int], *, grid: int = 1, tolerance: float | None = None
) -> np.ndarray:
    """E_MLS(v) = sum_i |p_i M_v + T_v - q_i|^2 at every pixel of an image of ``shape``:
    :meth:`glmls.MLS.error_field` as a function ((H, W) float64, square pixels, unweighted;
    ``grid`` > 1 evaluates the mesh every ``grid`` pixels and interpolates; ``tolerance``,
    the vertices of the adaptive mesh of that tolerance, interpolated on its leaves)."""
    return m.error_field(shape, grid=grid, tolerance=tolerance)
