"""Context creation: headless EGL, adopted contexts, and clear errors when GL is missing."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import moderngl
import numpy as np
import pytest

import glmls
from glmls.gl.context import GLContext, get_context

PROBE = textwrap.dedent(
    """
    import glmls
    try:
        glmls.MLS([[0, 0]], [[1, 1]])([[5, 5]])
    except glmls.GLUnavailableError as error:
        print("GLUnavailableError:", error)
    else:
        print("no error")
    """
)


def _probe(**env: str) -> str:
    result = subprocess.run(
        [sys.executable, "-c", PROBE],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_missing_egl_library_names_the_package():
    out = _probe(GLCONTEXT_LINUX_LIBEGL="/nonexistent/libEGL.so.1")
    assert "GLUnavailableError" in out
    assert "could not be loaded" in out
    assert "libegl1" in out


def test_missing_driver_names_the_packages():
    out = _probe(__EGL_VENDOR_LIBRARY_FILENAMES="/nonexistent/vendor.json")
    assert "GLUnavailableError" in out
    assert "libegl-mesa0" in out and "libgl1-mesa-dri" in out


def test_old_gl_version_is_explained(gl):
    if "llvmpipe" not in gl.mgl.info["GL_RENDERER"] and "Mesa" not in gl.mgl.info["GL_VERSION"]:
        pytest.skip("MESA_GL_VERSION_OVERRIDE is Mesa's: other drivers ignore it")
    out = _probe(MESA_GL_VERSION_OVERRIDE="3.3")
    assert "GLUnavailableError" in out
    assert "4.3" in out


def test_shared_headless_context_is_gl43_core(gl):
    assert gl is get_context()
    assert gl.mgl.version_code >= 430
    assert gl.limits["max_texture_size"] >= 1024


def test_adopted_context_is_used_and_not_released_by_glmls():
    mgl = moderngl.create_context(standalone=True, backend="egl", require=430)
    try:
        wrapper = get_context(mgl)
        assert wrapper.mgl is mgl and not wrapper.owned
        assert get_context(mgl) is wrapper
        with glmls.MLS([[0, 0], [10, 0]], [[1, 1], [11, 1]], ctx=mgl) as m:
            assert m.ctx is wrapper
            np.testing.assert_allclose(m([[5.0, 5.0]]), [[6.0, 6.0]], atol=1e-4)
        wrapper.release()
        assert mgl.error == "GL_NO_ERROR"  # the context itself is still alive
    finally:
        mgl.release()


def test_ctx_of_the_wrong_type_is_a_type_error():
    with pytest.raises(TypeError, match=r"moderngl\.Context"):
        get_context("egl")  # type: ignore[arg-type]


def test_owned_glcontext_release_is_idempotent():
    # require 4.3: NVIDIA gives exactly the version asked for (Mesa gives its newest)
    mgl = moderngl.create_context(standalone=True, backend="egl", require=430)
    ctx = GLContext(mgl, owned=True)
    ctx.release()
    ctx.release()  # twice is harmless
    assert ctx.released
