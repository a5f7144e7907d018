"""An MLS, as scikit-image's transforms, pickles (a spawned worker's argument, a data set's
attribute) and copies: the copy is a new MLS made from the same handles and settings, with
GPU objects of its own; f is the same, bit for bit."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls

SRC = np.array([[4.0, 4.0], [40.0, 6.0], [8.0, 30.0], [36.0, 28.0]])
DST = SRC + [[2.0, -1.0], [-3.0, 2.0], [1.0, 3.0], [4.0, -2.0]]
POINTS = np.array([[10.0, 12.0], [25.5, 17.25], [-5.0, 40.0]])


def _same(a: glmls.MLS, b: glmls.MLS) -> None:
    assert type(a) is type(b) and b is not a
    assert repr(a) == repr(b) and a.shape == b.shape and a.spacing == b.spacing
    assert_array_equal(a.src, b.src)
    assert_array_equal(a.dst, b.dst)
    points = POINTS if a.dimension == 2 else np.c_[POINTS, [1.0, 2.0, 3.0]]
    assert_array_equal(a(points), b(points))


@pytest.mark.parametrize("how", ["pickle", "copy", "deepcopy"])
def test_an_mls_pickles_and_copies(gl, how):
    made = {
        "pickle": lambda m: pickle.loads(pickle.dumps(m)),
        "copy": copy.copy,
        "deepcopy": copy.deepcopy,
    }[how]
    segments = np.array([[[2.0, 40.0], [30.0, 40.0]]])
    with glmls.MLS(
        SRC, DST, src_segments=segments, dst_segments=segments + 1, weight="gaussian",
        radius=30.0, transform="similarity", shape=(44, 48), storage="ssbo",
    ) as m:  # fmt: skip
        other = made(m)
        _same(m, other)
        assert other.storage == "ssbo" and other.src_segments.shape == (1, 2, 2)
        inverse = made(m.inverse)
        assert_array_equal(inverse(POINTS), m.inverse(POINTS))
        other.release()  # its own GPU objects: m lives on
        assert_array_equal(m(POINTS), made(m)(POINTS))
    p3 = np.array([[0.0, 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 9]])
    with glmls.MLS(p3, p3 + [1, 2, 3], shape=(10, 12, 14), spacing=(2.0, 1.0, 1.0)) as m3:
        _same(m3, made(m3))


def test_a_released_mls_does_not_pickle(gl):
    m = glmls.MLS(SRC, DST)
    m.release()
    for make in (pickle.dumps, copy.copy, copy.deepcopy):
        with pytest.raises(glmls.ReleasedError):
            make(m)
