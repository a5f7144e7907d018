"""Fixtures of the volume tests: 3D kernels on the shared context, released after each test."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.core.config import MLSConfig
from glmls.core.handles3 import fit_scaling3
from glmls.engine.kernel3 import MLSKernel3


@pytest.fixture
def kernel3(gl):
    """Make 3D kernels ``kernel3(src, dst, shape, **config)`` (released after the test)."""
    made = []

    def make(src, dst, shape, **config):
        src = np.asarray(src, np.float64)
        dst = np.asarray(dst, np.float64)
        kernel = MLSKernel3(gl, MLSConfig(**config), shape=tuple(shape))
        kernel.upload(src, dst, fit_scaling3(src, dst, tuple(shape)))
        made.append(kernel)
        return kernel

    yield make
    for kernel in made:
        kernel.release()


def box_handles(shape, rng, count=8, spread=1.5):
    """Handles at the corners of the volume's box (and some inside), moved by up to
    ``spread`` voxels."""
    d, h, w = shape
    corners = np.array([[x, y, z] for z in (0, d - 1) for y in (0, h - 1) for x in (0, w - 1)])
    extra = rng.uniform([0, 0, 0], [w - 1, h - 1, d - 1], (max(0, count - 8), 3))
    src = np.concatenate([corners, extra]).astype(np.float64)
    return src, src + rng.uniform(-spread, spread, src.shape)
