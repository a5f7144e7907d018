"""Vertex normals of meshes: glmls.Mesh(normals=...) checked, read from PLY (``nx``, ``ny``,
``nz``; ``normal_x``...) and OBJ (``vn`` and ``f v//vn``, ``f v/vt/vn``: one per vertex, not
where a vertex has several (hard edges) or a corner none), carried by MLS.deform as its
original normals and written back (OBJ exactly, PLY as float32); what a format cannot hold is
named. The deformed normals are checked against the float64 reference
(glmls.core.mesh3.deform_mesh) fed the GPU's own f and J: unit normals within 1e-4."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.core import mesh3
from glmls.errors import InputFileError
from glmls.files.meshes import Mesh, read_mesh, read_mesh_and_unkept, unwritten, write_mesh

TRIANGLE = [[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]


def _sphere_normals(rng):
    """The bundled sphere and normals of its own: (V, 3) random directions of random lengths
    (not unit: they are kept as given), two of them zero."""
    sphere = glmls.data.sphere()
    normals = rng.normal(0, 1, sphere.vertices.shape) * rng.uniform(0.1, 5, (162, 1))
    normals[[3, 70]] = 0.0
    return sphere, normals


def _ply_text(vertices, faces, normals, *, names=("nx", "ny", "nz"), kind="double"):
    """An ASCII PLY of double x, y, z and normals of ``kind`` named ``names``, each value
    as its shortest repr."""
    header = ["ply", "format ascii 1.0", f"element vertex {len(vertices)}"]
    header += [f"property double {a}" for a in "xyz"]
    header += [f"property {kind} {n}" for n in names]
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    rows = [" ".join(map(repr, [*v, *n])) for v, n in zip(vertices, normals, strict=True)]
    rows += [" ".join(map(str, [3, *f])) for f in faces]
    return "\n".join([*header, "end_header", *rows]) + "\n"


@pytest.mark.parametrize(
    ("normals", "error", "message"),
    [
        ([[0, 0, 1]] * 2, ValueError, r"normals must be \(V, 3\).*V = 3 vertices.*\(2, 3\)"),
        ([[0, 1]] * 3, ValueError, r"normals must be \(V, 3\).*shape \(3, 2\)"),
        ([0, 0, 1], ValueError, r"normals must be \(V, 3\).*shape \(3,\)"),
        ([[0, 0, 1], [0, 1], [1, 0, 0]], ValueError, r"normals must be \(V, 3\) rows"),
        ([[0, 0, 1], [0, np.nan, 1], [1, 0, 0]], ValueError, r"normals must be finite; row 1"),
        ([[0, 0, 1], [0, 0, 1], [np.inf, 0, 0]], ValueError, r"normals must be finite; row 2"),
        ([["0", "0", "1"]] * 3, TypeError, "normals must be real numbers, got dtype <U1"),
        (np.ones((3, 3), complex), TypeError, "normals must be real numbers, got dtype complex"),
        (np.ones((3, 3), bool), TypeError, "normals must be real numbers, got dtype bool"),
        (np.ones((3, 3), object), TypeError, "normals must be real numbers, got dtype object"),
    ],
)
def test_mesh_normals_are_checked(normals, error, message):
    with pytest.raises(error, match=message):
        Mesh(TRIANGLE, [[0, 1, 2]], normals=normals)


def test_mesh_normals_are_kept_as_given_float64_read_only_copies():
    given = np.array([[0, 0, 3], [0, 0, 0], [1, 2, 2]], np.int32)
    mesh = Mesh(TRIANGLE, [[0, 1, 2]], normals=given)
    given[0] = 9  # the caller's array may change; the mesh's does not
    assert mesh.normals.dtype == np.float64 and not mesh.normals.flags.writeable
    assert mesh.normals.tolist() == [[0, 0, 3], [0, 0, 0], [1, 2, 2]]  # not made unit
    assert Mesh(TRIANGLE, [[0, 1, 2]]).normals is None
    assert "normals=array((3, 3), float64)" in repr(mesh)
    with pytest.raises(TypeError):
        Mesh(TRIANGLE, [[0, 1, 2]], [[0, 0, 1]] * 3)  # keyword-only


@pytest.mark.parametrize("names", [("nx", "ny", "nz"), ("normal_x", "normal_y", "normal_z")])
def test_ply_normals_are_read_exactly_and_round_trip_as_float32(tmp_path, rng, names):
    sphere, normals = _sphere_normals(rng)
    text = _ply_text(sphere.vertices.tolist(), sphere.faces.tolist(), normals.tolist(), names=names)
    (tmp_path / "in.ply").write_text(text)
    mesh, unkept = read_mesh_and_unkept(tmp_path / "in.ply")
    assert unkept == ()
    assert mesh.normals.dtype == np.float64
    assert_array_equal(mesh.normals, normals)  # double: exactly
    write_mesh(tmp_path / "out.ply", mesh)
    assert (
        b"property float nx\nproperty float ny\nproperty float nz\n"
        in (tmp_path / "out.ply").read_bytes()
    )
    back, unkept = read_mesh_and_unkept(tmp_path / "out.ply")
    assert unkept == ()
    assert_array_equal(back.normals, normals.astype(np.float32))  # float32, as PLY writes
    write_mesh(tmp_path / "again.ply", back)
    assert_array_equal(read_mesh(tmp_path / "again.ply").normals, back.normals)


def test_ply_normals_beside_colours_and_texture_and_of_some_axes_only(tmp_path, rng):
    sphere, normals = _sphere_normals(rng)
    colors = rng.integers(0, 256, (162, 4), np.uint8)
    uv = rng.uniform(0, 1, (162, 2))
    mesh = Mesh(sphere.vertices, sphere.faces, colors=colors, uv=uv, face_uv=sphere.faces)
    write_mesh(tmp_path / "all.ply", mesh, normals=normals)
    back = read_mesh(tmp_path / "all.ply")
    assert_array_equal(back.colors, colors)
    assert_array_equal(back.uv, uv.astype(np.float32))
    assert_array_equal(back.normals, normals.astype(np.float32))
    # nx and ny without nz: no normals, named
    text = _ply_text(TRIANGLE, [[0, 1, 2]], [[1, 0]] * 3, names=("nx", "ny"), kind="float")
    (tmp_path / "two.ply").write_text(text)
    mesh, unkept = read_mesh_and_unkept(tmp_path / "two.ply")
    assert mesh.normals is None and unkept == ("normals",)
    # a normal that is not finite: the vertex named
    (tmp_path / "nan.ply").write_text(
        _ply_text(TRIANGLE, [[0, 1, 2]], [[0, 0, 1], [0, 0, 1], [0, float("nan"), 1]])
    )
    with pytest.raises(InputFileError, match=r"nan.ply: .*vertex 2: normal nx, ny, nz"):
        read_mesh(tmp_path / "nan.ply")
    # normals beyond float32: refused before writing
    with pytest.raises(ValueError, match="normals beyond float32's range"):
        write_mesh(tmp_path / "big.ply", TRIANGLE, faces=[[0, 1, 2]], normals=[[0, 0, 1e39]] * 3)
    assert not (tmp_path / "big.ply").exists()


@pytest.mark.parametrize("texture", [False, True])
def test_obj_normals_round_trip_exactly(tmp_path, rng, texture):
    sphere, normals = _sphere_normals(rng)
    # a vertex of no face keeps its normal too
    vertices = np.vstack([sphere.vertices, [[9.0, 9.0, 9.0]]])
    normals = np.vstack([normals, [[0.1, 0.2, 0.3]]])
    uv = rng.uniform(0, 1, (7, 2)) if texture else None
    face_uv = rng.integers(0, 7, sphere.faces.shape) if texture else None
    mesh = Mesh(vertices, sphere.faces, uv=uv, face_uv=face_uv, normals=normals)
    write_mesh(tmp_path / "out.obj", mesh)
    text = (tmp_path / "out.obj").read_text()
    face = sphere.faces[0] + 1
    if texture:
        t = face_uv[0] + 1
        assert f"f {face[0]}/{t[0]}/{face[0]} {face[1]}/{t[1]}/{face[1]} " in text
    else:
        assert f"f {face[0]}//{face[0]} {face[1]}//{face[1]} {face[2]}//{face[2]}\n" in text
    back, unkept = read_mesh_and_unkept(tmp_path / "out.obj")
    assert unkept == ()
    assert_array_equal(back.normals, normals)
    assert_array_equal(back.faces, sphere.faces)
    if texture:
        assert_array_equal(back.uv, uv)
        assert_array_equal(back.face_uv, face_uv)
    write_mesh(tmp_path / "again.obj", back)
    assert (tmp_path / "again.obj").read_text() == text


def test_obj_point_cloud_normals_round_trip(tmp_path, rng):
    points, normals = rng.normal(0, 1, (20, 3)), rng.normal(0, 1, (20, 3))
    write_mesh(tmp_path / "cloud.obj", points, faces=[], normals=normals)
    back = read_mesh(tmp_path / "cloud.obj")
    assert back.faces.shape == (0, 3)
    assert_array_equal(back.normals, normals)
    # vn lines that are not one per point: not kept, named
    (tmp_path / "odd.obj").write_text("v 0 0 0\nv 1 0 0\nvn 0 0 1\n")
    mesh, unkept = read_mesh_and_unkept(tmp_path / "odd.obj")
    assert mesh.normals is None and unkept == ("normals",)


def test_obj_normals_of_equal_values_per_corner_are_one_per_vertex(tmp_path):
    """A vn per face corner (as some tools write them), negative indices too: where all the
    corners of a vertex have equal values, they are the vertex's."""
    (tmp_path / "m.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
        "vn 0 0 1\nvn 0.5 0 1\nvn 0 0.5 1\nf 1//1 2//2 3//3\n"
        "vn 0.5 0 1\nvn 0.25 0.25 1\nvn 0 0.5 1\nf 2//-3 4//-2 3//-1\n"
    )
    mesh, unkept = read_mesh_and_unkept(tmp_path / "m.obj")
    assert unkept == ()
    assert mesh.normals.tolist() == [[0, 0, 1], [0.5, 0, 1], [0, 0.5, 1], [0.25, 0.25, 1]]


@pytest.mark.parametrize(
    ("faces", "note"),
    [
        # a hard edge: vertices 2 and 3 have normal 1 in one face, 2 in the other
        ("f 1//1 2//1 3//1\nf 2//2 4//2 3//2\n", "normals (a vertex has several: hard edges)"),
        ("f 1//1 2//1 3//1\nf 2 4 3\n", "normals (not on every face)"),
        ("f 1//1 2//1 3//1\nf 2//1 4 3//1\n", "normals (not on every face)"),
        ("f 1 2 3\nf 2 4 3\n", "normals"),
    ],
)
def test_obj_normals_that_are_not_one_per_vertex_are_not_kept_and_named(tmp_path, faces, note):
    (tmp_path / "m.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.5\nvn 0 0 1\nvn 0 -1 1\n" + faces
    )
    mesh, unkept = read_mesh_and_unkept(tmp_path / "m.obj")
    assert mesh.normals is None and unkept == (note,)
    assert mesh.faces.tolist() == [[0, 1, 2], [1, 3, 2]]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("vn 0 0 1\nf 1//1 2//1 3//2\n", r"line 5: normal 2 of a face, with 1 in the file"),
        ("vn 0 0 1\nf 1//1 2//1 3//-2\n", r"line 5: normal -2 of a face, with 1 normals"),
        ("vn 0 nan 1\nf 1//1 2//1 3//1\n", r"line 4: normal '0 nan 1', not 3 finite numbers"),
        ("vn 0 1\nf 1//1 2//1 3//1\n", r"line 4: normal '0 1', not 3 finite numbers"),
        ("vn 0 x 1\nf 1//1 2//1 3//1\n", r"line 4: normal '0 x 1', not 3 finite numbers"),
    ],
)
def test_obj_faults_of_normals_say_the_line(tmp_path, text, message):
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + text)
    with pytest.raises(InputFileError, match=f"bad.obj: {message}"):
        read_mesh(tmp_path / "bad.obj")


def test_stl_holds_no_normals_and_says_so(tmp_path, rng):
    sphere, normals = _sphere_normals(rng)
    mesh = Mesh(sphere.vertices, sphere.faces, normals=normals)
    assert unwritten("m.stl", mesh) == ("normals",)
    assert unwritten("m.ply", mesh) == unwritten("m.obj", mesh) == ()
    write_mesh(tmp_path / "m.stl", mesh)
    back, unkept = read_mesh_and_unkept(tmp_path / "m.stl")
    assert back.normals is None and unkept == ()  # facet normals: the faces' own


def test_deform_carries_a_meshs_own_normals(gl, rng, tmp_path):
    """MLS.deform of a glmls.Mesh with normals starts from them (not from its faces'), as the
    float64 reference does fed the GPU's f and J; write_mesh writes the carried normals of
    a DeformedMesh only where its input had normals of its own."""
    sphere, normals = _sphere_normals(rng)
    mesh = Mesh(sphere.vertices, sphere.faces, normals=normals)
    src = sphere.vertices[::9]
    dst = src + rng.normal(0, 0.05, src.shape)
    with glmls.MLS(src, dst, transform="similarity") as m:
        out = m.deform(mesh)
        plain = m.deform(Mesh(sphere.vertices, sphere.faces))
    ref = mesh3.deform_mesh(mesh.vertices, mesh.faces, normals, out.vertices, out.jacobian)
    clear = np.abs(ref.det_j) > 1e-4 * np.prod(np.linalg.norm(out.jacobian, axis=2), axis=1)
    assert clear.all()
    assert np.abs(out.normals - ref.normals).max() < 1e-4
    assert (out.normals[[3, 70]] == 0).all()  # no normal: zeros
    faces_own = mesh3.deform_mesh(mesh.vertices, mesh.faces, None, out.vertices, out.jacobian)
    assert np.abs(out.normals - faces_own.normals).max() > 0.5  # not the faces' normals
    assert out.own_normals and not plain.own_normals
    # deformed again: a DeformedMesh's own normals are its input's, carried; not its faces'
    again = mesh3.as_mesh(out)[2]  # directions: rows scaled to a largest component of 1
    lengths = np.linalg.norm(again, axis=1, keepdims=True)
    assert np.abs(again / np.where(lengths > 0, lengths, 1) - out.normals).max() < 1e-6
    assert mesh3.as_mesh(plain)[2] is None
    assert np.abs(plain.normals - faces_own.normals).max() < 1e-4
    write_mesh(tmp_path / "out.obj", out)
    assert_array_equal(read_mesh(tmp_path / "out.obj").normals, out.normals)
    write_mesh(tmp_path / "plain.obj", plain)
    assert read_mesh(tmp_path / "plain.obj").normals is None
    write_mesh(tmp_path / "given.obj", plain, normals=plain.normals)  # asked for: written
    assert_array_equal(read_mesh(tmp_path / "given.obj").normals, plain.normals)
