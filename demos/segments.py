"""
Segment handles keep straight edges straight
============================================

On the launch photo the rocket is tilted about its base while the lightning masts, the big
towers and the pad hold still. The same edit is made twice, with line-segment handles and with
point handles at the segments' ends, and the table measures how straight each edge stays:
the points bend the rocket's axis, the segments keep it straight.

From the command line::

    python demos/segments.py [--out demos/out/segments.jpg] [--tilt 9] [--scale 1]
        [--transform rigid] [--weight idw] [--alpha 1]

Straightness of a straight edge: points sampled along it in the source are mapped by f
(``m(points)``) and the largest distance of a mapped point from the straight line through the
mapped ends is its deviation in pixels (0 = still straight). The handles are measured, and so
are edges that are not handles (the rocket's sides, the masts' lattices, the towers' outer
legs). The photograph is glmls/data/rocket.jpg (SpaceX, public domain; see
glmls/data/README.md).
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import glmls

PIVOT = np.array([322.0, 405.0])  # the foot of the rocket on the pad, (x, y) pixels

#: segment handles, (x, y) pixels of the 640 x 427 photograph: the rocket's axis (tilted about
#: PIVOT), then the structures held still
HANDLES = {
    "rocket axis": [[322.0, 405.0], [322.0, 128.0]],
    "left mast": [[201.0, 124.0], [201.0, 400.0]],
    "right mast": [[447.0, 124.0], [447.0, 405.0]],
    "left tower": [[87.0, 2.0], [76.0, 410.0]],
    "right tower": [[561.0, 2.0], [568.0, 420.0]],
    "pad": [[268.0, 407.0], [376.0, 407.0]],
}
#: straight edges of the photograph that are not handles
EDGES = {
    "rocket, left side": [[314.0, 185.0], [314.0, 400.0]],
    "rocket, right side": [[330.0, 185.0], [330.0, 400.0]],
    "left mast, lattice": [[190.0, 192.0], [171.0, 398.0]],
    "right mast, lattice": [[454.0, 192.0], [469.0, 405.0]],
    "left tower, outer leg": [[46.0, 2.0], [4.0, 380.0]],
    "right tower, outer leg": [[595.0, 2.0], [612.0, 420.0]],
}


def handles(tilt: float, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(A, B): source and target segments, (S, 2, 2), of the photograph resized by ``scale``;
    the rocket's axis turned by ``tilt`` degrees (clockwise on screen) about its foot."""
    a = np.array(list(HANDLES.values()))
    b = a.copy()
    angle = np.radians(tilt)
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    b[0] = (a[0] - PIVOT) @ turn.T + PIVOT
    return a * scale, b * scale


def edges(scale: float = 1.0) -> np.ndarray:
    """The straight edges that are not handles, (E, 2, 2), for the photograph resized by
    ``scale``."""
    return np.array(list(EDGES.values())) * scale


def _along(segments: np.ndarray, samples: int) -> np.ndarray:
    """``samples`` evenly spaced points along each segment, (S, samples, 2)."""
    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    return (1 - t) * segments[:, :1] + t * segments[:, 1:]


def deviation(m: glmls.MLS, segments: np.ndarray, samples: int = 65) -> np.ndarray:
    """Per segment (S, 2, 2): the largest distance (pixels) of f at ``samples`` points along it
    from the straight line through f of its ends."""
    points = _along(segments, samples)
    mapped = m(points.reshape(-1, 2)).reshape(points.shape)
    start, end = mapped[:, :1], mapped[:, -1:]
    u, v = end - start, mapped - start
    cross = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    return (np.abs(cross) / np.linalg.norm(u, axis=-1)).max(axis=1)


def miss(m: glmls.MLS, a: np.ndarray, b: np.ndarray, samples: int = 65) -> np.ndarray:
    """Per handle: the largest distance (pixels) of f(p(t)) from its target q(t) along the
    segment (how far the edit is from the one asked for)."""
    points = _along(a, samples)
    mapped = m(points.reshape(-1, 2)).reshape(points.shape)
    return np.linalg.norm(mapped - _along(b, samples), axis=-1).max(axis=1)


@dataclass
class Version:
    """One version of the edit: per handle its bend (:func:`deviation`) and :func:`miss`, per
    checked edge its bend (pixels), and the warped image (``None`` if none was asked for)."""

    handles: np.ndarray
    miss: np.ndarray
    edges: np.ndarray
    image: np.ndarray | None


def compare(
    a: np.ndarray,
    b: np.ndarray,
    checks: np.ndarray,
    shape: tuple[int, int],
    image: np.ndarray | None = None,
    **options: object,
) -> dict[str, Version]:
    """The same edit with point handles at the segments' ends (``"points"``) and with segment
    handles (``"segments"``): A -> B, the straight edges ``checks`` (E, 2, 2) measured, and
    ``image`` warped if given. ``options`` go to :class:`glmls.MLS` (transform, weight, ctx)."""
    none = np.zeros((0, 2))
    versions = {
        "points": {"src": a.reshape(-1, 2), "dst": b.reshape(-1, 2)},
        "segments": {"src": none, "dst": none, "src_segments": a, "dst_segments": b},
    }
    results: dict[str, Version] = {}
    for name, given in versions.items():
        with glmls.MLS(**given, shape=shape, **options) as m:
            warped = None
            if image is not None:
                warped = m.warp(image, interpolation="linear", border="edge", grid=2)
            results[name] = Version(deviation(m, a), miss(m, a, b), deviation(m, checks), warped)
    return results


def draw_segments(
    picture: Image.Image, segments: np.ndarray, colour: tuple[int, int, int], width: int = 3
) -> None:
    """Lines with a dot at each end (no dots when ``width`` is 1: guides)."""
    draw = ImageDraw.Draw(picture)
    for (x0, y0), (x1, y1) in segments:
        draw.line([(x0, y0), (x1, y1)], fill=colour, width=width)
        if width > 1:
            for x, y in ((x0, y0), (x1, y1)):
                draw.ellipse([x - 4, y - 4, x + 4, y + 4], fill=colour)


def compose(panels: list[tuple[Image.Image, str]]) -> Image.Image:
    gap, band = 8, 26
    width = sum(p.width for p, _ in panels) + gap * (len(panels) - 1)
    height = max(p.height for p, _ in panels) + band
    sheet = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(sheet)
    x = 0
    for picture, title in panels:
        sheet.paste(picture, (x, band))
        draw.text((x + 4, 5), title, fill="black", font_size=14)
        x += picture.width + gap
    return sheet


def table(results: dict[str, Version]) -> list[str]:
    """The straightness table (Markdown): handles (deviation, miss), then other edges."""
    points, segments = results["points"], results["segments"]
    rows = [
        "| straight edge | bend, point handles (px) | bend, segment handles (px) |"
        " miss, point handles (px) | miss, segment handles (px) |",
        "|---|---:|---:|---:|---:|",
    ]
    for k, name in enumerate(HANDLES):
        values = (points.handles, segments.handles, points.miss, segments.miss)
        cells = " | ".join(f"{v[k]:.2f}" for v in values)
        rows.append(f"| handle: {name} | {cells} |")
    for k, name in enumerate(EDGES):
        cells = " | ".join(f"{v[k]:.2f}" for v in (points.edges, segments.edges))
        rows.append(f"| {name} | {cells} | - | - |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    default = Path(os.path.relpath(Path(__file__).parent / "out")) / "segments.jpg"
    parser.add_argument("--out", type=Path, default=default)
    parser.add_argument("--tilt", type=float, default=9.0, help="degrees, clockwise")
    parser.add_argument("--scale", type=float, default=1.0, help="size of the panels")
    parser.add_argument("--transform", default="rigid", choices=glmls.TRANSFORMS)
    parser.add_argument("--weight", default="idw", choices=glmls.WEIGHTS)
    parser.add_argument("--alpha", type=float, default=1.0, help="idw's exponent")
    args = parser.parse_args()

    image = glmls.data.rocket()
    shape = image.shape[:2]
    a, b = handles(args.tilt)
    options = {"transform": args.transform, "weight": args.weight, "alpha": args.alpha}
    results = compare(a, b, edges(), shape, image, **options)
    print("\n".join(table(results)))

    def panel(array: np.ndarray | None, drawn: list[tuple[np.ndarray, tuple[int, int, int], int]]):
        picture = Image.fromarray(np.asarray(array))
        for segments, colour, width in drawn:
            draw_segments(picture, segments, colour, width)
        size = (round(picture.width * args.scale), round(picture.height * args.scale))
        return picture.resize(size, Image.Resampling.LANCZOS)

    blue, red, green = (60, 140, 255), (255, 60, 40), (60, 220, 90)
    held = (a == b).all(axis=(1, 2))
    drawn = [(a[held], green, 3), (a[~held], blue, 3), (b[~held], red, 3)]
    guides = [(b, red, 1)]  # the targets: where the handles should lie, straight
    points, segments = results["points"], results["segments"]
    bent = max(points.handles.max(), points.edges.max())
    straight = max(segments.handles.max(), segments.edges.max())
    panels = [
        (panel(image, drawn), "input: segments held (green), rocket axis moved (blue -> red)"),
        (
            panel(points.image, guides),
            f"point handles at the segment ends: lines bend up to {bent:.1f} px",
        ),
        (
            panel(segments.image, guides),
            f"segment handles: lines straight to {straight:.2f} px",
        ),
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    compose(panels).save(args.out, quality=80, optimize=True)
    print(f"wrote {args.out} ({args.out.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main()
