"""One :class:`glmls.WarpOptions` value for the warp keywords: validated once, taken by
``MLS.warp``, ``glmls.warp``, the pipeline, the report, the command line and the window."""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import pickle

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.analysis import report
from glmls.app.settings import Settings
from glmls.cli.options import UsageError, warp_options_from_args
from glmls.imaging.options import Default, WarpOptions, default

IMAGE = (np.arange(30 * 40 * 3) % 251).astype(np.uint8).reshape(30, 40, 3)
SRC = np.array([[5, 5], [34, 6], [6, 24], [33, 23]], float)
DST = SRC + [[2, 1], [-1, 2], [1, -2], [-2, -1]]


def test_the_fields_are_the_keywords_of_mls_warp_with_their_defaults():
    fields = {f.name: f.default for f in dataclasses.fields(WarpOptions)}
    parameters = inspect.signature(glmls.MLS.warp).parameters
    for name, value in fields.items():
        shown = parameters[name].default
        assert isinstance(shown, Default) and shown.wrapped == value, name
        assert parameters[name].kind is inspect.Parameter.KEYWORD_ONLY
    assert "method: 'str' = 'quads'," in str(inspect.signature(glmls.MLS.warp))
    assert parameters["options"].default is None
    report_parameters = inspect.signature(report).parameters
    assert {"method", "interpolation", "warp_grid", "warp_tolerance", "border", "fit"} <= set(
        report_parameters
    )
    assert report_parameters["warp_options"].default is None


def test_values_are_normalised_frozen_hashable_and_picklable():
    options = WarpOptions(
        grid=np.int64(2),
        background=np.array([1, 2, 3]),
        output_shape=np.array([4, 6]),
        origin=[1, -2],
    )
    assert options.grid == 2 and type(options.grid) is int
    assert options.background == (1.0, 2.0, 3.0)
    assert options.output_shape == (4, 6) and options.origin == (1.0, -2.0)
    assert WarpOptions().background == 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.grid = 3  # type: ignore[misc]
    assert hash(options) == hash(pickle.loads(pickle.dumps(options)))
    assert pickle.loads(pickle.dumps(options)) == options
    with pytest.raises(TypeError):
        WarpOptions("quads")  # type: ignore[misc]  # keyword-only


@pytest.mark.parametrize(
    ("values", "error", "message"),
    [
        ({"method": "swirl"}, ValueError, "unknown method 'swirl'"),
        ({"interpolation": "cubic"}, ValueError, "unknown interpolation 'cubic'"),
        ({"border": "mirror"}, ValueError, "unknown border 'mirror'"),
        ({"method": 3}, TypeError, "method must be a string, one of quads"),
        ({"grid": 0}, ValueError, "grid must be an integer from 1"),
        ({"grid": 2.5}, TypeError, "grid must be an integer"),
        ({"grid": 2.0}, TypeError, "grid must be an integer"),
        ({"grid": True}, TypeError, "grid must be an integer"),
        ({"method": "paper-quads", "grid": 2}, ValueError, "grid must be 1, got 2"),
        ({"tolerance": 0.05, "grid": 4}, ValueError, "grid and tolerance exclude each other"),
        ({"tolerance": 0.05, "method": "splat"}, ValueError, "method 'quads'"),
        ({"tolerance": 1e-5}, ValueError, "tolerance must be at least"),
        ({"tolerance": "fine"}, TypeError, "tolerance must be a number"),
        ({"background": "red"}, TypeError, "background values must be real numbers"),
        ({"background": (1, "x")}, TypeError, "background values must be real numbers"),
        ({"background": (True,)}, TypeError, "background values must be real numbers"),
        ({"background": (1, 2, 3, 4, 5)}, ValueError, "1 to 4 values"),
        ({"background": [[1, 2]]}, ValueError, "1 to 4 values"),
        ({"output_shape": (4,)}, ValueError, "output_shape must be (H, W) integers"),
        ({"output_shape": (0, 4)}, ValueError, "H, W >= 1"),
        ({"output_shape": (5.0, 4)}, TypeError, "output_shape must be (H, W) integers"),
        ({"output_shape": (np.True_, 4)}, TypeError, "output_shape must be (H, W) integers"),
        ({"output_shape": "4x6"}, TypeError, "output_shape must be (H, W)"),
        ({"origin": (np.nan, 0)}, ValueError, "origin must be finite"),
        ({"origin": (1, 2, 3)}, ValueError, "origin must be (x0, y0)"),
        ({"origin": 5}, TypeError, "origin must be (x0, y0)"),
        ({"origin": (True, 0)}, TypeError, "origin must be (x0, y0) real numbers, got (True, 0)"),
    ],
)
def test_bad_values_are_named(values, error, message):
    with pytest.raises(error, match=message.replace("(", r"\(").replace(")", r"\)")):
        WarpOptions(**values)


def test_of_replaces_the_fields_given():
    base = WarpOptions(method="backward", grid=4)
    assert WarpOptions.of() == WarpOptions()
    assert WarpOptions.of(None, grid=2) == WarpOptions(grid=2)
    assert WarpOptions.of(base) is base
    assert WarpOptions.of(base, method=default("quads"), grid=default(1)) is base
    assert WarpOptions.of(base, method="quads") == WarpOptions(method="quads", grid=4)
    with pytest.raises(TypeError, match="unknown warp options colour, size; the options are"):
        WarpOptions.of(base, size=3, colour=1)
    with pytest.raises(TypeError, match=r"options must be a glmls\.WarpOptions, got dict"):
        WarpOptions.of({"grid": 2})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="grid must be 1"):
        WarpOptions.of(WarpOptions(method="paper-quads"), grid=2)


def test_mls_warp_takes_options_and_explicit_keywords_win(gl):
    with glmls.MLS(SRC, DST, shape=IMAGE.shape[:2], ctx=gl) as m:
        options = WarpOptions(method="backward", interpolation="linear", border="edge")
        by_keywords = m.warp(IMAGE, method="backward", interpolation="linear", border="edge")
        assert_array_equal(m.warp(IMAGE, options=options), by_keywords)
        # a keyword given explicitly replaces the field, even with the default's value
        quads = m.warp(IMAGE, interpolation="linear", border="edge")
        assert_array_equal(m.warp(IMAGE, options=options, method="quads"), quads)
        canvas = m.warp(IMAGE, options=options, output_shape=(10, 12), origin=(5, 5))
        assert_array_equal(canvas, by_keywords[5:15, 5:17])
        with pytest.raises(TypeError, match=r"options must be a glmls\.WarpOptions"):
            m.warp(IMAGE, options="backward")  # type: ignore[arg-type]
        with pytest.raises(ValueError, match="unknown method"):
            m.warp(IMAGE, options=options, method="swirl")


def test_glmls_warp_splits_its_keywords(gl):
    options = WarpOptions(method="backward", grid=2)
    with glmls.MLS(SRC, DST, transform="similarity", shape=IMAGE.shape[:2], ctx=gl) as m:
        expected = m.warp(IMAGE, options=options)
    out = glmls.warp(IMAGE, SRC, DST, transform="similarity", ctx=gl, options=options)
    assert_array_equal(out, expected)
    out = glmls.warp(IMAGE, SRC, DST, transform="similarity", ctx=gl, method="backward", grid=2)
    assert_array_equal(out, expected)
    with pytest.raises(TypeError, match=r"warp\(\) got an unknown keyword methd$"):
        glmls.warp(IMAGE, SRC, DST, methd="splat")
    with pytest.raises(TypeError, match=r"unknown keywords colour, shape$"):
        glmls.warp(IMAGE, SRC, DST, colour=1, shape=(3, 3))
    with pytest.raises(ValueError, match="unknown method 'swirl'"):
        glmls.warp(IMAGE, SRC, DST, method="swirl", transform="rigid")


def test_the_pipeline_takes_options(gl):
    pipe = glmls.gl.WarpPipeline.of(gl)
    options = WarpOptions(method="splat", background=(255, 0, 0))
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        expected = m.warp(IMAGE, options=options)
        assert_array_equal(pipe.warp(m, IMAGE, options), expected)
        assert_array_equal(pipe.warp(m, IMAGE, method="splat", background=(255, 0, 0)), expected)
        assert_array_equal(pipe.warp(m, IMAGE, options, grid=1), expected)
        with pytest.raises(TypeError, match="unknown warp option colour"):
            pipe.warp(m, IMAGE, colour=1)
        xy, residual, covered = pipe.coordinate_map(m, IMAGE.shape[:2])
        assert_array_equal(xy, m.coordinate_map(IMAGE.shape[:2]))
        assert covered.any() and residual.shape == IMAGE.shape[:2]
        with pytest.raises(ValueError, match="choose one of backward, backward-swap"):
            pipe.coordinate_map(m, IMAGE.shape[:2], options)
        with pytest.raises(ValueError, match="choose one of backward, backward-swap"):
            m.coordinate_map(IMAGE.shape[:2], method="quads")


def test_the_report_takes_options(gl):
    reference_points = np.array([[8, 8], [30, 8], [8, 22], [30, 22], [20, 15]], float)
    options = WarpOptions(method="backward", interpolation="linear", grid=2, border="edge")
    common = {"construction": False, "mesh_grid": 8}
    with glmls.MLS(SRC, DST, shape=IMAGE.shape[:2], ctx=gl) as m:
        a = report(IMAGE, m, reference_points, warp_options=options, **common)
        b = report(
            IMAGE, m, reference_points, method="backward", interpolation="linear", warp_grid=2,
            border="edge", **common,
        )  # fmt: skip
        c = report(IMAGE, m, reference_points, warp_options=options, warp_grid=1, **common)
        with pytest.raises(ValueError, match="tolerance= builds the adaptive mesh"):
            report(IMAGE, m, reference_points, warp_options=options, warp_tolerance=0.05)
    assert a.summary["warp"] == b.summary["warp"]
    assert a.summary["warp"]["method"] == "backward" and a.summary["warp"]["grid"] == 2
    assert_array_equal(a.images["deformed"], b.images["deformed"])
    assert c.summary["warp"]["grid"] == 1 and c.summary["warp"]["border"] == "edge"


def test_the_command_line_and_the_window_build_one_value():
    args = argparse.Namespace(
        method="backward", interpolation="linear", grid=2, tolerance=None, border="wrap"
    )
    assert warp_options_from_args(args) == WarpOptions(
        method="backward", interpolation="linear", grid=2, border="wrap"
    )
    args.background = (1.0, 2.0, 3.0)
    assert warp_options_from_args(args).background == (1.0, 2.0, 3.0)
    args.tolerance = 0.05
    with pytest.raises(UsageError, match="tolerance= builds the adaptive mesh"):
        warp_options_from_args(args)
    settings = Settings(method="quads", interpolation="linear", grid=8, tolerance=0.25)
    assert settings.warp_options() == WarpOptions(interpolation="linear", tolerance=0.25)
    settings = Settings(method="splat", grid=8, tolerance=0.25, border="edge")
    assert settings.warp_options(origin=(1, 2)) == WarpOptions(
        method="splat", grid=8, border="edge", origin=(1.0, 2.0)
    )
