"""The public API's habits beyond the warps: the exceptions a docstring's Raises names are
glmls's own, exported and documented; the configuration dataclasses take keyword
arguments only; the window's events and controller, and the analyses, refuse a bad value
naming it before any work."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

import glmls
from glmls.analysis import cell_jacobians, run_jobs
from glmls.app import Controller, Move, Press, Release, Scroll, Settings, Wait
from glmls.app.volume_controller import VolumeSettings
from glmls.gl import PipelineOptions
from glmls.volume import SlabOptions, warp_volume

SRC = [[1.0, 1.0], [8.0, 1.0], [1.0, 6.0]]


@pytest.mark.parametrize(
    ("name", "base"),
    [("NoDisplayError", RuntimeError), ("DistributedUnavailableError", ImportError)],
)
def test_the_raised_exceptions_are_glmls_s_own(name, base):
    error = getattr(glmls, name)
    assert name in glmls.__all__ and issubclass(error, base)
    assert error is getattr(glmls.errors, name)


def test_run_jobs_names_the_exported_error():
    assert "glmls.DistributedUnavailableError" in inspect.getdoc(run_jobs)


def test_every_subpackage_is_in_all():
    assert {"analysis", "augment", "data", "files", "gl", "reference", "volume"} <= set(
        glmls.__all__
    )


@pytest.mark.parametrize("options", [PipelineOptions, SlabOptions, Settings, VolumeSettings])
def test_the_configuration_takes_keywords_only(options):
    first = dataclasses.fields(options)[0]
    assert first.kw_only
    with pytest.raises(TypeError, match="positional"):
        options(getattr(options(), first.name))


def test_segments_and_options_are_keywords():
    c = Controller(SRC, SRC, (10, 12))
    with pytest.raises(TypeError, match="positional"):
        c.set_handles(SRC, SRC, None, None)
    c.set_handles(SRC, SRC, src_segments=None, dst_segments=None)
    assert (
        inspect.signature(warp_volume).parameters["options"].kind is inspect.Parameter.KEYWORD_ONLY
    )


@pytest.mark.parametrize(
    ("shape", "error", "message"),
    [
        ((0, 0), ValueError, r"shape must be \(H, W\) with H, W >= 1, got \(0, 0\)"),
        ("abc", TypeError, r"shape must be \(H, W\) integers, got 'abc'"),
        (None, TypeError, r"shape must be \(H, W\) integers, got None"),
        ((10.0, 12), TypeError, r"shape must be \(H, W\) integers"),
    ],
)
def test_the_controller_s_shape_is_named(shape, error, message):
    with pytest.raises(error, match=message):
        Controller(SRC, SRC, shape)


@pytest.mark.parametrize(
    ("make", "error", "message"),
    [
        (
            lambda: Wait(-1),
            ValueError,
            r"Wait\.frames must be an integer from 0 to 1000000, got -1",
        ),
        (lambda: Wait("x"), TypeError, r"Wait\.frames must be an integer"),
        (lambda: Wait(2.0), TypeError, r"Wait\.frames must be an integer"),
        (lambda: Press("a", 0), TypeError, r"Press\.x must be a finite number, got 'a'"),
        (lambda: Move(0, float("nan")), ValueError, r"Move\.y must be a finite number"),
        (lambda: Release(None, 0), TypeError, r"Release\.x must be a finite number"),
        (lambda: Scroll(1, 2, float("inf")), ValueError, r"Scroll\.dy must be a finite number"),
    ],
)
def test_an_event_s_bad_value_is_named(make, error, message):
    with pytest.raises(error, match=message):
        make()


def test_events_take_numpy_numbers():
    assert Press(np.float32(2.5), np.int64(3)).x == 2.5
    assert Wait(np.int64(4)).frames == 4


def test_cell_jacobians_names_a_deformation_that_is_no_function():
    with pytest.raises(TypeError, match=r"m must be a glmls.MLS or a function of points, got str"):
        cell_jacobians("m", (4, 4, 4))
