"""Numerical analysis of a deformation (section 5 of "Extensions to the MLS method for image
deformation"): the MLS error field (eqs. 7-9) and the reference-triangle errors (eqs. 10, 11).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import moderngl
import numpy as np
from scipy.spatial import Delaunay, QhullError

from .handles import as_points
from .mls import as_shape, mesh_axes

if TYPE_CHECKING:
    from .mls import MLS

_LOCAL = 8  # local_size_x/y of mls_error_field.comp.glsl
_ERROR_SHADER = "mls_error_field.comp.glsl"


# -- MLS error field (eq. 7) ------------------------------------------------------------------


def _dispatch(m: MLS, program, dims: tuple[int, int]) -> None:
    limit = m.ctx.limits["max_work_groups_x"]
    groups = (math.ceil(dims[0] / _LOCAL), math.ceil(dims[1] / _LOCAL))
    if max(groups) > limit:  # the y limit is at least 65535 too; x is the one we know
        raise ValueError(f"lattice of {dims[0]} x {dims[1]} points is too large for one dispatch")
    program["u_dims"].value = dims
    program.run(group_x=groups[0], group_y=groups[1])


def _lattice(m: MLS, shape, xs: np.ndarray, ys: np.ndarray) -> moderngl.Buffer:
    """E at the lattice points (xs[j], ys[i]) (pixels), in scaled units: the GPU buffer of
    len(ys) rows of len(xs) float32."""
    program = m._compute(_ERROR_SHADER, MLS_ERROR_INTERPOLATE=False)
    m._set_uniforms(program, shape)
    sc = m.scaling
    step_x = (xs[1] - xs[0]) if len(xs) > 1 else 1.0
    step_y = (ys[1] - ys[0]) if len(ys) > 1 else 1.0
    program["u_origin"].value = tuple(sc.to_gpu(np.array([[xs[0], ys[0]]]))[0])
    program["u_step"].value = (step_x / sc.scale, step_y / sc.scale)
    program["u_last"].value = tuple(sc.to_gpu(np.array([[xs[-1], ys[-1]]]))[0])
    count = len(xs) * len(ys)
    buffer = m._buffer("error_lattice", count * 4)
    buffer.bind_to_storage_buffer(2)
    _dispatch(m, program, (len(xs), len(ys)))
    return buffer


def error_field(m: MLS, shape: Sequence[int], *, grid: int = 1) -> np.ndarray:
    """E_MLS(v) = sum_i |p_i M_v + T_v - q_i|^2 at every pixel of an image of ``shape``.

    Returns an (H, W) float64 array in square pixels. Computed on the GPU from M and T of the
    engine's ``mls_core.glsl``, unweighted (paper eq. 7). ``grid`` = 1 evaluates every pixel
    centre; ``grid`` > 1 evaluates the vertices of :meth:`MLS.mesh`'s mesh (pixel-square
    corners every ``grid`` pixels) and interpolates bilinearly to the pixel centres, also on the
    GPU. Values are float32 on the GPU: expect a relative error of ~1e-6 to 1e-5.
    """
    shape = as_shape(shape)
    xs_mesh, ys_mesh = mesh_axes(shape, grid)  # validates grid
    m._check_alive()
    m.ctx.make_current()
    data = _field_bytes(m, shape, grid, xs_mesh, ys_mesh)
    height, width = shape
    return np.frombuffer(data, dtype=np.float32).reshape(height, width).astype(np.float64) * (
        m.scaling.scale**2
    )


def _field_bytes(m: MLS, shape, grid: int, xs_mesh, ys_mesh) -> bytes:
    height, width = shape
    if grid == 1:
        lattice = _lattice(m, shape, np.arange(width, dtype=float), np.arange(height, dtype=float))
        data = lattice.read(size=width * height * 4)
    else:
        lattice = _lattice(m, shape, xs_mesh, ys_mesh)
        program = m.ctx.compute((_ERROR_SHADER,), {"MLS_ERROR_INTERPOLATE": True})
        lattice.bind_to_storage_buffer(1)
        out = m._buffer("error_field", width * height * 4)
        out.bind_to_storage_buffer(2)
        program["u_vertex_dims"].value = (len(xs_mesh), len(ys_mesh))
        program["u_grid"].value = grid
        _dispatch(m, program, (width, height))
        data = out.read(size=width * height * 4)
    return data


# -- statistics (eqs. 8, 9) --------------------------------------------------------------------


def error_stats(values: object) -> dict[str, float | int | list[float] | None]:
    """Image-level statistics of an error field or per-triangle errors (paper eqs. 8, 9).

    NaN values (where an error is undefined) are left out and counted in ``nan_count``;
    ``count`` is the number of values used. Returns a JSON-ready dict: ``mean`` (eq. 8),
    ``std`` (eq. 9, the population standard deviation), ``min``, ``max``, ``within`` (the
    shares of values with |x - mean| <= 1, 2 and 3 std, in that order), ``count``,
    ``nan_count``. With no values left, the statistics are ``None``. Infinite values raise
    ``ValueError``.
    """
    array = np.asarray(values)
    if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
        raise TypeError(f"values must be real numbers, got dtype {array.dtype}")
    array = array.astype(np.float64, copy=False).ravel()
    nan = np.isnan(array)
    if np.isinf(array).any():
        raise ValueError(f"values must be finite or NaN; {int(np.isinf(array).sum())} are infinite")
    finite = array[~nan]
    stats: dict[str, float | int | list[float] | None] = {
        "count": int(finite.size),
        "nan_count": int(nan.sum()),
    }
    if finite.size == 0:
        return stats | {"mean": None, "std": None, "min": None, "max": None, "within": None}
    mean = float(finite.mean())
    std = float(np.sqrt(np.mean((finite - mean) ** 2)))
    deviation = np.abs(finite - mean)
    within = [float(np.count_nonzero(deviation <= k * std)) / finite.size for k in (1, 2, 3)]
    return stats | {
        "mean": mean,
        "std": std,
        "min": float(finite.min()),
        "max": float(finite.max()),
        "within": within,
    }


# -- reference-triangle errors (eqs. 10, 11) --------------------------------------------------


@dataclass(frozen=True, eq=False)
class TriangleErrors:
    """Per-triangle errors of a deformation over the Delaunay triangulation of reference points.

    - ``points`` (N, 2): the reference points r; ``deformed_points`` (N, 2): f(r).
    - ``simplices`` (T, 3): vertex indices of each triangle (scipy's order, counter-clockwise
      in (x, y)).
    - ``distance`` (T,): eq. (10), the mean relative change of the three edge lengths.
    - ``angle`` (T,): eq. (11), the mean over the three corners of
      (|cos a - cos a'| + eps) / (|cos a| + eps); NaN where f collapses an edge to a point.
    - ``flipped`` (T,): whether f reverses the triangle's orientation (a fold-over).
    - ``eps``: the epsilon of eq. (11).
    """

    points: np.ndarray
    deformed_points: np.ndarray
    simplices: np.ndarray
    distance: np.ndarray
    angle: np.ndarray
    flipped: np.ndarray
    eps: float

    def stats(self) -> dict[str, object]:
        """JSON-ready statistics: triangle count, flipped count, distance and angle stats."""
        return {
            "triangles": len(self.simplices),
            "flipped": int(self.flipped.sum()),
            "distance": error_stats(self.distance),
            "angle": error_stats(self.angle),
        }


def check_reference_points(points: object) -> np.ndarray:
    """The reference points as (N, 2) float64; ``ValueError`` unless they can be triangulated
    (at least 3, finite, no duplicates, not all on one line)."""
    r = as_points(points, "reference_points")  # raises ValueError on NaN / inf
    if len(r) < 3:
        raise ValueError(f"reference_points: a triangulation needs at least 3 points, got {len(r)}")
    order = np.lexsort((r[:, 1], r[:, 0]))
    same = (r[order[1:]] == r[order[:-1]]).all(axis=1)
    if same.any():
        k = int(np.argmax(same))
        i, j = sorted((int(order[k]), int(order[k + 1])))
        raise ValueError(
            f"reference_points[{i}] and reference_points[{j}] are the same point {r[i].tolist()}"
        )
    centred = r - r.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    if singular[1] <= 1e-10 * singular[0]:
        raise ValueError("reference_points all lie on one line: no triangle can be formed")
    return r


def delaunay(points: object) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 2) float64, simplices (T, 3) int) of the Delaunay triangulation.

    Unlike a bare ``scipy.spatial.Delaunay``, points that Qhull would silently leave out
    (near-duplicates, in ``coplanar``) raise ``ValueError``.
    """
    r = check_reference_points(points)
    try:
        tri = Delaunay(r)
    except QhullError as error:
        raise ValueError(f"reference_points cannot be triangulated: {error}") from None
    if len(tri.coplanar):
        left = sorted(int(i) for i in tri.coplanar[:, 0])
        raise ValueError(
            f"reference_points {left} coincide (within Qhull's precision) with other points "
            "and were left out of the triangulation; remove or move them"
        )
    return r, np.ascontiguousarray(tri.simplices, dtype=np.int64)


def _corner_cosines(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For triangles (T, 3, 2): the cosine of the angle at each corner k (T, 3), and the length
    of edge k, from corner k to corner k + 1 (T, 3)."""
    edges = np.roll(corners, -1, axis=1) - corners  # edge k: corner k -> corner k+1
    lengths = np.hypot(edges[..., 0], edges[..., 1])
    # angle at corner k between the edges to k+1 and to k-1 (the reversed edge k-1)
    before = -np.roll(edges, 1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cosine = (edges * before).sum(-1) / (lengths * np.roll(lengths, 1, axis=1))
    return np.clip(cosine, -1.0, 1.0), lengths


def triangle_errors_from_points(
    points: np.ndarray, deformed: np.ndarray, simplices: np.ndarray, *, eps: float = 1e-6
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(distance, angle, flipped) per triangle from r, f(r) and the triangles (eqs. 10, 11)."""
    ref = points[simplices]
    out = deformed[simplices]
    cos_ref, len_ref = _corner_cosines(ref)
    cos_out, len_out = _corner_cosines(out)
    distance = np.mean(np.abs(len_ref - len_out) / len_ref, axis=1)
    angle = np.mean((np.abs(cos_ref - cos_out) + eps) / (np.abs(cos_ref) + eps), axis=1)

    def signed_area(t: np.ndarray) -> np.ndarray:
        a, b = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]

    flipped = np.sign(signed_area(ref)) * np.sign(signed_area(out)) < 0
    return distance, angle, flipped


def triangle_errors(
    m: MLS | Callable[[np.ndarray], np.ndarray],
    reference_points: object,
    *,
    eps: float = 1e-6,
) -> TriangleErrors:
    """Distance (eq. 10) and angular (eq. 11) errors of every triangle of the Delaunay
    triangulation of ``reference_points`` (user points, distinct from the handles).

    ``m`` is an :class:`MLS` or any function mapping (K, 2) points to (K, 2) points. Raises
    ``ValueError`` for fewer than 3 points, NaN, duplicates or points all on one line.
    A uniform scale by s gives angle ~0 (exactly eps / (|cos a| + eps) per corner) and
    distance = |s - 1|.
    """
    if isinstance(eps, bool) or not isinstance(eps, (int, float)) or not eps > 0:
        raise ValueError(f"eps must be a positive number, got {eps!r}")
    r, simplices = delaunay(reference_points)
    deformed = np.array(m(r), dtype=np.float64)  # a copy: we freeze it
    if deformed.shape != r.shape:
        raise ValueError(f"m(points) returned shape {deformed.shape}, expected {r.shape}")
    distance, angle, flipped = triangle_errors_from_points(r, deformed, simplices, eps=eps)
    for array in (r, deformed, simplices, distance, angle, flipped):
        array.flags.writeable = False
    return TriangleErrors(r, deformed, simplices, distance, angle, flipped, float(eps))
