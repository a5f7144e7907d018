"""The public :class:`MLS` deformation, its inverse :class:`InverseMLS` and the one-call
:func:`warp`: the facade over the engine (:mod:`glmls.engine`, f on the GPU) and the image
construction (:mod:`glmls.imaging`).

An :class:`MLS` follows scikit-image's transform protocol: ``m(points)`` is f,
``m.inverse(points)`` is f's inverse and ``m.residuals(src, dst)`` the distances
|f(src) - dst|, so ``skimage.transform.warp(image, m.inverse)`` resamples an image by it.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Sequence
from typing import ClassVar

import moderngl
import numpy as np

from .core.config import MLSConfig, check_choice, check_flag, check_result_bytes
from .core.handles import Scaling, as_points, check_coordinates, point_rows
from .core.handles3 import dimension_of, planar_spacing
from .core.handleset import HandleSet
from .core.mesh import MeshLattice, as_shape, check_grid
from .core.mesh3 import DeformedMesh
from .engine.error_field import error_at
from .engine.error_field import error_field as evaluate_error_field
from .engine.kernel import DEFAULT_STORAGE, MLSKernel
from .engine.passes import deformed_lattice, evaluate_points
from .errors import ReleasedError
from .forking import ForkSafe, forwarded, in_helper, on_gpu
from .gl import helper
from .gl.context import GLContext, forked_from_gl, get_context
from .imaging.adaptive import ROOT_STEP, AdaptiveMesh, check_adaptive, interpolate
from .imaging.frame import Bounds
from .imaging.inverse import accepted, length_unit
from .imaging.options import FIELDS, WarpOptions, default
from .imaging.pipeline import GUESS_MESH_POINTS, WarpPipeline
from .volume.options import VOLUME_WARP_KEYWORDS

__all__ = ["MLS", "InverseMLS", "warp"]


class MLS(ForkSafe):
    """A Moving Least Squares deformation f from source handles ``src`` (p) to ``dst`` (q).

    Points are ``(x, y)`` = (column, row) rows of (N, 2) float arrays; pixel centres sit at
    integer coordinates, so pixel (row r, column c) is the point (c, r) and covers
    [c - 0.5, c + 0.5] x [r - 0.5, r + 0.5]. With row vectors (the paper's eq. 1),
    ``f(v) = v @ M(v) + T(v)``. Like scikit-image's transforms, ``m(points)`` is f,
    :attr:`inverse` is f's inverse (an :class:`InverseMLS`) and :meth:`residuals` measures
    how far f takes points from targets; :meth:`warp` deforms images on the GPU.

    With (N, 3) handles it is the MLS of 3D space (points (x, y, z) = (column, row, slice),
    voxel centres at integer coordinates; ``shape`` a volume's (D, H, W)): f, :meth:`matrices`,
    :attr:`inverse` and :meth:`residuals` at (K, 3) points, :meth:`deform` for meshes and
    point clouds, :meth:`warp` for volumes; segment handles, bins and the image passes are
    2D only (:doc:`the 3D guide </three_d>`).

    Special cases: no handles is the identity and one handle a translation by q - p, for every
    transform. Where a compact-support weight reaches fewer than the transform needs at a
    point, that point uses the similarity solution; a point that no handle reaches stays put.
    GPU objects are released by :meth:`release` (or a ``with`` block); the images come from
    its context's shared :class:`~glmls.gl.WarpPipeline`.

    Parameters
    ----------
    src, dst : array_like
        (N, 2) source and target handle points (N may be 0), or (N, 3) in 3D.
    src_segments, dst_segments : array_like or None
        (S, 2, 2) segment handles (Schaefer et al. 2006, section 4): segment s runs from
        ``src_segments[s, 0]`` to ``src_segments[s, 1]`` and goes to ``dst_segments[s, 0]``-
        ``dst_segments[s, 1]`` (:func:`glmls.polyline_segments` turns polylines into
        segments). Each weighs its points per unit of length, so a segment split in two is
        the same handle; with a weight that grows at least like 1 / d at d = 0 (idw with
        s = 0 and alpha >= 1/2, shepard, a weight made interpolating with alpha >= 1/2),
        f maps every point of a source segment onto its target segment
        (``glmls.core.segments.segments_interpolate``).
    transform : {"rigid", "similarity", "affine"}, default "rigid"
        The transform fitted at each point (:data:`glmls.TRANSFORMS`).
    weight : str, default "idw"
        The weight (:data:`glmls.WEIGHTS`; :class:`glmls.MLSConfig` has the formulas).
    alpha : float, default 1.0
        The weight's exponent (idw).
    s : float, default 1e-8
        idw's regularisation.
    radius : float or None, default None
        Influence radius in pixels (radius weights); None: the image diagonal, that of
        ``shape`` for f at points and that of the image warped for :meth:`warp` (a warp of
        an image of another size than ``shape`` takes its own diagonal).
    interpolating : bool, default False
        Make any weight interpolate the handles.
    shape : (int, int) or None, default None
        (H, W) of the image, for the default radius (and :attr:`inverse`'s first guess); in
        3D (D, H, W) of a volume.
    spacing : (float, float, float) or None, default None
        3D only: (dz, dy, dx) of the volume's voxels in the handles' units (ordered as
        ``shape``): the default radius is then the diagonal of (D dz, H dy, W dx), and the
        volume warps and analyses take this spacing unless given one (see
        :class:`~glmls.mls3.MLS3`). ValueError with 2D handles.
    ctx : moderngl.Context or GLContext or None
        The context to render with (default: glmls's shared headless EGL one).
    storage : {"auto", "ssbo", "ubo", "texture"}, default "auto"
        Where the handles live on the GPU: ``auto`` takes ``ubo`` where they fit, else
        ``texture`` for handles in spatial bins and ``ssbo`` for the others
        (``glmls.engine.storage``).
    bins : bool or None, default None
        Sort the handles into a spatial grid so that each point visits only those in reach
        (radius weights, ``glmls.engine.bins``): None where it pays, True always, False
        never.

    Raises
    ------
    ValueError
        For handles of the wrong shape, non-finite or beyond ±1e6 px, ``src`` and ``dst`` of
        different lengths, or a bad configuration (named).
    TypeError
        For handles that are not real numbers, or a ``ctx`` of another type.
    glmls.DegenerateHandlesError
        For an affine MLS whose (N, 2) source handles do not span the plane (3 points on
        a line). (N, 3) handles that do not span space are not refused: a ridge toward
        the similarity solution decides what they leave free
        (:doc:`the mathematics </mathematics>`).
    glmls.GLUnavailableError
        Where no OpenGL 4.3 context can be made.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> src = [[0, 0], [5, 0], [0, 3], [5, 3]]
    >>> dst = [[1, 0], [6, 0], [1, 3], [6, 3]]  # one pixel to the right
    >>> with glmls.MLS(src, dst, shape=(4, 6)) as m:
    ...     print(np.round(m([[2, 1]]), 3).tolist())
    ...     print(m.warp(np.arange(24, dtype=np.uint8).reshape(4, 6))[0].tolist())
    [[3.0, 1.0]]
    [0, 0, 1, 2, 3, 4]
    """

    #: The dimension of the handles; ``kinds`` maps each other dimension to the subclass
    #: that ``MLS(...)`` makes for its handles (``glmls.mls3`` registers 3).
    dimension = 2
    kinds: ClassVar[dict[int, type[MLS]]] = {}

    def __new__(cls, src: object = None, *args: object, **kwargs: object) -> MLS:
        kind = MLS.kinds.get(dimension_of(src)) if cls is MLS else None
        return object.__new__(kind if kind is not None else cls)

    def __init__(
        self,
        src: object,
        dst: object,
        *,
        src_segments: object = None,
        dst_segments: object = None,
        transform: str = "rigid",
        weight: str = "idw",
        alpha: float = 1.0,
        s: float = 1e-8,
        radius: float | None = None,
        interpolating: bool = False,
        shape: Sequence[int] | None = None,
        spacing: Sequence[float] | None = None,
        ctx: moderngl.Context | GLContext | None = None,
        storage: str = DEFAULT_STORAGE,
        bins: bool | None = None,
    ) -> None:
        config = MLSConfig(
            transform=transform,
            weight=weight,
            alpha=alpha,
            s=s,
            radius=radius,
            interpolating=interpolating,
        )
        handles = (src, dst, src_segments, dst_segments)
        self._setup(handles, config, shape, ctx, storage, bins, spacing)

    @classmethod
    def from_config(
        cls,
        src: object,
        dst: object,
        config: MLSConfig,
        *,
        src_segments: object = None,
        dst_segments: object = None,
        shape: Sequence[int] | None = None,
        spacing: Sequence[float] | None = None,
        ctx: moderngl.Context | GLContext | None = None,
        storage: str = DEFAULT_STORAGE,
        bins: bool | None = None,
    ) -> MLS:
        """An MLS with the settings of an :class:`MLSConfig`.

        Parameters
        ----------
        src, dst : array_like
            (N, 2) handle points.
        config : MLSConfig
            transform, weight, alpha, s, radius, interpolating.
        src_segments, dst_segments, shape, spacing, ctx, storage, bins
            As :class:`MLS`'s.

        Returns
        -------
        MLS

        Raises
        ------
        TypeError
            If ``config`` is not an :class:`MLSConfig`; else as :class:`MLS`.

        Examples
        --------
        >>> import glmls
        >>> config = glmls.MLSConfig(transform="similarity")
        >>> with glmls.MLS.from_config([[0, 0]], [[2, 1]], config) as m:
        ...     print(m([[5, 5]]).tolist())
        [[7.0, 6.0]]
        """
        if not isinstance(config, MLSConfig):
            raise TypeError(f"config must be an MLSConfig, got {type(config).__name__}")
        self = cls.__new__(cls, src)
        handles = (src, dst, src_segments, dst_segments)
        self._setup(handles, config, shape, ctx, storage, bins, spacing)
        return self

    def _setup(self, handles, config, shape, ctx, storage, bins, spacing=None) -> None:
        self._spacing: tuple[float, float, float] | None = planar_spacing(spacing)
        self._config = config
        self._shape = None if shape is None else as_shape(shape)
        if self._shape is not None:
            config.resolve_radius(self._shape)
        handles = self._validate(*handles)
        self._options = {"shape": self.shape, "storage": storage, "bins": bins}
        self._swapped: MLSKernel | None = None
        if ctx is None and forked_from_gl():
            self._made_forked(handles=handles)
            return
        self._gl = get_context(ctx)
        self._kernel = MLSKernel(self._gl, config, **self._options)  # type: ignore[arg-type]
        self._release_when_dropped(self._kernel)
        try:
            self._store(handles)
        except ValueError:
            self._kernel.release()
            raise

    def _validate(self, src, dst, src_segments, dst_segments) -> HandleSet:
        handles = HandleSet.validate(src, dst, src_segments, dst_segments)
        if self.config.transform == "affine":
            handles.check_affine()
        return handles

    def _store(self, handles: HandleSet) -> None:
        """The one way handles get in: the kernel's upload (none in a process forked from one
        that used GL: the helper's MLS takes them), then the read-only copies."""
        if not forked_from_gl():  # far targets' common translation stays out of float32
            bounded = self.config.weight_entry.support == "radius"
            near, offset = handles.near_targets(self.shape, bounded=bounded)
            self._kernel.upload(near, near.gpu_scaling(self.shape), offset)
        self._handles = handles
        self._drop_swapped()

    def _pipeline(self) -> WarpPipeline:
        self._kernel.check_alive()
        return WarpPipeline.of(self._gl)

    # -- the handles and the GPU state ------------------------------------------------------

    @property
    def src(self) -> np.ndarray:
        """Source handles p, (N, 2) float64, read-only.

        Examples
        --------
        >>> with glmls.MLS([[0, 0], [4, 0]], [[1, 0], [5, 0]]) as m:
        ...     print(m.src.tolist(), m.src.flags.writeable)
        [[0.0, 0.0], [4.0, 0.0]] False
        """
        return self._handles.src

    @property
    def dst(self) -> np.ndarray:
        """Target handles q, (N, 2) float64, read-only.

        Examples
        --------
        >>> with glmls.MLS([[0, 0], [4, 0]], [[1, 0], [5, 0]]) as m:
        ...     print(m.dst.tolist(), m.dst.dtype)
        [[1.0, 0.0], [5.0, 0.0]] float64
        """
        return self._handles.dst

    @property
    def src_segments(self) -> np.ndarray:
        """Source segment handles, (S, 2, 2) float64, read-only.

        Examples
        --------
        >>> segment = [[[0, 0], [8, 0]]]
        >>> with glmls.MLS([], [], src_segments=segment, dst_segments=segment) as m:
        ...     print(m.src_segments.shape, m.src.shape)
        (1, 2, 2) (0, 2)
        """
        return self._handles.src_segments

    @property
    def dst_segments(self) -> np.ndarray:
        """Target segment handles, (S, 2, 2) float64, read-only.

        Examples
        --------
        >>> src_segments, dst_segments = [[[0, 0], [8, 0]]], [[[0, 1], [8, 1]]]
        >>> with glmls.MLS([], [], src_segments=src_segments, dst_segments=dst_segments) as m:
        ...     print(m.dst_segments.tolist())
        [[[0.0, 1.0], [8.0, 1.0]]]
        """
        return self._handles.dst_segments

    @property
    def handles(self) -> HandleSet:
        """Every handle, points and segments (read-only arrays).

        Examples
        --------
        >>> with glmls.MLS([[0, 0], [4, 0]], [[1, 0], [5, 0]]) as m:
        ...     print(m.handles.points, m.handles.segments, len(m.handles))
        2 0 2
        """
        return self._handles

    @property
    def ctx(self) -> GLContext:
        """The :class:`~glmls.gl.GLContext` this MLS renders with.

        Examples
        --------
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     print(m.ctx is glmls.gl.get_context(), m.ctx.alive)
        True True
        """
        return self._here(self._gl)

    @property
    def kernel(self) -> MLSKernel:
        """The handles on the GPU and the shaders' defines and uniforms (for GL passes).

        Examples
        --------
        >>> with glmls.MLS([[0, 0], [8, 4]], [[1, 0], [8, 5]]) as m:
        ...     print(type(m.kernel).__name__, m.kernel.scaling == m.scaling)
        MLSKernel True
        """
        return self._here(self._kernel)

    @property
    def scaling(self) -> Scaling:
        """The GPU's coordinates: (pixel - center) / scale.

        Examples
        --------
        >>> with glmls.MLS([[0, 0], [8, 4]], [[0, 0], [8, 4]]) as m:
        ...     print(m.scaling)
        Scaling(center=(4.0, 2.0), scale=4.0)
        """
        return self.kernel.scaling

    @property
    def storage(self) -> str:
        """The handle storage in use (``"auto"`` resolved for this many handles).

        Examples
        --------
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     print(m.storage)
        ubo
        """
        return self.kernel.storage

    def defines(self) -> dict[str, object]:
        """The ``#define`` values of the MLS shaders for this configuration (for GL passes).

        Returns
        -------
        dict
            Name -> value, as the shaders are compiled with.

        Examples
        --------
        >>> with glmls.MLS([[0, 0], [8, 4]], [[1, 0], [8, 5]], transform="rigid") as m:
        ...     defines = m.defines()
        >>> defines["MLS_TRANSFORM"], defines["MLS_INTERPOLATING"]  # 0 affine, 1 similarity
        (2, False)
        """
        return self.kernel.defines()

    def uniforms(self, shape: tuple[int, int] | None = None) -> dict[str, float | bool]:
        """The MLS uniforms for an image of ``shape``, in scaled units (for GL passes).

        Parameters
        ----------
        shape : (int, int) or None
            (H, W) whose diagonal is the default radius (None: the MLS's own ``shape``).

        Returns
        -------
        dict
            Uniform name -> value.

        Examples
        --------
        >>> with glmls.MLS([[0, 0], [8, 4]], [[1, 0], [8, 5]], alpha=2.0) as m:
        ...     uniforms = m.uniforms((64, 64))
        >>> uniforms["u_alpha"]
        2.0
        """
        return self.kernel.uniforms(shape)

    def set_handles(
        self, src: object, dst: object, *, src_segments: object = None, dst_segments: object = None
    ) -> None:
        """Replace the handles (any count, points and segments), keeping the configuration.

        Cheaper than a new :class:`MLS` per frame of a drag: the handles go through the same
        upload as the constructor's (storage for their count, spatial bins rebuilt), nothing
        is compiled (unless segments appear or all go: their code is compiled in only where
        there are).

        Parameters
        ----------
        src, dst : array_like
            (N, 2) handle points.
        src_segments, dst_segments : array_like or None
            (S, 2, 2) segment handles.

        Raises
        ------
        ValueError, TypeError, glmls.DegenerateHandlesError
            As the constructor's; on error nothing changes.
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> import glmls
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     m.set_handles([[0, 0]], [[0, 2]])
        ...     print(m([[3, 3]]).tolist())
        [[3.0, 5.0]]
        """
        self._check_alive()
        handles = self._validate(src, dst, src_segments, dst_segments)
        with self._current():
            self._store(handles)

    def swapped_kernel(self) -> MLSKernel:
        """The kernel of the MLS map with p and q swapped (``backward-swap``; for GL passes).

        Returns
        -------
        MLSKernel
            Made on first use with this configuration and scaling, kept until the handles
            change.

        Raises
        ------
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> with glmls.MLS([[0, 0], [8, 4]], [[1, 0], [8, 5]]) as m:
        ...     print(m.swapped_kernel() is m.swapped_kernel())
        True
        """
        self.kernel.check_alive()
        if self._swapped is None:
            swapped = self._kernel.swapped()
            self._owns(swapped)
            self._swapped = swapped
        return self._swapped

    # -- f at points: scikit-image's transform protocol ------------------------------------

    @on_gpu
    def __call__(self, points: object) -> np.ndarray:
        """f at ``points``, evaluated on the GPU.

        Parameters
        ----------
        points : array_like
            (K, 2) points (x, y), finite, within ±1e6 px; (0, 2) gives (0, 2), one (2,) point
            (1, 2), as scikit-image's transforms take them.

        Returns
        -------
        numpy.ndarray
            (K, 2) float64 f(points) (float32 on the GPU: ~1e-7 of the coordinates' extent;
            targets far from their sources count as moved back near them, the translation
            added in float64: :doc:`the mathematics </mathematics>`).

        Raises
        ------
        ValueError
            For points of another shape, non-finite or beyond ±1e6 px.
        TypeError
            For points that are not real numbers.
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> with glmls.MLS([[0, 0], [9, 0], [0, 9]], [[1, 2], [10, 2], [1, 11]]) as m:
        ...     print(np.round(m([[4, 5], [0, 0]]), 3).tolist(), m([4, 5]).shape)
        [[5.0, 7.0], [1.0, 2.0]] (1, 2)
        """
        f, _ = evaluate_points(self._kernel, _points(points), with_matrix=False)
        return f

    @property
    def inverse(self) -> InverseMLS:
        """f's inverse as a transform: ``m.inverse(points)`` solves f(s) = u on the GPU.

        A new :class:`InverseMLS` of this MLS (it follows :meth:`set_handles`; nothing is
        cached); ``m.inverse.inverse`` is ``m``.

        Raises
        ------
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> with glmls.MLS([[0, 0], [9, 0], [0, 9]], [[1, 1], [10, 1], [1, 10]]) as m:
        ...     print(np.round(m.inverse([[5, 5]]), 3).tolist())
        [[4.0, 4.0]]
        """
        self._check_alive()
        return InverseMLS(self)

    def residuals(self, src: object, dst: object) -> np.ndarray:
        """The distance between f at ``src`` and ``dst``, per point.

        The ``residuals`` of scikit-image's transforms.

        Parameters
        ----------
        src, dst : array_like
            (K, 2) points each.

        Returns
        -------
        numpy.ndarray
            (K,) float64 |f(src) - dst|, pixels.

        Raises
        ------
        ValueError
            For points of another shape, non-finite, or ``src`` and ``dst`` of different
            lengths.
        TypeError
            For points that are not real numbers.
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> with glmls.MLS([[0, 0]], [[3, 4]]) as m:
        ...     print(np.round(m.residuals([[1, 1], [2, 2]], [[4, 5], [2, 2]]), 3).tolist())
        [0.0, 5.0]
        """
        source, target = _points(src, "src"), _points(dst, "dst")
        if len(source) != len(target):
            raise ValueError(
                f"src and dst must have the same length, got {len(source)} and {len(target)}"
            )
        return np.hypot(*(self(source) - target).T)

    @on_gpu
    def matrices(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        """The affine map of the MLS at each point: ``f(v) = v @ M + T``.

        Parameters
        ----------
        points : array_like
            (K, 2) points.

        Returns
        -------
        M : numpy.ndarray
            (K, 2, 2) float64.
        T : numpy.ndarray
            (K, 2) float64.

        Raises
        ------
        ValueError, TypeError, glmls.ReleasedError
            As :meth:`__call__`.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> with glmls.MLS([[0, 0]], [[2, 0]]) as m:
        ...     M, T = m.matrices([[1, 1]])
        >>> np.round(M, 3).tolist(), np.round(T, 3).tolist()
        ([[[1.0, 0.0], [0.0, 1.0]]], [[2.0, 0.0]])
        """
        v = _points(points)
        f, m = evaluate_points(self._kernel, v, with_matrix=True)
        return m, f - np.einsum("ki,kij->kj", v, m)  # type: ignore[return-value]

    def deform(self, mesh: object) -> DeformedMesh:
        """A triangle mesh or point cloud deformed by a 3D MLS (one made of (N, 3) handles).

        f at the vertices, the vertex normals carried by the inverse transpose of the
        Jacobian J = df/dv, det J and the folds, all computed on the GPU
        (:class:`~glmls.DeformedMesh`; :doc:`the 3D guide </three_d>`).

        Parameters
        ----------
        mesh : object
            An object with ``.vertices`` (V, 3) and ``.faces`` (F, 3) integer indices (a
            ``trimesh.Trimesh``, whose ``vertex_normals`` are used; a :class:`~glmls.Mesh`,
            whose ``normals`` are used where it has them, else its faces'), a ``(vertices,
            faces)`` tuple, or a point cloud (no faces, zero normals unless a
            :class:`~glmls.Mesh` gives them): a (V, 3) array of points, or an object with
            ``.vertices`` alone (a ``trimesh.PointCloud``). Vertex colours
            (a :class:`~glmls.Mesh`'s ``colors``, a trimesh's own vertex colours) go with
            their vertices, and texture coordinates (a :class:`~glmls.Mesh`'s ``uv`` and
            ``face_uv``, a trimesh's ``visual.uv``) with their faces' corners.

        Returns
        -------
        DeformedMesh
            The deformed vertices, normals (``own_normals`` where they carry the input's
            own), Jacobians, det J and folds, and the input's vertex colours (``colors``) and
            texture coordinates (``uv``, ``face_uv``), each None where it has none.

        Raises
        ------
        ValueError
            On an MLS of 2D handles, or for a malformed mesh (named), or vertex colours that
            are not (V, 3) or (V, 4) integers 0..255 or floats 0..1, or texture coordinates
            that are not (T, 2) finite with (F, 3) indices into them.
        TypeError
            For vertices that are not real numbers, or faces that are not integers (a
            float array of faces too: the message names its dtype), or texture coordinates
            that are not real numbers.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> vertices = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0], [0, 0, 4]], float)
        >>> faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
        >>> with glmls.MLS([[0, 0, 0]], [[1, 1, 1]]) as m:  # a translation
        ...     out = m.deform((vertices, faces))
        >>> out.vertices[1].tolist(), out.det_j.round(3).tolist(), out.folded
        ([5.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0], False)
        """
        raise ValueError("deform needs a 3D MLS: (N, 3) handles; this MLS has (N, 2) handles")

    # -- meshes and images -----------------------------------------------------------------

    @on_gpu
    def mesh(
        self, shape: Sequence[int], *, grid: int = 1, tolerance: float | None = None
    ) -> tuple[np.ndarray, np.ndarray] | AdaptiveMesh:
        """The mesh of pixel-square corners of an image of ``shape`` and its image under f.

        Vertices sit at x = -0.5, -0.5 + grid, ..., W - 0.5 (the last step may be shorter),
        likewise in y.

        Parameters
        ----------
        shape : (int, int)
            (H, W) of the image.
        grid : int, default 1
            The mesh step, pixels.
        tolerance : float or None, default None
            Pixels (``grid`` must stay 1): the error-bounded adaptive mesh that :meth:`warp`
            draws with that tolerance (:doc:`the adaptive mesh </adaptive>`).

        Returns
        -------
        (vertices, deformed) or AdaptiveMesh
            Each (rows, columns, 2) float64; with ``tolerance`` an
            ``AdaptiveMesh`` (vertices, f at them, triangles,
            leaves).

        Raises
        ------
        ValueError
            For a bad ``shape``, ``grid`` or ``tolerance`` (named), or a mesh whose arrays
            (40 bytes a vertex: the vertices and f in float64, f in float32 as read back;
            with ``tolerance`` at least 512 bytes a 32 px root cell) need more than this
            machine's physical memory (the message says both, in bytes).
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> import glmls
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     vertices, deformed = m.mesh((4, 6), grid=2)
        >>> vertices.shape, deformed[0, 0].tolist()
        ((3, 4, 2), [0.5, -0.5])
        """
        if tolerance is not None:
            value = check_adaptive("quads", grid, tolerance)
            roots = _mesh_lattice(shape, ROOT_STEP, ADAPTIVE_ROOT_BYTES, adaptive=True)
            return self._pipeline().adaptive.mesh(self._kernel, roots.shape, value)  # type: ignore[arg-type]
        lattice = _mesh_lattice(shape, grid, 40)  # vertices, f in float64 and float32
        vertices = lattice.points()
        return vertices, deformed_lattice(self._kernel, lattice).reshape(vertices.shape)

    @on_gpu
    def error_field(
        self, shape: Sequence[int], *, grid: int = 1, tolerance: float | None = None
    ) -> np.ndarray:
        """The MLS error field E_MLS (paper eq. 7) of an image of ``shape``.

        E_MLS(v) = sum_i |p_i M_v + T_v - q_i|^2 at every pixel centre, in square pixels,
        unweighted so that configurations with different weights compare fairly. float32 on
        the GPU: expect a relative error of ~1e-6 to 1e-5.

        Parameters
        ----------
        shape : (int, int)
            (H, W) of the image.
        grid : int, default 1
            1 evaluates every pixel centre; > 1 the vertices of :meth:`mesh`'s mesh,
            interpolated bilinearly to the pixel centres (both on the GPU).
        tolerance : float or None, default None
            (``grid`` 1) the vertices of the adaptive mesh of that tolerance, interpolated on
            each leaf's quadratic patch (numpy).

        Returns
        -------
        numpy.ndarray
            (H, W) float64.

        Raises
        ------
        ValueError
            For a bad ``shape``, ``grid`` or ``tolerance`` (named), a ``grid`` other than
            1 with a ``tolerance``, or a field that needs more than this machine's physical
            memory (12 bytes a pixel: the float64 field and the GPU's float32 one; the
            message says both, in bytes).
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> import glmls
        >>> with glmls.MLS([[0, 0], [5, 0]], [[0, 0], [5, 0]]) as m:
        ...     field = m.error_field((4, 6))
        >>> field.shape, float(field.max()) < 1e-6
        ((4, 6), True)
        """
        lattice = _field_lattice(shape, grid)  # validates shape and grid
        if tolerance is not None:
            mesh = self.mesh(lattice.shape, tolerance=check_adaptive("quads", grid, tolerance))
            values = error_at(self._kernel, mesh.source, lattice.shape)  # type: ignore[union-attr]
            return interpolate(mesh, values, lattice.shape)  # type: ignore[arg-type]
        return evaluate_error_field(self._kernel, lattice.shape, grid=lattice.grid)

    @forwarded
    def warp(
        self,
        image: object,
        *,
        method: str = default("quads"),
        interpolation: str = default("nearest"),
        grid: int = default(1),
        background: object = default(0),
        border: str = default("constant"),
        output_shape: Sequence[int] | None = default(None),
        origin: Sequence[float] | None = default(None),
        tolerance: float | None = default(None),
        options: WarpOptions | None = None,
    ) -> np.ndarray:
        """The image deformed by f, built on the GPU.

        Fold-overs: where deformed quads overlap, the first cell in row-major scan order of
        the source (smaller row, then column) shows, as the paper's marked pixels keep their
        colour; ``paper-quads`` (its squares), ``splat`` (its pixels) and ``backward`` (its
        first guess) follow the same order.

        Parameters
        ----------
        image : array_like
            H x W or H x W x C (C in 1..4), uint8, uint16, float32 or float64 (computed as
            float32). NaN and infinite pixels are carried as they are: with ``"linear"``
            interpolation an output pixel that blends a NaN is NaN, one that blends an
            infinity infinite (or NaN where its weight is 0: inf x 0). A masked array's mask
            is ignored (its data are warped).
        method : str, default "quads"
            ``"quads"``: forward with polygon interpolation (the mesh of pixel-square
            corners, step ``grid`` pixels, is deformed and each deformed quad filled);
            ``"splat"``: simple forward (each source pixel v written at round(f(v)), gaps
            and all); ``"backward"``: each output pixel u samples the source at s with
            f(s) = u (Newton's method from the rasterized inverse of the mesh, ``grid`` that
            guess's mesh); ``"backward-swap"``: s = the MLS map with p and q swapped, the
            shortcut of other MLS tools (only for comparison: it is not f's inverse);
            ``"paper-quads"``: the paper's pseudo-code exactly (squares of four adjacent
            pixel centres, each pixel inside a deformed square coloured by its nearest
            vertex; ``grid`` must be 1; ``"linear"`` blends the square's four vertices;
            :doc:`the warping guide </warp>` says how it differs from ``"quads"``).
        interpolation : {"nearest", "linear"}, default "nearest"
            ``"nearest"`` takes one source pixel's value (no new colours); ``"linear"``
            interpolates bilinearly (``splat`` ignores it).
        grid : int, default 1
            The mesh step in pixels.
        background : float or sequence of float, default 0
            What uncovered pixels hold: a scalar, or one value per channel; images with
            alpha (C = 2 or 4) get alpha 0 there unless ``background`` gives it. For an
            integer image, a whole number inside its dtype's range.
        border : {"constant", "edge", "symmetric", "reflect", "wrap"}, default "constant"
            What lies beyond the source image, with numpy.pad's meanings: ``"constant"``
            nothing (the background shows), ``"edge"`` the edge pixels repeated,
            ``"symmetric"`` mirrored with the edge pixel (``a b c | c b a``), ``"reflect"``
            mirrored about it (``a b c | b a``), ``"wrap"`` the image repeated. The backward
            methods sample by that rule; the forward methods extend the mesh past the image
            as far as the canvas needs (derived from f, see
            ``glmls.imaging.frame.border_margin``), so no canvas pixel keeps the
            background.
        output_shape : (int, int) or None, default None
            (H, W) of the output canvas (None: the input's). What f moves off the canvas is
            cut off; :meth:`bounds` gives the canvas that shows the whole deformed image.
        origin : (float, float) or None, default None
            Output pixel (column i, row j) shows the deformed plane's point ``origin`` +
            (i, j) (None: (0, 0)).
        tolerance : float or None, default None
            Pixels (``quads`` only; ``grid`` must stay 1): the error-bounded adaptive mesh
            instead of the regular one (:doc:`the adaptive mesh </adaptive>`): cells refined
            until the estimated distance between each output pixel's source point and f's
            inverse is within ``tolerance``, down to 1 px cells, and 1/2 or 1/4 px where f
            stretches.
            None: the regular mesh at ``grid``.
        options : WarpOptions or None, default None
            All of the above as one value; the keywords given explicitly here replace its
            fields (``m.warp(image, options=o, grid=4)`` is ``o`` with ``grid`` 4).

        Returns
        -------
        numpy.ndarray
            A new array of ``image``'s dtype and channels, of ``output_shape``.

        Raises
        ------
        ValueError
            For a bad image (empty, more than 4 channels, beyond the GL size limit) or a bad
            option (named; see :class:`glmls.WarpOptions`).
        TypeError
            For an image of another dtype, an option of the wrong type, or ``options`` that
            is not a :class:`glmls.WarpOptions`.
        glmls.ReleasedError
            After :meth:`release`.

        Warns
        -----
        glmls.BorderWarning
            Where a forward method's mesh, extended as far as it may go, still leaves canvas
            pixels uncovered with a border mode.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> image = np.arange(24, dtype=np.uint8).reshape(4, 6)
        >>> with glmls.MLS([[0, 0], [5, 3]], [[1, 0], [6, 3]]) as m:
        ...     print(m.warp(image, border="edge")[0].tolist())
        ...     options = glmls.WarpOptions(method="backward", interpolation="linear")
        ...     print(m.warp(image, options=options, background=255)[0].tolist())
        [0, 0, 1, 2, 3, 4]
        [255, 0, 1, 2, 3, 4]
        """
        chosen = WarpOptions.of(
            options,
            method=method,
            interpolation=interpolation,
            grid=grid,
            background=background,
            border=border,
            output_shape=output_shape,
            origin=origin,
            tolerance=tolerance,
        )
        return self._pipeline().warp(self, image, chosen)

    @forwarded
    def bounds(self, shape: Sequence[int], *, grid: int = 1) -> Bounds:
        """The bounding box of the deformed image of an image of ``shape``.

        The box of f at the corners of the pixel squares, every ``grid`` pixels (the mesh
        the ``quads`` are drawn with; 1 is closest to f), evaluated on the GPU. Its
        ``output_shape`` and ``origin`` give :meth:`warp` the canvas that shows all of it.

        Parameters
        ----------
        shape : (int, int)
            (H, W) of the image.
        grid : int, default 1
            The mesh step, pixels.

        Returns
        -------
        Bounds
            ``x0, y0, x1, y1`` in pixels.

        Raises
        ------
        ValueError
            For a bad ``shape`` or ``grid``, or a shape beyond the GL limit.
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> image = np.ones((4, 6), np.uint8)
        >>> with glmls.MLS([[0, 0]], [[2.5, -1]]) as m:
        ...     b = m.bounds(image.shape)
        ...     whole = m.warp(image, output_shape=b.output_shape, origin=b.origin)
        >>> b.origin, b.output_shape, whole.shape
        ((2.0, -1.0), (4, 7), (4, 7))
        """
        return self._pipeline().bounds(self, shape, grid=grid)

    @forwarded
    def coordinate_map(
        self,
        shape: Sequence[int],
        *,
        method: str = "backward",
        grid: int = 1,
        residual: bool = False,
        border: str = "constant",
        output_shape: Sequence[int] | None = None,
        origin: Sequence[float] | None = None,
    ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The map from output pixels to source points (x, y): f's inverse on a canvas.

        For each output pixel u = (column, row), the source point s with f(s) = u, solved
        on the GPU. Points outside the source image are kept (a remapper fills them by its
        border rule): ``cv2.remap(image, xy[..., 0], xy[..., 1], cv2.INTER_LINEAR)``, or per
        channel ``skimage.transform.warp(channel, np.stack([xy[..., 1], xy[..., 0]]))``, or
        ``scipy.ndimage.map_coordinates(channel, [xy[..., 1], xy[..., 0]], mode=...)``.
        Newton stops below 1e-3 px; pixels where it ends above 0.05 px (or, where f
        magnifies, above float32's rounding of the source point times f's stretch: no
        inverse found) hold its last iterate. :attr:`inverse` solves at any points instead
        of a canvas.

        Parameters
        ----------
        shape : (int, int)
            (H, W) of the source image.
        method : {"backward", "backward-swap"}, default "backward"
            f's inverse, or the swapped-handles shortcut.
        grid : int, default 1
            The first guess's mesh step, pixels.
        residual : bool, default False
            Also return |f(s) - u| per pixel.
        border : str, default "constant"
            The rule the remapper will use; any mode but ``"constant"`` makes Newton start
            from the mesh extended past the image (as :meth:`warp` does), so that points far
            outside the image are found too.
        output_shape, origin
            The output canvas, as in :meth:`warp` (default: the image of ``shape``).

        Returns
        -------
        numpy.ndarray or (numpy.ndarray, numpy.ndarray)
            (H, W, 2) float32 source points; with ``residual`` also (H, W) float32 pixels
            (NaN for ``backward-swap``).

        Raises
        ------
        ValueError
            For another method or a bad option (named).
        TypeError
            For a ``residual`` that is not a bool, or an option of the wrong type.
        glmls.ReleasedError
            After :meth:`release`.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     xy = m.coordinate_map((4, 6))
        >>> xy.shape, np.round(xy[0, 3], 3).tolist()
        ((4, 6, 2), [2.0, 0.0])
        """
        check_choice("method", method, ("backward", "backward-swap"))
        residual = check_flag("residual", residual)  # before any GPU work
        frame = {"output_shape": output_shape, "origin": origin}
        options = WarpOptions(method=method, grid=grid, border=border, **frame)  # type: ignore[arg-type]
        xy, res, _ = self._pipeline().coordinate_map(self, shape, options)
        return (xy, res) if residual else xy

    # -- lifetime --------------------------------------------------------------------------

    def release(self) -> None:
        """Free this object's GPU buffers.

        Safe to call twice; later use raises :class:`glmls.ReleasedError`. Leaving a ``with``
        block calls it.

        Examples
        --------
        >>> m = glmls.MLS([[0, 0]], [[1, 0]])
        >>> m.release()
        >>> m.release()  # a second time does nothing
        >>> m([[0, 0]])
        Traceback (most recent call last):
            ...
        glmls.errors.ReleasedError: ...
        """
        self._dropped = True  # made in a forked process: the helper has the GPU side
        if self._kernel is None or self._kernel.released:
            return
        self._drop_swapped()
        self._kernel.release()

    @property
    def released(self) -> bool:
        """Whether :meth:`release` has freed the GPU buffers.

        Examples
        --------
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     print(m.released)
        False
        >>> m.released
        True
        """
        return self._dropped if self._kernel is None else self._kernel.released

    def __enter__(self) -> MLS:
        if self.released:  # as a closed file refuses a with block
            raise ReleasedError("this MLS has been released; create a new one")
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def __repr__(self) -> str:
        c = self.config
        segments = f", {self._handles.segments} segments" if self._handles.segments else ""
        shape = "" if self.shape is None else f", shape={self.shape}"  # radius None: its diagonal
        return (
            f"MLS({self._handles.points} handles{segments}, transform={c.transform!r}, "
            f"weight={c.weight!r}, alpha={c.alpha}, s={c.s}, radius={c.radius}, "
            f"interpolating={c.interpolating}{shape}{', released' if self.released else ''})"
        )


class InverseMLS:
    """The inverse of an MLS map f as a transform, after scikit-image's protocol.

    ``inv(points)`` is, for each point u, the source point s with f(s) = u; ``inv.inverse``
    is f (the :class:`MLS`).

    Usually reached as :attr:`MLS.inverse`; ``InverseMLS(m)`` of a 3D MLS is its
    :class:`~glmls.mls3.InverseMLS3`, as ``m.inverse`` is. Solved on the GPU as the
    ``backward`` method solves each output pixel: a first guess from the rasterized inverse
    of the deformed mesh of the MLS's image (its ``shape``; without one, the smallest image
    from pixel (0, 0) that holds the source handles, its mesh coarser than ``grid`` where it
    would have more than ``glmls.imaging.pipeline.GUESS_MESH_POINTS`` points), extended
    past the image until its deformed border encloses the points
    (``glmls.imaging.frame.border_margin``, within that many mesh points) and drawn over
    a canvas that holds them, then Newton's method on f, stopping below 1e-4 px. f is the MLS's
    own, as ``m(points)`` evaluates it, so ``m(inv(u))`` is u within about 1e-3 px (float32
    on the GPU) where f stretches the plane little; where it magnifies, within float32's
    rounding of s times the stretch (a thousandfold: a few tenths of a pixel). A pixel
    here is the handles' unit, or less where the box of the handles (and of the MLS's
    ``shape``) is smaller than 32 units
    (``glmls.imaging.inverse.length_unit``), so that handles in metres get the inverse
    that the same handles in millimetres do.

    Which points have a preimage: u has one where Newton ends with |f(s) - u| <= 0.05 px
    (or 4 float32 steps of the coordinates where that is more, far from the image and the
    handles, s's steps times f's stretch there where f magnifies:
    ``glmls.imaging.inverse.accepted``), for s anywhere in the plane
    (not only inside the image: ``skimage.transform.warp`` then samples outside the image by
    its ``mode``, as glmls's ``border`` does). Elsewhere the
    row is NaN: where f leaves u uncovered (e.g. where a compact-support weight's reach
    ends, f jumps from the handles' transform to the identity and may skip a region; or a
    map that collapses the plane), and where Newton does not get there (u beyond the
    reach of the first guess's mesh, where Newton starts from u itself, unbounded). Where f
    folds, u has several preimages; the one of the first mesh cell in the source's scan
    order is found (as :meth:`MLS.warp` shows it), at the first guess's resolution (which
    depends on how far the points spread). Far from the image the accuracy follows
    float32: ~1e-7 of the coordinates (points near targets far from their sources are solved
    as the map moved back near them: as near ones).

    ``skimage.transform.warp(image, m.inverse)`` resamples an image by f: what
    ``m.warp(image, method="backward", interpolation="linear")`` draws, with skimage's
    ``mode`` in the place of ``border`` (``"edge"`` is the same rule; skimage's
    ``"constant"`` blends towards ``cval`` past the edge pixels' centres, where glmls reads
    the edge pixels up to the image's border). Its pixels
    whose point has no preimage are NaN, where glmls's hold ``background``:
    ``np.nan_to_num(out, nan=cval)``. At the jump of a compact weight's reach the two may
    differ by a pixel's width: there f comes within Newton's 0.05 px of points that it does
    not reach, and whether a solve accepts such a near preimage depends on where its Newton
    starts (the warp's first guess and this map's are drawn over different canvases).

    Parameters
    ----------
    forward : MLS
        The deformation f.
    grid : int, default 1
        The first guess's mesh step, pixels (coarser is faster for large images and few
        points, and may find another preimage where f folds); coarser where the mesh of
        the MLS's ``shape`` would hold more points than a 4096 x 4096 image's at ``grid``
        (the guess is drawn into at most that many texels).

    Raises
    ------
    TypeError
        If ``forward`` is not an :class:`MLS`, or, for a subclass, an MLS of another
        dimension.
    ValueError
        For a bad ``grid``.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> src = [[10, 10], [50, 10], [10, 40], [50, 40]]
    >>> dst = [[12, 8], [47, 14], [9, 42], [55, 38]]
    >>> with glmls.MLS(src, dst, shape=(50, 60)) as m:
    ...     s = m.inverse([[12, 8], [30, 25], [-100, 300]])
    ...     back = m(s)
    >>> np.round(s[0], 3).tolist()
    [10.0, 10.0]
    >>> bool(np.abs(back - [[12, 8], [30, 25], [-100, 300]]).max() < 1e-3)
    True

    Within its reach (20 px of (40, 30)) a compact-support weight moves the plane 10 px to
    the left; past it f is the identity: (55, 30) has no preimage.

    >>> with glmls.MLS([[40, 30]], [[30, 30]], weight="cressman", radius=20) as m:
    ...     s, valid = m.inverse([[20, 30], [55, 30], [70, 30]], return_valid=True)
    >>> np.round(s, 3).tolist(), valid.tolist()
    ([[30.0, 30.0], [nan, nan], [70.0, 30.0]], [True, False, True])
    """

    #: The dimension of the MLS it inverts; ``kinds`` maps each other dimension to the
    #: subclass that ``InverseMLS(m)`` makes for it (``glmls.mls3`` registers 3).
    dimension = 2
    kinds: ClassVar[dict[int, type[InverseMLS]]] = {}

    def __new__(cls, forward: object = None, *args: object, **kwargs: object) -> InverseMLS:
        dimension = getattr(forward, "dimension", None) if isinstance(forward, MLS) else None
        kind = InverseMLS.kinds.get(dimension) if cls is InverseMLS else None  # type: ignore[arg-type]
        return object.__new__(kind if kind is not None else cls)

    def __init__(self, forward: MLS, *, grid: int = 1) -> None:
        if not isinstance(forward, MLS):
            raise TypeError(f"forward must be a glmls.MLS, got {type(forward).__name__}")
        if forward.dimension != self.dimension:
            raise TypeError(
                f"forward must be a glmls.MLS of (N, {self.dimension}) handles for "
                f"{type(self).__name__}, got one of (N, {forward.dimension}): use its .inverse"
            )
        self._forward = forward
        self._grid = check_grid(grid)

    @property
    def grid(self) -> int:
        """The first guess's mesh step, pixels (read-only).

        Examples
        --------
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     print(m.inverse.grid, glmls.InverseMLS(m, grid=4).grid)
        1 4
        """
        return self._grid

    @property
    def inverse(self) -> MLS:
        """The forward map f: the :class:`MLS` this is the inverse of.

        Examples
        --------
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     print(m.inverse.inverse is m)
        True
        """
        return self._forward

    def __call__(
        self, points: object, *, return_valid: bool = False
    ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """f's inverse at ``points``, solved on the GPU.

        Parameters
        ----------
        points : array_like
            (K, 2) points u (x, y), finite, within ±1e6 px; (0, 2) gives (0, 2).
        return_valid : bool, default False
            Also return which rows have a preimage.

        Returns
        -------
        numpy.ndarray or (numpy.ndarray, numpy.ndarray)
            (K, 2) float64 source points s, NaN rows where u has no preimage (see
            :class:`InverseMLS`); with ``return_valid`` also the (K,) bool mask of the rows
            that have one.

        Raises
        ------
        ValueError
            For points of another shape, non-finite or beyond ±1e6 px, or a radius weight
            without radius or shape (as ``m(points)``).
        TypeError
            For points that are not real numbers, or a ``return_valid`` that is not a bool.
        glmls.ReleasedError
            After the MLS's :meth:`~MLS.release`.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> with glmls.MLS([[0, 0]], [[2, 0]]) as m:
        ...     print(m.inverse(np.zeros((0, 2))).shape, m.inverse([[5, 1]]).tolist())
        (0, 2) [[3.0, 1.0]]
        """
        return_valid = check_flag("return_valid", return_valid)
        s, valid = self._solve(_points(points))
        return (s, valid) if return_valid else s

    def _solve(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if forked_from_gl():  # see forwarded
            return in_helper(self._forward, "_solve", (points,), {}, grid=self.grid)
        return self._solved(points)

    def _solved(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = self._forward
        pipeline = m._pipeline()  # checks that the MLS is alive
        m.config.resolve_radius(m.shape)  # f needs a radius, as m(points) does
        shape, grid = self._guess_mesh()
        s, residual = pipeline.inverse_points(m, points, shape, grid=grid)
        targets = points - m.kernel.offset  # u as the GPU has it
        valid = accepted(m.scaling, targets, s, residual, unit=length_unit(m.kernel), f=m)
        s[~valid] = np.nan
        return s, valid

    def _guess_mesh(self) -> tuple[tuple[int, int], int]:
        """(H, W) of the image whose mesh gives the first guess, and that mesh's step: the
        MLS's ``shape`` at :attr:`grid`, or the least step within :data:`GUESS_MESH_LIMIT`
        points; without one, the smallest image (pixel (0, 0) at the
        origin) that holds the source handles, at least 1 x 1, at :attr:`grid` or the step
        that keeps its mesh within ``GUESS_MESH_POINTS`` points
        (handles far from the origin span an image of up to 1e12 pixels)."""
        m = self._forward
        if m.shape is not None:
            return m.shape, _guess_grid(m.shape, self.grid)
        points = m._handles.source_points()
        if not len(points):
            return (1, 1), self.grid
        x, y = (max(1, math.ceil(points[:, k].max() + 0.5)) for k in (0, 1))
        coarsest = math.ceil(math.sqrt(x * y / GUESS_MESH_POINTS))
        return (y, x), max(self.grid, coarsest)

    def residuals(self, src: object, dst: object) -> np.ndarray:
        """The distance between f's inverse at ``src`` and ``dst``, per point.

        Parameters
        ----------
        src, dst : array_like
            (K, 2) points each.

        Returns
        -------
        numpy.ndarray
            (K,) float64 |f^-1(src) - dst|, pixels; NaN where ``src`` has no preimage.

        Raises
        ------
        ValueError, TypeError, glmls.ReleasedError
            As :meth:`__call__`; ValueError also for lengths that differ.

        Examples
        --------
        >>> import numpy as np
        >>> import glmls
        >>> with glmls.MLS([[0, 0]], [[0, 2]]) as m:
        ...     print(np.round(m.inverse.residuals([[4, 4]], [[4, 1]]), 3).tolist())
        [1.0]
        """
        source, target = _points(src, "src"), _points(dst, "dst")
        if len(source) != len(target):
            raise ValueError(
                f"src and dst must have the same length, got {len(source)} and {len(target)}"
            )
        return np.hypot(*(self(source) - target).T)  # type: ignore[operator]

    def __repr__(self) -> str:
        grid = f", grid={self.grid}" if self.grid != 1 else ""
        return f"InverseMLS({self._forward!r}{grid})"


# ``__new__`` picks the class of the handles' dimension; the signature is ``__init__``'s.
for _kind in (MLS, InverseMLS):
    _kind.__signature__ = inspect.signature(
        _kind.__init__
    ).replace(  # type: ignore[attr-defined]
        parameters=list(inspect.signature(_kind.__init__).parameters.values())[1:],
        return_annotation=inspect.Signature.empty,
    )


#: The most points of the first guess's mesh of an MLS's ``shape``: the corners of a 4096 x
#: 4096 image, as many as the texels the guess is drawn into at most
#: (:data:`glmls.imaging.inverse.GUESS_MAX_TEXELS`), so that a finer mesh would add nothing.
#: Bytes an adaptive mesh takes at least per root cell: the 4 x 4 vertices of its quarter-step
#: lattice (evaluated for every root), each with its source and f in float64 (32 bytes).
ADAPTIVE_ROOT_BYTES = 16 * 32

GUESS_MESH_LIMIT = 4097 * 4097


def _mesh_lattice(
    shape: object, grid: object, point_bytes: int, *, adaptive: bool = False
) -> MeshLattice:
    """The corner lattice of ``shape`` at ``grid`` (an adaptive mesh's roots), refused where
    ``point_bytes`` a point exceed the machine's memory
    (:func:`~glmls.core.config.check_result_bytes`)."""
    lattice = MeshLattice.corners(shape, grid)
    what = "adaptive mesh" if adaptive else f"mesh at grid {lattice.grid}"
    check_result_bytes(f"{what} of shape {lattice.shape}", lattice.count * point_bytes)
    return lattice


def _field_lattice(shape: object, grid: object) -> MeshLattice:
    """The corner lattice of an error field of ``shape`` at ``grid``, refused where the
    field exceeds the machine's memory: the float64 field and the GPU's float32 one, and at
    ``grid`` > 1 its float32 lattice."""
    lattice = MeshLattice.corners(shape, grid)
    needed = math.prod(lattice.shape) * 12 + (lattice.count * 4 if lattice.grid > 1 else 0)
    check_result_bytes(f"error_field of shape {lattice.shape}", needed)
    return lattice


def _guess_grid(shape: tuple[int, int], grid: int) -> int:
    """The least mesh step from ``grid`` on whose mesh of ``shape`` holds at most
    :data:`GUESS_MESH_LIMIT` points: a shape of (10**6, 10**6) at grid 1 is a trillion points,
    evaluated band by band for hours, where a first guess needs far fewer."""

    def count(step: int) -> int:
        return (math.ceil(shape[0] / step) + 1) * (math.ceil(shape[1] / step) + 1)

    step = max(grid, math.ceil(math.sqrt(shape[0] * shape[1] / GUESS_MESH_LIMIT)))
    while count(step) > GUESS_MESH_LIMIT:
        step += 1
    return step


def _points(points: object, name: str = "points") -> np.ndarray:
    return check_coordinates(as_points(point_rows(points, 2), name), name)


#: The keywords of :class:`MLS` that :func:`warp` passes on (``shape`` is the image's;
#: ``spacing`` is a volume's, and these warp images).
MLS_KEYWORDS = frozenset(
    name
    for name, parameter in inspect.signature(MLS.__init__).parameters.items()
    if parameter.kind is parameter.KEYWORD_ONLY and name not in ("shape", "spacing")
)


def warp(image: object, src: object, dst: object, **options: object) -> np.ndarray:
    """Deform ``image`` by the MLS map taking handles ``src`` (p) to ``dst`` (q).

    The MLS's GPU objects are released before returning (the context's shared pipeline
    keeps its cached textures for the next call); keep an :class:`MLS` to warp many images
    with the same handles. The default radius is the image diagonal. In a process forked from
    one in which glmls used GL (a data loader's worker), it runs in a helper process started
    fresh, with the same result (see ``glmls.gl.context``).

    With (N, 3) handles it deforms a volume: ``MLS(src, dst, shape=volume.shape[:3],
    spacing=spacing, ...).warp(volume, **options)`` (:meth:`glmls.mls3.MLS3.warp`).

    Parameters
    ----------
    image : array_like
        H x W or H x W x C (C in 1..4), uint8, uint16, float32 or float64; with (N, 3)
        handles, a (D, H, W) or (D, H, W, C) volume of uint8, uint16, float32 or float64
        (computed as float32).
    src, dst : array_like
        (N, 2) handle points, or (N, 3) for a volume.
    **options
        Those of :meth:`MLS.warp` (the fields of :class:`WarpOptions`: ``method``,
        ``interpolation``, ``grid``, ``tolerance``, ``border``, ``background``,
        ``output_shape``, ``origin``; and ``options``, a :class:`WarpOptions` that those
        given replace fields of) and of :class:`MLS` (``src_segments``, ``dst_segments``,
        ``transform``, ``weight``, ``alpha``, ``s``, ``radius``, ``interpolating``,
        ``ctx``, ``storage``, ``bins``). A volume takes those of
        :class:`glmls.volume.VolumeOptions` instead of :class:`WarpOptions`, ``spacing``
        (dz, dy, dx) among them: the MLS's, for handles in physical units.

    Returns
    -------
    numpy.ndarray
        The deformed image, of ``image``'s dtype and channels.

    Raises
    ------
    TypeError
        For a keyword that is neither (all such named), or as :class:`MLS` and
        :meth:`MLS.warp`.
    ValueError
        As :class:`MLS` and :meth:`MLS.warp`; the warp options are checked before any GPU
        work.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> image = np.arange(24, dtype=np.uint8).reshape(4, 6)
    >>> out = glmls.warp(image, [[0, 0], [5, 3]], [[1, 0], [6, 3]], transform="similarity")
    >>> out[0].tolist()
    [0, 0, 1, 2, 3, 4]
    >>> glmls.warp(image, [[0, 0]], [[1, 0]], methd="splat")
    Traceback (most recent call last):
    ...
    TypeError: warp() got an unknown keyword methd

    A volume, by 3D handles (x, y, z), moved one voxel along z:

    >>> volume = np.zeros((6, 5, 4), np.uint8)
    >>> volume[2, 2, 1] = 9
    >>> src = np.array([[0.0, 0, 0], [3, 0, 0], [0, 4, 0], [0, 0, 5]])
    >>> np.argwhere(glmls.warp(volume, src, src + [0, 0, 1])).tolist()
    [[3, 2, 1]]
    """
    if options.get("ctx") is None and forked_from_gl():  # GL would hang here: a clean helper
        return helper.call(__name__, "warp", (image, src, dst), options)
    if dimension_of(src) == 3:
        return _warp_volume(image, src, dst, options)
    warp_options = {k: options.pop(k) for k in sorted(FIELDS | {"options"}) if k in options}
    _refuse_unknown(set(options) - MLS_KEYWORDS)
    chosen = WarpOptions.of(warp_options.pop("options", None), **warp_options)  # type: ignore[arg-type]
    array = np.asarray(image)
    shape = array.shape[:2] if array.ndim in (2, 3) and array.size else None
    with MLS(src, dst, shape=shape, **options) as m:  # type: ignore[arg-type]
        return m.warp(image, options=chosen)  # the caller's object: errors say what it was


def _refuse_unknown(unknown: set[str]) -> None:
    """``TypeError`` naming the keywords :func:`warp` takes neither for its MLS nor its warp."""
    if unknown:
        words = "unknown keywords" if len(unknown) > 1 else "an unknown keyword"
        raise TypeError(f"warp() got {words} {', '.join(sorted(unknown))}")


def _warp_volume(volume: object, src: object, dst: object, options: dict) -> np.ndarray:
    """:func:`warp` by (N, 3) handles: the MLS's keywords (and ``spacing``) make the MLS of
    the volume's shape, the rest are its warp's; a keyword of neither is a TypeError."""
    keywords = MLS_KEYWORDS | {"spacing"}
    made = {k: options.pop(k) for k in sorted(keywords) if k in options}
    _refuse_unknown(set(options) - VOLUME_WARP_KEYWORDS)
    array = np.asarray(volume)
    shape = array.shape[:3] if array.ndim in (3, 4) and array.size else None
    with MLS(src, dst, shape=shape, **made) as m:  # type: ignore[arg-type]
        return m.warp(volume, **options)
