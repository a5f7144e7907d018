"""A triangle mesh deformed by the 3D f on the GPU (``glmls/shaders/mls3/``): f, J, det J,
the deformed normals and the folds, read back in two pieces.

The passes, all on buffers and tables (:mod:`glmls.gl.tables`) that stay on the GPU until
the end:

1. (a mesh with faces and without normals of its own) ``mls3/mesh_scales.comp.glsl`` per
   face: at each vertex, the scale of the sum of its faces' normals (their largest
   component, and how many they are);
2. ``mls3/points.comp.glsl`` (``MLS3_MESH``) per vertex: f and J (``mls3_eval_jacobian``) and
   det J into one record of 16 floats per vertex, with the normal carried by cof(J) (a
   mesh without faces) or the vertex itself (a mesh with faces: the passes over faces read
   a corner's vertex and record as one record); copied into a table; and (an affine map
   onto coplanar targets, ``MLSKernel3.flat``) a flag per vertex where J is the derivative
   of affine's plain solve (or, by central differences, took it at each of its probes): f
   maps a neighbourhood (the probes) into the targets' plane, so J is singular exactly,
   and det J is 0 there, whatever float32's rounding left of it;
3. ``mls3/mesh_folds.comp.glsl`` per face, each face's records fetched once from their
   table: the fold flags, one byte per face, and (normals from the faces) the area-weighted
   normals summed at the vertices in fixed point (exact integer sums, so the result does
   not depend on the order the GPU adds in);
4. (a mesh with faces) ``mls3/mesh_normals.comp.glsl`` per vertex: the sums (or the
   mesh's own normals) carried by cof(J), into the records over the vertices.

The passes over faces read the vertices, faces and records at random: from tables, whose
texel fetches llvmpipe gathers for all lanes at once where it loads a storage buffer lane by
lane and component by component. A mesh is as large as its tables allow: 4 texels per vertex
in rows of :data:`~glmls.gl.tables.TABLE_WIDTH`, ``max_texture_size`` rows.

The float64 reference of the same quantities is :func:`glmls.core.mesh3.deform_mesh`.
"""

from __future__ import annotations

import numpy as np

from ..core.mesh3 import DeformedMesh, flat_to_zero
from ..gl import bindings
from ..gl.dispatch import fill_buffer, run_1d
from ..gl.tables import TABLE_WIDTH, table_rows
from .kernel3 import MLSKernel3
from .passes3 import jacobian_steps, jacobian_uniforms, largest_coordinates, run_points3

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
#: Floats per vertex record (``MESH3_RECORD``): the normal (first the vertex, in a mesh with
#: faces), f - v, J row by row, det J.
RECORD = 16
#: Ints per vertex of the normal sums (``MESH3_SUMS``): the scale, then the sum.
SUMS = 8
#: Faces per invocation of the passes over faces (``MESH3_FACES``: 3 uvec4 of indices read,
#: a byte each of fold flags, one uint, written).
FACES_PER_INVOCATION = 4
#: The tables (glmls.gl.tables) of the vertices, the faces and the records.
VERTICES_TABLE, FACES_TABLE, RECORDS_TABLE = "mesh3 vertices", "mesh3 faces", "mesh3 records"


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
    whole = -(-face_count // FACES_PER_INVOCATION) * FACES_PER_INVOCATION
    _check_tables(gl.limits["max_texture_size"], count, whole)
    groups = max_groups if max_groups is not None else gl.limits["max_work_groups_x"]
    scratch = kernel.scratch
    tables = scratch.tables
    with gl.use():
        # a vec4 per vertex: one fetch each
        padded = scratch.staging("vertices3", (count, 4), np.float32)
        kernel.scaling.to_gpu(vertices, out=padded[:, :3])
        padded[:, 3] = 0.0
        tables.write(VERTICES_TABLE, padded, bindings.MESH_VERTICES.index)
        if face_count:
            # whole 4s of faces: the passes read 4 at a time, as 3 uvec4
            indices = scratch.staging("faces3", (whole, 3), np.int32)
            indices[:face_count] = faces
            indices[face_count:] = 0
            words = indices.view(np.uint32).reshape(-1, 4)
            tables.write(FACES_TABLE, words, bindings.MESH_FACES.index)
        if normals is not None:
            given = scratch.buffer("normals3", count * 12)
            given.write(np.ascontiguousarray(normals, dtype=np.float32))
            given.bind_to_storage_buffer(bindings.MESH_NORMALS.index)
        elif face_count:
            _normal_scales(kernel, count, face_count, groups)
        # whole rows: the records' table is copied from this buffer
        items = RECORD // 4 * count
        records = scratch.buffer("records3", table_rows(items) * TABLE_WIDTH * 16)
        records.bind_to_storage_buffer(bindings.DEFORMED.index)
        source = "later" if face_count else "none" if normals is None else "given"
        if kernel.flat:
            flat_flags = scratch.buffer("flat3", count * 4)
            flat_flags.bind_to_storage_buffer(bindings.MESH_FLAT.index)
        run_points3(
            kernel,
            count,
            output="mesh",
            normals=source,
            shape=shape,
            max_groups=groups,
            flat=kernel.flat,
        )
        gl.mgl.memory_barrier()
        folds = np.zeros(whole, np.uint8)
        if face_count:
            tables.copy(RECORDS_TABLE, records, (0, items), 4, bindings.MESH_RECORDS.index)
            flags = scratch.buffer("folds3", folds.nbytes)
            flags.bind_to_storage_buffer(bindings.MESH_FOLDS.index)
            sums = {"MESH3_NORMAL_SUMS": normals is None}
            folds_program = gl.compute(MESH_FOLDS_PASS, sums)
            run_1d(
                folds_program, face_count, max_groups=groups, per_invocation=FACES_PER_INVOCATION
            )
            gl.mgl.memory_barrier()
            own = {"MESH3_GIVEN_NORMALS": normals is not None}
            run_1d(gl.compute(MESH_NORMALS_PASS, own), count, max_groups=groups)
            gl.mgl.memory_barrier()
            flags.read_into(folds, size=folds.nbytes)
        # (copied out below: the arrays returned are new, the records' host copy is not)
        out = scratch.staging("records3", (count, RECORD), np.float32)
        records.read_into(out, size=out.nbytes)
        if kernel.flat:
            plain = np.frombuffer(flat_flags.read(size=count * 4), np.uint32) != 0
    jacobian = out[:, 6:15].astype(np.float64).reshape(count, 3, 3)
    # the vertices as the upload scaled them (padded's first columns)
    det = _flat_to_zero(kernel, padded[:, :3], jacobian, out[:, 15].astype(np.float64))
    if kernel.flat:  # f maps the vertex's neighbourhood into the targets' plane: J is singular
        det[plain] = 0.0
    normals_out = out[:, 0:3].astype(np.float64)
    # J singular (f flattens space there): no normal, as the reference's, where float32's
    # n cof(J) is the flat image's normal or, with n along J's null direction, rounding's
    normals_out[det == 0] = 0.0
    deformed = vertices + out[:, 3:6] * kernel.scaling.scale
    if kernel.offset.any():  # the targets' offset, in float64 (MLSKernel3.offset)
        deformed += kernel.offset
    vertex_folds = det <= 0
    face_folds = folds[:face_count].view(bool)
    if face_count and vertex_folds.any():  # a face folds where one of its vertices does
        corners = vertex_folds[faces[:, 0]] | vertex_folds[faces[:, 1]]  # (flat ones too)
        face_folds = face_folds | corners | vertex_folds[faces[:, 2]]
    return DeformedMesh(
        vertices=deformed,
        faces=faces,
        normals=normals_out,
        jacobian=jacobian,
        det_j=det,
        vertex_folds=vertex_folds,
        face_folds=face_folds,
        colors=colors,
        uv=uv,
        face_uv=face_uv,
        own_normals=normals is not None,
    )


def _flat_to_zero(
    kernel: MLSKernel3, scaled: np.ndarray, jacobian: np.ndarray, det: np.ndarray
) -> np.ndarray:
    """``det`` (V,), in place, with 0 where J is singular to float32's rounding
    (:func:`~glmls.core.mesh3.flat_to_zero`): where f flattens the mesh (targets on a
    plane, say) the GPU's det J is that rounding, of either sign, and would fold a random
    half of the vertices. J's central differences over a step h carry about eps32 x scale
    x max(box, |v|) / h of rounding (``scaled`` (V, 3) the vertices as the GPU read them, v
    their largest coordinate; the box's half side: their float32 spacing; h of
    :func:`jacobian_steps`), the closed form's derivative less: the rule takes that bound
    at every vertex, whichever J it has."""
    scaling = kernel.scaling
    box = jacobian_uniforms(kernel)["u_jacobian_box"]
    largest = largest_coordinates(scaled)
    reach = np.maximum(box, largest)
    steps = jacobian_steps(kernel, scaled, largest=largest)
    rounding = np.finfo(np.float32).eps * scaling.scale * reach / steps
    return flat_to_zero(det, jacobian, rounding)


def _check_tables(limit: int, count: int, faces: int) -> None:
    """``ValueError`` where a mesh of ``count`` vertices and ``faces`` faces (a whole number
    of 4) does not fit tables of ``limit`` rows: its records, 4 texels per vertex (where it
    has faces), its faces, 3 texels per 4, and its vertices, one each."""
    room = TABLE_WIDTH * limit
    per_vertex = RECORD // 4 if faces else 1
    if per_vertex * count > room or faces // 4 * 3 > room:
        raise ValueError(
            f"a mesh of {count:,} vertices and {faces:,} faces does not fit this GL's tables "
            f"({limit} rows of {TABLE_WIDTH} texels: at most {room // per_vertex:,} vertices "
            f"and {room // 3 * 4:,} faces)"
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
