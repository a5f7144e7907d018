"""The MLS error field (paper eq. 7) over a volume, and the float64 deformation it and the
other 3D analyses can run on without a GPU.

Every 3D analysis takes ``m``: a :class:`glmls.MLS` of (N, 3) handles, or a
:class:`ReferenceDeformation` (the float64 numpy reference on the CPU), or anything with the
same members: ``m(points)`` (K, 3) -> (K, 3), ``m.matrices(points)`` -> M (K, 3, 3), T (K, 3),
and the handles ``m.src``, ``m.dst`` (N, 3). An ``m.spacing`` (that of
``glmls.MLS(..., spacing=...)``) is the analyses' spacing when they are given none.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from .. import reference
from ..core.config import MLSConfig, check_result_bytes, config_or_options
from ..core.handles import point_rows
from ..core.handles3 import (
    as_volume_spacing,
    checked_extent,
    fit_offset3,
    fit_scaling3,
    volume_extent,
)
from ..engine.kernel3 import MLSKernel3
from ..engine.passes3 import evaluate_points3
from ..gl.context import forked_from_gl
from ..mls import MLS
from .volume_lattice import (
    CHUNK,
    as_points3,
    as_volume_shape,
    axis_centres,
    check_grid3,
    check_handles3,
    check_three_d,
    deformation_spacing,
    interpolate_axis,
    lattice_points,
    spacing_scale,
)

__all__ = [
    "Deformation3D",
    "KernelDeformation",
    "ReferenceDeformation",
    "precision",
    "target_offset",
    "volume_deformation",
    "volume_error_field",
]


class Deformation3D(Protocol):
    """What the 3D analyses need of a deformation."""

    @property
    def src(self) -> np.ndarray: ...

    @property
    def dst(self) -> np.ndarray: ...

    def __call__(self, points: object) -> np.ndarray: ...

    def matrices(self, points: object) -> tuple[np.ndarray, np.ndarray]: ...


class ReferenceDeformation:
    """An MLS deformation of (N, 3) handles computed by :mod:`glmls.reference` (float64, CPU).

    The same members as :class:`glmls.MLS` that the 3D analyses use: ``m(points)``,
    ``m.matrices(points)``, ``src``, ``dst``, ``config``, ``shape``, ``spacing``, and ``with``
    blocks. Slow
    (the reference is O(K N) in memory and time, evaluated in blocks of points); it is the
    oracle the GPU is tested against, and runs where there is no GPU.

    Parameters
    ----------
    src, dst : array_like
        The handles p_i -> q_i, (N, 3) (x, y, z) rows each.
    config : glmls.MLSConfig, optional
        The transform and weight; when None, built from the other keyword arguments
        (:class:`glmls.MLSConfig`'s fields: ``transform="affine"``, ...).
    shape : tuple of int, optional
        (D, H, W) of the volume: its diagonal is the default radius of the radius weights.
    spacing : (float, float, float), optional
        (dz, dy, dx) of the volume's voxels in the handles' units, as :class:`glmls.MLS`'s:
        the default radius is then the diagonal of (D dz, H dy, W dx), and the analyses take
        this spacing when given none.

    Attributes
    ----------
    src, dst : numpy.ndarray
        The handles, (N, 3) float64, read-only.
    config : glmls.MLSConfig
        The configuration.
    shape : tuple of int or None
        The volume's (D, H, W).
    spacing : tuple of float or None
        Its voxels' (dz, dy, dx).

    Raises
    ------
    ValueError
        For handles that are not (N, 3) finite rows of the same count, bad options, or a
        ``spacing`` that is not three finite numbers > 0.
    TypeError
        For handles or a ``spacing`` that are not real numbers.

    Examples
    --------
    >>> src = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
    >>> m = glmls.analysis.ReferenceDeformation(src, np.add(src, 2.0), transform="affine")
    >>> m([[5.0, 5.0, 5.0]]).round(9).tolist()
    [[7.0, 7.0, 7.0]]
    >>> M, T = m.matrices([[5.0, 5.0, 5.0]])
    >>> M.shape, T.round(6).tolist()
    ((1, 3, 3), [[2.0, 2.0, 2.0]])
    """

    def __init__(
        self,
        src: object,
        dst: object,
        config: MLSConfig | None = None,
        *,
        shape: Sequence[int] | None = None,
        spacing: Sequence[float] | None = None,
        **options: object,
    ) -> None:
        p, q = as_points3(src, "src"), as_points3(dst, "dst")
        if p.shape != q.shape or len(p) == 0:
            raise ValueError(
                f"src and dst must be (N, 3) with N >= 1 alike, got {p.shape} and {q.shape}"
            )
        self.config = config_or_options(config, options)
        self.shape = None if shape is None else as_volume_shape(shape)
        self.spacing = None if spacing is None else as_volume_spacing(spacing)
        p.flags.writeable = q.flags.writeable = False
        self.src, self.dst = p, q

    def _blocks(self, points: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        v = as_points3(point_rows(points, 3))
        f, m, t = np.empty((len(v), 3)), np.empty((len(v), 3, 3)), np.empty((len(v), 3))
        step = max(1, CHUNK // (8 * len(self.src)))
        for start in range(0, len(v), step):
            end = start + step
            f[start:end], m[start:end], t[start:end] = reference.mls(
                self.src,
                self.dst,
                v[start:end],
                self.config,
                shape=self.shape,
                spacing=self.spacing,
            )
        return f, m, t

    def __call__(self, points: object) -> np.ndarray:
        """f at ``points``.

        Parameters
        ----------
        points : array_like
            (K, 3) points; one (3,) point gives a (1, 3) row, as :class:`glmls.MLS` does.

        Returns
        -------
        numpy.ndarray
            f(points), (K, 3) float64.

        Examples
        --------
        >>> src = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
        >>> m = glmls.analysis.ReferenceDeformation(src, np.add(src, [1, 2, 3]))
        >>> m([4, 5, 6]).round(9).tolist()
        [[5.0, 7.0, 9.0]]
        """
        return self._blocks(points)[0]

    def matrices(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        """The affine map at each point: ``f(v) = v @ M + T``.

        Parameters
        ----------
        points : array_like
            (K, 3) points, or one (3,) point.

        Returns
        -------
        M : numpy.ndarray
            (K, 3, 3) float64.
        T : numpy.ndarray
            (K, 3) float64.

        Examples
        --------
        >>> src = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
        >>> m = glmls.analysis.ReferenceDeformation(src, np.multiply(src, 2.0), transform="affine")
        >>> M, T = m.matrices([[1, 2, 3]])
        >>> M.round(9).tolist(), T.round(9).tolist()
        ([[[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]], [[0.0, 0.0, 0.0]])
        >>> m.matrices([1, 2, 3])[0].shape  # one point
        (1, 3, 3)
        """
        _, m, t = self._blocks(points)
        return m, t

    def release(self) -> None:
        """Nothing to free (for symmetry with :meth:`glmls.MLS.release`).

        Examples
        --------
        >>> m = glmls.analysis.ReferenceDeformation([[0, 0, 0]], [[1, 0, 0]])
        >>> m.release()
        >>> m([[0, 0, 0]]).tolist()  # still usable: nothing lives on the GPU
        [[1.0, 0.0, 0.0]]
        """

    def __enter__(self) -> ReferenceDeformation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


class KernelDeformation:
    """f of a :class:`glmls.MLS`'s GPU kernel with the default radius of a volume of
    ``extent`` (D dz, H dy, W dx, the handles' units), as its warp evaluates f: the members
    of ``Deformation3D`` (``src``, ``dst``, ``config`` and ``spacing`` are the MLS's)."""

    def __init__(self, m: object, kernel: MLSKernel3, extent: tuple[float, float, float]):
        self.src, self.dst = as_points3(m.src, "m.src"), as_points3(m.dst, "m.dst")  # type: ignore[attr-defined]
        self.config = m.config  # type: ignore[attr-defined]
        self.spacing = getattr(m, "spacing", None)
        self._kernel, self._extent = kernel, extent

    def __call__(self, points: object) -> np.ndarray:
        f, _ = evaluate_points3(self._kernel, as_points3(points), shape=self._extent)  # type: ignore[arg-type]
        return f

    def matrices(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        v = as_points3(points)
        f, m = evaluate_points3(self._kernel, v, output="matrix", shape=self._extent)  # type: ignore[arg-type]
        return m, f - np.einsum("ki,kij->kj", v, m)  # type: ignore[arg-type]


def precision(m: object) -> float:
    """The rounding of f as ``m`` computes it: float32's epsilon for the GPU kernel of a
    :class:`glmls.MLS` (its displacements are float32), float64's for the reference and
    other functions."""
    gpu = isinstance(m, KernelDeformation) or (isinstance(m, MLS) and m.dimension == 3)
    return float(np.finfo(np.float32 if gpu else np.float64).eps)


def frame_centre(m: object) -> np.ndarray:
    """(3,) float64: the centre of the GPU's frame of a 3D :class:`glmls.MLS` (or the
    kernel of a volume's warp), about which its float32 holds f's points: their rounding,
    which the analyses' flatness tolerances count, grows with the distance from it, not from
    the origin. Zeros for the float64 reference and other functions. In a process forked
    from one that used GL, whose kernel lives in a helper process, the same rule on the same
    handles (:func:`~glmls.core.handles3.fit_scaling3` of the near targets)."""
    if isinstance(m, KernelDeformation):
        return np.array(m._kernel.scaling.center, dtype=np.float64)
    if not isinstance(m, MLS) or m.dimension != 3:
        return np.zeros(3)
    if not forked_from_gl():
        return np.array(m.scaling.center, dtype=np.float64)
    near = m.dst - target_offset(m)
    return np.array(fit_scaling3(m.src, near, m.shape, m.spacing).center, dtype=np.float64)


def target_offset(m: object) -> np.ndarray:
    """(3,) float64: the translation of the targets that the GPU kernel of a
    :class:`glmls.MLS` computes f without, adding it back in float64
    (:attr:`~glmls.engine.kernel3.MLSKernel3.offset`, for targets far from their sources):
    f - offset has the float32 rounding of a map near its sources, which the analyses'
    flatness tolerances count. Zeros for the float64 reference and other functions. In a
    process forked from one that used GL, whose kernel lives in a helper process, the same
    rule on the same handles (:func:`~glmls.core.handles3.fit_offset3`)."""
    if isinstance(m, KernelDeformation):
        return np.array(m._kernel.offset, dtype=np.float64)
    if not isinstance(m, MLS) or m.dimension != 3:
        return np.zeros(3)
    if not forked_from_gl():
        return np.array(m.kernel.offset, dtype=np.float64)
    bounded = m.config.weight_entry.support == "radius"
    return fit_offset3(m.src, m.dst, m.shape, m.spacing, bounded=bounded)


def volume_deformation(m: Deformation3D, shape: Sequence[int], spacing: object) -> Deformation3D:
    """``m`` evaluated as the warp of a volume of ``shape`` (D, H, W) and ``spacing`` ((dz,
    dy, dx), None: voxels) evaluates it: a radius weight given no radius takes that volume's
    diagonal in the handles' units, whatever ``shape`` and ``spacing`` ``m`` was made with
    (an MLS made without ``spacing`` leaves each warp, and so each analysis, its own). ``m``
    itself where that changes nothing (another weight, an explicit radius, the volume ``m``
    was made for) or where ``m`` is neither a :class:`ReferenceDeformation` nor a
    :class:`glmls.MLS`. ``ValueError`` for a volume whose extent in the handles' units
    passes the coordinate range, as its warp refuses it."""
    check_three_d(m)
    dims = as_volume_shape(shape)
    steps = None if spacing is None else as_volume_spacing(spacing)
    extent = checked_extent(dims, steps, name="volume")  # as the volume's warp refuses it
    config = getattr(m, "config", None)
    if not isinstance(config, MLSConfig) or not config.uses_radius or config.radius is not None:
        return m
    own = getattr(m, "shape", None)
    if own is not None and volume_extent(own, getattr(m, "spacing", None)) == extent:
        return m
    if isinstance(m, ReferenceDeformation):
        return ReferenceDeformation(m.src, m.dst, config, shape=dims, spacing=steps)
    if not isinstance(m, MLS):
        return m
    if forked_from_gl():  # the kernel lives in the helper process: an MLS for the volume
        return MLS.from_config(m.src, m.dst, config, shape=dims, spacing=steps)
    return KernelDeformation(m, m.kernel, extent)


#: Up to this many handles E_MLS is summed handle by handle (as fast as the moments).
FEW_HANDLES = 6
#: Where the moments' sum of E_MLS is below this share of the size of its terms, the
#: cancellation between them may show, and E_MLS is summed handle by handle instead.
CANCELLATION = 1e-8


def fit_residuals(src: np.ndarray, dst: np.ndarray, m: np.ndarray, t: np.ndarray) -> np.ndarray:
    """E_MLS = sum_i |p_i M + T - q_i|^2 for each (M, T) of (K, 3, 3), (K, 3): (K,); 0 each
    without handles.

    From the handles' moments about their centroid c (a = p - c, b = q - c,
    T' = T + c M - c): E = tr(M^T A M) + 2 (S_a M) . T' - 2 tr(M^T B) + N |T'|^2
    - 2 T' . S_b + S_bb, O(K) instead of O(K N) (a 256^3 volume of 64 handles in seconds
    rather than minutes). The rows where these terms cancel to below :data:`CANCELLATION`
    of their size (a fit that meets the handles, E near 0) are summed handle by handle,
    so such an E keeps full precision (0 where the fit is exact)."""
    src, dst = np.asarray(src, np.float64), np.asarray(dst, np.float64)
    m, t = np.asarray(m, np.float64), np.asarray(t, np.float64)
    count = len(src)
    if count == 0:
        return np.zeros(len(m))
    if count <= FEW_HANDLES:
        return _summed(src, dst, m, t)
    centre = np.concatenate([src, dst]).mean(axis=0)
    a, b = src - centre, dst - centre
    moments_aa, moments_ab = a.T @ a, a.T @ b
    sum_a, sum_b, sum_bb = a.sum(axis=0), b.sum(axis=0), float((b * b).sum())
    out = np.empty(len(m))
    step = max(1, CHUNK // 16)
    for start in range(0, len(m), step):
        mk = m[start : start + step]
        tk = t[start : start + step] + centre @ mk - centre  # T'
        quadratic = (np.einsum("jl,klm->kjm", moments_aa, mk) * mk).sum(axis=(1, 2))
        offsets = count * (tk * tk).sum(axis=1)
        value = (
            quadratic
            + 2 * ((sum_a @ mk) * tk).sum(axis=1)
            - 2 * (mk * moments_ab).sum(axis=(1, 2))
            + offsets
            - 2 * (tk @ sum_b)
            + sum_bb
        )
        size = quadratic + offsets + sum_bb
        close = np.flatnonzero(value <= CANCELLATION * size)
        if len(close):
            value[close] = _summed(src, dst, mk[close], t[start : start + step][close])
        out[start : start + step] = value
    return out


def _summed(src: np.ndarray, dst: np.ndarray, m: np.ndarray, t: np.ndarray) -> np.ndarray:
    """E_MLS handle by handle, for the rows where the moments' sum cancels."""
    out = np.empty(len(m))
    step = max(1, CHUNK // (4 * max(1, len(src))))
    for start in range(0, len(m), step):
        end = start + step
        fitted = np.einsum("nd,kde->kne", src, m[start:end]) + t[start:end, None, :]
        out[start:end] = ((fitted - dst) ** 2).sum(axis=(1, 2))
    return out


def volume_error_field(
    m: Deformation3D, shape: Sequence[int], *, grid: int = 1, spacing: object = None
) -> np.ndarray:
    """The MLS error E_MLS (eq. 7) at every voxel of a volume.

    E_MLS(v) = sum_i |p_i M_v + T_v - q_i|^2, unweighted: how far the affine fit at v misses
    the handles. With ``grid`` = 1 it is evaluated at every voxel centre; with ``grid`` = g
    at the voxel centres 0, g, 2 g, ... along each axis (and the last voxel) and
    interpolated trilinearly between them: g^3 times fewer fits, for big volumes (a 256^3
    volume at g = 4 fits 65^3 points). f is that of the volume's warp: a radius weight given
    no radius takes the diagonal of this volume in the handles' units
    (``volume_deformation``).

    Parameters
    ----------
    m : glmls.MLS or ReferenceDeformation
        A deformation of (N, 3) handles (``m.matrices``, ``m.src``, ``m.dst``).
    shape : sequence of int
        (D, H, W), or (D, H, W, C) of which (D, H, W) is used.
    grid : int, optional
        The step of the evaluated voxels (1: every voxel).
    spacing : (float, float, float), optional
        (dz, dy, dx): voxel (k, j, i) is the point (i dx, j dy, k dz) of the handles' units,
        as :meth:`glmls.MLS.warp` places it (default: ``m.spacing``, else 1 each; another
        than ``m.spacing`` is a ValueError).

    Returns
    -------
    numpy.ndarray
        (D, H, W) float64, in square voxels (square handle units with ``spacing``).

    Raises
    ------
    ValueError
        For a shape that is not (D, H, W) with D, H, W >= 1, a grid out of range, a field
        that needs more than this machine's physical memory (16 bytes a voxel: the float64
        field and its interpolation's copy; the message says both, in bytes), handles
        that are not (N, 3), ``m.matrices`` returning values that are not finite, or a
        ``spacing`` of another length than 3, with a value that is not a finite number > 0,
        or other than ``m``'s.
    TypeError
        For an ``m`` without the handles ``m.src``, ``m.dst`` and the fits ``m.matrices`` (a
        plain function of points: eq. 7 measures the fits against the handles), a shape or
        a grid that is not integers (2.0 is none), or a ``spacing`` that is not a sequence
        of real numbers.

    See Also
    --------
    glmls.reference.mls_error : the same error in float64 at given points.
    error_stats : its statistics (eqs. 8, 9).

    Examples
    --------
    >>> src = np.array([[2.0, 2, 2], [13, 2, 2], [2, 13, 2], [2, 2, 13], [13, 13, 13]])
    >>> dst = src.copy()
    >>> dst[4] = [10.0, 10, 10]  # one corner pulled in: no rigid map fits every handle
    >>> m = glmls.analysis.ReferenceDeformation(src, dst)
    >>> field = glmls.analysis.volume_error_field(m, (16, 16, 16), grid=4)
    >>> field.shape, field.dtype.name, bool(field.min() > 0)
    ((16, 16, 16), 'float64', True)
    >>> exact = glmls.reference.mls_error(src, dst, [[8.0, 4.0, 12.0]])  # a lattice voxel
    >>> bool(np.isclose(field[12, 4, 8], exact[0]))
    True
    """
    check_handles3(m)
    depth, height, width = as_volume_shape(shape)
    step = check_grid3(grid)
    # the float64 field and the copy that each axis's interpolation makes of it
    check_result_bytes(
        f"volume_error_field of shape {(depth, height, width)}", depth * height * width * 16
    )
    steps = deformation_spacing(m, spacing)
    scale = spacing_scale(steps)
    m = volume_deformation(m, (depth, height, width), steps)  # f as the volume's warp has it
    src, dst = as_points3(m.src, "m.src"), as_points3(m.dst, "m.dst")
    z, y, x = (axis_centres(n, step) for n in (depth, height, width))
    field = np.empty((len(z), len(y), len(x)))
    planes = max(1, CHUNK // (len(y) * len(x)))  # whole planes of points per call of m
    for start in range(0, len(z), planes):
        block = lattice_points(z[start : start + planes], y, x) * scale
        matrix, translation = m.matrices(block)
        matrix = np.asarray(matrix, dtype=np.float64).reshape(len(block), 3, 3)
        translation = np.asarray(translation, dtype=np.float64).reshape(len(block), 3)
        # a NaN fit would pass as a NaN voxel, which error_stats leaves out as undefined
        if not (np.isfinite(matrix).all() and np.isfinite(translation).all()):
            raise ValueError("m.matrices(points) returned NaN or infinite values")
        residuals = fit_residuals(src, dst, matrix, translation)
        field[start : start + planes] = residuals.reshape(-1, len(y), len(x))
    field = interpolate_axis(field, x, width, 2)
    field = interpolate_axis(field, y, height, 1)
    return np.ascontiguousarray(interpolate_axis(field, z, depth, 0))
