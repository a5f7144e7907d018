"""The main job on the bundled example: deform the photograph's mesh and draw it.

``glmls-example --out DIR`` writes ``DIR/mesh.png``: left, the photograph with its handles
(p, green, -> q, red) and the mesh; right, the mesh deformed by MLS on the GPU.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from . import MLS, TRANSFORMS, WEIGHTS
from .data import astronaut, astronaut_handles


def _draw_mesh(draw: ImageDraw.ImageDraw, mesh: np.ndarray, colour, offset: float) -> None:
    for row in mesh:
        draw.line([(x + offset, y) for x, y in row], fill=colour, width=1)
    for col in mesh.transpose(1, 0, 2):
        draw.line([(x + offset, y) for x, y in col], fill=colour, width=1)


def _draw_handles(draw: ImageDraw.ImageDraw, src, dst, offset: float) -> None:
    for (px, py), (qx, qy) in zip(src, dst, strict=True):
        draw.line([(px + offset, py), (qx + offset, qy)], fill=(255, 255, 0), width=2)
        draw.ellipse([px + offset - 4, py - 4, px + offset + 4, py + 4], fill=(0, 200, 0))
        draw.ellipse([qx + offset - 4, qy - 4, qx + offset + 4, qy + 4], fill=(230, 0, 0))


def mesh_picture(image: np.ndarray, m: MLS, grid: int) -> Image.Image:
    """Side by side: the image with handles and mesh, and the deformed mesh."""
    height, width = image.shape[:2]
    vertices, deformed = m.mesh((height, width), grid=grid)
    canvas = Image.new("RGB", (2 * width, height), (255, 255, 255))
    canvas.paste(Image.fromarray(image), (0, 0))
    faded = (image.astype(np.float32) * 0.25 + 191).astype(np.uint8)
    canvas.paste(Image.fromarray(faded), (width, 0))
    draw = ImageDraw.Draw(canvas)
    _draw_mesh(draw, vertices, (255, 255, 255), 0)
    _draw_mesh(draw, deformed, (20, 40, 160), width)
    _draw_handles(draw, m.src, m.dst, 0)
    _draw_handles(draw, m.src, m.dst, width)
    return canvas


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="glmls-example", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/example"), help="output folder")
    parser.add_argument("--transform", choices=TRANSFORMS, default="rigid")
    parser.add_argument("--weight", choices=WEIGHTS, default="idw")
    parser.add_argument("--grid", type=int, default=16, help="mesh step in pixels")
    args = parser.parse_args(argv)
    if args.grid < 1:
        parser.error(f"--grid must be >= 1, got {args.grid}")
    image = astronaut()
    src, dst = astronaut_handles()
    with MLS(src, dst, transform=args.transform, weight=args.weight, shape=image.shape) as m:
        picture = mesh_picture(image, m, args.grid)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "mesh.png"
    picture.save(path)
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
