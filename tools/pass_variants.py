"""A shader change's A/B in one process: the GPU passes of a warp, timed pass by pass, with
two variants of one shader alternated call by call.

``python tools/pass_variants.py adaptive/scan.comp.glsl [--workload W1,W2]
[--tolerance 0.05 | --grid 4] [--rounds 20]``

The variant under test sits in the shader behind ``#if defined(XV) && XV == 1`` (the old
code in its ``#else``); this script adds ``XV`` (0, then 1) to the defines of every program
compiled from the named entry, so each call of the warp runs one variant, the next call the
other. Every compute dispatch is timed with a ``finish`` before and after it (on llvmpipe a
dispatch is its work), and summed per pass (entry and defines) and call; printed are the
medians over ``--rounds`` calls of each variant, ms, and whether the two variants' images
differ (pixels). The passes the variant does not touch are the control: their ratios show
the run's noise (20 rounds: a few per cent on a quiet host, 10-20 % on a noisy one). On a
shared host this resolves a change of one pass where whole calls (``ab_trees.py``) cannot.
The shaders are read from the checkout the script runs in: write both variants there.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import moderngl
import numpy as np
from ab_trees import WORKLOADS

import glmls
from glmls.gl.context import GLContext


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("entry", help="the entry with the variants: warp/cells.comp.glsl, ...")
    parser.add_argument("--workload", default="W1,W2", help="W1, W2 and/or W3, comma separated")
    how = parser.add_mutually_exclusive_group()
    how.add_argument("--tolerance", type=float, default=None)
    how.add_argument("--grid", type=int, default=None)
    parser.add_argument("--rounds", type=int, default=20, help="calls of each variant")
    args = parser.parse_args(argv)
    tolerance = args.tolerance if args.tolerance is not None else 0.05
    options = {"grid": args.grid} if args.grid is not None else {"tolerance": tolerance}

    variant = [0]
    names: dict[int, str] = {}
    compile_pass = GLContext.compute

    def compute(self, entry, defines=None, *rest, **keywords):
        defines = dict(defines or {})
        if entry == args.entry:
            defines["XV"] = variant[0]
        program = compile_pass(self, entry, defines, *rest, **keywords)
        # the kernel's MLS_* defines are the same for every pass of a run: left out
        shown = ",".join(
            f"{k.removeprefix('ADAPTIVE_')}={v}"
            for k, v in sorted(defines.items())
            if k != "XV" and (not k.startswith("MLS_") or k == "MLS_LATTICE")
        )
        names[id(program)] = f"{entry}({shown})" if shown else entry
        return program

    times: dict[str, float] = defaultdict(float)

    def timed(method):
        def run(self, *rest, **keywords):
            self.ctx.finish()
            start = time.perf_counter()
            out = method(self, *rest, **keywords)
            self.ctx.finish()
            times[names.get(id(self), "other")] += time.perf_counter() - start
            return out

        return run

    GLContext.compute = compute  # type: ignore[method-assign]
    moderngl.ComputeShader.run = timed(moderngl.ComputeShader.run)  # type: ignore[method-assign]
    moderngl.ComputeShader.run_indirect = timed(moderngl.ComputeShader.run_indirect)  # type: ignore[method-assign]

    for workload in args.workload.split(","):
        image, p, q = WORKLOADS[workload]()
        with glmls.MLS(p, q, shape=image.shape[:2], transform="rigid") as m:
            images = {}
            for v in (0, 1, 0, 1):  # compile both, then warm up
                variant[0] = v
                images[v] = m.warp(image, **options)
            differ = int(np.any(images[0] != images[1], axis=-1).sum())
            per_pass: dict[tuple[str, int], list[float]] = defaultdict(list)
            for k in range(args.rounds):
                for v in (0, 1) if k % 2 else (1, 0):
                    variant[0] = v
                    times.clear()
                    m.warp(image, **options)
                    for name, seconds in times.items():
                        per_pass[name, v].append(seconds * 1000)
        print(f"{workload} {options}: pixels that differ between the variants: {differ}")
        for name in sorted({name for name, _ in per_pass}):
            old, new = (statistics.median(per_pass.get((name, v), [0.0])) for v in (0, 1))
            ratio = f"{new / old:.3f}x" if old > 0 else "-"
            print(f"  {name[:72]:72s} {old:8.3f} {new:8.3f} ms  {ratio}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
