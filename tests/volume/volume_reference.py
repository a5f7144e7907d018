"""A float64 numpy reference of the volume constructions, written from their definitions:

- cells: for each output voxel centre, the FIRST cell in scan order of the source (smallest
  (z, y, x)) one of whose 6 deformed Kuhn tetrahedra contains it (the first of those), and the
  source point interpolated linearly in that tetrahedron;
- backward: f's inverse by Newton's method in float64 (glmls.volume.fields.newton_inverse);

then the source sampled at that point, nearest (within the cell's own voxels, for cells) or
trilinear, with numpy.pad's border rules."""

from __future__ import annotations

import numpy as np

from glmls.volume.fields import newton_inverse
from glmls.volume.frame import CornerLattice

TETRA = [(1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)]
CORNERS = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)])
EPS = 1e-5


def border_index(i: np.ndarray, n: int, border: str) -> np.ndarray:
    if border == "symmetric":
        m = np.mod(i, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    if border == "reflect":
        if n == 1:
            return np.zeros_like(i)
        m = np.mod(i, 2 * n - 2)
        return np.where(m < n, m, 2 * n - 2 - m)
    if border == "wrap":
        return np.mod(i, n)
    return np.clip(i, 0, n - 1)


def texel(volume: np.ndarray, p: np.ndarray, border: str) -> np.ndarray:
    """volume (D, H, W, C) at integer points p (K, 3) (x, y, z)."""
    d, h, w = volume.shape[:3]
    x = border_index(p[:, 0], w, border)
    y = border_index(p[:, 1], h, border)
    z = border_index(p[:, 2], d, border)
    return volume[z, y, x].astype(np.float64)


def sample(volume, s, border, linear):
    if not linear:
        return texel(volume, np.floor(s + 0.5).astype(np.int64), border)
    c = np.floor(s)
    t = s - c
    p = c.astype(np.int64)
    out = 0.0
    for corner in CORNERS:
        weight = np.prod(np.where(corner == 1, t, 1 - t), axis=1)
        out = out + weight[:, None] * texel(volume, p + corner, border)
    return out


def cells(field, shape, grid, out_shape, origin=(0.0, 0.0, 0.0), margin=0):
    """(key, source point) per output voxel: key -1 where no cell covers it."""
    lattice = CornerLattice(tuple(shape), grid, margin)
    nx, ny, nz = lattice.dims
    points = lattice.layer_points(0, nz)
    f = field.evaluate(points.reshape(-1, 3)).reshape(nz, ny, nx, 3) - np.asarray(origin)
    depth, height, width = out_shape
    key = np.full(out_shape, -1, np.int64)
    source = np.zeros((*out_shape, 3))
    nearest_lo = np.zeros((*out_shape, 3), np.int64)
    nearest_hi = np.zeros((*out_shape, 3), np.int64)
    top = np.array([width, height, depth]) - 1
    for cz in range(nz - 1):
        for cy in range(ny - 1):
            for cx in range(nx - 1):
                cell = np.array([cx, cy, cz])
                idx = cell + CORNERS
                q = f[idx[:, 2], idx[:, 1], idx[:, 0]]
                s = points[idx[:, 2], idx[:, 1], idx[:, 0]]
                for b, c in TETRA:
                    tet = q[[0, b, c, 7]]
                    lo = np.maximum(np.ceil(tet.min(0) - EPS), 0).astype(int)
                    hi = np.minimum(np.floor(tet.max(0) + EPS), top).astype(int)
                    if np.any(lo > hi):
                        continue
                    zz, yy, xx = np.meshgrid(
                        *(np.arange(lo[a], hi[a] + 1) for a in (2, 1, 0)), indexing="ij"
                    )
                    vox = np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=1)
                    free = key[vox[:, 2], vox[:, 1], vox[:, 0]] < 0
                    vox = vox[free]
                    if len(vox) == 0:
                        continue
                    edges = (tet[1:] - tet[0]).T  # columns e1, e2, e3
                    if abs(np.linalg.det(edges)) < 1e-12:
                        continue
                    lam = np.linalg.solve(edges, (vox - tet[0]).T).T
                    depth_in = np.minimum(lam.min(1), 1 - lam.sum(1))
                    inside = depth_in >= -EPS
                    vox, lam = vox[inside], lam[inside]
                    src = s[[0, b, c, 7]]
                    point = src[0] + lam @ (src[1:] - src[0])
                    k = (cz * (ny - 1) + cy) * (nx - 1) + cx
                    key[vox[:, 2], vox[:, 1], vox[:, 0]] = k
                    source[vox[:, 2], vox[:, 1], vox[:, 0]] = point
                    low = cell * grid + np.asarray(lattice.voxel_first)
                    nearest_lo[vox[:, 2], vox[:, 1], vox[:, 0]] = low
                    nearest_hi[vox[:, 2], vox[:, 1], vox[:, 0]] = np.minimum(
                        low + grid - 1, np.asarray(lattice.voxel_end) - 1
                    )
    return key, source, nearest_lo, nearest_hi


def warp_cells(
    field,
    volume,
    *,
    grid=1,
    linear=False,
    border="constant",
    background=0.0,
    out_shape=None,
    origin=(0.0, 0.0, 0.0),
    margin=0,
):
    """The cells method's volume (D, H, W, C) float64 (not rounded)."""
    out_shape = tuple(out_shape or volume.shape[:3])
    key, source, lo, hi = cells(field, volume.shape[:3], grid, out_shape, origin, margin)
    covered = key >= 0
    s = source[covered]
    if linear:
        values = sample(volume, s, border, True)
    else:
        p = np.clip(np.floor(s + 0.5).astype(np.int64), lo[covered], hi[covered])
        values = texel(volume, p, border)
    out = np.full((*out_shape, volume.shape[3]), float(background))
    out[covered] = values
    return out


def inverse(field, shape, out_shape=None, origin=(0.0, 0.0, 0.0), guess=None):
    """f's inverse at every output voxel (D, H, W, 3) and its residual, float64."""
    out_shape = tuple(out_shape or shape)
    k, j, i = np.meshgrid(*(np.arange(n) for n in out_shape), indexing="ij")
    u = np.stack([i, j, k], axis=-1).reshape(-1, 3) + np.asarray(origin)
    start = u if guess is None else guess.reshape(-1, 3)
    s, residual = newton_inverse(field, u, start)
    return s.reshape(*out_shape, 3), residual.reshape(out_shape)


def box_handles(shape, rng, count=8, spread=1.5):
    """Handles at the corners of the volume's box (and some inside), moved by up to
    ``spread`` voxels."""
    d, h, w = shape
    corners = np.array([[x, y, z] for z in (0, d - 1) for y in (0, h - 1) for x in (0, w - 1)])
    extra = rng.uniform([0, 0, 0], [w - 1, h - 1, d - 1], (max(0, count - 8), 3))
    src = np.concatenate([corners, extra]).astype(np.float64)
    return src, src + rng.uniform(-spread, spread, src.shape)
