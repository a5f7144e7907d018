"""The GPU MLS in three dimensions: the handles of one configuration on the GPU, and what
every pass over the 3D f needs to compile and bind.

A pass is a compute shader that does ``#include "mls3/core.glsl"`` and calls ``mls3_eval``,
``mls3_f``, ``mls3`` or ``mls3_f_voxels`` (``glmls/shaders/mls3/core.glsl`` documents them);
:meth:`MLSKernel3.program` compiles it with the kernel's defines and :meth:`MLSKernel3.bind`
sets its uniforms and binds the handles. The handles share the 2D kernel's storages
(:mod:`glmls.engine.storage`: two rows per handle, ``(p, 0)`` and ``(q - p, 0)``, scaled), its
weights (``mls/weighting.glsl``) and its uniforms (:func:`~glmls.engine.kernel.weight_uniforms`).
"""

from __future__ import annotations

from collections.abc import Mapping

import moderngl
import numpy as np

from ..core.config import MLSConfig, transform_code
from ..core.handles import Scaling
from ..core.handles3 import no_radius3, volume_diagonal
from ..core.mesh3 import coplanar
from ..core.weights import GAUSSIAN_CAP, GAUSSIAN_TOLERANCE
from ..errors import ReleasedError
from ..gl.context import GLContext
from ..gl.dispatch import set_uniforms
from ..gl.resources import Resources
from .kernel import DEFAULT_STORAGE, check_loop_budget, weight_uniforms
from .loops import check_plain_loops3
from .storage import HandleStorage, check_storage, make_storage, resolve_storage

__all__ = ["UNROLL_SLOTS3", "MLSKernel3", "unroll_slots3"]

#: Handle counts up to which the 3D passes read the handles at constant indices
#: (``MLS3_UNROLL``); more go through a loop.
UNROLL_SLOTS3 = (16, 64)


def unroll_slots3(count: int) -> int:
    """The ``MLS3_UNROLL`` slots for ``count`` handles: the smallest of
    :data:`UNROLL_SLOTS3` that holds them, or 0 (a loop)."""
    return next((slots for slots in UNROLL_SLOTS3 if count <= slots), 0)


class MLSKernel3:
    """The (N, 3) handles of one 3D MLS on the GPU, for ``config`` on context ``gl``.

    ``shape``: the volume (D, H, W) whose diagonal is the radius where ``config.radius`` is
    None, in the handles' units ((D dz, H dy, W dx) for voxels of a spacing); ``storage``:
    ``auto`` or one of :data:`glmls.engine.storage.STORAGES`. Empty until :meth:`upload`.
    """

    def __init__(
        self,
        gl: GLContext,
        config: MLSConfig,
        *,
        shape: tuple[float, float, float] | None = None,
        storage: str = DEFAULT_STORAGE,
    ) -> None:
        check_storage(storage)
        self.gl = gl
        self.config = config
        self.shape = shape
        self.scaling = Scaling((0.0, 0.0, 0.0), 1.0)  # type: ignore[arg-type]
        #: t (3,) float64, handle units: the GPU holds the targets q - t
        #: (:func:`~glmls.core.handles3.fit_offset3`), f read back gets t added in float64.
        self.offset = np.zeros(3)
        self.extent = 0.0
        self._storage_request = storage
        self._storage: HandleStorage | None = None
        self._rows = np.zeros((0, 4), np.float32)
        self._count = 0
        self.sources = np.zeros((0, 3))
        self.flat = False
        #: Scratch buffers of the passes (points in, f, M or J out).
        self.scratch = Resources(gl, "this MLS")
        self._released = False

    def upload(
        self,
        src: np.ndarray,
        dst: np.ndarray,
        scaling: Scaling,
        offset: np.ndarray | None = None,
    ) -> None:
        """Put validated (N, 3) handles ``src`` -> ``dst`` on the GPU in the coordinates of
        ``scaling``, the targets less ``offset`` (3,) (None: 0), which every f read back
        and every f in voxels of the shaders gets added. On error (too many handles for the
        storage) nothing changes."""
        self.check_alive()
        shift = np.zeros(3) if offset is None else np.asarray(offset, np.float64).reshape(3)
        count = len(src)
        check_plain_loops3(self.gl.loop_limit, count)
        slots = unroll_slots3(count)
        rows = np.zeros((2 * max(count, slots, 1), 4), np.float32)
        rows[0 : 2 * count : 2, :3] = scaling.to_gpu(src)
        # e = q - t - p, 0 if q - t = p
        rows[1 : 2 * count : 2, :3] = ((dst - shift) - src) / scaling.scale
        with self.gl.use():
            name = resolve_storage(self._storage_request, self.gl.mgl, len(rows))
            storage = self._storage
            if storage is None or storage.name != name:
                storage = make_storage(name, self.gl.mgl)
            if len(rows) > storage.capacity:
                capacity = storage.capacity
                if storage is not self._storage:
                    storage.release()
                raise ValueError(
                    f"{count} 3D handles (2 rows each) exceed the {name} handle storage's "
                    f"capacity of {capacity} rows on this GL driver; use storage='ssbo'"
                )
            try:
                storage.upload(rows)
            except BaseException:  # the storage before keeps the handles before
                if storage is not self._storage:
                    storage.release()
                raise
            if storage is not self._storage:
                if self._storage is not None:
                    self._storage.release()
                self._storage = storage
        self._rows, self._count, self.scaling, self.offset = rows, count, scaling, shift
        #: The handles' sources p, (N, 3) float64 in their units.
        self.sources = np.array(src, dtype=np.float64).reshape(-1, 3)
        #: Whether f maps into one plane wherever its solve is affine's plain A^-1 B: the
        #: transform is affine and the targets are :func:`~glmls.core.mesh3.coplanar`.
        self.flat = self.config.transform == "affine" and coplanar(
            np.asarray(dst, dtype=np.float64).reshape(-1, 3)
        )
        both = np.concatenate([src, dst - shift]) if count else np.zeros((1, 3))
        #: half the largest side of the handles' box, in their units
        self.extent = float((both.max(axis=0) - both.min(axis=0)).max()) / 2

    # -- what the passes need -----------------------------------------------------------

    @property
    def count(self) -> int:
        """Handles."""
        return self._count

    @property
    def storage(self) -> str:
        """The handle storage in use (``auto`` resolved for the handle count)."""
        return self._storage.name if self._storage is not None else self._storage_request

    def radius(self, shape: tuple[int, int, int] | None = None) -> float | None:
        """R in the handles' units: the configured radius, else the diagonal of ``shape``
        (the kernel's own when None); None for a weight without a radius. ``ValueError`` for
        a radius weight with neither."""
        config = self.config
        if not config.uses_radius or config.radius is not None:
            return config.radius
        shape = shape if shape is not None else self.shape
        if shape is None:
            raise no_radius3(config.weight)
        return volume_diagonal(shape)

    def defines(self) -> dict[str, object]:
        """The ``#define`` values of ``glmls/shaders/mls3/`` for this configuration."""
        config = self.config
        entry = config.weight_entry
        storage = self._storage
        unroll = storage is not None and storage.unrolls
        defines = {
            "MLS_WEIGHT_FUNCTION": entry.glsl_function,
            "MLS_WEIGHT_USES_S": entry.uses_s,
            "MLS_GAUSSIAN_TOLERANCE": GAUSSIAN_TOLERANCE,
            "MLS_GAUSSIAN_CAP": GAUSSIAN_CAP,
            "MLS_REACH_GAUSSIAN": entry.support == "gaussian",
            "MLS_WEIGHT_RADIUS": entry.support == "radius",
            # as in 2D (glmls.engine.kernel.config_defines)
            "MLS_WEIGHT_NEXT": entry.uses_s or config.interpolating,
            "MLS_TRANSFORM": transform_code(config.transform),
            "MLS_INTERPOLATING": config.interpolating,
            "MLS_ALPHA_ONE": config.alpha == 1.0,
            "MLS3_UNROLL": unroll_slots3(self._count) if unroll else 0,
        } | dict(storage.defines if storage is not None else {})
        if entry.edge64:  # its float64 version for the handles near d = R (mls/weighting.glsl)
            defines["MLS_WEIGHT_FUNCTION64"] = entry.glsl_function64
        if entry.slope:  # dw/d(d2) for the Jacobian (mls3/core.glsl, mls3_eval_jacobian)
            defines["MLS_SLOPE_FUNCTION"] = entry.glsl_slope
        return defines

    def uniforms(self, shape: tuple[int, int, int] | None = None) -> dict[str, object]:
        """The uniforms of ``glmls/shaders/mls3/core.glsl`` for a volume of ``shape`` (the
        kernel's own when None), in scaled units."""
        scaling = self.scaling
        weighting = weight_uniforms(
            self.config, scaling.scale, self.radius(shape), extent=self.extent / scaling.scale
        )
        weighting.pop("u_tiny_s")
        return weighting | {
            "u_mls3_count": self._count,
            "u_mls3_center": tuple(float(c) for c in scaling.center),
            "u_mls3_scale": float(scaling.scale),
            "u_mls3_offset": tuple(float(c) for c in self.offset),
        }

    def program(
        self, entry: str, defines: Mapping[str, object] | None = None
    ) -> moderngl.ComputeShader:
        """The compute program of ``entry`` (a pass including ``mls3/core.glsl``) with this
        kernel's defines and ``defines``."""
        self.check_alive()
        check_loop_budget(self.gl, entry, self._count)
        with self.gl.use():
            return self.gl.compute(entry, self.defines() | dict(defines or {}))

    def bind(
        self,
        program: moderngl.ComputeShader | moderngl.Program,
        shape: tuple[int, int, int] | None = None,
    ) -> None:
        """Make ``program`` (any program including ``mls3/core.glsl``, compiled with
        :meth:`defines`) evaluate this kernel's f, with the radius of a volume of ``shape``:
        its uniforms, and the handles bound."""
        self.check_alive()
        with self.gl.use():
            uniforms = self.uniforms(shape)
            self._storage.bind(program)  # type: ignore[union-attr]
            set_uniforms(program, uniforms)

    # -- life -----------------------------------------------------------------------------

    def check_alive(self) -> None:
        """``ReleasedError`` once released (or its context), ``GLUnavailableError`` in a
        process forked from the one that made it."""
        if self._released:
            raise ReleasedError("this MLS has been released; create a new one")
        self.gl.check_usable()

    @property
    def released(self) -> bool:
        return self._released

    def release(self) -> None:
        """Free the handle storage and the scratch buffers. Idempotent."""
        if self._released:
            return
        if self.gl.usable and self._storage is not None:
            with self.gl.use():
                self._storage.release()
        self.scratch.release()
        self._released = True
