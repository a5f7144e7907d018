"""Mesh files: PLY, OBJ and STL round trips, the vertex order kept, bad files named."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.errors import InputFileError
from glmls.files.meshes import Mesh, read_mesh, write_mesh


def _triangles(mesh: Mesh) -> np.ndarray:
    """The triangles' corners, each triangle's rotated to start at its smallest, sorted:
    the same for meshes that differ only in the order of their vertices."""
    corners = mesh.vertices[mesh.faces].round(4)
    keyed = []
    for triangle in corners:
        start = min(range(3), key=lambda k: tuple(triangle[k]))
        keyed.append(np.roll(triangle, -start, axis=0).ravel())
    return np.array(sorted(map(tuple, keyed)))


@pytest.mark.parametrize("suffix", [".ply", ".obj"])
def test_ply_and_obj_keep_the_vertex_order(tmp_path, suffix):
    mesh = glmls.data.sphere()
    write_mesh(tmp_path / f"m{suffix}", mesh)
    back = read_mesh(tmp_path / f"m{suffix}")
    assert_array_equal(back.faces, mesh.faces)
    assert back.vertices.dtype == np.float64
    exact = suffix == ".obj"  # PLY holds float32
    assert_allclose(back.vertices, mesh.vertices, rtol=0, atol=0 if exact else 1e-5)


def test_stl_merges_the_corners(tmp_path):
    mesh = glmls.data.sphere()
    write_mesh(tmp_path / "m.stl", mesh)
    back = read_mesh(tmp_path / "m.stl")
    assert back.vertices.shape == mesh.vertices.shape and back.faces.shape == mesh.faces.shape
    assert_allclose(_triangles(back), _triangles(mesh), atol=1e-4)


def test_write_takes_vertices_and_faces_or_any_object_with_them(tmp_path):
    class Deformed:  # like MLS.deform's result: vertices and more, no faces
        vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])

    faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    write_mesh(tmp_path / "t.obj", Deformed(), faces=faces)
    assert read_mesh(tmp_path / "t.obj").faces.tolist() == faces
    with pytest.raises(ValueError, match="no faces"):
        write_mesh(tmp_path / "u.obj", Deformed())
    with pytest.raises(ValueError, match=r"unknown mesh format \.vtk"):
        write_mesh(tmp_path / "t.vtk", glmls.data.sphere())


def test_quads_are_split_into_triangles(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    mesh = read_mesh(path)
    assert mesh.vertices.shape == (4, 3) and mesh.faces.shape == (2, 3)


def test_mesh_is_checked():
    with pytest.raises(ValueError, match=r"vertices must be \(V, 3\)"):
        Mesh(np.zeros((3, 2)), [[0, 1, 2]])
    with pytest.raises(
        ValueError, match=r"faces must index vertices 0\.\.2; face 0 is \[0, 1, 3\]$"
    ):
        Mesh(np.zeros((3, 3)), [[0, 1, 3]])
    with pytest.raises(TypeError, match="integer vertex indices"):
        Mesh(np.zeros((3, 3)), [[0, 1, 1.5]])
    mesh = Mesh(np.zeros((3, 3)), [[0, 1, 2]])
    assert not mesh.vertices.flags.writeable and mesh.faces.dtype == np.int64


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("m.ply", b"ply\nformat nonsense\n", "m.ply: not a readable .ply mesh"),
        ("m.obj", b"# nothing here\n", "m.obj: no mesh vertices"),
        ("m.stl", b"\x00" * 10, "m.stl: "),
        ("m.off", b"OFF\n", "m.off: unknown mesh format .off"),
    ],
)
def test_bad_files_are_named(tmp_path, name, content, message):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(InputFileError) as info:
        read_mesh(path)
    assert str(info.value).startswith(str(path)) and message in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(InputFileError, match=r"nope\.ply: no such file"):
        read_mesh(tmp_path / "nope.ply")


@pytest.mark.parametrize("suffix", [".ply", ".obj"])
def test_point_clouds_round_trip_through_ply_and_obj(tmp_path, suffix):
    """A point cloud (a mesh of no faces, as MLS.deform returns for (K, 3) points) is written
    and read back, its points in their order."""
    points = np.random.default_rng(0).uniform(-50, 50, (40, 3))
    write_mesh(tmp_path / f"c{suffix}", points, faces=np.zeros((0, 3), int))
    write_mesh(tmp_path / f"d{suffix}", Mesh(points, np.zeros((0, 3), int)))
    for name in ("c", "d"):
        back = read_mesh(tmp_path / f"{name}{suffix}")
        assert back.faces.shape == (0, 3)
        assert_allclose(back.vertices, points, rtol=0, atol=0 if suffix == ".obj" else 1e-4)


def test_stl_refuses_a_point_cloud_before_writing(tmp_path):
    """STL holds triangles only: a point cloud would be written as an empty file."""
    with pytest.raises(ValueError, match=r"\.ply or \.obj"):
        write_mesh(tmp_path / "c.stl", np.ones((4, 3)), faces=np.zeros((0, 3), int))
    assert not (tmp_path / "c.stl").exists()


def test_obj_keeps_small_and_large_coordinates_exactly(tmp_path):
    """OBJ is text: every float64 comes back as it was, metres (0.00525...) as well as
    voxels."""
    mesh = glmls.data.sphere()
    for vertices in ((mesh.vertices - 32) / 2000 + 1e-6, mesh.vertices * 1e5 + 1 / 3):
        write_mesh(tmp_path / "m.obj", vertices, faces=mesh.faces)
        back = read_mesh(tmp_path / "m.obj")
        assert_array_equal(back.vertices, vertices)
        assert_array_equal(back.faces, mesh.faces)


_FIVE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\n"


@pytest.mark.parametrize(
    "parts",
    [
        "usemtl red\nf 1 2 3\nusemtl blue\nf 1 3 4\nf 2 5 3\n",
        "mtllib m.mtl\nusemtl red\nf 1 2 3\nusemtl blue\nf 1 3 4\nusemtl red\nf 2 5 3\n",
        "o A\nf 1 2 3\no B\nf 1 3 4\nf 2 5 3\n",
        "g A\nusemtl red\nf 1 2 3\ng B\nusemtl blue\nf 1 3 4\nf 2 5 3\n",
    ],
)
def test_obj_of_several_materials_or_groups_keeps_the_files_order(tmp_path, parts):
    """The OBJ's vertices in its order, none duplicated, and its faces in their order,
    whatever materials, objects and groups divide them."""
    path = tmp_path / "parts.obj"
    (tmp_path / "m.mtl").write_text("newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n")
    path.write_text(_FIVE + parts)
    mesh = read_mesh(path)
    assert mesh.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3], [1, 4, 2]]


def test_obj_texture_coordinates_and_normals_do_not_split_vertices(tmp_path):
    path = tmp_path / "uv.obj"
    path.write_text(
        _FIVE + "vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 1 0 0\n"
        "f 1/1/1 2/2/1 3/3/1\nf 1/2/2 3/1/2 4/3/2\nf 2//1 5//2 3//1\n"
    )
    mesh = read_mesh(path)
    assert mesh.vertices.shape == (5, 3)
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3], [1, 4, 2]]


def test_obj_negative_indices_polygons_and_extra_vertex_values(tmp_path):
    """A negative index counts back from the last vertex before the face; a polygon is a fan
    of triangles from its first vertex; a vertex's colour (or w) is not its position."""
    path = tmp_path / "n.obj"
    path.write_text(
        "# a pentagon\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0\nv 0.5 2 0\nv -1 1 0 1.0\n"
        "f -5 -4 -3 -2 -1\n"
    )
    mesh = read_mesh(path)
    assert mesh.vertices[:, 2].tolist() == [0] * 5 and mesh.vertices[1].tolist() == [1, 0, 0]
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            "faces must index vertices 0..2; face 0 is [0, 1, 3]",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "line 4: vertex 0 of a face"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n", "line 4: vertex -4 of a face"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n", "line 4: 'x' is no vertex index"),
        ("v 0 0 0\nv 1 0 0\nf 1 2\n", "line 3: a face of fewer than 3 vertices"),
        ("v 0 0\n", "line 1: a vertex of fewer than 3 numbers"),
        ("v 0 0 nan\n", "line 1: vertex '0 0 nan', not finite"),
        ("v 0 0 zero\n", "line 1: vertex coordinate 'zero', not a number"),
    ],
)
def test_bad_obj_lines_are_named(tmp_path, content, message):
    path = tmp_path / "bad.obj"
    path.write_text(content)
    with pytest.raises(InputFileError) as info:
        read_mesh(path)
    assert str(info.value).startswith(f"{path}: ") and message in str(info.value)


def _ply(faces: list[list[int]], *, binary: bool = False) -> bytes:
    """A PLY of the five vertices of a unit square and its apex, and ``faces``."""
    vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]]
    kind = "binary_little_endian" if binary else "ascii"
    header = (
        f"ply\nformat {kind} 1.0\nelement vertex {len(vertices)}\nproperty float x\n"
        "property float y\nproperty float z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode()
    if not binary:
        rows = [" ".join(map(str, v)) for v in vertices]
        rows += [" ".join(map(str, [len(f), *f])) for f in faces]
        return header + ("\n".join(rows) + "\n").encode()
    body = np.array(vertices, "<f4").tobytes()
    for face in faces:
        body += np.uint8(len(face)).tobytes() + np.array(face, "<i4").tobytes()
    return header + body


@pytest.mark.parametrize("binary", [False, True])
def test_ply_polygons_are_fans_in_the_files_order(tmp_path, binary):
    """A PLY of triangles, quads and larger polygons keeps its faces' order, each polygon a
    fan from its first vertex in its place, as an OBJ's polygons are."""
    path = tmp_path / "mixed.ply"
    path.write_bytes(_ply([[0, 1, 2, 3], [0, 1, 4], [3, 2, 1, 0], [4, 1, 2]], binary=binary))
    expected = [[0, 1, 2], [0, 2, 3], [0, 1, 4], [3, 2, 1], [3, 1, 0], [4, 1, 2]]
    assert read_mesh(path).faces.tolist() == expected
    path.write_bytes(_ply([[0, 1, 2, 3], [1, 2, 3, 4]], binary=binary))  # quads alone
    assert read_mesh(path).faces.tolist() == [[0, 1, 2], [0, 2, 3], [1, 2, 3], [1, 3, 4]]
    path.write_bytes(_ply([[0, 1, 2, 3, 4]], binary=binary))
    assert read_mesh(path).faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]


@pytest.mark.parametrize("binary", [False, True])
def test_ply_faces_of_fewer_than_three_vertices_are_named(tmp_path, binary):
    """A face of two vertices (an edge) is no triangle: the file is refused, not read as a
    point cloud with its faces dropped."""
    path = tmp_path / "edges.ply"
    path.write_bytes(_ply([[0, 1, 2], [0, 1]], binary=binary))
    with pytest.raises(InputFileError, match=r"edges\.ply: .*face 1: a face of 2 vertices"):
        read_mesh(path)


def test_ply_face_list_of_another_name_is_read(tmp_path):
    """The face element's only list is its vertex indices, whatever its name."""
    path = tmp_path / "named.ply"
    path.write_bytes(_ply([[0, 1, 2], [0, 2, 3, 4]]).replace(b"vertex_indices", b"vertex_ids"))
    assert read_mesh(path).faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]


@pytest.mark.parametrize("binary", [False, True])
def test_a_truncated_ply_is_named(tmp_path, binary):
    path = tmp_path / "cut.ply"
    path.write_bytes(_ply([[0, 1, 2], [0, 2, 3, 4]], binary=binary)[:-3])
    with pytest.raises(
        InputFileError, match=r"cut\.ply: not a readable \.ply mesh: element 'face'"
    ):
        read_mesh(path)


def test_an_ascii_ply_of_more_rows_than_its_header_counts_is_refused(tmp_path):
    """A count too small would read part of the file as the whole mesh."""
    path = tmp_path / "more.ply"
    path.write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
        b"property float z\nend_header\n0 0 0\n1 0 0\n5 5 5\n"
    )
    with pytest.raises(InputFileError, match=r"more\.ply: .*3 values after the rows .*2 vertex"):
        read_mesh(path)
    path.write_bytes(path.read_bytes().replace(b"vertex 2", b"vertex 3") + b"\n \n")
    assert read_mesh(path).vertices.tolist()[2] == [5.0, 5.0, 5.0]


def test_a_binary_ply_of_more_rows_than_its_header_counts_is_refused(tmp_path):
    """As in ASCII: bytes past the counted rows are rows the header left out, not padding."""
    path = tmp_path / "more.ply"
    whole = _ply([[0, 1, 2], [0, 2, 3, 4]], binary=True)
    path.write_bytes(whole + bytes(13))
    with pytest.raises(InputFileError, match=r"more\.ply: .*13 bytes after the rows .*face"):
        read_mesh(path)
    path.write_bytes(whole + b"\n")  # a trailing newline, as some writers leave, is read
    assert read_mesh(path).faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]


def test_obj_with_a_utf8_byte_order_mark_keeps_its_first_vertex(tmp_path):
    """Windows editors start a UTF-8 file with a byte order mark: the first line is still a
    vertex, and every index still names the vertex it names without one."""
    path = tmp_path / "bom.obj"
    path.write_bytes("\ufeffv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 2 3 4\n".encode())
    mesh = read_mesh(path)
    assert mesh.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    assert mesh.faces.tolist() == [[0, 1, 2], [1, 2, 3]]


def test_stl_of_a_nan_corner_is_named_without_a_numpy_warning(tmp_path):
    """A corner that is not a number is the file's fault, said in one line: no warning of
    trimesh's merging of the corners first (an error under ``-W error``)."""
    path = tmp_path / "nan.stl"
    path.write_text(
        "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nan\nvertex 1 0 0\n"
        "vertex 0 1 0\nendloop\nendfacet\nendsolid s\n"
    )
    with pytest.raises(InputFileError, match=r"nan\.stl: .*line 4: vertex '0 0 nan', not finite"):
        read_mesh(path)


_TRIANGLE_PLY = (
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement {element} 1\n{properties}end_header\n0 0 0\n1 0 0\n0 1 0\n{row}\n"
)


@pytest.mark.parametrize(
    ("element", "properties", "row", "message"),
    [
        (
            "face",
            "property list uchar int vertex_ids\nproperty list uchar float texcoord\n",
            "3 0 1 2 6 0 0 1 0 0 1",
            r"element 'face': no list vertex_indices or vertex_index .*\(vertex_ids, texcoord\)",
        ),
        ("face", "property int flags\n", "5", r"element 'face': no list .*\(flags\)"),
        (
            "tristrips",
            "property list int int vertex_indices\n",
            "3 0 1 2",
            r"element 'tristrips': faces glmls does not read",
        ),
    ],
)
def test_a_ply_whose_faces_are_not_found_is_refused(tmp_path, element, properties, row, message):
    """Faces in the file that glmls cannot tell apart are refused, not dropped: the file is
    not read as a point cloud."""
    path = tmp_path / "lost.ply"
    path.write_text(_TRIANGLE_PLY.format(element=element, properties=properties, row=row))
    with pytest.raises(InputFileError, match=r"lost\.ply: not a readable \.ply mesh: " + message):
        read_mesh(path)


@pytest.mark.parametrize("binary", [False, True])
def test_a_ply_comment_naming_end_header_is_no_end_of_the_header(tmp_path, binary):
    path = tmp_path / "comment.ply"
    content = _ply([[0, 1, 2], [0, 2, 3, 4]], binary=binary)
    path.write_bytes(content.replace(b"1.0\n", b"1.0\ncomment written up to end_header\n", 1))
    assert read_mesh(path).faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("big.obj", _FIVE + "f 1 2 99999999999999999999999\n", "line 6: vertex 99999999999999"),
        (
            "big.ply",
            _TRIANGLE_PLY.format(
                element="face",
                properties=("property list uchar float vertex_indices\n"),
                row="3 0 1 1e20",
            ),
            "index 1e+20",
        ),
        (
            "inf.ply",
            _TRIANGLE_PLY.format(
                element="face",
                properties=("property list uchar float vertex_indices\n"),
                row="4 0 1 2 inf",
            ),
            "vertex index inf, beyond any vertex",
        ),
    ],
)
def test_face_indices_beyond_int64_are_named(tmp_path, name, content, message):
    """An index no int64 holds is the file's fault, named, not cast to another index (with a
    warning) or left to an OverflowError."""
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(InputFileError) as info:
        read_mesh(path)
    assert str(info.value).startswith(f"{path}: ") and message in str(info.value)


def test_obj_comments_after_data_and_old_fo_faces_are_read(tmp_path):
    path = tmp_path / "c.obj"
    path.write_text(
        "v 0 0 0 # origin\nv 1 0 0\nv 0 1 0#x\nv 0 0 1\nf 1 2 3 # base\nfo 1 3 4\n# f 2 3 4\n"
    )
    mesh = read_mesh(path)
    assert mesh.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3]]


@pytest.mark.parametrize("radius", [1e-8, 1.0, 1e11])
def test_stl_merges_the_corners_at_any_scale_in_the_order_they_come(tmp_path, radius):
    """Corners of the same coordinates are one vertex, and no others: a sphere of 10 nm in
    metres keeps its 162 vertices. The vertices come in the order of their first corner."""
    mesh = glmls.data.sphere()
    vertices = (mesh.vertices - 32) / 20 * radius
    write_mesh(tmp_path / "m.stl", vertices, faces=mesh.faces)
    back = read_mesh(tmp_path / "m.stl")
    first = list(dict.fromkeys(mesh.faces.ravel().tolist()))  # the vertices as corners name them
    assert_array_equal(back.vertices, vertices[first].astype(np.float32))
    assert_array_equal(np.array(first)[back.faces], mesh.faces)


def test_an_obj_vertex_weight_is_named_where_it_is_not_1(tmp_path):
    """``v x y z w``: a rational curve's weight, 1 by default, which a mesh does not keep."""
    from glmls.files.meshes import read_mesh_and_unkept

    (tmp_path / "w.obj").write_text("v 0 0 0 2\nv 1 0 0 2\nv 0 1 0 2\nf 1 2 3\n")
    (tmp_path / "one.obj").write_text("v 0 0 0 1\nv 1 0 0 1.0\nv 0 1 0\nf 1 2 3\n")
    mesh, unkept = read_mesh_and_unkept(tmp_path / "w.obj")
    assert_array_equal(mesh.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert unkept == ("vertex weights (w)",)
    assert read_mesh_and_unkept(tmp_path / "one.obj")[1] == ()


def test_a_ply_property_declared_twice_is_refused(tmp_path):
    """Which column would be x? Refused, naming the element and the property."""
    (tmp_path / "dup.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n"
        "0 9 0 0\n1 9 0 0\n0 9 1 0\n3 0 1 2\n"
    )
    with pytest.raises(InputFileError, match="element 'vertex' declares property 'x' twice"):
        read_mesh(tmp_path / "dup.ply")
