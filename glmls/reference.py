"""Float64 numpy reference of the MLS mathematics, written straight from the formulas.

Used by the tests to check the GPU; it is not a fallback path (it is slow: O(K N) memory).
Conventions as in :class:`glmls.MLS`: points are (x, y) rows, f(v) = v M + T with row vectors.

Degenerate cases follow the same rules as the shader (``glmls/shaders/mls/core.glsl``):

- a point exactly on a handle whose weight is infinite there: f = q_i, and M is the limit,
  the solution over the other handles about p_i;
- no handle in reach (compact-support weights): identity;
- coincident source handles in reach (spread about p* below 1e-13 of that about v of the
  handles not at the nearest one's place): M = I; in a gaussian's far tail, where the
  nearest outweighs the others by e^30 and more, their fit is M however small their weights
  (the moments are taken about the nearest handle);
- rigid with all targets in reach collapsed to one point: M = I;
- affine whose moment matrix A is singular or nearly (fewer than 3 handles in reach, or
  handles along one line or near it): (A + g(A))^-1 (B + g(A) M_sim), the ridge g(A) of A's
  small eigenvalue toward the similarity solution M_sim, as 3D below; on a line that is
  M_sim itself, and where the handles spread (A's small eigenvalue above 1e-3 trace(A)) the
  exact affine fit, with a smooth blend between.

Segment handles (the segments of a :class:`glmls.HandleSet`) add the integrals of the same
moments along each segment, per unit length, computed by an accurate quadrature
(:func:`segment_moments`). A point on a segment whose weight's integral is infinite there
(``glmls.core.segments.segments_interpolate``) maps to the segment's target at the same
parameter, and M is the limit, about that point (the segment adds only its second moment);
with a weight that grows more slowly than 1 / d the integral is finite and f continuous
across the segment.

In three dimensions (:func:`mls` with (N, 3) handles and (K, 3) points, (x, y, z) = (column,
row, slice); point handles only) the moments are A = sum w p^T p^ and B = sum w p^T q^ (3 x 3,
row vectors about p* and q*), and

- rigid: R = U diag(1, 1, d) V^T from the SVD B = U S V^T, d = sign det(U V^T) (Kabsch with
  the reflection fix: det R = +1), minimising sum w |p^ R - q^|^2 over rotations; with
  coplanar sources (A of rank 2) the fix acts on the null direction and R is still unique;
- similarity: mu R, with Umeyama's scale mu = trace(R^T B) / trace(A);
- affine: A^-1 B.

Degenerate sets, each continuous in v and exact for the identity (q = p); g(A) below is the
ridge, the spectral function of A that is 0 unless an eigenvalue e of A is below
``DEGENERATE_SHARE`` (1e-3) of trace(A), where it grows as 1e-3 trace(A) (1 - e / (1e-3
trace(A)))^2, so well-spread sources get the exact closed forms:

- one handle in reach, or coincident sources (spread about p* below 1e-13 of that about v
  of the handles not at the nearest one's place, as 2D): M = I, a translation;
- collinear sources (two handles, or more on a line): the rotation about the line is free;
  R is the SVD solution of B + c |B| R0, with c = 1e-3 (1 - e2 / (1e-3 trace(A)))^2 for
  A's middle eigenvalue e2 (0 unless e2 < 1e-3 trace(A): the sources near one line) and R0
  the least rotation taking A's principal axis a to the direction of a B (Rodrigues about
  a x aB): exactly R0 on a line,
  the data's own rotation where the sources spread, and a smooth blend between (an
  antiparallel a B, a half turn, has no continuous choice: any perpendicular axis); three
  or more coplanar sources need nothing: the reflection fix acts on B's null direction;
- collinear targets (B of rank 1, however the sources spread): the rotation about the
  targets' line is free; the same rule adds c' |B| R0', c' and R0' those of B B^T (its
  middle eigenvalue against its trace, and its principal axis a' to the direction of a' B);
- coplanar sources (affine): (A + g(A))^-1 (B + g(A) M_sim), a ridge toward the similarity
  solution M_sim in the directions where A is (nearly) singular; exact for a global
  similarity, and on a plane the in-plane part is the 2D affine solution (a global affine
  motion is reproduced where every eigenvalue of A is above 1e-3 trace(A));
- rigid with all targets in reach collapsed (trace(R^T B) <= 1e-6 trace(A), as 2D): M = I;
- a point on a handle whose weight is infinite there: f = q_i, M the limit, as 2D.

With every handle and point at z = 0, the 3D results equal the 2D ones in x, y (the rigid and
similarity ones while the 2D fit is closer to a rotation than to a mirror: in 3D a mirror of
the plane is a half turn).
"""

from __future__ import annotations

import numpy as np

from .core.config import MLSConfig, check_real, config_or_options
from .core.handles import as_points, check_coordinates, point_rows
from .core.handles3 import (
    as_points3,
    as_volume_shape,
    as_volume_spacing,
    no_radius3,
    planar_spacing,
    validate_handles3,
    volume_diagonal,
)
from .core.handleset import HandleSet
from .core.mesh import as_shape
from .core.ridges import DEGENERATE_SHARE, ridge3, ridge_matrix, rotation3
from .core.segments import (
    REFERENCE_NODES,
    REFERENCE_PANELS,
    segment_config,
    segment_pole,
    segments_interpolate,
    sinh_nodes,
)
from .core.weights import nearest_apart, squared_distances

__all__ = [
    "DEGENERATE_SHARE",
    "ON_SEGMENT",
    "ON_SEGMENT_RESOLUTION",
    "mls",
    "mls_error",
    "plain_affine",
    "segment_geometry",
    "segment_moments",
    "weights",
]


def weights(d2: np.ndarray, config: MLSConfig, radius: float | None) -> np.ndarray:
    """Table 1 weights for squared distances; +inf where a weight is infinite at d = 0.

    Each weight's formula is its registry entry's (``glmls.core.weights``); a common factor
    per point is allowed: the Gaussian is divided by its value at the nearest handles apart
    from the nearest one's place (the least distance above the least), so that it does not
    underflow far from every handle, where their moments about the nearest decide M
    (``glmls.core.weights.gaussian_excess``).

    Parameters
    ----------
    d2 : numpy.ndarray
        Squared distances (K, N) from K evaluated points to N handles, in square pixels.
    config : MLSConfig
        The weight, its parameters, and whether it is made interpolating.
    radius : float or None
        The influence radius R in pixels (``config.resolve_radius(shape)``); None for the
        weights that need none.

    Returns
    -------
    numpy.ndarray
        The weights w_i(v), (K, N) float64.

    Raises
    ------
    TypeError
        When ``radius`` is None for a weight that needs one or no real number, ``config``
        is no :class:`~glmls.MLSConfig`, or ``d2`` holds no real numbers.
    ValueError
        For ``d2`` that is not (K, N) or holds a NaN or a negative value, or a ``radius``
        that is not a finite number > 0.

    See Also
    --------
    glmls.MLSConfig : the weights' names and parameters.

    Examples
    --------
    >>> d2 = np.array([[0.0, 1.0, 4.0]])
    >>> glmls.reference.weights(d2, glmls.MLSConfig(), None).tolist()  # 1 / (s + d^2)
    [[100000000.0, 0.9999999900000002, 0.249999999375]]
    >>> config = glmls.MLSConfig(weight="gaussian", radius=2.0)
    >>> w = glmls.reference.weights(d2, config, 2.0)  # exp(-d^2 / R^2) / exp(-1 / R^2)
    >>> w.round(3).tolist(), (w / w[:, :1]).round(3).tolist()
    ([[1.284, 1.0, 0.472]], [[1.0, 0.779, 0.368]])
    """
    if not isinstance(config, MLSConfig):
        raise TypeError(f"config must be an MLSConfig, got {type(config).__name__}")
    if radius is None and config.uses_radius:
        raise TypeError(
            f"radius must be a number in pixels for weight {config.weight!r} "
            "(config.resolve_radius(shape) gives the default), got None"
        )
    radius = None if radius is None else check_real("radius", radius, low=0, low_open=True)
    d2 = squared_distances(d2)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = config.weight_entry.reference(d2, config, radius)
        if config.interpolating:
            w = w / d2**config.alpha
    return w


def _solve(a11, a12, a22, b, transform):
    """M (K, 2, 2) from moments; b has shape (K, 2, 2) with b[:, i, j] = sum w p^_i q^_j."""
    mu = a11 + a22
    big_a = b[:, 0, 0] + b[:, 1, 1]
    big_b = b[:, 0, 1] - b[:, 1, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        if transform == "rigid":
            norm = np.hypot(big_a, big_b)
            ok = norm > 1e-6 * mu
            norm = np.where(ok, norm, 1.0)
        else:
            norm = np.where(mu > 0, mu, 1.0)
            ok = np.ones_like(mu, dtype=bool)
        rot = (
            np.stack([np.stack([big_a, big_b], -1), np.stack([-big_b, big_a], -1)], -2)
            / norm[:, None, None]
        )
    rot[~ok] = np.eye(2)
    if transform != "affine":
        return rot
    # (A + g(A))^-1 (B + g(A) M_sim): the ridge toward the similarity solution where A's
    # small eigenvalue is below DEGENERATE_SHARE of its trace, as 3D (_solve3)
    big_a = np.stack([np.stack([a11, a12], -1), np.stack([a12, a22], -1)], -2)
    ridge, _, _ = ridge_matrix(big_a)
    lhs = big_a + ridge
    regular = _positive_det(lhs)
    lhs[~regular] = np.eye(2)
    return np.where(regular[:, None, None], np.linalg.solve(lhs, b + ridge @ rot), rot)


def _positive_det(lhs: np.ndarray) -> np.ndarray:
    """det(lhs) > 0 for each of the (K, n, n) matrices, each divided by its largest entry
    first: moments next to a steep weight (1e160 at 1e-9 px of a segment, alpha 10)
    overflow float64 in a determinant of their own size."""
    scale = np.abs(lhs).max(axis=(1, 2), keepdims=True)
    scale = np.where(scale > 0, scale, 1.0)
    return np.linalg.det(lhs / scale) > 0


#: A point nearer than this (pixels) to a segment whose weight's integral is infinite there is
#: on it, where the weight grows like 1 / d^p with p >= 2: the segment weighs ~h^(1-p) at h,
#: the others' share at most ~1e-9 of theirs at 1 px.
ON_SEGMENT = 1e-9
#: With 1 <= p < 2 (shepard, idw with alpha < 1) the segment weighs only ~h^(1-p), or
#: 2 log(L / h) at p = 1, and f approaches the target as slowly (0.04 px off at 1e-8 px of a
#: segment next to a handle 4 px away): such a point is on the segment only within float64's
#: resolution, this share of its distance to the segment's far end.
ON_SEGMENT_RESOLUTION = 1e-14


def _on_segment(config: MLSConfig, geometry: dict[str, np.ndarray]) -> np.ndarray:
    """(K, S): whether a point is on a segment handle (maps to its target): within
    :data:`ON_SEGMENT` or :data:`ON_SEGMENT_RESOLUTION` of it, after the pole of the
    weight; never where the weight's integral along the segment is finite on it
    (``glmls.core.segments.segments_interpolate``)."""
    dist2 = geometry["dist2"]
    if not segments_interpolate(config):
        return np.zeros(dist2.shape, dtype=bool)
    if segment_pole(config) >= 2.0:
        return dist2 <= ON_SEGMENT**2
    far = np.maximum(np.maximum(np.abs(geometry["x0"]), np.abs(geometry["x1"])), 1.0)
    return dist2 <= (ON_SEGMENT_RESOLUTION * far) ** 2


def segment_geometry(handles: HandleSet, v: np.ndarray) -> dict[str, np.ndarray]:
    """The geometry of every evaluated point against every segment handle.

    Parameters
    ----------
    handles : HandleSet
        The handles; only the segments are used.
    v : numpy.ndarray
        The evaluated points, (K, 2) float64 (x, y) rows.

    Returns
    -------
    dict of str to numpy.ndarray
        Per point and segment (K, S): ``x0``, ``x1``, the arc coordinates of the segment's
        ends about the foot of the perpendicular from v; ``h2``, the squared distance to the
        segment's line; ``dist2``, the squared distance to the segment. Per point and segment
        (K, S, 2): ``foot`` and its image ``target``, relative to v. Per segment (S, 2):
        ``u``, the unit direction, and ``g``, the target's change per unit of source length.

    Raises
    ------
    ValueError
        When ``v`` is not (K, 2) (numpy's broadcasting error).

    Examples
    --------
    >>> handles = glmls.HandleSet.validate(
    ...     np.zeros((0, 2)), np.zeros((0, 2)), [[[0, 0], [10, 0]]], [[[0, 1], [10, 1]]]
    ... )
    >>> g = glmls.reference.segment_geometry(handles, np.array([[5.0, 3.0]]))
    >>> g["x0"].tolist(), g["x1"].tolist(), g["h2"].tolist()
    ([[-5.0]], [[5.0]], [[9.0]])
    >>> g["foot"].tolist(), g["target"].tolist(), g["u"].tolist(), g["g"].tolist()
    ([[[0.0, -3.0]]], [[[0.0, -2.0]]], [[1.0, 0.0]], [[1.0, 0.0]])
    """
    a, b = handles.src_segments[:, 0], handles.src_segments[:, 1]
    c, d = handles.dst_segments[:, 0], handles.dst_segments[:, 1]
    length = np.hypot(*(b - a).T)
    u = (b - a) / length[:, None]
    g = (d - c) / length[:, None]
    av = a[None] - v[:, None]  # a - v
    x0 = (av * u[None]).sum(-1)  # a = foot + x0 u
    x1 = x0 + length[None]
    h = av[..., 0] * u[None, :, 1] - av[..., 1] * u[None, :, 0]  # cross product: signed
    foot = av - x0[..., None] * u[None]
    target = c[None] - v[:, None] - x0[..., None] * g[None]
    xc = np.clip(0.0, x0, x1)
    return {
        "x0": x0,
        "x1": x1,
        "h2": h * h,
        "dist2": h * h + xc * xc,
        "foot": foot,
        "target": target,
        "u": u,
        "g": g,
    }


def segment_moments(
    geometry: dict[str, np.ndarray], config: MLSConfig, radius: float | None, d2_points
) -> tuple[np.ndarray, np.ndarray]:
    """The weight's moments along each segment handle, and the point handles' weights.

    Quadrature: ``glmls.core.segments.sinh_nodes`` over the part of the segment where the
    weight is not 0.

    Parameters
    ----------
    geometry : dict of str to numpy.ndarray
        :func:`segment_geometry` of the handles and the evaluated points.
    config : MLSConfig
        The weight and its parameters.
    radius : float or None
        The influence radius R in pixels; None for the weights that need none.
    d2_points : numpy.ndarray
        Squared distances (K, N) from the points to the point handles.

    Returns
    -------
    moments : numpy.ndarray
        J (K, S, 3): the integrals of w x^k along each segment, k = 0, 1, 2, with x the arc
        length from the foot of the perpendicular.
    w_points : numpy.ndarray
        The point handles' weights (K, N), with the same common factor per point as J.

    Raises
    ------
    KeyError
        When ``geometry`` lacks an entry of :func:`segment_geometry`.

    Examples
    --------
    >>> handles = glmls.HandleSet.validate(
    ...     np.zeros((0, 2)), np.zeros((0, 2)), [[[0, 0], [10, 0]]], [[[0, 1], [10, 1]]]
    ... )
    >>> geometry = glmls.reference.segment_geometry(handles, np.array([[5.0, 3.0]]))
    >>> moments, w = glmls.reference.segment_moments(
    ...     geometry, glmls.MLSConfig(), None, np.zeros((1, 0))
    ... )
    >>> moments.round(4).tolist(), w.shape  # J1 = 0: the foot is the segment's middle
    ([[[0.6869, 0.0, 3.8177]]], (1, 0))
    """
    x0, x1, h2 = geometry["x0"], geometry["x1"], geometry["h2"]
    width = np.sqrt(h2)  # the weight's peak along the segment is this wide
    support = config.weight_entry.support
    if support != "everywhere":
        with np.errstate(over="ignore"):
            r2 = np.float64(radius) ** 2
            if support == "radius":
                # w = 0 from d = R on: integrate where |x| < sqrt(R^2 - h^2) only
                reach2 = r2 - h2
            else:
                # gaussian: weights below e^-40 of the nearest handles' apart from the
                # nearest one's place add nothing (in the far tail those decide M however
                # small against the nearest: relative to it, a segment that counted was cut)
                offset = nearest_apart(np.concatenate([geometry["dist2"], d2_points], axis=1))
                reach2 = offset + 40.0 * r2 - h2
            reach = np.sqrt(np.maximum(reach2, 0.0))
        x0, x1 = np.clip(x0, -reach, reach), np.clip(x1, -reach, reach)
        width = np.minimum(width, radius)  # type: ignore[call-overload]
    scale = np.maximum(np.abs(x0), np.abs(x1))
    c = np.maximum(width, ON_SEGMENT_RESOLUTION * np.maximum(scale, 1.0))
    x, wq = sinh_nodes(x0, x1, c, REFERENCE_PANELS, REFERENCE_NODES)
    if support == "gaussian":
        # a segment beyond the foot: the weight falls from its near end xs within
        # R^2 / (2 |xs|), narrower than the nodes about the foot (0.001 px 40 px past the
        # end at R = 0.3, where they gave M = I): nodes about that end, of that width
        near = np.where(x0 > 0, x0, np.where(x1 < 0, x1, 0.0))
        beyond = near != 0
        # (c elsewhere: its nodes are not taken; 1e-280 keeps x / c within float64 for
        # coordinates up to 1e6 where R^2 underflows)
        sliver = np.minimum(c, r2 / (2.0 * np.where(beyond, np.abs(near), 1.0)))
        sliver = np.where(beyond, np.maximum(sliver, 1e-280), c)
        y, wy = sinh_nodes(np.zeros_like(x0), x1 - x0, sliver, REFERENCE_PANELS, REFERENCE_NODES)
        from_end = np.where((x0 > 0)[..., None], x0[..., None] + y, x1[..., None] - y)
        x = np.where(beyond[..., None], from_end, x)
        wq = np.where(beyond[..., None], wy, wq)
    k, s, n = x.shape
    d2 = (h2[..., None] + x * x).reshape(k, s * n)
    if segment_config(config) is config:
        # one call: a weight may divide by a common factor per point (the gaussian)
        w = weights(np.concatenate([d2_points, d2], axis=1), config, radius)
        w_points, w_nodes = w[:, : d2_points.shape[1]], w[:, d2_points.shape[1] :]
    else:  # idw with a negligible s, which segments leave out (no common factor)
        w_points = weights(d2_points, config, radius)
        w_nodes = weights(d2, segment_config(config), radius)
    w_nodes = np.where(np.isinf(w_nodes), 0.0, w_nodes)
    w_nodes = w_nodes.reshape(k, s, n) * wq
    moments = np.stack([w_nodes.sum(-1), (w_nodes * x).sum(-1), (w_nodes * x * x).sum(-1)], -1)
    return moments, w_points


def mls(
    src: object,
    dst: object,
    points: object,
    config: MLSConfig | None = None,
    *,
    shape: tuple[int, int] | None = None,
    spacing: tuple[float, float, float] | None = None,
    src_segments: object = None,
    dst_segments: object = None,
    **options: object,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The MLS deformation f(v) = v M_v + T_v at ``points``, in float64.

    Straight from the paper's closed forms: the weighted centroids p*, q* (eq. 4) and the
    affine (eq. 5), similarity (eq. 6) or rigid solution for M, with segment handles adding
    their integrals along each segment.

    Parameters
    ----------
    src, dst : array_like
        Point handles p_i -> q_i, (N, 2) (x, y) rows, or (N, 3) (x, y, z) rows in 3D; N may be
        0 with segments.
    points : array_like
        The evaluated points v, (K, 2), or (K, 3) with 3D handles; one point as a (2,) or
        (3,) array is a (1, D) row.
    config : MLSConfig, optional
        The transform and weight; built from ``options`` when None.
    shape : tuple of int, optional
        (H, W) of the image, or (D, H, W) of a volume, whose diagonal is the default radius
        of the radius weights.
    spacing : (float, float, float), optional
        3D only: (dz, dy, dx) of the volume's voxels in the handles' units, as
        :class:`glmls.MLS`'s: the default radius is then the diagonal of (D dz, H dy, W dx).
    src_segments, dst_segments : array_like, optional
        Segment handles a-b -> c-d, (S, 2, 2); 2D only.
    **options
        :class:`glmls.MLSConfig`'s fields, when ``config`` is None.

    Returns
    -------
    f : numpy.ndarray
        f(points), (K, 2), or (K, 3) in 3D.
    M : numpy.ndarray
        The linear part M_v per point, (K, 2, 2) or (K, 3, 3), so that ``f = points @ M + T``
        row by row.
    T : numpy.ndarray
        The translation T_v per point, (K, 2) or (K, 3).

    Raises
    ------
    ValueError
        When the handles or points are malformed or beyond ±1e6 (px or voxels), one source
        point has two targets, a ``shape`` is not one that :class:`glmls.MLS` takes (the same
        errors as it raises), or the inputs are mixed (some with 2 columns and some with 3,
        or segments or ``spacing`` with 2D handles), an option is invalid, a ``spacing`` is
        not three finite numbers > 0, or a radius weight has neither ``radius`` nor
        ``shape``.
    TypeError
        When an option or the ``spacing`` has the wrong type.

    See Also
    --------
    glmls.MLS : the same map on the GPU.
    mls_error : E_MLS (eq. 7) of the same fit.

    Examples
    --------
    >>> src = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    >>> f, M, T = glmls.reference.mls(src, src + [2.0, 1.0], [[5.0, 5.0]])
    >>> f.tolist(), T.tolist()  # a translation is reproduced exactly
    ([[7.0, 6.0]], [[2.0, 1.0]])
    >>> dst = np.array([[0.0, 0.0], [12.0, 0.0], [0.0, 10.0]])
    >>> glmls.reference.mls(src, dst, [[5.0, 5.0]], transform="affine")[0].round(3).tolist()
    [[6.0, 5.0]]

    In 3D, a quarter turn about z of four handles is reproduced by the rigid transform:

    >>> src3 = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]])
    >>> quarter = np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]])  # x -> y, y -> -x
    >>> f, M, T = glmls.reference.mls(src3, src3 @ quarter, [[5.0, 0.0, 2.0]])
    >>> (f.round(6) + 0.0).tolist(), M.shape
    ([[0.0, 5.0, 2.0]], (1, 3, 3))

    With handles in millimetres of a volume of 10 x 20 x 40 voxels of (2, 1, 0.5) mm, the
    gaussian weight's default radius is the diagonal of (20, 20, 20) mm, as
    ``glmls.MLS(..., shape=(10, 20, 40), spacing=(2.0, 1.0, 0.5))`` takes it:

    >>> mm = dict(shape=(10, 20, 40), spacing=(2.0, 1.0, 0.5), weight="gaussian")
    >>> moved = src3 + [[1.0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]
    >>> f, _, _ = glmls.reference.mls(src3, moved, [[4.0, 4.0, 4.0]], **mm)
    >>> explicit = glmls.reference.mls(
    ...     src3, moved, [[4.0, 4.0, 4.0]], weight="gaussian", radius=np.sqrt(3 * 20.0**2)
    ... )[0]
    >>> bool(np.array_equal(f, explicit))
    True
    """
    config = config_or_options(config, options)
    if _dimension(src, dst, points) == 3:
        return _mls3_checked(src, dst, points, config, shape, spacing, src_segments, dst_segments)[
            :3
        ]
    planar_spacing(spacing)
    handles = HandleSet.validate(src, dst, src_segments, dst_segments)
    v = check_coordinates(as_points(point_rows(points, 2)), "points")
    shape = None if shape is None else as_shape(shape)
    k = len(v)
    f = v.copy()
    big_m = np.broadcast_to(np.eye(2), (k, 2, 2)).copy()
    if len(handles) == 0 or k == 0:
        return f, big_m, f - np.einsum("ki,kij->kj", v, big_m)
    radius = config.resolve_radius(shape)
    rows = np.arange(k)

    p, q = handles.src, handles.dst
    dp = p[None, :, :] - v[:, None, :]  # p_i - v, (K, N, 2)
    dq = q[None, :, :] - v[:, None, :]
    d2 = (dp**2).sum(-1)
    seg = segment_geometry(handles, v)
    moments, w = segment_moments(seg, config, radius, d2)
    j0, j1, j2 = moments[..., 0], moments[..., 1], moments[..., 2]
    u, g, foot, target = seg["u"][None], seg["g"][None], seg["foot"], seg["target"]

    # v on a handle whose weight is infinite there: on a point (w = inf) or a segment
    on_point = np.isinf(w)
    on_segment = _on_segment(config, seg)
    hit = on_point.any(axis=1) | on_segment.any(axis=1)
    w = np.where(on_point, 0.0, w)  # the hit handle's p^ is 0: it drops out of the moments
    # a hit segment adds only its second moment about the foot (J0 and J1 are infinite or
    # dominated there): p* is the foot
    j0 = np.where(on_segment, 0.0, j0)
    j1 = np.where(on_segment, 0.0, j1)

    wsum = w.sum(axis=1) + j0.sum(axis=1)
    reached = hit | (wsum > 0)
    # the moments about the nearest point handle o (p - p_o exactly 0 at its place), as 3D
    # (_mls3): where o's weight outweighs the others' by far (next to a steep weight's handle,
    # in a gaussian's far tail) the others' spread about p* keeps float64's precision
    # instead of being lost to the rounding of p* about v
    origin_p = np.zeros((k, 2))
    origin_q = np.zeros((k, 2))
    if len(p):
        nearest = np.argmin(d2, axis=1)
        origin_p, origin_q = dp[rows, nearest], dq[rows, nearest]  # p_o - v, q_o - v
        dp = p[None, :, :] - p[nearest][:, None, :]
        dq = q[None, :, :] - q[nearest][:, None, :]
        foot = foot - origin_p[:, None, :]
        target = target - origin_q[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        pmean = (w[..., None] * dp).sum(1) + (j0[..., None] * foot + j1[..., None] * u).sum(1)
        qmean = (w[..., None] * dq).sum(1) + (j0[..., None] * target + j1[..., None] * g).sum(1)
        pst = pmean / wsum[:, None]
        qst = qmean / wsum[:, None]
    # snapped: p* and q* are the point hit (or the foot on the segment hit) and its target
    for mask, where, what in ((on_segment, foot, target), (on_point, dp, dq)):
        if mask.shape[1]:
            first = np.argmax(mask, axis=1)
            snapped = mask.any(axis=1)[:, None]
            pst = np.where(snapped, where[rows, first], pst)
            qst = np.where(snapped, what[rows, first], qst)
    pst[~reached] = 0.0
    qst[~reached] = 0.0

    ph = dp - pst[:, None, :]
    qh = dq - qst[:, None, :]
    pf = foot - pst[:, None, :]  # the feet and their targets about p*, q*
    qf = target - qst[:, None, :]
    big_a = np.einsum("kn,kni,knj->kij", w, ph, ph) + _segment_products(j0, j1, j2, pf, u, pf, u)
    b = np.einsum("kn,kni,knj->kij", w, ph, qh) + _segment_products(j0, j1, j2, pf, u, qf, g)
    a11, a12, a22 = big_a[:, 0, 0], big_a[:, 0, 1], big_a[:, 1, 1]

    big_m = _solve(a11, a12, a22, b, config.transform)
    # coincident source handles: their spread about p* is negligible against the yardstick
    # (_yardstick: the spread about v, the nearest handle's own left out); sources all at
    # one place have p - p_o = 0 exactly
    yardstick = _yardstick(p, w, d2, seg["dist2"])
    yardstick += (seg["h2"] * j0 + j2).sum(1)
    coincident = ~(a11 + a22 > 1e-13 * yardstick)
    big_m[coincident | ~reached] = np.eye(2)
    # f(v) = q* + (v - p*) M, with p* - v = (p_o - v) + (p* - p_o)
    f = v + (origin_q + qst) - np.einsum("ki,kij->kj", origin_p + pst, big_m)
    f[~reached] = v[~reached]
    t = f - np.einsum("ki,kij->kj", v, big_m)
    return f, big_m, t


def _yardstick(p, w, d2, segment_d2) -> np.ndarray:
    """(K,) the yardstick of "coincident sources": sum w |p - v|^2 over the point handles
    not at the nearest one's place (a point handle; a segment nearer than every point handle
    leaves none out). The nearest's own w d^2 is left out: next to a handle whose weight is
    steep (1 / d^(2 alpha), alpha > 1) it grows without bound, and in a gaussian's far tail
    it outweighs the others by e^30 and more, yet in both places the others' spread about p*
    decides M (continuous up to the handle; and in the tail the fit of the nearest handles
    apart, however small their weights), as on the GPU (``glmls/shaders/mls/weighting.glsl``).
    """
    spread = w * d2
    if not d2.shape[1]:
        return spread.sum(1)
    rows = np.arange(len(d2))
    nearest = np.argmin(d2, axis=1)
    at_nearest = (p[None, :, :] == p[nearest][:, None, :]).all(-1)
    closer_segment = segment_d2.min(axis=1, initial=np.inf) < d2[rows, nearest]
    apart = ~at_nearest | closer_segment[:, None]
    return np.where(apart, spread, 0.0).sum(1)


def _segment_products(j0, j1, j2, pf, u, qf, g) -> np.ndarray:
    """(K, 2, 2): the sum over segments of the integral of w (pf + x u)^T (qf + x g)."""
    return (
        np.einsum("ks,ksi,ksj->kij", j0, pf, qf)
        + np.einsum("ks,ksi,ksj->kij", j1, pf, np.broadcast_to(g, pf.shape))
        + np.einsum("ks,ksi,ksj->kij", j1, np.broadcast_to(u, pf.shape), qf)
        + np.einsum(
            "ks,ksi,ksj->kij", j2, np.broadcast_to(u, pf.shape), np.broadcast_to(g, pf.shape)
        )
    )


def _residual(p: np.ndarray, q: np.ndarray, big_m: np.ndarray, t: np.ndarray) -> np.ndarray:
    """l_v(p) - q for every point v and handle p -> q, (K, N, d): l_v(x) = x M_v + T_v."""
    return np.einsum("ni,kij->knj", p, big_m) + t[:, None, :] - q[None]


def mls_error(
    src: object,
    dst: object,
    points: object,
    config: MLSConfig | None = None,
    *,
    shape: tuple[int, int] | None = None,
    spacing: tuple[float, float, float] | None = None,
    src_segments: object = None,
    dst_segments: object = None,
    **options: object,
) -> np.ndarray:
    """The MLS error E_MLS (eq. 7) at ``points``, in square pixels.

    E_MLS(v) = sum_i |l_v(p_i) - q_i|^2 over point handles plus, per segment handle, the
    integral along it per pixel of source length of |l_v(p(t)) - q(t)|^2, with
    l_v(x) = x M_v + T_v the fit at v (unweighted: the residual of the fit, not its
    objective).

    Parameters
    ----------
    src, dst : array_like
        Point handles p_i -> q_i, (N, 2) (x, y) rows, or (N, 3) (x, y, z) rows in 3D.
    points : array_like
        The evaluated points v, (K, 2), or (K, 3) with 3D handles; one point as a (2,) or
        (3,) array is a (1, D) row.
    config : MLSConfig, optional
        The transform and weight; built from ``options`` when None.
    shape : tuple of int, optional
        (H, W) of the image, or (D, H, W) of a volume, whose diagonal is the default radius
        of the radius weights.
    spacing : (float, float, float), optional
        3D only: (dz, dy, dx) of the volume's voxels in the handles' units (as :func:`mls`).
    src_segments, dst_segments : array_like, optional
        Segment handles a-b -> c-d, (S, 2, 2); 2D only.
    **options
        :class:`glmls.MLSConfig`'s fields, when ``config`` is None.

    Returns
    -------
    numpy.ndarray
        E_MLS per point, (K,) float64.

    Raises
    ------
    ValueError
        As :func:`mls`.
    TypeError
        As :func:`mls`.

    See Also
    --------
    glmls.analysis.error_field : the same error over a whole image, on the GPU.

    Examples
    --------
    >>> src = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    >>> glmls.reference.mls_error(src, src + 1.0, [[5.0, 5.0]]).tolist()  # a rigid motion
    [0.0]
    >>> dst = np.array([[0.0, 0.0], [12.0, 0.0], [0.0, 10.0]])
    >>> glmls.reference.mls_error(src, dst, [[5.0, 5.0]]).round(3).tolist()
    [2.364]
    """
    config = config_or_options(config, options)
    if _dimension(src, dst, points) == 3:
        _, big_m, t, _ = _mls3_checked(
            src, dst, points, config, shape, spacing, src_segments, dst_segments
        )
        p, q = np.asarray(src, dtype=np.float64), np.asarray(dst, dtype=np.float64)
        return (_residual(p, q, big_m, t) ** 2).sum(axis=(1, 2))
    planar_spacing(spacing)
    handles = HandleSet.validate(src, dst, src_segments, dst_segments)
    _, big_m, t = mls(
        handles.src,
        handles.dst,
        points,
        config,
        shape=shape,
        src_segments=handles.src_segments,
        dst_segments=handles.dst_segments,
    )
    error = (_residual(handles.src, handles.dst, big_m, t) ** 2).sum(axis=(1, 2))
    if handles.segments:
        a, b = handles.src_segments, handles.dst_segments
        ra, rb = _residual(a[:, 0], b[:, 0], big_m, t), _residual(a[:, 1], b[:, 1], big_m, t)
        length = np.hypot(*(a[:, 1] - a[:, 0]).T)
        error += ((ra * ra + ra * rb + rb * rb).sum(-1) * length / 3.0).sum(axis=1)
    return error


# ---------------------------------------------------------------------------------------------
# Three dimensions: point handles only, the same weights (they depend on d^2 alone).


def plain_affine(
    src: object,
    dst: object,
    points: object,
    config: MLSConfig | None = None,
    *,
    shape: tuple[int, int, int] | None = None,
    spacing: tuple[float, float, float] | None = None,
    **options: object,
) -> np.ndarray:
    """Where the 3D affine MLS solves for M by the plain A^-1 B, in float64.

    The plain solve: a handle in reach, the sources in reach not coincident, and every
    eigenvalue of A = sum w p^T p^ at least :data:`DEGENERATE_SHARE` of its trace (no
    ridge). With every target on one plane of normal n
    (``glmls.core.mesh3.coplanar``), B n = 0 there, so M n = 0: f maps the point into
    that plane, and a Jacobian by differences of such points is singular
    (``glmls.core.mesh3.deform_mesh``'s ``flat``).

    Parameters
    ----------
    src, dst : array_like
        Point handles p_i -> q_i, (N, 3) (x, y, z) rows.
    points : array_like
        The evaluated points v, (K, 3); one point as a (3,) array is a (1, 3) row.
    config : MLSConfig, optional
        The transform and weight; built from ``options`` when None.
    shape : tuple of int, optional
        (D, H, W) of a volume whose diagonal is the default radius of the radius weights.
    spacing : (float, float, float), optional
        (dz, dy, dx) of the volume's voxels in the handles' units, as :func:`mls`'s.
    **options
        :class:`glmls.MLSConfig`'s fields, when ``config`` is None.

    Returns
    -------
    numpy.ndarray
        (K,) bool; False everywhere for the rigid and similarity transforms.

    Raises
    ------
    ValueError
        For 2D handles or points, and as :func:`mls` does.
    TypeError
        As :func:`mls` does.

    Examples
    --------
    >>> src = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]])
    >>> glmls.reference.plain_affine(src, src * [1, 1, 0], [[2.0, 2, 2]], transform="affine")
    array([ True])
    >>> glmls.reference.plain_affine(src[:3], src[:3], [[2.0, 2, 2]], transform="affine")
    array([False])
    """
    config = config_or_options(config, options)
    if _dimension(src, dst, points) != 3:
        raise ValueError("plain_affine takes (N, 3) handles and (K, 3) points")
    return _mls3_checked(src, dst, points, config, shape, spacing, None, None)[3]


def _dimension(src: object, dst: object, points: object) -> int:
    """3 when src, dst and points all have 3 columns, 2 when none has (the 2D validation then
    applies); ValueError naming the shapes when they are mixed."""
    shapes = {name: np.shape(a) for name, a in (("src", src), ("dst", dst), ("points", points))}
    shapes["points"] = np.shape(point_rows(points, 3))  # one (x, y, z) point: a (1, 3) row
    three = [len(s) == 2 and s[1] == 3 for s in shapes.values()]
    if not any(three):
        return 2
    if not all(three):
        got = ", ".join(f"{name} {shape}" for name, shape in shapes.items())
        raise ValueError(
            "src, dst and points must all be (N, 2) (x, y) rows or all (N, 3) (x, y, z) "
            f"rows; got {got}"
        )
    return 3


def _mls3_checked(src, dst, points, config, shape, spacing, src_segments, dst_segments):
    """Validate 3D inputs, then :func:`_mls3`."""
    if src_segments is not None or dst_segments is not None:
        raise ValueError(
            "segment handles are 2D only: src_segments and dst_segments must be None with "
            "(N, 3) handles"
        )
    p, q = validate_handles3(src, dst)
    v = as_points3(point_rows(points, 3))
    shape = None if shape is None else as_volume_shape(shape)
    steps = None if spacing is None else as_volume_spacing(spacing)
    radius = config.radius
    if config.uses_radius and radius is None:
        if shape is None:
            raise no_radius3(config.weight)
        radius = volume_diagonal(shape, steps)
    return _mls3(p, q, v, config, radius)


def _solve3(big_a: np.ndarray, b: np.ndarray, transform: str) -> tuple[np.ndarray, np.ndarray]:
    """M (K, 3, 3) from A = sum w p^T p^ and B = sum w p^T q^ (p^, q^ row vectors), and
    where M is affine's plain A^-1 B, without a ridge (K,)."""
    rot = rotation3(big_a, b)
    mu = np.trace(big_a, axis1=-2, axis2=-1)
    along = np.einsum("kij,kij->k", rot, b)  # trace(R^T B): the fit's sum w p^ R q^T
    if transform == "rigid":
        collapsed = ~(along > 1e-6 * mu)  # as 2D: all targets in reach at one point
        rot[collapsed] = np.eye(3)
        return rot, np.zeros(len(b), bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        sim = rot * np.where(mu > 0, along / mu, 0.0)[:, None, None]  # Umeyama's scale
    if transform == "similarity":
        return sim, np.zeros(len(b), bool)
    # affine: (A + g(A))^-1 (B + g(A) M_sim), the ridge g(A) toward the similarity solution
    ridge, _, _ = ridge3(big_a)
    lhs = big_a + ridge
    ok = _positive_det(lhs)
    lhs[~ok] = np.eye(3)
    m = np.linalg.solve(lhs, b + ridge @ sim)
    return np.where(ok[:, None, None], m, sim), ok & ~ridge.any(axis=(1, 2))


def _mls3(p, q, v, config: MLSConfig, radius: float | None):
    """:func:`mls` for (N, 3) point handles and (K, 3) points, and :func:`plain_affine`."""
    k = len(v)
    f = v.copy()
    big_m = np.broadcast_to(np.eye(3), (k, 3, 3)).copy()
    plain = np.zeros(k, bool)
    if len(p) == 0 or k == 0:
        return f, big_m, f - np.einsum("ki,kij->kj", v, big_m), plain
    rows = np.arange(k)
    d2 = ((p[None] - v[:, None]) ** 2).sum(-1)
    w = weights(d2, config, radius)
    on_point = np.isinf(w)
    hit = on_point.any(axis=1)
    w = np.where(on_point, 0.0, w)
    wsum = w.sum(axis=1)
    reached = hit | (wsum > 0)
    # p - p_o and q - q_o about the nearest handle o (exactly 0 at its place): the centroids
    # and moments about them keep float64's precision where o's weight outweighs the others'
    # by far (next to a handle whose weight is steep, 1e40 against 1e-8), instead of losing
    # the others to the rounding of p* about v
    nearest = np.argmin(d2, axis=1)
    dp = p[None] - p[nearest][:, None]
    dq = q[None] - q[nearest][:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        pst = (w[..., None] * dp).sum(1) / wsum[:, None]
        qst = (w[..., None] * dq).sum(1) / wsum[:, None]
    first = np.argmax(on_point, axis=1)
    pst = np.where(hit[:, None], dp[rows, first], pst)
    qst = np.where(hit[:, None], dq[rows, first], qst)
    pst[~reached] = 0.0
    qst[~reached] = 0.0
    ph = dp - pst[:, None]
    qh = dq - qst[:, None]
    big_a = np.einsum("kn,kni,knj->kij", w, ph, ph)
    b = np.einsum("kn,kni,knj->kij", w, ph, qh)
    # coincident sources: their spread about p* against the yardstick, as 2D (:func:`mls`,
    # _yardstick). Sources all at one place have p - p_o = 0 exactly: no rounding noise to
    # allow for
    yardstick = _yardstick(p, w, d2, np.empty((k, 0)))
    coincident = ~(np.trace(big_a, axis1=-2, axis2=-1) > 1e-13 * yardstick)
    live = reached & ~coincident
    if live.any():
        big_m[live], plain[live] = _solve3(big_a[live], b[live], config.transform)
    # f(v) = q* + (v - p*) M, with p* - v = (p_o - v) + (p* - p_o)
    pst += p[nearest] - v
    qst += q[nearest] - v
    f = v + qst - np.einsum("ki,kij->kj", pst, big_m)
    f[~reached] = v[~reached]
    return f, big_m, f - np.einsum("ki,kij->kj", v, big_m), plain
