"""STL files cut short or of a wrong size: a binary STL of other than the bytes its header
counts is named so (it was read as ASCII text, "no mesh vertices in it"), and an ASCII STL
whose last solid has no ``endsolid`` is refused (trimesh read the solids before it as the
whole file, or none)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import run_glmls as cli

from glmls.errors import InputFileError
from glmls.files import read_mesh, write_mesh

FACET = """facet normal 0 0 1
outer loop
vertex {x} 0 0
vertex {x1} 0 0
vertex {x} 1 0
endloop
endfacet
"""


def _solid(name: str, start: float) -> str:
    facets = "".join(FACET.format(x=start + k, x1=start + k + 1) for k in range(2))
    return f"solid {name}\n{facets}endsolid {name}\n"


@pytest.fixture
def binary(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "whole.stl"
    write_mesh(
        path, rng.random((30, 3)), faces=rng.permuted(np.tile(np.arange(30), (20, 1)))[:, :3]
    )
    return path.read_bytes()


@pytest.mark.parametrize("kept", [1, 30, 1000])
def test_a_binary_stl_cut_short_is_named_so(tmp_path, binary, kept):
    path = tmp_path / "cut.stl"
    path.write_bytes(binary[: len(binary) - kept])
    message = (
        rf"cut\.stl: not a readable \.stl mesh: a binary STL whose header counts 20 triangles "
        rf"\(1084 bytes\), but the file has {len(binary) - kept} bytes: cut short"
    )
    with pytest.raises(InputFileError, match=message):
        read_mesh(path)


def test_bytes_after_the_counted_triangles_are_named(tmp_path, binary):
    path = tmp_path / "long.stl"
    path.write_bytes(binary + bytes(7))
    with pytest.raises(InputFileError, match=r"has 7 bytes after them \(a wrong count"):
        read_mesh(path)


def test_a_binary_stl_whose_header_says_solid_still_reads(tmp_path, binary):
    path = tmp_path / "solid.stl"
    path.write_bytes(b"solid exported".ljust(80, b" ") + binary[80:])
    assert read_mesh(path).faces.shape == (20, 3)


def test_an_ascii_stl_of_two_solids_reads_both(tmp_path):
    path = tmp_path / "two.stl"
    path.write_text(_solid("a", 0) + _solid("b", 10))
    assert read_mesh(path).faces.shape == (4, 3)


@pytest.mark.parametrize("cut", [10, 40])
def test_an_ascii_stl_cut_in_its_last_solid_is_refused(tmp_path, cut):
    text = _solid("a", 0) + _solid("b", 10)
    path = tmp_path / "cut.stl"
    path.write_text(text[:-cut])  # read before as solid a alone, 2 of its 4 faces
    with pytest.raises(InputFileError, match=r"line 17: a solid without its endsolid line"):
        read_mesh(path)


def test_an_ascii_stl_without_endsolid_is_refused(tmp_path):
    path = tmp_path / "open.stl"
    path.write_text(_solid("a", 0).replace("endsolid a\n", ""))
    with pytest.raises(InputFileError, match=r"line 1: a solid without its endsolid line"):
        read_mesh(path)


def test_glmls_warp_of_a_cut_stl_is_one_line(tmp_path, binary):
    (tmp_path / "cut.stl").write_bytes(binary[:-30])
    src = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    (tmp_path / "h3.json").write_text(json.dumps({"src": src, "dst": src}))
    result = cli("warp", "cut.stl", "out.stl", "--handles", "h3.json", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("glmls warp: cut.stl: not a readable .stl")
    assert lines[0].endswith("cut short"), lines
    assert not (tmp_path / "out.stl").exists()
