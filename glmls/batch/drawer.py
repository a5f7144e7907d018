"""What every batched path owns on a context (:class:`BatchDrawer`: its GL objects and the
texture arrays of a chunk's sources, one per context and path) and how a chunk's meshes
reach the batch shaders (:func:`upload_meshes`: f of every image at one lattice, into the
mesh table that ``batch/mesh.glsl`` reads)."""

from __future__ import annotations

from typing import ClassVar, Self

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..gl import bindings
from ..gl.context import GLContext, get_context
from ..gl.resources import Resources
from ..gl.tables import TABLE_WIDTH, table_rows
from .fill import SourceArrays

__all__ = ["MESH_ALIGN", "BatchDrawer", "mesh_stride", "upload_meshes"]

#: Bytes between two images' meshes in the mesh buffer are a multiple of this (at least the
#: GL storage buffer offset alignment of any driver).
MESH_ALIGN = 256


def mesh_stride(lattice: MeshLattice) -> int:
    """Bytes from one image's mesh to the next in the mesh buffer."""
    return -(-lattice.count * 8 // MESH_ALIGN) * MESH_ALIGN


def upload_meshes(
    gl: GLContext, resources: Resources, lattices, lattice: MeshLattice
) -> moderngl.Buffer:
    """f of every image of ``lattices`` (a :class:`~glmls.engine.batched.BatchLattices` or
    :class:`~glmls.batch.gpu.KernelLattices`) at ``lattice``'s points, image k's from byte
    ``k * mesh_stride(lattice)`` of the mesh buffer (returned), copied into the mesh table
    that ``batch/mesh.glsl`` reads, with the images' scalings in a table of their own; both
    bound."""
    stride = mesh_stride(lattice)
    vertices = len(lattices) * stride // 8
    # whole rows of the table: its copy reads them
    mesh = resources.buffer("mesh", table_rows(vertices) * TABLE_WIDTH * 8)
    lattices.evaluate(gl, resources, lattice, mesh, stride)
    scaling = np.zeros((len(lattices), 4), np.float32)
    scaling[:, :2] = lattices.centers
    scaling[:, 2] = lattices.scales
    gl.mgl.memory_barrier()  # the lattice passes' stores before the copy
    resources.tables.copy("batch mesh", mesh, (0, vertices), 2, bindings.BATCH_MESH.index)
    resources.tables.write("batch scaling", scaling, bindings.BATCH_SCALING.index)
    return mesh


class BatchDrawer:
    """A batched path of a context (``quads``, ``splat``, ``paper-quads``): its GL objects
    and the texture arrays it uploads a chunk's sources into; one per context and class,
    :meth:`of`."""

    #: The name of its GL objects (:class:`~glmls.gl.resources.Resources`) in messages.
    label: ClassVar[str] = "a batch path"

    def __init__(self, gl: GLContext) -> None:
        self._gl = gl
        self._resources = Resources(gl, self.label)
        self._sources = SourceArrays(gl)

    @classmethod
    def of(cls, ctx: moderngl.Context | GLContext | None = None) -> Self:
        """The one of ``ctx`` (default: glmls's headless context), made on first use."""
        gl = get_context(ctx)
        return gl.shared(cls, lambda: cls(gl))

    @property
    def ctx(self) -> GLContext:
        """The context it renders with."""
        return self._gl

    @property
    def resources(self) -> Resources:
        """Its GL objects (the mesh buffer of the last chunk among them; passes of f at
        points take their buffers from them)."""
        return self._resources

    def release(self) -> None:
        """Free the GL objects."""
        self._sources.release()
        self._resources.release()
