"""Texture coordinates of meshes: glmls.Mesh(uv=..., face_uv=...) checked, read from OBJ
(``vt`` and ``f v/vt``, ``f v/vt/vn``, negative indices, per face corner: seams where a vertex
has different ones in different faces) and PLY (``s``/``t``, ``u``/``v``,
``texture_u``/``texture_v``: one per vertex), carried by MLS.deform and written back (OBJ
exactly, PLY as float32 where each vertex has one); what a format cannot hold is named."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.errors import InputFileError
from glmls.files.meshes import Mesh, read_mesh, read_mesh_and_unkept, unwritten, write_mesh

TRIANGLE = [[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]


def _seamed_sphere(rng):
    """The sphere, its vertices in a random order, with texture coordinates per face corner:
    (u, v) of longitude and latitude, the faces east of the meridian x = 0 (about the centre) taking
    their corners' coordinates from entries of their own with u + 1, so that a vertex on the
    meridian has two different ones in its faces there; the entries in a random order, so
    that their indices are not the vertices'."""
    sphere = glmls.data.sphere()
    order = rng.permutation(len(sphere.vertices))
    vertices, faces = sphere.vertices[order], np.argsort(order)[sphere.faces]
    centred = vertices - vertices.mean(axis=0)
    x, y, z = (centred / np.linalg.norm(centred, axis=1, keepdims=True)).T
    base = np.stack([np.arctan2(x, z) / (2 * np.pi) + 0.5, np.arccos(y) / np.pi], axis=1)
    east = centred[faces].mean(axis=1)[:, 0] > 0
    corner_uv = base[faces]  # (F, 3, 2)
    corner_uv[east] += [1.0, 0.0]
    # one entry per (vertex, side): the west ones shared by all the vertex's west faces
    keys = faces + np.where(east, len(vertices), 0)[:, None]
    unique, inverse = np.unique(keys.ravel(), return_inverse=True)
    shuffle = rng.permutation(len(unique))
    face_uv = shuffle[inverse].reshape(-1, 3)
    uv = np.empty((len(unique), 2))
    uv[face_uv.ravel()] = corner_uv.reshape(-1, 2)
    return vertices, faces, uv, face_uv


def _obj(vertices, faces, uv, face_uv):
    """An OBJ text of the mesh, its faces in three spellings: ``f v/vt``, ``f v/vt/vn`` and
    negative (relative) ``vt`` indices, the vt lines after the v lines and before the
    faces."""
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
    lines += [f"vt {u!r} {v!r}" for u, v in uv.tolist()]
    lines += ["vn 0 0 1"]
    count = len(uv)
    for k, (f, t) in enumerate(zip(faces.tolist(), face_uv.tolist(), strict=True)):
        if k % 3 == 0:
            corners = [f"{a + 1}/{b + 1}" for a, b in zip(f, t, strict=True)]
        elif k % 3 == 1:
            corners = [f"{a + 1}/{b + 1}/1" for a, b in zip(f, t, strict=True)]
        else:
            corners = [f"{a + 1}/{b - count}" for a, b in zip(f, t, strict=True)]
        lines.append("f " + " ".join(corners))
    return "\n".join(lines) + "\n"


def _handles(vertices):
    src = vertices[::16]
    return src, src * 1.2 + [0.3, -0.2, 0.1]


def test_obj_texture_seams_survive_read_deform_write_read(tmp_path, rng):
    vertices, faces, uv, face_uv = _seamed_sphere(rng)
    # a seam: a vertex with two different coordinates in two of its faces
    per_corner = uv[face_uv].reshape(-1, 2)
    first = np.zeros((len(vertices), 2))
    first[faces.ravel()] = per_corner
    assert (first[faces.ravel()] != per_corner).any(axis=1).sum() > 10
    (tmp_path / "in.obj").write_text(_obj(vertices, faces, uv, face_uv))
    mesh, unkept = read_mesh_and_unkept(tmp_path / "in.obj")
    assert unkept == ("normals (not on every face)",)
    assert mesh.uv.dtype == np.float64 and mesh.face_uv.dtype == np.int64
    assert_array_equal(mesh.uv, uv)
    assert_array_equal(mesh.face_uv, face_uv)
    assert_array_equal(mesh.faces, faces)
    with glmls.MLS(*_handles(vertices)) as m:
        deformed = m.deform(mesh)
    assert_array_equal(deformed.uv, uv)
    assert_array_equal(deformed.face_uv, face_uv)
    assert np.abs(deformed.vertices - vertices).max() > 0.1  # they moved
    write_mesh(tmp_path / "out.obj", deformed)
    assert unwritten(tmp_path / "out.obj", mesh) == ()
    back, unkept = read_mesh_and_unkept(tmp_path / "out.obj")
    assert unkept == ()
    assert_array_equal(back.uv, uv)  # exactly: shortest reprs
    assert_array_equal(back.face_uv, face_uv)
    assert_array_equal(back.faces, faces)
    assert_array_equal(back.vertices, deformed.vertices)


def test_obj_with_seams_to_ply_and_stl_is_written_without_them_and_named(tmp_path, rng):
    vertices, faces, uv, face_uv = _seamed_sphere(rng)
    mesh = Mesh(vertices, faces, uv=uv, face_uv=face_uv)
    seams = "texture coordinates (a vertex has several, at seams: PLY holds one per vertex)"
    assert unwritten("o.ply", mesh) == (seams,)
    assert unwritten("o.stl", mesh) == ("texture coordinates",)
    write_mesh(tmp_path / "o.ply", mesh)
    back, unkept = read_mesh_and_unkept(tmp_path / "o.ply")
    assert back.uv is None and back.face_uv is None and unkept == ()
    assert_array_equal(back.faces, faces)


def test_obj_without_seams_goes_to_ply_as_one_coordinate_per_vertex(tmp_path, rng):
    """Indices into ``vt`` that are not the vertices' (in another order, one vertex's
    coordinate given twice), but one coordinate per vertex: PLY holds them, as float32."""
    vertices, faces = glmls.data.sphere().vertices, glmls.data.sphere().faces
    per_vertex = rng.uniform(-1, 2, (len(vertices), 2))
    order = rng.permutation(len(vertices))
    uv = np.concatenate([per_vertex[order], per_vertex[faces[0, :1]]])
    rank = np.argsort(order)
    face_uv = rank[faces]
    face_uv[0, 0] = len(uv) - 1  # the same value under another index
    mesh = Mesh(vertices, faces, uv=uv, face_uv=face_uv)
    assert unwritten("o.ply", mesh) == ()
    write_mesh(tmp_path / "o.ply", mesh)
    back, unkept = read_mesh_and_unkept(tmp_path / "o.ply")
    assert unkept == ()
    assert_array_equal(back.face_uv, faces)
    assert_array_equal(back.uv, per_vertex.astype(np.float32))


@pytest.mark.parametrize(
    ("names", "kind", "form"),
    [
        (("s", "t"), "float", "ascii"),
        (("u", "v"), "double", "binary_little_endian"),
        (("texture_u", "texture_v"), "float", "binary_big_endian"),
    ],
)
def test_ply_texture_coordinates_survive_read_deform_write_read(tmp_path, rng, names, kind, form):
    sphere = glmls.data.sphere()
    vertices, faces = sphere.vertices, sphere.faces
    uv = rng.uniform(0, 1, (len(vertices), 2)).astype(np.float32).astype(np.float64)
    code = {"float": "f4", "double": "f8"}[kind]
    order = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}[form]
    header = ["ply", f"format {form} 1.0", f"element vertex {len(vertices)}"]
    header += [f"property float {a}" for a in "xyz"] + [f"property {kind} {n}" for n in names]
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    head = ("\n".join([*header, "end_header"]) + "\n").encode("ascii")
    if form == "ascii":
        body = [
            " ".join(map(repr, [*v, *t]))
            for v, t in zip(vertices.tolist(), uv.tolist(), strict=True)
        ]
        body += [" ".join(map(str, [3, *f])) for f in faces.tolist()]
        data = head + ("\n".join(body) + "\n").encode("ascii")
    else:
        rows = np.empty(
            len(vertices), [(a, order + "f4") for a in "xyz"] + [("uv", order + code, 2)]
        )
        for axis, a in enumerate("xyz"):
            rows[a] = vertices[:, axis]
        rows["uv"] = uv
        tri = np.empty(len(faces), [("n", "u1"), ("i", order + "i4", (3,))])
        tri["n"], tri["i"] = 3, faces
        data = head + rows.tobytes() + tri.tobytes()
    (tmp_path / "in.ply").write_bytes(data)
    mesh, unkept = read_mesh_and_unkept(tmp_path / "in.ply")
    assert unkept == ()
    assert_array_equal(mesh.uv, uv)
    assert_array_equal(mesh.face_uv, faces)
    with glmls.MLS(*_handles(vertices)) as m:
        deformed = m.deform(mesh)
    assert np.abs(deformed.vertices - vertices).max() > 0.1
    for out in ("out.ply", "out.obj"):
        write_mesh(tmp_path / out, deformed)
        back, unkept = read_mesh_and_unkept(tmp_path / out)
        assert unkept == ()
        assert_array_equal(back.uv[back.face_uv], uv[faces])
    header = (tmp_path / "out.ply").read_bytes().split(b"end_header")[0].decode()
    assert "property float s\nproperty float t\n" in header


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("vt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3\n", "line 7: a face with texture coordinates on"),
        ("vt 0 0\nf 1//1 2/1 3/1\n", "line 5: a face with texture coordinates on some"),
        ("vt 0 0\nvt 1 0\nf 1/1 2/2 3/3\n", "line 6: texture coordinate 3 of a face, with 2"),
        ("vt 0 0\nf 1/-2 2/1 3/1\n", "line 5: texture coordinate -2 of a face, with 1 "),
        ("vt 0 0\nf 1/0 2/1 3/1\n", "line 5: texture coordinate 0 of a face"),
        ("vt 0 0\nf 1/a 2/1 3/1\n", "line 5: 'a' is no texture coordinate index"),
        ("vt 0 nan\nf 1/1 2/1 3/1\n", "line 4: texture coordinate '0 nan', not finite"),
        ("vt zero 0\nf 1/1 2/1 3/1\n", "line 4: texture coordinate 'zero 0', not finite"),
        ("vt\nf 1/1 2/1 3/1\n", "line 4: a texture coordinate of no numbers"),
        ("f 1/1 2/1 3/1\n", "line 4: texture coordinate 1 of a face, with 0 in the file"),
    ],
)
def test_obj_faulty_texture_coordinates_are_refused_naming_the_line(tmp_path, text, message):
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + text)
    with pytest.raises(InputFileError, match=f"bad.obj: {message}"):
        read_mesh(tmp_path / "bad.obj")


@pytest.mark.parametrize(
    ("text", "uv", "unkept"),
    [
        # some faces with, some without: none kept, and named
        (
            "vt 0 0\nf 1/1 2/1 3/1\nf 1 3 2\n",
            None,
            ("texture coordinates (not on every face)",),
        ),
        # vt lines no face names: not kept, named
        ("vt 0 0\nf 1 2 3\n", None, ("texture coordinates",)),
        ("vt 0 0\n", None, ("texture coordinates",)),  # a point cloud
        # a missing v is 0; a w of 0 is nothing; a w of another value is named
        ("vt 0.25\nf 1/1 2/1 3/1\n", [[0.25, 0.0]], ()),
        ("vt 0.25 0.5 0\nf 1/1 2/1 3/1\n", [[0.25, 0.5]], ()),
        ("vt 0.25 0.5 0.75\nf 1/1 2/1 3/1\n", [[0.25, 0.5]], ("3D texture coordinates (w)",)),
        # a face names a vt line after it
        ("f 1/2 2/2 3/1\nvt 0 0\nvt 1 1\n", [[0, 0], [1, 1]], ()),
    ],
)
def test_obj_texture_coordinates_kept_or_named(tmp_path, text, uv, unkept):
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + text)
    mesh, found = read_mesh_and_unkept(tmp_path / "m.obj")
    assert found == unkept
    assert (mesh.uv is None) == (uv is None) and (mesh.face_uv is None) == (uv is None)
    if uv is not None:
        assert mesh.uv.tolist() == uv


def test_obj_quads_with_texture_coordinates_are_fans_of_their_corners(tmp_path):
    (tmp_path / "q.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/4 2/3 3/2 4/1\n"
    )
    mesh = read_mesh(tmp_path / "q.obj")
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert mesh.face_uv.tolist() == [[3, 2, 1], [3, 1, 0]]


def test_mesh_uv_kept_as_read_only_copies():
    given, indices = np.array([[0.5, 0.25], [1, 0], [0, 1]]), np.array([[2, 1, 0]], np.int32)
    mesh = Mesh(TRIANGLE, [[0, 1, 2]], uv=given, face_uv=indices)
    assert mesh.uv.dtype == np.float64 and mesh.face_uv.dtype == np.int64
    assert not mesh.uv.flags.writeable and not mesh.face_uv.flags.writeable
    given[0, 0], indices[0, 0] = 9, 0
    assert mesh.uv[0, 0] == 0.5 and mesh.face_uv[0, 0] == 2
    plain = Mesh(TRIANGLE, [[0, 1, 2]])
    assert plain.uv is None and plain.face_uv is None
    cloud = Mesh(TRIANGLE, [], uv=np.zeros((0, 2)), face_uv=[])
    assert cloud.uv.shape == (0, 2) and cloud.face_uv.shape == (0, 3)


@pytest.mark.parametrize(
    ("uv", "face_uv", "error", "message"),
    [
        ([[0, 0]], None, ValueError, "uv is given without face_uv"),
        (None, [[0, 0, 0]], ValueError, "face_uv is given without uv"),
        ([[0, 0, 0]], [[0, 0, 0]], ValueError, r"uv must be \(T, 2\) rows \(u, v\), got shape"),
        ([0, 0], [[0, 0, 0]], ValueError, r"got shape \(2,\)"),
        ([[0, 0], [np.inf, 0]], [[0, 0, 1]], ValueError, r"finite; row 1 is \[inf, 0.0\]"),
        ([[0, 0], [0, np.nan]], [[0, 0, 1]], ValueError, r"finite; row 1 is \[0.0, nan\]"),
        ([[True, False]], [[0, 0, 0]], TypeError, "uv must be real numbers, got dtype bool"),
        ([[1j, 0]], [[0, 0, 0]], TypeError, "dtype complex128"),
        ([["a", "b"]], [[0, 0, 0]], TypeError, "dtype <U1"),
        (
            [[0, 0]],
            [[0, 0, 1]],
            ValueError,
            r"face_uv must index uv 0\.\.0; face 0 is \[0, 0, 1\]$",
        ),
        (
            [[0, 0]],
            [[0, -1, 0]],
            ValueError,
            r"face_uv must index uv 0\.\.0; face 0 is \[0, -1, 0\]$",
        ),
        (
            np.zeros((0, 2)),
            [[0, 0, 0]],
            ValueError,
            r"face_uv must index uv, which is empty; face 0 is \[0, 0, 0\]$",
        ),
        ([[0, 0]], [[0, 0]], ValueError, r"F = 1 faces, got shape \(1, 2\)"),
        ([[0, 0]], [[0, 0, 0]] * 2, ValueError, r"F = 1 faces, got shape \(2, 3\)"),
        ([[0, 0]], [[0, 0.5, 0]], TypeError, "face_uv must be integer indices into uv"),
        ([[0, 0]], [[0, np.nan, 0]], TypeError, "got dtype float64"),
        (
            [[0, 0]],
            np.array([[0, 2**63, 0]], np.uint64),
            ValueError,
            r"face 0 is \[0, 9223372036854775808, 0\]",
        ),
    ],
)
def test_mesh_uv_are_checked(tmp_path, uv, face_uv, error, message):
    with pytest.raises(error, match=message):
        Mesh(TRIANGLE, [[0, 1, 2]], uv=uv, face_uv=face_uv)
    with pytest.raises(error, match=message):
        write_mesh(tmp_path / "never.obj", TRIANGLE, faces=[[0, 1, 2]], uv=uv, face_uv=face_uv)
    assert not (tmp_path / "never.obj").exists()


def test_whole_float_texture_indices_are_taken():
    mesh = Mesh(TRIANGLE, [[0, 1, 2]], uv=[[0, 0], [1, 1]], face_uv=[[1.0, 0.0, 1.0]])
    assert mesh.face_uv.tolist() == [[1, 0, 1]] and mesh.face_uv.dtype == np.int64


def test_stl_holds_no_texture_coordinates(tmp_path):
    mesh = Mesh(TRIANGLE, [[0, 1, 2]], uv=[[0, 0]], face_uv=[[0, 0, 0]], colors=[[1, 2, 3]] * 3)
    assert unwritten("m.stl", mesh) == ("vertex colours", "texture coordinates")
    write_mesh(tmp_path / "m.stl", mesh)
    back, unkept = read_mesh_and_unkept(tmp_path / "m.stl")
    assert back.uv is None and unkept == ()
    with pytest.raises(ValueError, match=r"unknown mesh format \.off"):
        unwritten("m.off", mesh)


def test_trimesh_texture_coordinates_go_with_their_vertices(rng):
    import trimesh

    sphere = glmls.data.sphere()
    uv = rng.uniform(0, 1, (len(sphere.vertices), 2))
    textured = trimesh.Trimesh(
        sphere.vertices, sphere.faces, visual=trimesh.visual.TextureVisuals(uv=uv), process=False
    )
    with glmls.MLS(*_handles(sphere.vertices)) as m:
        out = m.deform(textured)
        plain = m.deform(trimesh.Trimesh(sphere.vertices, sphere.faces, process=False))
    assert_array_equal(out.uv, uv)
    assert_array_equal(out.face_uv, sphere.faces)
    assert plain.uv is None and plain.face_uv is None
    assert_array_equal(out.vertices, plain.vertices)
