"""Tens of thousands of handles on a driver that caps a shader's loop iterations (Mesa's
llvmpipe: 65,535 over all the loops of an invocation): every handle counts in f, and the
Newton passes refuse what they could not finish instead of leaving handles out."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.engine.kernel import CAPPED_NEWTON_HANDLES


@pytest.mark.parametrize("dim", [2, 3])
def test_the_last_of_40000_handles_counts(gl, rng, dim):
    """One handle among 40,000 moves its point 10 px: were the handles after the driver's
    loop limit left out, f would keep it in place."""
    src = rng.uniform(0, 50, (40_000, dim))
    dst = src.copy()
    src[-1] = dst[-1] = 100.0
    dst[-1, 0] = 110.0
    with glmls.MLS(src, dst, transform="affine", ctx=gl) as m:
        f = m(src[-1:])
    np.testing.assert_allclose(f[0], dst[-1], atol=1e-3)


def test_a_newton_pass_beyond_the_loop_limit_is_refused(gl, rng):
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    count = CAPPED_NEWTON_HANDLES + 1
    src = rng.uniform(0, 50, (count, 2))
    with glmls.MLS(src, src + 0.5, ctx=gl) as m:
        np.testing.assert_allclose(m([[10.0, 10.0]]), [[10.5, 10.5]], atol=1e-3)
        with pytest.raises(ValueError, match=f"{count:,} handles: the inverse of f .* llvmpipe"):
            m.inverse([[10.0, 10.0]])
    with glmls.MLS(src[:CAPPED_NEWTON_HANDLES], src[:CAPPED_NEWTON_HANDLES] + 0.5, ctx=gl) as m:
        np.testing.assert_allclose(m.inverse([[10.5, 10.5]]), [[10.0, 10.0]], atol=1e-3)


def test_a_batched_newton_pass_beyond_the_loop_limit_is_refused(gl, rng):
    """warp_batch's backward method runs Newton for every image in one batched pass: it
    refuses the image its own glmls.warp refuses, naming it, rather than leave handles out."""
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    count = CAPPED_NEWTON_HANDLES + 1
    images = rng.integers(0, 255, (2, 8, 8), dtype=np.uint8)
    src = [rng.uniform(0, 7, (3, 2)), rng.uniform(0, 7, (count, 2))]
    dst = [p + 0.25 for p in src]
    with pytest.raises(ValueError, match=f"{count:,} handles: the inverse of f .* llvmpipe"):
        glmls.warp(images[1], src[1], dst[1], method="backward", ctx=gl)
    with pytest.raises(ValueError, match=f"images\\[1\\]: {count:,} handles: the inverse of f"):
        glmls.warp_batch(images, src, dst, method="backward", ctx=gl)


def test_the_newton_budget_is_checked_before_the_first_guess(gl, rng, monkeypatch):
    """The refusal comes before the first guess's mesh is drawn: with thousands of handles
    spread over a large image that mesh alone takes minutes on llvmpipe."""
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    from glmls.imaging.quads import CellScan
    from glmls.imaging.raster import MeshRaster

    def drawn(*args, **kwargs):
        raise AssertionError("the first guess was drawn before the refusal")

    src = rng.uniform(0, 50, (CAPPED_NEWTON_HANDLES + 1, 2))
    with glmls.MLS(src, src + 0.5, ctx=gl) as m:
        monkeypatch.setattr(CellScan, "draw", drawn)
        monkeypatch.setattr(MeshRaster, "draw", drawn)
        with pytest.raises(ValueError, match="the inverse of f"):
            m.inverse([[10.0, 10.0]])
        with pytest.raises(ValueError, match="the inverse of f"):
            m.coordinate_map((8, 8))


def test_a_volume_newton_pass_is_refused_before_the_lattice(gl, rng, monkeypatch):
    """A volume's backward warp and map refuse the handles their Newton pass could not all
    visit before f is evaluated on the cells' lattice, the long part with many handles."""
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    from glmls.volume import volume_coordinate_map
    from glmls.volume.kernel_field import KernelField

    def filled(*args, **kwargs):
        raise AssertionError("the lattice was evaluated before the refusal")

    src = rng.uniform(0, 50, (CAPPED_NEWTON_HANDLES + 1, 3))
    with glmls.MLS(src, src + 0.5, ctx=gl) as m:
        monkeypatch.setattr(KernelField, "fill", filled)
        with pytest.raises(ValueError, match="the inverse of f"):
            m.warp(np.zeros((4, 5, 6), np.uint8), method="backward")
        with pytest.raises(ValueError, match="the inverse of f"):
            volume_coordinate_map(m, (4, 5, 6))


def test_a_3d_jacobian_the_cap_cut_short_is_refused(gl, rng):
    """120,000 3D handles: f and its derivative at a point (three more passes over the
    handles) fit in the cap; at a point on a handle, which snaps (s = 0), J is central
    differences of f, whose six more evaluations do not. Those points are reported, the
    others' J is the derivative's."""
    src = rng.uniform(0, 50, (120_000, 3))
    dst = src + rng.normal(0, 0.5, src.shape)
    v = np.concatenate([rng.uniform(10, 40, (4, 3)), src[:4]])
    with glmls.MLS(src, dst, s=0.0, ctx=gl) as m:
        if gl.loop_limit is not None:
            with pytest.raises(ValueError, match=r"f at 4 of 8 points: 120,000 3D handles"):
                m.jacobian(v)
        v = v[:4]
        f, jacobian = m.jacobian(v)
    h = 1e-4
    expected = np.stack(
        [
            (
                reference.mls(src, dst, v + h * e, s=0.0)[0]
                - reference.mls(src, dst, v - h * e, s=0.0)[0]
            )
            / (2 * h)
            for e in np.eye(3)
        ],
        axis=1,
    )
    np.testing.assert_allclose(f, reference.mls(src, dst, v, s=0.0)[0], atol=1e-3)
    np.testing.assert_allclose(jacobian, expected, atol=1e-2)


def test_more_3d_handles_than_one_evaluation_may_visit_are_refused(gl, rng):
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    src = rng.uniform(0, 50, (1_000_000, 3))
    with pytest.raises(ValueError, match=r"1,000,000 3D handles: one evaluation of f"):
        glmls.MLS(src, src + 1.0, ctx=gl)
