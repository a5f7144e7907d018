"""The volume window: three orthogonal slices through a point of a volume, deformed live by a
3D MLS whose handles are dragged within the slice planes (``glmls demo VOLUME``).

A :class:`~glmls.app.volume_controller.VolumeController` takes the events (montage pixels,
as the 2D window's take image pixels: replays and recordings have the same format), a
:class:`~glmls.app.volume_session.VolumeSession` keeps the MLS, the three deformed slices
and the overlay in step with it, and a :class:`~glmls.app.volume_view.VolumeView` draws
them; the operating-system window, the layout and the text are the 2D window's.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..files.landmarks import elastix_indices, read_handles, write_handles
from ..files.volume_dtypes import in_dtype, warped_as
from ..files.volumes import VOLUME_SUFFIXES, Volume, write_volume
from .glfw_window import NoDisplayError
from .hud import PANEL_CHARS, frame_rate, wrap
from .volume_controller import AXES, VIEWS, VolumeController, VolumeSettings
from .volume_session import VolumeSession, check_fits, display_volume
from .volume_view import VolumeView, label_quads, montage_layout, text_groups, window_size
from .window_loop import WindowLoop

__all__ = ["NoDisplayError", "VolumeApp"]


class VolumeApp(WindowLoop):
    """The volume window (``glmls demo VOLUME``): a volume, its 3D handles and a controller.

    Three orthogonal slices through the slice point are deformed live by a 3D MLS as the
    handles are dragged within their planes; :doc:`/window` lists the mouse actions and the
    keys. Constructing it opens nothing: :meth:`run` opens the window (it needs a display: a
    desktop, or Xvfb with ``xvfb-run``) and returns when it closes, or after ``frames``
    frames. Its :class:`VolumeController` takes the events.

    Parameters
    ----------
    volume : numpy.ndarray or glmls.Volume
        (D, H, W) or (D, H, W, C); shown grey (``display_volume``).
        A :class:`~glmls.Volume` brings its spacing and affine.
    src, dst : array_like
        The handles (N, 3) (x, y, z) in handle units: voxel (i, j, k) sits at
        (i dx, j dy, k dz), as in ``glmls warp`` and :meth:`glmls.MLS.warp`.
    spacing : (float, float, float), optional
        The voxel size (dz, dy, dx); default the volume's, else 1. The views show the
        physical aspect, the slices and the saved volume are warped with it.
    save_as : str, default ".npy"
        The format of the deformed volume ``s`` saves (``.nii``, ``.nii.gz``,
        ``.tif``, ``.tiff`` or ``.npy``); NIfTI keeps the volume's affine (else one of the
        spacing), an ImageJ TIFF the spacing, ``.npy`` neither.
    settings : VolumeSettings, optional
        The MLS configuration and the construction of the slices.
    name : str
        The volume's name (the title, the saved files' names).
    out_dir : str or os.PathLike
        Where ``s``, ``j`` and ``S`` save.
    handles_path : str or os.PathLike, optional
        The file ``l`` loads (else the last one saved).
    targets_path : str or os.PathLike, optional
        The targets' file where ``handles_path`` is an elastix pair's sources'; a pair of
        ``index`` files (voxel indices) is put in the handles' units by the spacing, as
        ``glmls warp`` does.
    window_size : tuple of int, optional
        (width, height) of the window.
    record : str or os.PathLike, optional
        Write every event fed there as a replay file when the window closes.
    read_files : mapping of str or os.PathLike to str, optional
        Files the window's inputs came from, each with what it is: a save (``s``, ``j``,
        ``S``) that would replace one of them is refused, and the window says so.

    Attributes
    ----------
    controller : VolumeController
        The handles, the settings, the slice point and the view's state; :meth:`feed`
        changes it.
    frames : int
        Frames drawn so far.

    Raises
    ------
    ValueError
        For handles that are not (N, 3) alike, or an unknown ``save_as``.

    See Also
    --------
    App : the image window.

    Examples
    --------
    Construction opens nothing, and the controller takes events at once:

    >>> from glmls.app import Key, VolumeApp, VolumeSettings
    >>> volume = glmls.data.phantom()
    >>> src, dst = glmls.data.phantom_handles()
    >>> app = VolumeApp(volume, src, dst, settings=VolumeSettings(method="backward"))
    >>> app.feed(Key("Up"))
    >>> app.controller.point
    (32, 32, 33)

    Running the window needs a display (so these lines are not run here):

    >>> app.run(events=[Key("e")], frames=3, screenshot="volume.png")  # doctest: +SKIP
    >>> app.run()  # until the window is closed  # doctest: +SKIP
    """

    def __init__(
        self,
        volume: np.ndarray,
        src: object,
        dst: object,
        *,
        spacing: tuple[float, float, float] | None = None,
        save_as: str = ".npy",
        settings: VolumeSettings | None = None,
        name: str = "volume",
        out_dir: str | Path = ".",
        handles_path: str | Path | None = None,
        targets_path: str | Path | None = None,
        window_size: tuple[int, int] | None = None,
        record: str | Path | None = None,
        read_files: Mapping[str | Path, str] | None = None,
    ) -> None:
        given = volume if isinstance(volume, Volume) else Volume(np.asarray(volume))
        if save_as not in VOLUME_SUFFIXES:
            raise ValueError(
                f"save_as must be one of {', '.join(VOLUME_SUFFIXES)}, got {save_as!r}"
            )
        self.volume = given.data
        #: The voxel size (dz, dy, dx) given or the volume's (None: 1) and its affine.
        self.spacing = given.spacing if spacing is None else tuple(spacing)
        self.affine = given.affine
        self.nifti = given.nifti  # a NIfTI input's header fields, kept by s as glmls warp does
        self.save_as = save_as
        self.display = display_volume(self.volume)
        self.controller = VolumeController(
            src, dst, self.display.shape, spacing=self.spacing, settings=settings
        )
        self._start(
            self.controller.grid.montage_shape,
            name=name,
            out_dir=out_dir,
            handles_path=handles_path,
            targets_path=targets_path,
            window_size=window_size,
            record=record,
            read_files=read_files,
        )

    def _open(self, *, vsync: bool) -> None:
        panel = PANEL_CHARS * 8 + 24
        size = self.window_size or window_size(self.controller.grid, panel)
        self._open_window(size, vsync=vsync)
        try:
            check_fits(self.gl, self.display.shape)
        except ValueError:  # refused before a frame, not at the first drag
            self.gl.release()
            self.window.close()
            self.window = None
            raise
        self.session = VolumeSession(self.gl, self.controller, self.display)
        self.view = VolumeView(self.gl, self.controller)
        self._listen()

    # -- events and commands ----------------------------------------------------------------

    def _save_warped(self) -> Path:
        path = self._writable(self._path(f"warped{self.save_as}"))
        mls = self.session.mls if self.window is not None else None
        if mls is None:
            raise ValueError("no valid deformation")
        c = self.controller
        s = c.settings
        warped = mls.warp(
            warped_as(self.volume),  # int16 (CT), bool, ...: the GPU takes floats
            method=s.method,
            interpolation=s.interpolation,
            grid=s.grid,
            border=s.border,
            spacing=c.grid.spacing,
        )
        nifti = self.save_as in (".nii", ".nii.gz")
        write_volume(
            path,
            Volume(
                in_dtype(np.asarray(warped), self.volume.dtype),
                spacing=self.spacing,
                affine=self.affine if nifti else None,
                nifti=self.nifti if nifti else None,
            ),
        )
        return path

    def _save_handles(self, path: Path) -> None:
        if not len(self.controller.src):  # a handle file holds one at least
            raise ValueError("no handles to save")
        write_handles(path, self.controller.src, self.controller.dst)

    def _load_handles(self, path: Path, targets: Path | None) -> str:
        c = self.controller
        src, dst = read_handles(path, dst=targets, ndim=3)
        if self.spacing is not None and elastix_indices(path, dst=targets):  # voxel indices
            scale = np.array(self.spacing[::-1], dtype=np.float64)
            src, dst = src * scale, dst * scale
        c.set_handles(src, dst)
        return f"loaded {len(c.src)} handles from {path}"

    # -- frames -----------------------------------------------------------------------------

    def readout(self) -> list[str]:
        """The lines of the on-screen readout.

        Returns
        -------
        list of str
            The lines, top first; before the window opens, those of the state alone.

        Examples
        --------
        >>> from glmls.app import Key, VolumeApp
        >>> app = VolumeApp(np.zeros((8, 10, 12)), [[2.0, 2, 2]], [[3.0, 2, 2]], name="cube")
        >>> app.readout()[0]
        'glmls  cube  12x10x8'
        >>> [line for line in app.readout() if line.startswith("point")]
        ['point      x 6  y 5  z 4   (click)']
        >>> app.feed(Key("Up"))  # the slice point one voxel along z
        >>> [line for line in app.readout() if line.startswith("point")]
        ['point      x 6  y 5  z 5   (click)']
        """
        c, s = self.controller, self.controller.settings
        fps, frame_ms = frame_rate(self.frame_times)
        ms = {k: 1000 * v for k, v in self.timings.items()}
        depth, height, width = self.display.shape
        x, y, z = c.point
        normal = "xyz"[AXES[c.active][2]]
        lines = [
            f"glmls  {self.name}  {width}x{height}x{depth}",
            f"fps {fps:5.1f}   frame {frame_ms:5.1f} ms",
            f"ms: handles {ms.get('handles', 0):.2f}  slices {ms.get('slices', 0):.1f}",
            f"    analysis {ms.get('analysis', 0):.1f}  draw {ms.get('draw', 0):.1f}",
            "",
            f"transform  {s.config.transform}   (t)",
            f"weight     {s.config.weight}, {c.parameter()}   (w, +/-)",
            f"construct  {s.method} {s.interpolation}   (c)",
            f"grid       {s.grid} voxels   (g/G)",
            f"border     {s.border}   (b)",
            f"point      x {x}  y {y}  z {z}   (click)",
            *self._voxel_size(),
            f"active     {VIEWS[c.active]}: {normal} +/- (Up/Down)",
            f"handles    {len(c.src)} (shown within {c.near:g} voxels)",
            f"overlay    {c.overlay}   (e, f)",
            "",
        ]
        if self.window is not None and self.session.error:
            # with no valid f yet (opened without handles) the slices show the volume itself
            kept = "the last valid f" if self.session.mls is not None else "the volume as it is"
            lines += wrap(f"! {self.session.error}", PANEL_CHARS) + [f"  ({kept})"]
        if self.window is not None and self.session.slice_error:
            lines += wrap(f"! {self.session.slice_error}", PANEL_CHARS)
            lines += ["  (those slices shown undeformed)"]
        lines += self.session.lines if self.window is not None else []
        lines += ["", "F1 or ?: help"]
        for message in self._shown_messages():
            lines += wrap(message, PANEL_CHARS)
        return lines

    def _voxel_size(self) -> list[str]:
        """The readout's line of the voxel size (x, y, z) where the spacing is not 1."""
        grid = self.controller.grid
        if grid.isotropic:
            return []
        return ["voxel      " + " x ".join(f"{d:g}" for d in grid.scale) + " (x, y, z)"]

    def _view_key(self) -> tuple:
        c = self.controller
        return (
            c.revision,
            c.point,
            c.active,
            c.overlay,
            c.show_handles,
            c.help_visible,
            self.window.framebuffer_size,  # type: ignore[union-attr]
            self._shown(),
        )

    def render(self) -> None:
        """Draw one frame into the window's back buffer.

        :meth:`run` opens the window and calls it once a frame; ``on_frame`` sees each frame
        drawn, before it is shown.

        Examples
        --------
        >>> from glmls.app import Key, VolumeApp
        >>> volume = np.zeros((8, 10, 12))
        >>> app = VolumeApp(volume, [[2.0, 2, 2]], [[3.0, 2, 2]], window_size=(400, 300))
        >>> app.window is None  # nothing to draw into before run
        True

        With a display (so these lines are not run here), the frames drawn and seen:

        >>> shots = []
        >>> def keep(window):
        ...     shots.append(window.screenshot())
        >>> app.run(events=[Key("e")], frames=2, on_frame=keep)  # doctest: +SKIP
        >>> len(shots), app.frames, shots[-1].shape  # doctest: +SKIP
        (2, 2, (300, 400, 3))
        """
        window = self.window
        assert window is not None, "open the window with run() first"
        text = self._lay_out()
        session = self.session
        slices = session.slices()
        overlays = session.overlays()
        start = time.perf_counter()
        c = self.controller
        groups = text_groups(
            text,
            self.readout(),
            help_visible=c.help_visible,
            framebuffer=window.framebuffer_size,
        )
        # the labels under the help, at their own sizes (the readout may be smaller)
        groups[1:1] = label_quads(self.layout, c, text)
        self.view.draw(
            self.layout,
            c,
            # a view shown undeformed (the warp refused it) is another picture of one plane
            ((session.revision, c.point, session.mls is None, *session.slice_errors), slices),
            ((session.revision, c.point, c.overlay), overlays),
            groups,
        )
        session.timings["draw"] = time.perf_counter() - start

    def _lay_out(self):
        text = self._text_renderer().atlas
        self.layout = montage_layout(
            self.window.framebuffer_size, self.controller.grid, self._panel
        )
        return text

    def _framed(self) -> None:
        self.timings = dict(self.session.timings)  # handles, slices, analysis, draw
