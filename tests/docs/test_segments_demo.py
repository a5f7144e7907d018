"""demos/segments.py: segment handles keep the launch photo's straight edges straight where
point handles at the same ends bend them; and the bundled photograph it uses."""

from __future__ import annotations

import importlib.util

import numpy as np
from helpers import ROOT, run_demo

import glmls
from glmls import data


def _demo():
    spec = importlib.util.spec_from_file_location("segments_demo", ROOT / "demos" / "segments.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_rocket_photograph_is_bundled():
    image = data.rocket()
    assert image.shape == (427, 640, 3) and image.dtype == np.uint8
    assert 20 < image.mean() < 200  # a photograph, not a blank


def test_segment_handles_keep_the_edges_straight(gl):
    """At a quarter of the photograph's size (the map scales with the handles: rigid idw), the
    segment handles land on their targets and stay straight; the point handles at their ends
    bend the rocket's axis by more than 3 px and every other edge more than the segments do."""
    demo = _demo()
    scale = 0.25
    a, b = demo.handles(9.0, scale)
    shape = (round(427 * scale), round(640 * scale))
    results = demo.compare(a, b, demo.edges(scale), shape, ctx=gl)
    points, segments = results["points"], results["segments"]
    assert segments.image is None
    assert segments.handles.max() < 0.01 and segments.miss.max() < 0.01
    assert points.handles[0] > 3.0  # the rocket's axis: 14.8 px at full size
    assert (segments.handles < points.handles).all()
    assert (segments.edges < points.edges).all()
    assert segments.edges.max() < 0.15  # 0.30 px at full size
    assert points.edges[:2].min() > 1.0  # the rocket's sides: 7.3 px at full size


def test_the_segments_demo_runs(tmp_path):
    out = tmp_path / "segments.jpg"
    done = run_demo("segments", "--out", str(out), "--scale", "0.25")
    assert done.returncode == 0, done.stderr
    assert "| handle: rocket axis |" in done.stdout
    picture = glmls.imread(out)
    assert picture.ndim == 3 and picture.shape[1] > 3 * 160
