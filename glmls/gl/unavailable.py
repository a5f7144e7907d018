"""Why OpenGL is unavailable, in words: the messages of :class:`~glmls.GLUnavailableError`
that :mod:`glmls.gl.context` raises (no EGL library or driver, a context older than OpenGL
4.3, a process forked from one that used GL), each saying how to fix it."""

from __future__ import annotations

from ..errors import GLUnavailableError

__all__ = ["FIX", "FORKED", "PACKAGES_DRIVER", "PACKAGES_EGL", "explain"]

#: The message for a GL context made or used in a process forked from one that used GL
#: (``{pid}``: that process).
FORKED = (
    "OpenGL unavailable: glmls made a GL context in process {pid}, and this process was "
    "forked from it; GL drivers do not survive fork (GL here would hang), so only "
    "glmls.warp(), glmls.warp_batch(), glmls.augment, glmls.MLS objects made without a ctx "
    "and the render_* pictures of glmls.analysis work here (they run in a helper process). "
    "Use the 'spawn' start method "
    "(multiprocessing.get_context('spawn'); PyTorch: DataLoader(..., "
    "multiprocessing_context='spawn')), or make the first glmls GL call in the worker "
    "processes only."
)

#: The Debian/Ubuntu packages of the EGL library, of Mesa's drivers, and the fix in words.
PACKAGES_EGL = "libegl1"
PACKAGES_DRIVER = "libegl-mesa0 libgl1-mesa-dri"
FIX = (
    "On Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri "
    "(Mesa's llvmpipe runs GL 4.5 on the CPU); with an NVIDIA GPU, its driver's EGL "
    "library (libnvidia-egl) instead of Mesa's."
)


def explain(error: Exception) -> GLUnavailableError:
    """Turn glcontext's terse errors into one that says what is missing and how to fix it."""
    text = str(error)
    if "not loaded" in text:
        what = f"the EGL or GL library could not be loaded ({text}); install {PACKAGES_EGL}"
    elif "device" in text or "eglInitialize" in text or "eglGetDisplay" in text:
        what = f"no EGL driver answered ({text}); install {PACKAGES_DRIVER}"
    elif "eglCreateContext" in text or "version" in text.lower():
        what = f"the driver offers no OpenGL 4.3 core context ({text})"
    else:
        what = f"creating a headless EGL context failed ({text})"
    return GLUnavailableError(f"OpenGL unavailable: {what}. {FIX}")
