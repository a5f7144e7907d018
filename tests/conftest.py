"""One GL context for the whole test session; GL errors are checked around every test."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.gl.context import GLContext
from glmls.imaging.options import PipelineOptions


@pytest.fixture(scope="session")
def gl() -> GLContext:
    """The shared headless context (created once, released at exit)."""
    return glmls.gl.get_context()


@pytest.fixture(autouse=True)
def _no_gl_errors(request):
    """Fail a test that leaves a GL error behind (only for tests that use the GPU)."""
    if "gl" not in request.fixturenames:
        yield
        return
    gl = request.getfixturevalue("gl")
    with gl:
        assert gl.mgl.error == "GL_NO_ERROR", "a GL error was pending before the test"
    yield
    with gl:
        assert gl.mgl.error == "GL_NO_ERROR"


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture
def pipeline(gl):
    """Make pipelines of their own with the given options (released after the test)."""
    made = []

    def make(**options):
        pipe = glmls.gl.WarpPipeline(gl, options=PipelineOptions(**options))
        made.append(pipe)
        return pipe

    yield make
    for pipe in made:
        pipe.release()
