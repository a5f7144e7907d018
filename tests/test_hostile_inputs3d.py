"""Hostile input to the public 3D surface (meshes, volumes and their files, handle files):
each gets a ValueError/TypeError naming the bad value, or a documented result; never an
error from deep inside, a file that reads back wrong, or two lines where the command line
promises one."""

from __future__ import annotations

import re

import numpy as np
import pytest

import glmls

TRIANGLE = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])


# -- mesh files: float32 formats ----------------------------------------------------------


@pytest.mark.parametrize("suffix", [".ply", ".stl"])
@pytest.mark.parametrize("value", [1e39, -1e300])
def test_vertices_beyond_float32_are_refused_before_a_float32_file_is_written(
    tmp_path, suffix, value
):
    # PLY and STL hold float32: such a vertex was written as inf, a file read_mesh refuses
    vertices = TRIANGLE.copy()
    vertices[2, 1] = value
    path = tmp_path / f"big{suffix}"
    with pytest.raises(ValueError, match=r"big\.(ply|stl): vertices beyond float32's range.*row 2"):
        glmls.write_mesh(path, vertices, faces=[[0, 1, 2]])
    assert not path.exists()
    # float32's largest value itself is written, and read back as it is
    vertices[2, 1] = np.sign(value) * float(np.finfo(np.float32).max)
    glmls.write_mesh(path, vertices, faces=[[0, 1, 2]])
    back = glmls.read_mesh(path)
    np.testing.assert_array_equal(np.sort(back.vertices, axis=0), np.sort(vertices, axis=0))


def test_obj_holds_vertices_beyond_float32_exactly(tmp_path):
    vertices = TRIANGLE.copy()
    vertices[2, 1] = 1e300
    glmls.write_mesh(tmp_path / "big.obj", vertices, faces=[[0, 1, 2]])
    np.testing.assert_array_equal(glmls.read_mesh(tmp_path / "big.obj").vertices, vertices)


def test_texture_coordinates_beyond_float32_are_refused_for_ply(tmp_path):
    uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1e39]]
    with pytest.raises(ValueError, match=r"texture coordinates beyond float32's range.*row 2"):
        glmls.write_mesh(
            tmp_path / "uv.ply", TRIANGLE, faces=[[0, 1, 2]], uv=uv, face_uv=[[0, 1, 2]]
        )
    assert not (tmp_path / "uv.ply").exists()


# -- file functions given no path ---------------------------------------------------------

VOLUME = np.zeros((2, 3, 4), np.uint8)
HANDLES3 = [[1.0, 2.0, 3.0]]


@pytest.mark.parametrize(
    "call",
    [
        lambda path: glmls.read_volume(path),
        lambda path: glmls.write_volume(path, VOLUME),
        lambda path: glmls.read_mesh(path),
        lambda path: glmls.write_mesh(path, TRIANGLE, faces=[[0, 1, 2]]),
        lambda path: glmls.files.read_handles(path),
        lambda path: glmls.files.read_handle_set(path),
        lambda path: glmls.files.read_points(path),
        lambda path: glmls.files.write_handles(path, HANDLES3, HANDLES3),
        lambda path: glmls.imread(path),
        lambda path: glmls.imwrite(path, VOLUME[0]),
        lambda path: glmls.files.read_icc_profile(path),
        lambda path: glmls.files.atomic_write(path).__enter__(),
    ],
    ids=[
        "read_volume",
        "write_volume",
        "read_mesh",
        "write_mesh",
        "read_handles",
        "read_handle_set",
        "read_points",
        "write_handles",
        "imread",
        "imwrite",
        "read_icc_profile",
        "atomic_write",
    ],
)
@pytest.mark.parametrize("path", [None, 3.5, VOLUME], ids=["None", "float", "array"])
def test_a_path_that_is_no_path_is_a_type_error_naming_it(call, path):
    # an array in the path's place: write_volume(volume, path), its arguments swapped
    name = type(path).__name__
    with pytest.raises(
        TypeError, match=rf"^path must be a file path \(str or os\.PathLike\), got .*\({name}\)$"
    ):
        call(path)


def test_a_targets_file_that_is_no_path_is_a_type_error_naming_it(tmp_path):
    (tmp_path / "moving.pts").write_text("point\n1\n1 2 3\n")
    with pytest.raises(TypeError, match=r"^dst must be a file path .*got 7 \(int\)$"):
        glmls.files.read_handles(tmp_path / "moving.pts", dst=7)


@pytest.mark.parametrize("kind", [str, bytes])
def test_paths_of_str_and_bytes_are_read(tmp_path, kind):
    path = tmp_path / "v.npy"
    np.save(path, VOLUME)
    name = str(path) if kind is str else bytes(path)
    np.testing.assert_array_equal(glmls.read_volume(name).data, VOLUME)


@pytest.mark.parametrize("kind", [str, bytes])
def test_images_take_paths_of_str_and_bytes(tmp_path, kind):
    path = tmp_path / "grey.png"
    name = str(path) if kind is str else bytes(path)
    glmls.imwrite(name, VOLUME[1] + 7)
    np.testing.assert_array_equal(glmls.imread(name), VOLUME[1] + 7)
    assert glmls.files.read_icc_profile(name) is None


def test_a_folder_is_no_image_to_read_a_profile_from(tmp_path):
    with pytest.raises(ValueError, match=r": a folder, not an image file$"):
        glmls.files.read_icc_profile(tmp_path)


# -- handles of three coordinates in the wrong arrangement -------------------------------


@pytest.mark.parametrize(
    ("src", "message"),
    [
        # a batch's (1, N, 3): was asked for (N, 2) rows, as if 2D
        (np.zeros((1, 4, 3)), r"src must have shape \(N, 3\) as \(x, y, z\) rows, got \(1, 4, 3\)"),
        # ragged rows of (x, y, z): was asked for (N, 2) rows too
        ([[0, 0, 0], [1, 1]], r"src must have shape \(N, 3\) .*rows of different lengths"),
    ],
)
def test_3d_handles_in_a_wrong_shape_are_named_as_3d(src, message):
    with pytest.raises(ValueError, match=message):
        glmls.MLS(src, src)
    with pytest.raises(ValueError, match=message):
        glmls.warp(VOLUME, src, src)


def test_2d_handles_in_a_wrong_shape_keep_the_2d_message():
    with pytest.raises(ValueError, match=r"src must have shape \(N, 2\) as \(x, y\) rows"):
        glmls.MLS(np.zeros((1, 4, 2)), np.zeros((1, 4, 2)))
    with pytest.raises(ValueError, match=r"src must have shape \(N, 2\) as \(x, y\) rows"):
        glmls.MLS([[0, 0], [1, 1, 1]], [[0, 0], [1, 1, 1]])


# -- NIfTI affines the header's float32 cannot hold ---------------------------------------


@pytest.mark.parametrize(
    ("options", "message"),
    [
        # 1e-50 is 0 in float32: the file's affine had a voxel axis of length 0
        ({"spacing": (1e-50, 1.0, 1.0)}, r"in float32, in which its voxel axes .* length 0"),
        ({"affine": np.diag([1.0, 1.0, 1e-50, 1.0])}, r"in float32, in which its voxel axes"),
        # 1e39 is inf in float32: the file's affine was not finite
        ({"spacing": (1e39, 1.0, 1.0)}, r"beyond float32's range .* its largest is 1e\+39"),
        (
            {"affine": np.array([[1, 0, 0, 1e39], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])},
            r"beyond float32's range",
        ),
        # NIfTI holds the 3 x 4 above the last row: this one was dropped, another affine
        (
            {"affine": np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0.5, 0, 0, 1.0]])},
            r"last row must be \(0, 0, 0, 1\), as NIfTI holds it; got \[0\.5, 0\.0, 0\.0, 1\.0\]",
        ),
    ],
)
@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_an_affine_nifti_cannot_hold_is_refused_before_writing(tmp_path, options, message, suffix):
    path = tmp_path / f"v{suffix}"
    with pytest.raises(ValueError, match=rf"^{tmp_path}/v\.nii(\.gz)?: .*{message}"):
        glmls.write_volume(path, VOLUME, **options)
    assert not path.exists()


@pytest.mark.parametrize("size", [1e-40, 3e38])
def test_voxel_sizes_float32_holds_are_written_and_read_back(tmp_path, size):
    # a subnormal float32 and one next to its largest: written, read back as float32 has them
    glmls.write_volume(tmp_path / "v.nii", VOLUME, spacing=(size, 1.0, 1.0))
    back = glmls.read_volume(tmp_path / "v.nii")
    assert back.spacing == (float(np.float32(size)), 1.0, 1.0)
    np.testing.assert_array_equal(back.data, VOLUME)


# -- a volume's shape of None -------------------------------------------------------------


@pytest.mark.parametrize("method", ["bounds", "coordinate_map"])
def test_a_shape_of_none_is_named(gl, method):
    # None passed the shape check (None is "no output_shape" there) and failed inside
    with glmls.MLS([[0.0, 0, 0]], [[1.0, 0, 0]]) as m:
        with pytest.raises(TypeError, match=r"^shape must be \(D, H, W\) integers, got None$"):
            getattr(m, method)(None)
        assert getattr(m, method)((2, 3, 4)) is not None


# -- volume results beyond the machine's memory --------------------------------------------

HANDLES3 = np.array([[2.0, 2, 2], [13, 2, 2], [2, 13, 2], [2, 2, 13]])
VOLUME_RESULTS = {
    "volume_error_field": glmls.analysis.volume_error_field,
    "volume_error_field-grid": lambda m, shape: glmls.analysis.volume_error_field(m, shape, grid=4),
    "cell_jacobians": glmls.analysis.cell_jacobians,
    "cell_jacobians-grid": lambda m, shape: glmls.analysis.cell_jacobians(m, shape, grid=4),
}


@pytest.mark.parametrize("call", VOLUME_RESULTS.values(), ids=VOLUME_RESULTS.keys())
@pytest.mark.parametrize("on_gpu", [False, True])
def test_a_volume_result_beyond_the_memory_is_refused_up_front(request, monkeypatch, call, on_gpu):
    # (4096,) * 3 was numpy's MemoryError; a volume beyond a small machine's memory was
    # allocated (overcommitted) and filled: swapping, or the out-of-memory kill
    if on_gpu:
        m = glmls.MLS(HANDLES3, HANDLES3 + 1, ctx=request.getfixturevalue("gl"))
    else:
        m = glmls.analysis.ReferenceDeformation(HANDLES3, HANDLES3 + 1)
    with m:
        for shape in ((4096,) * 3, (10**6, 10**6, 10**6)):
            with pytest.raises(ValueError, match=r"needs [\d,]+ bytes .* more than this machine"):
                call(m, shape)
        monkeypatch.setattr(glmls.core.config, "physical_memory", lambda: 2**16)
        with pytest.raises(ValueError, match=r"of shape \(40, 50, 60\).* more than this machine"):
            call(m, (40, 50, 60))
        assert call(m, (4, 5, 6)) is not None  # what fits is computed


# -- mesh faces that name no vertex --------------------------------------------------------

TETRAHEDRON = np.array([[0.0, 0, 0], [4, 0, 0], [0, 4, 0], [0, 0, 4]])


@pytest.mark.parametrize(
    ("faces", "message"),
    [
        ([[0, 1, 2], [0, 1, 4]], r"must index vertices 0\.\.3; face 1 is \[0, 1, 4\]$"),
        (
            [[0, 1, 2], [0, -1, 3], [5, 1, 2]],
            r"must index vertices 0\.\.3; face 1 is \[0, -1, 3\] \(2 such faces\)$",
        ),
        (
            np.array([[0, 1, 2**63]], np.uint64),
            r"must index vertices 0\.\.3; face 0 is \[0, 1, 9223372036854775808\]$",
        ),
    ],
)
def test_a_face_out_of_range_is_named_by_its_number(gl, faces, message):
    # the message gave the faces' overall range ("outside 0..3"), not which face was bad
    with glmls.MLS(HANDLES3, HANDLES3 + 1, ctx=gl) as m:
        with pytest.raises(ValueError, match=f"^mesh faces {message}"):
            m.deform((TETRAHEDRON, faces))
        with pytest.raises(ValueError, match=f"^faces {message}"):
            m.deform(glmls.Mesh(TETRAHEDRON, faces))


@pytest.mark.parametrize(
    ("faces", "error", "message"),
    [
        ([[0, 1, 2], [0, 1]], ValueError, r"\(F, 3\) integer vertex indices: rows of 3$"),
        ([[0, 1, 2, 3]], ValueError, r"\(F, 3\) integer vertex indices, got shape \(1, 4\)"),
        ([[0, 1, 2.5]], TypeError, r"integer vertex indices, got dtype float64"),
    ],
)
def test_faces_of_another_arity_or_type_are_named(gl, faces, error, message):
    # ragged rows were numpy's "setting an array element with a sequence"
    with glmls.MLS(HANDLES3, HANDLES3 + 1, ctx=gl) as m:
        with pytest.raises(error, match=f"^mesh faces must be {message}"):
            m.deform((TETRAHEDRON, faces))


def test_a_2d_mls_names_the_handles_whatever_the_faces(gl):
    src = np.array([[0.0, 0], [5, 0], [0, 5]])
    with glmls.MLS(src, src + 1, ctx=gl) as m:
        with pytest.raises(ValueError, match=r"deform needs a 3D MLS"):
            m.deform((TETRAHEDRON, [[0, 1, 9]]))


# -- elastix point files that are no file --------------------------------------------------


@pytest.fixture
def pts_files(tmp_path, monkeypatch):
    """An image, a pair of elastix point files, an empty one and a folder named like one."""
    monkeypatch.chdir(tmp_path)
    from PIL import Image

    Image.fromarray(np.zeros((24, 24), np.uint8)).save("image.png")
    (tmp_path / "src.pts").write_text("point\n3\n2 2\n20 3\n4 20\n")
    (tmp_path / "dst.pts").write_text("point\n3\n3 2\n20 4\n4 21\n")
    (tmp_path / "empty.pts").write_text("")
    (tmp_path / "folder.pts").mkdir()
    return tmp_path


PTS_FAULTS = [
    ("folder.pts", None, "folder.pts: a folder, not a file"),
    ("folder.pts", "dst.pts", "folder.pts: a folder, not a file"),
    ("missing.pts", None, "missing.pts: no such file"),
    ("missing.pts", "dst.pts", "missing.pts: no such file"),
    ("src.pts", "missing.pts", "missing.pts: no such file"),
    ("src.pts", "folder.pts", "folder.pts: a folder, not a file"),
    ("empty.pts", "dst.pts", "empty.pts: content: expected 'index' or 'point'"),
    ("src.pts", "empty.pts", "empty.pts: content: expected 'index' or 'point'"),
    ("src.pts", None, "src.pts: content: an elastix point file holds the sources only"),
]


@pytest.mark.parametrize(("src", "dst", "message"), PTS_FAULTS)
def test_a_pts_file_that_is_no_file_is_named(pts_files, src, dst, message):
    # a folder or a missing file given without targets was reported as the missing targets
    from glmls.files.landmarks import handle_dimension, read_handle_set, read_handles

    for read in (read_handles, read_handle_set, handle_dimension):
        with pytest.raises(glmls.InputFileError, match=f"^{re.escape(str(pts_files))}/{message}"):
            read(pts_files / src, dst=None if dst is None else pts_files / dst)


@pytest.mark.parametrize(("src", "dst", "message"), PTS_FAULTS)
@pytest.mark.parametrize("command", ["warp", "analyze"])
def test_the_command_line_names_a_pts_file_in_one_line(
    pts_files, capsys, command, src, dst, message
):
    from glmls.cli.main import main

    args = ["image.png", "out.png"] if command == "warp" else ["image.png", "--out", "report"]
    targets = [] if dst is None else ["--targets", dst]
    assert main([command, *args, "--handles", src, *targets]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"glmls {command}: ") and err.count("\n") == 1 and message in err, err
    assert not (pts_files / "out.png").exists() and not (pts_files / "report").exists()


# -- NaN and infinite voxels of a float volume ---------------------------------------------

FLOAT_VOLUME = np.random.default_rng(6).random((6, 7, 8)).astype(np.float32)
BAD_VOXEL = (3, 3, 4)
VOLUME_SRC = np.array([[0.0, 0, 0], [7, 0, 0], [0, 6, 0], [0, 0, 5], [4, 3, 2]])
VOLUME_DST = VOLUME_SRC + [[0, 0, 0], [0.3, 0.2, 0], [0, -0.3, 0.2], [0.2, 0, 0], [0.4, -0.3, 0.2]]


def volume_with(value: float, dst: np.ndarray, **options) -> np.ndarray:
    volume = FLOAT_VOLUME.copy()
    volume[BAD_VOXEL] = value
    return glmls.warp(volume, VOLUME_SRC, dst, **options)


@pytest.mark.parametrize("method", ["backward", "quads"])
@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_nan_or_infinite_voxel_reaches_only_the_voxels_that_weigh_it(
    gl, method, interpolation, bad
):
    options = {"method": method, "interpolation": interpolation}
    volume = FLOAT_VOLUME.copy()
    volume[BAD_VOXEL] = bad
    # the identity gives it back bit for bit: a voxel of weight 0 takes no part in a blend
    np.testing.assert_array_equal(volume_with(bad, VOLUME_SRC, **options), volume)
    out = volume_with(bad, VOLUME_DST, **options)
    low, high = volume_with(0.0, VOLUME_DST, **options), volume_with(1e6, VOLUME_DST, **options)
    depends = low != high
    spoilt = ~np.isfinite(out)
    assert depends.any()
    np.testing.assert_array_equal(spoilt, depends)  # NaN or infinite where it weighs, only
    np.testing.assert_array_equal(out[~spoilt], low[~spoilt])
