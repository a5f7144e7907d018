"""
A batch of random deformations for data augmentation
====================================================

``glmls.augment.Augment`` deforms a batch at random, each sample from its own ``(seed,
index)``, with the labels moved through the map that placed the pixels. A contact sheet: a
text line under Luo et al.'s three text deformations (distortion, stretching, perspective),
the fiducial points' targets as small rings and the keypoints (one on each word's first
letter) as red dots, then the photograph under the jittered grid with a box around the face
(green, from its densely sampled outline) and keypoints on the eyes and the mouth.

From the command line::

    python demos/augment_batch.py [--out demos/out/augment_batch.jpg] [--seed 0]
    python demos/augment_batch.py --out docs/images/augment_batch.jpg   # the docs' picture

The photograph is glmls/data/astronaut.jpg (NASA, public domain; see demos/README.md).
"""

from __future__ import annotations

import argparse
import os
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

import glmls
from glmls.augment import Augment

TEXT = "glmls augment"
#: (x, y) of the eyes and the middle of the mouth in the 512 x 512 photograph, and a box
#: around the face
FACE_POINTS = np.array([[202.0, 100.0], [248.0, 103.0], [224.0, 146.0]])
FACE_BOX = np.array([[174.0, 58.0, 280.0, 186.0]])


def text_line(height: int = 48, width: int = 300) -> tuple[np.ndarray, np.ndarray]:
    """A dark text line on a light ground, and a keypoint on each word's first letter."""
    picture = Image.new("RGB", (width, height), (236, 230, 214))
    draw = ImageDraw.Draw(picture)
    font = ImageFont.load_default(size=34)
    draw.text((14, 4), TEXT, fill=(30, 40, 90), font=font)
    first = draw.textbbox((14, 4), "g", font=font)
    second = draw.textbbox((14 + draw.textlength("glmls ", font=font), 4), "a", font=font)
    points = np.array(
        [[(first[0] + first[2]) / 2, (first[1] + first[3]) / 2],
         [(second[0] + second[2]) / 2, (second[1] + second[3]) / 2]]
    )  # fmt: skip
    return np.asarray(picture), points


def marked(image, keypoints, valid, targets=None, boxes=None, scale=1.0) -> Image.Image:
    """The image (resized by ``scale``) with its keypoints, handle targets and boxes."""
    picture = Image.fromarray(image)
    picture = picture.resize(
        (round(picture.width * scale), round(picture.height * scale)), Image.Resampling.LANCZOS
    )
    draw = ImageDraw.Draw(picture)

    def at(point):
        return (point[0] + 0.5) * scale - 0.5, (point[1] + 0.5) * scale - 0.5

    for x, y in [at(p) for p in (targets if targets is not None else [])]:
        draw.ellipse([x - 3, y - 3, x + 3, y + 3], outline=(40, 150, 255), width=1)
    for box in boxes if boxes is not None else []:
        x0, y0 = at(box[:2])
        x1, y1 = at(box[2:])
        draw.rectangle([x0, y0, x1, y1], outline=(40, 200, 60), width=2)
    for (x, y), ok in zip([at(p) for p in keypoints], valid, strict=True):
        colour = (230, 30, 30) if ok else (150, 150, 150)
        draw.ellipse([x - 4, y - 4, x + 4, y + 4], fill=colour, outline="white")
    return picture


def sheet(rows: list[tuple[str, list[Image.Image]]]) -> Image.Image:
    gap, band = 8, 22
    width = max(sum(p.width for p in row) + gap * (len(row) - 1) for _, row in rows)
    height = sum(max(p.height for p in row) + band + gap for _, row in rows)
    canvas = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(canvas)
    y = 0
    for title, row in rows:
        draw.text((2, y + 3), title, fill="black", font_size=14)
        x = 0
        for picture in row:
            canvas.paste(picture, (x, y + band))
            x += picture.width + gap
        y += max(p.height for p in row) + band + gap
    return canvas


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    default = Path(os.path.relpath(Path(__file__).parent / "out")) / "augment_batch.jpg"
    parser.add_argument("--out", type=Path, default=default)
    parser.add_argument("--seed", type=int, default=0, help="the augmentation's seed")
    parser.add_argument("--n", type=int, default=3, help="samples per preset")
    args = parser.parse_args()

    line, points = text_line()
    batch = np.stack([line] * args.n)
    marks = np.stack([points] * args.n)
    rows = []
    for preset in ("text-distort", "text-stretch", "text-perspective"):
        out = Augment(preset, seed=args.seed)(batch, keypoints=marks)
        pictures = [
            marked(out.images[i], out.keypoints[i], out.keypoints_valid[i], out.params[i]["dst"])
            for i in range(args.n)
        ]
        rows.append((preset, pictures))
        moved = np.abs(out.keypoints - marks).max()
        print(f"{preset}: keypoints moved by up to {moved:.1f} pixels")

    photo = glmls.imread(resources.files("glmls") / "data" / "astronaut.jpg")
    photos = np.stack([photo] * args.n)
    out = Augment("grid", seed=args.seed, rows=4, cols=4, displacement=0.06)(
        photos, keypoints=np.stack([FACE_POINTS] * args.n), boxes=np.stack([FACE_BOX] * args.n)
    )
    scale = 0.45
    pictures = [
        marked(
            out.images[i], out.keypoints[i], out.keypoints_valid[i], boxes=out.boxes[i], scale=scale
        )
        for i in range(args.n)
    ]
    rows.append(("grid 4 x 4, displacement 0.06", pictures))
    print(f"grid: the face's box became {np.round(out.boxes[:, 0], 1).tolist()}")

    args.out.parent.mkdir(parents=True, exist_ok=True)
    sheet(rows).save(args.out, quality=85, optimize=True)
    print(f"wrote {args.out} ({args.out.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main()
