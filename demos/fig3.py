"""
The paper's Fig. 3: polygon interpolation against the simple forward map
========================================================================

The handles enlarge the astronaut's head 1.7 times and hold the frame still. The input with
its handles (p blue, q red) stands beside two forward maps of the same deformation: the
forward map with polygon interpolation (``method="quads"``: the deformed mesh filled by the
GPU's scan conversion) and the simple forward map (``method="splat"``: each source pixel
written once at round(f(v))), which leaves gaps wherever the map stretches the image.

From the command line::

    python demos/fig3.py [--out demos/out/fig3.png] [--grid 1]

The photograph is glmls/data/astronaut.jpg (NASA, public domain; see demos/README.md).
"""

from __future__ import annotations

import argparse
import os
import time
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import glmls

HEAD = np.array([224.0, 105.0])  # centre of the face, (x, y) pixels
ENLARGE = 1.7


def handles(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """p, q: a ring around the head moved outward, its centre and the frame held still."""
    height, width = shape
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    ring = HEAD + 70 * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    xs, ys = np.linspace(0, width - 1, 4), np.linspace(0, height - 1, 4)
    frame = np.array(
        [(x, y) for x in xs for y in ys if x in (xs[0], xs[-1]) or y in (ys[0], ys[-1])]
    )
    p = np.concatenate([[HEAD], ring, frame])
    q = np.concatenate([[HEAD], HEAD + ENLARGE * (ring - HEAD), frame])
    return p, q


def draw_handles(image: np.ndarray, p: np.ndarray, q: np.ndarray) -> Image.Image:
    """The input with each handle p (blue) and its target q (red), joined by a line."""
    canvas = Image.fromarray(image)
    draw = ImageDraw.Draw(canvas)
    for (px, py), (qx, qy) in zip(p, q, strict=True):
        draw.line([(px, py), (qx, qy)], fill=(255, 255, 0), width=2)
        draw.ellipse([qx - 5, qy - 5, qx + 5, qy + 5], fill=(230, 30, 30))
        draw.ellipse([px - 5, py - 5, px + 5, py + 5], fill=(40, 90, 255))
    return canvas


def compose(panels: list[Image.Image], titles: list[str]) -> Image.Image:
    width, height = panels[0].size
    gap, band = 8, 28
    sheet = Image.new("RGB", (len(panels) * (width + gap) - gap, height + band), "white")
    draw = ImageDraw.Draw(sheet)
    for k, (panel, title) in enumerate(zip(panels, titles, strict=True)):
        x = k * (width + gap)
        sheet.paste(panel, (x, band))
        draw.text((x + 6, 7), title, fill="black", font_size=16)
    return sheet


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path(os.path.relpath(Path(__file__).parent / "out")) / "fig3.png",
    )
    parser.add_argument("--grid", type=int, default=1, help="mesh step of the quads, pixels")
    args = parser.parse_args()

    image = glmls.imread(resources.files("glmls") / "data" / "astronaut.jpg")
    p, q = handles(image.shape[:2])
    with glmls.MLS(p, q, transform="rigid", shape=image.shape) as m:
        start = time.perf_counter()
        quads = m.warp(image, method="quads", grid=args.grid, background=255)
        middle = time.perf_counter()
        splat = m.warp(image, method="splat", background=255)
        end = time.perf_counter()
        folds = glmls.analysis.foldovers(m, image.shape, grid=args.grid)
    print(
        f"quads {1e3 * (middle - start):.0f} ms, splat {1e3 * (end - middle):.0f} ms, "
        f"{folds.count} folded cells"
    )
    sheet = compose(
        [draw_handles(image, p, q), Image.fromarray(quads), Image.fromarray(splat)],
        [
            "input, handles p (blue) -> q (red)",
            "forward with polygon interpolation",
            "simple forward",
        ],
    )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
