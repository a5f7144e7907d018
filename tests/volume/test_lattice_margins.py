"""The lattice's margins past the volume are per side: each as far as f moves that face into
the canvas (plus a voxel), none past a face f moves out of it. The result is the one of a
lattice with one wide margin on every side, voxel for voxel, for every border mode and both
methods; and a canvas that shows part of the volume takes only the cells f can take into
it, with the whole lattice's result."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from volume_reference import box_handles

import glmls
from glmls.core.config import MLSConfig
from glmls.volume import VolumeOptions, bands, construction, warp_volume
from glmls.volume.fields import ReferenceField
from glmls.volume.frame import CornerLattice, VolumeFrame
from glmls.volume.margins import border_margin3

SHAPE = (10, 12, 14)


def _shifted(shape, rng, shift, squeeze=0.0, bend=(0.0, 0.0, 0.0)):
    """Handles at the volume's corners moved by ``shift`` (x, y, z), y squeezed by
    ``squeeze`` voxels a side, and one inside moved by ``bend``."""
    src, _ = box_handles(shape, rng, count=8)
    d, h, w = shape
    centre = (np.array([w, h, d]) - 1) / 2
    dst = src + np.asarray(shift, float)
    dst[:, 1] = centre[1] + (src[:, 1] - centre[1]) * (1 - 2 * squeeze / (h - 1)) + shift[1]
    inner = np.array([[w / 3, h / 2, d / 2]])
    return np.concatenate([src, inner]), np.concatenate([dst, inner + np.asarray(bend)])


def test_margins_follow_each_face():
    """A shift by 5.5 voxels along +x moves the low x face inward (a margin of 5.5 + 1,
    rounded up to the grid) and the high one outward (none); z is unmoved (one voxel, a
    grid step); y is squeezed by 3 voxels a side, so a face further out is moved further
    in: its margin is where the face's image clears the volume's first voxel, and no grid
    step less."""
    src, dst = _shifted(SHAPE, np.random.default_rng(1), (5.5, 0.0, 0.0), squeeze=3.0)
    field = ReferenceField(src, dst, MLSConfig(transform="affine"), shape=SHAPE)
    lattice = CornerLattice(SHAPE, 2)
    margins = border_margin3(field, lattice, VolumeFrame(SHAPE))
    assert margins[0] == (8, 0) and margins[2] == (2, 2)
    d, h, w = SHAPE
    face = np.stack(np.meshgrid(np.arange(w), [0.0], np.arange(d), indexing="ij"), -1)
    face = face.reshape(-1, 3)
    for end, sign, edge in ((0, 1, -0.5), (1, -1, h - 0.5)):
        for margin, clear in ((margins[1][end], True), (margins[1][end] - 2, False)):
            face[:, 1] = edge - sign * margin
            image = field.evaluate(face)[:, 1]
            assert np.all(sign * (image - edge) <= -1.0) == clear, (end, margin, image)
    # a canvas reaching 3 voxels past the high x face: 3 + 1 - 5.5 < 0, still none there;
    # 9 past it: 9 + 1 - 5.5 = 4.5, so 6
    for reach, high in ((3, 0), (9, 6)):
        d, h, w = SHAPE
        frame = VolumeFrame((d, h, w + reach), (0.0, 0.0, 0.0))
        assert border_margin3(field, lattice, frame)[0] == (8, high)
    # a canvas starting 4 voxels before the low z face: 4 + 1 there
    frame = VolumeFrame((SHAPE[0] + 4, *SHAPE[1:]), (0.0, 0.0, -4.0))
    assert border_margin3(field, lattice, frame)[2] == (6, 2)


def test_lattice_margins_are_checked():
    lattice = CornerLattice(SHAPE, 2, ((0, 2), (4, 6), (2, 0)))
    assert lattice.low_margin == (0, 4, 2) and lattice.high_margin == (2, 6, 0)
    assert lattice.first == (-0.5, -4.5, -2.5)
    d, h, w = SHAPE
    assert lattice.sizes == (w + 2, h + 10, d + 2)
    assert lattice.box_cells == ((0, 2, 1), (7, 8, 6))
    assert CornerLattice(SHAPE, 2, 4).margins == ((4, 4),) * 3
    for bad in (3, ((0, 3), (0, 0), (0, 0)), ((0, -2), (0, 0), (0, 0))):
        with pytest.raises(ValueError, match="multiples of the grid"):
            CornerLattice(SHAPE, 2, bad)
    for bad in ("2", ((0, 2.0), (0, 0), (0, 0)), None):
        with pytest.raises(TypeError, match="CornerLattice margin"):
            CornerLattice(SHAPE, 2, bad)
    with pytest.raises(ValueError, match="regular"):
        CornerLattice(SHAPE, 2, 2, regular=False)
    # a border lattice without margins is still regular: its points those of a wider one
    bare = CornerLattice((11, 13, 14), 5, 0, regular=True)
    assert bare.last == (14.5, 14.5, 14.5)
    assert CornerLattice((11, 13, 14), 5).last == (13.5, 12.5, 10.5)


def _uniform(monkeypatch, extra):
    """Make the construction's lattice take one margin on every side: the largest of the
    per-side ones plus ``extra`` voxels."""
    made = construction.border_margin3

    def wide(field, lattice, frame, **options):
        margin = max(max(pair) for pair in made(field, lattice, frame, **options)) + extra
        return ((margin, margin),) * 3

    monkeypatch.setattr(construction, "border_margin3", wide)


def _kept_lattices(monkeypatch):
    """The lattices the construction makes from now on, in a list it fills."""
    lattices = []
    made = construction._lattice

    def keep(*args, **kwargs):
        lattices.append(made(*args, **kwargs))
        return lattices[-1]

    monkeypatch.setattr(construction, "_lattice", keep)
    return lattices


def _uncut(monkeypatch):
    """Make the construction take its whole lattice, whatever the canvas."""
    monkeypatch.setattr(construction, "_cropped", lambda field, lattice, frame, pad: lattice)


CASES = {
    # shifted along x, squeezed along y, bent inside
    "shift": ((5.5, 0.0, 0.0), 3.0, (0.0, 2.0, 1.0)),
    # shrunk along y and shifted back along z: the z low face outward
    "squeeze": ((0.0, 0.0, -4.0), 2.5, (2.0, 0.0, 0.0)),
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize(
    ("border", "method"),
    [(b, m) for b in ("constant", "edge", "reflect", "wrap") for m in ("quads", "backward")][1:],
)
@pytest.mark.parametrize("canvas", ["own", "wider"])
def test_per_side_margins_give_the_wide_margin_result(
    kernel3, monkeypatch, case, border, method, canvas
):
    """Voxel for voxel the result of one margin, on every side, wider than any of them (the
    ``constant`` border's cells method has no margins)."""
    rng = np.random.default_rng(7)
    volume = rng.uniform(0, 255, SHAPE).astype(np.float32)
    shift, squeeze, bend = CASES[case]
    src, dst = _shifted(SHAPE, rng, shift, squeeze, bend)
    m = kernel3(src, dst, SHAPE, transform="affine")
    d, h, w = SHAPE
    frame = {}
    if canvas == "wider":  # past the low x and high z faces
        frame = {"output_shape": (d + 3, h, w + 4), "origin": (-4.0, 0.0, 0.0)}
    options = VolumeOptions(method=method, border=border, interpolation="linear", grid=2, **frame)
    lattices = _kept_lattices(monkeypatch)
    sides = warp_volume(m, volume, options=options)
    _uniform(monkeypatch, 4)
    wide = warp_volume(m, volume, options=options)
    np.testing.assert_array_equal(sides, wide)
    narrow, broad = lattices
    assert narrow.cell_count < broad.cell_count
    if border != "constant":
        assert not np.any(sides == 0.0)  # every voxel shows the volume


def test_a_side_short_of_its_margin_leaves_voxels_empty(kernel3, monkeypatch):
    """What the comparison above catches: the low x face moved 5.5 voxels inward with the
    margin there taken away, the voxels before it are left to the background."""
    rng = np.random.default_rng(7)
    volume = rng.uniform(1, 255, SHAPE).astype(np.float32)
    src, dst = _shifted(SHAPE, rng, (5.5, 0.0, 0.0))
    m = kernel3(src, dst, SHAPE, transform="affine")
    options = VolumeOptions(border="edge", interpolation="linear", grid=2)
    made = construction.border_margin3

    def short(field, lattice, frame, **options):
        (_, x_high), y, z = made(field, lattice, frame, **options)
        return (0, x_high), y, z

    full = warp_volume(m, volume, options=options)
    monkeypatch.setattr(construction, "border_margin3", short)
    cut = warp_volume(m, volume, options=options)
    assert not np.any(full == 0.0)
    assert np.all(cut[:, :, :4] == 0.0) and np.array_equal(cut[:, :, 6:], full[:, :, 6:])


def _dragged(shape, rng, drag):
    """Handles at the volume's corners and inside, one of those inside moved by ``drag``."""
    src, _ = box_handles(shape, rng, count=12)
    dst = src.copy()
    dst[9] += np.asarray(drag, float)
    return src, dst


@pytest.mark.parametrize(("method", "grid"), [("quads", 1), ("backward", 2)])
@pytest.mark.parametrize("border", ["constant", "edge"])
def test_a_slice_takes_the_cells_about_its_plane(kernel3, monkeypatch, method, grid, border):
    """A canvas one voxel thick (a slice, as the volume window's views) takes only the
    lattice's cells within f's reach of its plane: the slice of the whole lattice, voxel
    for voxel, along each axis, with a handle dragged 20 voxels in the plane."""
    shape = (20, 72, 80)
    rng = np.random.default_rng(3)
    volume = rng.uniform(0, 255, shape).astype(np.float32)
    src, dst = _dragged(shape, rng, (20.0, -12.0, 0.0))
    m = kernel3(src, dst, shape, transform="rigid", weight="idw")
    d, h, w = shape
    planes = [
        ((1, h, w), (0.0, 0.0, 9.0)),
        ((d, 1, w), (0.0, 40.0, 0.0)),
        ((d, h, 1), (30.0, 0.0, 0.0)),
    ]
    lattices = _kept_lattices(monkeypatch)
    monkeypatch.setattr(construction, "REACH_SAMPLES", 9)  # cut lattices of 8 x 9^3 points on
    slices = [
        VolumeOptions(
            method=method,
            border=border,
            interpolation="linear",
            grid=grid,
            output_shape=size,
            origin=origin,
        )
        for size, origin in planes
    ]
    cut = [warp_volume(m, volume, options=options) for options in slices]
    _uncut(monkeypatch)
    for options, sliced in zip(slices, cut, strict=True):
        np.testing.assert_array_equal(sliced, warp_volume(m, volume, options=options))
    for short, whole in zip(lattices[:3], lattices[3:], strict=True):
        assert short.cell_count < whole.cell_count, (short.cells, whole.cells)
    assert lattices[0].cell_count < 0.6 * lattices[3].cell_count  # f hardly moves z
    assert np.mean(np.concatenate([c.ravel() for c in cut]) == 0.0) < (
        0.2 if border == "constant" else 1e-9
    )


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_a_narrow_bump_between_the_samples_keeps_its_cells(kernel3, monkeypatch, method):
    """One handle pulled 12 voxels out of a slice's plane among six that hold 3 voxels from
    it: f's displacement peaks within a few voxels of that handle, between the samples of
    f's reach (every 8 voxels here). The slice keeps the cells about the handle's source,
    whose images cross its plane: the whole lattice's result, voxel for voxel."""
    shape = (40, 48, 48)
    rng = np.random.default_rng(5)
    volume = rng.uniform(1, 255, shape).astype(np.float32)
    corners, _ = box_handles(shape, rng, count=8, spread=0.0)
    centre = np.array([[23.5, 23.5, 12.0]])
    ring = centre + 3.0 * np.concatenate([np.eye(3), -np.eye(3)])
    src = np.concatenate([corners, ring, centre])
    dst = src.copy()
    dst[-1] += [0.0, 0.0, 12.0]
    m = kernel3(src, dst, shape, transform="affine", weight="idw", alpha=2.0)
    options = VolumeOptions(
        method=method, grid=1, interpolation="linear", output_shape=(1, 48, 48), origin=(0, 0, 24)
    )
    monkeypatch.setattr(construction, "REACH_SAMPLES", 6)
    monkeypatch.setattr(bands, "REACH_SAMPLES", 6)
    sliced = warp_volume(m, volume, options=options)
    _uncut(monkeypatch)
    np.testing.assert_array_equal(sliced, warp_volume(m, volume, options=options))


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_the_space_pulled_over_the_canvas_shows_on_every_canvas(gl, method):
    """As in 2D (tests/imaging/test_canvas.py): a handle 20 voxels above the volume pulled
    into its middle folds the space above over it; with the edge border those cells come
    first in scan order and show on the volume's own canvas as on one three times as large
    (the margins reach past the handle: glmls.volume.margins's _pulled_margins)."""
    d, h, w = 12, 14, 16
    index = np.arange(d * h * w, dtype=np.float32).reshape(d, h, w)
    corners = np.array([[x, y, z] for z in (0, 11) for y in (0, 13) for x in (0, 15)], float)
    src = np.concatenate([[[8.0, -20.0, 6.0]], corners])
    dst = src.copy()
    dst[0] = [8.0, 7.0, 6.0]
    options = {"border": "edge", "method": method, "interpolation": "nearest"}
    with glmls.MLS(src, dst, shape=(d, h, w), ctx=gl) as m:
        own = m.warp(index, **options)
        large = m.warp(index, output_shape=(3 * d, 3 * h, 3 * w), origin=(-w, -h, -d), **options)
    np.testing.assert_array_equal(own, large[d : 2 * d, h : 2 * h, w : 2 * w])


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("reach", [400.0, 1400.0])
def test_handles_far_past_the_volume_leave_the_canvas_its_margins(gl, method, reach):
    """Handles hundreds of voxels past a 12 x 13 x 14 volume, all moved 20 voxels along y
    (f a translation): the margins they ask for (twice their distance, on the sides they lie
    past) would take the whole lattice budget, and the side the canvas needs (-y, 20
    voxels) none of it, leaving the whole volume at the background. The canvas's cover
    comes first: every voxel shows the volume shifted, numpy.pad's edge rule beyond it."""
    shape = (12, 13, 14)
    volume = np.random.default_rng(0).integers(1, 255, shape).astype(np.uint8)
    expected = np.pad(volume, 30, mode="edge")[30:42, 10:23, 30:44]
    src = np.array([[0.0, 0, 0], [reach, 0, 0], [0, reach, 0], [0, 0, reach], [reach] * 3])
    with glmls.MLS(src, src + [0, 20, 0], transform="rigid", shape=shape, ctx=gl) as m:
        with warnings.catch_warnings():
            warnings.simplefilter("error", glmls.BorderWarning)
            out = m.warp(volume, method=method, border="edge")
    np.testing.assert_array_equal(out, expected)


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_a_crop_of_a_landmark_set_is_covered(gl, method):
    """A 32^3 crop at the corner of 20 landmarks spread over 300 voxels, all moved about 10
    voxels along y: every voxel shows the volume (none is 0 in it), without a warning."""
    rng = np.random.default_rng(66)
    shape = (32, 32, 32)
    volume = rng.integers(1, 255, shape).astype(np.uint8)
    src = rng.uniform(0, 300, (20, 3))
    dst = src + [0, 10, 0] + rng.normal(0, 1, src.shape)
    with glmls.MLS(src, dst, transform="affine", shape=shape, ctx=gl) as m:
        with warnings.catch_warnings():
            warnings.simplefilter("error", glmls.BorderWarning)
            out = m.warp(volume, method=method, border="edge")
    assert out.min() > 0
