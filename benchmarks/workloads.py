"""The end-to-end workloads the adaptive mesh's benchmarks time: ``WORKLOADS[name]()`` gives
(image, src, dst), the handles for a rigid idw ``MLS``.

- ``W1``: ``glmls.cli.bench.cases.make_inputs(1024, 64)``: handles on a jittered lattice,
  no folds;
- ``W2``: 64 random handles moved by up to 35 px on a random 1024² RGB image (folds);
- ``W3``: ``make_inputs(512, 16)``.

``tools/ab_trees.py`` builds the same workloads without importing glmls (it times several
checkouts side by side).
"""

from __future__ import annotations

import numpy as np

from glmls.cli.bench.cases import make_inputs


def random_inputs(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """W2: a random size x size RGB image and 64 random handles moved by up to 35 px."""
    rng = np.random.default_rng(4)
    p = rng.uniform(0.05 * size, 0.95 * size, (64, 2))
    q = p + rng.uniform(-35, 35, (64, 2))
    image = np.random.default_rng(0).integers(0, 256, (size, size, 3), dtype=np.uint8)
    return image, p, q


WORKLOADS = {
    "W1": lambda: make_inputs(1024, 64),
    "W2": lambda: random_inputs(1024),
    "W3": lambda: make_inputs(512, 16),
}
