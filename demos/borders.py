"""
Border modes and the output canvas
==================================

A deformation that pulls the image border in leaves black slivers with the constant border
and fills them with ``border="edge"`` or ``"symmetric"``; a deformation that pushes the
image out is cut off on the input's frame and kept whole on the canvas of ``MLS.bounds``
(``glmls warp --fit`` on the command line).

From the command line::

    python demos/borders.py [--out demos/out/borders.png] [--scale 0.5]

The photograph is glmls/data/astronaut.jpg (NASA, public domain; see demos/README.md).
"""

from __future__ import annotations

import argparse
import os
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import glmls


def turned(shape: tuple[int, int], zoom: float, degrees: float):
    """p, q: five handles (the corners' insides and the centre) turned and zoomed about
    the centre: the rigid MLS turns the picture and bends it towards the zoom."""
    height, width = shape
    centre = np.array([(width - 1) / 2, (height - 1) / 2])
    p = np.array([[0.2, 0.2], [0.8, 0.2], [0.8, 0.8], [0.2, 0.8], [0.5, 0.5]])
    p = p * [width - 1, height - 1]
    a = np.radians(degrees)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return p, (p - centre) @ rot.T * zoom + centre


def panel(image: np.ndarray, scale: float, title: str) -> tuple[Image.Image, str]:
    picture = Image.fromarray(image)
    size = (round(picture.width * scale), round(picture.height * scale))
    return picture.resize(size, Image.Resampling.LANCZOS), title


def compose(panels: list[tuple[Image.Image, str]]) -> Image.Image:
    gap, band = 10, 26
    width = sum(p.width for p, _ in panels) + gap * (len(panels) - 1)
    height = max(p.height for p, _ in panels) + band
    sheet = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(sheet)
    x = 0
    for picture, title in panels:
        sheet.paste(picture, (x, band))
        draw.rectangle([x, band, x + picture.width - 1, band + picture.height - 1], outline="grey")
        draw.text((x + 4, 5), title, fill="black", font_size=14)
        x += picture.width + gap
    return sheet


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    default = Path(os.path.relpath(Path(__file__).parent / "out")) / "borders.png"
    parser.add_argument("--out", type=Path, default=default)
    parser.add_argument("--scale", type=float, default=0.5, help="size of the panels")
    args = parser.parse_args()

    image = glmls.imread(resources.files("glmls") / "data" / "astronaut.jpg")
    shape = image.shape[:2]
    opaque = np.dstack([image, np.full(shape, 255, np.uint8)])  # uncovered: alpha 0
    panels = []
    with glmls.MLS(*turned(shape, 0.88, 7.0), shape=shape) as m:  # pulls the border in
        for border in ("constant", "edge", "symmetric"):
            out = m.warp(image, border=border, interpolation="linear", grid=2)
            uncovered = int((m.warp(opaque, border=border, grid=2)[..., 3] == 0).sum())
            print(f"pulled in, border {border}: {uncovered} pixels left to the background")
            panels.append(panel(out, args.scale, f"border={border!r}"))
    with glmls.MLS(*turned(shape, 1.12, 7.0), shape=shape) as m:  # pushes the image out
        cut = m.warp(image, interpolation="linear", grid=2, background=255)
        b = m.bounds(shape, grid=2)
        whole = m.warp(
            image,
            interpolation="linear",
            grid=2,
            background=255,
            output_shape=b.output_shape,
            origin=b.origin,
        )
        print(
            f"pushed out: bounds x {b.x0:.1f} .. {b.x1:.1f}, y {b.y0:.1f} .. {b.y1:.1f}; "
            f"canvas {b.output_shape} from {b.origin}"
        )
    panels.append(panel(cut, args.scale, "pushed out: the input's frame"))
    panels.append(panel(whole, args.scale, "output_shape, origin = m.bounds"))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    compose(panels).save(args.out, optimize=True)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
