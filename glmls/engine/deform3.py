"""A triangle mesh deformed by the 3D f on the GPU (``glmls/shaders/mls3/``): f, J, det J,
the deformed normals and the folds, read back in two pieces.

The passes, all on buffers that stay on the GPU until the end:

1. (a mesh with faces and without normals of its own) ``mls3/mesh_scales.comp.glsl`` per
   face: at each vertex, the scale of the sum of its faces' normals (their largest
   component, and how many they are);
2. ``mls3/points.comp.glsl`` (``MLS3_MESH``) per vertex: f and J by central differences, det J
   and the normal carried by cof(J) (or, for normals from the faces, the scale of step 1),
   into one record of 16 floats per vertex;
3. ``mls3/mesh_folds.comp.glsl`` per face, each face's vertices and records read once: the
   fold flags, one byte per face, and (normals from the faces) the area-weighted normals
   summed at the vertices in fixed point (exact integer sums, so the result does not depend
   on the order the GPU adds in);
4. (normals from the faces) ``mls3/mesh_normals.comp.glsl`` per vertex: the sums carried by
   cof(J), into the records.

The float64 reference of the same quantities is :func:`glmls.core.mesh3.deform_mesh`.
"""

from __future__ import annotations

import numpy as np

from ..core.mesh3 import DeformedMesh
from ..gl import bindings
from ..gl.dispatch import fill_buffer, run_1d
from .kernel3 import MLSKernel3
from .passes3 import run_points3

__all__ = [
    "MESH_FOLDS_PASS",
    "MESH_NORMALS_PASS",
    "MESH_SCALES_PASS",
    "RECORD",
    "deform_mesh3",
]

MESH_SCALES_PASS = "mls3/mesh_scales.comp.glsl"
MESH_FOLDS_PASS = "mls3/mesh_folds.comp.glsl"
MESH_NORMALS_PASS = "mls3/mesh_normals.comp.glsl"
#: Floats per vertex record (``MESH3_RECORD``): f - v, J row by row, the normal, det J.
RECORD = 16
#: Ints per vertex of the normal sums (``MESH3_SUMS``): the scale, then the sum.
SUMS = 8
#: Faces per invocation of the passes over faces (``MESH3_FACES``: 3 ivec4 of indices read,
#: a byte each of fold flags, one uint, written).
FACES_PER_INVOCATION = 4


def deform_mesh3(
    kernel: MLSKernel3,
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray | None,
    *,
    shape: tuple[int, int, int] | None = None,
    max_groups: int | None = None,
    colors: np.ndarray | None = None,
    uv: np.ndarray | None = None,
    face_uv: np.ndarray | None = None,
) -> DeformedMesh:
    """The :class:`~glmls.core.mesh3.DeformedMesh` of a mesh by ``kernel``'s f, on the GPU.

    ``vertices`` (V, 3) float64, ``faces`` (F, 3) integer indices in [0, V) and ``normals``
    (V, 3) or None (then the area-weighted normals of the faces) as
    :func:`glmls.core.mesh3.as_mesh` returns them. ``shape``: the volume whose diagonal is the
    default radius (None: the kernel's own); ``max_groups`` work groups per dispatch (the GL
    limit by default). J, det J and the normals are float32 on the GPU, returned as float64.
    ``colors``: the vertices' own (:func:`glmls.core.mesh3.mesh_colors`), ``uv`` and
    ``face_uv`` the mesh's texture coordinates (:func:`glmls.core.mesh3.mesh_uv`), carried as
    they are; ``own_normals`` where ``normals`` are given.
    """
    count, face_count = len(vertices), len(faces)
    if count == 0:
        kernel.check_alive()
        empty = np.zeros((0, 3))
        return DeformedMesh(
            vertices=empty,
            faces=faces,
            normals=empty.copy(),
            jacobian=np.zeros((0, 3, 3)),
            det_j=np.zeros(0),
            vertex_folds=np.zeros(0, bool),
            face_folds=np.zeros(face_count, bool),
            colors=colors,
            uv=uv,
            face_uv=face_uv,
            own_normals=normals is not None,
        )
    kernel.radius(shape)  # a radius weight without one is refused before any GPU work
    gl = kernel.gl
    groups = max_groups if max_groups is not None else gl.limits["max_work_groups_x"]
    scratch = kernel.scratch
    with gl.use():
        # a vec4 per vertex: one load where a face reads its corner
        padded = scratch.staging("vertices3", (count, 4), np.float32)
        kernel.scaling.to_gpu(vertices, out=padded[:, :3])
        padded[:, 3] = 0.0
        points = scratch.buffer("points3", padded.nbytes)
        points.write(padded)
        points.bind_to_storage_buffer(bindings.POINTS.index)
        whole = -(-face_count // FACES_PER_INVOCATION) * FACES_PER_INVOCATION
        if face_count:
            # room for whole 4s of faces: the passes read 4 at a time
            indices = scratch.buffer("faces3", whole * 12)
            indices.write(np.ascontiguousarray(faces, dtype=np.int32))
            indices.bind_to_storage_buffer(bindings.MESH_FACES.index)
        source = "none"
        if normals is not None:
            source = "given"
            given = scratch.buffer("normals3", count * 12)
            given.write(np.ascontiguousarray(normals, dtype=np.float32))
            given.bind_to_storage_buffer(bindings.MESH_NORMALS.index)
        elif face_count:
            source = "faces"
            _normal_scales(kernel, count, face_count, groups)
        records = scratch.buffer("records3", count * RECORD * 4)
        records.bind_to_storage_buffer(bindings.DEFORMED.index)
        run_points3(kernel, count, output="mesh", normals=source, shape=shape, max_groups=groups)
        gl.mgl.memory_barrier()
        folds = np.zeros(whole, np.uint8)
        if face_count:
            flags = scratch.buffer("folds3", folds.nbytes)
            flags.bind_to_storage_buffer(bindings.MESH_FOLDS.index)
            sums = {"MESH3_NORMAL_SUMS": source == "faces"}
            folds_program = gl.compute(MESH_FOLDS_PASS, sums)
            run_1d(
                folds_program, face_count, max_groups=groups, per_invocation=FACES_PER_INVOCATION
            )
            gl.mgl.memory_barrier()
            if source == "faces":
                run_1d(gl.compute(MESH_NORMALS_PASS), count, max_groups=groups)
                gl.mgl.memory_barrier()
            flags.read_into(folds, size=folds.nbytes)
        # (copied out below: the arrays returned are new, the records' host copy is not)
        out = scratch.staging("records3", (count, RECORD), np.float32)
        records.read_into(out, size=out.nbytes)
    det = out[:, 15]
    deformed = vertices + out[:, 0:3] * kernel.scaling.scale
    if kernel.offset.any():  # the targets' offset, in float64 (MLSKernel3.offset)
        deformed += kernel.offset
    return DeformedMesh(
        vertices=deformed,
        faces=faces,
        normals=out[:, 12:15].astype(np.float64),
        jacobian=out[:, 3:12].astype(np.float64).reshape(count, 3, 3),
        det_j=det.astype(np.float64),
        vertex_folds=det <= 0,
        face_folds=folds[:face_count].view(bool),
        colors=colors,
        uv=uv,
        face_uv=face_uv,
        own_normals=normals is not None,
    )


def _normal_scales(kernel: MLSKernel3, count: int, face_count: int, groups: int) -> None:
    """The normal sums of the vertices, zeros but for their scales
    (``mls3/mesh_scales.comp.glsl``), bound for the points pass and the faces pass; the
    vertices and faces are bound."""
    gl = kernel.gl
    sums = kernel.scratch.buffer("normal_sums3", count * SUMS * 4)
    fill_buffer(gl, sums, count * SUMS * 4)
    sums.bind_to_storage_buffer(bindings.MESH_NORMALS.index)
    program = gl.compute(MESH_SCALES_PASS)
    run_1d(program, face_count, max_groups=groups, per_invocation=FACES_PER_INVOCATION)
    gl.mgl.memory_barrier()
