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
