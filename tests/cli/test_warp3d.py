"""``glmls warp`` on volumes and meshes: the files, the spacing and affine, the dtype, the fold
summary (with a stand-in MLS, in this process), the mistakes (one line, exit status 2), and
end to end on the bundled phantom and sphere with the GPU's 3D MLS."""

from __future__ import annotations

import argparse
import json
import types
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest
import tifffile
from helpers import run_glmls, write_elastix_points
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.cli import warp3d
from glmls.cli.main import main

AFFINE = np.array(
    [[-2.0, 0.0, 0.0, 30.0], [0.0, 1.0, 0.0, -4.0], [0.0, 0.0, 3.0, 5.0], [0, 0, 0, 1]]
)


class StandIn:
    """An MLS of 3D handles that moves everything by the mean displacement: what the command
    does with the files, without the GPU's 3D MLS."""

    calls: ClassVar[list] = []

    def __init__(self, src, dst, **settings):
        self.shift = (np.asarray(dst) - np.asarray(src)).mean(axis=0)
        StandIn.calls.append(("MLS", np.asarray(src).shape, settings))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def warp(self, volume, **options):
        StandIn.calls.append(("warp", volume.dtype.name, options))
        return np.asarray(volume, dtype=np.float32) + 0.6

    def deform(self, mesh):
        count = len(mesh.faces)
        return types.SimpleNamespace(
            vertices=mesh.vertices + self.shift,
            vertex_folds=np.zeros(len(mesh.vertices), bool),
            face_folds=np.arange(count) < 2,
        )


@pytest.fixture
def stand_in(monkeypatch):
    StandIn.calls = []
    monkeypatch.setattr(warp3d, "MLS", StandIn)
    return StandIn


@pytest.fixture
def files(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    src, dst = glmls.data.phantom_handles()
    (tmp_path / "h3.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    (tmp_path / "h2.json").write_text(json.dumps({"src": [[1, 2]], "dst": [[2, 3]]}))
    glmls.write_volume(tmp_path / "v.nii.gz", glmls.data.phantom()[:8, :9, :10], affine=AFFINE)
    glmls.write_mesh(tmp_path / "sphere.ply", glmls.data.sphere())
    glmls.imwrite(tmp_path / "a.png", np.zeros((8, 10), np.uint8))
    return tmp_path


def _last(calls, kind):
    return [c for c in calls if c[0] == kind][-1]


def test_volume_keeps_the_affine_and_passes_its_spacing(files, stand_in, capsys):
    assert main(["warp", "v.nii.gz", "out.nii.gz", "--handles", "h3.json", "--alpha", "2"]) == 0
    out, err = capsys.readouterr()
    assert out.strip() == "out.nii.gz"
    assert "warp: volume 10 x 9 x 8 voxels (x, y, z), spacing (dz, dy, dx) = (3.0, 1.0, 2.0)" in err
    _, shape, settings = _last(stand_in.calls, "MLS")
    assert shape == (10, 3) and settings["alpha"] == 2.0
    _, dtype, options = _last(stand_in.calls, "warp")
    assert dtype == "uint8" and options["spacing"] == (3.0, 1.0, 2.0)
    assert options["method"] == "quads" and options["interpolation"] == "nearest"
    written = glmls.read_volume(files / "out.nii.gz")
    assert_allclose(written.affine, AFFINE)
    assert written.data.dtype == np.uint8
    assert_array_equal(written.data, glmls.read_volume(files / "v.nii.gz").data + 1)


def test_spacing_option_wins_and_other_formats(files, stand_in, capsys):
    volume = np.arange(4 * 5 * 6, dtype=np.int16).reshape(4, 5, 6) - 50
    np.save(files / "v.npy", volume)
    assert main(["warp", "v.npy", "out/", "--handles", "h3.json", "--spacing", "2,1,0.5"]) == 0
    assert _last(stand_in.calls, "warp")[1] == "float32"  # int16 is warped as float32
    assert _last(stand_in.calls, "warp")[2]["spacing"] == (2.0, 1.0, 0.5)
    written = np.load(files / "out" / "v.npy")
    assert written.dtype == np.int16  # and written back as int16, rounded
    assert_array_equal(written, volume + 1)
    assert main(["warp", "v.npy", "stack.tif", "--handles", "h3.json", "--spacing", "2"]) == 0
    assert glmls.read_volume(files / "stack.tif").spacing == (2.0, 2.0, 2.0)
    assert main(["warp", "stack.tif", "plain.npy", "--handles", "h3.json"]) == 0
    assert _last(stand_in.calls, "warp")[2]["spacing"] == (2.0, 2.0, 2.0)  # the stack's
    capsys.readouterr()


def test_a_stack_written_one_slice_a_write_is_a_volume(files, stand_in, capsys):
    """Each page a tifffile series of its own: warped as the volume with 3D handles, and
    with 2D handles or by augment refused as a volume, not read as its first page."""
    volume = np.arange(4 * 5 * 6, dtype=np.uint8).reshape(4, 5, 6)
    with tifffile.TiffWriter(files / "pages.tif") as tiff:
        for page in volume:
            tiff.write(page)
    assert main(["warp", "pages.tif", "out.npy", "--handles", "h3.json"]) == 0
    assert "warp: volume 6 x 5 x 4 voxels (x, y, z)" in capsys.readouterr().err
    assert_array_equal(np.load(files / "out.npy"), volume + 1)
    assert main(["warp", "pages.tif", "out.png", "--handles", "h2.json"]) == 2
    assert main(["augment", "pages.tif", "aug", "--n", "1"]) == 2
    assert "pages.tif: a volume (a TIFF stack)" in capsys.readouterr().err
    assert not (files / "out.png").exists() and not (files / "aug").exists()


@pytest.mark.parametrize("pattern", ["vols", "vols/*.npy", "vols/*.nii.gz"])
def test_a_folder_or_glob_of_volumes_is_named_as_images_with_its_reason(
    files, stand_in, capsys, pattern
):
    """Volumes are warped one a call: a folder or a glob takes 2D images, and 3D handles
    for one say so (not "no such file" for a glob that matches, nor images alone)."""
    (files / "vols").mkdir()
    for name in ("a.npy", "b.npy"):
        np.save(files / "vols" / name, np.zeros((4, 5, 6), np.uint8))
    assert main(["warp", pattern, "out/", "--handles", "h3.json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert (
        f"h3.json: 3D handles (x, y, z), but {pattern} names images: a folder or a glob "
        "takes 2D images (a volume or a mesh is named on its own)" in err
    )
    assert not (files / "out").exists() and not stand_in.calls


def test_one_channel_volume_keeps_its_axis_through_tiff(files, stand_in, capsys):
    volume = np.arange(4 * 5 * 6, dtype=np.uint16).reshape(4, 5, 6, 1)
    np.save(files / "one.npy", volume)
    assert main(["warp", "one.npy", "one.tif", "--handles", "h3.json"]) == 0
    assert glmls.read_volume(files / "one.tif").shape == (4, 5, 6, 1)
    assert main(["warp", "one.tif", "back.npy", "--handles", "h3.json"]) == 0
    assert_array_equal(np.load(files / "back.npy"), volume + 2)
    capsys.readouterr()


def test_stderr_gives_the_spacing_as_the_file_was_written(files, stand_in, capsys):
    """A NIfTI header holds its affine in float32: a voxel of 0.8 reads back as
    0.800000011920929, which stderr does not show."""
    affine = np.diag([0.5, 0.8, 2.0, 1.0])
    glmls.write_volume(files / "thin.nii.gz", glmls.data.phantom()[:4, :5, :6], affine=affine)
    assert glmls.read_volume(files / "thin.nii.gz").spacing[1] != 0.8  # float32's 0.8
    assert main(["warp", "thin.nii.gz", "out.nii.gz", "--handles", "h3.json"]) == 0
    err = capsys.readouterr().err
    assert "spacing (dz, dy, dx) = (2.0, 0.8, 0.5)" in err, err


def test_the_mls_has_the_volume_shape_and_spacing(files, stand_in, capsys):
    """As for images (the image diagonal): the MLS is made with the volume's shape and
    spacing, so that ``--weight gaussian`` without ``--radius`` takes the volume's diagonal
    in the units of the handles (the spacing's): v.nii.gz is 8 x 9 x 10 voxels of
    (dz, dy, dx) = (3, 1, 2)."""
    argv = ["warp", "v.nii.gz", "out.nii.gz", "--handles", "h3.json", "--weight", "gaussian"]
    assert main(argv) == 0
    settings = _last(stand_in.calls, "MLS")[2]
    assert settings["shape"] == (8, 9, 10) and settings["spacing"] == (3.0, 1.0, 2.0)
    assert settings["radius"] is None
    assert main([*argv, "--radius", "7"]) == 0
    assert _last(stand_in.calls, "MLS")[2]["radius"] == 7.0
    capsys.readouterr()


def test_a_radius_weight_defaults_to_the_volume_diagonal_in_handle_units(files):
    """End to end on the GPU: the default radius is the diagonal of (24, 9, 20), bit for bit
    the warp with that radius given."""
    argv = ["warp", "v.nii.gz", "--handles", "h3.json", "--weight", "gaussian", "--quiet"]
    assert main([*argv[:2], "default.nii.gz", *argv[2:]]) == 0
    radius = repr(float(np.sqrt(24**2 + 9**2 + 20**2)))
    assert main([*argv[:2], "given.nii.gz", *argv[2:], "--radius", radius]) == 0
    default = glmls.read_volume(files / "default.nii.gz").data
    assert_array_equal(default, glmls.read_volume(files / "given.nii.gz").data)


def test_a_radius_weight_on_a_mesh_asks_for_the_radius(files, capsys):
    assert main(["warp", "sphere.ply", "o.ply", "--handles", "h3.json", "--weight", "linear"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--weight linear needs --radius" in err


def test_a_volume_of_more_than_four_channels_is_one_line(files, capsys):
    # the channels decide before the handles' warnings, which would come first otherwise
    glmls.write_volume("seven.nii", np.zeros((6, 8, 10, 7), np.uint8))
    assert main(["warp", "seven.nii", "o.nii", "--handles", "h3.json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a volume of 7 channels; glmls warps 1 to 4" in err
    assert not Path("o.nii").exists()


def test_a_mask_is_written_back_rounded_not_grown(files, monkeypatch, capsys):
    """A bool volume (a mask) is warped as float32 and written back as bool: true where the
    warped value is at least 1/2, as integers are rounded, not wherever it is above 0 (a
    trilinear warp would grow the mask by a voxel all round)."""

    class Halves(StandIn):
        def warp(self, volume, **options):
            return np.asarray(volume, dtype=np.float32) * np.float32(0.4) + np.float32(0.2)

    monkeypatch.setattr(warp3d, "MLS", Halves)
    mask = np.zeros((4, 5, 6), bool)
    mask[1:3, 2:4, 2:5] = True
    np.save(files / "mask.npy", mask)
    assert main(["warp", "mask.npy", "out.npy", "--handles", "h3.json"]) == 0
    written = np.load(files / "out.npy")
    assert written.dtype == np.bool_
    assert_array_equal(written, mask)  # 0.2 -> False, 0.6 -> True
    capsys.readouterr()


def test_mesh_is_written_with_its_faces_and_the_folds_said(files, stand_in, capsys):
    assert main(["warp", "sphere.ply", "out.obj", "--handles", "h3.json"]) == 0
    out, err = capsys.readouterr()
    assert out.strip() == "out.obj"
    assert "warp: mesh of 162 vertices and 320 faces; folded: 0 vertices, 2 faces" in err
    assert "warning: sphere.ply: 2 of 320 faces fold over" in err
    written, source = glmls.read_mesh(files / "out.obj"), glmls.data.sphere()
    assert_array_equal(written.faces, source.faces)
    shift = np.mean(np.subtract(*reversed(glmls.data.phantom_handles())), axis=0)
    assert_allclose(written.vertices, source.vertices + shift, atol=1e-5)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["warp", "v.nii.gz", "o.nii", "--handles", "h2.json"],
            "h2.json: 2D handles (x, y), but v.nii.gz is a volume: it takes 3D handles (x, y, z)",
        ),
        (
            ["warp", "sphere.ply", "o.ply", "--handles", "h2.json"],
            "but sphere.ply is a mesh: it takes 3D handles",
        ),
        (
            ["warp", "a.png", "o.png", "--handles", "h3.json"],
            "h3.json: 3D handles (x, y, z), but a.png names images: they take 2D handles (x, y)",
        ),
        (["warp", "v.nii.gz", "o.png", "--handles", "h3.json"], "o.png: a volume is written as"),
        (["warp", "sphere.ply", "o.nii", "--handles", "h3.json"], "o.nii: a mesh is written as"),
        (["warp", "a.png", "o.png", "--handles", "h2.json", "--spacing", "2"], "--spacing: for"),
        (["warp", "v.nii.gz", "o.nii", "--handles", "h3.json", "--fit"], "--fit: for images"),
        (
            ["warp", "sphere.ply", "o.ply", "--handles", "h3.json", "--spacing", "1"],
            "--spacing: for volumes, not for a mesh (sphere.ply)",
        ),
        (
            ["warp", "sphere.ply", "o.ply", "--handles", "h3.json", "--method", "backward"],
            "--method: for images and volumes, not for a mesh (sphere.ply)",
        ),
        (["warp", "v.nii.gz", "o.nii", "--handles", "m.pts", "--targets", "f.pts"], "m.pts: no "),
        (["warp", "missing.nii", "o.nii", "--handles", "h3.json"], "missing.nii: no such file"),
        (["warp", "bad.nii", "o.nii", "--handles", "h3.json"], "bad.nii: not a"),
        (["warp", "bad.ply", "o.ply", "--handles", "h3.json"], "bad.ply: not a readable .ply"),
    ],
)
def test_mistakes_are_one_line_and_status_2(files, stand_in, capsys, argv, message):
    (files / "bad.nii").write_bytes(b"garbage")
    (files / "bad.ply").write_bytes(b"ply\nformat nonsense\n")
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("glmls warp: ")
    assert message in err


def test_a_point_cloud_is_warped_to_ply_and_refused_as_stl(files, stand_in, capsys):
    glmls.write_mesh(files / "cloud.ply", glmls.data.sphere().vertices, faces=[])
    assert main(["warp", "cloud.ply", "out.ply", "--handles", "h3.json"]) == 0
    assert glmls.read_mesh(files / "out.ply").vertices.shape == (162, 3)
    capsys.readouterr()
    assert main(["warp", "cloud.ply", "out.stl", "--handles", "h3.json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "point cloud (no faces); STL holds triangles only" in err
    assert not (files / "out.stl").exists()


def test_elastix_pair_needs_its_targets(files, stand_in, capsys):
    src, dst = glmls.data.phantom_handles()
    for name, points in (("moving.pts", src), ("fixed.pts", dst)):
        write_elastix_points(files / name, "index", points)
    assert main(["warp", "v.nii.gz", "o.nii", "--handles", "moving.pts"]) == 2
    assert "give the targets' file too" in capsys.readouterr().err
    argv = ["warp", "v.nii.gz", "o.nii", "--handles", "moving.pts", "--targets", "fixed.pts"]
    assert main(argv) == 0
    assert _last(stand_in.calls, "MLS")[1] == (10, 3)
    capsys.readouterr()


def test_elastix_index_points_are_put_at_the_voxels_physical_places(files, monkeypatch, capsys):
    """An elastix pair of index files holds voxel indices: the volume's spacing (dz, dy, dx)
    = (3, 1, 2) of v.nii.gz puts them at (i dx, j dy, k dz), the units of the warp; point
    files are coordinates, taken as they are."""
    made = []

    class Recording(StandIn):
        def __init__(self, src, dst, **settings):
            made.append((np.asarray(src), np.asarray(dst)))
            super().__init__(src, dst, **settings)

    monkeypatch.setattr(warp3d, "MLS", Recording)
    src, dst = glmls.data.phantom_handles()
    for kind in ("index", "point"):
        for name, points in (("moving.pts", src), ("fixed.pts", dst)):
            write_elastix_points(files / name, kind, points)
        argv = ["warp", "v.nii.gz", "o.nii", "--handles", "moving.pts", "--targets", "fixed.pts"]
        assert main(argv) == 0
        scale = [2.0, 1.0, 3.0] if kind == "index" else [1.0, 1.0, 1.0]
        assert_allclose(made[-1][0], src * scale)
        assert_allclose(made[-1][1], dst * scale)
    capsys.readouterr()


def test_parse_spacing():
    assert warp3d.parse_spacing("1,2,3") == (1.0, 2.0, 3.0)
    assert warp3d.parse_spacing("0.5") == (0.5, 0.5, 0.5)
    for bad, message in (
        ("1,2", r"spacing must be three numbers \(dz, dy, dx\) .* got 2: \(1\.0, 2\.0\)"),
        ("0,1,1", r"spacing must be positive and finite \(dz, dy, dx\), got \(0\.0, 1\.0, 1\.0\)"),
        ("1,inf,1", r"spacing must be positive and finite .*inf"),
        ("-1", r"spacing must be positive and finite .*\(-1\.0, -1\.0, -1\.0\)"),
        ("a", r"expected DZ,DY,DX numbers, got 'a'"),
    ):
        with pytest.raises(argparse.ArgumentTypeError, match=message):
            warp3d.parse_spacing(bad)


# -- end to end, on the GPU's 3D MLS --------------------------------------------------------


def _mls3d():
    """The 3D MLS (glmls.MLS of (N, 3) handles), or a skip where it is not there."""
    try:
        m = glmls.MLS(np.zeros((1, 3)), np.ones((1, 3)))
    except (TypeError, ValueError) as error:
        pytest.skip(f"glmls.MLS takes no 3D handles here: {error}")
    return m


def test_bundled_volume_end_to_end(tmp_path):
    src, dst = glmls.data.phantom_handles()
    with _mls3d() as m:
        try:
            expected = m.warp(glmls.data.phantom())
        except (TypeError, ValueError, NotImplementedError) as error:
            pytest.skip(f"MLS.warp takes no volumes here: {error}")
    glmls.write_volume(tmp_path / "phantom.nii.gz", glmls.data.phantom())
    (tmp_path / "h.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    result = run_glmls(
        "warp", "phantom.nii.gz", "out.nii.gz", "--handles", "h.json", cwd=tmp_path,
        module="glmls.cli",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    written = glmls.read_volume(tmp_path / "out.nii.gz")
    assert_allclose(written.affine, np.eye(4))
    with glmls.MLS(src, dst) as m:
        expected = m.warp(glmls.data.phantom(), spacing=(1.0, 1.0, 1.0))
    assert_array_equal(written.data, expected)


def test_bundled_mesh_end_to_end(tmp_path):
    src, dst = glmls.data.sphere_handles()
    with _mls3d() as m:
        if not hasattr(m, "deform"):
            pytest.skip("MLS.deform is not there")
    glmls.write_mesh(tmp_path / "sphere.obj", glmls.data.sphere())
    (tmp_path / "h.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    result = run_glmls(
        "warp", "sphere.obj", "out.obj", "--handles", "h.json", cwd=tmp_path, module="glmls.cli"
    )
    assert result.returncode == 0, result.stderr
    assert "folded: 0 vertices, 0 faces" in result.stderr
    with glmls.MLS(src, dst) as m:
        expected = m.deform(glmls.data.sphere())
    written = glmls.read_mesh(tmp_path / "out.obj")
    assert_allclose(written.vertices, expected.vertices, rtol=0, atol=1e-9)
    assert_array_equal(written.faces, glmls.data.sphere().faces)


def test_elastix_pair_of_2d_points_warps_an_image(files, capsys):
    (files / "moving.pts").write_text("index\n2\n1 1\n8 6\n")
    (files / "fixed.pts").write_text("index\n2\n2 1\n9 6\n")
    argv = ["warp", "a.png", "o.png", "--handles", "moving.pts", "--targets", "fixed.pts"]
    assert main(argv) == 0
    assert capsys.readouterr().out.strip() == "o.png"
    assert glmls.imread(files / "o.png").shape == (8, 10)


def test_handles_outside_the_volume_are_warned_of_with_the_likely_convention(
    files, stand_in, capsys
):
    """Handles mostly outside the volume in the frame of the warp: a warning on stderr (the
    warp goes on), with a hint where voxel indices (given with a spacing) or world
    coordinates (given without --world) would lie inside."""
    np.save(files / "big.npy", np.zeros((64, 64, 64), np.uint8))
    assert main(["warp", "big.npy", "out.npy", "--handles", "h3.json"]) == 0
    assert "warning" not in capsys.readouterr().err  # the phantom's handles, in voxels
    argv = ["warp", "big.npy", "out.npy", "--handles", "h3.json", "--spacing", "0.5"]
    assert main(argv) == 0  # the volume spans 32 units: the voxel handles lie outside it
    err = capsys.readouterr().err
    assert "glmls warp: warning: big.npy: 9 of 10 handles lie outside the 64 x 64 x 64 " in err
    assert "in voxel indices? the handles are in the units of the spacing" in err
    affine = np.array([[0, -2.0, 0, 100], [1.0, 0, 0, -5], [0, 0, 1.0, 7], [0, 0, 0, 1]])
    glmls.write_volume(files / "big.nii.gz", np.zeros((64, 64, 64), np.uint8), affine=affine)
    src, dst = glmls.data.phantom_handles()
    scale = np.array([1.0, 2.0, 1.0])  # (dx, dy, dz) of the affine
    world = {k: glmls.files.volume_to_world(p * scale, affine).tolist() for k, p in
             (("src", src), ("dst", dst))}  # fmt: skip
    (files / "world.json").write_text(json.dumps(world))
    assert main(["warp", "big.nii.gz", "out.nii.gz", "--handles", "world.json"]) == 0
    assert "world coordinates of the file's affine? add --world" in capsys.readouterr().err
    argv = ["warp", "big.nii.gz", "out.nii.gz", "--handles", "world.json", "--world"]
    assert main(argv) == 0
    assert "warning" not in capsys.readouterr().err


def test_the_radius_help_names_the_units_of_volumes_and_meshes(capsys):
    with pytest.raises(SystemExit):
        main(["warp", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--radius RADIUS influence radius in the handles' units, pixels for an image" in text
    assert "a volume's in its handles' units; a mesh needs one" in text


@pytest.mark.parametrize("name", ["v.nii.gz", "sphere.ply"])
def test_an_output_below_a_file_is_refused_before_the_warp(files, capsys, name):
    assert main(["warp", name, f"h3.json/{name}", "--handles", "h3.json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "h3.json is a file, not a folder" in err


def test_the_grid_goes_to_the_warp_only_where_given(files, stand_in):
    """Left out, the volume's own default (1 for quads, 2 for the backward method's first
    guess); given, as given; a 2D image keeps grid 1."""
    assert main(["warp", "v.nii.gz", "o.nii.gz", "--handles", "h3.json"]) == 0
    assert _last(stand_in.calls, "warp")[2]["grid"] is None
    argv = ["warp", "v.nii.gz", "o.nii.gz", "--handles", "h3.json", "--method", "backward"]
    assert main([*argv, "--grid", "1"]) == 0
    assert _last(stand_in.calls, "warp")[2]["grid"] == 1
    from glmls.cli.options import add_warp_options, warp_options_from_args

    parser = argparse.ArgumentParser()
    add_warp_options(parser)
    assert warp_options_from_args(parser.parse_args([])).grid == 1
    assert warp_options_from_args(parser.parse_args(["--grid", "4"])).grid == 4


def test_a_grid_on_a_mesh_is_refused_even_at_1(files, stand_in, capsys):
    assert main(["warp", "sphere.ply", "o.ply", "--handles", "h3.json", "--grid", "1"]) == 2
    assert "--grid" in capsys.readouterr().err


def test_a_grid_not_smaller_than_the_volume_is_warned_about(files, stand_in, capsys):
    assert main(["warp", "v.nii.gz", "o.nii.gz", "--handles", "h3.json", "--grid", "10"]) == 0
    assert "--grid 10 is not smaller than the 10 x 9 x 8 volume" in capsys.readouterr().err
    assert main(["warp", "v.nii.gz", "o.nii.gz", "--handles", "h3.json", "--grid", "9"]) == 0
    assert "--grid" not in capsys.readouterr().err


def test_a_nifti_output_keeps_the_inputs_codes_units_and_description(files, stand_in):
    import nibabel as nib

    image = nib.Nifti1Image(np.zeros((10, 9, 8), np.int16), AFFINE)
    image.set_sform(AFFINE, code=4)
    image.set_qform(AFFINE, code=2)
    image.header.set_xyzt_units("mm", "sec")
    image.header["descrip"] = b"an atlas"
    nib.save(image, "mni.nii.gz")
    assert main(["warp", "mni.nii.gz", "out.nii.gz", "--handles", "h3.json", "--quiet"]) == 0
    header = nib.load("out.nii.gz").header
    assert (int(header["sform_code"]), int(header["qform_code"])) == (4, 2)
    assert header.get_xyzt_units() == ("mm", "sec") and header["descrip"] == b"an atlas"


def test_a_warped_t_map_keeps_its_intent_and_display_range(files):
    """End to end on the GPU, trilinear: a t statistic stays one of 12 degrees of freedom,
    and its values stay within the input's, so within its display range."""
    import nibabel as nib

    values = np.linspace(-4.5, 5.5, 10 * 9 * 8, dtype=np.float32).reshape(10, 9, 8)
    image = nib.Nifti1Image(values, AFFINE)
    image.header.set_intent("t test", (12.0,), name="t-map")
    image.header["cal_min"], image.header["cal_max"] = -4.5, 5.5
    image.header["aux_file"] = b"hot.lut"
    nib.save(image, "tmap.nii.gz")
    argv = ["warp", "tmap.nii.gz", "out.nii.gz", "--handles", "h3.json", "--quiet"]
    assert main([*argv, "--interpolation", "linear"]) == 0
    out = nib.load("out.nii.gz")
    assert out.header.get_intent() == ("t test", (12.0,), "t-map")
    assert (float(out.header["cal_min"]), float(out.header["cal_max"])) == (-4.5, 5.5)
    assert out.header["aux_file"] == b"hot.lut"
    warped = np.asanyarray(out.dataobj)
    assert not np.array_equal(warped, values)
    assert warped.min() >= -4.5 - 1e-6 and warped.max() <= 5.5 + 1e-6


def test_a_warped_displacement_field_is_written_as_plain_vectors(files, stand_in):
    """Its components are moved, not turned: no longer the field's displacements."""
    import nibabel as nib

    image = nib.Nifti1Image(np.zeros((10, 9, 8, 1, 3), np.float32), AFFINE)
    image.header.set_intent("displacement vector", name="warp")
    nib.save(image, "field.nii.gz")
    assert main(["warp", "field.nii.gz", "out.nii.gz", "--handles", "h3.json", "--quiet"]) == 0
    header = nib.load("out.nii.gz").header
    assert header["dim"][:6].tolist() == [5, 10, 9, 8, 1, 3]
    assert header.get_intent() == ("vector", (), "")


def test_a_time_series_is_warped_and_written_back_4d(files, stand_in):
    import nibabel as nib

    image = nib.Nifti1Image(np.zeros((10, 9, 8, 3), np.float32), AFFINE)
    image.header["pixdim"][4] = 2.0
    nib.save(image, "bold.nii.gz")
    assert main(["warp", "bold.nii.gz", "out.nii.gz", "--handles", "h3.json", "--quiet"]) == 0
    header = nib.load("out.nii.gz").header
    assert header["dim"][:6].tolist() == [4, 10, 9, 8, 3, 1] and header["pixdim"][4] == 2.0


def test_a_long_time_series_is_one_line_about_its_time_points(files, capsys):
    import nibabel as nib

    nib.save(nib.Nifti1Image(np.zeros((10, 9, 8, 7), np.int16), AFFINE), "bold.nii.gz")
    assert main(["warp", "bold.nii.gz", "o.nii.gz", "--handles", "h3.json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a time series of 7 time points (NIfTI's 4th axis)" in err
    assert "channels;" not in err and not Path("o.nii.gz").exists()


@pytest.mark.parametrize("handles", ["h2.json", "h3.json"])
@pytest.mark.parametrize(("axes", "what"), [("CYX", "3 channels"), ("TYX", "3 time points")])
def test_a_tiff_of_a_2d_images_channels_is_one_line_naming_its_axes(
    files, capsys, handles, axes, what
):
    import tifffile

    tifffile.imwrite("c.tif", np.zeros((3, 20, 24), np.uint8), imagej=True, metadata={"axes": axes})
    assert main(["warp", "c.tif", "o.tif", "--handles", handles]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"glmls warp: c.tif: a TIFF of axes {axes} (3, 20, 24), {what} of a 2D image, not a "
        "volume (a stack of slices: axis Z, or pages without axes)\n"
    )


def test_elastix_index_files_on_a_mesh_are_refused(files, stand_in, capsys):
    """Voxel indices need a volume's geometry to become coordinates; a mesh has none, so an
    elastix pair of ``index`` files is refused (``point`` files are its coordinates)."""
    src, dst = glmls.data.phantom_handles()
    for kind in ("index", "point"):
        for name, points in (("moving.pts", src), ("fixed.pts", dst)):
            write_elastix_points(files / name, kind, points)
        argv = ["warp", "sphere.ply", "o.ply", "--handles", "moving.pts", "--targets", "fixed.pts"]
        capsys.readouterr()
        if kind == "index":
            assert main(argv) == 2
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and "voxel indices" in err and "mesh" in err, err
            assert not (files / "o.ply").exists()
        else:
            assert main(argv) == 0
    for command in ("analyze",):
        argv = [command, "sphere.ply", "--handles", "moving.pts", "--targets", "fixed.pts"]
        (files / "moving.pts").write_text(
            (files / "moving.pts").read_text().replace("point", "index", 1)
        )
        (files / "fixed.pts").write_text(
            (files / "fixed.pts").read_text().replace("point", "index", 1)
        )
        capsys.readouterr()
        assert main([*argv, "--out", "report"]) == 2
        assert "voxel indices" in capsys.readouterr().err


def test_3d_handles_on_a_tiff_of_one_page_say_why_it_is_an_image(files, capsys):
    """A volume of one slice saved as an ImageJ stack is a TIFF of one page, which glmls
    reads as an image: the refusal of its 3D handles says so, and where such a volume goes."""
    import tifffile

    tifffile.imwrite(files / "one.tif", np.zeros((1, 8, 9), np.uint8), imagej=True)
    assert main(["warp", "one.tif", "o.tif", "--handles", "h3.json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a TIFF of one page is an image" in err and ".npy" in err
    assert main(["warp", "a.png", "o.png", "--handles", "h3.json"]) == 2
    assert "TIFF" not in capsys.readouterr().err


def test_mesh_colours_are_carried_and_what_is_not_is_one_line(files, stand_in, capsys):
    sphere = glmls.data.sphere()
    colors = np.random.default_rng(3).integers(0, 256, (len(sphere.vertices), 3), np.uint8)
    glmls.write_mesh(files / "col.ply", glmls.Mesh(sphere.vertices, sphere.faces, colors=colors))
    for out in ("out.ply", "out.obj"):
        assert main(["warp", "col.ply", out, "--handles", "h3.json"]) == 0
        assert "does not carry" not in capsys.readouterr().err
        assert_array_equal(glmls.read_mesh(files / out).colors, colors)
    assert main(["warp", "col.ply", "out.stl", "--handles", "h3.json"]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert [x for x in lines if "carry" in x] == [
        "warp: out.stl does not carry the input's vertex colours"
    ]
    # texture coordinates: a PLY's s and t beside x, y, z and the colours
    text = ["ply", "format ascii 1.0", f"element vertex {len(sphere.vertices)}"]
    text += [f"property float {n}" for n in ("x", "y", "z", "s", "t")]
    text += [f"property uchar {n}" for n in ("red", "green", "blue")]
    text += [f"element face {len(sphere.faces)}", "property list uchar int vertex_indices"]
    text += ["end_header"]
    text += [
        " ".join(map(str, [*v, 0.5, 0.5, *c]))
        for v, c in zip(sphere.vertices.tolist(), colors.tolist(), strict=True)
    ]
    text += [" ".join(map(str, [3, *f])) for f in sphere.faces.tolist()]
    (files / "tex.ply").write_text("\n".join(text) + "\n")
    assert main(["warp", "tex.ply", "t.ply", "--handles", "h3.json"]) == 0
    assert "carry" not in capsys.readouterr().err
    assert_array_equal(glmls.read_mesh(files / "t.ply").colors, colors)
    assert_array_equal(glmls.read_mesh(files / "t.ply").uv, np.full((len(colors), 2), 0.5))
    assert main(["warp", "tex.ply", "t.stl", "--handles", "h3.json"]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert [x for x in lines if "carry" in x] == [
        "warp: t.stl does not carry the input's vertex colours, texture coordinates"
    ]
    assert main(["warp", "tex.ply", "t.stl", "--handles", "h3.json", "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_mesh_texture_coordinates_are_carried_by_obj_and_named_where_not(files, stand_in, capsys):
    """An OBJ of texture coordinates per face corner, with a seam (vertex 2 has vt 2 in one
    face and vt 4 in the other) and materials: OBJ carries the coordinates exactly, PLY
    cannot (one per vertex) and STL holds none; each says so in its one line."""
    (files / "tex.obj").write_text(
        "mtllib tex.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
        "vt 0.1 0.2\nvt 0.30000000000000004 0.2\nvt 0.1 0.7\nvt 0.9 0.6\nvt 1 1\n"
        "usemtl skin\nf 1/1 2/2 3/3\nf 2/4/1 4/-1/1 3/3/1\nvn 0 0 1\n"
    )
    mesh = glmls.read_mesh(files / "tex.obj")
    for out, carried in (
        ("out.obj", ""),
        ("out.ply", "texture coordinates (a vertex has several, at seams: PLY holds one "
         "per vertex), "),
        ("out.stl", "texture coordinates, "),
    ):  # fmt: skip
        assert main(["warp", "tex.obj", out, "--handles", "h3.json"]) == 0
        lines = [x for x in capsys.readouterr().err.splitlines() if "carry" in x]
        assert lines == [
            f"warp: {out} does not carry the input's {carried}materials, "
            "normals (not on every face)"
        ]
    back = glmls.read_mesh(files / "out.obj")
    assert_array_equal(back.uv, mesh.uv)
    assert_array_equal(back.face_uv, [[0, 1, 2], [3, 4, 2]])
    src, dst = glmls.data.phantom_handles()
    assert_allclose(back.vertices, mesh.vertices + (dst - src).mean(axis=0), rtol=0, atol=1e-12)
    assert glmls.read_mesh(files / "out.ply").uv is None


def test_mesh_normals_turn_with_a_rigid_warp_and_stl_says_it_drops_them(tmp_path, capsys):
    """A mesh of normals of its own (not its faces': random directions, one zero), moved by
    handles that a rotation and a translation take to their targets: the rigid MLS is that
    motion, and the written normals are the input's turned by it (unit), within 1e-4; PLY
    and OBJ carry them, STL names them as what it does not carry."""
    rng = np.random.default_rng(7)
    sphere = glmls.data.sphere()
    normals = rng.normal(0, 1, sphere.vertices.shape) * rng.uniform(0.5, 3, (162, 1))
    normals[5] = 0.0
    angle = 0.7
    turn = np.array(
        [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    )
    src = sphere.vertices[::8]
    dst = src @ turn.T + [3.0, -2.0, 1.5]
    (tmp_path / "h.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    glmls.write_mesh(
        tmp_path / "in.obj", glmls.Mesh(sphere.vertices, sphere.faces, normals=normals)
    )
    expected = normals @ turn.T / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    for out in ("out.obj", "out.ply"):
        argv = ["warp", str(tmp_path / "in.obj"), str(tmp_path / out), "--handles"]
        assert main([*argv, str(tmp_path / "h.json"), "--transform", "rigid"]) == 0
        assert "carry" not in capsys.readouterr().err
        written = glmls.read_mesh(tmp_path / out)
        assert_allclose(written.vertices, sphere.vertices @ turn.T + [3, -2, 1.5], atol=1e-4)
        assert np.abs(written.normals - expected).max() < 1e-4
        assert (written.normals[5] == 0).all()
    argv = ["warp", str(tmp_path / "in.obj"), str(tmp_path / "out.stl"), "--handles"]
    assert main([*argv, str(tmp_path / "h.json")]) == 0
    lines = [x for x in capsys.readouterr().err.splitlines() if "carry" in x]
    assert lines == [f"warp: {tmp_path / 'out.stl'} does not carry the input's normals"]
    # an input without normals of its own gains none
    glmls.write_mesh(tmp_path / "plain.obj", sphere)
    argv = ["warp", str(tmp_path / "plain.obj"), str(tmp_path / "plain.ply"), "--handles"]
    assert main([*argv, str(tmp_path / "h.json")]) == 0
    assert glmls.read_mesh(tmp_path / "plain.ply").normals is None


def test_a_3d_csv_is_read_by_its_header_and_a_lacking_column_is_one_line(files, stand_in, capsys):
    src, dst = glmls.data.phantom_handles()
    rows = ["name,dst_x,dst_y,dst_z,src_x,src_y,src_z"]
    for k, (p, q) in enumerate(zip(src.tolist(), dst.tolist(), strict=True)):
        rows.append(f"P{k},{','.join(map(repr, [*q, *p]))}")
    Path("h3.csv").write_text("\n".join(rows) + "\n")
    assert main(["warp", "v.nii.gz", "by_name.nii.gz", "--handles", "h3.csv", "--quiet"]) == 0
    assert main(["warp", "v.nii.gz", "by_json.nii.gz", "--handles", "h3.json", "--quiet"]) == 0
    assert [c[1] for c in stand_in.calls if c[0] == "MLS"] == [(len(src), 3)] * 2
    by_name, by_json = (glmls.read_volume(f"by_{k}.nii.gz").data for k in ("name", "json"))
    assert_array_equal(by_name, by_json)
    capsys.readouterr()
    Path("h3.csv").write_text("src_x,src_y,src_z,dst_x,dst_y\n1,2,3,4,5\n")
    assert main(["warp", "v.nii.gz", "o.nii.gz", "--handles", "h3.csv"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "h3.csv: line 1: the header lacks the column dst_z" in err
