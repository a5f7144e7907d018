"""The passes that evaluate the 3D f on the GPU (``glmls/shaders/mls3/points.comp.glsl``): at
a list of points, read back in one piece (f, and M or the Jacobian J = df/dv where asked);
or on a regular lattice, written into a GL buffer that stays on the GPU. The same program
writes a mesh's vertex records for :mod:`glmls.engine.deform3`.
"""

from __future__ import annotations

from collections.abc import Sequence

import moderngl
import numpy as np

from ..core.handles import float32_rounding
from ..gl import bindings
from ..gl.dispatch import SecondPass, run_1d, set_uniforms
from .kernel3 import MLSKernel3

__all__ = [
    "INVERSE3_PASS",
    "JACOBIAN_FLOOR",
    "JACOBIAN_STEP",
    "MESH_NORMALS",
    "POINTS3_PASS",
    "STEP_BOX",
    "evaluate_lattice3",
    "evaluate_points3",
    "invert_points3",
    "jacobian_steps",
    "jacobian_uniforms",
    "largest_coordinates",
    "length_unit",
    "points3_program",
    "run_points3",
]

POINTS3_PASS = "mls3/points.comp.glsl"
#: The central differences' step (voxels) of J where it is not the closed form's derivative
#: (near degenerate handle sets, ``mls3_eval_jacobian``) and of the inverse's Newton: small
#: against the handles' spacing (the error is second order in it), large against float32's
#: spacing of the coordinates (~1e-7 of the volume's extent; the steps are the ones float32
#: really took).
JACOBIAN_STEP = 0.05
#: The half side of the box of the handles (and volume) from which on J's step and the
#: inverse's tolerances are JACOBIAN_STEP, NEWTON_TOLERANCE3 and NEWTON_ACCEPT handle units
#: (voxels); in a smaller box they shrink with it, so that handles in metres get the
#: derivatives and inverse that the same handles in millimetres do.
STEP_BOX = 16.0
#: J's step is at least this share of the larger of the box's half side and the point's
#: distance from its centre: float32's rounding of f stays about eps32 / JACOBIAN_FLOOR
#: (5e-4) of J, in units however large (micrometres) and far from the handles.
JACOBIAN_FLOOR = 2.0**-12
#: What a points pass writes besides f.
OUTPUTS = ("f", "matrix", "jacobian")
#: A points pass's outputs: :data:`OUTPUTS`, or a mesh's vertex records (f, J, the deformed
#: normal and det J; :mod:`glmls.engine.deform3`).
PROGRAM_OUTPUTS = (*OUTPUTS, "mesh")
#: Where the mesh pass takes vertex normals from: none, the mesh's own, or later (a mesh with
#: faces: the records keep the vertex for the passes over faces, and the normals pass of
#: :mod:`glmls.engine.deform3` writes the normal over it; ``MLS3_MESH_NORMALS`` 0, 1, 2).
MESH_NORMALS = ("none", "given", "later")


def points3_program(
    kernel: MLSKernel3,
    *,
    lattice: bool,
    output: str = "f",
    normals: str = "none",
    stage: int = 0,
    flat: bool = False,
) -> moderngl.ComputeShader:
    """The compiled 3D points pass: on a lattice (``lattice``) or a list; ``output`` one of
    ``"f"``, ``"matrix"`` (f and M), ``"jacobian"`` (f and J), ``"mesh"`` (a mesh's vertex
    records, with ``normals`` one of :data:`MESH_NORMALS`, and with ``flat`` a flag per
    vertex, ``MLS3_MESH_FLAT``: where J is the derivative of affine's plain solve, or, by
    central differences, took that solve at each of its probes).
    ``stage``: of the two passes of :func:`run_points3`, 1 or 2; 0 for one pass."""
    if output not in PROGRAM_OUTPUTS:
        raise ValueError(f"unknown output {output!r}; choose one of {', '.join(PROGRAM_OUTPUTS)}")
    if normals not in MESH_NORMALS:
        raise ValueError(f"unknown normals {normals!r}; choose one of {', '.join(MESH_NORMALS)}")
    mesh = output == "mesh"
    defines = {
        "MLS3_LATTICE": lattice,
        "MLS3_WRITE_MATRIX": output == "matrix",
        "MLS3_WRITE_JACOBIAN": output in ("jacobian", "mesh"),
        "MLS3_MESH": mesh,
        "MLS3_MESH_NORMALS": MESH_NORMALS.index(normals) if mesh else 0,
        "MLS3_MESH_FLAT": mesh and flat,
        "MLS3_STAGE": stage,
    }
    return kernel.program(POINTS3_PASS, defines)


def run_points3(
    kernel: MLSKernel3,
    count: int,
    *,
    output: str,
    normals: str = "none",
    shape: tuple[int, int, int] | None = None,
    max_groups: int,
    flat: bool = False,
) -> None:
    """Run the points pass of ``output`` over the ``count`` points bound (and its outputs
    bound), in two stages: the first takes only the solve's plain branch (and, where it
    writes J, J's shared passes over the handles) and lists the points that need more (the
    solve's branches for degenerate moments, and J through them; J's central differences,
    six full evaluations of f, where a point snaps to a handle: ``mls3_eval_jacobian``),
    the second computes those again with everything, one invocation per listed point. So
    the other points do not wait for them: a GPU's warp, and a CPU renderer's vector
    whatever its lanes' mask, runs a branch for all its lanes where one takes it. ``flat``:
    as :func:`points3_program`'s."""
    first, second_program = (
        points3_program(
            kernel, lattice=False, output=output, normals=normals, stage=stage, flat=flat
        )
        for stage in (1, 2)
    )
    for program in (first, second_program):
        kernel.bind(program, shape)
        set_uniforms(program, jacobian_uniforms(kernel))
    later = kernel.scratch.buffer("points_later3", 16 + 4 * count)
    second = SecondPass(kernel.gl, later, count)
    second.start(first)
    run_1d(first, count, max_groups=max_groups)
    second.finish(second_program)


def length_unit(kernel: MLSKernel3) -> float:
    """The length, handle units, of which J's step and the inverse's tolerances are the
    fixed shares: 1, or less in a box of half side below :data:`STEP_BOX`."""
    scale = kernel.scaling.scale
    half = max(kernel.extent, scale / 2 if scale > 1 else 0.0)  # scale: the volume's box too
    return min(1.0, half / STEP_BOX) if half > 0 else 1.0


def jacobian_uniforms(kernel: MLSKernel3) -> dict[str, float]:
    """The uniforms of J's central differences (where J takes them, and the inverse's
    Newton; scaled units): the step of
    :func:`length_unit`, and the least step per unit of the larger of the box's half side
    and the point's largest scaled coordinate (``u_jacobian_floor``, ``u_jacobian_box``)."""
    scale = kernel.scaling.scale
    half = max(kernel.extent, scale / 2 if scale > 1 else 0.0)
    return {
        "u_jacobian_step": JACOBIAN_STEP * length_unit(kernel) / scale,
        "u_jacobian_floor": JACOBIAN_FLOOR,
        "u_jacobian_box": half / scale,
    }


def jacobian_steps(
    kernel: MLSKernel3, points: np.ndarray, *, largest: np.ndarray | None = None
) -> np.ndarray:
    """(K,) the central differences' step of J at each of ``points`` (K, 3), handle units:
    what ``mls3_jacobian_step`` of the shaders takes. ``largest``: the points'
    :func:`largest_coordinates`, where already at hand (``points`` is then not read)."""
    values = jacobian_uniforms(kernel)
    if largest is None:
        largest = largest_coordinates(kernel.scaling.to_gpu(points))
    least = values["u_jacobian_floor"] * np.maximum(values["u_jacobian_box"], largest)
    return np.maximum(values["u_jacobian_step"], least) * kernel.scaling.scale


def largest_coordinates(scaled: np.ndarray) -> np.ndarray:
    """(K,) float32 the largest |coordinate| of each of the (K, 3) float32 points ``scaled``
    (as :meth:`~glmls.core.handles.Scaling.to_gpu` gives them, the coordinates the GPU
    reads; a view of wider rows too)."""
    # column by column: numpy's max over the short axis of (K, 3) rows is ~10x slower
    largest = np.abs(scaled[:, 0])
    for axis in (1, 2):
        np.maximum(largest, np.abs(scaled[:, axis]), out=largest)
    return largest


def evaluate_points3(
    kernel: MLSKernel3,
    points: np.ndarray,
    *,
    output: str = "f",
    shape: tuple[int, int, int] | None = None,
    max_groups: int | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """f at ``points`` ((K, 3) float64 voxels) as (K, 3) float64 (the kernel's
    :attr:`~glmls.engine.kernel3.MLSKernel3.offset` added in float64), with M (``output=
    "matrix"``) or the Jacobian J = df/dv (``"jacobian"``, the derivative of the solve's
    closed form, or of the float64 solve near degenerate handle sets; central differences of
    :data:`JACOBIAN_STEP` voxels where a point snaps to a handle; J[r, c] = d f_c / d v_r) as
    (K, 3, 3) float64, else None.
    ``shape``: the volume whose diagonal is the default radius (None: the kernel's own).
    One dispatch per ``max_groups`` work groups (the GL limit by default), one read-back."""
    if output not in OUTPUTS:
        raise ValueError(f"unknown output {output!r}; choose one of {', '.join(OUTPUTS)}")
    count = len(points)
    if count == 0:
        kernel.check_alive()
        return np.zeros((0, 3)), (None if output == "f" else np.zeros((0, 3, 3)))
    kernel.radius(shape)  # a radius weight without one is refused before any GPU work
    with kernel.gl.use():
        scratch = kernel.scratch
        source = scratch.buffer("points3", count * 12)
        source.write(np.ascontiguousarray(kernel.scaling.to_gpu(points)))
        source.bind_to_storage_buffer(bindings.POINTS.index)
        f_out = scratch.buffer("f3", count * 12)
        f_out.bind_to_storage_buffer(bindings.DEFORMED.index)
        if output != "f":
            scratch.buffer("M3", count * 36).bind_to_storage_buffer(bindings.MATRICES.index)
        groups = max_groups if max_groups is not None else kernel.gl.limits["max_work_groups_x"]
        run_points3(kernel, count, output=output, shape=shape, max_groups=groups)
        kernel.gl.mgl.memory_barrier()
        d = np.frombuffer(f_out.read(size=count * 12), np.float32).reshape(count, 3)
        if kernel.gl.loop_limit is not None and np.isnan(d).any():
            cut = int(np.isnan(d).any(axis=1).sum())
            raise ValueError(
                f"f at {cut:,} of {count:,} points: {kernel.count:,} 3D handles walked more "
                f"loop iterations than Mesa's llvmpipe runs in one shader invocation "
                f"({kernel.gl.loop_limit:,}; f would leave handles out); use fewer handles "
                f"or a GPU"
            )
        # f = v + (f - v): v keeps its float64 digits, and f is v itself where d is 0; the
        # targets' offset is added in float64 (MLSKernel3.offset)
        f = points + d.astype(np.float64) * kernel.scaling.scale
        if kernel.offset.any():
            f += kernel.offset
        if output == "f":
            return f, None
        m = np.frombuffer(scratch.cached("M3").read(size=count * 36), np.float32)
        return f, m.astype(np.float64).reshape(count, 3, 3)


def evaluate_lattice3(
    kernel: MLSKernel3,
    target: moderngl.Buffer,
    *,
    origin: Sequence[float],
    step: Sequence[float],
    size: Sequence[int],
    first: int = 0,
    count: int | None = None,
    shape: tuple[int, int, int] | None = None,
    max_groups: int | None = None,
) -> int:
    """f (in voxels, float32 x, y, z per point) at the points of the lattice ``origin + (i,
    j, k) * step`` (voxels; ``size`` = (nx, ny, nz) points, i fastest) into ``target`` from
    its start, without read-back: ``count`` points (all by default) from lattice index
    ``first`` (i + nx (j + ny k)). ``shape``: the volume whose diagonal is the default radius
    (None: the kernel's own). Returns the number of points written."""
    nx, ny, nz = (int(n) for n in size)
    total = nx * ny * nz
    count = total - first if count is None else count
    if first < 0 or count < 0 or first + count > total:
        raise ValueError(f"points {first}..{first + count} are not in a lattice of {total}")
    if target.size < count * 12:
        raise ValueError(f"{count} points (12 bytes each) do not fit in {target.size} bytes")
    if count == 0:
        return 0
    scaling = kernel.scaling
    with kernel.gl.use():
        program = points3_program(kernel, lattice=True)
        kernel.bind(program, shape)
        o = scaling.to_gpu(np.asarray([origin], np.float64))[0]
        s = np.asarray(step, np.float64) / scaling.scale
        set_uniforms(
            program,
            {
                "u_lattice3_origin": tuple(float(c) for c in o),
                "u_lattice3_step": tuple(float(c) for c in s),
                "u_lattice3_dims": (nx, ny, nz),
                "u_first": first,
            },
        )
        target.bind_to_storage_buffer(bindings.DEFORMED.index)
        groups = max_groups if max_groups is not None else kernel.gl.limits["max_work_groups_x"]
        run_1d(program, count, max_groups=groups)
    return count


INVERSE3_PASS = "mls3/inverse.comp.glsl"
#: Newton's steps on f(s) = u at most, from each of the two starts.
NEWTON_STEPS3 = 24
#: Newton stops below this residual |f(s) - u| (voxels) ...
NEWTON_TOLERANCE3 = 1e-4
#: ... or, where more, this many float32 steps of the scaled coordinates (:func:`_converged`).
NEWTON_FLOAT_STEPS3 = 4.0
#: A step moves s by at most this share of the scaled extent (the handles' and volume's box) ...
NEWTON_MAX_STEP3 = 0.25
#: ... times |s| / NEWTON_FAR3 where s's largest scaled coordinate |s| is beyond NEWTON_FAR3
#: (the box spans at most 1 each way about its centre): far out f tends to the fit of all
#: the handles, its curvature falls as 1 / |s|, and the start (the swapped MLS, whose fit of
#: q to p is not the inverse of that of p to q but for a rigid one) misses by a share of |s|
#: that fixed steps could not cover in NEWTON_STEPS3.
NEWTON_FAR3 = 4.0
#: The dispatches more a point whose evaluations ran out takes where the driver caps a
#: shader's loop iterations (:func:`invert_points3`).
NEWTON_ROUNDS3 = 8


def invert_points3(
    kernel: MLSKernel3,
    points: np.ndarray,
    guess: np.ndarray,
    *,
    shape: tuple[int, int, int] | None = None,
    max_groups: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """f's inverse at ``points`` u ((K, 3) float64 voxels) by Newton's method on the GPU from
    ``guess`` (K, 3), then from u where that does not converge: the source points s (K, 3)
    and the residuals |f(s) - u| (K,), voxels, the better end of each point's starts.
    ``shape`` as :func:`evaluate_points3`."""
    count = len(points)
    if count == 0:
        kernel.check_alive()
        return np.zeros((0, 3)), np.zeros(0)
    kernel.radius(shape)  # as evaluate_points3
    s, residual = _start3(kernel, points, guess, shape=shape, max_groups=max_groups)
    left = np.flatnonzero(~_converged(kernel, points, s, residual))
    if len(left):
        ends, again = _start3(
            kernel, points[left], points[left], shape=shape, max_groups=max_groups
        )
        _keep_better(s, residual, left, ends, again)
    return s, residual


def _converged(
    kernel: MLSKernel3, points: np.ndarray, s: np.ndarray, residual: np.ndarray
) -> np.ndarray:
    """(K,) bool: Newton's end s reached ``points`` u: its residual within
    NEWTON_TOLERANCE3, or within NEWTON_FLOAT_STEPS3 float32 steps of the larger scaled
    coordinate of u and s where that is more. Far from the scaling's centre float32 cannot
    bring f(s) nearer u than that, and a start from u itself, where f is the identity out of
    the handles' reach, would otherwise replace the preimage found by one far from it."""
    targets = points - kernel.offset  # u in the GPU's frame of the targets
    floor = float32_rounding(kernel.scaling, targets, s, NEWTON_FLOAT_STEPS3)
    return residual <= np.maximum(NEWTON_TOLERANCE3 * length_unit(kernel), floor)


def _keep_better(
    s: np.ndarray, residual: np.ndarray, rows: np.ndarray, ends: np.ndarray, again: np.ndarray
) -> np.ndarray:
    """Where the new ends of ``rows`` have smaller residuals (``again``), they replace those
    rows of ``s`` and ``residual``; returns which of ``rows`` did (a NaN residual never
    does)."""
    better = again < residual[rows]
    s[rows[better]] = ends[better]
    residual[rows[better]] = again[better]
    return better


def _start3(
    kernel: MLSKernel3,
    points: np.ndarray,
    starts: np.ndarray,
    *,
    shape: tuple[int, int, int] | None,
    max_groups: int | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Newton from ``starts``: the best ends and their residuals (voxels).

    Where the driver caps an invocation's loop iterations (llvmpipe), a dispatch makes only
    the evaluations of f that fit (``mls3_evaluations``, shaders/mls3/newton.glsl); a point
    whose evaluations ran out before Newton ended resumes from its best point in a dispatch
    of its own, up to NEWTON_ROUNDS3 more while each brings its residual down, so that every
    point's rounds depend on that point alone. A GPU's dispatch makes them all."""
    s, residual, cut = _newton3(kernel, points, starts, shape=shape, max_groups=max_groups)
    rows = np.flatnonzero(cut)
    for _ in range(NEWTON_ROUNDS3):
        if len(rows) == 0:
            break
        ends, again, more = _newton3(
            kernel, points[rows], s[rows], shape=shape, max_groups=max_groups
        )
        better = _keep_better(s, residual, rows, ends, again)
        rows = rows[better & more]
    return s, residual


def _newton3(
    kernel: MLSKernel3,
    points: np.ndarray,
    guess: np.ndarray,
    *,
    shape: tuple[int, int, int] | None,
    max_groups: int | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One dispatch of INVERSE3_PASS from ``guess``: the best ends, their residuals (voxels)
    and where the evaluations ran out before Newton ended."""
    count = len(points)
    scaling = kernel.scaling
    with kernel.gl.use():
        program = kernel.program(INVERSE3_PASS)
        scratch = kernel.scratch
        # the GPU's f is that of the targets less the kernel's offset: so are the u it meets
        targets = points - kernel.offset if kernel.offset.any() else points
        data = np.concatenate([scaling.to_gpu(targets), scaling.to_gpu(guess)], axis=1)
        source = scratch.buffer("inverse3", count * 24)
        source.write(np.ascontiguousarray(data, dtype=np.float32))
        source.bind_to_storage_buffer(bindings.POINTS.index)
        out = scratch.buffer("inverse3_out", count * 16)
        out.bind_to_storage_buffer(bindings.DEFORMED.index)
        kernel.bind(program, shape)
        set_uniforms(
            program,
            {
                **jacobian_uniforms(kernel),
                "u_tolerance": NEWTON_TOLERANCE3 * length_unit(kernel) / scaling.scale,
                "u_max_step": NEWTON_MAX_STEP3,
                "u_far": NEWTON_FAR3,
                "u_steps": NEWTON_STEPS3,
            },
        )
        groups = max_groups if max_groups is not None else kernel.gl.limits["max_work_groups_x"]
        run_1d(program, count, max_groups=groups)
        kernel.gl.mgl.memory_barrier()
        result = np.frombuffer(out.read(size=count * 16), np.float32).reshape(count, 4)
    s = scaling.from_gpu(result[:, :3])
    cut = result[:, 3] < 0  # a NaN residual is an end
    return s, np.abs(result[:, 3]).astype(np.float64) * scaling.scale, cut
