"""``glmls analyze`` on a mesh or a point cloud with 3D handles: the report at the vertices
against the float64 reference, the deformed mesh, and the mistakes (one line, status 2)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.analysis import ReferenceDeformation, error_stats, tetrahedron_errors
from glmls.analysis.volume_field import fit_residuals
from glmls.cli.analyze_mesh import VERTEX_ARRAYS
from glmls.cli.main import main

SRC = [[12, 32, 32], [52, 32, 32], [32, 12, 32], [32, 52, 32], [32, 32, 12], [32, 32, 52]]
DST = [[10, 32, 32], [58, 32, 32], [32, 12, 32], [32, 52, 32], [32, 32, 12], [32, 33, 55]]
REFERENCE = [[20, 32, 32], [44, 32, 32], [32, 20, 32], [32, 44, 32], [32, 32, 20], [32, 32, 44]]


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    glmls.write_mesh(tmp_path / "sphere.obj", glmls.data.sphere())
    glmls.write_mesh(tmp_path / "cloud.ply", glmls.data.sphere().vertices, faces=[])
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    (tmp_path / "h2.json").write_text(json.dumps({"src": [[1, 2]], "dst": [[2, 3]]}))
    (tmp_path / "r3.json").write_text(json.dumps({"points": REFERENCE}))
    (tmp_path / "far.json").write_text(json.dumps({"points": [*REFERENCE, [3, 3, 1e30]]}))
    (tmp_path / "far.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1e30 0\nf 1 2 3\n")
    own = {"points": REFERENCE, "tetrahedra": [[0, 2, 4, 1], [1, 3, 5, 0]]}
    (tmp_path / "own_tets.json").write_text(json.dumps(own))
    bad = {"points": REFERENCE, "tetrahedra": [[0, 2, 4, 6]]}
    (tmp_path / "bad_tets.json").write_text(json.dumps(bad))
    flat = {"points": REFERENCE, "tetrahedra": [[0, 1, 2, 3], [0, 1, 2, 2]]}
    (tmp_path / "flat_tets.json").write_text(json.dumps(flat))
    return tmp_path


def test_analyze_a_mesh_reports_at_its_vertices(inputs, capsys):
    argv = ["analyze", "sphere.obj", "--handles", "h3.json", "--reference", "r3.json"]
    assert main([*argv, "--transform", "similarity", "--out", "rep"]) == 0
    out, err = capsys.readouterr()
    assert out.split() == ["rep/report.json", "rep/vertices.npz", "rep/deformed.ply"]
    assert "E_MLS at 162 vertices median" in err and "folded: 0 vertices, 0 faces" in err
    summary = json.loads((inputs / "rep" / "report.json").read_text())
    assert summary["mesh"] == {"vertices": 162, "faces": 320}
    assert summary["analysis"]["reference_points"] == "given"
    sphere = glmls.data.sphere()
    m = ReferenceDeformation(SRC, DST, transform="similarity")
    matrix, translation = m.matrices(sphere.vertices)
    field = error_stats(fit_residuals(m.src, m.dst, matrix, translation))
    for key in ("mean", "median", "trimmed_mean", "max"):
        assert_allclose(summary["error_field"][key], field[key], rtol=1e-3)
    assert summary["error_field"]["unit"] == "(handle units)^2"
    tetrahedra = tetrahedron_errors(m, REFERENCE).stats()
    assert summary["tetrahedra"]["tetrahedra"] == tetrahedra["tetrahedra"]
    assert_allclose(summary["tetrahedra"]["angle"]["mean"], tetrahedra["angle"]["mean"], atol=1e-3)
    jacobians = summary["jacobians"]
    assert jacobians["vertex_folds"] == jacobians["face_folds"] == 0
    assert jacobians["degenerate_faces"] == 0
    assert jacobians["det"]["min"] > 0 and jacobians["ratio"]["min"] >= 1.0
    deformed = glmls.read_mesh(inputs / "rep" / "deformed.ply")
    assert_array_equal(deformed.faces, sphere.faces)
    assert_allclose(deformed.vertices, m(sphere.vertices), atol=1e-3)
    # the values at every vertex (and the folds of every face), which the report sums up
    with np.load(inputs / "rep" / "vertices.npz") as values:
        assert sorted(values.files) == sorted(VERTEX_ARRAYS)
        errors = fit_residuals(m.src, m.dst, matrix, translation)
        assert_allclose(values["error_field"], errors, rtol=1e-3, atol=1e-6 * errors.max())
        assert error_stats(values["error_field"])["median"] == summary["error_field"]["median"]
        step = 1e-4 * np.eye(3)  # J of the float64 reference by central differences
        columns = [(m(sphere.vertices + e) - m(sphere.vertices - e)) / 2e-4 for e in step]
        assert_allclose(values["det_j"], np.linalg.det(np.stack(columns, -1)), rtol=1e-3)
        assert values["ratio"].shape == (162,) and (values["ratio"] >= 1.0).all()
        assert values["vertex_folds"].dtype == bool and not values["vertex_folds"].any()
        assert values["face_folds"].shape == (320,) and not values["face_folds"].any()


def test_faces_of_zero_area_in_the_input_are_counted_apart_from_the_map_folds(inputs, capsys):
    sphere = glmls.data.sphere()
    count = len(sphere.vertices)
    midpoint = (sphere.vertices[0] + sphere.vertices[1]) / 2
    vertices = np.vstack([sphere.vertices, sphere.vertices[0], midpoint])
    # a repeated index, a vertex repeated at another index, three vertices on a line
    extra = [[0, 0, 1], [0, count, 1], [0, 1, count + 1]]
    glmls.write_mesh(inputs / "degenerate.ply", vertices, faces=np.vstack([sphere.faces, extra]))
    argv = ["analyze", "degenerate.ply", "--handles", "h3.json", "--transform", "similarity"]
    assert main([*argv, "--out", "rep"]) == 0
    err = capsys.readouterr().err
    jacobians = json.loads((inputs / "rep" / "report.json").read_text())["jacobians"]
    assert jacobians["vertex_folds"] == 0 and jacobians["degenerate_faces"] == 3
    assert jacobians["face_folds"] == 3  # the map folds none: only the input's flat faces
    assert "folded: 0 vertices, 3 faces (3 of zero area in the input)" in err


def test_analyze_a_point_cloud_and_a_folding_map(inputs, capsys):
    mirror = np.array(SRC, float) * [-1, 1, 1] + [64, 0, 0]  # a mirror: every J folds
    (inputs / "m3.json").write_text(json.dumps({"src": SRC, "dst": mirror.tolist()}))
    argv = ["analyze", "sphere.obj", "--handles", "m3.json", "--transform", "affine"]
    assert main([*argv, "--out", "fold"]) == 0
    jacobians = json.loads((inputs / "fold" / "report.json").read_text())["jacobians"]
    assert jacobians["vertex_folds"] == 162 and jacobians["face_folds"] == 320
    with np.load(inputs / "fold" / "vertices.npz") as values:
        assert values["vertex_folds"].all() and values["face_folds"].all()
        assert (values["det_j"] < 0).all()
    assert main(["analyze", "cloud.ply", "--handles", "h3.json", "--out", "cloud"]) == 0
    summary = json.loads((inputs / "cloud" / "report.json").read_text())
    assert summary["mesh"] == {"vertices": 162, "faces": 0}
    assert summary["analysis"]["reference_points"] == "handles"
    capsys.readouterr()


def test_deformed_mesh_keeps_the_inputs_normals_turned_by_j_inverse_transpose(inputs, capsys):
    """deformed.ply carries the input's own normals as n J^-T (unit), J the float64
    reference's central differences, as ``glmls warp`` writes them; a mesh without normals
    gains none."""
    sphere = glmls.data.sphere()
    radial = sphere.vertices - sphere.vertices.mean(axis=0)
    normals = radial / np.linalg.norm(radial, axis=1, keepdims=True)
    glmls.write_mesh(
        inputs / "shaded.ply", glmls.Mesh(sphere.vertices, sphere.faces, normals=normals)
    )
    argv = ["analyze", "shaded.ply", "--handles", "h3.json", "--transform", "affine"]
    assert main([*argv, "--out", "rep"]) == 0
    written = glmls.read_mesh(inputs / "rep" / "deformed.ply").normals
    m = ReferenceDeformation(SRC, DST, transform="affine")
    step = 1e-3
    columns = [
        (m(sphere.vertices + step * axis) - m(sphere.vertices - step * axis)) / (2 * step)
        for axis in np.eye(3)
    ]
    jacobian = np.stack(columns, axis=1)  # J[k, r, c] = d f_c / d v_r
    turned = np.einsum("kc,krc->kr", normals, np.linalg.inv(jacobian))  # n J^-T, row vectors
    turned /= np.linalg.norm(turned, axis=1, keepdims=True)
    assert written is not None
    assert_allclose(written, turned, atol=1e-3)  # the GPU's J in float32, PLY's float32
    assert main(["analyze", "sphere.obj", "--handles", "h3.json", "--out", "plain"]) == 0
    assert glmls.read_mesh(inputs / "plain" / "deformed.ply").normals is None
    capsys.readouterr()


def test_a_map_that_flattens_the_mesh_folds_every_vertex(inputs, capsys):
    """Targets on the plane z = 32 (affine): J is singular at every vertex (the float64
    reference's J has rank 2), so every vertex and face folds and no ratio is defined,
    rather than float32's rounding of det J deciding a random half."""
    flat = np.array(SRC, float)
    flat[:, 2] = 32.0
    (inputs / "flat.json").write_text(json.dumps({"src": SRC, "dst": flat.tolist()}))
    vertices = glmls.data.sphere().vertices
    m = ReferenceDeformation(SRC, flat, transform="affine")
    columns = [(m(vertices + 1e-3 * e) - m(vertices - 1e-3 * e)) / 2e-3 for e in np.eye(3)]
    singular = np.linalg.svd(np.stack(columns, axis=1), compute_uv=False)
    assert (singular[:, 2] < 1e-8 * singular[:, 0]).all()
    argv = ["analyze", "sphere.obj", "--handles", "flat.json", "--transform", "affine"]
    assert main([*argv, "--out", "flat"]) == 0
    jacobians = json.loads((inputs / "flat" / "report.json").read_text())["jacobians"]
    assert jacobians["vertex_folds"] == 162 and jacobians["face_folds"] == 320
    assert jacobians["det"]["max"] == 0.0
    assert jacobians["ratio"]["count"] == 0 and jacobians["ratio"]["nan_count"] == 162
    capsys.readouterr()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["sphere.obj", "--handles", "h3.json", "--fit"], "--fit: for images, not for a mesh"),
        (
            ["sphere.obj", "--handles", "h2.json"],
            "h2.json: 2D handles (x, y), but sphere.obj is a mesh: it takes 3D handles (x, y, z)",
        ),
        (["sphere.obj"], "missing --handles"),
        (["sphere.obj", "--handles", "h3.json", "--weight", "gaussian"], "needs --radius"),
        (["missing.ply", "--handles", "h3.json"], "missing.ply: no such file"),
        (["far.obj", "--handles", "h3.json"], "far.obj: mesh vertices must lie within"),
        (
            ["sphere.obj", "--handles", "h3.json", "--reference", "far.json"],
            "far.json: reference_points must lie within ±1e+06",
        ),
        *(
            (["sphere.obj", "--handles", "h3.json", *option], f"{option[0]}: for images and")
            for option in (
                ["--method", "backward"],
                ["--grid", "2"],
                ["--border", "edge"],
                ["--interpolation", "linear"],
                ["--analysis-grid", "4"],
                ["--cmap", "linear"],
            )
        ),
        (
            ["sphere.obj", "--handles", "h3.json", "--reference", "bad_tets.json"],
            'bad_tets.json: "tetrahedra"[0]: expected 4 point indices, integers in 0..5',
        ),
        (
            ["sphere.obj", "--handles", "h3.json", "--reference", "flat_tets.json"],
            'flat_tets.json: "tetrahedra"[1]: [0, 1, 2, 2] repeats a vertex',
        ),
    ],
)
def test_bad_mesh_inputs_exit_2_with_one_line(inputs, capsys, args, message):
    assert main(["analyze", *args, "--out", "rep"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not (inputs / "rep" / "report.json").exists()


def test_the_reference_file_may_give_its_own_tetrahedra(inputs, capsys):
    """``"tetrahedra"`` in the ``--reference`` JSON: those are measured, not the points'
    Delaunay tetrahedra."""
    argv = ["analyze", "sphere.obj", "--handles", "h3.json", "--reference", "own_tets.json"]
    assert main([*argv, "--out", "rep"]) == 0
    capsys.readouterr()
    summary = json.loads((inputs / "rep" / "report.json").read_text())
    m = ReferenceDeformation(SRC, DST)
    own = tetrahedron_errors(m, REFERENCE, tetrahedra=[[0, 2, 4, 1], [1, 3, 5, 0]]).stats()
    assert summary["tetrahedra"]["tetrahedra"] == own["tetrahedra"] == 2
    assert_allclose(summary["tetrahedra"]["distance"]["mean"], own["distance"]["mean"], rtol=1e-4)


def test_deformed_ply_names_what_it_does_not_carry(inputs, capsys):
    """A seam's texture coordinates (vertex 2 has vt 2 in one face and vt 5 in the other)
    have no place in deformed.ply (one per vertex): analyze names them, as glmls warp does."""
    (inputs / "seam.obj").write_text(
        "v 20 20 20\nv 44 20 20\nv 20 44 20\nv 44 44 20\n"
        "vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0.5\nf 1/1 2/2 3/3\nf 2/5 4/4 3/3\n"
    )
    assert main(["analyze", "seam.obj", "--handles", "h3.json", "--out", "rep"]) == 0
    lines = [x for x in capsys.readouterr().err.splitlines() if "carry" in x]
    assert lines == [
        "analyze: rep/deformed.ply does not carry the input's texture coordinates (a vertex "
        "has several, at seams: PLY holds one per vertex)"
    ]
