"""What the batched forward methods share (``splat``, :mod:`.forward`; ``paper-quads``,
:mod:`.paper`): the atlases of a chunk's output canvases (stacked top to bottom) that one
draw fills, the images, the label images and the numbers of the source pixels drawn, and
their read-back."""

from __future__ import annotations

import moderngl
import numpy as np

from ..gl.resources import Resources, keep_framebuffer
from ..imaging.frame import Frame
from ..imaging.readback import read_rgba8
from ..imaging.source import SourceImage

__all__ = ["ForwardTargets"]


class ForwardTargets:
    """The atlases one forward draw of a chunk of ``count`` images writes, each filled
    beforehand: the images' (in ``source``'s form, RGBA8 or RGBA32F, filled with
    ``background``), with ``labels`` (the chunk's label images and their background) the
    label images', and where ``drawn`` the numbers + 1 of the source pixels drawn (RGBA32F,
    0 where none is); :attr:`framebuffer` has them as its attachments in that order."""

    def __init__(
        self,
        resources: Resources,
        count: int,
        frame: Frame,
        source: SourceImage,
        background: tuple[float, float, float, float],
        labels: tuple[list[SourceImage], tuple[float, float, float, float]] | None,
        *,
        drawn: bool,
    ) -> None:
        self.count, self.frame, self.source = count, frame, source
        self.size = atlas = (frame.size[0], frame.size[1] * count)
        self.label_sources = None if labels is None else labels[0]
        # the atlas in the first rows of a texture kept from a larger chunk; the others of
        # exactly its size (one framebuffer draws them all)
        roles = ["forward atlas"]
        self._images = resources.framebuffer(roles[0], atlas, _dtype(source), tall=True)
        rows = atlas[1]
        resources.fill(self._images.color_attachments[0], background, rows=rows)
        size = self._images.size
        self._labels = self._drawn = None
        if labels is not None:
            self._labels = resources.framebuffer("forward labels", size, _dtype(labels[0][0]))
            resources.fill(self._labels.color_attachments[0], labels[1], rows=rows)
            roles.append("forward labels")
        if drawn:
            self._drawn = resources.framebuffer("forward drawn", size, "f4")
            resources.fill(self._drawn.color_attachments[0], (0.0,) * 4, rows=rows)
            roles.append("forward drawn")
        self.framebuffer = self._images
        if len(roles) > 1:
            self.framebuffer = resources.attached("forward targets", tuple(roles))

    def read(
        self, mgl: moderngl.Context
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The atlases read back: (N, H, W, C) in the sources' dtype, the label images
        alike or None, and the (N, H, W, 2) float32 numbers + 1 of the image pixels drawn
        or None."""
        count, frame = self.count, self.frame
        out = _read(mgl, self._images, self.size, self.source, count, frame)
        warped = numbers = None
        if self._labels is not None and self.label_sources is not None:
            warped = _read(mgl, self._labels, self.size, self.label_sources[0], count, frame)
        if self._drawn is not None:
            values = _read_float(mgl, self._drawn, self.size)
            numbers = values.reshape(count, *frame.shape, 4)[..., :2]
        return out, warped, numbers


def _dtype(source: SourceImage) -> str:
    return "f1" if source.normalized else "f4"


def _read_float(mgl, framebuffer, atlas) -> np.ndarray:
    values = np.empty((atlas[1], atlas[0], 4), np.float32)
    with keep_framebuffer(mgl):
        framebuffer.use()
        framebuffer.read_into(values, (0, 0, *atlas), 4, dtype="f4")
    return values


def _read(mgl, framebuffer, atlas, source: SourceImage, count: int, frame: Frame):
    """The atlas read back as (N, H, W, C) in the sources' dtype."""
    if source.normalized:
        with keep_framebuffer(mgl):
            framebuffer.use()
            values = read_rgba8(framebuffer, atlas, source.channels)
    else:
        values = _read_float(mgl, framebuffer, atlas)[..., : source.channels]
    return source.restore(values.reshape(count, *frame.shape, -1))
