"""The lattice's margins past the volume for the border modes (:func:`border_margin3`): how
far past each side of the volume the cells must reach so that their deformed image covers
every voxel of the output canvas."""

from __future__ import annotations

import inspect
import math
import warnings
from pathlib import Path

import numpy as np

from ..core.box_growth import Box, box_gains, boxes_meet
from ..errors import BorderWarning
from .fields import Field
from .frame import CornerLattice, Margins, VolumeFrame

__all__ = ["MARGIN_POINTS3", "border_margin3", "margin_shortfall3", "search_margins3"]

#: The most points of the extended lattice, unless the volume and the canvas together have
#: more voxels (then twice theirs, in lattice points): the search of a border mode's margins
#: stops there.
MARGIN_POINTS3 = 1 << 24
#: Rounds of the search at most: where the lattice only gives the backward method's first
#: guesses (``constant``), and where it must cover the canvas (the other border modes).
_GUESS_ROUNDS = 8
_COVER_ROUNDS = 16
#: Points a side at most at which a face of the lattice is sampled.
_FACE_SAMPLES = 33
#: Where a round would end, the cells between a face's samples whose images reach into the
#: canvas's box are sampled again, finer, so that their images lie at most about this far
#: apart (voxels: half the voxel by which the box is grown), with at most this many points
#: in all and this many a side of a cell.
_FINE_STEP = 0.5
_FINE_POINTS = 1 << 18
_FINE_SIDE = 65

_PACKAGE = str(Path(__file__).resolve().parents[1])


def border_margin3(
    field: Field, lattice: CornerLattice, frame: VolumeFrame, *, cover: bool = False
) -> Margins:
    """The margins (voxels, multiples of the grid) that ``lattice`` needs past each side of
    the volume so that its deformed image reaches past every voxel of ``frame``
    (:func:`search_margins3`). With ``cover`` (a border mode other than ``constant``: the
    cells must cover the canvas), a :class:`~glmls.errors.BorderWarning` where the largest
    lattice allowed does not."""
    margins, covered = search_margins3(field, lattice, frame, cover=cover)
    if cover and not covered:
        warnings.warn(margin_shortfall3(margins), BorderWarning, stacklevel=_caller_level())
    return margins


def margin_shortfall3(margins: Margins) -> str:
    """The :class:`~glmls.errors.BorderWarning` of a lattice whose ``margins`` still leave
    part of the canvas uncovered."""
    most = max(max(pair) for pair in margins)
    return (
        f"the lattice reaches {most} voxels past the volume, and f's image of it does not "
        "cover the whole canvas, nor would a larger lattice's up to the most for this volume "
        "and canvas: voxels beyond keep the background"
    )


def search_margins3(
    field: Field, lattice: CornerLattice, frame: VolumeFrame, *, cover: bool = False
) -> tuple[Margins, bool]:
    """The margins of :func:`border_margin3`, and whether the image of the lattice so
    extended covers the canvas.

    The image of the lattice's boundary must keep out of the frame's box grown by a voxel.
    Per side, of the points sampled on the lattice's face there (at most 33 x 33) whose
    images lie in that box across the face, the one f takes furthest into it along the
    face's normal says how much further out the face must lie; a face whose image keeps out
    of the box needs no margin. Before a round ends the search (with ``cover``), the cells
    between the samples whose images reach into the box are sampled again, their images
    about half a voxel apart (:func:`_finer`): a face far larger than the box, sampled
    sparsely, may pass through it between its samples (a shrink leaves every sample
    outside). The faces are first the volume's, then those of the lattice
    with the margins found so far, until each holds (f past the volume is not f on its
    faces: where f shrinks the volume, a face further out is moved further in). Each round
    goes to where the need, growing with the margin at the rate the last two rounds show,
    meets the margin, not only to the last round's need: a shrinking by half doubles the
    margin that its faces ask for at first.

    Without ``cover`` (the backward method's guesses with ``constant``) each margin is at
    most the frame's reach past its side plus twice the volume's largest side. With it, the
    lattice may have up to :data:`MARGIN_POINTS3` points (or twice the volume's and the
    canvas's voxels); and the sampled image of the lattice's boundary must also wind around
    the box (its solid angle seen from the box's centre): where every face holds but the
    box lies outside the deformed lattice (f moves the volume off the canvas sideways), the
    margins grow to the preimage of the box under the affine map that fits f on the faces
    best (else double), and the search goes on. Where the box is out of the image of the
    boundary and inside it, the margins are found even if a face does not hold along its
    normal (a map that mirrors the volume).

    With ``cover``, the margins then reach past the source handles beyond the volume that
    f takes over the canvas (:func:`_pulled_margins`), as far as the budget lets them
    beyond the margins found: the canvas's cover first.

    With ``cover`` the search also ends, the canvas uncovered, as soon as no larger margins
    could help (:func:`~glmls.core.box_growth.box_gains`, the rule of the image's mesh),
    judged over rounds that grew every side's margin, per voxel of the least: the box of the
    deformed faces stopped growing with the margins (a map that collapses the volume: all
    handles' targets at one point), or, outside the canvas, growing on twice as fast as it
    did up to the most any side may reach it would not meet the canvas. The margins are then
    the last round's, or none where that box misses the canvas."""
    grid = lattice.grid
    d, h, w = lattice.shape
    size = np.array([w, h, d], dtype=float)
    low = np.array(frame.origin_voxels)
    high = low + np.array(frame.shape[::-1]) - 1
    # the frame's voxel cubes grown by a voxel, (axis, low / high)
    grown = np.stack([low - 1.5, high + 1.5], axis=1)
    budget = max(MARGIN_POINTS3, 2 * (d * h * w + frame.voxels) // grid**3)
    margins, covered = _covering(field, lattice, cover, size, (low, high), grown, budget)
    if cover:
        # then the space that handles beyond the volume pull over the canvas, within what
        # the budget leaves: after the canvas's cover, which a larger lattice keeps (its
        # cells take in the smaller one's), so that handles far past the volume that f
        # barely moves do not take the budget of a side that the canvas needs
        pulled = np.maximum(margins, grid * np.ceil(_pulled_margins(field, size, grown) / grid))
        margins = _within(margins, pulled, size, grid, budget)
    return _as_margins(margins), covered


def _covering(
    field: Field,
    lattice: CornerLattice,
    cover: bool,
    size: np.ndarray,
    voxels: tuple[np.ndarray, np.ndarray],
    grown: np.ndarray,
    budget: int,
) -> tuple[np.ndarray, bool]:
    """:func:`search_margins3`'s search of the faces (``size``: the volume's (x, y, z);
    ``voxels``: the frame's first and last voxel centres (x, y, z); ``grown``: its box grown
    by a voxel, (axis, low / high); ``budget``: the most lattice points): the (3, 2) margins
    and whether the lattice so extended covers the canvas."""
    grid = lattice.grid
    d, h, w = lattice.shape
    low, high = voxels
    centre = grown.mean(axis=1)
    # how far the frame's voxel centres reach past each side
    overhang = np.stack([np.maximum(0.0, -0.5 - low), np.maximum(0.0, high - size + 0.5)], 1)
    margins = np.zeros((3, 2))
    last = None
    # the last round's least margin and the box of its deformed faces: how fast the box
    # grows with the margins tells whether the budget's lattice could ever cover the canvas.
    # By the least margin, a round that left some side's margin as it was decides nothing
    # (the box need not move along that side's axis), and growth counts per voxel that
    # every side grew
    seen: Box | None = None
    for _ in range(_COVER_ROUNDS if cover else _GUESS_ROUNDS):
        box = np.stack([-0.5 - margins[:, 0], size - 0.5 + margins[:, 1]], axis=1)
        faces = _faces(box)
        images = field.evaluate(np.concatenate([points for *_, points in faces]))
        further, clear = _need(faces, images, grown, overhang + 1 - margins)
        if cover and (clear or np.all(further <= 0)):  # the round may end: look closer
            finer = _finer(faces, images, grown, grid)
            if finer:
                fine_images = field.evaluate(np.concatenate([points for *_, points in finer]))
                more, fine_clear = _need(finer, fine_images, grown, overhang + 1 - margins)
                further = np.maximum(further, more)
                clear = clear and fine_clear
        winding = _winding(faces, images, centre) if cover else None
        if clear and winding is not None and abs(winding) > 0.5:
            return margins, True
        if cover:
            limit = _side_limits(size, margins, grid, budget)
            now = (float(margins.min()), *_box(images))
            if seen is not None and not box_gains(seen, now, float(limit.max()), low, high):
                # a box that misses the canvas covers none of it: no margins then
                met = boxes_meet((now[1], now[2]), low, high)
                return (margins if met else np.zeros((3, 2))), False
            seen = now
        else:
            limit = overhang + 2 * max(w, h, d)
        need = np.minimum(np.maximum(further + margins, 0.0), limit)
        if np.all(need <= margins):
            if not cover or winding is None:
                return margins, True
            if np.any(further > 0):  # a face short of where it must lie, at the limit
                return margins, False
            # every face holds, yet the box lies outside the deformed lattice
            goal = _preimage_need(faces, images, grown, size)
            if goal is None or np.all(goal <= margins):
                goal = 2 * margins + grid
            goal = np.minimum(goal, limit)
            last = None
        else:
            goal = need
            if last is not None:
                with np.errstate(divide="ignore", invalid="ignore"):
                    rate = np.where(margins > last[0], (need - last[1]) / (margins - last[0]), 0.0)
                rate = np.clip(np.nan_to_num(rate), 0.0, 1.0)
                # a need that grows (nearly) as fast as the margin (f shrinks the volume to
                # almost a point) is met far out, if at all; at most doubled a round, as the
                # rate also counts what the other sides' margins did to this face (a face
                # that grows across takes in more of f's image), and a side that leapt to
                # its limit would leave the others' none of the lattice's budget
                ahead = np.where(rate < 0.95, (need - margins) / np.maximum(1 - rate, 0.05), limit)
                doubled = np.maximum(need, 2 * margins + grid)
                goal = np.minimum(np.maximum(need, np.minimum(margins + ahead, doubled)), limit)
            last = (margins, need)
        grown_margins = np.maximum(margins, grid * np.ceil(goal / grid))
        if cover:
            grown_margins = _within(margins, grown_margins, size, grid, budget)
            if np.all(grown_margins <= margins):
                return margins, False
        margins = grown_margins
    return margins, not cover


def _pulled_margins(field: Field, size: np.ndarray, grown: np.ndarray) -> np.ndarray:
    """(3, 2) voxels: per side, twice the distance past it of each source handle beyond the
    volume whose image under f lies over the canvas (``grown``: its box, (axis, low / high)),
    grown by that distance. f folds the space about such a handle onto the canvas, where
    cells before the volume's in scan order may show, whatever the volume's own faces do;
    a larger canvas would reach them for its own sake (the margins search only that the
    faces' image enclose the canvas)."""
    sources = np.asarray(field.sources, dtype=np.float64).reshape(-1, 3)
    past = np.stack([-0.5 - sources, sources - (size - 0.5)], axis=2)  # (N, axis, side)
    far = past.max(axis=(1, 2))
    outside = far > 0
    least = np.zeros((3, 2))
    if not outside.any():
        return least
    images = field.evaluate(sources[outside])
    reach = far[outside][:, None]
    over = np.all((images >= grown[:, 0] - reach) & (images <= grown[:, 1] + reach), axis=1)
    if over.any():
        least = 2.0 * np.maximum(past[outside][over], 0.0).max(axis=0)
    return least


def _box(images: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (low, high) corners (x, y, z) of the finite ``images``; empty (low above high)
    where none is."""
    finite = images[np.isfinite(images).all(axis=1)]
    if len(finite) == 0:
        return np.full(3, np.inf), np.full(3, -np.inf)
    return finite.min(axis=0), finite.max(axis=0)


def _as_margins(margins: np.ndarray) -> Margins:
    return tuple((int(a), int(b)) for a, b in margins)  # type: ignore[return-value]


def _points(size: np.ndarray, margins: np.ndarray, grid: int) -> float:
    """The points of a lattice of step ``grid`` over ``size`` (x, y, z) with ``margins``."""
    return float(np.prod(np.ceil((size + margins.sum(axis=1)) / grid) + 1))


def _side_limits(size: np.ndarray, margins: np.ndarray, grid: int, budget: int) -> np.ndarray:
    """(3, 2): per side, the margin there that keeps the lattice within ``budget`` points
    with the other margins as they are."""
    extent = size + margins.sum(axis=1)
    points = np.ceil(extent / grid) + 1
    limits = np.empty((3, 2))
    for axis in range(3):
        across = float(np.prod(np.delete(points, axis)))
        free = (max(budget // across, 2) - 1) * grid - extent[axis]
        limits[axis] = margins[axis] + max(free, 0.0)
    return limits


def _within(
    margins: np.ndarray, goal: np.ndarray, size: np.ndarray, grid: int, budget: int
) -> np.ndarray:
    """``goal`` (margins, multiples of the grid, at least ``margins``), or where its lattice
    has more than ``budget`` points the largest share of the way from ``margins`` to it
    that has not (the same share on every side)."""
    if _points(size, goal, grid) <= budget:
        return goal

    def part(share: float) -> np.ndarray:
        return margins + grid * np.floor(share * (goal - margins) / grid)

    low, high = 0.0, 1.0
    for _ in range(40):
        middle = (low + high) / 2
        low, high = (middle, high) if _points(size, part(middle), grid) <= budget else (low, middle)
    return part(low)


def _faces(box: np.ndarray) -> list[tuple[int, int, int, int, np.ndarray]]:
    """The six faces of ``box`` ((axis, low / high)), each (axis, end, na, nb, points): the
    (na, nb) points sampled on it along the other two axes in order, (na nb, 3). The faces
    share their edges' points, so that their images close up."""
    axes = [np.linspace(lo, hi, min(_FACE_SAMPLES, int(hi - lo) + 1)) for lo, hi in box]
    faces = []
    for axis in range(3):
        others = [a for a in range(3) if a != axis]
        grid_a, grid_b = np.meshgrid(axes[others[0]], axes[others[1]], indexing="ij")
        for end in (0, 1):
            face = np.empty((grid_a.size, 3))
            face[:, axis] = box[axis, end]
            face[:, others[0]] = grid_a.ravel()
            face[:, others[1]] = grid_b.ravel()
            faces.append((axis, end, *grid_a.shape, face))
    return faces


def _need(
    faces: list, images: np.ndarray, grown: np.ndarray, unmoved: np.ndarray
) -> tuple[np.ndarray, bool]:
    """(3, 2): per axis and end (low, high), how much further out the face there must lie
    (voxels; <= 0 or -inf: none) so that the images of its points that lie in ``grown``
    across the face keep out of it along the face's normal; ``unmoved`` where f is not a
    number at one of the face's points (as though f did not move it). And whether no image
    lies in ``grown`` at all."""
    need = np.full((3, 2), -np.inf)
    clear = True
    start = 0
    for axis, end, *_, face in faces:
        image = images[start : start + len(face)]
        start += len(face)
        if not np.all(np.isfinite(image)):
            need[axis, end] = unmoved[axis, end]
            clear = False
            continue
        across = [a for a in range(3) if a != axis]
        lateral = image[:, across]
        inside = np.all((lateral >= grown[across, 0]) & (lateral <= grown[across, 1]), axis=1)
        if np.any(inside):
            normal = image[inside, axis]
            into = normal - grown[axis, 0] if end == 0 else grown[axis, 1] - normal
            need[axis, end] = max(need[axis, end], float(np.max(into)))
            clear = clear and not np.any((normal > grown[axis, 0]) & (normal < grown[axis, 1]))
    return need, clear


def _finer(faces: list, images: np.ndarray, grown: np.ndarray, grid: int) -> list:
    """Faces' points (as :func:`_faces`' entries, one (axis, end, count, 1, points) per
    face, for :func:`_need`) sampled again, finer, in the cells between ``faces``' samples
    whose images' box meets ``grown`` (the canvas's box) and spans more than
    :data:`_FINE_STEP`: so many a side that their images lie about that far apart where f
    is near linear across a cell, within :data:`_FINE_SIDE` a side and
    :data:`_FINE_POINTS` in all. Only faces sampled more sparsely than their lattice's
    vertices (``grid`` apart): where the samples are those vertices, the lattice's boundary
    is the cells' faces between their images. Empty where no cell needs it."""
    wanted = []
    start = 0
    for axis, end, na, nb, face in faces:
        image = images[start : start + len(face)].reshape(na, nb, 3)
        start += len(face)
        if na < 2 or nb < 2 or not np.all(np.isfinite(image)):
            continue  # (f not a number there: _need takes the face as unmoved)
        across = [a for a in range(3) if a != axis]
        spacing = np.ptp(face[:, across], axis=0) / (np.array([na, nb]) - 1)
        if np.all(spacing <= grid):
            continue
        corners = np.stack([image[:-1, :-1], image[1:, :-1], image[1:, 1:], image[:-1, 1:]])
        low, high = corners.min(axis=0), corners.max(axis=0)
        span = (high - low).max(axis=-1)
        meets = np.all((high >= grown[:, 0]) & (low <= grown[:, 1]), axis=-1)
        cells = np.argwhere(meets & (span > _FINE_STEP))
        if len(cells):
            side = min(_FINE_SIDE, math.ceil(float(span[meets].max()) / _FINE_STEP) + 1)
            wanted.append((axis, end, face.reshape(na, nb, 3), cells, side))
    if not wanted:
        return []
    total = sum(len(cells) * side**2 for *_, cells, side in wanted)
    shrink = min(1.0, math.sqrt(_FINE_POINTS / total))
    finer = []
    for axis, end, points, cells, side in wanted:
        side = max(2, int(side * shrink))
        i, j = cells[:, 0], cells[:, 1]
        corner = points[i, j]
        along_a = (points[i + 1, j] - corner)[:, None, None]
        along_b = (points[i, j + 1] - corner)[:, None, None]
        t = np.linspace(0.0, 1.0, side)
        fine = corner[:, None, None] + t[:, None, None] * along_a + t[None, :, None] * along_b
        fine = fine.reshape(-1, 3)
        finer.append((axis, end, len(fine), 1, fine))
    return finer


#: Per axis, the sign of the normal of a face's triangles (p00, p10, p11) along it: the
#: cross product of the face's two axes in order ((y, z), (x, z), (x, y)).
_TURN = (1.0, -1.0, 1.0)


def _winding(faces: list, images: np.ndarray, centre: np.ndarray) -> float | None:
    """How many times the image of the faces (triangulated between their samples, turned
    outward) winds around ``centre``: the sum of its triangles' solid angles over 4 pi
    (Van Oosterom and Strackee). None where f is not a number at one of the points."""
    if not np.all(np.isfinite(images)):
        return None
    total = 0.0
    start = 0
    for axis, end, na, nb, face in faces:
        q = images[start : start + len(face)].reshape(na, nb, 3) - centre
        start += len(face)
        if na < 2 or nb < 2:
            continue
        p00, p10, p11, p01 = q[:-1, :-1], q[1:, :-1], q[1:, 1:], q[:-1, 1:]
        angle = _solid_angles(p00, p10, p11) + _solid_angles(p00, p11, p01)
        total += _TURN[axis] * (1.0 if end else -1.0) * float(angle.sum())
    return total / (4 * math.pi)


def _solid_angles(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The signed solid angles of the triangles (a, b, c) (..., 3) seen from the origin."""
    la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
    triple = np.einsum("...i,...i", a, np.cross(b, c))
    dots = (
        la * lb * lc
        + np.einsum("...i,...i", a, b) * lc
        + np.einsum("...i,...i", a, c) * lb
        + np.einsum("...i,...i", b, c) * la
    )
    return 2 * np.arctan2(triple, dots)


def _preimage_need(
    faces: list, images: np.ndarray, grown: np.ndarray, size: np.ndarray
) -> np.ndarray | None:
    """(3, 2): the margins that take in the preimage of ``grown``'s corners (and a voxel)
    under the affine map that fits f at the faces' points best (least squares); None where
    that map is singular."""
    points = np.concatenate([face for *_, face in faces])
    lhs = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    fit, *_ = np.linalg.lstsq(lhs, images, rcond=None)
    matrix, offset = fit[:3], fit[3]
    if not np.all(np.isfinite(fit)) or np.linalg.cond(matrix) > 1e12:
        return None
    corners = np.array([[grown[a, (c >> a) & 1] for a in range(3)] for c in range(8)])
    preimage = np.linalg.solve(matrix.T, (corners - offset).T).T
    low = -0.5 - preimage.min(axis=0) + 1
    high = preimage.max(axis=0) - (size - 0.5) + 1
    return np.maximum(np.stack([low, high], axis=1), 0.0)


def _caller_level() -> int:
    """The ``stacklevel`` of :func:`warnings.warn` in :func:`border_margin3` that names the
    first caller outside glmls (the warp's, whichever entry point it took)."""
    here = inspect.currentframe()
    frame = here.f_back.f_back if here is not None and here.f_back is not None else None
    level = 2  # border_margin3's caller
    while frame is not None and frame.f_code.co_filename.startswith(_PACKAGE):
        frame = frame.f_back
        level += 1
    return level
