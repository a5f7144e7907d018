"""Exceptions raised by glmls."""

from __future__ import annotations


class GLUnavailableError(RuntimeError):
    """No usable OpenGL 4.3 context: EGL, a driver or the GL version is missing.

    The message says what was missing and which packages provide it. It is also raised in a
    forked child process by a context its parent created.

    See Also
    --------
    glmls.gl.get_context : the shared headless context, which raises it.

    Examples
    --------
    >>> issubclass(glmls.GLUnavailableError, RuntimeError)
    True
    >>> try:
    ...     context = glmls.gl.get_context()
    ... except glmls.GLUnavailableError as error:
    ...     print("no GPU:", error)  # doctest: +SKIP
    """


class DegenerateHandlesError(ValueError):
    """The handles cannot define the requested transform (e.g. affine on collinear points).

    Examples
    --------
    >>> on_a_line = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]
    >>> try:
    ...     glmls.MLS(on_a_line, on_a_line, transform="affine")
    ... except glmls.DegenerateHandlesError as error:
    ...     print(isinstance(error, ValueError), str(error)[:42])
    True affine MLS needs at least 3 source handles
    """


class ReleasedError(RuntimeError):
    """A GPU object was used after :meth:`~glmls.MLS.release`, or after its GL context was released.

    Examples
    --------
    >>> m = glmls.MLS([[0.0, 0.0]], [[1.0, 1.0]])
    >>> m.release()
    >>> try:
    ...     m.warp(np.zeros((8, 8), np.uint8))
    ... except glmls.ReleasedError as error:
    ...     print(error)
    this MLS has been released; create a new one
    """


class ContextError(RuntimeError):
    """A GL context was used from a thread where it cannot be current.

    That is a thread other than the one that keeps it current (a window's, or one bound with
    ``make_current()``). The message says the rule.

    See Also
    --------
    glmls.gl.GLContext.make_current : binds a context to the calling thread.

    Examples
    --------
    >>> issubclass(glmls.ContextError, RuntimeError)
    True
    """


class NoDisplayError(RuntimeError):
    """No window could be opened: no display, no glfw, or no OpenGL 4.3 core context on it.

    Raised by the real-time windows (:meth:`glmls.app.App.run`,
    :meth:`glmls.app.VolumeApp.run`, ``glmls demo``); the message says how to run them (under
    a display, or ``xvfb-run -a``) and which headless commands do without one.

    Examples
    --------
    >>> issubclass(glmls.NoDisplayError, RuntimeError)
    True
    """


class DistributedUnavailableError(ImportError):
    """A Dask scheduler was asked for, but Dask's ``distributed`` package is not installed.

    Raised by the studies and the tune (:func:`glmls.analysis.run_jobs`, ``glmls tune
    --scheduler``); the message says which extra installs it.

    Examples
    --------
    >>> issubclass(glmls.DistributedUnavailableError, ImportError)
    True
    """


class DtypeError(TypeError, ValueError):
    """An array of a dtype that glmls does not take for it; the message names the array.

    Both a ``TypeError``, as numpy and scikit-image report a wrong dtype, and a ``ValueError``,
    as glmls reports every other bad input (a wrong shape, a value that is not finite), so
    that either ``except`` clause catches it.

    Examples
    --------
    >>> try:
    ...     glmls.warp_batch(np.zeros((2, 8, 8), np.int64), [[[1.0, 1.0]]] * 2, [[[2.0, 2.0]]] * 2)
    ... except ValueError as error:
    ...     print(isinstance(error, TypeError), error)
    True images[0] has dtype int64; expected one of uint8, uint16, float32, float64
    """


class InputFileError(ValueError):
    """A malformed input file; the message names the file, the line or entry, and the fault.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "study.json"
    >>> _ = path.write_text('{"items": []}')
    >>> try:
    ...     glmls.data.read_manifest(path)
    ... except glmls.InputFileError as error:
    ...     print(isinstance(error, ValueError), str(error).endswith('"items": no items'))
    True True
    """


class BorderWarning(UserWarning):
    """A border mode could not fill the whole output canvas.

    The canvas lies farther past the image than the forward methods' mesh may reach (or f
    shrinks the plane that much); the pixels beyond keep the background. A volume warp
    (either method) warns alike where its lattice of cells, at its largest, does not cover
    the canvas.

    Examples
    --------
    >>> import warnings
    >>> image = np.full((16, 16), 7, np.uint8)
    >>> with glmls.MLS(np.zeros((0, 2)), np.zeros((0, 2))) as m:
    ...     with warnings.catch_warnings(record=True) as caught:
    ...         warnings.simplefilter("always")
    ...         out = m.warp(image, border="edge", output_shape=(4, 4), origin=(-1e6, 0.0))
    >>> caught[0].category.__name__, out.max().item()
    ('BorderWarning', 0)
    """


class ImageWarning(UserWarning):
    """An image was read, but not all of it.

    Only the first frame of an animation or of a multi-page TIFF is read.

    Examples
    --------
    >>> import pathlib, tempfile, warnings
    >>> from PIL import Image
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "two.gif"
    >>> frames = [Image.new("L", (4, 3), value) for value in (0, 255)]
    >>> frames[0].save(path, save_all=True, append_images=frames[1:])
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     image = glmls.imread(path)
    >>> image.shape, caught[0].category.__name__
    ((3, 4, 3), 'ImageWarning')
    """
