"""What segment handles cost against point handles: 16 of each on a 1024^2 image.

Cases, each timed in turns (A B C ... A B C ...) so that a noisy machine slows them alike;
medians and spreads of ``--rounds`` rounds:

- ``frame``: f on the grid-4 mesh of corners (the MLS part of an interactive frame;
  the mesh, 0.5 MB, is read back) and ``ctx.finish()``;
- ``warp``: ``m.warp(image, grid=4)`` end to end (numpy in, numpy out).

Handles: 16 points, or 16 segments (idw alpha 1: closed form; idw alpha 2 and the gaussian:
numerical integration), random in the image and moved by up to 35 px at each end.

    python benchmarks/segments.py --rounds 7
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import glmls

SIZE = 1024
NONE = np.zeros((0, 2))


def cases(rng):
    p = rng.uniform(0.1 * SIZE, 0.9 * SIZE, (16, 2))
    q = p + rng.uniform(-35, 35, p.shape)
    a = rng.uniform(0.1 * SIZE, 0.9 * SIZE, (16, 2, 2))
    b = a + rng.uniform(-35, 35, a.shape)
    shape = (SIZE, SIZE)
    return {
        "16 points, idw a=1": glmls.MLS(p, q, shape=shape),
        "16 segments, idw a=1 (closed form)": glmls.MLS(
            NONE, NONE, src_segments=a, dst_segments=b, shape=shape
        ),
        "16 points, idw a=2": glmls.MLS(p, q, alpha=2.0, shape=shape),
        "16 segments, idw a=2 (quadrature)": glmls.MLS(
            NONE, NONE, src_segments=a, dst_segments=b, alpha=2.0, shape=shape
        ),
        "16 segments, gaussian (quadrature)": glmls.MLS(
            NONE, NONE, src_segments=a, dst_segments=b, weight="gaussian", shape=shape
        ),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (SIZE, SIZE, 3), np.uint8)
    models = cases(rng)
    ctx = glmls.gl.get_context()

    def frame(m):
        m.mesh((SIZE, SIZE), grid=4)
        with ctx.use():
            ctx.mgl.finish()

    def warp(m):
        m.warp(image, grid=4)

    timings = {(name, kind): [] for name in models for kind in ("frame", "warp")}
    for m in models.values():  # compile and warm up
        frame(m)
        warp(m)
    for _ in range(args.rounds):
        for name, m in models.items():
            for kind, run in (("frame", frame), ("warp", warp)):
                start = time.perf_counter()
                run(m)
                timings[name, kind].append(time.perf_counter() - start)
    base = {kind: np.median(timings["16 points, idw a=1", kind]) for kind in ("frame", "warp")}
    print(f"{'case':38} {'frame ms':>16} {'ratio':>6} {'warp ms':>16} {'ratio':>6}")
    for name in models:
        cells = []
        for kind in ("frame", "warp"):
            t = np.array(timings[name, kind]) * 1e3
            cells.append(
                f"{np.median(t):7.1f} ±{np.ptp(t) / 2:5.1f} {np.median(t) / 1e3 / base[kind]:6.2f}"
            )
        print(f"{name:38} {cells[0]:>23} {cells[1]:>23}")
    for m in models.values():
        m.release()


if __name__ == "__main__":
    main()
