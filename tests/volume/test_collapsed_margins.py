"""Border modes where f collapses or strongly shrinks the volume. The margin search ends as
soon as no larger lattice could cover more of the canvas (the box of the deformed faces
stopped growing: all handles' targets at one point), with a BorderWarning and no lattice
past its first rounds; where larger margins do help (an affine shrink to 1/20, a similarity
shrink to 1/10) they grow in a few rounds as far as they help, and every voxel covered shows
the input extended by the border's rule at f's float64 inverse (scipy.ndimage's modes)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.ndimage import map_coordinates

import glmls
from glmls.core.config import MLSConfig
from glmls.errors import BorderWarning
from glmls.volume import margins
from glmls.volume.fields import ReferenceField
from glmls.volume.frame import CornerLattice, VolumeFrame

SHAPES = ((16, 16, 16), (18, 20, 24))
#: numpy.pad's border modes as scipy.ndimage.map_coordinates names them
MODES = {"edge": "nearest", "reflect": "mirror", "wrap": "grid-wrap"}
#: (transform, scale about the volume's centre; 0: every target at the centre)
MAPS = {
    "all q equal": ("affine", 0.0),
    "affine 0.05": ("affine", 0.05),
    "similarity 1/10": ("similarity", 0.1),
}
BACKGROUND = -7.0
#: The maps whose lattice the budget of MARGIN_POINTS3 points leaves short of the canvas,
#: per method (the backward method's lattice step is 2, so its margins reach twice as far).
UNCOVERED = {("all q equal", "quads"), ("all q equal", "backward"), ("affine 0.05", "quads")}
#: The border modes warped per map: the shrink to 1/20 takes a lattice at the budget (some
#: 16 million points, seconds a warp), so only the mode that moves preimages most.
BORDERS = {"all q equal": tuple(MODES), "affine 0.05": ("wrap",), "similarity 1/10": tuple(MODES)}
#: f32's error in preimages up to 160 voxels past the volume, at values 20 to 80 that change
#: by up to 10 a voxel
ATOL = 0.05


def _centre(shape):
    d, h, w = shape
    return (np.array([w, h, d], float) - 1) / 2


def _handles(shape, scale, shift=(0.0, 0.0, 0.0)):
    """The volume's corners and four points inside, and their images under the scale by
    ``scale`` about the volume's centre and the shift by ``shift``."""
    d, h, w = shape
    corners = [[x, y, z] for z in (0, d - 1) for y in (0, h - 1) for x in (0, w - 1)]
    inner = np.random.default_rng(5).uniform(1, min(shape) - 2, (4, 3))
    src = np.concatenate([np.array(corners, float), inner])
    centre = _centre(shape)
    return src, (src - centre) * scale + centre + np.asarray(shift)


def _volume(shape):
    """Smooth values (no voxel at the background), so that f32's error in a far preimage
    moves a voxel's value little."""
    k, j, i = np.indices(shape, dtype=np.float64)
    return (50 + 20 * np.sin(0.4 * i) * np.cos(0.3 * j) + 10 * np.sin(0.5 * k)).astype(np.float32)


def _preimages(shape, scale, shift=(0.0, 0.0, 0.0)):
    """f's float64 inverse at every voxel centre, (D, H, W, 3) (x, y, z)."""
    u = np.indices(shape)[::-1].reshape(3, -1).T.astype(np.float64)
    centre = _centre(shape)
    s = (u - np.asarray(shift) - centre) / scale + centre
    return s.reshape(*shape, 3)


def _reference(volume, preimages, border):
    coords = preimages.reshape(-1, 3)[:, ::-1].T
    values = map_coordinates(volume.astype(np.float64), coords, order=1, mode=MODES[border])
    return values.reshape(volume.shape)


class _Counted:
    """A field that counts the calls of its ``evaluate``: the search's rounds."""

    def __init__(self, field):
        self.field = field
        self.sources = field.sources
        self.calls = 0

    def evaluate(self, points):
        self.calls += 1
        return self.field.evaluate(points)


def _search(shape, transform, scale, grid):
    src, dst = _handles(shape, scale)
    field = _Counted(ReferenceField(src, dst, MLSConfig(transform=transform), shape=shape))
    lattice = CornerLattice(shape, grid)
    found, covered = margins.search_margins3(field, lattice, VolumeFrame(shape), cover=True)
    return np.array(found, float), covered, field.calls


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("transform", ["affine", "similarity"])
@pytest.mark.parametrize("grid", [1, 2])
@pytest.mark.parametrize("scale", [0.0, 1e-4])
def test_a_collapse_ends_the_search_in_its_first_rounds(shape, transform, grid, scale):
    """Every target at the volume's centre (or the volume shrunk to 1/10,000 about it): the
    faces' image does not grow with the margins, so no lattice covers the
    canvas; the search stops at the second round, its margins those of the first."""
    found, covered, calls = _search(shape, transform, scale, grid)
    assert not covered
    assert calls <= 2
    assert found.max() <= max(shape) + grid, found


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("name", ["affine 0.05", "similarity 1/10"])
@pytest.mark.parametrize("grid", [1, 2])
def test_a_shrink_grows_the_margins_as_far_as_they_help(shape, name, grid):
    """A shrink is no collapse: the faces' image grows with the margins, which grow in a few
    rounds until the lattice covers the canvas or has the most points it may (one more grid
    step a side would take it past the budget): at most doubling a round, and twice more
    where the faces' samples are looked at closer before the search ends."""
    transform, scale = MAPS[name]
    found, covered, calls = _search(shape, transform, scale, grid)
    assert calls <= 8
    d, h, w = shape
    size = np.array([w, h, d], float)
    if covered:
        # the deformed faces lie outside the canvas's voxels grown by a voxel
        assert np.all(scale * (found + size[:, None] / 2) >= size[:, None] / 2 + 1 - 1e-9)
    else:
        wider = np.ceil((size + found.sum(axis=1) + 2 * grid) / grid) + 1
        assert np.prod(wider) > max(margins.MARGIN_POINTS3, 2 * 2 * d * h * w // grid**3)
    if name == "similarity 1/10":
        assert covered


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("name", list(MAPS))
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_collapsed_and_shrunk_volumes_show_the_extended_input(gl, shape, name, method):
    """Where the lattice covers the canvas every voxel equals the float64 reference; where
    it cannot, a BorderWarning, the voxels covered equal it (those whose preimage lies
    within 4 times the volume's largest side of it among them: the margins grew as far as
    they help) and the rest keep the background. All targets at one point, which is no
    voxel centre, cover no voxel."""
    transform, scale = MAPS[name]
    src, dst = _handles(shape, scale)
    volume = _volume(shape)
    uncovered = (name, method) in UNCOVERED
    with glmls.MLS(src, dst, transform=transform, shape=shape) as m:
        for border in BORDERS[name]:
            options = {"method": method, "border": border, "interpolation": "linear"}
            if uncovered:
                with pytest.warns(BorderWarning, match="does not cover the whole canvas"):
                    out = m.warp(volume, background=BACKGROUND, **options)
            else:
                out = m.warp(volume, background=BACKGROUND, **options)
            assert np.isfinite(out).all()
            if scale == 0.0:
                assert np.all(out == BACKGROUND), border
                continue
            preimages = _preimages(shape, scale)
            expected = _reference(volume, preimages, border)
            shown = out != BACKGROUND
            if uncovered:
                d, h, w = shape
                reach = 4 * max(shape)
                top = np.array([w, h, d]) - 0.5 + reach
                near = np.all((preimages >= -0.5 - reach) & (preimages <= top), axis=-1)
                assert np.all(shown[near]), border
                assert not np.all(shown), border
            else:
                assert np.all(shown), border
            np.testing.assert_allclose(out[shown], expected[shown], atol=ATOL, err_msg=border)


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_a_far_translation_is_covered(gl, method):
    """A translation by 3 volume widths along x with ``edge``: the lattice reaches that far
    past the low x face, the canvas is covered (no BorderWarning) and every voxel shows the
    volume's low x face."""
    shape = SHAPES[1]
    width = shape[2]
    src, dst = _handles(shape, 1.0, (3.0 * width, 0.0, 0.0))
    volume = _volume(shape)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BorderWarning)
        with glmls.MLS(src, dst, transform="affine", shape=shape) as m:
            out = m.warp(volume, method=method, border="edge", interpolation="linear")
    expected = np.broadcast_to(volume[:, :, :1], shape)
    np.testing.assert_allclose(out, expected, atol=1e-3)
