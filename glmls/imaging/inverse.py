"""The backward construction: for each output pixel u the source point s with f(s) = u
(``glmls/shaders/warp/inverse.comp.glsl``), and f's inverse at a list of points
(``warp/inverse_points.comp.glsl``).

The first guess is the rasterized piecewise linear inverse of the deformed mesh (the quads,
drawn with their source points instead of colours), then Newton's method on f refines it
(``warp/newton.glsl``, shared by both passes). ``backward-swap`` instead evaluates the MLS
map with p and q swapped, the shortcut of other MLS tools: the caller passes that map's
kernel.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import moderngl
import numpy as np

from ..core.handles import COORDINATE_LIMIT, Scaling, float32_rounding
from ..core.mesh import MeshLattice
from ..engine.kernel import MLSKernel
from ..engine.passes3 import STEP_BOX
from ..gl import bindings
from ..gl.context import GLContext, current
from ..gl.dispatch import SecondPass, run_1d, run_2d, set_uniforms
from ..gl.resources import Resources
from .frame import Frame
from .options import PipelineOptions
from .quads import CellScan
from .raster import MeshRaster

__all__ = [
    "ACCEPT_STEPS",
    "GUESS_MAX_TEXELS",
    "GUESS_TEXELS",
    "IDENTITY_FOUND",
    "NEWTON_ACCEPT",
    "NEWTON_MAX_STEP",
    "NEWTON_STEPS",
    "NEWTON_TOLERANCE",
    "POINTS_NEWTON_STEPS",
    "POINTS_TOLERANCE",
    "RESCUE_RUNS",
    "STRETCH_STEP",
    "InverseSolver",
    "accept_residual",
    "accepted",
    "guess_size",
    "length_unit",
    "stretch_at",
]

#: Newton on f stops below this residual |f(s) - u| (pixels) ...
NEWTON_TOLERANCE = 1e-3
#: ... or after this many steps; a pixel whose residual stays above NEWTON_ACCEPT (pixels) is
#: left uncovered (no source point found).
NEWTON_STEPS = 8
NEWTON_ACCEPT = 0.05
#: ... or this many float32 steps of the scaled coordinates, where that is more: far from
#: the scaling's centre (up to the 1e6 px that coordinates may reach) float32 cannot tell
#: f(s) from u to 0.05 px (its step is 0.0625 px at 9.5e5 px), ``warp/newton.glsl``'s
#: warp_accept.
ACCEPT_STEPS = 4.0


def accept_residual(
    scaling: Scaling,
    u: np.ndarray,
    s: np.ndarray,
    *,
    unit: float = 1.0,
    stretch: np.ndarray | None = None,
) -> np.ndarray:
    """(K,) the residual |f(s) - u| (pixels) up to which s counts as a preimage of the
    points ``u``, (K, D) pixels: :data:`NEWTON_ACCEPT` times ``unit`` (the length of a
    pixel, less for handles in a small box: :func:`length_unit`), or :data:`ACCEPT_STEPS`
    float32 steps of the larger scaled coordinate of u and s, times the scale, where more;
    s's steps times ``stretch`` ((K,), how many times f magnifies lengths at s:
    :func:`stretch_at`), where given: under a thousandfold magnification a float32 step of
    s moves f(s) by a tenth of a pixel (``warp/newton.glsl``'s warp_accept_at alike)."""
    rounding = float32_rounding(scaling, u, s, ACCEPT_STEPS, stretch)
    return np.maximum(NEWTON_ACCEPT * unit, rounding)


#: The difference step of :func:`stretch_at`, in length units (``warp/newton.glsl``'s
#: warp_damped_h).
STRETCH_STEP = 1 / 32


def stretch_at(f: Callable[[np.ndarray], np.ndarray], s: np.ndarray, step: float) -> np.ndarray:
    """(K,) how many times f magnifies lengths at the points ``s`` (K, D): along each axis
    the shorter of the differences of ``step`` on its two sides, the longest axis's, where
    f is smooth on every side (else, or not finite, 1; the GPU's ``common/stretch.glsl``
    alike). A side is smooth where halving the step halves the difference (within
    a quarter): a jump of f (where a compact weight's reach ends) within the step does not
    shrink with it, whether it lies on one side of s or, in a sliver between two reaches'
    edges, on both. ``f`` evaluates f at points."""
    count, dim = s.shape
    axes = np.eye(dim)
    # s, then per axis s + step, s + step / 2, s - step, s - step / 2
    offsets = np.concatenate(
        [np.zeros((1, dim)), *(axes[a] * [[1.0], [0.5], [-1.0], [-0.5]] * step for a in range(dim))]
    )
    probes = f((s[None] + offsets[:, None]).reshape(-1, dim)).reshape(len(offsets), count, dim)
    moved = np.linalg.norm(probes[1:] - probes[0], axis=2).reshape(dim, 2, 2, count)
    full, half = moved[:, :, 0], moved[:, :, 1]  # (axis, side, K)
    with np.errstate(invalid="ignore"):
        smooth = (np.abs(full - 2 * half) <= 0.25 * full).all(axis=(0, 1))
        stretch = np.where(smooth, full.min(axis=1).max(axis=0) / step, 1.0)
    return np.where(np.isfinite(stretch), stretch, 1.0)


def accepted(
    scaling: Scaling,
    u: np.ndarray,
    s: np.ndarray,
    residual: np.ndarray,
    *,
    unit: float,
    f: Callable[[np.ndarray], np.ndarray],
) -> np.ndarray:
    """(K,) bool: the points s (K, D) whose ``residual`` |f(s) - u| (pixels) at the points
    ``u`` lies within :func:`accept_residual`, with f's stretch at s (:func:`stretch_at`,
    steps of :data:`STRETCH_STEP` ``unit``) where the residual is above it without: where
    f magnifies, s's own float32 rounding shows in f(s). ``f`` evaluates f (as the GPU
    does) at points."""
    with np.errstate(invalid="ignore"):
        valid = residual <= accept_residual(scaling, u, s, unit=unit)
        doubt = ~valid & np.isfinite(s).all(axis=1) & np.isfinite(residual)
        doubt &= (np.abs(s) <= COORDINATE_LIMIT - 1).all(axis=1)
    if doubt.any():
        at = s[doubt]
        stretch = stretch_at(f, at, STRETCH_STEP * unit)
        accept = accept_residual(scaling, u[doubt], at, unit=unit, stretch=stretch)
        valid[doubt] = residual[doubt] <= accept
    return valid


#: How many times the backward method's second pass runs over the pixels the first left
#: (``warp/inverse.comp.glsl``'s ``u_run``): each run starts only from the pixels the run
#: before found, so that a region of pixels whose first guesses all miss (the mesh's cells
#: that f stretches over it, where the rigid fit's rotation turns fast) fills from its rim;
#: a run follows only where the run before found a pixel
#: (:meth:`~glmls.gl.dispatch.SecondPass.finish_runs`).
RESCUE_RUNS = 8


def length_unit(kernel: MLSKernel) -> float:
    """The length, pixels, of which the inverse at points takes its difference step and
    tolerances as fixed shares: 1, or less where the box of the handles (and of the MLS's
    image) has a half side below :data:`~glmls.engine.passes3.STEP_BOX`, as in 3D
    (:func:`glmls.engine.passes3.length_unit`): handles in metres get the inverse that the
    same handles in millimetres do."""
    scale = kernel.scaling.scale
    half = max(kernel.extent, scale / 2 if scale > 1 else 0.0)  # scale: the image's box too
    return min(1.0, half / STEP_BOX) if half > 0 else 1.0


#: The flag (the fourth value of a point's result) of a point u where f is the identity, whose
#: preimage is u itself (``warp/inverse_points.comp.glsl``).
IDENTITY_FOUND = 2.0

#: f's inverse at a list of points stops below this residual instead (pixels): a list is
#: short next to an image's pixels, and its points are read back as numbers. Where float32
#: noise in f keeps Newton above it, the last iterate (within NEWTON_ACCEPT) is kept.
POINTS_TOLERANCE = 1e-4
#: ... in at most this many steps (a list's points are few: more steps cost little) ...
POINTS_NEWTON_STEPS = 16
#: ... each step at most this long (scaled units, a tenth of the image: far from the
#: solution, Newton's step may overshoot), or 4 texels of the first guess where longer;
#: unbounded where no texel gave a guess (Newton from u itself).
NEWTON_MAX_STEP = 0.2
#: The first guess at a list of points is drawn over a canvas that holds them all, with at most
#: this many texels or 4 per point (whichever is more, up to GUESS_MAX_TEXELS, 256 MiB of
#: RGBA32F): coarser than a pixel where the points spread far; Newton refines the guess read
#: at the texel under each point.
GUESS_TEXELS = 1 << 18
GUESS_MAX_TEXELS = 1 << 24


def guess_size(frame: Frame, points: int, limit: int) -> tuple[int, int]:
    """(W, H) texels of the first guess over ``frame`` for ``points`` points: the frame's
    pixels, or fewer, each texel the same fraction of the frame, to stay within
    max(:data:`GUESS_TEXELS`, 4 ``points``) texels (at most :data:`GUESS_MAX_TEXELS`) and
    ``limit`` texels a side."""
    width, height = frame.size
    budget = min(max(GUESS_TEXELS, 4 * points), GUESS_MAX_TEXELS)
    step = max(1.0, math.sqrt(width * height / budget), width / limit, height / limit)
    if step == 1.0:
        return width, height
    return max(1, min(limit, math.ceil(width / step))), max(1, min(limit, math.ceil(height / step)))


class InverseSolver:
    """The backward map of a pipeline (its GL objects are the pipeline's)."""

    def __init__(
        self,
        gl: GLContext,
        resources: Resources,
        options: PipelineOptions,
        cells: CellScan,
        raster: MeshRaster,
    ) -> None:
        self._gl = gl
        self._resources = resources
        self._options = options
        self._cells = cells
        self._raster = raster

    @current
    def solve(
        self,
        kernel: MLSKernel,
        lattice: MeshLattice,
        frame: Frame,
        *,
        swap: bool = False,
        border: int = 0,
    ) -> moderngl.Texture:
        """The RGBA32F texture (s.x, s.y, residual in pixels, covered) of the output pixels of
        ``frame`` for ``lattice``'s image (``lattice`` is the first guess's mesh: its grid,
        and its margin past the image for a border mode). ``swap``: ``kernel`` is the
        swapped-handles map, evaluated once per pixel (residual -1). ``border`` 0
        (constant): pixels whose source point lies outside the image are not covered; other
        modes keep them. A second pass takes the pixels whose Newton ended above the residual
        accepted, and (constant border) those whose point lies just outside the image: by at
        most Newton's longest step where the mesh covered the pixel, else a few pixels. It
        runs damped Newton from the first's point and the pixel where Newton did not
        converge, then from the covered neighbours' points (for a point outside, only those
        far from it, which show another sheet of a fold), and runs again (up to
        :data:`RESCUE_RUNS` runs) from the points of the pixels the run before found. Leaves
        the texture's framebuffer bound."""
        height, width = lattice.shape
        # first, so that a pass the driver cannot run is refused before the first guess's
        # mesh, which with many handles over a large image takes long on a CPU renderer
        defines = {"WARP_SWAP": swap, "WARP_NEWTON_STEPS": NEWTON_STEPS, "WARP_BORDER": border}
        program = kernel.program("warp/inverse.comp.glsl", defines)
        # damped Newton over the pixels where the first pass's ends above the residual
        # accepted (next to a fold or a handle), or just outside the image (a fold may give
        # another preimage inside), in a second pass over those alone
        rescue = None
        if not swap:
            rescue = kernel.program("warp/inverse.comp.glsl", defines | {"WARP_RESCUE": True})
        framebuffer = self._resources.framebuffer("coords", frame.size)
        texture = self._resources.texture("coords", frame.size, 4, "f4")
        if not swap:
            framebuffer.use()
            framebuffer.viewport = (0, 0, *frame.size)
            self._resources.fill(texture, (0.0, 0.0, 0.0, 0.0))
            drawn = self._options.compute_quads and self._cells.draw(
                kernel, None, lattice, frame, linear=False, coords=True, flip_y=False
            )
            if not drawn:
                self._raster.draw(
                    kernel, None, lattice, frame, linear=False, coords=True, flip_y=False
                )
        sc = kernel.scaling
        uniforms = {
            **frame.uniforms(kernel),
            "u_source_size": (width, height),
            "u_center": sc.center,
            "u_scale": sc.scale,
            "u_tolerance": NEWTON_TOLERANCE,
            "u_newton_unit": 1.0,  # an image's pixels
            "u_accept": NEWTON_ACCEPT,
            "u_accept_steps": ACCEPT_STEPS,
        }
        second = SecondPass(self._gl)
        kernel.bind(program, lattice.shape)
        set_uniforms(program, uniforms)
        if rescue is not None:
            second.start(program)
        self._gl.mgl.memory_barrier()
        texture.bind_to_image(bindings.INVERSE_MAP.index, read=True, write=True)
        run_2d(program, frame.size, max_groups=self._gl.limits["max_work_groups_x"])
        if rescue is not None:
            kernel.bind(rescue, lattice.shape)
            set_uniforms(rescue, uniforms)
            second.finish_runs(rescue, RESCUE_RUNS)
        self._gl.mgl.memory_barrier()
        return texture

    @current
    def solve_points(
        self,
        kernel: MLSKernel,
        lattice: MeshLattice,
        frame: Frame,
        points: np.ndarray,
        *,
        shape: tuple[int, int] | None,
        limit: int,
    ) -> np.ndarray:
        """(K, 4) float32 for ``points`` ((K, 2) float64 pixels, K >= 1, inside ``frame``):
        (s.x, s.y) scaled, the residual |f(s) - u| in pixels, and 1 where the mesh of
        ``lattice`` gave the first guess (0: Newton started at u). The guess is drawn over
        ``frame`` in :func:`guess_size` texels (``limit``: the GL limit of a side); f is that
        of an image of ``shape`` (None: the kernel's own), as :meth:`glmls.MLS.__call__`'s.
        Newton's difference step and tolerances are shares of :func:`length_unit`. Leaves
        the guess's framebuffer bound."""
        unit = length_unit(kernel)
        size = guess_size(frame, len(points), limit)
        program = kernel.program(  # first, as in solve
            "warp/inverse_points.comp.glsl", {"WARP_NEWTON_STEPS": POINTS_NEWTON_STEPS}
        )
        framebuffer = self._resources.framebuffer("guess", size)
        texture = self._resources.texture("guess", size, 4, "f4")
        framebuffer.use()
        framebuffer.viewport = (0, 0, *size)
        self._resources.fill(texture, (0.0, 0.0, 0.0, 0.0))
        fill = {"linear": False, "coords": True, "flip_y": False}
        drawn = (
            size == frame.size
            and self._options.compute_quads
            and self._cells.draw(kernel, None, lattice, frame, **fill)  # type: ignore[arg-type]
        )
        if not drawn:
            self._raster.draw(kernel, None, lattice, frame, **fill)  # type: ignore[arg-type]
        kernel.bind(program, shape)
        sc = kernel.scaling
        texel = max(frame.size[0] / size[0], frame.size[1] / size[1])  # pixels
        uniforms = {
            **frame.uniforms(kernel),
            "u_guess_size": size,
            "u_center": sc.center,
            "u_scale": sc.scale,
            "u_tolerance": POINTS_TOLERANCE * unit,
            "u_newton_unit": unit,
            "u_max_step": max(NEWTON_MAX_STEP, 4 * texel / sc.scale),
        }
        set_uniforms(program, uniforms)
        count = len(points)
        source = self._resources.buffer("inverse_points", count * 8)
        points = points - kernel.offset  # u as the GPU has it: the canvas's frame too
        source.write(np.ascontiguousarray(sc.to_gpu(points), dtype=np.float32))
        out = self._resources.buffer("inverse_out", count * 16)
        self._gl.mgl.memory_barrier()
        source.bind_to_storage_buffer(bindings.POINTS.index)
        out.bind_to_storage_buffer(bindings.DEFORMED.index)
        texture.use(bindings.COORDS.index)
        run_1d(program, count, max_groups=self._gl.limits["max_work_groups_x"])
        self._gl.mgl.memory_barrier()
        found = np.frombuffer(out.read(size=count * 16), np.float32).reshape(count, 4).copy()
        return self._rescue_points(kernel, shape, points, found, uniforms)

    def _rescue_points(
        self, kernel: MLSKernel, shape, points: np.ndarray, found: np.ndarray, uniforms: dict
    ) -> np.ndarray:
        """``found`` (the first dispatch's results) with its points whose residual is above
        the one accepted solved again by damped Newton, from their point and from u, in a
        second dispatch over those alone (``WARP_RESCUE``, as the backward method's second
        pass, with the first's ``uniforms``)."""
        sc = kernel.scaling
        with np.errstate(invalid="ignore"):
            accept = accept_residual(
                sc, points, sc.from_gpu(found[:, :2]), unit=uniforms["u_newton_unit"]
            )
            left = ~(found[:, 2] <= accept)
        if not left.any():
            return found
        index = np.flatnonzero(left)
        program = kernel.program(
            "warp/inverse_points.comp.glsl",
            {"WARP_NEWTON_STEPS": POINTS_NEWTON_STEPS, "WARP_RESCUE": True},
        )
        kernel.bind(program, shape)
        set_uniforms(program, uniforms)
        source = self._resources.buffer("inverse_points", len(index) * 8)
        source.write(np.ascontiguousarray(sc.to_gpu(points[index]), dtype=np.float32))
        out = self._resources.buffer("inverse_out", len(index) * 16)
        out.write(np.ascontiguousarray(found[index]))
        self._gl.mgl.memory_barrier()
        source.bind_to_storage_buffer(bindings.POINTS.index)
        out.bind_to_storage_buffer(bindings.DEFORMED.index)
        run_1d(program, len(index), max_groups=self._gl.limits["max_work_groups_x"])
        self._gl.mgl.memory_barrier()
        found[index] = np.frombuffer(out.read(size=len(index) * 16), np.float32).reshape(-1, 4)
        return found
