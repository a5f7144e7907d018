"""The MLS of (N, 3) handles: what :class:`glmls.MLS` becomes when its handles are 3D.

``glmls.MLS(src, dst)`` with (N, 3) handles returns an :class:`MLS3` (a subclass of
:class:`~glmls.MLS`, so one class for both to its users): f of points and point clouds,
its linear parts, its inverse, and meshes deformed with their normals and folds, all on the
GPU through :class:`~glmls.engine.kernel3.MLSKernel3`. Points are (x, y, z) = (column, row,
slice), voxel centres at integer coordinates; f(v) = v M + T with row vectors.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NoReturn

import numpy as np

from .core.config import check_flag
from .core.handles import (
    Scaling,
    check_gpu_distinct,
    check_gpu_spread,
    point_rows,
)
from .core.handles3 import (
    as_points3,
    as_volume_shape,
    as_volume_spacing,
    checked_extent,
    fit_offset3,
    fit_scaling3,
    validate_handles3,
    volume_extent,
)
from .core.mesh3 import DeformedMesh, as_mesh, mesh_colors, mesh_uv
from .engine.deform3 import deform_mesh3
from .engine.kernel3 import MLSKernel3
from .engine.passes3 import evaluate_points3, invert_points3, length_unit
from .forking import forwarded, on_gpu
from .gl.context import forked_from_gl, get_context
from .imaging.inverse import accepted
from .mls import MLS, InverseMLS
from .volume import volume_bounds, volume_coordinate_map, warp_volume

__all__ = ["MLS3", "InverseMLS3"]

#: Points a side of the lattice whose images give the inverse its last starts.
LATTICE_SIDE = 24
#: Points a side of the lattice of one point outside the handles' box.
LOCAL_LATTICE_SIDE = 12
#: Points outside the handles' box restarted together (their lattices' images in memory).
LOCAL_LATTICE_CHUNK = 2048
#: The lattice points (those with images nearest u) Newton starts from again.
LATTICE_STARTS = 4


def _lattice(lo: np.ndarray, hi: np.ndarray, side: int) -> np.ndarray:
    """(side**3, 3) points evenly spaced over the box from ``lo`` to ``hi``."""
    axes = [np.linspace(lo[k], hi[k], side) for k in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def _two_d_only(what: str) -> ValueError:
    return ValueError(f"{what} is 2D only: this MLS has (N, 3) handles")


class MLS3(MLS):
    """A Moving Least Squares deformation of 3D space, from (N, 3) handles.

    Made by :class:`glmls.MLS` from (N, 3) ``src`` and ``dst``, with the same parameters;
    the closed forms and their degenerate cases are those of :func:`glmls.reference.mls` in
    three dimensions (:doc:`the mathematics </mathematics>`), evaluated in float32 on the
    GPU. Points are (x, y, z) = (column, row, slice), voxel centres at integer coordinates.

    Parameters
    ----------
    src, dst : array_like
        (N, 3) source and target handle points (N may be 0).
    src_segments, dst_segments : None
        Segment handles are 2D only: ValueError unless None.
    transform, weight, alpha, s, radius, interpolating
        As :class:`glmls.MLS`'s (``radius`` in the handles' units).
    shape : (int, int, int) or None, default None
        (D, H, W) of a volume, whose diagonal in the handles' units is the radius weights'
        default radius: that of (D dz, H dy, W dx) with ``spacing``, in voxels without. Every
        method takes it (``m(points)``, :meth:`matrices`, :meth:`jacobian`, :meth:`deform`,
        :attr:`inverse`, :meth:`residuals`); a volume warp (or ``bounds``,
        ``coordinate_map``) and the 3D analyses of a volume take that volume's, the same for
        a volume of ``shape``. As in 2D, a radius weight needs neither ``radius`` nor
        ``shape`` to be made: without both, :meth:`warp` (``bounds``, ``coordinate_map``,
        the analyses of a volume) takes each volume's diagonal, and the methods of points,
        which have no volume, raise ValueError asking for one.
    spacing : (float, float, float) or None, default None
        (dz, dy, dx) of the volume's voxels in the handles' units, ordered as ``shape``:
        voxel (k, j, i) is the point (i dx, j dy, k dz). The volume warps, ``bounds``,
        ``coordinate_map`` and the 3D analyses (:func:`glmls.analysis.volume_report`, ...)
        take it when given no ``spacing``; given another, they raise ValueError (make an
        MLS without ``spacing`` to warp volumes of several spacings, each warp's own then).
        None: voxels, (1, 1, 1) for the warps.
    ctx : moderngl.Context or GLContext or None
        The context to compute with (default: glmls's shared one).
    storage : {"auto", "ssbo", "ubo", "texture"}, default "auto"
        Where the handles live on the GPU (two rows each).
    bins : None or False
        Spatial bins are 2D only: ValueError if True.

    Raises
    ------
    ValueError
        For malformed handles, segments, ``bins=True``, a bad ``shape``, or a ``spacing``
        that is not three finite numbers > 0.
    TypeError
        For a ``spacing`` that is not real numbers.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> src = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
    >>> dst = [[1, 0, 0], [11, 0, 0], [1, 10, 0], [1, 0, 10]]  # one voxel along x
    >>> with glmls.MLS(src, dst, transform="affine") as m:
    ...     print(type(m).__name__, np.round(m([[5, 5, 5]]), 3).tolist())
    MLS3 [[6.0, 5.0, 5.0]]

    Handles in millimetres of a volume of 10 slices 2 mm apart, rows of 1 mm and columns of
    0.5 mm: the default radius is the volume's diagonal in millimetres, for every method.

    >>> volume = np.zeros((10, 20, 40), np.uint8)
    >>> mm = [[2.0, 4.0, 4.0], [16.0, 4.0, 6.0], [4.0, 15.0, 10.0], [10.0, 10.0, 16.0]]
    >>> moved = np.add(mm, [[1.0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]])
    >>> m = glmls.MLS(mm, moved, weight="gaussian", shape=volume.shape, spacing=(2.0, 1.0, 0.5))
    >>> m  # doctest: +NORMALIZE_WHITESPACE
    MLS(4 3D handles, transform='rigid', weight='gaussian', alpha=1.0, s=1e-08, radius=None,
        interpolating=False, shape=(10, 20, 40), spacing=(2.0, 1.0, 0.5))
    >>> round(m.kernel.radius(), 6)  # sqrt(20² + 20² + 20²) mm
    34.641016
    >>> m.warp(volume).shape  # with the MLS's spacing
    (10, 20, 40)
    >>> m.release()

    Without ``radius`` or ``shape`` a radius weight takes the diagonal of each volume warped,
    as a 2D MLS takes each image's; f at points then has no volume to take one from.

    >>> m = glmls.MLS(mm, moved, weight="gaussian", spacing=(2.0, 1.0, 0.5))
    >>> m.warp(volume).shape  # the radius: this volume's diagonal, 34.64 mm
    (10, 20, 40)
    >>> m(mm)
    Traceback (most recent call last):
        ...
    ValueError: weight 'gaussian' needs an influence radius: ...
    >>> m.release()
    """

    dimension = 3

    def _setup(self, handles, config, shape, ctx, storage, bins, spacing=None) -> None:
        src, dst, src_segments, dst_segments = handles
        if src_segments is not None or dst_segments is not None:
            raise ValueError(
                "segment handles are 2D only: src_segments and dst_segments must be None "
                "with (N, 3) handles"
            )
        if bins:
            raise ValueError("bins are 2D only: bins must be None or False with (N, 3) handles")
        self._config = config
        self._shape = None if shape is None else as_volume_shape(shape)
        self._spacing = None if spacing is None else as_volume_spacing(spacing)
        if self._shape is not None:
            checked_extent(self._shape, self._spacing)
        p, q = validate_handles3(src, dst)
        self._storage_name = storage
        self._options = {"storage": storage, "bins": None}
        self._swapped = None
        if ctx is None and forked_from_gl():
            p.setflags(write=False)
            q.setflags(write=False)
            self._made_forked(p=p, q=q)
            return
        self._gl = get_context(ctx)
        self._kernel = MLSKernel3(self._gl, config, shape=self._extent, storage=storage)  # type: ignore[assignment]
        self._release_when_dropped(self._kernel)
        try:
            self._store3(p, q)
        except ValueError:
            self._kernel.release()
            raise

    def _store3(self, p: np.ndarray, q: np.ndarray) -> None:
        if not forked_from_gl():  # there the helper's MLS takes them
            # far targets' common translation stays out of float32
            offset = fit_offset3(
                p,
                q,
                self.shape,  # type: ignore[arg-type]
                self.spacing,  # type: ignore[arg-type]
                bounded=self.config.weight_entry.support == "radius",
            )
            near = q - offset
            scaling = fit_scaling3(p, near, self.shape, self.spacing)  # type: ignore[arg-type]
            if len(p):
                check_gpu_spread(float(np.ptp(p, axis=0).max()), scaling.scale)
            check_gpu_distinct(p, q, scaling.to_gpu(p), lambda: scaling.to_gpu(near), scaling.scale)
            self._kernel.upload(p, q, scaling, offset)  # type: ignore[call-arg, arg-type]
        p.setflags(write=False)
        q.setflags(write=False)
        self._p, self._q = p, q
        self._drop_swapped()

    @property
    def _extent(self) -> tuple[float, float, float] | None:
        """The volume in the handles' units, (D dz, H dy, W dx), whose diagonal is the
        default radius (the kernel's ``shape``); None without ``shape``."""
        if self.shape is None:
            return None
        return self.shape if self.spacing is None else volume_extent(self.shape, self.spacing)  # type: ignore[return-value]

    # -- the handles and the GPU state ------------------------------------------------------

    @property
    def src(self) -> np.ndarray:
        """Source handles p, (N, 3) float64, read-only.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0], [4, 0, 0]], [[1, 0, 0], [5, 0, 0]]) as m:
        ...     print(m.src.tolist(), m.src.flags.writeable)
        [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0]] False
        """
        return self._p

    @property
    def dst(self) -> np.ndarray:
        """Target handles q, (N, 3) float64, read-only.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0], [4, 0, 0]], [[1, 0, 0], [5, 0, 0]]) as m:
        ...     print(m.dst.tolist())
        [[1.0, 0.0, 0.0], [5.0, 0.0, 0.0]]
        """
        return self._q

    @property
    def src_segments(self) -> np.ndarray:
        """No segments in 3D: (0, 2, 3).

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0]], [[1, 0, 0]]) as m:
        ...     print(m.src_segments.shape)
        (0, 2, 3)
        """
        return np.zeros((0, 2, 3))

    @property
    def dst_segments(self) -> np.ndarray:
        """No segments in 3D: (0, 2, 3).

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0]], [[1, 0, 0]]) as m:
        ...     print(m.dst_segments.shape)
        (0, 2, 3)
        """
        return np.zeros((0, 2, 3))

    @property
    def handles(self):
        """2D only (a :class:`~glmls.HandleSet` holds 2D handles): ValueError.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0]], [[1, 0, 0]]) as m:
        ...     m.handles
        Traceback (most recent call last):
            ...
        ValueError: ...
        """
        raise _two_d_only("MLS.handles")

    @property
    def kernel(self) -> MLSKernel3:  # type: ignore[override]
        """The handles on the GPU and the shaders' defines and uniforms (for GL passes).

        ``#include "mls3/core.glsl"``: ``MLSKernel3.program``, ``MLSKernel3.bind``.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0], [8, 4, 2]], [[1, 0, 0], [8, 5, 2]]) as m:
        ...     print(type(m.kernel).__name__)
        MLSKernel3
        """
        return self._here(self._kernel)  # type: ignore[return-value]

    @property
    def scaling(self) -> Scaling:
        """The GPU's coordinates: (voxel - center) / scale.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0], [8, 4, 2]], [[0, 0, 0], [8, 4, 2]]) as m:
        ...     print(m.scaling)
        Scaling(center=(4.0, 2.0, 1.0), scale=4.0)
        """
        return self.kernel.scaling

    def uniforms(self, shape: Sequence[int] | None = None) -> dict[str, object]:  # type: ignore[override]
        """The uniforms of ``mls3/core.glsl`` for a volume of ``shape`` (for GL passes).

        Parameters
        ----------
        shape : (int, int, int) or None
            The volume (D, H, W) whose diagonal is the default radius, in the handles' units
            (None: the MLS's own, of its ``shape`` and ``spacing``).

        Returns
        -------
        dict
            Uniform name -> value.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0], [8, 4, 2]], [[1, 0, 0], [8, 5, 2]], alpha=2.0) as m:
        ...     uniforms = m.uniforms((16, 16, 16))
        >>> uniforms["u_alpha"]
        2.0
        """
        if shape is None:
            return self.kernel.uniforms()
        return self.kernel.uniforms(volume_extent(as_volume_shape(shape), self.spacing))  # type: ignore[arg-type]

    def set_handles(
        self, src: object, dst: object, *, src_segments: object = None, dst_segments: object = None
    ) -> None:
        """Replace the (N, 3) handles, keeping the configuration (as :meth:`glmls.MLS.set_handles`).

        Parameters
        ----------
        src, dst : array_like
            (N, 3) handle points.
        src_segments, dst_segments : None
            2D only.

        Examples
        --------
        >>> import glmls
        >>> with glmls.MLS([[0, 0, 0]], [[1, 0, 0]]) as m:
        ...     m.set_handles([[0, 0, 0]], [[0, 0, 2]])
        ...     print(m([[3, 3, 3]]).tolist())
        [[3.0, 3.0, 5.0]]
        """
        self._check_alive()
        if src_segments is not None or dst_segments is not None:
            raise ValueError("segment handles are 2D only")
        p, q = validate_handles3(src, dst)
        with self._current():
            self._store3(p, q)

    def swapped_kernel(self) -> MLSKernel3:  # type: ignore[override]
        """The kernel of the MLS with p and q swapped (for GL passes).

        An approximate inverse of f.

        Returns
        -------
        MLSKernel3
            Made on first use, kept until the handles change.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0], [8, 4, 2]], [[1, 0, 0], [8, 5, 2]]) as m:
        ...     print(m.swapped_kernel() is m.swapped_kernel())
        True
        """
        self.kernel.check_alive()
        if self._swapped is None:
            swapped = MLSKernel3(
                self._gl,
                self.config,
                shape=self._extent,  # type: ignore[arg-type]
                storage=self._storage_name,
            )
            # q -> p in the frame of q - t: the forward kernel's, moved by its offset t
            offset = self.kernel.offset
            scaling = self.scaling
            if offset.any():
                center = tuple(float(c) for c in np.add(scaling.center, offset))
                scaling = Scaling(center, scaling.scale)  # type: ignore[arg-type]
            swapped.upload(self._q, self._p, scaling, -offset)
            self._owns(swapped)
            self._swapped = swapped  # type: ignore[assignment]
        return self._swapped  # type: ignore[return-value]

    # -- f at points -------------------------------------------------------------------------

    @on_gpu
    def __call__(self, points: object) -> np.ndarray:
        """f at ``points``, evaluated on the GPU.

        Parameters
        ----------
        points : array_like
            (K, 3) points (x, y, z).

        Returns
        -------
        numpy.ndarray
            (K, 3) float64 f(points).

        Examples
        --------
        >>> import glmls
        >>> with glmls.MLS([[0, 0, 0]], [[1, 2, 3]]) as m:  # one handle: a translation
        ...     print(m([[5, 5, 5]]).tolist())
        [[6.0, 7.0, 8.0]]
        """
        f, _ = evaluate_points3(self._kernel, _rows(points))  # type: ignore[arg-type]
        return f

    @property
    def inverse(self) -> InverseMLS3:
        """f's inverse as a transform (an :class:`InverseMLS3`), solved on the GPU.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0]], [[1, 2, 3]]) as m:  # a translation
        ...     print(np.round(m.inverse([[1, 2, 3]]), 3).tolist())
        [[0.0, 0.0, 0.0]]
        """
        self._check_alive()
        return InverseMLS3(self)

    def residuals(self, src: object, dst: object) -> np.ndarray:
        """|f(src) - dst| per point, voxels.

        Parameters
        ----------
        src, dst : array_like
            (K, 3) points each.

        Returns
        -------
        numpy.ndarray
            (K,) float64 distances.

        Examples
        --------
        >>> import glmls
        >>> with glmls.MLS([[0, 0, 0]], [[0, 0, 2]]) as m:
        ...     print(m.residuals([[1, 1, 1]], [[1, 1, 1]]).tolist())
        [2.0]
        """
        source, target = _rows(src, "src"), _rows(dst, "dst")
        if len(source) != len(target):
            raise ValueError(
                f"src and dst must have the same length, got {len(source)} and {len(target)}"
            )
        return np.linalg.norm(self(source) - target, axis=1)

    @on_gpu
    def matrices(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        """The affine map of the MLS at each point: ``f(v) = v @ M + T``.

        Parameters
        ----------
        points : array_like
            (K, 3) points.

        Returns
        -------
        M : numpy.ndarray
            (K, 3, 3) float64.
        T : numpy.ndarray
            (K, 3) float64.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> with glmls.MLS([[0, 0, 0]], [[2, 0, 0]]) as m:
        ...     M, T = m.matrices([[1, 1, 1]])
        >>> M[0].tolist(), T.tolist()
        ([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [[2.0, 0.0, 0.0]])
        """
        v = _rows(points)
        f, m = evaluate_points3(self._kernel, v, output="matrix")  # type: ignore[arg-type]
        return m, f - np.einsum("ki,kij->kj", v, m)  # type: ignore[return-value]

    @on_gpu
    def jacobian(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        """f and its Jacobian J = df/dv, on the GPU.

        J is the derivative of the MLS's closed form at each point, to float32's rounding;
        where the solve takes a ridge (fewer than four handles in general position weigh
        in: the degenerate sets' rules), the derivative of that float64 solve, differenced
        in the moments; where the point snaps to a handle, central differences of f over
        0.05 voxel (:doc:`the mathematics </mathematics>`).

        Parameters
        ----------
        points : array_like
            (K, 3) points.

        Returns
        -------
        f : numpy.ndarray
            (K, 3) float64 f(points).
        J : numpy.ndarray
            (K, 3, 3) float64, row vectors: df = dv J, J[k, r, c] = d f_c / d v_r.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> src = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
        >>> with glmls.MLS(src, np.multiply(src, 2.0), transform="affine") as m:
        ...     f, J = m.jacobian([[3, 3, 3]])
        >>> (np.round(J[0], 3) + 0.0).tolist()
        [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]
        """
        v = _rows(points)
        return evaluate_points3(self._kernel, v, output="jacobian")  # type: ignore[arg-type, return-value]

    @on_gpu
    def deform(self, mesh: object) -> DeformedMesh:
        """A triangle mesh or point cloud deformed by f on the GPU.

        As :meth:`glmls.MLS.deform`.

        Parameters
        ----------
        mesh : object
            ``.vertices`` and ``.faces``, a ``(vertices, faces)`` tuple or (V, 3) points.

        Returns
        -------
        DeformedMesh
            The deformed vertices, normals, Jacobians, det J and folds.

        Examples
        --------
        >>> import glmls
        >>> with glmls.MLS([[0, 0, 0]], [[1, 1, 1]]) as m:  # a point cloud
        ...     print(m.deform([[1.0, 2.0, 3.0]]).vertices.tolist())
        [[2.0, 3.0, 4.0]]
        """
        vertices, faces, normals = as_mesh(mesh)
        colors = mesh_colors(mesh, len(vertices))
        uv, face_uv = mesh_uv(mesh, faces)
        kernel = self._kernel
        return deform_mesh3(  # type: ignore[arg-type]
            kernel, vertices, faces, normals, colors=colors, uv=uv, face_uv=face_uv
        )

    # -- volumes and what is 2D only --------------------------------------------------------

    @forwarded
    def warp(self, volume: object, **options: object) -> np.ndarray:  # type: ignore[override]
        """The volume deformed by f on the GPU (:func:`glmls.volume.warp_volume`).

        Parameters
        ----------
        volume : array_like
            A (D, H, W) or (D, H, W, C) volume (C in 1..4) of uint8, uint16, float32 or
            float64 (computed as float32, returned as float64); a 3-d array is (D, H, W)
            whatever its sizes (an RGB image (H, W, 3) is a volume 3 voxels wide: a 2D image
            takes an MLS of (N, 2) handles).
        **options
            :class:`glmls.volume.VolumeOptions`' fields: ``method`` (``"quads"``, the
            tetrahedra of the deformed lattice, or ``"backward"``), ``interpolation``,
            ``grid``, ``border``, ``background``, ``output_shape``, ``origin``, ``spacing``
            (default: the MLS's ``spacing``, else 1 each; another is a ValueError); and
            ``slabs``, a :class:`glmls.volume.SlabOptions` bounding the output slabs and
            lattice bands (any choice gives the same volume). :meth:`bounds` gives the
            ``output_shape`` and ``origin`` of the canvas that holds the whole deformed
            volume.

        Returns
        -------
        numpy.ndarray
            The deformed volume, with the input's dtype and channels.

        Raises
        ------
        ValueError
            For a volume or an option that is not valid (named).

        Warns
        -----
        glmls.BorderWarning
            Where a border mode other than ``constant`` cannot fill the whole canvas (the
            lattice of cells at its largest does not cover it).

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> volume = np.zeros((4, 5, 6), np.uint8)
        >>> volume[1, 2, 3] = 200
        >>> src = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])
        >>> with glmls.MLS(src, src + [1, 0, 0]) as m:  # one voxel along x
        ...     out = m.warp(volume)
        >>> [int(i) for i in np.argwhere(out == 200)[0]]
        [1, 2, 4]
        """
        return warp_volume(self, volume, **options)

    @forwarded
    def bounds(self, shape, *, grid=1, spacing=None):  # type: ignore[override]
        """The bounding box of the deformed volume (:func:`glmls.volume.volume_bounds`).

        Parameters
        ----------
        shape : tuple of int
            (D, H, W) of the volume, or its (D, H, W, C) with channels.
        grid : int, default 1
            The step of the lattice of voxel-cube corners where f is evaluated.
        spacing : (float, float, float) or None, default None
            (dz, dy, dx) of the voxels, in the handles' units (None: the MLS's ``spacing``,
            else 1 each).

        Returns
        -------
        glmls.volume.VolumeBounds
            Whose ``output_shape`` and ``origin`` give the canvas that shows all of it.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> src = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])
        >>> with glmls.MLS(src, src + [0, 0, 2]) as m:
        ...     b = m.bounds((4, 5, 6))
        >>> b.output_shape, b.origin
        ((4, 5, 6), (0.0, 0.0, 2.0))
        """
        return volume_bounds(self, shape, grid=grid, spacing=spacing)

    @forwarded
    def coordinate_map(self, shape, **options):  # type: ignore[override]
        """The backward map of a volume (:func:`glmls.volume.volume_coordinate_map`).

        Parameters
        ----------
        shape : tuple of int
            (D, H, W) of the source volume, or its (D, H, W, C) with channels.
        **options
            :class:`glmls.volume.VolumeOptions`' ``grid``, ``border``, ``output_shape``,
            ``origin`` and ``spacing`` (and ``method="backward"``, the map's);
            ``interpolation`` and ``background``, which a map does not use, are a
            ``TypeError``.

        Returns
        -------
        map : numpy.ndarray
            (D, H, W, 3) float32 source points (x, y, z) of the output voxels.
        residual : numpy.ndarray
            (D, H, W) float32 |f(s) - u|, voxels.
        covered : numpy.ndarray
            (D, H, W) bool: a source point was found.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> src = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])
        >>> with glmls.MLS(src, src + [1, 0, 0]) as m:
        ...     points, residual, covered = m.coordinate_map((4, 5, 6))
        >>> points[0, 0, 3].tolist()
        [2.0, 0.0, 0.0]
        """
        return volume_coordinate_map(self, shape, **options)

    def mesh(self, shape, *, grid=1, tolerance=None) -> NoReturn:  # type: ignore[override]
        """2D only: ValueError (see :meth:`deform` for 3D meshes).

        Parameters
        ----------
        shape, grid, tolerance
            As :meth:`glmls.MLS.mesh`'s.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0]], [[1, 0, 0]]) as m:
        ...     m.mesh((8, 8))
        Traceback (most recent call last):
            ...
        ValueError: ...
        """
        raise _two_d_only("MLS.mesh (an image's mesh)")

    def error_field(self, shape, *, grid=1, tolerance=None) -> NoReturn:  # type: ignore[override]
        """2D only: ValueError.

        Parameters
        ----------
        shape, grid, tolerance
            As :meth:`glmls.MLS.error_field`'s.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0]], [[1, 0, 0]]) as m:
        ...     m.error_field((8, 8))
        Traceback (most recent call last):
            ...
        ValueError: ...
        """
        raise _two_d_only("MLS.error_field")

    def __repr__(self) -> str:
        c = self.config
        volume = "".join(
            f", {name}={value}"
            for name, value in (("shape", self.shape), ("spacing", self.spacing))
            if value is not None
        )
        state = ", released" if self.released else ""
        return (
            f"MLS({len(self._p)} 3D handles, transform={c.transform!r}, weight={c.weight!r}, "
            f"alpha={c.alpha}, s={c.s}, radius={c.radius}, interpolating={c.interpolating}"
            f"{volume}{state})"
        )


class InverseMLS3(InverseMLS):
    """The inverse of a 3D MLS map f, as :attr:`glmls.MLS.inverse` returns it.

    ``inv(points)`` solves f(s) = u at (K, 3) points on the GPU by Newton's method (J by
    central differences, stopping below 1e-4 voxel), from the MLS with p and q swapped at u,
    then from u itself, and where neither reaches u (next to a fold both may lie in the
    basin of no preimage) from the four points of a lattice around u whose images lie
    nearest it. Far from the handles, where f tends to the fit of them all and the swapped
    MLS misses the preimage by a share of the distance, Newton's steps grow with the
    distance from the handles' box (``glmls.engine.passes3.NEWTON_FAR3``): points across
    glmls's coordinate range find theirs. A row is NaN where Newton does not end within
    0.05 voxel of u (no preimage, or none found), or, far out where that is more, within 4
    float32 steps of the larger coordinate of u and s, s's times f's stretch there where f
    magnifies (as in 2D: ``glmls.imaging.inverse.accepted``); a voxel is the handles'
    unit, or less where their box is smaller than 32 units
    (``glmls.engine.passes3.length_unit``).
    ``return_valid=True`` also returns the mask of the rows that have one. Where f folds, u
    has several preimages and one of them is found; so too where a radius weight's reach
    ends (``cressman``, ``shepard``, ``linear``): f jumps there from the handles' transform
    to the identity, so a point u = f(x) beyond every handle's reach is its own preimage as
    well as x's image, and either may be found (the jump overlaps the map with itself
    without det J <= 0 on either side).

    Parameters
    ----------
    forward : MLS
        The deformation f (of (N, 3) handles).
    grid : int, default 1
        Unused in 3D (the first guess needs no mesh).

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> src = [[0, 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 9]]
    >>> with glmls.MLS(src, np.add(src, 1.0)) as m:
    ...     print(np.round(m.inverse([[5, 5, 5]]), 3).tolist())
    [[4.0, 4.0, 4.0]]
    """

    dimension = 3

    def __call__(
        self, points: object, *, return_valid: bool = False
    ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """f's inverse at ``points``, solved on the GPU.

        Parameters
        ----------
        points : array_like
            (K, 3) points u.
        return_valid : bool, default False
            Also return which rows have a preimage.

        Returns
        -------
        numpy.ndarray or (numpy.ndarray, numpy.ndarray)
            (K, 3) float64 source points s, NaN rows where u has none; with
            ``return_valid`` also the (K,) bool mask of the rows that have one.

        Raises
        ------
        TypeError
            For points that are not real numbers, or a ``return_valid`` that is not a bool.
        ValueError
            For points that are not (K, 3) finite coordinates.

        Examples
        --------
        >>> import glmls
        >>> with glmls.MLS([[0, 0, 0]], [[2, 0, 0]]) as m:
        ...     print(m.inverse([[5, 1, 1]]).round(3).tolist())
        [[3.0, 1.0, 1.0]]
        """
        return_valid = check_flag("return_valid", return_valid)
        s, valid = self._solve(_rows(points))
        return (s, valid) if return_valid else s

    def _solved(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = self._forward
        m.kernel.check_alive()
        guess, _ = evaluate_points3(m.swapped_kernel(), points)  # type: ignore[arg-type]
        s, residual = invert_points3(m.kernel, points, guess)  # type: ignore[arg-type]
        unit = length_unit(m.kernel)  # type: ignore[arg-type]
        targets = points - m.kernel.offset  # u in the GPU's frame of the targets
        valid = accepted(m.scaling, targets, s, residual, unit=unit, f=m)
        if not valid.all():
            missed = np.flatnonzero(~valid)
            s[missed], residual[missed] = self._from_lattice(points[missed], s[missed])
            valid[missed] = accepted(
                m.scaling, targets[missed], s[missed], residual[missed], unit=unit, f=m
            )
        s[~valid] = np.nan
        return s, valid

    def _from_lattice(self, u: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Newton again for the points u that neither start reached, from the points of a
        lattice whose images lie nearest u (next to a fold the swapped MLS and u itself can
        both lie in the basin of no preimage): the best ends and their residuals.

        A point's lattice depends on that point and f alone, never on the other points of
        the call, so that its answer does not either: for u within the handles' box (sources
        and targets, widened by the handles' largest move, about as far as a preimage lies
        from u) the lattice of that box, LATTICE_SIDE points a side; for u outside it, its
        own lattice spanning u and its first attempt's end, widened likewise,
        LOCAL_LATTICE_SIDE points a side."""
        m = self._forward
        reach = float(np.linalg.norm(m.dst - m.src, axis=1).max(initial=0.0)) + 1.0
        handles = np.concatenate([m.src, m.dst])
        lo, hi = handles.min(axis=0) - reach, handles.max(axis=0) + reach
        inside = ((u >= lo) & (u <= hi)).all(axis=1)
        ends, residuals = s.copy(), np.full(len(u), np.inf)
        if inside.any():
            rows = np.flatnonzero(inside)
            lattice = _lattice(lo, hi, LATTICE_SIDE)
            ends[rows], residuals[rows] = self._restart(u[rows], lattice[None])
        outside = np.flatnonzero(~inside)
        for first_row in range(0, len(outside), LOCAL_LATTICE_CHUNK):
            rows = outside[first_row : first_row + LOCAL_LATTICE_CHUNK]
            # each row's own box: u and its first end, where finite
            first = np.where(np.isfinite(s[rows]).all(axis=1)[:, None], s[rows], u[rows])
            low = np.minimum(u[rows], first) - reach
            high = np.maximum(u[rows], first) + reach
            lattices = np.stack(
                [_lattice(a, b, LOCAL_LATTICE_SIDE) for a, b in zip(low, high, strict=True)]
            )
            ends[rows], residuals[rows] = self._restart(u[rows], lattices)
        return ends, residuals

    def _restart(self, u: np.ndarray, lattices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Newton from the LATTICE_STARTS points whose images lie nearest each u of its
        lattice (``lattices`` (1, P, 3), one for all, or (len(u), P, 3), one each): the best
        end of each u and its residual (inf where its lattice has no finite image)."""
        m = self._forward
        images, _ = evaluate_points3(m.kernel, lattices.reshape(-1, 3))  # type: ignore[arg-type]
        images = images.reshape(lattices.shape)
        starts = min(LATTICE_STARTS, lattices.shape[1])
        # the squared distances of each u's lattice images to u, NaN images never nearest
        far = ((images - u[:, None]) ** 2).sum(axis=2) if len(lattices) > 1 else None
        if far is None:
            from scipy.spatial import cKDTree

            kept = np.flatnonzero(np.isfinite(images[0]).all(axis=1))
            if len(kept) == 0:
                return np.full((len(u), 3), np.nan), np.full(len(u), np.inf)
            starts = min(starts, len(kept))
            _, nearest = cKDTree(images[0, kept]).query(u, k=starts)
            chosen = lattices[0, kept[nearest.reshape(len(u), starts)]]
        else:
            far = np.where(np.isfinite(far), far, np.inf)
            nearest = np.argsort(far, axis=1, kind="stable")[:, :starts]
            chosen = np.take_along_axis(lattices, nearest[..., None], axis=1)
        ends, residuals = invert_points3(
            m.kernel,  # type: ignore[arg-type]
            np.repeat(u, starts, axis=0),
            chosen.reshape(-1, 3),
        )
        residuals = residuals.reshape(len(u), starts)
        best = np.argmin(np.where(np.isfinite(residuals), residuals, np.inf), axis=1)
        rows = np.arange(len(u))
        return ends.reshape(len(u), starts, 3)[rows, best], residuals[rows, best]

    def residuals(self, src: object, dst: object) -> np.ndarray:
        """|f^-1(src) - dst| per point, voxels.

        Parameters
        ----------
        src, dst : array_like
            (K, 3) points each.

        Returns
        -------
        numpy.ndarray
            (K,) float64; NaN where ``src`` has no preimage.

        Examples
        --------
        >>> with glmls.MLS([[0, 0, 0]], [[1, 2, 3]]) as m:  # a translation
        ...     print(np.round(m.inverse.residuals([[1, 2, 3]], [[0, 0, 1]]), 3).tolist())
        [1.0]
        """
        source, target = _rows(src, "src"), _rows(dst, "dst")
        if len(source) != len(target):
            raise ValueError(
                f"src and dst must have the same length, got {len(source)} and {len(target)}"
            )
        return np.linalg.norm(self(source) - target, axis=1)  # type: ignore[operator]


MLS.kinds[3] = MLS3
InverseMLS.kinds[3] = InverseMLS3


def _rows(points: object, name: str = "points") -> np.ndarray:
    """(N, 3) points, one (3,) point as (1, 3) (as scikit-image's transforms take it)."""
    return as_points3(point_rows(points, 3), name)
