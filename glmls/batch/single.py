"""One image of a batch on the shared pipeline: the image, its mask, the map of the output
pixels to the source points they show, and its keypoints."""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import moderngl
import numpy as np

from ..core.handles import COORDINATE_LIMIT
from ..core.mesh import MeshLattice
from ..gl.context import GLContext, current, get_context
from ..gl.resources import Resources, keep_framebuffer
from ..imaging.frame import Frame, border_margin, make_frame
from ..imaging.options import WarpOptions
from ..imaging.pipeline import WarpPipeline
from ..mls import MLS
from .footprints import RING
from .labels import (
    in_lattice,
    mesh_corners,
    mesh_keypoints,
    mesh_map,
    on_canvas,
    visible,
)

__all__ = [
    "PROBE_STEP",
    "ImageLabels",
    "SingleWarper",
    "beyond_mesh",
    "in_domain",
    "mask_form",
    "probe_points",
    "probed",
    "restore_mask",
]


class ImageLabels(NamedTuple):
    """What one image of a batch gave (None: not asked for)."""

    image: np.ndarray
    mask: np.ndarray | None = None
    keypoints: np.ndarray | None = None
    keypoints_valid: np.ndarray | None = None
    map: np.ndarray | None = None
    valid: np.ndarray | None = None


def beyond_mesh(lattice: MeshLattice, points: np.ndarray) -> np.ndarray:
    """(P,) bool: the source ``points`` outside the domain of ``lattice``'s cells, where
    ``quads`` keypoints move by f (no cell's map reaches them)."""
    return ~in_lattice(lattice, points)


def mask_form(mask: np.ndarray) -> np.ndarray:
    """A label image as an image the pipeline warps exactly: uint8 and uint16 as they are,
    other integers as float32 (exact within +-2**24)."""
    if mask.dtype in (np.uint8, np.uint16):
        return mask
    return mask.astype(np.float32)


def restore_mask(values: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The warped :func:`mask_form` back to the mask's dtype."""
    if values.dtype == dtype:
        return values
    return np.rint(values).astype(dtype)


def mask_options(options: WarpOptions) -> WarpOptions:
    """The options of a label image: nearest sampling, label 0 where nothing shows."""
    return dataclasses.replace(options, interpolation="nearest", background=0.0)


def by_mesh(options: WarpOptions) -> bool:
    """Are keypoints moved by the regular mesh and tested for folds on it (``quads``, whose
    fill it is)? The other methods test them against their backward map, which shows, where
    f folds, the layer its own search finds: for ``backward`` often not the one the mesh's
    scan order shows."""
    return uses_mesh(options)


def packable(image: np.ndarray, mask: np.ndarray | None, options: WarpOptions) -> bool:
    """Can ``mask`` ride as one more channel of ``image``'s warp: 8 bits, nearest, an image
    of 1 or 3 channels (whose background then leaves the new channel at 0)."""
    if mask is None or options.interpolation != "nearest" or image.dtype != np.uint8:
        return False
    if image.ndim == 3 and image.shape[2] not in (1, 3):
        return False
    if mask.dtype != np.uint8:
        return False
    background = np.asarray(options.background)
    return background.ndim == 0 or len(background) == (image.shape[2] if image.ndim == 3 else 1)


def uses_mesh(options: WarpOptions) -> bool:
    """Does the method place the pixels by the regular mesh's piecewise linear map?"""
    return options.method == "quads" and options.tolerance is None


#: The methods that push the source pixels forward, leaving holes where f stretches.
FORWARD = ("splat", "paper-quads")


def drawn(mls: MLS, shape: tuple[int, int], options: WarpOptions) -> tuple[np.ndarray, np.ndarray]:
    """The source pixel (x, y) that ``mls.warp`` draws with ``options`` at each output
    pixel, (H, W, 2) float64, and (H, W) bool, the pixels it draws: an image of its pixels'
    coordinates + 1 warped with nearest sampling on a background of 0 (float32: exact)."""
    height, width = shape
    rows, columns = np.mgrid[:height, :width]
    numbers = np.dstack([columns + 1, rows + 1]).astype(np.float32)
    warped = mls.warp(numbers, options=mask_options(options)).astype(np.float64)
    return warped - 1.0, warped[..., 0] > 0.5


class SingleWarper:
    """Per-image work of a batch on a context's shared :class:`~glmls.gl.WarpPipeline`."""

    def __init__(self, gl: GLContext) -> None:
        self._gl = gl
        self.pipeline = WarpPipeline.of(gl)
        self._resources = Resources(gl, "the batch warper")

    @classmethod
    def of(cls, ctx: moderngl.Context | GLContext | None = None) -> SingleWarper:
        """The warper shared by everything that renders with ``ctx``."""
        gl = get_context(ctx)
        return gl.shared(SingleWarper, lambda: cls(gl))

    def release(self) -> None:
        """Free the cached GL objects."""
        self._resources.release()

    def warp_one(
        self,
        mls: MLS,
        image: np.ndarray,
        options: WarpOptions,
        *,
        mask: np.ndarray | None,
        points: np.ndarray | None,
        maps: bool,
        index: int,
    ) -> ImageLabels:
        """Image ``index`` of a batch warped by ``mls`` (released here) with its labels."""
        with mls:
            packed = packable(image, mask, options)
            try:
                out = mls.warp(np.dstack([image, mask]) if packed else image, options=options)
            except (ValueError, TypeError) as error:
                raise type(error)(f"images[{index}]: {error}") from error
            warped_mask = None
            if packed:  # the label rode along as one more channel of the same warp
                channels = image.shape[2] if image.ndim == 3 else 0
                out, warped_mask = (out[..., :channels] if channels else out[..., 0]), out[..., -1]
                warped_mask = restore_mask(warped_mask, mask.dtype)  # type: ignore[union-attr]
            elif mask is not None:
                warped = mls.warp(mask_form(mask), options=mask_options(options))
                warped_mask = restore_mask(warped, mask.dtype)
            if points is None and not maps:
                return ImageLabels(out, warped_mask)
            shape = image.shape[:2]
            limit = self.pipeline.max_image_size
            frame = make_frame(options.output_shape, options.origin, shape, limit)
            coords = covered = moved = valid = None
            shown = None  # the source points the picture shows, to test keypoints against
            if maps or (points is not None and not by_mesh(options)):
                forward = options.method in FORWARD
                # f's inverse at every pixel (Newton's method): the maps, what the backward
                # methods show, and a border mode's copies; a forward method's keypoints on
                # the constant border need only the pixels it drew
                if maps or not forward or options.border != "constant":
                    coords, covered = self.source_points(mls, shape, options, frame)
                    shown = coords, covered
                if forward:  # what the fill drew, not f's inverse found
                    pixels, filled = drawn(mls, shape, options)
                    covered = None if covered is None else covered & filled
                    if options.border != "constant":  # beyond the image a drawn pixel is
                        # the border rule's copy, of another number: f's inverse there
                        height, width = shape
                        edge = (coords < 0.5) | (coords > (width - 1.5, height - 1.5))
                        pixels = np.where(edge.any(axis=-1)[..., None], coords, pixels)
                    shown = pixels, filled
            if points is not None:
                moved, valid = self.keypoints(mls, shape, options, frame, points, shown)
            return ImageLabels(out, warped_mask, moved, valid, coords, covered)

    def keypoints(self, mls, shape, options, frame, points, shown):
        """(P, 2) keypoints on the canvas and (P,) bool valid (``shown``: the source points
        the output pixels show and where they show one, or for ``splat`` and
        ``paper-quads`` the source pixels they drew; unused for the mesh)."""
        if not by_mesh(options):
            moved, jacobian, inside = self.move(mls, shape, options, frame, points)
            moved = moved - np.asarray(frame.origin)
            forward = options.method in FORWARD
            return moved, visible(points, moved, jacobian, *shown, inside, drawn=forward)
        lattice = self.lattice(mls, shape, options, frame)
        grid = lattice.points()
        rows, columns = grid.shape[:2]
        vertices = mls(grid.reshape(-1, 2)).reshape(rows, columns, 2)
        # each keypoint followed by its footprint's edge (RING)
        moved, valid = mesh_keypoints(
            lattice, vertices, points, None, nearest=(len(RING), frame.origin)
        )
        beyond = beyond_mesh(lattice, points)
        if beyond.any():  # no cell there: f, not a cell's map drawn out
            moved[beyond] = mls(points[beyond])
        moved = moved - np.asarray(frame.origin)
        return moved, valid & on_canvas(moved, frame.shape)

    def lattice(self, mls: MLS, shape: tuple[int, int], options: WarpOptions, frame: Frame):
        """The quads' mesh, as the pipeline builds it: extended past the image as far as the
        canvas needs with a border mode."""
        lattice = MeshLattice.corners(shape, options.grid)
        if options.border == "constant":
            return lattice
        return lattice.with_margin(border_margin(mls.kernel, lattice, frame, warn=False))

    def move(
        self,
        mls: MLS,
        shape: tuple[int, int],
        options: WarpOptions,
        frame: Frame,
        points: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where ``points`` land (the deformed plane), the local Jacobians (P, 2, 2) and
        whether each lies in the source domain that the method draws."""
        count = len(points)
        if count == 0:
            return np.zeros((0, 2)), np.zeros((0, 2, 2)), np.zeros(0, bool)
        if uses_mesh(options):
            corners, inside = mesh_corners(self.lattice(mls, shape, options, frame), points)
            deformed = mls(corners.reshape(-1, 2)).reshape(count, 4, 2)
            out, jacobian = mesh_map(corners, deformed, points)
            return out, jacobian, inside
        values, jacobian = _probed(mls, points)
        if options.method == "backward-swap":
            values, jacobian = _swapped_preimages(mls, points, values, jacobian)
        return values, jacobian, in_domain(points, shape, options.border)

    @current
    def source_points(
        self, mls: MLS, shape: tuple[int, int], options: WarpOptions, frame: Frame
    ) -> tuple[np.ndarray, np.ndarray]:
        """(H, W, 2) float32 source point shown per output pixel and (H, W) bool covered:
        the quads' own interpolated source points for ``quads`` on a regular mesh, the
        backward map (f's inverse, or the swapped map for ``backward-swap``) otherwise."""
        if uses_mesh(options):
            return self._quads_points(mls, self.lattice(mls, shape, options, frame), frame)
        texture = self.pipeline.solve_inverse(
            mls,
            shape,
            swap=options.method == "backward-swap",
            grid=options.grid,
            border=options.border,
            frame=frame,
        )
        values = np.frombuffer(texture.read(), np.float32).reshape(*frame.shape, 4)
        return values[..., :2].copy(), values[..., 3] > 0.5

    def _quads_points(self, mls: MLS, lattice: MeshLattice, frame: Frame):
        mgl = self._gl.mgl
        with keep_framebuffer(mgl):
            framebuffer = self._resources.framebuffer("coords", frame.size)
            texture = self._resources.texture("coords", frame.size, 4, "f4")
            framebuffer.use()
            framebuffer.viewport = (0, 0, *frame.size)
            self._resources.fill(texture, (0.0, 0.0, 0.0, 0.0))
            pipe = self.pipeline
            fill = {"linear": True, "coords": True, "flip_y": False}
            drawn = pipe.options.compute_quads and pipe.cells.draw(
                mls.kernel, None, lattice, frame, **fill
            )
            if not drawn:
                pipe.raster.draw(mls.kernel, None, lattice, frame, **fill)
            mgl.memory_barrier()
            values = np.frombuffer(texture.read(), np.float32).reshape(*frame.shape, 4)
        return values[..., :2].copy(), values[..., 2] > 0.5


#: Pixels between a keypoint and the probes of its Jacobian's central differences: next to a
#: fold, where f curves within a pixel, a forward difference of half a pixel can point the
#: wrong way (float32's noise in f, ~1e-5 px, is ~1e-4 of the quarter pixel between them).
PROBE_STEP = 0.125


def probe_points(points: np.ndarray) -> np.ndarray:
    """(5P, 2): ``points`` (P, 2), then each moved by :data:`PROBE_STEP` along +x, -x, +y
    and -y, the points at which :func:`probed` takes f (about the nearest point within the
    coordinates the GPU takes, for a point at their limit)."""
    step = PROBE_STEP
    out = np.empty((5, *points.shape))
    out[0] = points
    reach = COORDINATE_LIMIT - step
    if np.abs(points).max(initial=0.0) > reach:  # the probes about a point just inside
        points = np.clip(points, -reach, reach)
    # axis by axis, the very operations of points + (step, 0.0) and so on (numpy adds a pair
    # to (..., 2) arrays with inner loops of two elements); + 0.0 turns -0.0 into 0.0 there
    x, y = points[..., 0], points[..., 1]
    out[1, ..., 0], out[1, ..., 1] = x + step, y + 0.0
    out[2, ..., 0], out[2, ..., 1] = x - step, y - 0.0
    out[3, ..., 0], out[3, ..., 1] = x + 0.0, y + step
    out[4, ..., 0], out[4, ..., 1] = x - 0.0, y - step
    return out.reshape(-1, *points.shape[1:])


def probed(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """f at P points (P, 2) and its Jacobians (P, 2, 2) (rows: d/dx, d/dy) by central
    differences, from ``values``, f at their :func:`probe_points` (5P, 2)."""
    values = values.reshape(5, -1, 2)
    jacobian = np.stack([values[1] - values[2], values[3] - values[4]], axis=1)
    return values[0], jacobian / (2 * PROBE_STEP)


def in_domain(points: np.ndarray, shape: tuple[int, int], border: str) -> np.ndarray:
    """(P,) bool: the source ``points`` that a backward method draws from: within the image
    of ``shape`` (H, W) with the ``constant`` border, anywhere with the others."""
    if border != "constant":
        return np.ones(len(points), bool)
    height, width = shape
    x, y = points[:, 0], points[:, 1]
    return (x >= -0.5) & (x <= width - 0.5) & (y >= -0.5) & (y <= height - 0.5)


def _probed(mls: MLS, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``mls`` at ``points`` (P, 2) and its Jacobians (P, 2, 2) (:func:`probed`)."""
    return probed(mls(probe_points(points)))


def _swapped_preimages(
    mls: MLS, points: np.ndarray, values: np.ndarray, jacobian: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Where ``backward-swap`` shows source ``points``: output pixel u shows s(u), s the MLS
    map with p and q swapped, so a point p lands at s's inverse at p (not at f(p), which
    differs from it by the shortcut's error), with the Jacobian the inverse of s's there.
    ``values``, ``jacobian``: f's, kept where s has no preimage found, and for every point
    where the swapped handles make no MLS of their own (two q that float32 merges with
    different p, or q on one line for the affine fit): the pixels show the swapped kernel's
    map as the single warp evaluates it, unchecked, which has no inverse to solve here."""
    try:
        swapped = MLS.from_config(
            mls.dst,
            mls.src,
            mls.config,
            src_segments=mls.dst_segments,
            dst_segments=mls.src_segments,
            shape=mls.shape,
            ctx=mls.ctx,
            storage=mls.storage,
        )
    except ValueError:  # DegenerateHandlesError too
        return values, jacobian
    with swapped:
        found, ok = swapped.inverse(points, return_valid=True)
        ok &= (np.abs(found) <= COORDINATE_LIMIT).all(axis=1)  # else past what f takes
        if not ok.any():
            return values, jacobian
        _, forward = _probed(swapped, found[ok])
    det = forward[:, 0, 0] * forward[:, 1, 1] - forward[:, 0, 1] * forward[:, 1, 0]
    regular = np.abs(det) > 1e-12  # s turns over there: f's values stay
    where = np.flatnonzero(ok)[regular]
    values, jacobian = values.copy(), jacobian.copy()
    values[where] = found[where]
    jacobian[where] = np.linalg.inv(forward[regular])
    return values, jacobian
