"""The paper's "forward with polygon interpolation", exactly as its pseudo-code says, in float64
numpy: the reference that ``method="paper-quads"`` (``glmls/shaders/warp/paper_quads.comp.glsl``)
is tested against.

::

    For each square S of adjacent pixels in the initial image
      Compute quadrilateral Q as applying f for S vertices (floating point coordinates)
      Compute the bounding rectangle R for Q (pixel coordinates)
      For each candidate pixel P in R
        If P was not marked and P inside Q, then
          Interpolate P's color using Q vertices' colors and mark P.

- A square S is four adjacent pixel centres (x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1);
  the squares are visited in row-major scan order (y outer, x inner), so where quadrilaterals
  overlap (f folds) the first square in that order keeps the pixel.
- The candidates are the output pixel centres in Q's bounding rectangle (widened by the
  tolerance below).
- "P inside Q": the crossing number of a ray from P parallel to Ox (towards +x) with Q's four
  edges is odd (the even-odd rule, half-open in y so a vertex on the ray counts once), or P
  lies within :data:`EDGE_TOLERANCE` of an edge. Points on an edge thus belong to Q (closed
  quadrilaterals; the first square in scan order keeps a pixel on a shared edge), and the
  tolerance absorbs f's float32 rounding on the GPU, so that the identity or a translation by
  whole pixels shows every pixel of the image, its border rows and columns included.
- The colour is the nearest neighbour's, as in the paper's tests: the vertex of S whose
  deformed position is nearest to P (ties: the first of the order above).
"""

from __future__ import annotations

import numpy as np

__all__ = ["EDGE_TOLERANCE", "paper_quads"]

#: Distance (output pixels) from an edge of Q within which a pixel centre counts as inside.
EDGE_TOLERANCE = 1.0 / 256.0

#: Offsets (x, y) of the four vertices of a square, in the order of the ties of the nearest.
SQUARE_VERTICES = ((0, 0), (1, 0), (1, 1), (0, 1))

_CHUNK = 1 << 20  # candidates per chunk: bounds the memory of the vectorised test


def paper_quads(
    deformed: object,
    output_shape: object,
    *,
    origin: object = (0.0, 0.0),
    tolerance: float = EDGE_TOLERANCE,
    counts: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """For each output pixel, the source pixel the paper's construction shows there.

    Parameters
    ----------
    deformed : (H, W, 2) array_like
        f at the source pixel centres, (x, y) in the deformed plane: ``deformed[y, x] =
        f(x, y)``.
    output_shape : (Ho, Wo)
        The output image; its pixel (column i, row j) is the deformed plane's point
        ``origin + (i, j)``.
    origin : (x0, y0)
        See ``output_shape``.
    tolerance : float
        :data:`EDGE_TOLERANCE` by default.
    counts : bool
        Also return how many quadrilaterals contain each pixel centre by the crossing number
        alone (> 1 where f folds; a centre on an edge two squares share counts once).

    Returns
    -------
    (Ho, Wo, 2) int64 array
        The (x, y) index into ``deformed`` of the source pixel each output pixel shows, -1
        where no quadrilateral covers it.
    (Ho, Wo) int64 array
        With ``counts``.
    """
    f = np.asarray(deformed, dtype=np.float64)
    if f.ndim != 3 or f.shape[2] != 2:
        raise ValueError(f"deformed must be (H, W, 2), got shape {f.shape}")
    height, width = (int(n) for n in output_shape)  # type: ignore[union-attr]
    if height < 1 or width < 1:
        raise ValueError(f"output_shape must be (H, W) with H, W >= 1, got {output_shape!r}")
    f = f - np.asarray(origin, dtype=np.float64)  # output pixel coordinates
    out = np.full((height, width, 2), -1, np.int64)
    count = np.zeros(height * width, np.int64)
    rows, cols = f.shape[0] - 1, f.shape[1] - 1
    if rows < 1 or cols < 1:
        return (out, count.reshape(height, width)) if counts else out
    # the squares' vertices in the order of SQUARE_VERTICES, squares in scan order
    quad = np.stack([f[:-1, :-1], f[:-1, 1:], f[1:, 1:], f[1:, :-1]], axis=2).reshape(-1, 4, 2)
    # R widened by the tolerance: a centre within it of an edge of Q is inside
    first = np.maximum(np.ceil(quad.min(axis=1) - tolerance), 0)
    last = np.minimum(np.floor(quad.max(axis=1) + tolerance), [width - 1, height - 1])
    finite = np.isfinite(quad).all(axis=(1, 2)) & (first <= last).all(axis=1)
    squares = np.nonzero(finite)[0]
    x0, y0 = first[squares].astype(np.int64).T
    nx = last[squares, 0].astype(np.int64) - x0 + 1
    ny = last[squares, 1].astype(np.int64) - y0 + 1
    sizes = nx * ny
    best = np.full(height * width, np.iinfo(np.int64).max, np.int64)
    vertex = np.zeros(height * width, np.int64)
    ends = np.cumsum(sizes)
    start = 0
    while start < len(squares):
        # squares [start, stop) with at most _CHUNK candidates (at least one square)
        base = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, base + _CHUNK, side="right")))
        part = slice(start, stop)
        boxes = (x0[part], y0[part], nx[part], ny[part], sizes[part])
        _chunk(quad, squares[part], boxes, width, tolerance, (best, vertex, count))
        start = stop
    covered = best != np.iinfo(np.int64).max
    k, v = best[covered], vertex[covered]
    offsets = np.array(SQUARE_VERTICES)
    flat = out.reshape(-1, 2)
    flat[covered, 0] = k % cols + offsets[v, 0]
    flat[covered, 1] = k // cols + offsets[v, 1]
    return (out, count.reshape(height, width)) if counts else out


def _chunk(quad, squares, boxes, width, tolerance, marks) -> None:
    """The candidates of ``squares`` (increasing scan order; their bounding ``boxes`` (x0,
    y0, columns, rows, pixels)): mark each pixel inside one of them, unless an earlier square
    (an earlier chunk, or earlier here) has. ``marks``: (best square, its vertex, crossing
    count) per pixel, updated."""
    x0, y0, nx, _, counts = boxes
    best, vertex, count = marks
    which = np.repeat(np.arange(len(squares)), counts)
    local = np.arange(len(which)) - np.repeat(np.cumsum(counts) - counts, counts)
    px = (x0[which] + local % nx[which]).astype(np.float64)
    py = (y0[which] + local // nx[which]).astype(np.float64)
    q = quad[squares[which]]  # (n, 4, 2)
    a, b = q, np.roll(q, -1, axis=1)  # edges a -> b
    ax, ay, bx, by = a[..., 0], a[..., 1], b[..., 0], b[..., 1]
    pxe, pye = px[:, None], py[:, None]
    straddles = (ay > pye) != (by > pye)
    with np.errstate(divide="ignore", invalid="ignore"):
        cross_x = ax + (pye - ay) * (bx - ax) / (by - ay)
    crossings = (straddles & (pxe < cross_x)).sum(axis=1)
    # distance to each edge (a degenerate edge: to its point)
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(length2 > 0, ((pxe - ax) * dx + (pye - ay) * dy) / length2, 0.0)
    t = np.clip(t, 0.0, 1.0)
    ex, ey = ax + t * dx - pxe, ay + t * dy - pye
    on_edge = (ex * ex + ey * ey <= tolerance * tolerance).any(axis=1)
    odd = crossings % 2 == 1
    np.add.at(count, (py * width + px).astype(np.int64)[odd], 1)
    inside = odd | on_edge
    pixel = (py * width + px).astype(np.int64)[inside]
    k = squares[which[inside]]
    near = np.argmin(((q[inside] - np.stack([px, py], -1)[inside, None, :]) ** 2).sum(-1), axis=1)
    # candidates come in increasing square order: the first one of each pixel is its square
    pixels, first = np.unique(pixel, return_index=True)
    fresh = k[first] < best[pixels]
    best[pixels[fresh]] = k[first][fresh]
    vertex[pixels[fresh]] = near[first][fresh]
