"""Points next to a handle whose weight is infinite on it, on the GPU against the float64
reference: 1e-8 to 1e-1 px from a segment handle (across it, beside and beyond its ends) and
from a point handle, with other handles a few pixels away, for every weight of the registry,
made interpolating or not, and every transform.

The GPU snaps a point to such a handle (f = its target) only where that changes f by less
than float32 shows: within a distance after the pole p of the weight (w ~ 1 / d^p), which
for p = 1 next to a segment (shepard, idw with alpha = 1/2), where the segment's weight grows
only like log(1 / h), is float32's resolution of the coordinates
(``glmls.engine.kernel.segment_hit2``).

Tolerance: 2e-6 of the image size (0.00024 px here) plus how far the reference's f moves
over float32's resolution of the point (2^-22 of the scale, 1.5e-5 px here; the handle's
own target where that reaches the handle): next to a segment of p = 1, f moves by 0.06 px
over the last 1e-5 px, which float32 cannot resolve.
"""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.engine.kernel import SNAP_DISTANCE, SNAP_RESOLUTION, segment_hit2

H, W = 100, 120
SIZE = max(H, W)
SRC_SEGMENTS = np.array([[[30.0, 40.0], [80.0, 52.0]], [[35.0, 52.0], [75.0, 58.0]]])
DST_SEGMENTS = SRC_SEGMENTS + np.array(
    [[[2.0, -3.0], [-1.0, 4.0]], [[-3.0, 2.0], [1.0, -2.0]]]
)  # the second segment is 7-10 px from the first, its target moves otherwise
A, B = SRC_SEGMENTS[0]
U = (B - A) / np.linalg.norm(B - A)
N = np.array([-U[1], U[0]])
SRC = np.array([A + 0.4 * (B - A) - 4.0 * N, B + 3.0 * U - 2.0 * N, [10.0, 90.0], [110.0, 10.0]])
DST = SRC + np.array([[5.0, -6.0], [-4.0, 3.0], [1.0, 1.0], [-1.0, 2.0]])
DISTANCES = 10.0 ** np.arange(-8.0, 0.0)


def near(place: np.ndarray, directions: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Points at every distance of DISTANCES from ``place`` in each direction, and
    ``place`` repeated (the handle's nearest point to each of them)."""
    points = [place + d * u for u in directions for d in DISTANCES]
    return np.array(points), np.tile(place, (len(points), 1))


DIAGONAL = (N - U) / np.sqrt(2.0)
PLACES = [
    near(A + 0.4 * (B - A), [N, -N]),  # across the segment's middle
    near(A + 0.97 * (B - A), [N, -N]),  # 1.5 px from its end
    near(A, [-U, N, DIAGONAL]),  # beyond its end, beside it
    near(B, [U, -N]),
    near(SRC[0], [N, U]),  # next to a point handle
]
POINTS = np.concatenate([p for p, _ in PLACES])
NEAREST = np.concatenate([q for _, q in PLACES])

OPTIONS = [
    {"weight": name, **({"radius": 60.0 if name == "gaussian" else 200.0} if name != "idw" else {})}
    for name in glmls.WEIGHTS
]
CASES = [
    *OPTIONS,
    *({**options, "interpolating": True} for options in OPTIONS),
    {"weight": "idw", "s": 0.0},
    {"weight": "idw", "alpha": 0.5, "s": 0.0},  # p = 1, as shepard
    {"weight": "idw", "alpha": 0.75, "s": 0.0},  # p = 1.5
    {"weight": "shepard", "radius": 200.0, "alpha": 4.0, "interpolating": True},
]


def case_id(options: dict) -> str:
    return "-".join(f"{k}={v}" for k, v in options.items())


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("options", CASES, ids=case_id)
def test_gpu_follows_the_reference_next_to_a_handle(gl, options, transform):
    handles = {"src_segments": SRC_SEGMENTS, "dst_segments": DST_SEGMENTS}
    with glmls.MLS(SRC, DST, shape=(H, W), transform=transform, **handles, **options) as m:
        f = m(POINTS)
        config, scale = m.config, m.scaling.scale
    f_ref = reference.mls(SRC, DST, POINTS, config, shape=(H, W), **handles)[0]
    # f_ref over float32's resolution of the point: toward and away from the handle, and the
    # handle's nearest point itself where the resolution reaches it
    resolution = SNAP_RESOLUTION * scale
    away = POINTS - NEAREST
    distance = np.linalg.norm(away, axis=1, keepdims=True)
    step = resolution * away / distance
    around = [POINTS + step, np.where(distance > resolution, POINTS - step, NEAREST)]
    moves = [reference.mls(SRC, DST, v, config, shape=(H, W), **handles)[0] for v in around]
    spread = np.max([np.linalg.norm(g - f_ref, axis=1) for g in moves], axis=0)
    error = np.linalg.norm(f - f_ref, axis=1)
    worst = int(np.argmax(error - spread))
    assert (error <= 2e-6 * SIZE + spread).all(), (
        f"{POINTS[worst].tolist()} ({distance[worst, 0]:.0e} px from a handle): GPU "
        f"{f[worst].tolist()}, reference {f_ref[worst].tolist()}, {error[worst]:.2e} px apart "
        f"(float32's resolution moves the reference by {spread[worst]:.2e} px)"
    )


def test_segment_snapping_distance_follows_the_pole():
    """p = 1: float32's resolution only; p = 2: where a handle the extent away weighs 2^-24
    of the segment; steeper: 1e-3 px; one handle that stays (extent 0): finite, positive."""
    scale, extent = 60.0, 0.8
    shepard = glmls.MLSConfig(weight="shepard", radius=200.0)
    assert segment_hit2(shepard, scale, extent) == (SNAP_RESOLUTION * extent) ** 2
    d_px = extent * scale
    expected = 2.0**-24 * 2.0**-1 * d_px**2 / scale  # (2^-24 2^(-p/2) D^p)^(1 / (p - 1))
    assert np.isclose(segment_hit2(glmls.MLSConfig(s=0.0), scale, extent), expected**2)
    steep = glmls.MLSConfig(weight="shepard", radius=200.0, interpolating=True)
    assert segment_hit2(steep, scale, extent) == (SNAP_DISTANCE / scale) ** 2
    assert 0.0 < segment_hit2(glmls.MLSConfig(), scale, 0.0) < 1e-30
