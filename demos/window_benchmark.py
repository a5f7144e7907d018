"""
Frames per second of the real-time window while a handle is dragged
===================================================================

Opens the real window (run it under a display or ``xvfb-run -a``) on the bundled 512 x 512
photograph with 16 handles at grid 4, feeds a scripted drag of one handle (one cursor move
per frame, through the same controller as the mouse) and reports the frames drawn per second
of wall-clock time, swaps included, after a warm-up. ``--overlay e`` (etc.) turns overlays on
first. Writes nothing unless ``--json OUT`` is given. It needs a window, so the gallery leaves
it out.

From the command line::

    xvfb-run -a python demos/window_benchmark.py [--frames 300] [--grid 4] [--overlay e]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from glmls.app.controller import CONSTRUCTIONS, Settings
from glmls.app.events import Key, Move, Press, Release
from glmls.app.window import App, NoDisplayError
from glmls.data import astronaut, astronaut_handles

#: Six handles added to the bundled ten: 16 handles in all.
EXTRA = [[60, 200], [470, 220], [150, 420], [330, 430], [300, 200], [160, 170]]


def drag_events(centre: np.ndarray, frames: int, radius: float = 40.0) -> list:
    """Press on the handle, move it around a circle (one move per frame), release."""
    events: list = [Press(*centre)]
    for k in range(frames):
        angle = 2 * math.pi * k / 120
        events.append(
            Move(centre[0] + radius * math.sin(angle), centre[1] - radius * 0.5 * k / frames)
        )
    events.append(Release(*centre))
    return events


def run_scripted(app, events: list, on_frame, name: str) -> bool:
    """Run the window for ``events``, one per frame, and one frame more, ``on_frame`` after
    each; False, said on standard error, where there is no display."""
    try:
        app.run(events=events, frames=len(events) + 1, on_frame=on_frame)
    except NoDisplayError as error:
        print(f"{name}: {error}", file=sys.stderr)
        return False
    return True


def report(result: dict, path: str | None) -> None:
    """Print ``result`` as one line of JSON; also write it to ``path`` where given."""
    print(json.dumps(result))
    if path:
        with open(path, "w", encoding="utf-8") as out:
            json.dump(result, out, indent=2)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--frames", type=int, default=300, help="drag frames measured")
    parser.add_argument("--warmup", type=int, default=20, help="drag frames not measured")
    parser.add_argument("--grid", type=int, default=4)
    parser.add_argument("--construction", type=int, default=0, help="0 quads-nearest .. 3")
    parser.add_argument("--overlay", action="append", default=[], help="overlay keys: e a f m")
    parser.add_argument("--window-size", default="840x512")
    parser.add_argument("--json", help="write the result here")
    args = parser.parse_args(argv)
    for name, least in (("frames", 1), ("warmup", 0)):
        if getattr(args, name) < least:
            parser.error(f"--{name} must be >= {least}, got {getattr(args, name)}")
    if not 0 <= args.construction < len(CONSTRUCTIONS):
        parser.error(
            f"--construction must be 0 to {len(CONSTRUCTIONS) - 1}, got {args.construction}"
        )
    image = astronaut()
    src, dst = astronaut_handles()
    src = np.concatenate([src, EXTRA]).astype(float)
    dst = np.concatenate([dst, EXTRA]).astype(float)
    assert len(src) == 16
    width, height = (int(v) for v in args.window_size.split("x"))
    method, interpolation = CONSTRUCTIONS[args.construction]
    settings = Settings(method=method, interpolation=interpolation, grid=args.grid)
    app = App(image, src, dst, settings=settings, name="astronaut", window_size=(width, height))
    app.controller.reference = np.zeros((0, 2))
    events = [Key(k) for k in args.overlay]
    events += drag_events(dst[2], args.warmup + args.frames)
    stamps: list[float] = []
    drawn: list[int] = []

    def on_frame(a: App) -> None:
        stamps.append(time.perf_counter())
        drawn.append(a.controller.revision)

    if not run_scripted(app, events, on_frame, "window_benchmark"):
        return 1
    first = len(args.overlay) + 1 + args.warmup  # frames before the measured drag
    measured = stamps[first : first + args.frames + 1]
    seconds = measured[-1] - measured[0]
    fps = (len(measured) - 1) / seconds
    result = {
        "fps": round(fps, 1),
        "ms_per_frame": round(1000 / fps, 2),
        "frames": len(measured) - 1,
        "grid": args.grid,
        "handles": 16,
        "image": "512x512",
        "window": args.window_size,
        "overlays": args.overlay,
        "construction": args.construction,
        "stage_ms": {k: round(1000 * v, 2) for k, v in app.timings.items()},
        "distinct_handle_states": len(set(drawn[first : first + args.frames + 1])),
    }
    report(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
