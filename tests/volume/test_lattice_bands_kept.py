"""Where the device's storage buffers are smaller than ``SlabOptions.band_bytes`` (llvmpipe's
128 MiB against a 256^3 volume's lattice at grid 1), the lattice is held in as many buffers
as band_bytes allows: a slab's scan over every band and its resolve over them again
evaluate f on each band once, not twice, and the result is the same to the last bit."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.gl.context import GLContext
from glmls.volume import SlabOptions
from glmls.volume.kernel_field import KernelField

SHAPE = (11, 9, 13)


def _fills(monkeypatch) -> list[tuple[int, int]]:
    """The (first layer, layers) of every evaluation of f on the lattice, as they happen."""
    calls: list[tuple[int, int]] = []
    fill = KernelField.fill

    def counting(self, lattice, first, layers, target):
        calls.append((first, layers))
        fill(self, lattice, first, layers, target)

    monkeypatch.setattr(KernelField, "fill", counting)
    return calls


def _small_buffers(monkeypatch, gl, nbytes: int) -> None:
    limits = dict(GLContext.limits.fget(gl), max_ssbo_size=nbytes)
    monkeypatch.setattr(GLContext, "limits", property(lambda self: limits))


@pytest.mark.parametrize(
    ("method", "channels", "limit"),
    # buffers that hold the slab whole (one slab: no survey) and a few layers of the lattice
    [("quads", None, 10_000), ("backward", 3, 64_000)],
)
def test_bands_held_at_once_are_evaluated_once(gl, rng, monkeypatch, method, channels, limit):
    src = rng.uniform(0, 12, (7, 3))
    dst = src + rng.normal(0, 1.5, src.shape)
    shape = SHAPE if channels is None else (*SHAPE, channels)
    volume = (rng.random(shape) * 255).astype(np.uint8 if channels is None else np.float32)
    options = dict(method=method, interpolation="linear", grid=1)
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        whole = m.warp(volume, **options)
        calls = _fills(monkeypatch)
        _small_buffers(monkeypatch, gl, limit)
        kept = m.warp(volume, **options, slabs=SlabOptions(band_bytes=1 << 20))
        bands = len(calls)
        assert bands > 1
        assert len({first for first, _ in calls}) == bands, calls  # none evaluated twice
        np.testing.assert_array_equal(kept, whole)
        # band_bytes within one buffer: one band at a time, and the scan's bands but the
        # last evaluated again for the resolve
        calls.clear()
        single = m.warp(volume, **options, slabs=SlabOptions(band_bytes=limit))
        assert len(calls) == 2 * bands - 1, calls
        np.testing.assert_array_equal(single, whole)
        assert gl.mgl.error == "GL_NO_ERROR"
