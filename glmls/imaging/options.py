"""How a :class:`~glmls.imaging.pipeline.WarpPipeline` builds images: the choices between
equivalent internal paths, as one value. The defaults are the fastest; tests and benchmarks
take the other paths by passing other options, never by changing module state."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["PipelineOptions"]


@dataclass(frozen=True)
class PipelineOptions:
    """- ``compute_quads``: scan-convert the quads in a compute shader (False: the GL
      rasterizer draws two triangles per cell, as it does for other viewports);
    - ``fast_embedded``: nearest quads of 8-bit images first take the pass without keys,
      redone with keys only where the mesh is not shown to be an embedding;
    - ``band_bytes``: the largest mesh buffer of one band; bigger meshes are evaluated
      band by band (and the GL rasterizer's index buffer stays within it too);
    - ``fixup_min``, ``fixup_fraction``: capacity of the fused quads' fix-up list (pixels
      where triangles overlap): one pixel in ``fixup_fraction``, at least ``fixup_min``;
      beyond it (heavy fold-overs) every pixel is redone instead: slower, same result.
    """

    compute_quads: bool = True
    fast_embedded: bool = True
    band_bytes: int = 1 << 26
    fixup_min: int = 4096
    fixup_fraction: int = 8

    def __post_init__(self) -> None:
        for name in ("band_bytes", "fixup_min", "fixup_fraction"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")

    def fixup_capacity(self, pixels: int) -> int:
        return max(self.fixup_min, pixels // self.fixup_fraction)
