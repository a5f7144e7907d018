"""Vertex colours of meshes: glmls.Mesh(colors=...) checked, read from PLY (ASCII and binary;
uchar, float, double) and OBJ (``v x y z r g b``), carried by MLS.deform and written back
exactly, each with its vertex; STL holds none; what a file holds that a Mesh does not keep is
named."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.errors import InputFileError
from glmls.files.meshes import Mesh, read_mesh, read_mesh_and_unkept, write_mesh

TRIANGLE = [[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]
ORDERS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
CODES = {"uchar": "u1", "float": "f4", "double": "f8", "int": "i4"}


def _ply(path, vertex, faces, *, form="ascii", face_extra=(), elements=()):
    """A PLY file: ``vertex`` (name, PLY type, values) columns; ``faces`` (F, 3) triangles
    with ``face_extra`` columns of the same kind; ``elements`` (name, rows) of one uchar
    property each."""
    header = ["ply", f"format {form} 1.0", f"element vertex {len(vertex[0][2])}"]
    header += [f"property {kind} {name}" for name, kind, _ in vertex]
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    header += [f"property {kind} {name}" for name, kind, _ in face_extra]
    for name, rows in elements:
        header += [f"element {name} {rows}", "property uchar flag"]
    head = ("\n".join([*header, "end_header"]) + "\n").encode("ascii")
    order = ORDERS[form]
    if order is None:
        lines = [" ".join(repr(c[2][i]) for c in vertex) for i in range(len(vertex[0][2]))]
        lines += [
            " ".join(["3", *map(str, f)] + [repr(c[2][k]) for c in face_extra])
            for k, f in enumerate(np.asarray(faces).tolist())
        ]
        lines += ["0"] * sum(rows for _, rows in elements)
        path.write_bytes(head + ("\n".join(lines) + "\n").encode("ascii"))
        return
    rows = np.empty(len(vertex[0][2]), [(n, order + CODES[k]) for n, k, _ in vertex])
    for name, _, values in vertex:
        rows[name] = values
    fields = [("n", "u1"), ("i", order + "i4", (3,))]
    tri = np.empty(len(faces), fields + [(n, order + CODES[k]) for n, k, _ in face_extra])
    tri["n"], tri["i"] = 3, faces
    for name, _, values in face_extra:
        tri[name] = values
    tail = bytes(sum(rows for _, rows in elements))
    path.write_bytes(head + rows.tobytes() + tri.tobytes() + tail)


def _shuffled_sphere(rng):
    """The sphere with its vertices in a random order (faces renumbered): an order that only
    reading in the file's order keeps."""
    sphere = glmls.data.sphere()
    order = rng.permutation(len(sphere.vertices))
    rank = np.argsort(order)
    return sphere.vertices[order], rank[sphere.faces]


def _handles(vertices):
    src = vertices[::16]
    return src, src * 1.2 + [0.3, -0.2, 0.1]


@pytest.mark.parametrize("out", [".ply", ".obj"])
@pytest.mark.parametrize(
    ("form", "kind", "channels"),
    [
        ("ascii", "uchar", 3),
        ("binary_little_endian", "uchar", 4),
        ("binary_big_endian", "float", 3),
        ("ascii", "float", 4),
        ("binary_little_endian", "double", 3),
    ],
)
def test_ply_colours_survive_read_deform_write_read(tmp_path, rng, out, form, kind, channels):
    vertices, faces = _shuffled_sphere(rng)
    colors = rng.integers(0, 256, (len(vertices), channels), dtype=np.uint8)
    stored = colors if kind == "uchar" else colors / 255.0  # floats 0..1, as PLY tools write
    names = ("red", "green", "blue", "alpha")[:channels]
    columns = [(a, "float", vertices[:, i].tolist()) for i, a in enumerate("xyz")]
    columns += [(n, kind, stored[:, i].tolist()) for i, n in enumerate(names)]
    _ply(tmp_path / "in.ply", columns, faces, form=form)
    mesh = read_mesh(tmp_path / "in.ply")
    assert mesh.colors.dtype == np.uint8 and mesh.colors.shape == colors.shape
    assert_array_equal(mesh.colors, colors)
    with glmls.MLS(*_handles(vertices)) as m:
        deformed = m.deform(mesh)
    assert_array_equal(deformed.colors, colors)
    write_mesh(tmp_path / f"out{out}", deformed)
    back = read_mesh(tmp_path / f"out{out}")
    assert_array_equal(back.colors, colors)
    assert_array_equal(back.faces, faces)
    # each colour with its vertex: the vertices are the deformed ones, in the same order
    assert_allclose(back.vertices, deformed.vertices, rtol=1e-6, atol=1e-5)


def test_obj_colours_survive_read_deform_write_read(tmp_path, rng):
    vertices, faces = _shuffled_sphere(rng)
    colors = rng.integers(0, 256, (len(vertices), 3), dtype=np.uint8)
    lines = [
        f"v {x!r} {y!r} {z!r} " + " ".join(f"{c / 255:.4f}" for c in rgb)
        for (x, y, z), rgb in zip(vertices.tolist(), colors.tolist(), strict=True)
    ]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces.tolist()]
    (tmp_path / "in.obj").write_text("\n".join(lines) + "\n")
    mesh = read_mesh(tmp_path / "in.obj")
    assert_array_equal(mesh.colors, colors)
    with glmls.MLS(*_handles(vertices)) as m:
        deformed = m.deform(mesh)
    for out in (".obj", ".ply"):
        write_mesh(tmp_path / f"out{out}", deformed)
        back = read_mesh(tmp_path / f"out{out}")
        assert_array_equal(back.colors, colors)
        assert_allclose(back.vertices, deformed.vertices, rtol=1e-6, atol=1e-5)


@pytest.mark.parametrize("channels", [3, 4])
def test_obj_writes_every_byte_as_0_to_1_and_reads_it_back(tmp_path, rng, channels):
    colors = rng.permutation(np.repeat(np.arange(256, dtype=np.uint8), channels))
    colors = colors.reshape(256, channels)
    vertices = rng.normal(0, 1, (256, 3))
    write_mesh(tmp_path / "c.obj", vertices, faces=[], colors=colors)
    rows = [line.split() for line in (tmp_path / "c.obj").read_text().splitlines()]
    values = np.array([row[4:] for row in rows], dtype=np.float64)
    assert values.shape == (256, channels) and 0 <= values.min() and values.max() <= 1
    assert_array_equal(read_mesh(tmp_path / "c.obj").colors, colors)


@pytest.mark.parametrize(
    ("lines", "expected"),
    [
        (
            "v 0 0 0 1 0.25 0\nv 1 0 0 0 0 0\nv 0 1 0 0.6 1 1\n",
            [[255, 64, 0], [0] * 3, [153, 255, 255]],
        ),
        (
            "v 0 0 0 255 64 0\nv 1 0 0 0 0 0\nv 0 1 0 153 255 255\n",
            [[255, 64, 0], [0] * 3, [153, 255, 255]],
        ),
        (
            "v 0 0 0 1 0 0 0.5\nv 1 0 0 0 1 0 1\nv 0 1 0 0 0 1 0\n",
            [[255, 0, 0, 128], [0, 255, 0, 255], [0, 0, 255, 0]],
        ),
    ],
)
def test_obj_colours_floats_0_to_1_rounded_or_whole_bytes(tmp_path, lines, expected):
    (tmp_path / "c.obj").write_text(lines + "f 1 2 3\n")
    mesh, unkept = read_mesh_and_unkept(tmp_path / "c.obj")
    assert mesh.colors.tolist() == expected and unkept == ()


def test_obj_colours_on_some_vertices_only_are_named_not_kept(tmp_path):
    (tmp_path / "c.obj").write_text("v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 1 1\nf 1 2 3\n")
    mesh, unkept = read_mesh_and_unkept(tmp_path / "c.obj")
    assert mesh.colors is None and unkept == ("vertex colours (not on every vertex alike)",)
    (tmp_path / "w.obj").write_text("v 0 0 0 1\nv 1 0 0\nv 0 1 0 1\nf 1 2 3\n")  # weights
    assert read_mesh_and_unkept(tmp_path / "w.obj")[1] == ()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "v 0 0 0 0 0 0\nv 1 0 0 1.5 0 0\nv 0 1 0 0 0 0\n",
            "line 2: vertex colour 1.5, not in 0..1",
        ),
        ("v 0 0 0 0 0 0\nv 1 0 0 0 0 0\nv 0 1 0 0 -1 0\n", "line 3: vertex colour -1, not in 0..1"),
        ("v 0 0 0 0 0 256\nv 1 0 0 0 0 0\nv 0 1 0 0 0 0\n", "line 1: vertex colour 256"),
    ],
)
def test_obj_colours_out_of_range_are_named(tmp_path, text, message):
    (tmp_path / "c.obj").write_text(text)
    with pytest.raises(InputFileError, match=f"c.obj: {message}"):
        read_mesh(tmp_path / "c.obj")


@pytest.mark.parametrize(
    ("kind", "value", "message"),
    [
        ("uchar", 300, "red 300, not a colour in 0..255"),
        ("float", 1.25, "red 1.25, not a colour in 0..1"),
    ],
)
@pytest.mark.parametrize("form", ["ascii", "binary_little_endian"])
def test_ply_colours_out_of_range_are_named(tmp_path, form, kind, value, message):
    if form != "ascii" and kind == "uchar":
        kind = "int"  # a uchar cannot hold 300; another integer type can
    columns = [(a, "float", [0.0, 1.0, 0.0]) for a in "xyz"]
    columns += [
        (n, kind, [0, value, 0] if n == "red" else [0, 0, 0]) for n in ("red", "green", "blue")
    ]
    _ply(tmp_path / "c.ply", columns, [[0, 1, 2]], form=form)
    with pytest.raises(
        InputFileError, match=f"c.ply: not a readable .ply mesh: vertex 1: {message}"
    ):
        read_mesh(tmp_path / "c.ply")


def test_what_a_ply_holds_beyond_the_mesh_is_named(tmp_path):
    columns = [(a, "float", [0.0, 1.0, 0.0]) for a in "xyz"]
    columns += [(n, "float", [0.0, 0.0, 1.0]) for n in ("nx", "ny", "nz", "s", "t", "quality")]
    columns += [(n, "uchar", [1, 2, 3]) for n in ("red", "green")]  # no blue: no colours
    face_extra = [(n, "uchar", [9]) for n in ("red", "green", "blue")]
    for form in ("ascii", "binary_big_endian"):
        _ply(
            tmp_path / "m.ply",
            columns,
            [[0, 1, 2]],
            form=form,
            face_extra=face_extra,
            elements=[("edge", 2), ("material", 0)],
        )
        mesh, unkept = read_mesh_and_unkept(tmp_path / "m.ply")
        assert mesh.colors is None and mesh.faces.tolist() == [[0, 1, 2]]
        assert mesh.uv.tolist() == [[0, 0], [0, 0], [1, 1]]  # s, t: kept
        assert mesh.normals.tolist() == [[0, 0, 0], [0, 0, 0], [1, 1, 1]]  # nx, ny, nz: kept
        assert unkept == (
            "face colours",
            "vertex properties quality, red, green",
            "elements edge",
        )
    write_mesh(tmp_path / "plain.ply", mesh)
    assert read_mesh_and_unkept(tmp_path / "plain.ply")[1] == ()


def test_what_an_obj_holds_beyond_the_mesh_is_named(tmp_path):
    (tmp_path / "m.obj").write_text(
        "mtllib m.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\ns off\n"
        "usemtl red\nf 1/1/1 2/1/1 3/1/1\nl 1 2\n"
    )
    mesh, unkept = read_mesh_and_unkept(tmp_path / "m.obj")
    assert mesh.faces.tolist() == [[0, 1, 2]]
    assert mesh.uv.tolist() == [[0, 0]] and mesh.face_uv.tolist() == [[0, 0, 0]]  # kept
    assert mesh.normals.tolist() == [[0, 0, 1]] * 3  # kept: one per vertex
    assert unkept == (
        "materials",
        "object and group names",
        "lines",
    )


def test_stl_holds_no_vertex_colours_and_its_face_attributes_are_named(tmp_path, rng):
    sphere = glmls.data.sphere()
    colors = rng.integers(0, 256, (len(sphere.vertices), 3), dtype=np.uint8)
    write_mesh(tmp_path / "m.stl", Mesh(sphere.vertices, sphere.faces, colors=colors))
    mesh, unkept = read_mesh_and_unkept(tmp_path / "m.stl")
    assert mesh.colors is None and unkept == ()
    content = bytearray((tmp_path / "m.stl").read_bytes())
    content[84 + 48 : 84 + 50] = b"\x1f\x80"  # the first triangle's attribute bytes
    (tmp_path / "a.stl").write_bytes(bytes(content))
    assert read_mesh_and_unkept(tmp_path / "a.stl")[1] == ("face attributes (colours)",)


@pytest.mark.parametrize(
    ("given", "expected"),
    [
        (np.array([[0, 1, 2], [253, 254, 255], [7, 8, 9]], np.uint8), None),
        (np.array([[0, 1, 2, 3], [253, 254, 255, 0], [7, 8, 9, 10]], np.int64), None),
        (
            [[0.0, 0.25, 1.0], [0.6, 1 / 255, 254 / 255], [0.5, 0.0, 0.0]],
            [[0, 64, 255], [153, 1, 254], [128, 0, 0]],
        ),
    ],
)
def test_mesh_colors_are_kept_as_read_only_uint8(given, expected):
    mesh = Mesh(TRIANGLE, [[0, 1, 2]], colors=given)
    assert mesh.colors.dtype == np.uint8 and not mesh.colors.flags.writeable
    assert mesh.colors.tolist() == (np.asarray(given).tolist() if expected is None else expected)
    if isinstance(given, np.ndarray):
        given[0, 0] = 99  # a copy: the caller's array may change
        assert mesh.colors[0, 0] == 0
    assert Mesh(TRIANGLE, [[0, 1, 2]]).colors is None


@pytest.mark.parametrize(
    ("colors", "error", "message"),
    [
        ([[0, 0], [0, 0], [0, 0]], ValueError, r"got shape \(3, 2\)"),
        ([[0, 0, 0]] * 4, ValueError, r"V = 3 vertices, got shape \(4, 3\)"),
        ([0, 0, 0], ValueError, r"got shape \(3,\)"),
        (
            [[0, 0, 0], [0, 256, 0], [0, 0, 0]],
            ValueError,
            r"integers 0..255; row 1 is \[0, 256, 0\]",
        ),
        ([[0, 0, 0], [0, 0, 0], [-1, 0, 0]], ValueError, r"row 2 is \[-1, 0, 0\]"),
        (
            [[0.0, 0, 0], [0, 0, 0], [0, 1.5, 0]],
            ValueError,
            r"floats 0..1; row 2 is \[0.0, 1.5, 0.0\]",
        ),
        ([[np.nan, 0, 0], [0, 0, 0], [0, 0, 0]], ValueError, r"row 0 is \[nan, 0.0, 0.0\]"),
        ([[True, False, True]] * 3, TypeError, "dtype bool"),
        ([["red", "0", "0"]] * 3, TypeError, "dtype <U3"),
        ([[1j, 0, 0]] * 3, TypeError, "dtype complex128"),
    ],
)
def test_mesh_colors_are_checked(tmp_path, colors, error, message):
    with pytest.raises(error, match=message):
        Mesh(TRIANGLE, [[0, 1, 2]], colors=colors)
    with pytest.raises(error, match=message):
        write_mesh(tmp_path / "never.ply", TRIANGLE, faces=[[0, 1, 2]], colors=colors)
    assert not (tmp_path / "never.ply").exists()
