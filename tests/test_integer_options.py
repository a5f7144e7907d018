"""One rule for every integer option, 2D, 3D and batch alike: Python and numpy integers (and
0-d integer arrays) are integers; a float, even a whole one (``2.0``), a bool, a string or
None is a ``TypeError``, an integer out of range a ``ValueError``, both naming the option and
the value in the same words wherever the option is the same."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.augment import Augment
from glmls.core.config import check_integer, counted, is_integer
from glmls.gl import PipelineOptions
from glmls.volume import SlabOptions, VolumeOptions

IMAGE = np.zeros((4, 6), np.uint8)
VOLUME = np.zeros((4, 5, 6), np.uint8)
SRC3 = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])


@pytest.fixture
def mls2(gl):
    with glmls.MLS([[0, 0], [5, 3]], [[1, 0], [6, 3]], ctx=gl) as m:
        yield m


@pytest.fixture
def mls3(gl):
    with glmls.MLS(SRC3, SRC3 + [1, 0, 0], ctx=gl) as m:
        yield m


@pytest.mark.parametrize("value", [2, np.int64(2), np.uint8(2), np.array(2)])
def test_integers_are_integers(value):
    assert is_integer(value) and check_integer("n", value, 1) == 2


@pytest.mark.parametrize("value", [2.0, np.float64(2), np.float16(2), True, np.True_, "2", None])
def test_other_types_are_no_integers(value):
    with pytest.raises(TypeError, match=r"n must be an integer >= 1, got "):
        check_integer("n", value, 1)


@pytest.mark.parametrize("value", [2.0, np.float32(2), True, np.array(2.0)])
def test_a_whole_float_grid_is_refused_alike_everywhere(mls2, mls3, value):
    calls = {
        "pixels": [
            lambda: mls2.warp(IMAGE, grid=value),
            lambda: mls2.bounds(IMAGE.shape, grid=value),
            lambda: mls2.coordinate_map(IMAGE.shape, grid=value),
            lambda: glmls.WarpOptions(grid=value),
            lambda: glmls.warp_batch([IMAGE], [[[0, 0]]], [[[1, 0]]], grid=value),
        ],
        "voxels": [
            lambda: mls3.warp(VOLUME, grid=value),
            lambda: mls3.bounds(VOLUME.shape, grid=value),
            lambda: mls3.coordinate_map(VOLUME.shape, grid=value),
            lambda: VolumeOptions(grid=value),
        ],
    }
    for unit, made in calls.items():
        message = f"grid must be an integer from 1 to 1048576 ({unit}), got {value!r}"
        for call in made:
            with pytest.raises(TypeError) as error:
                call()
            assert str(error.value) == message


@pytest.mark.parametrize("dims", [(5.0, 5), (5, np.float64(6)), (True, 5)])
def test_an_output_shape_of_floats_or_bools_is_refused_in_2d_and_3d(mls2, mls3, dims):
    with pytest.raises(TypeError, match=r"output_shape must be \(H, W\) integers"):
        mls2.warp(IMAGE, output_shape=dims)
    with pytest.raises(TypeError, match=r"output_shape must be \(D, H, W\) integers"):
        mls3.warp(VOLUME, output_shape=(*dims, 6))
    with pytest.raises(TypeError, match=r"shape must be \(H, W\) integers"):
        mls2.bounds(dims)


def test_numpy_integer_sizes_are_taken(mls2, mls3):
    out = mls2.warp(IMAGE, output_shape=(np.int64(5), np.array(7)), grid=np.uint8(2))
    assert out.shape == (5, 7)
    assert mls3.warp(VOLUME, output_shape=np.array([3, 4, 5]), grid=np.int32(1)).shape == (3, 4, 5)


@pytest.mark.parametrize("origin", [(True, 0), (0, np.False_), ("1", 0), (1j, 0)])
def test_an_origin_of_no_real_numbers_is_a_type_error(mls2, mls3, origin):
    with pytest.raises(TypeError, match=r"origin must be \(x0, y0\) real numbers, got \("):
        mls2.warp(IMAGE, origin=origin)
    with pytest.raises(TypeError, match=r"origin must be \(x0, y0, z0\) real numbers, got \("):
        mls3.warp(VOLUME, origin=(*origin, 0))


@pytest.mark.parametrize("method", [None, 3])
def test_a_method_that_is_no_string_is_a_type_error_in_2d_and_3d(mls2, mls3, method):
    for call in (
        lambda: mls2.warp(IMAGE, method=method),
        lambda: mls2.coordinate_map(IMAGE.shape, method=method),
        lambda: mls3.warp(VOLUME, method=method),
    ):
        with pytest.raises(TypeError, match=rf"method must be a string, one of .*; got {method}"):
            call()


def test_the_sizes_of_the_internal_paths_follow_the_rule():
    with pytest.raises(TypeError, match=r"band_bytes must be an integer >= 1, got 4096.0"):
        PipelineOptions(band_bytes=4096.0)
    with pytest.raises(TypeError, match="compute_quads must be True or False"):
        PipelineOptions(compute_quads=1)
    with pytest.raises(TypeError, match=r"slab_bytes must be an integer >= 64, got True"):
        SlabOptions(slab_bytes=True)
    with pytest.raises(ValueError, match=r"slab_bytes must be an integer >= 64, got 8"):
        SlabOptions(slab_bytes=8)
    assert SlabOptions(slab_bytes=np.int64(4096)).slab_bytes == 4096


def test_the_augment_counts_follow_the_rule():
    with pytest.raises(TypeError, match=r"rows must be an integer >= 2, got 3.0"):
        Augment("grid", rows=3.0)
    with pytest.raises(TypeError, match=r"seed must be an integer >= 0, got 1.0"):
        Augment("grid", seed=1.0)
    with pytest.raises(ValueError, match=r"seed must be an integer >= 0, got -1"):
        Augment("grid", seed=-1)


def test_a_huge_volume_output_is_refused_before_anything_is_allocated(mls3):
    with pytest.raises(ValueError, match=r"output_shape must have D, H, W <= 1e\+06"):
        mls3.warp(VOLUME, output_shape=(10**9, 5, 5))
    with pytest.raises(ValueError, match=r"shape must have D, H, W <= 1e\+06"):
        mls3.bounds((10**9, 5, 5))
    with pytest.raises(ValueError, match="more than this machine's memory"):
        mls3.warp(VOLUME, output_shape=(10**6, 2048, 2048))


def test_the_volume_coordinate_map_refuses_what_it_would_not_use(mls3):
    for name, value in (("interpolation", "linear"), ("background", 3)):
        with pytest.raises(TypeError, match=f"coordinate_map\\(\\) takes no {name}"):
            mls3.coordinate_map(VOLUME.shape, **{name: value})
    with pytest.raises(ValueError, match="unknown method 'quads'; choose one of backward"):
        mls3.coordinate_map(VOLUME.shape, method="quads")
    points, _, _ = mls3.coordinate_map(VOLUME.shape, method="backward")
    assert points.shape == (*VOLUME.shape, 3)


def test_counts_in_messages_agree_with_their_nouns(gl):
    assert counted(1, "pixel") == "1 pixel" and counted(2, "pixel") == "2 pixels"
    tall = np.zeros((glmls.gl.WarpPipeline.of(gl).max_image_size + 1, 1), np.uint8)
    with glmls.MLS([[0, 0]], [[0, 0]], ctx=gl) as m, pytest.raises(ValueError) as error:
        m.warp(tall)
    assert "image 1 pixel wide and" in str(error.value)
    with pytest.raises(ValueError, match="indices holds 1 value for 2 images"):
        Augment("grid").draw([(8, 8), (8, 8)], indices=[0])
