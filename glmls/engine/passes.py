"""The passes that evaluate f on the GPU (``glmls/shaders/mls/points.comp.glsl``): at a list of
points, read back; or on a :class:`~glmls.core.mesh.MeshLattice`, band by band into a buffer
that stays on the GPU for the image passes.
"""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..gl import bindings
from ..gl.dispatch import run_1d, set_uniforms
from .kernel import MLSKernel
from .loops import LANES

__all__ = [
    "POINTS_PASS",
    "POINTS_PER_INVOCATION",
    "deformed_lattice",
    "evaluate_lattice",
    "evaluate_points",
    "lattice_bands",
    "points_program",
]

POINTS_PASS = "mls/points.comp.glsl"
#: Points each invocation of the pass evaluates (``MLS_POINTS_PER_INVOCATION``): with two,
#: each handle is read once for both (``mls_eval_pair``): the pass ~1.1x faster on llvmpipe
#: at 16-64 handles, 1.3x at 256.
POINTS_PER_INVOCATION = 2


def points_program(
    kernel: MLSKernel, *, lattice: bool, with_matrix: bool
) -> moderngl.ComputeShader:
    """The compiled points pass: on a lattice (``lattice``) or a list, with M or without."""
    defines = {
        "MLS_LATTICE": lattice,
        "MLS_WRITE_MATRIX": with_matrix,
        "MLS_POINTS_PER_INVOCATION": POINTS_PER_INVOCATION,
    }
    return kernel.program(POINTS_PASS, defines)


def _max_groups(kernel: MLSKernel, max_groups: int | None) -> int:
    return max_groups if max_groups is not None else kernel.gl.limits["max_work_groups_x"]


def evaluate_points(
    kernel: MLSKernel,
    points: np.ndarray,
    *,
    with_matrix: bool,
    shape: tuple[int, int] | None = None,
    max_groups: int | None = None,
    keep: tuple[moderngl.Buffer, int] | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """f at ``points`` ((K, 2) float64 pixels) as (K, 2) float64, and M as (K, 2, 2) float64
    where ``with_matrix`` (else None). ``shape``: the image whose default radius applies
    (None: the kernel's own). ``max_groups``: work groups per dispatch (the GL limit by
    default). ``keep`` (buffer, byte offset, a multiple of 8): the displacements f - v as
    the GPU computed them (K x 2 float32, scaled coordinates) are written there, for later
    passes (and read back from there: no copy)."""
    count = len(points)
    if count == 0:
        kernel.check_alive()
        return np.zeros((0, 2)), (np.zeros((0, 2, 2)) if with_matrix else None)
    with kernel.gl.use():
        groups = _max_groups(kernel, max_groups)
        return _evaluate_points(kernel, points, with_matrix, shape, groups, keep)


def _evaluate_points(kernel, points, with_matrix, shape, max_groups, keep):
    count = len(points)
    f_out, at = (kernel.scratch.buffer("f", count * 8), 0) if keep is None else keep
    if at % 8 or f_out.size < at + count * 8:
        raise ValueError(f"keep: {count} points do not fit at byte {at} of {f_out.size}")
    d, m = _run_points(kernel, points, with_matrix, shape, max_groups, f_out, at)
    cut = np.flatnonzero(np.isnan(d).any(axis=1)) if kernel.gl.loop_limit is not None else []
    if len(cut):
        # past a CPU renderer's cap on an invocation's loops (f NaN): the lanes that it
        # counts together walked apart; again with each point alone in its vector of lanes
        alone = LANES * POINTS_PER_INVOCATION
        again = np.repeat(points[cut], alone, axis=0)
        scratch = kernel.scratch.buffer("f alone", len(again) * 8)
        d2, m2 = _run_points(kernel, again, with_matrix, shape, max_groups, scratch, 0)
        d[cut] = d2[::alone]
        if m is not None:
            m[cut] = m2[::alone]  # type: ignore[index]
        _check_whole(kernel, d)
        if keep is not None:
            f_out.write(np.ascontiguousarray(d), offset=at)  # what later passes read
    # f = v + (f - v) + t: v keeps its float64 digits, f is v + t where d is exactly 0, and
    # the targets' offset t (MLSKernel.offset) joins in float64
    f = points + d.astype(np.float64) * kernel.scaling.scale + kernel.offset
    return f, None if m is None else m.astype(np.float64).reshape(count, 2, 2)


def _run_points(kernel, points, with_matrix, shape, max_groups, f_out, at):
    """The points pass at ``points`` into ``f_out`` from byte ``at``: f - v (K, 2) and M
    (K, 4) float32 as read back (M None without ``with_matrix``)."""
    count = len(points)
    program = points_program(kernel, lattice=False, with_matrix=with_matrix)
    scratch = kernel.scratch
    source = scratch.buffer("points", count * 8)
    source.write(np.ascontiguousarray(kernel.scaling.to_gpu(points)))  # no copy into bytes
    source.bind_to_storage_buffer(bindings.POINTS.index)
    kernel.bind(program, shape)
    f_out.bind_to_storage_buffer(bindings.DEFORMED.index)
    set_uniforms(program, {"u_out_first": at // 8})
    if with_matrix:
        scratch.buffer("M", count * 16).bind_to_storage_buffer(bindings.MATRICES.index)
    run_1d(program, count, max_groups=max_groups, per_invocation=POINTS_PER_INVOCATION)
    kernel.gl.mgl.memory_barrier()  # the shader's writes before the read
    d = np.frombuffer(f_out.read(size=count * 8, offset=at), np.float32).reshape(count, 2)
    if not with_matrix:
        return d.copy(), None
    m = np.frombuffer(scratch.cached("M").read(size=count * 16), np.float32).reshape(count, 4)
    return d.copy(), m.copy()


def _check_whole(kernel: MLSKernel, f: np.ndarray) -> None:
    """``ValueError`` where the points pass marked f NaN (``mls/points.comp.glsl``): on a
    driver that caps an invocation's loop iterations, the walks near those points took more
    than the cap (at a list of points, each alone in its vector of lanes), and f would have
    left handles out."""
    if kernel.gl.loop_limit is None:
        return
    cut = np.isnan(f).any(axis=1)
    if cut.any():
        crowd = (
            "thousands of handles crowd the spatial bins near them; use bins=False or a GPU"
            if kernel.bins is not None
            else "use fewer handles or a GPU"
        )
        raise ValueError(
            f"f at {int(cut.sum()):,} of {len(f):,} points walked more handles than Mesa's "
            f"llvmpipe runs loop iterations in one shader invocation "
            f"({kernel.gl.loop_limit:,}; f would leave handles out): {crowd}"
        )


def evaluate_lattice(
    kernel: MLSKernel,
    lattice: MeshLattice,
    target: moderngl.Buffer,
    *,
    first_row: int = 0,
    rows: int | None = None,
    max_groups: int | None = None,
    offset: int = 0,
) -> int:
    """f (scaled) at ``rows`` rows of ``lattice`` from ``first_row`` (all by default) into
    ``target`` from byte ``offset`` (a multiple of the GL storage buffer offset alignment);
    returns the number of points written. The radius is the one of the lattice's image."""
    nx, ny = lattice.dims
    rows = ny - first_row if rows is None else rows
    with kernel.gl.use():
        program = points_program(kernel, lattice=True, with_matrix=False)
        kernel.bind(program, lattice.shape)
        set_uniforms(program, lattice.uniforms(kernel.scaling) | {"u_first_row": first_row})
        target.bind_to_storage_buffer(bindings.DEFORMED.index, offset=offset)
        run_1d(
            program,
            nx * rows,
            max_groups=_max_groups(kernel, max_groups),
            per_invocation=POINTS_PER_INVOCATION,
        )
        if kernel.walks_checked:
            kernel.gl.mgl.memory_barrier()
            f = target.read(size=nx * rows * 8, offset=offset)
            _check_whole(kernel, np.frombuffer(f, np.float32).reshape(-1, 2))
    return nx * rows


def deformed_lattice(kernel: MLSKernel, lattice: MeshLattice) -> np.ndarray:
    """f at every point of ``lattice``, read back: (K, 2) float64 pixels in the lattice's
    row-major order (the radius that of the lattice's image)."""
    buffer = kernel.scratch.buffer("mesh", lattice.count * 8)
    count = evaluate_lattice(kernel, lattice, buffer)
    kernel.gl.mgl.memory_barrier()
    return kernel.deformed(np.frombuffer(buffer.read(size=count * 8), np.float32).reshape(-1, 2))


def lattice_bands(
    kernel: MLSKernel,
    lattice: MeshLattice,
    target: moderngl.Buffer,
    rows_per_band: int,
    *,
    overlap: int | None = None,
    reverse: bool = False,
) -> Iterator[tuple[int, tuple[int, int]]]:
    """Evaluate f on ``lattice`` band by band into ``target`` (large enough for
    ``rows_per_band`` rows); yields (first row, (points per row, rows)) once each band is in
    the buffer. Bands of cells overlap by a row (or ``overlap``, see
    :meth:`MeshLattice.bands`), computed identically in both; ``reverse``: the last band
    first."""
    mgl = kernel.gl.mgl
    nx = lattice.dims[0]
    bands = list(lattice.bands(rows_per_band, overlap=overlap))
    for first, rows in reversed(bands) if reverse else bands:
        # Draws issued before may still read the buffer (llvmpipe shades fragments later, at
        # a flush): order them before it is overwritten.
        mgl.memory_barrier()
        evaluate_lattice(kernel, lattice, target, first_row=first, rows=rows)
        mgl.memory_barrier()
        yield first, (nx, rows)
