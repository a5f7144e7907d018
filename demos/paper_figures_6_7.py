"""
The paper's Figs. 6 and 7: the MLS error field and the angular error
====================================================================

Four handles are dragged on the astronaut's face (hair up, mouth corners out and up, chin
down) while the eyes, the head's outline and the frame hold still. Fig. 6: the input with its
handles, the deformed image (similarity transform, inverse-distance weights) and the MLS error
field. Fig. 7: the input with its handles, the Delaunay triangulation of reference points on
the face and each triangle's angular error. ``glmls.analysis.report`` computes all of it.

From the command line::

    python demos/paper_figures_6_7.py [--out out/paper_figures_6_7] [--grid 1]
                                      [--cmap paper|viridis] [--percentile 99]

The photograph is glmls/data/astronaut.jpg (NASA, public domain).
"""

from __future__ import annotations

import argparse
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image

import glmls
from glmls.analysis.reporting import compose

# Four dragged handles (hair up, mouth corners out and up, chin down) ...
DRAGGED_SRC = [[228, 20], [203, 142], [243, 142], [223, 175]]
DRAGGED_DST = [[228, 6], [195, 133], [252, 133], [223, 189]]
# ... and fixed ones: the eyes, around the head, and the frame of the picture.
FIXED = [
    [200, 102], [248, 102], [150, 100], [305, 100], [228, 235],
    [0, 0], [256, 0], [511, 0], [0, 256], [511, 256], [0, 511], [256, 511], [511, 511],
]  # fmt: skip
# Reference points chosen on the face, not at the handles.
REFERENCE = [
    [198, 96], [250, 96], [220, 124], [210, 138], [238, 139], [224, 153], [224, 168],
    [180, 118], [268, 114], [186, 58], [268, 58], [226, 30], [165, 82], [296, 82],
    [192, 160], [258, 160], [185, 196], [268, 196], [226, 206], [226, 80],
]  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--out", type=Path, default=Path("out/paper_figures_6_7"))
    parser.add_argument("--grid", type=int, default=1, help="error field mesh step (pixels)")
    parser.add_argument(
        "--cmap", choices=["paper", "viridis"], default="paper", help="paper: white to red"
    )
    parser.add_argument(
        "--percentile", type=float, default=99.0, help="upper bound of the error field colours"
    )
    args = parser.parse_args()

    path = resources.files("glmls").joinpath("data/astronaut.jpg")
    with path.open("rb") as file:
        image = np.asarray(Image.open(file).convert("RGB"))
    src = np.array(DRAGGED_SRC + FIXED, float)
    dst = np.array(DRAGGED_DST + FIXED, float)

    with glmls.MLS(src, dst, transform="similarity", weight="idw", shape=image.shape) as m:
        result = glmls.analysis.report(
            image,
            m,
            REFERENCE,
            grid=args.grid,
            cmap="linear" if args.cmap == "paper" else "viridis",
            percentile=args.percentile,
            out_dir=args.out,
        )
    images = result.images
    middle = images["deformed"]
    fig6 = compose(
        [images["input_handles"], middle, images["error_field"], images["error_field_colorbar"]]
    )
    fig7 = compose(
        [
            images["input_handles"],
            images["triangulation"],
            images["triangle_angle"],
            images["triangle_angle_colorbar"],
        ]
    )
    Image.fromarray(fig6).save(args.out / "fig6.png")
    Image.fromarray(fig7).save(args.out / "fig7.png")

    s = result.summary
    field, angle = s["error_field"], s["triangles"]["angle"]
    print(f"wrote {args.out}/fig6.png, fig7.png, report.json and the single pictures")
    print(f"fold-overs: {s['foldovers']['cells']} cells; timings (s): {s['timings_s']}")
    print(
        f"E_MLS (px^2): mean {field['mean']:.1f}, std {field['std']:.1f}, "
        f"min {field['min']:.1f}, max {field['max']:.1f}, within 1/2/3 std {field['within']}"
    )
    print(
        f"angular error over {s['triangles']['triangles']} triangles: mean {angle['mean']:.4f}, "
        f"std {angle['std']:.4f}, max {angle['max']:.4f}; flipped {s['triangles']['flipped']}"
    )


if __name__ == "__main__":
    main()
