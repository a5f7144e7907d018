"""f of a 3D MLS on the GPU for the volume construction: the lattice band pass
(``volume/lattice.comp.glsl``) and Newton's method for the backward method
(``volume/newton.comp.glsl``, and its fold pass's ``volume/folds.comp.glsl``), all
evaluating the kernel's f (``mls3/core.glsl``) through ``volume/field.glsl``, in source
voxels of the volume's spacing."""

from __future__ import annotations

import moderngl
import numpy as np

from ..core.handles3 import checked_extent
from ..engine.kernel3 import MLSKernel3
from ..engine.passes3 import evaluate_points3
from ..gl import bindings
from ..gl.dispatch import SecondPass, run_1d, set_uniforms
from .fields import NEWTON_ACCEPT, NEWTON_TOLERANCE, slab_corner
from .frame import CornerLattice

__all__ = ["NEWTON_STEPS", "NEWTON_TOLERANCE", "KernelField", "pending_bytes"]

#: Newton on f stops below :data:`~glmls.volume.fields.NEWTON_TOLERANCE` or after this many
#: steps (and as many halvings of a step that raised the residual, in all); a voxel whose
#: residual stays above :data:`~glmls.volume.fields.NEWTON_ACCEPT` is left uncovered.
NEWTON_STEPS = 12
#: Each step goes at most this share of the volume's largest side (far from the solution
#: Newton's step may overshoot).
NEWTON_MAX_STEP = 0.1


class KernelField:
    """The :class:`~glmls.volume.fields.Field` of an :class:`~glmls.engine.kernel3.MLSKernel3`
    for voxels of ``spacing`` (dz, dy, dx); ``shape`` (D, H, W), the volume whose diagonal is
    the default radius of a radius weight (None: the kernel's own), measured in the handles'
    units as the points are: the diagonal of (D dz, H dy, W dx); ``ValueError`` where that
    extent passes the coordinate range."""

    def __init__(
        self,
        kernel: MLSKernel3,
        spacing: tuple[float, float, float] = (1.0, 1.0, 1.0),
        shape: tuple[int, int, int] | None = None,
    ) -> None:
        self.kernel = kernel
        dz, dy, dx = spacing
        self.scale = np.array([dx, dy, dz], dtype=np.float64)
        #: What the kernel takes the default radius's diagonal of: the volume's extent in
        #: the handles' units (the kernel's passes take it as a shape, and only for that).
        self.shape = None if shape is None else checked_extent(shape, spacing, name="volume")

    @property
    def sources(self) -> np.ndarray:
        """The handles' sources p in source voxels, (N, 3)."""
        return self.kernel.sources / self.scale

    def _uniforms(self) -> dict[str, object]:
        return {"u_volume_scale": tuple(float(c) for c in self.scale)}

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        f, _ = evaluate_points3(self.kernel, points * self.scale, output="f", shape=self.shape)
        return f / self.scale

    def fill(
        self, lattice: CornerLattice, first: int, layers: int, target: moderngl.Buffer
    ) -> None:
        nx, ny, _ = lattice.dims
        count = nx * ny * layers
        kernel = self.kernel
        # two stages: the second computes the points whose solve needs more than its plain
        # branch (volume/lattice.comp.glsl)
        first_pass, second_pass = (
            kernel.program("volume/lattice.comp.glsl", {"VOLUME_LATTICE_STAGE": stage})
            for stage in (1, 2)
        )
        uniforms = lattice.uniforms() | self._uniforms() | {"u_first_layer": first}
        with kernel.gl.use():
            later = kernel.scratch.buffer("lattice_later3", 16 + 4 * count)
            second = SecondPass(kernel.gl, later, count)
            for program in (first_pass, second_pass):
                kernel.bind(program, self.shape)
                set_uniforms(program, uniforms)
            target.bind_to_storage_buffer(bindings.VOLUME_LATTICE.index)
            second.start(first_pass)
            run_1d(first_pass, count, max_groups=kernel.gl.limits["max_work_groups_x"])
            second.finish(second_pass)
            kernel.gl.mgl.memory_barrier()

    def refine(
        self,
        coords: moderngl.Buffer,
        size: tuple[int, int, int],
        origin: tuple[float, float, float],
        shape: tuple[int, int, int],
        *,
        constant: bool,
        first: int | tuple[int, int, int] = 0,
        pending: moderngl.Buffer | None = None,
    ) -> None:
        """Newton's method on the GPU from the first guesses in ``coords`` (see
        ``volume/newton.comp.glsl``) for a slab of ``size`` (W, H, slices) whose voxel
        (i, j, k) shows ``origin`` + (i, j, ``first`` + k), or + (i, j, k) + ``first`` given
        as the slab's first voxel (x, y, z) (source voxels), of a volume of
        ``shape``: a first pass evaluates f once per voxel and lists those not yet within the
        tolerance in ``pending`` (at least :func:`pending_bytes` of the slab's voxels; None:
        one made here), which a second pass finishes."""
        kernel = self.kernel
        width, height, depth = size
        count = width * height * depth
        defines = {"WARP_NEWTON_STEPS": NEWTON_STEPS, "WARP_BORDER": 0 if constant else 1}
        first_pass = kernel.program("volume/newton.comp.glsl", defines | {"VOLUME_NEWTON_FIRST": 1})
        second_pass = kernel.program("volume/newton.comp.glsl", defines)
        own = pending is None
        if own:
            pending = kernel.gl.mgl.buffer(reserve=pending_bytes(count))
        elif pending.size < pending_bytes(count):
            raise ValueError(
                f"the pending list holds {pending.size} bytes, not {pending_bytes(count)}"
            )
        uniforms = self._newton_uniforms(size, origin, first, shape)
        try:
            with kernel.gl.use():
                second = SecondPass(kernel.gl, pending, count)
                for program in (first_pass, second_pass):
                    kernel.bind(program, self.shape)
                    set_uniforms(program, uniforms)
                coords.bind_to_storage_buffer(bindings.VOLUME_COORDS.index)
                kernel.gl.mgl.memory_barrier()
                second.start(first_pass)
                groups = kernel.gl.limits["max_work_groups_x"]
                run_1d(first_pass, count, max_groups=groups)
                second.finish(second_pass)
                kernel.gl.mgl.memory_barrier()
        finally:
            if own:
                pending.release()

    def rescue(
        self,
        neighbours: moderngl.Buffer,
        coords: moderngl.Buffer,
        listed: moderngl.Buffer,
        *,
        size: tuple[int, int, int],
        first: tuple[int, int, int],
        window: tuple[tuple[int, int, int], tuple[int, int, int]],
        origin: tuple[float, float, float],
        shape: tuple[int, int, int],
        constant: bool,
    ) -> None:
        """The fold pass's Newton on the GPU (``volume/folds.comp.glsl``), one invocation per
        voxel of ``listed`` (see :meth:`glmls.volume.fields.Field.rescue`)."""
        kernel = self.kernel
        defines = {"WARP_NEWTON_STEPS": NEWTON_STEPS, "WARP_BORDER": 0 if constant else 1}
        program = kernel.program("volume/folds.comp.glsl", defines)
        uniforms = self._newton_uniforms(size, origin, first, shape)
        uniforms |= {"u_window_first": window[0], "u_window_size": window[1]}
        with kernel.gl.use():
            kernel.bind(program, self.shape)
            set_uniforms(program, uniforms)
            neighbours.bind_to_storage_buffer(bindings.VOLUME_NEIGHBOURS.index)
            coords.bind_to_storage_buffer(bindings.VOLUME_COORDS.index)
            SecondPass(kernel.gl, listed, size[0] * size[1] * size[2]).finish(program)
            kernel.gl.mgl.memory_barrier()

    def _newton_uniforms(self, size, origin, first, shape) -> dict[str, object]:
        """The uniforms of ``volume/newton.glsl`` for a slab of ``size`` from voxel ``first``
        showing ``origin`` + the voxel, of a volume of ``shape``."""
        return self._uniforms() | {
            "u_slab_size": size,
            "u_frame_origin": origin,
            "u_slab_first": slab_corner(first),
            "u_volume_size": shape[::-1],
            "u_tolerance": NEWTON_TOLERANCE,
            "u_accept": NEWTON_ACCEPT,
            "u_max_step": NEWTON_MAX_STEP * max(shape),
        }


def pending_bytes(voxels: int) -> int:
    """Bytes of the list of :meth:`KernelField.refine` for a slab of ``voxels``: a 16-byte
    header and 16 bytes a voxel (each may need the second pass)."""
    return 16 + 16 * voxels
