"""Exceptions raised by glmls."""

from __future__ import annotations


class GLUnavailableError(RuntimeError):
    """No usable OpenGL 4.3 context: EGL, a driver or the GL version is missing.

    The message says what was missing and which packages provide it.
    """


class DegenerateHandlesError(ValueError):
    """The handles cannot define the requested transform (e.g. affine on collinear points)."""


class ReleasedError(RuntimeError):
    """A GPU object was used after :meth:`release`, or after its GL context was released."""


class ContextError(RuntimeError):
    """A GL context was used from a thread where it cannot be current: one that another thread
    keeps current (a window's, or bound with ``make_current()``). The message says the rule."""


class InputFileError(ValueError):
    """A malformed input file; the message names the file, the line or entry, and the fault."""


class BorderWarning(UserWarning):
    """A border mode could not fill the whole output canvas: the canvas lies farther past
    the image than the forward methods' mesh may reach (or f shrinks the plane that much);
    the pixels beyond keep the background."""


class ImageWarning(UserWarning):
    """An image was read, but not all of it (the first frame of an animation or of a
    multi-page TIFF)."""
