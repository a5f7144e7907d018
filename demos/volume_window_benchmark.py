"""
Milliseconds per frame of the volume window while a handle is dragged
=====================================================================

Opens the real volume window (run it under a display or ``xvfb-run -a``) on the bundled 64^3
phantom with its 10 handles, feeds a scripted drag of the large sphere's target in the axial
view (one cursor move per frame, through the same controller as the mouse), then moves the
slice point along z one voxel a frame, and reports the median milliseconds per frame of each
part, swaps included, after a warm-up. ``--overlay e`` or ``f`` turns an overlay on first,
``--method backward`` builds the slices by the backward method. Writes nothing unless
``--json OUT`` is given. It needs a window, so the gallery leaves it out.

From the command line::

    xvfb-run -a python demos/volume_window_benchmark.py [--frames 60] [--overlay e]
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np
from window_benchmark import report, run_scripted  # demos/ is the script's folder

from glmls.app.events import Key, Move, Press, Release
from glmls.app.volume_controller import VolumeSettings
from glmls.app.volume_window import VolumeApp
from glmls.data import phantom, phantom_handles


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--frames", type=int, default=60, help="drag frames measured")
    parser.add_argument("--warmup", type=int, default=5, help="drag frames not measured")
    parser.add_argument("--steps", type=int, default=30, help="slice-point frames measured")
    parser.add_argument("--grid", type=int, default=4)
    parser.add_argument("--method", choices=("quads", "backward"), default="quads")
    parser.add_argument("--overlay", choices=("e", "f"), action="append", default=[])
    parser.add_argument("--window-size", default="1000x560")
    parser.add_argument("--json", help="write the result here")
    args = parser.parse_args(argv)
    for name, least in (("frames", 1), ("warmup", 0), ("steps", 1)):
        if getattr(args, name) < least:
            parser.error(f"--{name} must be >= {least}, got {getattr(args, name)}")
    volume = phantom()
    src, dst = phantom_handles()
    width, height = (int(v) for v in args.window_size.split("x"))
    settings = VolumeSettings(method=args.method, grid=args.grid)
    app = VolumeApp(volume, src, dst, settings=settings, window_size=(width, height))
    x, y = dst[0, 0], dst[0, 1]  # the large sphere's target, in the axial view (z = 32)
    events: list = [Key(k) for k in args.overlay] + [Press(x, y)]
    for k in range(args.warmup + args.frames):
        angle = 2 * math.pi * k / 30
        events.append(Move(x + 3 * math.sin(angle), y - 3 * math.cos(angle)))
    events += [Release(x, y)] + [Key("Up")] * args.steps
    stamps: list[float] = []

    def on_frame(a: VolumeApp) -> None:
        stamps.append(time.perf_counter())

    if not run_scripted(app, events, on_frame, "volume_window_benchmark"):
        return 1
    gaps = np.diff(stamps) * 1000  # gaps[i]: frame i + 1, which fed events[i + 1]
    first = len(args.overlay) + 1 + args.warmup
    drag = gaps[first - 1 : first - 1 + args.frames]
    steps = gaps[first + args.frames : first + args.frames + args.steps]
    result = {
        "drag_ms_median": round(float(np.median(drag)), 1),
        "drag_ms_p90": round(float(np.percentile(drag, 90)), 1),
        "slice_point_ms_median": round(float(np.median(steps)), 1),
        "method": args.method,
        "grid": args.grid,
        "overlays": args.overlay,
        "volume": "64x64x64",
        "window": args.window_size,
        "stage_ms": {k: round(1000 * v, 2) for k, v in app.timings.items()},
    }
    report(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
