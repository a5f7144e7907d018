"""A growable vertex buffer for geometry rebuilt every frame, drawn alpha-blended."""

from __future__ import annotations

import moderngl
import numpy as np

from ..gl.context import GLContext


class StreamingVertices:
    """Float32 vertex rows for ``program`` with ``layout`` (e.g. ``"2f 4f"``) and attribute
    names; the buffer grows (to twice the need, at least 64 KiB) and is reused between frames."""

    def __init__(
        self, gl: GLContext, program: moderngl.Program, layout: str, *attributes: str
    ) -> None:
        self._gl = gl
        self._program = program
        self._format = (layout, *attributes)
        self._buffer: moderngl.Buffer | None = None
        self._vao: moderngl.VertexArray | None = None

    def draw(self, vertices: np.ndarray, mode: int = moderngl.TRIANGLES) -> None:
        """Upload ``vertices`` and draw them blended over the current framebuffer."""
        if len(vertices) == 0:
            return
        mgl = self._gl.mgl
        raw = np.ascontiguousarray(vertices, np.float32).tobytes()
        if self._buffer is None or self._buffer.size < len(raw):
            self.release()
            self._buffer = mgl.buffer(reserve=max(2 * len(raw), 1 << 16))
            self._vao = mgl.vertex_array(self._program, [(self._buffer, *self._format)])
        self._buffer.write(raw)
        mgl.enable(moderngl.BLEND)
        mgl.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self._vao.render(mode, vertices=len(vertices))  # type: ignore[union-attr]

    def release(self) -> None:
        for obj in (self._vao, self._buffer):
            if obj is not None:
                obj.release()
        self._vao = self._buffer = None
