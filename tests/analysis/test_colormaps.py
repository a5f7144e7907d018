"""Colour tables, limits, CPU colouring and the colour bar."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.analysis import colormaps


def test_viridis_table():
    table = glmls.analysis.VIRIDIS
    assert table.shape == (256, 3) and table.dtype == np.uint8
    # matplotlib's #440154, #21918c (entry 128) and #fde725
    assert table[0].tolist() == [0x44, 0x01, 0x54]
    assert table[128].tolist() == [0x21, 0x91, 0x8C]
    assert table[255].tolist() == [0xFD, 0xE7, 0x25]
    assert not table.flags.writeable
    # ordered by lightness: Rec. 601 luma rises (8-bit rounding aside: every 4th entry)
    luma = table @ np.array([0.299, 0.587, 0.114])
    assert (np.diff(luma[::4]) > 0).all()
    assert np.diff(luma).min() > -0.5


def test_linear_map_goes_from_low_to_high():
    table = glmls.analysis.linear_colormap((0, 0, 255), (255, 0, 0), n=5)
    assert table.tolist() == [[0, 0, 255], [64, 0, 191], [128, 0, 128], [191, 0, 64], [255, 0, 0]]
    assert colormaps.colormap([(0, 0, 0), (255, 255, 255)]).shape == (256, 3)
    assert colormaps.colormap("linear")[0].tolist() == list(colormaps.LOW_COLOR)
    with pytest.raises(ValueError, match="unknown colour map"):
        colormaps.colormap("jet")
    with pytest.raises(ValueError, match="0-255"):
        glmls.analysis.linear_colormap((0, 0, 300))
    with pytest.raises(ValueError, match="n must"):
        glmls.analysis.linear_colormap(n=1)


def test_limits_and_percentile(rng):
    values = rng.exponential(1.0, 1000)
    values[:3] = [np.nan, 1e6, 2e6]
    lo, hi = glmls.analysis.color_limits(values)
    assert (lo, hi) == (np.nanmin(values), 2e6)
    _, robust = glmls.analysis.color_limits(values, percentile=95)
    assert robust == np.percentile(values[~np.isnan(values)], 95)
    assert glmls.analysis.color_limits(values, vmin=0, vmax=3) == (0.0, 3.0)
    assert glmls.analysis.color_limits([np.nan]) == (0.0, 1.0)
    for bad in (0, 101, np.nan):
        with pytest.raises(ValueError, match="percentile"):
            glmls.analysis.color_limits(values, percentile=bad)
    with pytest.raises(TypeError, match="percentile"):
        glmls.analysis.color_limits(values, percentile=True)
    with pytest.raises(ValueError, match="vmin <= vmax"):
        glmls.analysis.color_limits(values, vmin=5, vmax=1)


@pytest.mark.parametrize(
    "values",
    [None, [None, 1.0], ["1", "2"], [1.0 + 2.0j, 3.0]],
    ids=["None", "None in a list", "strings", "complex"],
)
@pytest.mark.parametrize("call", [glmls.analysis.color_limits, glmls.analysis.apply_colormap])
def test_values_that_are_no_real_numbers_are_a_dtype_error_naming_them(call, values):
    """None was NaN (grey, limits 0 and 1), a complex value its real part, a string a
    ValueError from float() that named no argument."""
    with pytest.raises(glmls.DtypeError, match=r"^values must be real numbers, got dtype "):
        call(values)


def test_bools_are_coloured_as_0_and_1():
    out = glmls.analysis.apply_colormap([True, False], cmap=[(0, 0, 0), (255, 255, 255)])
    assert out.tolist() == [[255, 255, 255], [0, 0, 0]]


def test_apply_colormap_rule_and_nan():
    values = np.array([[0.0, 0.5, 1.0], [2.0, -1.0, np.nan]])
    table = glmls.analysis.linear_colormap((0, 0, 0), (255, 255, 255), n=3)
    out = glmls.analysis.apply_colormap(values, cmap=table, vmin=0, vmax=1, nan_color=(1, 2, 3))
    assert out[0, :, 0].tolist() == [0, 128, 255]
    assert out[1, 0].tolist() == [255, 255, 255]  # clipped above
    assert out[1, 1].tolist() == [0, 0, 0]  # clipped below
    assert out[1, 2].tolist() == [1, 2, 3]
    # constant values: all at the minimum colour
    assert (glmls.analysis.apply_colormap(np.ones(4)) == glmls.analysis.VIRIDIS[0]).all()


def test_colorbar_has_the_colours_and_numbers():
    bar = glmls.analysis.colorbar("viridis", 0.0, 2.0, length=200, thickness=16, ticks=3, label="E")
    assert bar.dtype == np.uint8 and bar.ndim == 3 and bar.shape[0] > 200
    column = bar[:, 8]
    assert (column == glmls.analysis.VIRIDIS[-1]).all(axis=1).any()  # top: the maximum
    assert (column == glmls.analysis.VIRIDIS[0]).all(axis=1).any()
    top = np.argmax((column == glmls.analysis.VIRIDIS[-1]).all(axis=1))
    bottom = np.argmax((column == glmls.analysis.VIRIDIS[0]).all(axis=1))
    assert top < bottom
    labels = bar[:, 24:]
    assert (labels < 128).any()  # dark digits were drawn right of the bar
    with pytest.raises(ValueError, match="ticks"):
        glmls.analysis.colorbar("viridis", 0, 1, ticks=1)
    with pytest.raises(ValueError, match="limits"):
        glmls.analysis.colorbar("viridis", 1, 0)


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"font_size": 0}, ValueError, r"font_size must be an integer from 1 to 1024, got 0"),
        ({"font_size": 12.5}, TypeError, r"font_size must be an integer from 1 to 1024, got 12\.5"),
        ({"length": "64"}, TypeError, r"length must be an integer from 16 to 16384, got '64'"),
        ({"thickness": True}, TypeError, r"thickness must be an integer from 2 to 16384, got True"),
        ({"ticks": 2.0}, TypeError, r"ticks must be an integer from 2 to length \(256\), got 2\.0"),
        # beyond these, Pillow failed unnamed (OSError: invalid pixel size), or the bar was
        # numpy's MemoryError, or ticks were drawn for minutes
        (
            {"font_size": 65536},
            ValueError,
            r"font_size must be an integer from 1 to 1024, got 65536",
        ),
        (
            {"length": 10**9},
            ValueError,
            r"length must be an integer from 16 to 16384, got 1000000000",
        ),
        ({"length": 0}, ValueError, r"length must be an integer from 16 to 16384, got 0"),
        ({"thickness": -2}, ValueError, r"thickness must be an integer from 2 to 16384, got -2"),
        ({"thickness": 10**9}, ValueError, r"thickness must be .* 16384, got 1000000000"),
        (
            {"ticks": 10**7},
            ValueError,
            r"ticks must be an integer from 2 to length \(256\), got 10000000",
        ),
        ({"ticks": 65, "length": 64}, ValueError, r"ticks must be .* to length \(64\), got 65"),
        (
            {"label": "E" * 10**5},
            ValueError,
            r"label makes the colour bar \d+ pixels wide at font_size 12, more than 16384; "
            r"shorten it, or make the font smaller",
        ),
        ({"lo": "0"}, TypeError, r"lo must be a number, got '0' \(str\)"),
    ],
)
def test_colorbar_names_an_option_that_is_no_number_it_takes(options, error, message):
    arguments = {"cmap": "viridis", "lo": 0.0, "hi": 1.0, **options}
    with pytest.raises(error, match=rf"^{message}$"):
        glmls.analysis.colorbar(**arguments)


def test_colorbar_draws_its_largest_options():
    bar = glmls.analysis.colorbar("viridis", 0, 1, length=16384, thickness=2, ticks=16384)
    assert bar.shape == (16384 + 24, bar.shape[1], 3)
    assert bar[12, 0].tolist() == glmls.analysis.VIRIDIS[-1].tolist()
    bar = glmls.analysis.colorbar("viridis", 0, 1, length=16, thickness=16300, font_size=12)
    assert bar.shape[1] <= 16384 and bar[12, 16299].tolist() == glmls.analysis.VIRIDIS[-1].tolist()
    bar = glmls.analysis.colorbar("viridis", 0, 1, length=16, font_size=1024)
    assert bar.shape[0] == 16 + 2 * 1024
    with pytest.raises(ValueError, match=r"^thickness 16384 makes the colour bar \d+ pixels wide"):
        glmls.analysis.colorbar("viridis", 0, 1, thickness=16384, font_size=1024)


@pytest.mark.parametrize(
    ("value", "text"),
    [(0, "0"), (3.14159, "3.14"), (7578.2, "7578"), (15156.4, "1.52e4"), (1.23e-4, "1.23e-4")],
)
def test_number_format(value, text):
    assert colormaps.format_number(value) == text


@pytest.mark.parametrize(
    ("lo", "hi", "labels"),
    [
        (0.0, 2.0, ["0", "0.5", "1", "1.5", "2"]),
        (1 / 3, 0.3342, ["0.3333", "0.3336", "0.3338", "0.334", "0.3342"]),
        (259.9999, 260.0003, ["259.9999", "260.0000", "260.0001", "260.0002", "260.0003"]),
        (15000.0, 15004.0, ["1.5000e4", "1.5001e4", "1.5002e4", "1.5003e4", "1.5004e4"]),
    ],
)
def test_tick_labels_tell_neighbouring_ticks_apart(lo, hi, labels):
    """3 significant digits, or as many more as the ticks of a narrow scale need."""
    assert colormaps.tick_labels(np.linspace(lo, hi, 5)) == labels
    assert colormaps.tick_labels([1.0, 1.0]) == ["1", "1"]  # equal values: no more digits


def test_a_tick_mark_stands_apart_from_its_label():
    """The mark at the bar's edge, then a gap of half the digits' height before them: a
    mark right before the digits reads as a minus sign."""
    bar = glmls.analysis.colorbar("viridis", 1.0, 2.0, length=64, thickness=10, ticks=2)
    row = bar[12] < 128  # the top tick's row, 12 px of margin above the bar
    ink = np.flatnonzero(row.all(axis=1))
    mark = ink[ink < 16]
    assert mark.tolist() == [10, 11, 12, 13, 14]
    digits = np.flatnonzero((bar[6:19] < 128).all(axis=2).any(axis=0))
    assert digits[digits > 14].min() >= 15 + 6  # half of the 12 px font between


@pytest.mark.parametrize(
    "values",
    [
        [-1e308, 0.0, 1e308],  # hi - lo overflows float64
        [0.0, 1e39, 2e39],  # beyond float32
        [0.0, 1e-40, 2e-40],  # float32's subnormals
    ],
)
def test_finite_values_at_the_extremes_keep_their_scale(gl, values):
    """Finite values whose span overflows float64, or that float32 cannot hold, are coloured
    by the rule t = (x - lo) / (hi - lo) as any others: on the CPU, on the GPU and in the
    colour bar, without a warning."""
    table = colormaps.colormap("viridis")
    expected = table[[0, (len(table) - 1) // 2 + 1, len(table) - 1]].tolist()
    assert glmls.analysis.apply_colormap(values).tolist() == expected
    rendered = glmls.analysis.render_field([values], ctx=gl)
    assert rendered[0].tolist() == expected
    lo, hi = values[0], values[-1]
    bar = glmls.analysis.colorbar("viridis", lo, hi, length=64)
    assert (
        bar[12, 0].tolist() == table[-1].tolist() and bar[12 + 63, 0].tolist() == table[0].tolist()
    )
