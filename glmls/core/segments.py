"""Line-segment handles (Schaefer, McPhail & Warren 2006, section 4): validation, polylines and
the moments of one segment that MLS needs, in float64.

A segment handle s runs from ``A[s, 0]`` to ``A[s, 1]`` in the source and from ``B[s, 0]`` to
``B[s, 1]`` in the target: p(t) = (1 - t) a + t b, q(t) = (1 - t) c + t d, t in [0, 1]. Every sum
of point MLS becomes an integral along the segment per unit length, with the weight
|b - a| w(|p(t) - v|) at parameter t, so a segment split in two is the same handle as the whole.

With x the arc length from the foot of the perpendicular from v (the closest point of the
segment's line) and h the distance of v to that line, |p(t) - v|^2 = h^2 + x^2, and a segment's
share of every moment follows from three integrals over its arc, J_k = integral of w x^k dx
(k = 0, 1, 2): see :func:`segment_integrals`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import DtypeError
from .config import MLSConfig
from .handles import as_points, check_coordinates

__all__ = [
    "SEGMENT_PANEL_WIDTH",
    "SEGMENT_S_FLOOR",
    "as_segments",
    "check_on_segments",
    "polyline_segments",
    "segment_config",
    "segment_feet",
    "segment_panel_width",
    "segment_pole",
    "segments_interpolate",
    "validate_segments",
]

#: idw's adjusting term s below this (pixels^(2 alpha)) is a guard against division by zero
#: (the default is 1e-8), not a smoothing: segment handles use s = 0 then, so that f maps every
#: point of a source segment onto its target (with s = 1e-8 the weight of the segment's
#: neighbourhood, pi / sqrt(s), would not dominate the others: 0.5 px off on a busy image).
SEGMENT_S_FLOOR = 1e-6


def segment_config(config: MLSConfig) -> MLSConfig:
    """The configuration whose weight segment handles use: ``config``, with idw's s set to 0
    where it is below :data:`SEGMENT_S_FLOOR`."""
    if config.weight_entry.uses_s and 0.0 < config.s < SEGMENT_S_FLOOR:
        return replace(config, s=0.0)
    return config


def segments_interpolate(config: MLSConfig) -> bool:
    """Whether f maps every point of a source segment onto its target, f(p(t)) = q(t): where
    the weight of segment handles (:func:`segment_config`) grows at least like 1 / d at
    d = 0, so that its integral along the segment is infinite on it. A weight infinite at
    d = 0 that grows more slowly (idw with alpha < 1/2 and s = 0, a weight made interpolating
    with alpha < 1/2, idw made interpolating with alpha < 1/4) has a finite integral there:
    f is continuous across the segment and passes beside its target.

    Examples
    --------
    >>> segments_interpolate(MLSConfig(s=0.0)), segments_interpolate(MLSConfig(alpha=0.3, s=0.0))
    (True, False)
    """
    return segment_pole(config) >= 1.0


def segment_pole(config: MLSConfig) -> float:
    """The power p of the weight w ~ 1 / d^p at d = 0 that segment handles take
    (:func:`segment_config`), times 1 / d^(2 alpha) more where interpolating; 0 where w(0)
    is finite. Integrated along a segment h away, w gives ~h^(1-p) (p > 1), ~2 log(1 / h)
    (p = 1) or a finite value (p < 1).

    Examples
    --------
    >>> segment_pole(MLSConfig()), segment_pole(MLSConfig(weight="shepard", radius=50.0))
    (2.0, 1.0)
    """
    return segment_config(config).pole


#: The GPU's widest Gauss-Legendre panel along a segment (8 nodes), in the variable t of
#: x = c sinh(t) (glmls/shaders/mls/segments.glsl); steep weights take narrower ones.
SEGMENT_PANEL_WIDTH = 1.5


def segment_panel_width(config: MLSConfig) -> float:
    """The width of the GPU's panels along a segment for ``config``'s weight: in t the
    weight's tail falls like e^(-(p - 1) |t|) (p its :func:`segment_pole`), which 8 nodes
    resolve to ~1e-9 over a panel 12 / (p - 1) wide; :data:`SEGMENT_PANEL_WIDTH` where that
    is wider (p up to 9). Panels 1.5 wide would integrate poles of 20 and 40 (idw made
    interpolating with alpha 5 and 10) to 1.5e-4 and 5.9e-3 only.

    Examples
    --------
    >>> segment_panel_width(MLSConfig()), segment_panel_width(MLSConfig(alpha=10.0, s=0.0))
    (1.5, 0.631578947368421)
    """
    pole = segment_pole(config)
    return SEGMENT_PANEL_WIDTH if pole <= 9.0 else min(SEGMENT_PANEL_WIDTH, 12.0 / (pole - 1.0))


def as_segments(segments: object, name: str) -> np.ndarray:
    """``segments`` as a C-contiguous float64 (S, 2, 2) array; ``ValueError``/``TypeError``
    naming ``name`` if it is not one (wrong shape, not numbers, NaN or inf)."""
    try:
        array = np.asarray(segments)
    except ValueError:  # ragged: segments of different lengths or ends of other sizes
        raise ValueError(
            f"{name} must have shape (S, 2, 2): S segments of two (x, y) ends, "
            f"got rows of different lengths"
        ) from None
    if array.dtype == object or not (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    ):
        raise DtypeError(f"{name} must be real numbers, got dtype {array.dtype}")
    if array.shape in ((0,), (0, 2, 2)):  # [] is no segments
        return np.zeros((0, 2, 2))
    if array.ndim != 3 or array.shape[1:] != (2, 2):
        raise ValueError(
            f"{name} must have shape (S, 2, 2): S segments of two (x, y) ends, got {array.shape}"
        )
    array = np.ascontiguousarray(array, dtype=np.float64)
    bad = ~np.isfinite(array).reshape(len(array), 4).all(axis=1)
    if bad.any():
        row = int(np.argmax(bad))
        raise ValueError(f"{name} must be finite; segment {row} is {array[row].tolist()}")
    check_coordinates(array.reshape(-1, 2), name)
    return array


def validate_segments(src_segments: object, dst_segments: object) -> tuple[np.ndarray, np.ndarray]:
    """Check source segments A and target segments B; return them as float64 (S, 2, 2).

    ``ValueError`` for: only one of the two given, different counts, a source segment of zero
    length (a point: use a point handle), or one source segment (either direction) given two
    different targets.
    """
    if (src_segments is None) != (dst_segments is None):
        given, missing = (
            ("src_segments", "dst_segments")
            if dst_segments is None
            else ("dst_segments", "src_segments")
        )
        raise ValueError(f"{given} needs {missing}: give both (shape (S, 2, 2)) or neither")
    if src_segments is None:
        return np.zeros((0, 2, 2)), np.zeros((0, 2, 2))
    a = as_segments(src_segments, "src_segments")
    b = as_segments(dst_segments, "dst_segments")
    if len(a) != len(b):
        raise ValueError(
            f"src_segments and dst_segments must have the same length, got {len(a)} and {len(b)}"
        )
    zero = (a[:, 0] == a[:, 1]).all(axis=1)
    if zero.any():
        row = int(np.argmax(zero))
        raise ValueError(
            f"src_segments[{row}] has zero length (both ends at {a[row, 0].tolist()}): "
            "that is a point, give it as a point handle (src, dst)"
        )
    _check_conflicts(a, b)
    return a, b


def _check_conflicts(a: np.ndarray, b: np.ndarray) -> None:
    """``ValueError`` if one source segment (taken in either direction) has two different
    targets: f cannot take two values along it."""
    if len(a) < 2:
        return
    # orient every segment so that its source runs from the lexicographically smaller end
    flip = (a[:, 0, 0] > a[:, 1, 0]) | ((a[:, 0, 0] == a[:, 1, 0]) & (a[:, 0, 1] > a[:, 1, 1]))
    a2 = np.where(flip[:, None, None], a[:, ::-1], a).reshape(-1, 4)
    b2 = np.where(flip[:, None, None], b[:, ::-1], b).reshape(-1, 4)
    order = np.lexsort(a2.T[::-1])
    same = (a2[order[1:]] == a2[order[:-1]]).all(axis=1)
    differ = (b2[order[1:]] != b2[order[:-1]]).any(axis=1)
    conflict = same & differ
    if conflict.any():
        k = int(np.argmax(conflict))
        i, j = sorted((int(order[k]), int(order[k + 1])))
        # b[j] in a[i]'s direction, so that the two targets compare end by end
        reversed_ = flip[i] != flip[j]
        other = b[j, ::-1] if reversed_ else b[j]
        given = f" (src_segments[{j}] reversed, its target too)" if reversed_ else ""
        raise ValueError(
            f"src_segments[{i}] and src_segments[{j}] are the same segment {a[i].tolist()} "
            f"with different targets {b[i].tolist()} and {other.tolist()}{given}"
        )


#: Candidate (point, segment) pairs tested at once by :func:`check_on_segments` (memory bound).
_PAIR_BLOCK = 1 << 18


def check_on_segments(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
    """``ValueError`` if a source point lies on a source segment whose target there is not
    the point's own target: f cannot take both values; or if a source segment is no longer
    than the tolerance below (a point to the GPU).

    The points are the point handles and the ends of the segments (a segment's end on
    another segment, two segments sharing a vertex); "on" and "the same target" are up to
    a tolerance of a few float32 steps of the handles' extent (what the GPU tells apart),
    the target's widened by the segment's stretch (its target's length over its own).

    Parameters
    ----------
    p, q : numpy.ndarray
        Validated point handles, (N, 2) float64.
    a, b : numpy.ndarray
        Validated segment handles, (S, 2, 2) float64, no zero-length source segment.
    """
    if not len(a):
        return
    x = np.concatenate([p, a.reshape(-1, 2)])
    y = np.concatenate([q, b.reshape(-1, 2)])
    owner = np.concatenate([np.full(len(p), -1), np.repeat(np.arange(len(a)), 2)])
    both = np.concatenate([x, y])
    extent = float((both.max(axis=0) - both.min(axis=0)).max())
    tol = 4.0 * float(np.finfo(np.float32).eps) * max(extent / 2.0, 1.0)
    length = np.hypot(*(a[:, 1] - a[:, 0]).T)
    if (length <= tol).any():
        # its ends (nearly) one point on the GPU: its moments are lost, or NaN
        s = int(np.argmax(length <= tol))
        raise ValueError(
            f"src_segments[{s}] {a[s].tolist()} is {length[s]:.3g} px long, shorter than "
            f"float32 on the GPU tells apart at this scale ({tol:.3g} px): give it as a "
            "point handle"
        )
    found = _first_on_segment(x, y, owner, a, b, tol)
    if found is None:
        return
    k, s, t, there = found
    if k < len(p):
        name, own = f"src[{k}] {p[k].tolist()}", "its target"
    else:
        name = f"src_segments[{(k - len(p)) // 2}][{(k - len(p)) % 2}] {x[k].tolist()}"
        own = "that end's target"
    raise ValueError(
        f"{name} lies on src_segments[{s}] {a[s].tolist()} (at t = {t:.6g}), whose target "
        f"there is {there.tolist()}, but {own} is {y[k].tolist()}"
    )


def _cell_candidates(
    x: np.ndarray, a: np.ndarray, tol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Which points x may lie within ``tol`` of which source segment a: with the points
    sorted into square cells (``order``), each item (segment ``seg``, cell) holds the sorted
    points ``order[lo:lo + counts]``. The cells a segment covers are those of samples half a
    cell apart along it and their 8 neighbours (a cell is at least 4 tol wide): a point within
    tol of the segment is within half a cell of a sample. Work grows with the points near the
    segments, not with points times segments."""
    both = np.concatenate([x, a.reshape(-1, 2)])
    low = both.min(axis=0)
    extent = max(float((both.max(axis=0) - low).max()), tol)
    length = np.hypot(*(a[:, 1] - a[:, 0]).T)
    # about one point per cell, and no wider than a typical segment (where a polyline's many
    # ends crowd); at most 2^20 samples along the segments, 4096 cells across
    cell = min(extent / np.sqrt(len(x)), float(np.median(length)))
    cell = max(cell, 2.0 * float(length.sum()) / 2**20, extent / 4096.0, 4.0 * tol)
    width = int(extent / cell) + 3  # cells -1 .. grid + 1 of the neighbourhoods
    corner = np.floor((x - low) / cell).astype(np.int64) + 1
    order = np.argsort(corner[:, 0] * width + corner[:, 1], kind="stable")
    keys = (corner[:, 0] * width + corner[:, 1])[order]
    n = np.maximum(np.ceil(2.0 * length / cell).astype(np.int64) + 1, 2)
    seg = np.repeat(np.arange(len(a)), n)
    t = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n - 1, n)
    samples = a[seg, 0] + t[:, None] * (a[seg, 1] - a[seg, 0])
    centre = np.floor((samples - low) / cell).astype(np.int64) + 1
    near = [(centre[:, 0] + i) * width + centre[:, 1] + j for i in (-1, 0, 1) for j in (-1, 0, 1)]
    items = np.unique(np.tile(seg, 9) * width * width + np.concatenate(near))
    cells = items % (width * width)
    lo = np.searchsorted(keys, cells, "left")
    return order, items // (width * width), lo, np.searchsorted(keys, cells, "right") - lo


def _first_on_segment(
    x: np.ndarray, y: np.ndarray, owner: np.ndarray, a: np.ndarray, b: np.ndarray, tol: float
) -> tuple[int, int, float, np.ndarray] | None:
    """The first (point k, segment s, parameter t, segment target there) of a point x[k]
    within ``tol`` of a source segment s other than its own (``owner[k]``) whose target
    there is off y[k] by more than the tolerance; None if there is none."""
    order, item_seg, lo, counts = _cell_candidates(x, a, tol)
    first = np.cumsum(counts) - counts
    best: tuple[int, int] | None = None
    for block in np.split(np.arange(len(lo)), np.flatnonzero(np.diff(first // _PAIR_BLOCK)) + 1):
        n = counts[block]
        if not n.sum():
            continue
        seg = np.repeat(item_seg[block], n)
        k = order[np.repeat(lo[block], n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)]
        start, step = a[seg, 0], a[seg, 1] - a[seg, 0]
        t = np.clip(((x[k] - start) * step).sum(axis=1) / (step**2).sum(axis=1), 0.0, 1.0)
        on = (((start + t[:, None] * step - x[k]) ** 2).sum(axis=1) <= tol**2) & (owner[k] != seg)
        if not on.any():
            continue
        k, seg, t = k[on], seg[on], t[on]
        there = (1.0 - t)[:, None] * b[seg, 0] + t[:, None] * b[seg, 1]
        stretch = np.hypot(*(b[seg, 1] - b[seg, 0]).T) / np.hypot(*(a[seg, 1] - a[seg, 0]).T)
        off = np.hypot(*(y[k] - there).T) > tol * (1.0 + stretch)
        if off.any():
            pairs = sorted(zip(k[off].tolist(), seg[off].tolist(), strict=True))
            best = pairs[0] if best is None else min(best, pairs[0])
    if best is None:
        return None
    k, s = best
    step = a[s, 1] - a[s, 0]
    t = float(np.clip(np.dot(x[k] - a[s, 0], step) / np.dot(step, step), 0.0, 1.0))
    return k, s, t, (1.0 - t) * b[s, 0] + t * b[s, 1]


def polyline_segments(points: object) -> np.ndarray:
    """The segments of a polyline, segment k from vertex k to vertex k + 1.

    Give a source polyline and its target polyline of the same K to get ``src_segments`` and
    ``dst_segments``; close a polygon by repeating its first vertex. Repeated consecutive
    vertices give zero-length segments, which :class:`glmls.MLS` refuses (in the source).

    Parameters
    ----------
    points : array_like
        The vertices, (K, 2) (x, y) rows.

    Returns
    -------
    numpy.ndarray
        The segments, (K - 1, 2, 2) float64.

    Raises
    ------
    ValueError
        For fewer than 2 vertices, a wrong shape or a value that is not finite.
    TypeError
        For vertices that are not numeric.

    Examples
    --------
    >>> glmls.polyline_segments([[0, 0], [10, 0], [10, 5]]).tolist()
    [[[0.0, 0.0], [10.0, 0.0]], [[10.0, 0.0], [10.0, 5.0]]]
    """
    vertices = as_points(points, "polyline")
    if len(vertices) < 2:
        raise ValueError(f"a polyline needs at least 2 vertices, got {len(vertices)}")
    return np.stack([vertices[:-1], vertices[1:]], axis=1)


def segment_feet(
    segments: np.ndarray, points: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For source segments (S, 2, 2) and points (K, 2): the parameter t0 of the foot of the
    perpendicular from each point to each segment's line (K, S; may lie outside [0, 1]), the
    squared distance h^2 to that line (K, S), and the squared distance to the segment itself
    (K, S)."""
    a = segments[None, :, 0]
    d = segments[None, :, 1] - a
    length2 = (d**2).sum(-1)
    w = points[:, None, :] - a
    t0 = (w * d).sum(-1) / length2
    foot = a + t0[..., None] * d
    h2 = ((points[:, None, :] - foot) ** 2).sum(-1)
    tc = np.clip(t0, 0.0, 1.0)
    closest = a + tc[..., None] * d
    return t0, h2, ((points[:, None, :] - closest) ** 2).sum(-1)


#: Gauss-Legendre panels of the reference quadrature (see :func:`segment_integrals`).
REFERENCE_PANELS = 24
REFERENCE_NODES = 12


def sinh_nodes(
    x0: np.ndarray, x1: np.ndarray, c: np.ndarray, panels: int, nodes: int
) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature nodes x and weights for integrals over [x0, x1] of functions of
    sqrt(c^2 + x^2), which peak at x = 0 with width c: the sinh substitution x = c sinh(u)
    (Johnston & Elliott 2005) turns the peak into a smooth bump, integrated by ``panels``
    Gauss-Legendre panels of ``nodes`` nodes each. Shapes: inputs broadcast to (...), outputs
    (..., panels * nodes); the weights include the Jacobian c cosh(u)."""
    gx, gw = np.polynomial.legendre.leggauss(nodes)
    u0 = np.arcsinh(x0 / c)
    u1 = np.arcsinh(x1 / c)
    width = (u1 - u0) / panels
    # panel k spans [u0 + k width, u0 + (k + 1) width]; node (1 + gx) / 2 of it
    k = np.arange(panels)[:, None] + (1.0 + gx[None, :]) / 2.0  # (panels, nodes)
    u = u0[..., None] + width[..., None] * k.reshape(-1)
    weight = (width / 2.0)[..., None] * np.tile(gw, panels)
    return c[..., None] * np.sinh(u), weight * c[..., None] * np.cosh(u)
