"""World coordinates of a NIfTI affine: ``glmls.files.world_to_volume`` maps them through the
affine's inverse to the frame of the 3D warps (voxel indices times the spacing), and ``glmls
warp --world`` takes handles so; refused for files without an affine."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls.cli.main import main
from glmls.files import volume_to_world, world_to_volume

SHAPE = (6, 10, 8)  # D, H, W
STEPS = np.array([0.5, 0.8, 2.0])  # dx, dy, dz: the spacing (dz, dy, dx) = (2, 0.8, 0.5)


def _rotation(axis: str, degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    a, b = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    r = np.eye(3)
    r[a, a], r[a, b], r[b, a], r[b, b] = c, -s, s, c
    return r


def _affine() -> np.ndarray:
    """Voxel indices (i, j, k, 1) to the world: rotated, scaled by the spacing, shifted."""
    affine = np.eye(4)
    affine[:3, :3] = _rotation("z", 30) @ _rotation("x", -20) @ np.diag(STEPS)
    affine[:3, 3] = [-40.0, 12.5, 80.0]
    return affine


def _to_world(points: np.ndarray) -> np.ndarray:
    """(i dx, j dy, k dz) to world coordinates, with the affine as NIfTI defines it."""
    indices = points / STEPS
    return indices @ _affine()[:3, :3].T + _affine()[:3, 3]


def test_world_to_volume_inverts_the_affine():
    rng = np.random.default_rng(2)
    points = rng.uniform(0, 5, (9, 3))
    world = _to_world(points)
    assert_allclose(world_to_volume(world, _affine()), points, atol=1e-12)
    assert_allclose(volume_to_world(points, _affine()), world, atol=1e-12)
    # another spacing for the warp: the same voxels, in its units
    other = world_to_volume(world, _affine(), spacing=(1.0, 1.0, 1.0))
    assert_allclose(other, points / STEPS, atol=1e-12)


@pytest.mark.parametrize(
    ("points", "affine", "message"),
    [
        (np.zeros((2, 2)), np.eye(4), r"\(N, 3\)"),
        (np.full((1, 3), np.nan), np.eye(4), "finite"),
        (np.zeros((1, 3)), np.eye(3), "4 x 4"),
        (np.zeros((1, 3)), np.diag([1.0, 0.0, 1.0, 1.0]), "singular"),
    ],
)
def test_world_to_volume_refuses_bad_input(points, affine, message):
    with pytest.raises(ValueError, match=message):
        world_to_volume(points, affine)


@pytest.mark.parametrize(
    "columns",
    [
        np.diag([1.0, 1.0, 1e-9]),  # a voxel size a billionth of the others
        np.diag([0.8, 1e-7, 0.8]),
        np.array([[1.0, 1.0, 0.0], [0.0, 1e-8, 0.0], [0.0, 0.0, 2.0]]),  # axes i, j as one
    ],
)
def test_a_nearly_singular_affine_is_refused_naming_it(columns):
    affine = np.eye(4)
    affine[:3, :3] = columns
    for function in (world_to_volume, volume_to_world):
        with pytest.raises(
            ValueError, match=r"affine is singular or nearly so: .* rows \[[^\]]+\]$"
        ):
            function(np.ones((2, 3)), affine)


@pytest.mark.parametrize("size", [1e-4, 1e-6])
def test_an_affine_of_small_voxels_is_no_singular_one(size):
    """Micrometre voxels in metres: every voxel size small, their ratios 1."""
    affine = _affine()
    affine[:3] *= size
    points = np.random.default_rng(5).uniform(0, 5, (9, 3))
    world = (points / STEPS) @ affine[:3, :3].T + affine[:3, 3]
    spacing = np.linalg.norm(affine[:3, :3], axis=0)[::-1]
    assert_allclose(world_to_volume(world, affine), points * size, rtol=1e-9)
    assert_allclose(volume_to_world(points * size, affine, spacing=spacing), world, rtol=1e-9)


def test_warp_refuses_world_handles_of_a_nearly_singular_affine(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    flat = np.diag([1.0, 1.0, 1e-9, 1.0])
    glmls.write_volume(tmp_path / "flat.nii", np.ones(SHAPE, np.float32), affine=flat)
    points = [[1.0, 1.0, 1e-9], [5.0, 1.0, 2e-9], [1.0, 6.0, 3e-9], [4.0, 4.0, 4e-9]]
    moved = [[x + 0.5, y, z] for x, y, z in points]
    (tmp_path / "h.json").write_text(json.dumps({"src": points, "dst": moved}))
    assert main(["warp", "flat.nii", "out.nii", "--handles", "h.json", "--world"]) == 2
    err = capsys.readouterr().err
    assert "flat.nii: affine is singular or nearly so" in err and err.count("\n") == 1, err
    assert not (tmp_path / "out.nii").exists()


@pytest.fixture
def nifti(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float32) for n in SHAPE), indexing="ij")
    data = (np.sin(x / 1.5) + np.cos(y / 2.0) + z / 3.0).astype(np.float32)
    glmls.write_volume(tmp_path / "v.nii.gz", data, affine=_affine())
    extent = (np.array(SHAPE[::-1]) - 1) * STEPS
    rng = np.random.default_rng(4)
    src = rng.uniform(0.1, 0.9, (6, 3)) * extent  # (i dx, j dy, k dz)
    dst = src + rng.uniform(-0.6, 0.6, (6, 3))
    (tmp_path / "units.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    world = {"src": _to_world(src).tolist(), "dst": _to_world(dst).tolist()}
    (tmp_path / "world.json").write_text(json.dumps(world))
    return tmp_path


def test_world_handles_warp_as_the_same_handles_in_voxels_times_spacing(nifti, gl):
    assert glmls.read_volume(nifti / "v.nii.gz").spacing == pytest.approx((2.0, 0.8, 0.5))
    common = ["--quiet", "--method", "backward", "--interpolation", "linear"]
    assert main(["warp", "v.nii.gz", "units.nii.gz", "--handles", "units.json", *common]) == 0
    assert (
        main(["warp", "v.nii.gz", "world.nii.gz", "--handles", "world.json", "--world", *common])
        == 0
    )
    units, world = (glmls.read_volume(nifti / f"{n}.nii.gz") for n in ("units", "world"))
    assert_allclose(world.data, units.data, rtol=0, atol=1e-5)
    assert_allclose(world.affine, _affine(), atol=1e-6)  # the output keeps the input's affine
    source = glmls.read_volume(nifti / "v.nii.gz").data
    assert np.abs(world.data - source).max() > 0.05  # the handles moved it
    # the same world handles taken as units are another warp
    assert main(["warp", "v.nii.gz", "raw.nii.gz", "--handles", "world.json", *common]) == 0
    raw = glmls.read_volume(nifti / "raw.nii.gz").data
    assert np.abs(raw - units.data).max() > 0.05


def test_world_needs_an_affine(nifti, capsys):
    np.save(nifti / "v.npy", np.zeros(SHAPE, np.float32))
    glmls.imwrite(nifti / "i.png", np.zeros((8, 8), np.uint8))
    (nifti / "h2.json").write_text(json.dumps({"src": [[1, 1]], "dst": [[2, 1]]}))
    for argv, frame in (
        (["warp", "v.npy", "o.npy", "--handles", "units.json", "--world"], "voxels times"),
        (["warp", "i.png", "o.png", "--handles", "h2.json", "--world"], "handles in pixels"),
        (["analyze", "v.npy", "--handles", "units.json", "--world", "--out", "rep"], "voxels"),
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "--world" in err and "affine" in err and err.count("\n") == 1, err
        assert frame in err, err  # the frame of the input's kind: no voxels for an image
    assert not (nifti / "o.npy").exists() and not (nifti / "rep").exists()


@pytest.mark.parametrize("function", [world_to_volume, volume_to_world])
def test_the_examples_run(function):
    """Their docstrings' examples (glmls.files is outside the packages whose doctests
    tests/docs runs), and numpydoc's checks there."""
    import doctest

    from numpydoc.validate import validate

    finder, runner = doctest.DocTestFinder(), doctest.DocTestRunner()
    for test in finder.find(function, function.__name__, globs={}):
        assert runner.run(test).failed == 0
    errors = validate(f"glmls.files.{function.__name__}")["errors"]
    checks = {"GL08", "SS01", "SS03", "SS06", "PR01", "PR02", "PR07", "RT01", "EX01"}
    assert [e for e in errors if e[0] in checks] == []


def test_world_handles_of_a_sheared_affine_are_warned_of():
    """The warp's frame (i dx, j dy, k dz) is the world through the inverse of the affine:
    an isometry of it where the affine's columns are orthogonal (rotations, flips), but a
    shear of it where they are not, in which a rigid motion of the world is no rigid motion
    (nor distances the world's): --world says so, once."""
    from types import SimpleNamespace

    from glmls.cli.warp3d import volume_handle_warnings

    args = SimpleNamespace(handles="h.json", targets=None, world=True)
    src = np.array([[1.0, 1.0, 1.0], [3.0, 4.0, 2.0]])
    assert volume_handle_warnings(args, src, SHAPE, (2.0, 0.8, 0.5), _affine()) == []
    sheared = _affine()
    sheared[:3, 1] += 0.3 * sheared[:3, 0]  # column j leans towards column i
    spacing = tuple(np.linalg.norm(sheared[:3, :3], axis=0)[::-1])  # the file's, as read
    [message] = volume_handle_warnings(args, src, SHAPE, spacing, sheared)
    assert "sheared" in message and "rigid" in message, message
    args.world = False  # handles in the frame itself: nothing to warn of
    assert volume_handle_warnings(args, src, SHAPE, spacing, sheared) == []


def test_world_handles_with_a_spacing_out_of_proportion_are_warned_of(nifti, gl, capsys):
    """--spacing other than the affine's voxel sizes (not merely in other units) stretches
    the frame unevenly against the world: a rigid motion of the world is no rigid motion
    there, and --world says so, once; a spacing in proportion only scales the frame."""
    from types import SimpleNamespace

    from glmls.cli.warp3d import volume_handle_warnings

    args = SimpleNamespace(handles="h.json", targets=None, world=True)
    src = np.array([[1.0, 1.0, 1.0], [3.0, 4.0, 2.0]])
    for spacing in ((2.0, 0.8, 0.5), (20.0, 8.0, 5.0)):  # the file's, in mm and in 0.1 mm
        assert volume_handle_warnings(args, src, SHAPE, spacing, _affine()) == []
    [message] = volume_handle_warnings(args, src, SHAPE, (1.0, 1.0, 1.0), _affine())
    assert "(1.0, 1.0, 1.0) is out of proportion" in message and "rigid" in message, message
    args.world = False
    assert volume_handle_warnings(args, src, SHAPE, (1.0, 1.0, 1.0), _affine()) == []
    argv = ["warp", "v.nii.gz", "o.nii.gz", "--handles", "world.json", "--world"]
    assert main([*argv, "--spacing", "1"]) == 0
    err = capsys.readouterr().err
    assert err.count("out of proportion") == 1, err
    assert main([*argv, "--spacing", "20,8,5"]) == 0
    assert "warning" not in capsys.readouterr().err


def test_demo_takes_world_handles_as_warp_does(nifti, capsys):
    """``glmls demo VOLUME --world``: the window's handles are the world handles mapped as
    ``glmls warp --world`` maps them (checked without opening the window); refused without
    an affine, without handles, and for images."""
    from glmls.cli.demo_volume import volume_inputs
    from glmls.cli.main import build_parser

    parse = build_parser().parse_args
    argv = ["demo", "v.nii.gz", "--handles", "world.json", "--world"]
    _, _, src, dst = volume_inputs(parse(argv))
    units = json.loads((nifti / "units.json").read_text())
    assert_allclose(src, units["src"], atol=1e-9)
    assert_allclose(dst, units["dst"], atol=1e-9)
    np.save(nifti / "v.npy", np.zeros(SHAPE, np.float32))
    glmls.imwrite(nifti / "i.png", np.zeros((8, 8), np.uint8))
    (nifti / "h2.json").write_text(json.dumps({"src": [[1, 1]], "dst": [[2, 1]]}))
    for argv, words in (
        (["demo", "v.npy", "--handles", "units.json", "--world"], "affine"),
        (["demo", "--handles", "units.json", "--world"], "affine"),
        (["demo", "v.nii.gz", "--world"], "--handles"),
        (["demo", "i.png", "--handles", "h2.json", "--world"], "not for images"),
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "--world" in err and words in err and err.count("\n") == 1, err


def test_demo_hints_at_world_for_world_handles_given_without_it(nifti, capsys, monkeypatch):
    """World handles given to the volume window without ``--world`` get ``glmls warp``'s
    hint (the window opens all the same)."""
    from glmls.cli import demo_volume

    monkeypatch.setattr(demo_volume, "run_window", lambda app, args, events: 0)
    monkeypatch.setattr("glmls.app.volume_window.VolumeApp", lambda *a, **k: None)
    (nifti / "far.json").write_text(
        json.dumps({"src": _to_world(np.full((4, 3), 2.0)).tolist(), "dst": [[0, 0, 0]] * 4})
    )
    assert main(["demo", "v.nii.gz", "--handles", "far.json"]) == 0
    assert "add --world" in capsys.readouterr().err
