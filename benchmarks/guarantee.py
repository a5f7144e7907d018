"""The adaptive mesh's guarantee, measured: the table of ``docs/adaptive.md``.

``python benchmarks/guarantee.py [--weights '[{}, {"alpha": 3.0}]'] [--maps smooth,dense]
[--tolerances 0.02,0.05,0.25] [--margins]``

For each weight (``MLS`` keywords), map and tolerance, on a 160 x 192 image: every covered
output pixel's source point as the warp computes it, its distance from f's true inverse
(Newton's method from it in float64, f from ``glmls.reference``, where f is locally
invertible), and the bound of the leaf whose triangle drew the pixel (the first in
scan order, emulated in numpy). Printed per case: the largest error over the tolerance of
all pixels, and of those whose leaf vouches for them (its ``AdaptiveMesh.estimate`` within
the tolerance), the share of the latter, how many of them err past the tolerance, and the
leaves; then the worst per weight. ``tests/imaging/test_adaptive.py`` checks the same
bound the same way on fewer cases.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

import glmls
from glmls import reference
from glmls.analysis.guarantee import (
    SHAPE,
    guarantee_handles,
    inverse_error,
    pixel_leaves,
    source_points,
)
from glmls.imaging.adaptive.patch import NODES, SAFETY, TESTS, estimate_cells

#: The weights of the table in docs/adaptive.md.
WEIGHTS = [
    {},
    {"transform": "similarity"},
    {"transform": "affine"},
    {"alpha": 0.3},
    {"alpha": 0.6},
    {"alpha": 0.8},
    {"alpha": 1.5},
    {"alpha": 2.0},
    {"alpha": 2.5},
    {"alpha": 3.0},
    {"weight": "gaussian", "radius": 30},
    {"weight": "gaussian", "radius": 60},
    {"weight": "gaussian", "radius": 30, "interpolating": True, "alpha": 0.6},
]
MAPS = ("smooth", "stretched", "random", "random2", "dense", "segments")


def measure(config: dict, case: str, tolerance: float, margins: bool = False) -> dict:
    """One case: the errors over the tolerance, all pixels and those vouched for (and with
    ``margins``, :func:`leaf_margins`)."""
    with glmls.MLS(**guarantee_handles(case), shape=SHAPE, **config) as m:
        mesh, xy, covered = source_points(m, SHAPE, tolerance)
        error, _ = inverse_error(m, SHAPE, xy, covered)
        leaf, vouched = pixel_leaves(mesh, SHAPE, tolerance)
        finite = np.isfinite(error)
        checked = vouched & finite
        out = {
            "all": float(error[finite].max()) / tolerance,
            "vouched": float(error[checked].max()) / tolerance if checked.any() else 0.0,
            "share": float(checked.sum() / max(finite.sum(), 1)),
            "over": int((error[checked] > tolerance).sum()),
            "leaves": len(mesh.leaves),
        }
        if margins:
            worst = np.zeros(len(mesh.leaves))
            np.maximum.at(worst, leaf[checked], error[checked])
            out["margins"] = leaf_margins(m, mesh, worst, 0.3 * tolerance)
    return out


def leaf_margins(m, mesh, worst: np.ndarray, floor: float) -> tuple[float, float]:
    """Per leaf erring by more than ``floor`` (``worst``: its largest error where it vouches),
    that error over its miss over its Jacobian's smallest singular value, f in float64 at
    its 5 x 5 grid (``estimate_cells``' bound over ``SAFETY``): the largest, with the miss
    taken where the patch's error peaks (the test's), and at the 16 test points alone. Above
    ``SAFETY``, a leaf at the tolerance would err past it."""
    sure = np.flatnonzero(worst > floor)
    if len(sure) == 0:
        return 0.0, 0.0
    x0, y0, x1, y1 = mesh.leaves[sure].T
    quarters = np.array([[c, r] for r, c in NODES + TESTS]) / 4.0  # nodes, then tests
    corner = np.stack([x0, y0], -1)[:, None]
    size = np.stack([x1 - x0, y1 - y0], -1)[:, None]
    points = (corner + size * quarters).reshape(-1, 2)
    segments = {"src_segments": m.src_segments, "dst_segments": m.dst_segments}
    f, _, _ = reference.mls(m.src, m.dst, points, m.config, shape=SHAPE, **segments)
    ids = np.arange(len(points)).reshape(-1, 25)
    ratios = []
    for inset in (True, False):
        bound, _ = estimate_cells(
            f[:, 0], f[:, 1], ids[:, :9], ids[:, 9:], x1 - x0, y1 - y0, inset=inset
        )
        ratios.append(float((worst[sure] * SAFETY / bound).max()))
    return ratios[0], ratios[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--weights", type=json.loads, default=WEIGHTS, help="a JSON list")
    parser.add_argument("--maps", default=",".join(MAPS), help=", ".join(MAPS))
    parser.add_argument("--tolerances", default="0.02,0.05,0.25")
    parser.add_argument(
        "--margins",
        action="store_true",
        help="also each case's largest leaf error over its miss over its smallest singular "
        "value (leaves erring by more than 0.3 of the tolerance): the test's miss, and at the "
        "16 test points alone",
    )
    args = parser.parse_args(argv)
    tolerances = [float(t) for t in args.tolerances.split(",")]
    worst = {}
    for config in args.weights:
        name = json.dumps(config)
        for case in args.maps.split(","):
            for tolerance in tolerances:
                r = measure(config, case, tolerance, args.margins)
                extra = ""
                if args.margins:
                    extra = "  margins {:.3f}, at the test points {:.3f}".format(*r["margins"])
                print(
                    f"{name:70s} {case:9s} {tolerance:5.2f}: all {r['all']:9.3f}  vouched "
                    f"{r['vouched']:.3f} ({r['share']:.4f}, {r['over']} over)  "
                    f"{r['leaves']} leaves{extra}",
                    flush=True,
                )
                worst[name] = max(worst.get(name, 0.0), r["vouched"])
    print("\nthe largest error over the tolerance where a leaf vouches, per weight:")
    for name, value in worst.items():
        print(f"  {name:70s} {value:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
