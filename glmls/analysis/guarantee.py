"""The adaptive mesh's guarantee, measured against the float64 reference: the maps of the
table of :doc:`/adaptive` (:func:`guarantee_handles`), the source point the warp computes
at every output pixel (:func:`source_points`), its distance from f's true inverse
(:func:`inverse_error`) and the leaf whose triangle drew each pixel (:func:`first_triangles`).

``benchmarks/guarantee.py`` prints the table from these; ``tests/imaging/test_adaptive.py``
checks the same bound on fewer cases.
"""

from __future__ import annotations

import numpy as np

from .. import reference
from ..gl.resources import keep_framebuffer
from ..imaging.frame import Frame
from ..imaging.pipeline import WarpPipeline

__all__ = [
    "SHAPE",
    "first_triangles",
    "guarantee_handles",
    "inverse_error",
    "jittered_moves",
    "pixel_leaves",
    "smooth_handles",
    "source_points",
    "stretched_handles",
]

#: The image's shape (rows, columns).
SHAPE = (160, 192)


def smooth_handles(shape, rng, displacement=None):
    """A jittered 3 x 3 lattice of handles over the image, targets moved by up to
    ``displacement`` (8 % of the image by default): a typical, fold-free deformation."""
    height, width = shape
    displacement = displacement or 0.08 * min(shape)
    lattice = np.stack(np.meshgrid([0.15, 0.5, 0.85], [0.15, 0.5, 0.85]), -1).reshape(-1, 2)
    p = lattice * [width - 1, height - 1] + rng.uniform(-0.05, 0.05, (9, 2)) * [width, height]
    return p, p + rng.uniform(-displacement, displacement, p.shape)


def stretched_handles(shape):
    """Two close handles pulled apart (the map stretches strongly between them) and four
    that pin the corners."""
    height, width = shape
    c = np.array([(width - 1) / 2, (height - 1) / 2])
    p = np.array([[0.15, 0.15], [0.85, 0.15], [0.85, 0.85], [0.15, 0.85]]) * [width, height]
    p = np.concatenate([p, [c - [4, 0], c + [4, 0]]])
    q = p.copy()
    q[4] -= [14, 0]
    q[5] += [14, 0]
    return p, q


def jittered_moves(shape, rng):
    """W2 in small: random handles moved by up to 3.4 % of the image (the mesh folds)."""
    height, width = shape
    p = rng.uniform(0.05, 0.95, (24, 2)) * [width, height]
    return p, p + rng.uniform(-0.034, 0.034, p.shape) * [width, height]


def guarantee_handles(case):
    """The handles of the guarantee's maps (:doc:`/adaptive`), as ``MLS`` keywords:
    smooth, two close handles pulled apart, two draws of random ones that fold, 60 handles
    moved by up to 3 px, and 8 point handles with 4 segments."""
    if case == "random2":
        p, q = jittered_moves(SHAPE, np.random.default_rng(11))
        return {"src": p, "dst": q}
    rng = np.random.default_rng(7)
    if case == "dense":
        p = rng.uniform(0.05, 0.95, (60, 2)) * [SHAPE[1], SHAPE[0]]
        return {"src": p, "dst": p + rng.uniform(-3, 3, p.shape)}
    if case == "segments":
        rng = np.random.default_rng(3)
        size = [SHAPE[1], SHAPE[0]]
        p = rng.uniform(0.1, 0.9, (8, 2)) * size
        q = p + rng.uniform(-5, 5, p.shape)
        a = rng.uniform(0.15, 0.85, (4, 2)) * size
        src = np.stack([a, a + rng.uniform(-30, 30, a.shape)], 1)
        dst = src + rng.uniform(-4, 4, (4, 1, 2))
        return {"src": p, "dst": q, "src_segments": src, "dst_segments": dst}
    p, q = {  # each drawn after the others before it
        "smooth": smooth_handles(SHAPE, rng),
        "stretched": stretched_handles(SHAPE),
        "random": jittered_moves(SHAPE, rng),
    }[case]
    return {"src": p, "dst": q}


def source_points(m, shape, tolerance):
    """(the adaptive mesh, (H, W, 2) source points the warp uses, (H, W) covered)."""
    pipe = WarpPipeline.of(m.ctx)
    with m.ctx.use():
        mesh = pipe.adaptive.mesh(m.kernel, shape, tolerance)
        mgl = m.ctx.mgl
        with keep_framebuffer(mgl):  # never leave a released framebuffer bound
            fb = mgl.simple_framebuffer((shape[1], shape[0]), components=4, dtype="f4")
            try:
                fb.use()
                fb.clear(0, 0, 0, 0)
                fill = {"linear": False, "coords": True, "flip_y": False, "border": 0}
                pipe.adaptive.draw(mesh, None, Frame(shape), fb, **fill)
                raw = fb.read(components=4, dtype="f4")
            finally:
                fb.release()
    values = np.frombuffer(raw, np.float32).reshape(*shape, 4)
    return mesh, values[..., :2].astype(np.float64), values[..., 2] > 0.5


def inverse_error(m, shape, xy, covered, steps=8):
    """|s - f^-1(u)| at every covered output pixel u where f is locally invertible (folded
    pixels have no single inverse), f in float64: (H, W), NaN elsewhere; and the share of
    the covered pixels that are. To first order, J(s)^-1 (f(s) - u) (J by central
    differences), then Newton's steps (up to ``steps``) where that is over 0.01 px: the
    first order errs by f's curvature times the distance squared (idw alpha 2 at 1 px: 1.085
    px by first order, 0.79 exact). A pixel whose steps do not settle, or reach a point
    where f is not locally invertible, keeps the first order."""
    yy, xx = np.nonzero(covered)
    s = xy[yy, xx]
    u = np.stack([xx, yy], -1).astype(np.float64)
    segments = {"src_segments": m.src_segments, "dst_segments": m.dst_segments}

    def newton(points):  # (f - u, J) at points (n, 2)
        h = 1e-3
        around = ([0, 0], [h, 0], [-h, 0], [0, h], [0, -h])
        f, _, _ = reference.mls(
            m.src,
            m.dst,
            np.concatenate([points + d for d in around]),
            m.config,
            shape=shape,
            **segments,
        )
        f0, fx1, fx0, fy1, fy0 = np.split(f, 5)
        return f0, np.stack([(fx1 - fx0) / (2 * h), (fy1 - fy0) / (2 * h)], axis=-1)

    f0, jac = newton(s)
    regular = np.linalg.det(jac) > 0.05
    s, u = s[regular], u[regular]
    first = s - np.linalg.solve(jac[regular], (f0[regular] - u)[..., None])[..., 0]
    inverse = first.copy()
    active = np.flatnonzero(np.hypot(*(inverse - s).T) > 0.01)
    t = inverse[active]
    for _ in range(steps):
        if len(active) == 0:
            break
        f_t, jac_t = newton(t)
        ok = np.linalg.det(jac_t) > 0.05
        inverse[active[~ok]] = first[active[~ok]]  # off the sheet: the first order
        t, active, f_t, jac_t = t[ok], active[ok], f_t[ok], jac_t[ok]
        t -= np.linalg.solve(jac_t, (f_t - u[active])[..., None])[..., 0]
        settled = np.hypot(*(t - inverse[active]).T) < 1e-7
        inverse[active] = t
        t, active = t[~settled], active[~settled]
    inverse[active] = first[active]  # not settled: the first order
    error = np.full(shape, np.nan)
    error[yy[regular], xx[regular]] = np.hypot(*(s - inverse).T)
    return error, regular.mean()


def first_triangles(mesh, shape, margin=1e-4):
    """Each pixel centre's first triangle of ``mesh`` in scan order, as the scan draws it:
    (H, W) indices, -1 where none covers it, and where one within ``margin`` (barycentric)
    of its edges decides (rounding may go either way there)."""
    tri = mesh.deformed[mesh.triangles.astype(np.int64)]  # (T, 3, 2)
    height, width = shape
    strict = np.full(shape, -1)
    loose = np.full(shape, -1)
    for t in range(len(tri) - 1, -1, -1):  # the first triangle last: it stays
        a, b, c = tri[t]
        area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        lo = np.maximum(np.floor(tri[t].min(0)), 0).astype(int)
        hi = np.minimum(np.ceil(tri[t].max(0)), [width - 1, height - 1]).astype(int)
        if abs(area) < 1e-9 or (lo > hi).any():
            continue
        yy, xx = np.mgrid[lo[1] : hi[1] + 1, lo[0] : hi[0] + 1]
        lb = ((xx - a[0]) * (c[1] - a[1]) - (yy - a[1]) * (c[0] - a[0])) / area
        lc = ((b[0] - a[0]) * (yy - a[1]) - (b[1] - a[1]) * (xx - a[0])) / area
        least = np.minimum(np.minimum(lb, lc), 1 - lb - lc)
        strict[yy[least > margin], xx[least > margin]] = t
        loose[yy[least > -margin], xx[least > -margin]] = t
    return np.where(strict == loose, strict, -1)


def pixel_leaves(mesh, shape, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """The leaf of ``mesh`` whose triangle draws each pixel (:func:`first_triangles`),
    (H, W), -1 where none or where rounding decides; and (H, W) bool, where that leaf
    vouches for the pixel (its ``AdaptiveMesh.estimate`` within ``tolerance``)."""
    first = first_triangles(mesh, shape)
    drawn = first >= 0
    leaf = np.full(shape, -1)
    leaf[drawn] = mesh.triangle_leaf[first[drawn]]
    vouched = np.zeros(shape, bool)
    vouched[drawn] = mesh.estimate[leaf[drawn]] <= tolerance
    return leaf, vouched
