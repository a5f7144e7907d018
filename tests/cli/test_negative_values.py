"""A value that begins with '-' but is numbers ("-1,1,1", "-1e-3") is an option's value, not an
option: ``--spacing -1,1,1`` and ``--spacing=-1,1,1`` both reach the spacing's check."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.cli.main import build_parser, main


def _one_line_error(capsys, argv) -> str:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("command", ["warp", "demo", "analyze"])
@pytest.mark.parametrize("joined", [False, True])
def test_a_negative_spacing_is_the_spacing_check_s_error(capsys, tmp_path, command, joined):
    spacing = ["--spacing=-1,1,1"] if joined else ["--spacing", "-1,1,1"]
    argv = {"warp": ["warp", "v.nii", "o.nii"], "demo": ["demo", "--volume"]}.get(
        command, ["analyze", "v.nii", "--out", str(tmp_path)]
    )
    err = _one_line_error(capsys, [*argv, *spacing])
    assert "argument --spacing: spacing must be positive and finite (dz, dy, dx)" in err, err
    assert "(-1.0, 1.0, 1.0)" in err, err


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--spacing", "-0.5", "spacing must be positive and finite"),  # one number, isotropic
        ("--spacing", "-1e-3,1,1", "spacing must be positive and finite"),
        ("--spacing", "-inf,1,1", "spacing must be positive and finite"),
        ("--spacing", "-1,a,1", "expected DZ,DY,DX numbers, got '-1,a,1'"),
        ("--background", "-1,x", "comma-separated numbers per channel, got '-1,x'"),
        ("--background", "0,-9007199254740993", "it would be -9007199254740992"),  # -(2**53 + 1)
    ],
)
def test_every_negative_value_reaches_its_check(capsys, option, value, message):
    for given in ([option, value], [f"{option}={value}"]):
        err = _one_line_error(capsys, ["warp", "a.png", "b.png", "--handles", "h.json", *given])
        assert f"argument {option}: " in err and message in err, err


def test_negative_numbers_are_values():
    parser = build_parser()
    args = parser.parse_args(
        ["warp", "a.png", "b.png", "--handles", "h", "--background", "-1,0.5,-2e-1"]
    )
    assert args.background == (-1.0, 0.5, -0.2)
    args = parser.parse_args(
        ["warp", "a.png", "b.png", "--handles", "h", "--alpha", "-1e-3", "--s", "-2"]
    )
    assert (args.alpha, args.s) == (-1e-3, -2.0)
    args = parser.parse_args(
        ["warp", "a.png", "b.png", "--handles", "h", "--background=-1,0,0", "--quiet"]
    )
    assert args.background == (-1.0, 0.0, 0.0) and args.quiet


def test_an_option_is_still_an_option(capsys):
    """Only an option that takes a value takes the next word; a flag before a negative word
    leaves it to the rest of the line."""
    argv = ["warp", "a.png", "b.png", "--handles", "h.json", "--keep-going", "-1,1"]
    err = _one_line_error(capsys, argv)
    # the command's own mistake: named by it, pointing to its --help
    assert err.startswith("glmls warp: unrecognized arguments: -1,1"), err
    assert err.endswith("(see glmls warp --help)\n"), err
    err = _one_line_error(capsys, ["warp", "a.png", "b.png", "--spacing"])
    assert "argument --spacing: expected one argument" in err, err


def test_a_negative_background_warps(tmp_path):
    """End to end: a float image's negative background is filled where nothing lands."""
    image = tmp_path / "a.tif"
    glmls.imwrite(image, np.ones((16, 16), np.float32))
    handles = tmp_path / "h.json"
    handles.write_text('{"src": [[2, 2], [12, 2], [2, 12]], "dst": [[6, 2], [16, 2], [6, 12]]}')
    out = tmp_path / "b.tif"
    argv = ["warp", str(image), str(out), "--handles", str(handles), "--transform", "affine"]
    assert main([*argv, "--background", "-2.5", "--quiet"]) == 0
    warped = glmls.imread(out)
    assert warped.min() == -2.5 and warped.max() == 1.0


@pytest.mark.parametrize(
    ("given", "field", "expected"),
    [
        (["--spac", "-1,2,3"], "spacing", "spacing must be positive and finite"),
        (["--backg", "-1,0,0"], "background", (-1.0, 0.0, 0.0)),
        (["--alp", "-1e-3"], "alpha", -1e-3),
    ],
)
def test_an_abbreviated_option_takes_its_negative_value(capsys, given, field, expected):
    """argparse takes an unambiguous prefix of a long option for the option; its value is
    read as it is after the option's full name."""
    argv = ["warp", "a.png", "b.png", "--handles", "h", *given]
    if isinstance(expected, str):
        assert expected in _one_line_error(capsys, argv)
    else:
        assert getattr(build_parser().parse_args(argv), field) == expected


def test_an_ambiguous_prefix_is_argparse_s_error(capsys):
    """An option's full name is that option although it is the prefix of others (--s of
    --spacing, --seed); a prefix of two options is argparse's error, as without a value."""
    argv = ["warp", "a.png", "b.png", "--handles", "h", "--s", "-1e-3"]
    assert build_parser().parse_args(argv).s == -1e-3
    argv = ["warp", "a.png", "b.png", "--handles", "h", "--inter", "-1e-3"]
    err = _one_line_error(capsys, argv)
    assert "ambiguous option: --inter" in err, err


def test_words_after_a_double_dash_are_left_alone(capsys):
    """``--`` ends the options: a word after it is not an option's value, even after an
    option's name."""
    argv = ["warp", "a.png", "b.png", "--handles", "h", "--alpha", "--", "-1e-3"]
    err = _one_line_error(capsys, argv)
    assert "argument --alpha: expected one argument" in err, err
