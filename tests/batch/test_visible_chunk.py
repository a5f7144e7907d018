"""Keypoint validity for a whole chunk at once (:func:`glmls.batch.labels.visible_chunk`)
against a float64 reference of the same rule taken point by point through
``np.linalg.pinv``: exactly the same flags on random chunks with ragged keypoint counts
(images without any), points off the canvas and outside the domain, singular, nearly
singular, zero, subnormal, huge and non-finite Jacobians, and source points placed at the
threshold's distance to within rounding."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.batch.labels import SLACK, visible, visible_chunk


def reference_flag(point, out, jacobian, coords, covered, inside, drawn) -> bool:
    """One keypoint's flag, the rule written out: on the canvas, inside the domain, the
    nearest pixel covered, and the source point shown there within :data:`SLACK` (plus,
    ``drawn``, the half pixel's diagonal through the local map) plus half the local map's
    change over the step of the point the local map puts there; the local map's inverse the
    Jacobian's pseudo-inverse, none (nothing shown) where it has a NaN or infinite entry or
    the SVD does not resolve it."""
    height, width = covered.shape
    if not (inside and -0.5 <= out[0] < width - 0.5 and -0.5 <= out[1] < height - 0.5):
        return False
    pixel = np.rint(out)
    col, row = int(pixel[0]), int(pixel[1])
    if not covered[row, col] or not np.isfinite(jacobian).all():
        return False
    step = pixel - out
    with np.errstate(all="ignore"):
        try:
            inverse = np.linalg.pinv(jacobian[None])[0]
            spread = np.linalg.norm(inverse[None], ord=2, axis=(1, 2))[0]
        except np.linalg.LinAlgError:
            return False
        expected = point + np.einsum("ki,kij->kj", step[None], inverse[None])[0]
        reach = np.linalg.norm(step[None], axis=1)[0] * spread
        slack = SLACK + (np.sqrt(0.5) * max(spread, 1.0) if drawn else 0.0)
        shown = coords[row, col].astype(np.float64)
        distance = np.linalg.norm((shown - expected)[None], axis=1)[0]
        return bool(distance <= slack + 0.5 * reach)


def jacobians(rng: np.random.Generator, count: int) -> np.ndarray:
    """(count, 2, 2) local maps of every kind: regular (either orientation), of rank one,
    within 1e-16 to 1e-6 of rank one, zero, subnormal, huge, with NaN or infinite entries."""
    regular = np.eye(2) + rng.normal(0.0, 0.6, (count, 2, 2))
    u, v = rng.normal(size=(count, 2)), rng.normal(size=(count, 2))
    rank_one = u[:, :, None] * v[:, None, :]
    near = rank_one + 10.0 ** rng.uniform(-16, -6, (count, 1, 1)) * rng.normal(size=(count, 2, 2))
    kind = rng.integers(0, 10, count)
    out = np.where((kind == 0)[:, None, None], rank_one, regular)
    out = np.where((kind == 1)[:, None, None], near, out)
    out[kind == 2] = 0.0
    out[kind == 3] = regular[kind == 3] * 1e-310
    out[kind == 4] = regular[kind == 4] * 1e200
    nan = np.flatnonzero(kind == 5)
    out[nan, rng.integers(0, 2, len(nan)), rng.integers(0, 2, len(nan))] = np.nan
    inf = np.flatnonzero(kind == 6)
    out[inf, rng.integers(0, 2, len(inf)), rng.integers(0, 2, len(inf))] = np.inf
    return out


def chunk(rng: np.random.Generator, *, borderline: bool, drawn: bool):
    """A random chunk: (points, images, out, jacobian, coords, covered, inside)."""
    n = int(rng.integers(1, 6))
    height, width = int(rng.integers(1, 12)), int(rng.integers(1, 12))
    counts = rng.integers(0, 30, n)
    counts[rng.random(n) < 0.3] = 0
    total = int(counts.sum())
    images = np.repeat(np.arange(n), counts)
    points = rng.uniform(-3.0, 14.0, (total, 2))
    out = rng.uniform(-1.5, max(height, width) + 0.5, (total, 2))
    jacobian = jacobians(rng, total)
    yy, xx = np.mgrid[0:height, 0:width]
    grid = np.stack([xx, yy], axis=-1).astype(np.float64)
    coords = (grid[None] + rng.normal(0.0, 2.0, (n, height, width, 2))).astype(np.float32)
    covered = rng.random((n, height, width)) > 0.2
    inside = rng.random(total) > 0.1
    if borderline and total:
        # place the source point shown at each keypoint's pixel at its threshold's distance,
        # within a few ulps, where the closed form's and the pseudo-inverse's rounding differ
        on = np.flatnonzero(
            np.all((out >= -0.5) & (out < (width - 0.5, height - 0.5)), axis=1)
            & np.isfinite(jacobian).all(axis=(1, 2))
        )
        for k in on:
            pixel = np.rint(out[k])
            step = pixel - out[k]
            try:
                with np.errstate(all="ignore"):
                    inverse = np.linalg.pinv(jacobian[k][None])[0]
                    spread = np.linalg.norm(inverse, 2)
            except np.linalg.LinAlgError:  # subnormal entries: nothing to place
                continue
            slack = SLACK + (np.sqrt(0.5) * max(spread, 1.0) if drawn else 0.0)
            threshold = slack + 0.5 * np.linalg.norm(step) * spread
            if not np.isfinite(threshold) or threshold > 1e6:
                continue
            angle = rng.uniform(0.0, 2 * np.pi)
            direction = np.array([np.cos(angle), np.sin(angle)])
            col, row = np.clip(pixel.astype(np.int64), 0, (width - 1, height - 1))
            source = coords[images[k], row, col].astype(np.float64)
            gap = threshold * (1.0 + rng.normal(0.0, 4e-16))
            points[k] = source - gap * direction - step @ inverse
    return points, images, out, jacobian, coords, covered, inside


@pytest.mark.parametrize("drawn", [False, True])
@pytest.mark.parametrize("borderline", [False, True])
def test_chunk_flags_are_the_pseudo_inverse_rules(drawn, borderline):
    rng = np.random.default_rng(7 + 2 * drawn + borderline)
    checked = shown = 0
    for _ in range(150):
        points, images, out, jacobian, coords, covered, inside = chunk(
            rng, borderline=borderline, drawn=drawn
        )
        flags = visible_chunk(points, images, out, jacobian, coords, covered, inside, drawn=drawn)
        assert flags.shape == (len(points),) and flags.dtype == bool
        want = [
            reference_flag(
                points[k], out[k], jacobian[k], coords[images[k]], covered[images[k]],
                inside[k], drawn,
            )
            for k in range(len(points))
        ]  # fmt: skip
        np.testing.assert_array_equal(flags, want)
        checked += len(points)
        shown += int(flags.sum())
    assert checked > 1000 and 0 < shown < checked  # both answers occur


def test_per_image_form_is_the_chunk_form():
    rng = np.random.default_rng(3)
    for _ in range(40):
        points, images, out, jacobian, coords, covered, inside = chunk(
            rng, borderline=False, drawn=False
        )
        flags = visible_chunk(points, images, out, jacobian, coords, covered, inside)
        for k in range(len(coords)):
            mine = images == k
            alone = visible(
                points[mine], out[mine], jacobian[mine], coords[k], covered[k], inside[mine]
            )
            np.testing.assert_array_equal(alone, flags[mine])


def test_well_conditioned_keypoints_take_no_pseudo_inverse(monkeypatch):
    """Regular Jacobians away from the threshold: the closed form decides every flag."""
    inverted = []

    def counting(a, *args, **kwargs):
        inverted.append(len(a))
        return np.linalg.inv(a)

    monkeypatch.setattr(np.linalg, "pinv", counting)
    rng = np.random.default_rng(11)
    n, height, width, count = 8, 32, 32, 400
    images = np.repeat(np.arange(n), count // n)
    points = rng.uniform(0.0, 31.0, (count, 2))
    jacobian = np.eye(2) + rng.normal(0.0, 0.1, (count, 2, 2))
    out = points + rng.normal(0.0, 0.2, (count, 2))
    yy, xx = np.mgrid[0:height, 0:width]
    coords = np.broadcast_to(np.stack([xx, yy], -1), (n, height, width, 2)).astype(np.float32)
    covered = np.ones((n, height, width), bool)
    flags = visible_chunk(points, images, out, jacobian, coords, covered, np.ones(count, bool))
    assert sum(inverted) <= 2 and flags.sum() > count // 2


def test_empty_and_all_off_canvas_chunks():
    coords = np.zeros((3, 4, 5, 2), np.float32)
    covered = np.ones((3, 4, 5), bool)
    none = np.zeros((0, 2))
    flags = visible_chunk(
        none, np.zeros(0, np.int64), none, np.zeros((0, 2, 2)), coords, covered, np.zeros(0, bool)
    )
    assert flags.shape == (0,)
    off = np.array([[-0.6, 1.0], [5.0, 0.0], [1.0, 3.5]])
    flags = visible_chunk(
        off, np.array([0, 1, 2]), off, np.tile(np.eye(2), (3, 1, 1)), coords, covered,
        np.ones(3, bool),
    )  # fmt: skip
    assert not flags.any()
