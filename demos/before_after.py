"""
Before and after
================

The bundled portrait (``glmls.data.astronaut()``) deformed by its bundled handles
(``glmls.data.astronaut_handles()``): the head turned and tilted while the shoulders and the
background hold (the edit made ``--strength`` times larger, 1.5 by default, so that it shows
at a glance). A light grid drawn over the photograph shows how the plane bends. Left, the
input with each source handle p (a disk) and an arrow to its target q; right, the rigid MLS
deformation (idw, alpha 1) built by the default forward method with bilinear colours, with
the targets q marked: every handle lands on its target.

From the command line::

    python demos/before_after.py [--out demos/out/before_after.png] [--scale 0.9]
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import glmls
from glmls.analysis import render_handles


def compose(left: np.ndarray, right: np.ndarray, titles: tuple[str, str], scale: float):
    """The two pictures side by side on a white sheet, each with its title above it."""
    gap, band = 12, 28
    pictures = []
    for array in (left, right):
        picture = Image.fromarray(array)
        size = (round(picture.width * scale), round(picture.height * scale))
        pictures.append(picture.resize(size, Image.Resampling.LANCZOS))
    width = sum(p.width for p in pictures) + gap
    height = max(p.height for p in pictures) + band
    sheet = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(sheet)
    x = 0
    for picture, title in zip(pictures, titles, strict=True):
        sheet.paste(picture, (x, band))
        draw.text((x + 4, 6), title, fill="black", font_size=16)
        x += picture.width + gap
    return sheet


def draw_grid(image: np.ndarray, step: int = 32) -> np.ndarray:
    """A copy of ``image`` with light lines every ``step`` pixels, blended at 40 %."""
    picture = Image.fromarray(image).convert("RGBA")
    lines = Image.new("RGBA", picture.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(lines)
    for x in range(step // 2, picture.width, step):
        draw.line([(x, 0), (x, picture.height)], fill=(255, 255, 255, 100), width=1)
    for y in range(step // 2, picture.height, step):
        draw.line([(0, y), (picture.width, y)], fill=(255, 255, 255, 100), width=1)
    return np.asarray(Image.alpha_composite(picture, lines).convert("RGB"))


def mark_targets(image: np.ndarray, points: np.ndarray, radius: float = 5.0) -> np.ndarray:
    """Red disks with a white rim at ``points`` (x, y) over a copy of ``image``."""
    picture = Image.fromarray(image)
    draw = ImageDraw.Draw(picture)
    for x, y in points:
        box = [x - radius, y - radius, x + radius, y + radius]
        draw.ellipse(box, fill=(230, 30, 30), outline="white", width=2)
    return np.asarray(picture)


def main() -> None:
    parser = argparse.ArgumentParser(description="Before and after: a deformation by MLS.")
    default = Path(os.path.relpath(Path(__file__).parent / "out")) / "before_after.png"
    parser.add_argument("--out", type=Path, default=default, help="PNG or JPEG to write")
    parser.add_argument("--scale", type=float, default=0.9, help="size of the panels")
    parser.add_argument("--strength", type=float, default=1.5, help="the edit's scale")
    args = parser.parse_args()

    image = draw_grid(glmls.data.astronaut())
    src, dst = glmls.data.astronaut_handles()
    dst = src + args.strength * (dst - src)
    with glmls.MLS(src, dst, transform="rigid", weight="idw", shape=image.shape) as m:
        out = m.warp(image, interpolation="linear", border="edge")
        moved = np.linalg.norm(m(src) - dst, axis=1).max()
    print(f"{len(src)} handles, largest move {np.linalg.norm(dst - src, axis=1).max():.1f} px")
    print(f"largest distance of f(p) from q: {moved:.4f} px")

    before = render_handles(image, src, dst, radius=6.0, width=3.0, head=14.0)
    after = mark_targets(out, dst)
    sheet = compose(before, after, ("input, handles p -> q", "deformed (rigid MLS)"), args.scale)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(args.out, optimize=True, quality=85)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
