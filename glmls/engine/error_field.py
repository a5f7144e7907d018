"""The MLS error field of "Extensions to the MLS method for image deformation", eq. (7), on the
GPU (``glmls/shaders/mls/error_field.comp.glsl``):

    E_MLS(v) = sum_i |p_i M_v + T_v - q_i|^2,

unweighted, at every pixel centre, or at the corners of a mesh every ``grid`` pixels and then
interpolated bilinearly to the pixel centres, also on the GPU.
"""

from __future__ import annotations

import numpy as np

from ..core.mesh import MeshLattice
from ..gl import bindings
from ..gl.dispatch import run_2d, set_uniforms
from .kernel import MLSKernel

__all__ = ["ERROR_PASS", "error_at", "error_field"]

ERROR_PASS = "mls/error_field.comp.glsl"
_ROW = 1024  # points per row of the 2-D dispatch of error_at


def error_field(kernel: MLSKernel, shape: tuple[int, int], *, grid: int = 1) -> np.ndarray:
    """E_MLS at every pixel of an image of ``shape`` (H, W), (H, W) float64 in square pixels.

    ``grid`` 1 evaluates MLS at every pixel centre; ``grid`` > 1 at the corner lattice every
    ``grid`` pixels, interpolated. Values are float32 on the GPU: expect a relative error of
    ~1e-6 to 1e-5.
    """
    lattice = MeshLattice.centres(shape) if grid == 1 else MeshLattice.corners(shape, grid)
    with kernel.gl.use():
        return _error_field(kernel, lattice, grid)


def error_at(kernel: MLSKernel, points: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """E_MLS at ``points`` ((K, 2) float64 pixels), (K,) float64 in square pixels; ``shape``:
    the image whose default radius applies. float32 on the GPU, as :func:`error_field`."""
    count = len(points)
    if count == 0:
        kernel.check_alive()
        return np.zeros(0)
    with kernel.gl.use():
        program = kernel.program(
            ERROR_PASS, {"MLS_ERROR_INTERPOLATE": False, "MLS_ERROR_POINTS": True}
        )
        kernel.bind(program, shape)
        source = kernel.scratch.buffer("error points", count * 8)
        source.write(kernel.scaling.to_gpu(points).tobytes())
        source.bind_to_storage_buffer(bindings.POINTS.index)
        values = kernel.scratch.buffer("error lattice", count * 4)
        values.bind_to_storage_buffer(bindings.ERROR_FIELD.index)
        dims = (min(count, _ROW), -(-count // _ROW))
        set_uniforms(program, {"u_dims": dims, "u_count": count})
        run_2d(program, dims, max_groups=kernel.gl.limits["max_work_groups_x"])
        kernel.gl.mgl.memory_barrier()
        data = values.read(size=count * 4)
    return np.frombuffer(data, np.float32).astype(np.float64) * kernel.scaling.scale**2


def _error_field(kernel: MLSKernel, lattice: MeshLattice, grid: int) -> np.ndarray:
    max_groups = kernel.gl.limits["max_work_groups_x"]
    program = kernel.program(ERROR_PASS, {"MLS_ERROR_INTERPOLATE": False})
    kernel.bind(program, lattice.shape)
    set_uniforms(program, lattice.uniforms(kernel.scaling))
    values = kernel.scratch.buffer("error lattice", lattice.count * 4)
    values.bind_to_storage_buffer(bindings.ERROR_FIELD.index)
    run_2d(program, lattice.dims, max_groups=max_groups)
    kernel.gl.mgl.memory_barrier()  # the read or the next pass sees the values written
    height, width = lattice.shape
    if grid == 1:
        data = values.read(size=width * height * 4)
    else:
        program = kernel.gl.compute(ERROR_PASS, {"MLS_ERROR_INTERPOLATE": True})
        values.bind_to_storage_buffer(bindings.ERROR_VERTICES.index)
        out = kernel.scratch.buffer("error field", width * height * 4)
        out.bind_to_storage_buffer(bindings.ERROR_FIELD.index)
        set_uniforms(program, {"u_vertex_dims": lattice.dims, "u_grid": grid})
        run_2d(program, (width, height), max_groups=max_groups)
        kernel.gl.mgl.memory_barrier()
        data = out.read(size=width * height * 4)
    field = np.frombuffer(data, dtype=np.float32).reshape(height, width)
    return field.astype(np.float64) * kernel.scaling.scale**2
