"""The registry of weights: the one place that knows each weight. Its entries match the
paper's Table 1, the shaders have one function per entry, and a new weight is one entry plus
one GLSL function."""

from __future__ import annotations

import re
import shutil
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.app.controller import BINDINGS
from glmls.cli.main import build_parser
from glmls.core.config import MLSConfig
from glmls.core.weights import RADIUS_WEIGHTS, REGISTRY, WEIGHTS, Weight, weight
from glmls.gl.context import create_headless
from glmls.gl.shaders import ShaderLibrary

SHADERS = Path(str(resources.files("glmls").joinpath("shaders")))
SIGNATURE = r"float mls_weight_(\w+)\(float d2, float m, float inv_m, float sigma\)"


def test_the_paper_weights_and_their_properties():
    assert WEIGHTS == ("idw", "cressman", "shepard", "gaussian", "linear")
    assert RADIUS_WEIGHTS == ("cressman", "shepard", "gaussian", "linear")
    assert glmls.WEIGHTS == WEIGHTS and glmls.RADIUS_WEIGHTS == RADIUS_WEIGHTS
    infinite = {name for name in WEIGHTS if REGISTRY[name].infinite_at_zero(MLSConfig(s=1.0))}
    assert infinite == {"shepard"}
    assert REGISTRY["idw"].infinite_at_zero(MLSConfig(s=0.0))
    assert REGISTRY["idw"].reach(10.0, 100) is None
    assert REGISTRY["linear"].reach(10.0, 100) == pytest.approx(10.0, rel=1e-4)
    gaussian = 10 * np.sqrt(np.log(100 * 2**24))
    assert REGISTRY["gaussian"].reach(10.0, 100) == pytest.approx(gaussian, rel=1e-4)
    with pytest.raises(ValueError, match="unknown weight 'cubic'; choose one of idw, cressman"):
        weight("cubic")


TABLE_1 = {  # the paper's formulas at R = 4 (idw: s = 0.5, alpha = 1)
    "idw": lambda d: 1 / (0.5 + d**2),
    "cressman": lambda d: max(0.0, (16 - d**2) / (16 + d**2)),
    "shepard": lambda d: max(0.0, (4 - d) / (4 * d)),
    "gaussian": lambda d: np.exp(-(d**2) / 16),
    "linear": lambda d: max(0.0, 4 - d),
}


@pytest.mark.parametrize("name", list(TABLE_1))
def test_reference_formulas_are_table_1_up_to_a_common_factor(name):
    """MLS ignores a factor common to all handles at a point; the registry's formulas use one
    to stay finite for extreme radii. Ratios of weights, and zeros, are the paper's."""
    config = MLSConfig(weight=name, s=0.5, radius=4.0)
    distances = np.array([1.0, 1.5, 2.0, 3.9, 4.0, 5.0])
    w = REGISTRY[name].reference(distances[None] ** 2, config, 4.0)[0]
    table = np.array([TABLE_1[name](d) for d in distances])
    assert_allclose(w / w[0], table / table[0], rtol=1e-12, atol=1e-15)
    assert ((w == 0) == (table == 0)).all()


def test_the_gaussian_is_table_1_up_to_a_common_factor():
    config = MLSConfig(weight="gaussian", radius=4.0)
    d2 = np.array([[1.0, 4.0, 9.0]])
    w = reference.weights(d2, config, 4.0)
    assert_allclose(w / w[0, 0], np.exp(-d2 / 16) / np.exp(-1 / 16))


@pytest.mark.parametrize("name", RADIUS_WEIGHTS)
def test_reference_weights_name_a_missing_radius(name):
    config = MLSConfig(weight=name)
    with pytest.raises(TypeError, match=f"radius .*{name}.* got None"):
        reference.weights(np.array([[1.0, 4.0]]), config, None)


@pytest.mark.parametrize(
    ("d2", "config", "radius", "error", "message"),
    [
        # NaN came back as a weight of NaN, -1 as the weight -1 (idw's 1 / d^2)
        ([[np.nan, 1.0]], MLSConfig(), None, ValueError, r"d2 must be squared distances, >= 0"),
        ([[-1.0, 1.0]], MLSConfig(), None, ValueError, r"d2 must be squared distances, >= 0"),
        ([[1.0 + 0j]], MLSConfig(), None, TypeError, r"d2 must be real numbers, got dtype complex"),
        # the Gaussian's factor per point took axis 1: numpy's AxisError
        ([1.0, 4.0], MLSConfig(weight="gaussian"), 4.0, ValueError, r"d2 must be \(K, N\)"),
        # an AttributeError on the string
        ([[1.0]], "idw", None, TypeError, r"config must be an MLSConfig, got str"),
        ([[1.0]], MLSConfig(weight="gaussian"), np.nan, ValueError, r"radius must be a finite"),
        ([[1.0]], MLSConfig(weight="linear"), "4", TypeError, r"radius must be"),
    ],
)
def test_reference_weights_name_what_is_no_weight_input(d2, config, radius, error, message):
    with pytest.raises(error, match=message):
        reference.weights(np.array(d2), config, radius)


def test_every_entry_has_one_glsl_function_and_no_other():
    text = (SHADERS / "mls" / "weights.glsl").read_text()
    assert sorted(re.findall(SIGNATURE, text)) == sorted(REGISTRY)
    for entry in REGISTRY.values():
        assert entry.glsl_function == f"mls_weight_{entry.name}"


def test_every_entry_has_its_slope_glsl_function():
    """The 3D Jacobian differentiates the moments by each weight's slope dw/d(d2)
    (mls3/core.glsl); every weight of the registry gives its own."""
    text = (SHADERS / "mls" / "weights.glsl").read_text()
    found = re.findall(
        r"float mls_slope_(\w+)\(float d2, float w, float m, float inv_m, float sigma\)", text
    )
    assert sorted(found) == sorted(REGISTRY)
    for name, entry in REGISTRY.items():
        assert entry.slope and entry.glsl_slope == f"mls_slope_{name}"


def test_every_compact_weight_has_a_float64_glsl_function_near_its_reach():
    """3D MLS evaluates the radius weights near d = R in float64 (mls/weighting.glsl)."""
    text = (SHADERS / "mls" / "weights.glsl").read_text()
    found = re.findall(
        r"double mls_weight64_(\w+)\(double d2, float m, float inv_m, float sigma\)", text
    )
    compact = [name for name, entry in REGISTRY.items() if entry.support == "radius"]
    assert sorted(found) == sorted(compact)
    for name in compact:
        assert REGISTRY[name].glsl_function64 == f"mls_weight64_{name}"
    assert all(
        entry.glsl_function64 is None for name, entry in REGISTRY.items() if name not in compact
    )


def test_a_float64_edge_only_for_a_compact_weight():
    with pytest.raises(ValueError, match="'bump': edge64 is for radius weights"):
        Weight(
            "bump",
            "exp(-d^2 / R^2)",
            needs_radius=True,
            support="gaussian",
            infinite_at_zero=lambda params: False,
            reference=lambda d2, params, radius: np.exp(-d2),
            edge64=True,
        )


def test_the_window_and_the_command_line_list_every_weight():
    help_text = next(text for keys, action, text in BINDINGS if action == "weight")
    assert all(name in help_text for name in WEIGHTS)
    parser = build_parser()
    args = parser.parse_args(["warp", "a.png", "b.png", "--handles", "h", "--weight", "linear"])
    assert args.weight == "linear"


def test_a_sixth_weight_is_one_entry_and_one_glsl_function(gl, tmp_path, monkeypatch, rng):
    """Wendland's C2 function (1 - d/R)^4 (4 d/R + 1), compact like cressman: added to the
    registry and to a copy of the shaders, it runs on the GPU, bins included, and matches
    its float64 formula."""

    def wendland(d2, params, radius):
        t = np.sqrt(d2) / radius
        return np.where(t < 1, (1 - t) ** 4 * (4 * t + 1), 0.0)

    monkeypatch.setitem(
        REGISTRY,
        "wendland",
        Weight(
            "wendland",
            "(1 - d/R)^4 (4 d/R + 1)",
            needs_radius=True,
            support="radius",
            infinite_at_zero=lambda params: False,
            reference=wendland,
        ),
    )
    shaders = tmp_path / "shaders"
    shutil.copytree(SHADERS, shaders)
    with open(shaders / "mls" / "weights.glsl", "a") as glsl:
        glsl.write(
            "\nfloat mls_weight_wendland(float d2, float m, float inv_m, float sigma) {\n"
            "    float t = sqrt(d2) / u_radius;\n"
            "    return t < 1.0 ? pow(1.0 - t, 4.0) * (4.0 * t + 1.0) : 0.0;\n"
            "}\n"
        )
    own = create_headless(shaders=ShaderLibrary(shaders))
    p = rng.uniform(0, 256, (600, 2))
    q = p + rng.uniform(-3, 3, p.shape)
    v = rng.uniform(0, 255, (500, 2))
    try:
        for bins in (False, True):
            with glmls.MLS(p, q, weight="wendland", radius=24.0, ctx=own, bins=bins) as m:
                f = m(v)
                assert (m.kernel.bins is not None) == bins
            f_ref, _, _ = reference.mls(p, q, v, weight="wendland", radius=24.0)
            assert_allclose(f, f_ref, rtol=0, atol=0.01)
    finally:
        own.release()
