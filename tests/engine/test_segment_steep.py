"""Segment handles under a steep weight (idw made interpolating, alpha 5 to 10: poles of 20
to 40), on the GPU against the float64 reference: the panels along a segment narrow with the
pole (glmls.core.segments.segment_panel_width), whose tail falls like e^(-(pole - 1) |t|) in
the quadrature's variable t; at the width of gentle weights, 1.5, the integrals would be off
by 1.5e-4 (pole 20) and 5.9e-3 (pole 40), and f by up to 0.65 px (affine, the handles in
reach near a line, which magnifies them).

Tolerance: 0.01 px, the segments' documented accuracy (docs/segments.md).
"""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.core.config import MLSConfig
from glmls.core.segments import SEGMENT_PANEL_WIDTH, segment_panel_width

SRC_SEGMENTS = np.array(
    [
        [[191.089, 80.936], [12.292, 4.958]],
        [[243.981, 273.827], [181.991, 218.849]],
        [[163.087, 280.522], [244.756, 0.822]],
    ]
)
DST_SEGMENTS = np.array(
    [
        [[198.237, 71.608], [16.885, -1.529]],
        [[251.245, 274.656], [177.985, 217.303]],
        [[153.654, 273.007], [248.169, 3.765]],
    ]
)
SRC = np.array([[184.616, 115.103], [299.163, 294.251], [205.663, 195.138]])
DST = np.array([[187.631, 113.326], [293.325, 297.794], [206.068, 192.102]])
# points whose nearest handle is 3/4 as far as the next, the handles in reach near a line
POINTS = np.array([[29.806, 326.845], [270.752, 319.412], [120.0, 150.0], [230.0, 100.0]])


@pytest.mark.parametrize("alpha", [5.0, 8.0, 10.0])
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_steep_weights_follow_the_reference(gl, alpha, transform):
    options = {"weight": "idw", "alpha": alpha, "interpolating": True, "transform": transform}
    segments = {"src_segments": SRC_SEGMENTS, "dst_segments": DST_SEGMENTS}
    expected, _, _ = reference.mls(SRC, DST, POINTS, **segments, **options)
    with glmls.MLS(SRC, DST, ctx=gl, **segments, **options) as m:
        f = m(POINTS)
    np.testing.assert_allclose(f, expected, atol=0.01)


def test_the_panels_narrow_with_the_pole():
    assert segment_panel_width(MLSConfig()) == SEGMENT_PANEL_WIDTH  # pole 2
    assert segment_panel_width(MLSConfig(weight="cressman", radius=9.0)) == SEGMENT_PANEL_WIDTH
    widths = [segment_panel_width(MLSConfig(alpha=a, interpolating=True)) for a in (2.5, 5, 10)]
    assert widths == pytest.approx([12 / 9, 12 / 19, 12 / 39])  # poles 10, 20, 40 (s -> 0)
