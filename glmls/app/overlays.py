"""What the window draws over the deformed image, in image pixel coordinates.

Geometry (handles, mesh wireframe, fold-overs, reference triangles) is built on the CPU as
triangle or line vertices and drawn by :class:`GeometryDrawer` into the image viewport;
pictures the pipeline rendered offscreen at the image's size (splat and backward results, the
error field) are scaled onto the viewport by :class:`PictureDrawer`. Sizes on screen (disk
radii, line widths) are given in framebuffer pixels and divided by the layout's scale.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..analysis.canvas import HANDLE_SOURCE_COLOR, HANDLE_TARGET_COLOR
from ..analysis.colormaps import apply_colormap, picture_limits
from ..analysis.shapes import arrow_triangles, disk_triangles, segment_triangles
from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import set_uniforms
from ..imaging.adaptive import AdaptiveMesh
from ..imaging.frame import Frame
from .vertices import StreamingVertices

__all__ = [
    "GeometryDrawer",
    "PictureDrawer",
    "adaptive_lines",
    "fold_geometry",
    "handle_geometry",
    "mesh_lines",
    "read_screen",
    "reference_geometry",
    "segment_geometry",
    "triangle_geometry",
]

FOLD_COLOR = (1.0, 0.1, 0.6, 0.55)
MESH_COLOR = (0.3, 1.0, 0.4, 0.7)
REFERENCE_COLOR = (0.0, 1.0, 1.0, 1.0)
#: A segment being drawn (it becomes a handle when the button is released).
DRAWING_COLOR = (1.0, 1.0, 1.0, 0.9)
OUTLINE_COLOR = (0.0, 0.0, 0.0, 0.8)
#: Mesh lines closer than this on screen (framebuffer pixels) are thinned out.
MESH_MIN_SPACING = 6.0


def _rgba(color, alpha: float = 1.0) -> np.ndarray:
    rgb = np.asarray(color, np.float32)[:3]
    if rgb.max() > 1.0:
        rgb = rgb / 255.0
    return np.array([*rgb, alpha], np.float32)


def _colored(positions: np.ndarray, rgba) -> np.ndarray:
    rgba = np.asarray(rgba, np.float32)
    if rgba.ndim == 1:
        rgba = np.tile(rgba, (len(positions), 1))
    return np.concatenate([positions.astype(np.float32), rgba], axis=1)


def handle_geometry(src: np.ndarray, dst: np.ndarray, scale: float) -> np.ndarray:
    """Triangles of the handles: an arrow p -> q, a small disk at p, a disk at q (Fig. 6 left's
    colours). Rows: x, y, r, g, b, a."""
    unit = 1.0 / scale  # image pixels per framebuffer pixel
    parts = [
        _colored(arrow_triangles(src, dst, 2.0 * unit, 9.0 * unit), _rgba(HANDLE_TARGET_COLOR)),
        _colored(disk_triangles(src, 3.5 * unit), _rgba(HANDLE_SOURCE_COLOR)),
        _colored(disk_triangles(dst, 6.0 * unit), (0.0, 0.0, 0.0, 0.8)),
        _colored(disk_triangles(dst, 4.5 * unit), _rgba(HANDLE_TARGET_COLOR)),
    ]
    return np.concatenate(parts)


def segment_geometry(
    src_segments: np.ndarray,
    dst_segments: np.ndarray,
    scale: float,
    drawing: np.ndarray | None = None,
) -> np.ndarray:
    """Triangles of the segment handles: each source segment a thin blue line with disks at
    its ends, thin arrows from its ends to the target's (a -> c, b -> d), the target segment
    a thick yellow line outlined in black with disks at its ends, the start c larger than the
    end d; and the segment being drawn (``drawing``, (2, 2)), white. Rows: x, y, r, g, b, a."""
    unit = 1.0 / scale  # image pixels per framebuffer pixel
    a, b = src_segments[:, 0], src_segments[:, 1]
    c, d = dst_segments[:, 0], dst_segments[:, 1]
    source, target = _rgba(HANDLE_SOURCE_COLOR), _rgba(HANDLE_TARGET_COLOR)
    starts, ends = np.concatenate([a, b]), np.concatenate([c, d])
    parts = [
        _colored(segment_triangles(a, b, 2.0 * unit), source),
        _colored(disk_triangles(starts, 3.0 * unit), source),
        _colored(arrow_triangles(starts, ends, 1.2 * unit, 7.0 * unit), _rgba(target, 0.8)),
        _colored(segment_triangles(c, d, 6.0 * unit), OUTLINE_COLOR),
        _colored(disk_triangles(c, 6.5 * unit), OUTLINE_COLOR),
        _colored(disk_triangles(d, 5.0 * unit), OUTLINE_COLOR),
        _colored(segment_triangles(c, d, 3.5 * unit), target),
        _colored(disk_triangles(c, 5.0 * unit), target),
        _colored(disk_triangles(d, 3.5 * unit), target),
    ]
    if drawing is not None:
        start, end = drawing[:1], drawing[1:]
        parts += [
            _colored(segment_triangles(start, end, 6.0 * unit), OUTLINE_COLOR),
            _colored(segment_triangles(start, end, 3.5 * unit), DRAWING_COLOR),
            _colored(disk_triangles(drawing, 3.5 * unit), DRAWING_COLOR),
        ]
    return np.concatenate([np.zeros((0, 6), np.float32), *parts])


def reference_geometry(points: np.ndarray, scale: float) -> np.ndarray:
    """Triangles of disks at the (deformed) reference points."""
    unit = 1.0 / scale
    return np.concatenate(
        [
            _colored(disk_triangles(points, 4.0 * unit), (0.0, 0.0, 0.0, 0.8)),
            _colored(disk_triangles(points, 2.5 * unit), REFERENCE_COLOR),
        ]
    )


def mesh_lines(deformed: np.ndarray, stride: int = 1) -> np.ndarray:
    """Line-segment vertices (pairs) along every ``stride``-th row and column of a deformed
    mesh (rows, columns, 2), the last row and column included."""
    rows, cols = deformed.shape[:2]
    keep_r = sorted(set(range(0, rows, stride)) | {rows - 1})
    keep_c = sorted(set(range(0, cols, stride)) | {cols - 1})
    horizontal = deformed[keep_r]  # (r, cols, 2)
    vertical = deformed[:, keep_c].transpose(1, 0, 2)  # (c, rows, 2)
    segments = [
        np.stack([line[:-1], line[1:]], axis=1).reshape(-1, 2)
        for line in (*horizontal, *vertical)
        if len(line) > 1
    ]
    return _colored(np.concatenate([np.zeros((0, 2)), *segments]), MESH_COLOR)


def adaptive_lines(mesh: AdaptiveMesh) -> np.ndarray:
    """Line-segment vertices (pairs) along the deformed outlines of the adaptive mesh's
    leaves: each fan triangle's edge on its leaf's boundary."""
    ends = mesh.triangles[:, 1:].astype(np.int64)  # (T, 2): the edge opposite the centre
    return _colored(mesh.deformed[ends].reshape(-1, 2), MESH_COLOR)


def fold_geometry(deformed: np.ndarray, folded: np.ndarray) -> np.ndarray:
    """Triangles of the folded cells' deformed quads."""
    i, j = np.nonzero(folded)
    a, b = deformed[i, j], deformed[i, j + 1]
    c, d = deformed[i + 1, j + 1], deformed[i + 1, j]
    tris = np.stack([a, b, c, a, c, d], axis=1).reshape(-1, 2)
    return _colored(tris, FOLD_COLOR)


def triangle_geometry(
    deformed_points: np.ndarray, simplices: np.ndarray, values: np.ndarray, *, percentile=99.0
) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """(filled triangles, edge segments, colour limits) of the deformed reference triangles,
    each filled with its value's colour on the paper's white-to-red map (grey for NaN), the
    angle errors in degrees from 0."""
    finite = values[np.isfinite(values)]
    limits = picture_limits("angle", finite, percentile=percentile)
    colors = apply_colormap(values, cmap="linear", vmin=limits[0], vmax=limits[1]) / 255.0
    rgba = np.concatenate([colors, np.full((len(colors), 1), 0.6)], axis=1)
    corners = deformed_points[simplices].reshape(-1, 2)
    fill = _colored(corners, np.repeat(rgba, 3, axis=0))
    tri = deformed_points[simplices]
    edges = np.stack([tri, np.roll(tri, -1, axis=1)], axis=2).reshape(-1, 2)
    return fill, _colored(edges, (1.0, 1.0, 0.0, 0.9)), limits


class GeometryDrawer:
    """Draws x, y, r, g, b, a vertex rows (image pixels) into the current viewport, which
    shows the canvas :attr:`frame` (the image's own by default)."""

    def __init__(self, gl: GLContext, shape: tuple[int, int]) -> None:
        self._gl = gl
        self._program = gl.program("draw/geometry.vert.glsl", "draw/color.frag.glsl")
        self._vertices = StreamingVertices(gl, self._program, "2f 4f", "in_position", "in_color")
        self.frame = Frame(shape)

    def draw(self, vertices: np.ndarray, mode: int = moderngl.TRIANGLES) -> None:
        # image row 0 at the top of the window
        uniforms = {"u_size": self.frame.size, "u_origin": self.frame.origin, "u_flip_y": True}
        set_uniforms(self._program, uniforms)
        self._vertices.draw(vertices, mode)

    def release(self) -> None:
        self._vertices.release()


class PictureDrawer:
    """An offscreen RGBA picture of a canvas's size (:meth:`resize`), scaled onto the
    current viewport."""

    def __init__(self, gl: GLContext, shape: tuple[int, int]) -> None:
        self._gl = gl
        self._program = gl.program("common/fullscreen.vert.glsl", "draw/picture.frag.glsl")
        self._vao = gl.mgl.vertex_array(self._program, [])
        self._make(shape)

    def _make(self, shape: tuple[int, int]) -> None:
        height, width = shape
        self.texture = self._gl.mgl.texture((width, height), 4)
        self.texture.repeat_x = self.texture.repeat_y = False
        self.framebuffer = self._gl.mgl.framebuffer(color_attachments=[self.texture])

    def resize(self, shape: tuple[int, int]) -> None:
        """A picture of ``shape`` (H, W) from now on (its texture made again on change)."""
        if self.texture.size != (shape[1], shape[0]):
            self.framebuffer.release()
            self.texture.release()
            self._make(shape)

    def draw(self, *, opacity: float = 1.0, linear: bool = False) -> None:
        mgl = self._gl.mgl
        mode = moderngl.LINEAR if linear else moderngl.NEAREST
        self.texture.filter = (mode, mode)
        self.texture.use(bindings.PICTURE.index)
        set_uniforms(self._program, {"u_opacity": float(opacity)})
        mgl.enable(moderngl.BLEND)
        mgl.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self._vao.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self._vao.release()
        self.framebuffer.release()
        self.texture.release()


def read_screen(gl: GLContext, framebuffer: tuple[int, int]) -> np.ndarray:
    """The window's back buffer just drawn, (H, W, 3) uint8, top row first.

    Copied into a texture and read from there: moderngl's ``screen.read`` selects colour
    attachment 0 as the read buffer, which the default framebuffer does not have
    (``GL_INVALID_OPERATION`` left on the context); read there only for a window larger than
    the largest texture."""
    width, height = framebuffer
    mgl = gl.mgl
    with gl.use():
        if max(width, height) > mgl.info["GL_MAX_TEXTURE_SIZE"]:  # no texture that large
            data = mgl.screen.read(viewport=(0, 0, width, height), components=3, alignment=1)
            return np.frombuffer(data, np.uint8).reshape(height, width, 3)[::-1].copy()
        texture = mgl.texture((width, height), 3)
        try:
            mgl.copy_framebuffer(texture, mgl.screen)
            data = texture.read(alignment=1)
        finally:
            texture.release()
    return np.frombuffer(data, np.uint8).reshape(height, width, 3)[::-1].copy()
