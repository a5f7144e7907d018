"""The numbers of text mesh files (OBJ, ASCII PLY, ASCII STL): decimal numbers of ASCII
digits (a sign, a point, an exponent), indices and PLY integers plain integers; what else
Python's float() or int() reads (``1_0`` as 10, other scripts' digits) is refused, naming the
file and the line (PLY: the element, row and property). Good files read exactly."""

from __future__ import annotations

import numpy as np
import pytest

from glmls import read_mesh
from glmls.errors import InputFileError

_OBJ = "v 0 0 0\nv {x} 0 0\nv 0 1 0\nf 1 2 {c}\n"


def _refused(path, content: str, message: str) -> None:
    path.write_bytes(content.encode("utf-8"))
    with pytest.raises(InputFileError) as info:
        read_mesh(path)
    assert str(info.value).startswith(f"{path}: ") and message in str(info.value)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (_OBJ.format(x="1_0", c=3), "line 2: vertex coordinate '1_0', not a number"),
        (_OBJ.format(x="\u0661", c=3), "line 2: vertex coordinate '\u0661', not a number"),
        (_OBJ.format(x="\uff11", c=3), "line 2: vertex coordinate '\uff11', not a number"),
        (_OBJ.format(x="0x10", c=3), "line 2: vertex coordinate '0x10', not a number"),
        (_OBJ.format(x="nan", c=3), "line 2: vertex 'nan 0 0', not finite"),
        (_OBJ.format(x="-inf", c=3), "line 2: vertex '-inf 0 0', not finite"),
        (_OBJ.format(x=1, c="1_0"), "line 4: '1_0' is no vertex index"),
        (_OBJ.format(x=1, c="\u0663"), "line 4: '\u0663' is no vertex index"),
        (
            "v 0 0 0 1_0 0 0\nv 1 0 0 0 0 0\nv 0 1 0 0 0 0\nf 1 2 3\n",
            "line 1: vertex colour '1_0', not a number",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1_0 0\nvt 0 1\nf 1/1 2/2 3/3\n",
            "line 5: texture coordinate '1_0 0', not finite numbers",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/\u0663\n",
            "line 7: '\u0663' is no texture coordinate index",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1_0 0 1\nf 1//1 2//1 3//1\n",
            "line 4: normal '1_0 0 1', not 3 finite numbers",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn \uff10 0 1\nf 1//1 2//1 3//1\n",
            "line 4: normal '\uff10 0 1', not 3 finite numbers",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1_0\n",
            "line 5: '1_0' is no normal index",
        ),
    ],
)
def test_obj_numbers_python_reads_but_the_format_does_not_are_named(tmp_path, content, message):
    _refused(tmp_path / "bad.obj", content, message)


def _ply(vertex: str, face: str, *, face_list: str = "uchar int", red: bool = False) -> str:
    colour = "property uchar red\nproperty uchar green\nproperty uchar blue\n" if red else ""
    paint = " 0 0 0" if red else ""
    return (
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        f"property float z\n{colour}element face 1\nproperty list {face_list} vertex_indices\n"
        f"end_header\n0 0 0{paint}\n{vertex}\n0 1 0{paint}\n{face}\n"
    )


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (_ply("1_0 0 0", "3 0 1 2"), "element 'vertex': row 1, property 'x': '1_0', not a number"),
        (_ply("\u0663 0 0", "3 0 1 2"), "row 1, property 'x': '\u0663', not a number"),
        (_ply("1 0 0", "3 0 1 2.0"), "row 0, list 'vertex_indices': '2.0', not an integer"),
        (_ply("1 0 0", "3 0 1 2e0"), "row 0, list 'vertex_indices': '2e0', not an integer"),
        (_ply("1 0 0", "3 0 1 1_0"), "row 0, list 'vertex_indices': '1_0', not an integer"),
        (_ply("1 0 0", "3 0 1 \u0662"), "row 0, list 'vertex_indices': '\u0662', not an integer"),
        (_ply("1 0 0", "3.0 0 1 2"), "row 0, the count of list 'vertex_indices': '3.0', not a"),
        (_ply("1 0 0", "-3 0 1 2"), "row 0, the count of list 'vertex_indices': '-3', not a"),
        (
            _ply("1 0 0 2_55 0 0", "3 0 1 2", red=True),
            "element 'vertex': row 1, property 'red': '2_55', not an integer",
        ),
    ],
)
def test_ply_numbers_python_reads_but_the_format_does_not_are_named(tmp_path, content, message):
    _refused(tmp_path / "bad.ply", content, message)


def test_ply_numbers_of_faces_of_other_lengths_are_named(tmp_path):
    """Rows of lists of different lengths are read one by one: a fault there is named too."""
    content = (
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n3 0 2 1_0\n"
    )
    _refused(tmp_path / "bad.ply", content, "element 'face': row 1, list 'vertex_indices': '1_0'")


_STL = (
    "solid s\nfacet normal 0 0 1\nouter loop\nvertex {a}\nvertex {b}\nvertex 0 1 0\n"
    "endloop\nendfacet\nendsolid s\n"
)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (_STL.format(a="1_0 0 0", b="1 0 0"), "line 4: vertex '1_0 0 0', not 3 numbers"),
        (_STL.format(a="\u0661 0 0", b="1 0 0"), "line 4: vertex '\u0661 0 0', not 3 numbers"),
        # two numbers on one line, four on the next: six, which would read as two corners
        (_STL.format(a="0 0", b="0 1 0 0"), "line 4: vertex '0 0', not 3 numbers"),
        (_STL.format(a="0 0 inf", b="1 0 0"), "line 4: vertex '0 0 inf', not finite"),
        (
            _STL.format(a="0 0 0", b="1 0 0").replace("normal 0 0 1", "normal 0 0 1_0"),
            "line 2: facet normal '0 0 1_0', not 3 numbers",
        ),
        # a facet of 2 or 4 corners: named, not a failure to reshape trimesh's corners
        (
            _STL.format(a="0 0 0", b="1 0 0").replace("vertex 0 1 0\n", ""),
            "line 3: a facet of 2 vertices, not a triangle",
        ),
        (
            _STL.format(a="0 0 0", b="1 0 0").replace("endloop", "vertex 1 1 0\nendloop"),
            "line 3: a facet of 4 vertices, not a triangle",
        ),
    ],
)
def test_ascii_stl_numbers_are_named(tmp_path, content, message):
    _refused(tmp_path / "bad.stl", content, message)


# signs, exponents of both cases, more digits than a float64 holds, -0, a point alone at
# either end
_WORDS = ["-0", "+1.5", "1e-3", "1E+02", "0.1000000000000000055511151231257827", ".5", "7.", "-2e0"]


def _expected(words: list[str]) -> np.ndarray:
    return np.array([float(word) for word in words]).reshape(-1, 3)


def test_good_obj_numbers_read_exactly(tmp_path):
    words = [*_WORDS, "0"]
    path = tmp_path / "good.obj"
    rows = ["\t".join(words[i : i + 3]) for i in range(0, 9, 3)]
    path.write_text("".join(f"v\t{row}\n" for row in rows) + "f +1 -2\t3\n")
    mesh = read_mesh(path)
    np.testing.assert_array_equal(mesh.vertices, _expected(words))
    assert np.signbit(mesh.vertices[0, 0])  # -0 kept
    assert mesh.faces.tolist() == [[0, 1, 2]]


def test_good_ply_numbers_read_exactly(tmp_path):
    words = [*_WORDS, "0"]
    rows = ["\t".join(words[i : i + 3]) for i in range(0, 9, 3)]
    path = tmp_path / "good.ply"
    path.write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
        "property double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        + "".join(f"{row}\t+255 0 -0\n" for row in rows)
        + "+3\t0 +1 2\n"
    )
    mesh = read_mesh(path)
    np.testing.assert_array_equal(mesh.vertices, _expected(words))
    assert np.signbit(mesh.vertices[0, 0])
    assert mesh.faces.tolist() == [[0, 1, 2]]
    assert mesh.colors.tolist() == [[255, 0, 0]] * 3


def test_good_ascii_stl_numbers_read_as_their_values(tmp_path):
    words = ["+1.5", "1e-3", "-2E+0", ".5", "7.", "0", "0", "1", "0"]
    path = tmp_path / "good.stl"
    rows = ["\t".join(words[i : i + 3]) for i in range(0, 9, 3)]
    path.write_text(
        "solid s\nfacet normal 0 0 1E+0\nouter loop\n"
        + "".join(f"vertex\t{row}\n" for row in rows)
        + "endloop\nendfacet\nendsolid s\n"
    )
    mesh = read_mesh(path)
    np.testing.assert_array_equal(mesh.vertices, _expected(words))
