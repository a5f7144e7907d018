"""Where an adaptive warp's time goes (``m.warp(image, tolerance=t)``), stage by stage.

``python benchmarks/adaptive_stages.py [--workload W1|W2|W3] [--tolerance 0.05] [--repeat 15]``

One process, the workload's ``MLS`` kept, ``m.warp`` end to end, and within it (each stage
timed where the pipeline calls it, so the stages do not overlap, and on llvmpipe a dispatch
returns when its work is done):

- ``build``: the whole adaptive build (:meth:`AdaptiveScan.build`), of which ``f``, the
  evaluations of f level by level (:meth:`GPUCells.evaluate`: the GPU pass, its upload and
  read-back), ``test``, the cells' tests and the children's predictions
  (:meth:`GPUCells.test`), and ``bookkeeping``, the rest (the numpy quadtree: splits,
  leaves, fans and assembly);
- ``draw``: the upload of the mesh, the fold check and the scan passes
  (:meth:`AdaptiveScan.draw`);
- ``rest``: everything else of the call (the image's upload and read-back, the ``MLS``'s
  handles, the framebuffer).

Then the counts: levels, evaluations of f, leaves, triangles. Medians of ``--repeat`` calls
after three untimed ones, ms. The A/B of whole calls is ``tools/ab_trees.py``'s job; this says
what a change should aim at.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from workloads import WORKLOADS

import glmls
from glmls.imaging.adaptive.cells import GPUCells
from glmls.imaging.adaptive.scan import AdaptiveScan


def stages(workload: str, tolerance: float, repeat: int) -> tuple[dict, dict]:
    """(median ms per stage, counts) of ``workload``'s warp at ``tolerance``."""
    image, p, q = WORKLOADS[workload]()
    spent: dict[str, float] = {}
    counts = {"evaluations": 0}

    def timing(cls, name: str, label: str):
        real = getattr(cls, name)

        def timed(self, *args, **kwargs):
            start = time.perf_counter()
            try:
                return real(self, *args, **kwargs)
            finally:
                spent[label] = spent.get(label, 0.0) + time.perf_counter() - start

        return real, timed

    patches = {
        (GPUCells, "evaluate"): "f",
        (GPUCells, "test"): "test",
        (AdaptiveScan, "build"): "build",
        (AdaptiveScan, "draw"): "draw",
    }
    originals = {}
    for (cls, name), label in patches.items():
        originals[cls, name], timed = timing(cls, name, label)
        setattr(cls, name, timed)
    real_evaluate = GPUCells.evaluate

    def counted(self, points):
        counts["evaluations"] += len(points)
        return real_evaluate(self, points)

    GPUCells.evaluate = counted
    rows = []
    try:
        with glmls.MLS(p, q, shape=image.shape[:2]) as m:
            for k in range(3 + repeat):
                spent.clear()
                counts["evaluations"] = 0
                start = time.perf_counter()
                m.warp(image, tolerance=tolerance)
                total = time.perf_counter() - start
                evaluations = counts["evaluations"]
                if k >= 3:
                    rows.append(
                        {
                            "total": total,
                            "build": spent["build"],
                            "f": spent.get("f", 0.0),
                            "test": spent.get("test", 0.0),
                            "bookkeeping": spent["build"]
                            - spent.get("f", 0.0)
                            - spent.get("test", 0.0),
                            "draw": spent["draw"],
                            "rest": total - spent["build"] - spent["draw"],
                        }
                    )
            mesh = m.mesh(image.shape[:2], tolerance=tolerance)
    finally:
        for (cls, name), real in originals.items():
            setattr(cls, name, real)
    medians = {key: statistics.median(row[key] for row in rows) * 1e3 for key in rows[0]}
    counts.update(
        evaluations=evaluations,
        levels=mesh.levels,
        leaves=len(mesh.leaves),
        triangles=len(mesh.triangles),
    )
    return medians, counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workload", default="W1", choices=sorted(WORKLOADS))
    parser.add_argument("--tolerance", type=float, default=0.05)
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args()
    medians, counts = stages(args.workload, args.tolerance, args.repeat)
    print(f"{args.workload} at {args.tolerance:g} px, medians of {args.repeat} calls (ms):")
    for key in ("total", "build", "f", "test", "bookkeeping", "draw", "rest"):
        indent = "    " if key in ("f", "test", "bookkeeping") else "  "
        print(f"{indent}{key:12s} {medians[key]:7.2f}")
    print("  " + ", ".join(f"{key} {value:,}" for key, value in counts.items()))


if __name__ == "__main__":
    main()
