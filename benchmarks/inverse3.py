"""f's 3D inverse at points, ``m.inverse(u)``: the time of a call and how well it solves.

``python benchmarks/inverse3.py [--handles 64 2000] [--points 100000] [--move 3]
[--transform rigid] [--repeat 5]``

N random handles in a 50^3 box, each moved uniformly by up to ``--move`` voxels a coordinate
(folds appear from about 3 with thousands of handles), and K points u = f(x) of random x in
the box. For each handle count it prints the median and the least of ``--repeat`` calls after
an untimed one, the points without a preimage found (NaN rows), the largest residual
|f(s) - u| of the others by glmls's own f, and how many preimages lie more than 0.01 voxel
from x (another preimage, where f folds). For A/B runs against another checkout, set
``PYTHONPATH`` and alternate the runs.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import glmls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--handles", type=int, nargs="+", default=[64, 2000])
    parser.add_argument("--points", type=int, default=100_000)
    parser.add_argument("--move", type=float, default=3.0)
    parser.add_argument("--transform", default="rigid")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    if args.repeat < 1 or args.points < 1 or min(args.handles) < 1:
        parser.error("--repeat, --points and --handles must be at least 1")
    print(
        f"{'handles':>8} {'points':>8} {'median s':>9} {'least s':>8} {'NaN':>5} "
        f"{'max residual':>13} {'other preimage':>15}"
    )
    for count in args.handles:
        rng = np.random.default_rng(0)
        src = rng.uniform(0, 50, (count, 3))
        dst = src + rng.uniform(-args.move, args.move, src.shape)
        x = rng.uniform(0, 50, (args.points, 3))
        with glmls.MLS(src, dst, transform=args.transform) as m:
            u = m(x)
            s = m.inverse(u)
            times = []
            for _ in range(args.repeat):
                start = time.perf_counter()
                s = m.inverse(u)
                times.append(time.perf_counter() - start)
            found = np.isfinite(s).all(axis=1)
            residual = np.linalg.norm(m(s[found]) - u[found], axis=1)
        other = int((np.linalg.norm(s[found] - x[found], axis=1) > 0.01).sum())
        largest = residual.max() if len(residual) else float("nan")
        print(
            f"{count:>8} {args.points:>8} {statistics.median(times):>9.3f} "
            f"{min(times):>8.3f} {int((~found).sum()):>5} {largest:>13.3g} {other:>15}"
        )


if __name__ == "__main__":
    main()
