"""The slab textures that the volume construction's last pass writes, and their read-back.

Each slab of output voxels is written into a 3D texture of its size (image stores of the
source's format), then copied by the GPU into a pixel-pack buffer and read once into the
output array. The textures of the last few slab sizes are kept between slabs and calls:
boxes of columns and rows take up to four sizes (the last column's and row's narrower).
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..gl.context import GLContext
from ..gl.resources import Resources
from .bands import Slab
from .pieces import slab_region
from .source import SourceVolume

__all__ = ["SlabTargets"]

#: Slab textures kept between slabs (boxes of columns and rows take up to four sizes).
TARGETS_KEPT = 4


class SlabTargets:
    """The slab textures of ``gl``, read back through ``resources``' pack buffer."""

    def __init__(self, gl: GLContext, resources: Resources) -> None:
        self._gl = gl
        self._resources = resources
        self._kept: dict[tuple, moderngl.Texture3D] = {}

    def texture(self, slab: Slab, source: SourceVolume) -> moderngl.Texture3D:
        """The texture for ``slab`` of an output of ``source``'s format."""
        key = (slab.size, source.target_components, source.texture_dtype)
        if key in self._kept:
            return self._kept[key]
        if len(self._kept) >= TARGETS_KEPT:
            self._kept.pop(next(iter(self._kept))).release()
        texture = self._gl.mgl.texture3d(slab.size, key[1], dtype=key[2])
        self._kept[key] = texture
        return texture

    def read(
        self, texture: moderngl.Texture3D, slab: Slab, source: SourceVolume, out: np.ndarray
    ) -> None:
        """``slab``'s voxels of ``texture`` into ``out`` through a pixel-pack buffer: the GPU
        copies the texture into it, the host reads it once, straight into ``out`` where the
        layouts agree (a plain texture read went through the driver's staging at ~1.3 GB/s on
        an H200 machine)."""
        nbytes = slab.voxels * source.voxel_bytes
        pack = self._resources.buffer("volume_readback", nbytes)
        texture.read_into(pack, alignment=1)
        region = out[slab_region(slab)]
        whole_slices = slab.width == out.shape[2] and slab.height == out.shape[1]
        same = source.target_components == source.channels and out.dtype == source.data.dtype
        if same and whole_slices:
            pack.read_into(region, size=nbytes)
            return
        raw = np.frombuffer(pack.read(size=nbytes), dtype=source.data.dtype)
        values = raw.reshape(slab.depth, slab.height, slab.width, source.target_components)
        region[...] = values[..., : source.channels]

    def release(self) -> None:
        """Free the kept textures (where the context is still usable). Idempotent."""
        if self._kept and self._gl.usable:
            with self._gl.use():
                for texture in self._kept.values():
                    texture.release()
        self._kept.clear()
