"""The backward method on maps that fold over strongly, with the border modes that extend the
source over the whole plane (``edge``, ``reflect``, ``symmetric``, ``wrap``): every output
pixel that has a preimage within the mesh's reach is drawn, from a true preimage, checked
against f in float64 (:mod:`glmls.reference`).

The maps mirror their sources (q = (W - 1 - x, y), or about a diagonal) but for a few handles
left in place, with the rigid transform: the rigid fit of mirrored handles has points, in the
mesh's margin, about which its rotation is undefined and turns a full circle, and the mesh's
cells there, first in scan order, are stretched over much of the canvas. Their piecewise
linear inverse is no guess at all, nor are the guesses of their neighbours: the second pass
fills those regions from their rims, run by run.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls import reference
from glmls.core.mesh import MeshLattice
from glmls.imaging.frame import Frame, border_margin
from glmls.imaging.inverse import NEWTON_ACCEPT

SHAPE = (48, 64)
MAPS = {
    # q = (63 - x, y) but for one handle
    "mirror": (
        [[17.9, 3.8], [3.0, 37.0], [55.9, 28.1], [45.0, 25.4], [57.2, 37.1], [2.2, 38.9],
         [4.0, 33.4], [12.4, 39.1], [33.9, 14.9], [26.9, 3.2], [9.3, 30.8], [40.2, 28.5],
         [24.6, 44.9], [59.9, 31.5], [40.4, 31.6]],
        [[45.6, 4.0], [60.4, 36.3], [7.0, 28.9], [19.5, 24.1], [7.3, 38.4], [1.6, 42.0],
         [58.7, 34.8], [52.6, 40.9], [30.4, 15.2], [25.9, 3.9], [54.3, 29.5], [23.2, 28.9],
         [39.1, 43.7], [2.5, 31.0], [21.5, 33.3]],
    ),
    # mirrored about the diagonal through the centre but for two handles
    "diagonal": (
        [[25.9, 26.7], [31.9, 26.3], [35.6, 39.6], [7.1, 33.9], [50.4, 32.6], [26.2, 42.5],
         [3.8, 36.5], [37.5, 3.8], [21.6, 18.3], [12.4, 29.6], [27.9, 32.8]],
        [[35.8, 18.2], [35.6, 23.2], [45.5, 26.2], [41.7, 1.1], [41.2, 43.7], [49.7, 17.7],
         [44.2, -3.0], [11.2, 29.2], [27.9, 12.7], [14.8, 26.8], [40.5, 20.7]],
    ),
}  # fmt: skip
BORDERS = ("edge", "reflect", "symmetric", "wrap")
#: |f(s) - u| with f in float64 at the GPU's source point s, pixels: Newton's acceptance,
#: plus f's float32 error (~1e-4 px here) with room to spare.
PREIMAGE = NEWTON_ACCEPT + 1e-3


def f64(m: glmls.MLS, points: np.ndarray) -> np.ndarray:
    return reference.mls(m.src, m.dst, points, m.config, shape=m.shape)[0]


def has_preimage(m: glmls.MLS, u: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """(K,) bool: whether each point of ``u`` ((K, 2) pixels) has a preimage by f (float64)
    in the box from ``low`` to ``high``: the eight source points of a half-pixel lattice of
    the box whose images lie nearest u, each refined by damped Newton to |f(s) - u| < 1e-6."""
    xs = np.arange(low[0], high[0] + 1e-9, 0.5)
    ys = np.arange(low[1], high[1] + 1e-9, 0.5)
    lattice = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    values = f64(m, lattice)
    starts = 8
    nearest = [np.argsort(np.hypot(*(values - point).T))[:starts] for point in u]
    s = lattice[np.concatenate(nearest)] if len(u) else np.zeros((0, 2))
    target = np.repeat(u, starts, axis=0)
    r = f64(m, s) - target
    for _ in range(40):
        h = 1e-6
        jx = (f64(m, s + [h, 0]) - r - target) / h
        jy = (f64(m, s + [0, h]) - r - target) / h
        det = jx[:, 0] * jy[:, 1] - jy[:, 0] * jx[:, 1]
        det = np.where(np.abs(det) < 1e-14, 1e-14, det)
        step = (
            np.stack(
                [jy[:, 1] * r[:, 0] - jy[:, 0] * r[:, 1], jx[:, 0] * r[:, 1] - jx[:, 1] * r[:, 0]],
                -1,
            )
            / det[:, None]
        )
        step *= np.minimum(1.0, 4.0 / np.maximum(np.hypot(*step.T), 1e-300))[:, None]
        t = np.ones(len(s))
        for _ in range(12):  # halve the steps that raise the residual
            worse = np.hypot(*(f64(m, s - step * t[:, None]) - target).T) > np.hypot(*r.T)
            if not worse.any():
                break
            t = np.where(worse, t / 2, t)
        s = s - step * t[:, None]
        r = f64(m, s) - target
    found = ((s >= low) & (s <= high)).all(axis=1) & (np.hypot(*r.T) < 1e-6)
    return found.reshape(len(u), starts).any(axis=1)


def padded_nearest(image: np.ndarray, s: np.ndarray, mode: str, pad: int) -> np.ndarray:
    """The values of ``image`` padded by numpy.pad's ``mode`` at the pixels containing the
    points ``s`` ((K, 2) x, y, within ``pad`` pixels of the image)."""
    wide = np.pad(image, pad, mode=mode)
    column, row = (np.floor(s + 0.5).astype(int) + pad).T
    return wide[row, column]


@pytest.mark.parametrize("name", sorted(MAPS))
def test_every_pixel_with_a_preimage_is_drawn(gl, name):
    """With a border that extends the source, every pixel whose preimage lies within the
    mesh's reach is drawn (a second pass that starts from the 5 x 5 neighbours alone, in one
    run, leaves 626 of the mirror's 3,072 pixels and 110 of the diagonal's to the
    background), each from a source point s that f (float64) takes within ``PREIMAGE`` of
    the pixel, with the padded source's pixel at s, for every such border, and the batch
    draws the same."""
    src, dst = (np.array(a, float) for a in MAPS[name])
    height, width = SHAPE
    image = np.random.default_rng(7).uniform(0, 1, SHAPE).astype(np.float32)
    rows, cols = np.mgrid[0:height, 0:width]
    u = np.stack([cols, rows], -1).astype(float)
    with glmls.MLS(src, dst, shape=SHAPE, transform="rigid", ctx=gl) as m:
        margin = border_margin(m.kernel, MeshLattice.corners(SHAPE, 1), Frame(SHAPE), warn=False)
        xy = m.coordinate_map(SHAPE, border="edge").astype(float)
        for border in BORDERS:
            out = m.warp(image, method="backward", border=border, background=np.nan)
            drawn = ~np.isnan(out)
            # the pixels left: none with a preimage in the mesh's reach
            low = np.array([-0.5 - margin] * 2)
            high = np.array([width - 0.5 + margin, height - 0.5 + margin])
            missed = u[~drawn][has_preimage(m, u[~drawn], low, high)]
            assert len(missed) == 0, (border, len(missed), missed[:5])
            # the pixels drawn: from a preimage, its padded source's value
            s = xy[drawn]
            assert np.hypot(*(f64(m, s) - u[drawn]).T).max() < PREIMAGE
            assert (np.abs(s) < margin + max(SHAPE)).all()
            assert_array_equal(out[drawn], padded_nearest(image, s, border, margin + 8))
            batch = glmls.warp_batch(
                image[None], src[None], dst[None], method="backward", border=border,
                transform="rigid", background=np.nan, ctx=gl,
            )  # fmt: skip
            assert_array_equal(batch[0], out)
