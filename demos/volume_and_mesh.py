"""
3D: a volume and a mesh deformed by MLS
=======================================

The bundled 64³ phantom deformed by a rigid MLS of 3D point handles (the large sphere moved
4 voxels along x and 2 along -y, the small one 2 along -z, the body's corners held): three
orthogonal slices and the maximum-intensity projection of the input with the handles (arrows
from p to q) and of the deformed volume built by the forward method (the tetrahedra of the
deformed voxel-corner lattice), then the error field of eq. 7 on the same slices. Below, the
bundled sphere mesh before and after its edit (the +x pole pulled out 6, the +z pole 3),
seen along z, its faces shaded by the normals that the Jacobian carried.

From the command line::

    python demos/volume_and_mesh.py [--out demos/out/volume_and_mesh.png]

The same from the command line: ``glmls warp phantom.nii.gz out.nii.gz --handles h3.json``
and ``glmls analyze phantom.nii.gz --handles h3.json --out report/``.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import glmls
from glmls.analysis import render_volume_slices, volume_error_field


def mesh_view(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, size: int):
    """The mesh seen along z (orthographic, painter's order), shaded by its normals."""
    picture = Image.new("RGB", (size, size), "white")
    draw = ImageDraw.Draw(picture)
    scale = size / 64.0
    face_normals = normals[faces].mean(axis=1)
    face_normals /= np.linalg.norm(face_normals, axis=1, keepdims=True)
    light = np.array([0.3, -0.4, 0.87])
    depth = vertices[faces, 2].mean(axis=1)
    for f in np.argsort(depth):  # far faces first: the nearer ones cover them
        if face_normals[f, 2] <= 0:
            continue
        shade = int(60 + 180 * max(0.0, float(face_normals[f] @ light)))
        corners = [(float(x) * scale, float(y) * scale) for x, y in vertices[faces[f], :2]]
        draw.polygon(corners, fill=(shade, shade, min(255, shade + 30)), outline=(40, 40, 60))
    return picture


def titled(picture: Image.Image, title: str) -> Image.Image:
    band = 22
    sheet = Image.new("RGB", (picture.width, picture.height + band), "white")
    sheet.paste(picture, (0, band))
    ImageDraw.Draw(sheet).text((4, 4), title, fill="black", font_size=14)
    return sheet


def side_by_side(pictures: list[Image.Image], gap: int = 8) -> Image.Image:
    width = sum(p.width for p in pictures) + gap * (len(pictures) - 1)
    sheet = Image.new("RGB", (width, max(p.height for p in pictures)), "white")
    x = 0
    for p in pictures:
        sheet.paste(p, (x, 0))
        x += p.width + gap
    return sheet


def stack(pictures: list[Image.Image]) -> Image.Image:
    width = max(p.width for p in pictures)
    sheet = Image.new("RGB", (width, sum(p.height for p in pictures)), "white")
    y = 0
    for p in pictures:
        sheet.paste(p, ((width - p.width) // 2, y))
        y += p.height
    return sheet


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    default = Path(os.path.relpath(Path(__file__).parent / "out")) / "volume_and_mesh.png"
    parser.add_argument("--out", type=Path, default=default)
    args = parser.parse_args()

    volume = glmls.data.phantom()
    src, dst = glmls.data.phantom_handles()
    with glmls.MLS(src, dst, transform="rigid", shape=volume.shape) as m:
        deformed = m.warp(volume, interpolation="linear")
        error = volume_error_field(m, volume.shape, grid=4)
        moved = np.abs(m(src) - dst).max()
    print(f"phantom {volume.shape}: handles on their targets within {moved:.4f} voxels")
    print(f"error field: max {error.max():.3f}, mean {error.mean():.3f} (eq. 7)")
    views = [
        titled(Image.fromarray(render_volume_slices(volume, src=src, dst=dst)), "input, p -> q"),
        titled(Image.fromarray(render_volume_slices(deformed)), "deformed (tetrahedra)"),
        titled(
            Image.fromarray(render_volume_slices(error, cmap="viridis", projection="max")),
            "MLS error field (eq. 7)",
        ),
    ]

    mesh = glmls.data.sphere()
    src, dst = glmls.data.sphere_handles()
    with glmls.MLS(src, dst, transform="rigid") as m:
        out = m.deform(mesh)
    print(
        f"sphere: {len(out.vertices)} vertices, {int(out.vertex_folds.sum())} folded vertices, "
        f"{int(out.face_folds.sum())} folded faces"
    )
    size = views[0].height // 2
    before = mesh_view(np.asarray(mesh.vertices), np.asarray(mesh.faces), _normals(mesh), size)
    after = mesh_view(out.vertices, out.faces, out.normals, size)
    pair = titled(side_by_side([before, after]), "sphere mesh, before and after (seen along z)")

    args.out.parent.mkdir(parents=True, exist_ok=True)
    stack([side_by_side(views), pair]).save(args.out, optimize=True)
    print(f"wrote {args.out}")


def _normals(mesh) -> np.ndarray:
    """The sphere's own vertex normals: from its centre outwards."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    n = v - v.mean(axis=0)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


if __name__ == "__main__":
    main()
