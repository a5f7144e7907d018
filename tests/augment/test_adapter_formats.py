"""The adapters of glmls.augment in every format their libraries offer, judged by the pixels:
a keypoint on a bright spot and a box around a bright object must land where the deformed
image shows the spot and the object, through A.Compose (every BboxParams and KeypointParams
format, label fields, filtering) and through torchvision v2 (tv_tensors, plain tensors, PIL,
batches, SanitizeBoundingBoxes), with the call forms and outputs of those libraries' own
transforms; and torch tensors in and out of Augment in any memory layout."""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

os.environ.setdefault("NO_ALBUMENTATIONS_UPDATE", "1")  # no version check over the network

A = pytest.importorskip("albumentations", reason="albumentations not installed (the extra)")
torch = pytest.importorskip("torch", reason="torch not installed (the torch extra)")
tv_tensors = pytest.importorskip("torchvision.tv_tensors", reason="torchvision not installed")

import PIL.Image  # noqa: E402
from torchvision.transforms import v2  # noqa: E402

from glmls.augment import Augment  # noqa: E402
from glmls.augment.albumentations import MLSDeform  # noqa: E402
from glmls.augment.torchvision import MLSTransform  # noqa: E402

H, W = 48, 64
#: A grid deformation that moves handles by up to 4 px: enough to tell a half-pixel slip.
GRID = {"rows": 3, "cols": 3, "displacement": 0.06}
#: Where the bright spots sit, (x, y): pixel centres at integers, off the pixel grid too.
SPOTS = np.array([[20.0, 15.0], [41.3, 30.6], [12.5, 33.0]])
#: The bright object, pixel rows and columns (inclusive): its box is its pixels' edges.
ROWS, COLS = (12, 31), (18, 45)
#: The object's box (x_min, y_min, x_max, y_max) with pixel edges at integers, as
#: albumentations' pascal_voc and torchvision's XYXY count.
OBJECT_BOX = (COLS[0], ROWS[0], COLS[1] + 1, ROWS[1] + 1)


def spots_image(points: np.ndarray = SPOTS, shape: tuple[int, int] = (H, W)) -> np.ndarray:
    """A float32 image, 0 but a small Gaussian spot at each point."""
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    image = np.zeros(shape)
    for x, y in points:
        image += np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * 1.3**2))
    return image.astype(np.float32)


def spot_centres(image: np.ndarray, near: np.ndarray, radius: int = 5) -> np.ndarray:
    """Each spot's brightness-weighted centre (x, y) in ``image``, looked for around ``near``."""
    image = np.asarray(image, np.float64)
    yy, xx = np.mgrid[0 : image.shape[0], 0 : image.shape[1]]
    centres = []
    for x, y in near:
        window = (np.abs(xx - x) <= radius) & (np.abs(yy - y) <= radius)
        weight = np.where(window, image, 0.0)
        centres.append([(weight * xx).sum() / weight.sum(), (weight * yy).sum() / weight.sum()])
    return np.array(centres)


def object_image(shape: tuple[int, int] = (H, W)) -> np.ndarray:
    image = np.zeros(shape, np.float32)
    image[ROWS[0] : ROWS[1] + 1, COLS[0] : COLS[1] + 1] = 1.0
    return image


def object_box(image: np.ndarray) -> np.ndarray:
    """The box around the pixels more than half bright, pixel edges at integers."""
    rows, cols = np.nonzero(np.asarray(image, np.float64) > 0.5)
    return np.array([cols.min(), rows.min(), cols.max() + 1, rows.max() + 1], np.float64)


# --- albumentations -------------------------------------------------------------------------


def to_format(box, fmt: str, shape=(H, W)) -> list[float]:
    x0, y0, x1, y1 = box
    height, width = shape
    if fmt == "pascal_voc":
        return [x0, y0, x1, y1]
    if fmt == "coco":
        return [x0, y0, x1 - x0, y1 - y0]
    if fmt == "yolo":
        return [
            (x0 + x1) / 2 / width,
            (y0 + y1) / 2 / height,
            (x1 - x0) / width,
            (y1 - y0) / height,
        ]
    return [x0 / width, y0 / height, x1 / width, y1 / height]  # albumentations


def from_format(box, fmt: str, shape=(H, W)) -> np.ndarray:
    a, b, c, d = np.asarray(box, np.float64)[:4]
    height, width = shape
    if fmt == "pascal_voc":
        return np.array([a, b, c, d])
    if fmt == "coco":
        return np.array([a, b, a + c, b + d])
    if fmt == "yolo":
        return np.array(
            [(a - c / 2) * width, (b - d / 2) * height, (a + c / 2) * width, (b + d / 2) * height]
        )
    return np.array([a * width, b * height, c * width, d * height])


@pytest.mark.parametrize("fmt", ["pascal_voc", "coco", "yolo", "albumentations"])
def test_albumentations_a_box_follows_its_object_in_every_format(gl, fmt):
    compose = A.Compose(
        [MLSDeform("grid", preset_options=GRID)],
        bbox_params=A.BboxParams(format=fmt, label_fields=["labels", "names"]),
        seed=11,
    )
    out = compose(
        image=object_image(), bboxes=[to_format(OBJECT_BOX, fmt)], labels=[3], names=["car"]
    )
    assert len(out["bboxes"]) == 1 and list(out["labels"]) == [3] and out["names"] == ["car"]
    moved = from_format(out["bboxes"][0], fmt)
    assert np.abs(moved - OBJECT_BOX).max() > 1.5  # the deformation moved it
    np.testing.assert_allclose(moved, object_box(out["image"]), atol=1.0)
    half = A.Compose([HalfSize()], bbox_params=A.BboxParams(format=fmt, label_fields=[]))
    halved = half(image=object_image(), bboxes=[to_format(OBJECT_BOX, fmt)])["bboxes"][0]
    expected = np.array(OBJECT_BOX, np.float64) / 2 + 0.25  # a half-pixel slip would show
    np.testing.assert_allclose(from_format(halved, fmt), expected, atol=2e-3)


@pytest.mark.parametrize(
    "fmt, extra",
    [
        ("xy", []),
        ("yx", []),
        ("xya", [30.0]),
        ("xys", [2.0]),
        ("xyas", [30.0, 2.0]),
        ("xysa", [2.0, 30.0]),
    ],
)
def test_albumentations_a_keypoint_follows_its_spot_in_every_format(gl, fmt, extra):
    """x and y move with the pixels (yx read as y then x); the angle and scale are kept, as
    albumentations' own distortions (A.GridDistortion) keep them; label fields ride along."""
    given = [([y, x] if fmt == "yx" else [x, y]) + extra for x, y in SPOTS]
    params = A.KeypointParams(format=fmt, label_fields=["ids"], remove_invisible=False)
    compose = A.Compose([MLSDeform("grid", preset_options=GRID)], keypoint_params=params, seed=5)
    out = compose(image=spots_image(), keypoints=given, ids=[0, 1, 2])
    moved = np.asarray(out["keypoints"], np.float64)
    assert moved.shape == (3, 2 + len(extra)) and list(out["ids"]) == [0, 1, 2]
    xy = moved[:, ::-1] if fmt == "yx" else moved[:, :2]
    assert np.abs(xy - SPOTS).max() > 1.0  # the deformation moved them
    np.testing.assert_allclose(xy, spot_centres(out["image"], xy), atol=0.3)
    np.testing.assert_allclose(moved[:, 2:], np.array(given)[:, 2:], atol=1e-4)
    half = A.Compose([HalfSize()], keypoint_params=params)(
        image=spots_image(), keypoints=given, ids=[0, 1, 2]
    )
    halved = np.asarray(half["keypoints"], np.float64)
    np.testing.assert_allclose(
        halved[:, ::-1] if fmt == "yx" else halved[:, :2], SPOTS / 2, atol=1e-3
    )
    grid = A.Compose([A.GridDistortion(p=1)], keypoint_params=params, seed=5)
    kept = np.asarray(grid(image=spots_image(), keypoints=given, ids=[0, 1, 2])["keypoints"])
    np.testing.assert_allclose(kept[:, 2:], np.array(given)[:, 2:], atol=1e-4)


class Fixed(MLSDeform):
    """MLSDeform with a fixed draw: every point (x, y) to scale (x, y) + (shift, 0), pixel
    centres at integers (a similarity MLS of four corner handles)."""

    scale, shift = 1.0, 0.0

    def get_params_dependent_on_data(self, params, data):
        height, width = params["shape"][:2]
        src = [[0.0, 0.0], [width - 1.0, 0.0], [0.0, height - 1.0], [width - 1.0, height - 1.0]]
        draw = {
            "preset": "grid",
            "shape": [height, width],
            "src": src,
            "dst": [[self.scale * x + self.shift, self.scale * y] for x, y in src],
            "options": {"transform": "similarity", "interpolation": "linear", "border": "edge"},
        }
        return {"mls": draw}


class ShiftLeft(Fixed):
    """Every point 6 px to the left."""

    shift = -6.0


class HalfSize(Fixed):
    """The image shrunk to half its size towards the centre of pixel (0, 0): a pixel's edge
    at e (pixel edges at integers, as boxes count) goes to e / 2 + 1/4, a pixel centre at c
    (as keypoints count) to c / 2."""

    scale = 0.5


@pytest.mark.parametrize("remove_invisible", [True, False])
def test_albumentations_keypoints_pushed_out_and_empty_lists(gl, remove_invisible):
    params = A.KeypointParams(format="xy", label_fields=["ids"], remove_invisible=remove_invisible)
    compose = A.Compose([ShiftLeft()], keypoint_params=params)
    out = compose(image=spots_image(), keypoints=[(3.0, 10.0), (30.0, 10.0)], ids=[7, 8])
    expected = [[24.0, 10.0]] if remove_invisible else [[-3.0, 10.0], [24.0, 10.0]]
    np.testing.assert_allclose(out["keypoints"], expected, atol=1e-3)
    assert list(out["ids"]) == ([8] if remove_invisible else [7, 8])
    boxes = A.BboxParams(format="coco", label_fields=["labels"])
    empty = A.Compose([ShiftLeft()], keypoint_params=params, bbox_params=boxes)(
        image=spots_image(), keypoints=[], ids=[], bboxes=[], labels=[]
    )
    assert len(empty["keypoints"]) == 0 and len(empty["bboxes"]) == 0


@pytest.mark.parametrize("clip, min_area, kept", [(True, 0, True), (True, 70, False)])
def test_albumentations_box_filters_see_the_moved_box(gl, clip, min_area, kept):
    """A box 8 x 10 px moved 6 px to the left, 4 px of it left: min_area (in pixels after
    clipping) keeps or drops it; BboxParams(clip=True) clips the given box first."""
    params = A.BboxParams(
        format="pascal_voc", label_fields=["labels"], clip=clip, min_area=min_area
    )
    out = A.Compose([ShiftLeft()], bbox_params=params)(
        image=object_image(), bboxes=[(2.0, 10.0, 10.0, 20.0)], labels=[1]
    )
    if kept:
        np.testing.assert_allclose(out["bboxes"], [[0.0, 10.0, 4.0, 20.0]], atol=1e-3)
    else:
        assert len(out["bboxes"]) == 0 and len(out["labels"]) == 0


def test_albumentations_masks_and_images_of_every_kind_move_alike(gl, rng):
    """A single mask and a list of masks, uint8, int32, bool and float32, grayscale (H, W) and
    (H, W, 1), colour and 5-channel images: one map for all, labels kept."""
    labels = np.zeros((H, W), np.uint8)
    labels[ROWS[0] : ROWS[1] + 1, COLS[0] : COLS[1] + 1] = 4
    gray = rng.integers(0, 255, (H, W), dtype=np.uint8)
    compose = A.Compose([MLSDeform("grid", preset_options=GRID)], seed=2)
    out = compose(image=gray, mask=labels)
    assert out["image"].shape == (H, W) and out["mask"].dtype == np.uint8
    for values in (labels.astype(np.int32), labels > 0, labels.astype(np.float32)):
        again = A.Compose([MLSDeform("grid", preset_options=GRID)], seed=2)
        many = again(image=gray, masks=[values, values])["masks"]
        assert [m.dtype for m in many] == [values.dtype] * 2
        for one in many:
            np.testing.assert_array_equal(one != 0, out["mask"] != 0)
    assert set(np.unique(out["mask"]).tolist()) == {0, 4}
    again = A.Compose([MLSDeform("grid", preset_options=GRID)], seed=2)
    np.testing.assert_array_equal(again(image=gray[..., None])["image"][..., 0], out["image"])
    many = rng.integers(0, 255, (H, W, 5), dtype=np.uint8)
    many[..., 4] = gray
    five = A.Compose([MLSDeform("grid", preset_options=GRID)], seed=2)(image=many)["image"]
    np.testing.assert_array_equal(five[..., 4], out["image"])
    soft = A.Compose([MLSDeform("grid", preset_options=GRID)], seed=2)(
        image=gray.astype(np.float32) / 255
    )["image"]
    assert soft.dtype == np.float32
    np.testing.assert_allclose(soft * 255, out["image"], atol=1.0)


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.float16])
def test_floating_point_masks_keep_their_values_exactly(gl, dtype):
    """A floating-point mask's values are labels (or soft labels): nearest sampling gives each
    pixel one of them, bit for bit, in albumentations and torchvision alike; a float64 value
    is not rounded to float32 on the way."""
    mask = np.zeros((H, W), dtype)
    mask[ROWS[0] : ROWS[1] + 1, COLS[0] : COLS[1] + 1] = 1 / 3
    mask[ROWS[0] : ROWS[0] + 4, COLS[0] : COLS[0] + 4] = 0.1
    mask[-8:, :10] = -2.7
    compose = A.Compose([MLSDeform("grid", preset_options=GRID)], seed=2)
    out = compose(image=object_image(), mask=mask, masks=[mask])
    reference = compose.transforms[0].get_applied_params()["mls"]
    for moved in (out["mask"], out["masks"][0]):
        assert moved.dtype == mask.dtype
        assert set(np.unique(moved).tolist()) == set(np.unique(mask).tolist())
    labels = np.searchsorted(np.unique(mask), mask).astype(np.uint8) + 1
    expected = Augment("grid").replay([object_image()], [reference], masks=[labels]).masks[0]
    np.testing.assert_array_equal(out["mask"], np.r_[0, np.unique(mask)][expected])
    torch.manual_seed(0)
    transform = MLSTransform("grid", **GRID)
    _, moved = transform(tv_tensors.Image(image_tensor(object_image())), tv_tensors.Mask(mask))
    assert moved.dtype == torch.from_numpy(mask).dtype
    assert set(np.unique(moved.numpy()).tolist()) == set(np.unique(mask).tolist())
    if dtype == np.float32:  # and torch's bfloat16, which numpy lacks
        half = tv_tensors.Mask(torch.from_numpy(mask).to(torch.bfloat16))
        torch.manual_seed(0)
        _, moved = transform(tv_tensors.Image(image_tensor(object_image())), half)
        assert moved.dtype == torch.bfloat16
        assert set(torch.unique(moved).tolist()) == set(torch.unique(half).tolist())


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.float16])
def test_float_mask_values_are_told_apart_by_their_bits(gl, dtype):
    """-0.0 and 0.0, and NaNs of different payloads, compare equal (or not at all) as
    numbers but are values of their own: each comes back bit for bit, where the draw leaves
    the pixels in place and where it moves them."""
    bits, quiet = {  # the quiet NaN with no payload
        np.float64: (np.uint64, 0x7FF8000000000000),
        np.float32: (np.uint32, 0x7FC00000),
        np.float16: (np.uint16, 0x7E00),
    }[dtype]
    mask = np.zeros((H, W), dtype)
    mask[:, : W // 3] = -0.0
    mask[: H // 2, W // 3 :] = np.array(quiet + 5, bits).view(dtype)
    mask[H // 2 :, 2 * W // 3 :] = np.array(quiet + 9, bits).view(dtype)
    kinds = set(np.unique(mask.view(bits)).tolist())
    assert len(kinds) == 4
    for options in ({"displacement": 0.0}, GRID):
        compose = A.Compose([MLSDeform("grid", preset_options=options)], seed=2)
        moved = compose(image=object_image(), mask=mask)["mask"]
        assert moved.dtype == mask.dtype
        assert set(np.unique(moved.view(bits)).tolist()) <= kinds
        if options != GRID:
            np.testing.assert_array_equal(moved.view(bits), mask.view(bits))
        torch.manual_seed(0)
        image = tv_tensors.Image(image_tensor(object_image()))
        _, out = MLSTransform("grid", **options)(image, tv_tensors.Mask(mask))
        assert set(np.unique(out.numpy().view(bits)).tolist()) <= kinds
        if options != GRID:
            np.testing.assert_array_equal(out.numpy().view(bits), mask.view(bits))


def test_albumentations_alone_as_in_compose(gl):
    """Called alone with its random generator seeded as Compose seeds it, the transform gives
    what it gives in A.Compose(seed=...) (targets in albumentations' own format)."""
    image = spots_image()
    alone = MLSDeform("grid", preset_options=GRID)
    alone.set_random_seed(4)
    points = np.array([[20.0, 15.0, 0.0, 0.0, 0.0]])
    boxes = np.array([[0.2, 0.3, 0.6, 0.7]])
    one = alone(image=image, keypoints=points, bboxes=boxes)
    compose = A.Compose(
        [MLSDeform("grid", preset_options=GRID)],
        keypoint_params=A.KeypointParams(format="xy"),
        bbox_params=A.BboxParams(format="albumentations"),
        seed=4,
    )
    both = compose(image=image, keypoints=points[:, :2], bboxes=boxes)
    np.testing.assert_array_equal(one["image"], both["image"])
    np.testing.assert_allclose(one["keypoints"][:, :2], both["keypoints"], atol=1e-4)
    np.testing.assert_allclose(one["bboxes"], both["bboxes"], atol=1e-5)


def test_albumentations_serialisation_and_seeds(gl):
    compose = A.Compose(
        [MLSDeform("text-stretch", preset_options={"segments": 3}, box_step=1.5, p=0.9)], seed=8
    )
    rebuilt = A.from_dict(A.to_dict(compose))
    rebuilt.set_random_seed(8)
    image = spots_image()
    first = [compose(image=image)["image"] for _ in range(3)]
    again = [rebuilt(image=image)["image"] for _ in range(3)]
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(first[0], first[1])  # each call draws anew
    t = rebuilt.transforms[0]
    assert (t.preset, t.preset_options) == ("text-stretch", {"segments": 3})
    assert (t.box_step, t.p) == (1.5, 0.9)


@pytest.mark.parametrize("p", [-0.1, 1.5, float("nan")])
def test_albumentations_p_out_of_range_is_refused(p):
    with pytest.raises(ValueError, match=rf"^p must be a probability from 0 to 1, got {p}$"):
        MLSDeform(p=p)


@pytest.mark.parametrize("p", [None, True, "0.5", 1j])
def test_albumentations_p_of_the_wrong_type_is_refused(p):
    """A p that is no real number is refused as glmls refuses one (albumentations' own
    check would take True and "0.5" as numbers)."""
    with pytest.raises(TypeError, match=r"^p must be a probability from 0 to 1, got "):
        MLSDeform(p=p)
    assert MLSDeform(p=np.array(0.5)).p == 0.5


@pytest.mark.parametrize("name", ["preset_options", "warp_options"])
@pytest.mark.parametrize("value", ["rows=3", [1, 2], 5])
def test_albumentations_options_that_are_not_mappings_are_named(name, value):
    with pytest.raises(TypeError, match=f"{name} must be a mapping or None, got"):
        MLSDeform(**{name: value})


def test_albumentations_landmarks_without_keypoints_is_an_error(gl):
    """The landmarks preset moves the keypoints it is given: without them there is nothing to
    move, which would be an identity in silence; albumentations' targets_as_params says so."""
    transform = MLSDeform("landmarks", preset_options={"displacement": 2, "units": "pixels"})
    assert transform.targets_as_params == ["keypoints"]
    assert MLSDeform("grid").targets_as_params == []
    with pytest.raises(ValueError, match="keypoints"):
        A.Compose([transform], seed=0)(image=spots_image())
    with pytest.raises(ValueError, match="keypoints"):
        transform(image=spots_image())
    params = A.KeypointParams(format="yx")
    out = A.Compose([transform], keypoint_params=params, seed=0)(
        image=spots_image(), keypoints=SPOTS[:, ::-1]
    )
    moved = np.asarray(out["keypoints"])[:, ::-1]
    np.testing.assert_allclose(moved, spot_centres(out["image"], moved), atol=0.3)


# --- torchvision ----------------------------------------------------------------------------


def half_size(shape: tuple[int, int]) -> dict:
    """HalfSize's draw for MLSTransform: (x, y) to (x, y) / 2, pixel centres at integers."""
    return {
        **HalfSize().get_params_dependent_on_data({"shape": shape}, {})["mls"],
        "config": {},
        "seed": 0,
        "index": 0,
    }


def image_tensor(array: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(array))[None]  # (1, H, W)


@pytest.mark.parametrize("fmt", ["XYXY", "XYWH", "CXCYWH"])
def test_torchvision_a_box_follows_its_object_in_every_format(gl, fmt):
    F = v2.functional
    image = tv_tensors.Image(image_tensor(object_image()))
    given = F.convert_bounding_box_format(
        torch.tensor([OBJECT_BOX], dtype=torch.float32), old_format="XYXY", new_format=fmt
    )
    boxes = tv_tensors.BoundingBoxes(given, format=fmt, canvas_size=(H, W))
    torch.manual_seed(3)
    out_image, out_boxes = MLSTransform("grid", **GRID)(image, boxes)
    assert isinstance(out_boxes, tv_tensors.BoundingBoxes) and out_boxes.format == boxes.format
    assert out_boxes.canvas_size == (H, W) and out_boxes.dtype == torch.float32
    xyxy = F.convert_bounding_box_format(
        out_boxes.as_subclass(torch.Tensor), old_format=fmt, new_format="XYXY"
    )[0].numpy()
    assert np.abs(xyxy - OBJECT_BOX).max() > 1.5
    np.testing.assert_allclose(xyxy, object_box(out_image.numpy()[0]), atol=1.0)
    elastic = v2.ElasticTransform(alpha=20.0)(image, boxes)[1]  # torchvision's own: the same kind
    assert elastic.format == out_boxes.format and elastic.canvas_size == out_boxes.canvas_size
    half = MLSTransform("grid")
    half.augment.draw = lambda shapes, **_: [half_size(tuple(s)) for s in shapes]
    points = tv_tensors.KeyPoints(torch.from_numpy(SPOTS), canvas_size=(H, W))
    _, halved, moved = half(image, boxes, points)
    xyxy = F.convert_bounding_box_format(
        halved.as_subclass(torch.Tensor), old_format=fmt, new_format="XYXY"
    )[0].numpy()
    np.testing.assert_allclose(xyxy, np.array(OBJECT_BOX) / 2 + 0.25, atol=2e-3)
    np.testing.assert_allclose(moved.numpy(), SPOTS / 2, atol=1e-3)


def test_torchvision_keypoints_follow_their_spots_in_a_batch(gl):
    """A batch (N, C, H, W): each sample its own draw, its keypoints on its spots."""
    one = spots_image()
    batch = tv_tensors.Image(torch.from_numpy(np.stack([one[None]] * 3)))
    points = tv_tensors.KeyPoints(torch.from_numpy(np.stack([SPOTS] * 3)), canvas_size=(H, W))
    torch.manual_seed(0)
    out_images, out_points = MLSTransform("grid", **GRID)(batch, points)
    assert isinstance(out_points, tv_tensors.KeyPoints) and out_points.canvas_size == (H, W)
    assert out_points.dtype == points.dtype and out_points.shape == points.shape
    for k in range(3):
        xy = out_points[k].numpy()
        np.testing.assert_allclose(xy, spot_centres(out_images[k, 0].numpy(), xy), atol=0.3)
    assert not torch.allclose(out_points[0], out_points[1])


def test_torchvision_every_input_of_a_call_moves_by_one_draw(gl, rng):
    """torchvision transforms every input of one call alike: two images (an image and its
    depth map, a stereo pair), several masks, several keypoint sets and box sets of one
    sample take the same deformation, as v2.ElasticTransform gives them."""
    colour = rng.integers(0, 255, (3, H, W), dtype=np.uint8)
    first = tv_tensors.Image(torch.from_numpy(colour))
    second = tv_tensors.Image(torch.from_numpy(colour.copy()))
    mask = tv_tensors.Mask(torch.from_numpy((object_image() > 0).astype(np.uint8)))
    points = tv_tensors.KeyPoints(torch.from_numpy(SPOTS), canvas_size=(H, W))
    boxes = tv_tensors.BoundingBoxes(
        torch.tensor([OBJECT_BOX], dtype=torch.float32), format="XYXY", canvas_size=(H, W)
    )
    sample = {
        "image": first,
        "depth": second,
        "masks": mask,
        "semantic": tv_tensors.Mask(mask.clone()),
        "points": points,
        "more_points": tv_tensors.KeyPoints(points.clone(), canvas_size=(H, W)),
        "boxes": boxes,
        "crowd": tv_tensors.BoundingBoxes(boxes.clone(), format="XYXY", canvas_size=(H, W)),
        "labels": torch.tensor([5]),
    }
    transform = MLSTransform("grid", **GRID)
    torch.manual_seed(1)
    out = transform(sample)
    assert len(transform.last_params) == 1
    assert torch.equal(out["image"], out["depth"]) and not torch.equal(out["image"], first)
    assert torch.equal(out["masks"], out["semantic"])
    assert torch.equal(out["points"], out["more_points"])
    assert torch.equal(out["boxes"], out["crowd"])
    assert out["labels"] is sample["labels"]
    elastic = v2.ElasticTransform(alpha=50.0)(sample)
    assert torch.equal(elastic["image"], elastic["depth"])
    with pytest.raises(ValueError, match=r"\(24, 32\).*\(48, 64\)|\(48, 64\).*\(24, 32\)"):
        transform(first, tv_tensors.Image(torch.zeros(3, 24, 32, dtype=torch.uint8)))


def test_torchvision_landmarks_of_a_batch_of_one(gl):
    """A batch of one may give its KeyPoints without the batch dimension: every landmark is
    the sample's, not the first alone."""
    image = tv_tensors.Image(torch.from_numpy(spots_image()[None, None]))
    points = tv_tensors.KeyPoints(torch.from_numpy(SPOTS), canvas_size=(H, W))
    transform = MLSTransform("landmarks", displacement=3.0, units="pixels")
    torch.manual_seed(6)
    out_image, out_points = transform(image, points)
    assert len(transform.last_params[0]["src"]) == len(SPOTS) + 4  # the corners pinned
    xy = out_points.numpy()
    np.testing.assert_allclose(xy, transform.last_params[0]["dst"][: len(SPOTS)], atol=0.05)
    np.testing.assert_allclose(xy, spot_centres(out_image.numpy()[0, 0], xy), atol=0.3)


def test_torchvision_labels_that_do_not_fit_are_named(gl):
    """A canvas_size other than the image's (torchvision's own transforms refuse it: "Found
    multiple HxW dimensions") and boxes whose maximum lies below their minimum (XYWH labelled
    XYXY) are errors naming them, not boxes and keypoints moved by another image's map or
    turned into plausible boxes."""
    image = tv_tensors.Image(image_tensor(object_image()))
    transform = MLSTransform("grid", **GRID)
    turned = tv_tensors.KeyPoints(torch.from_numpy(SPOTS), canvas_size=(W, H))
    with pytest.raises(ValueError, match=rf"\({H}, {W}\), \({W}, {H}\)"):
        transform(image, turned)
    with pytest.raises(ValueError, match="multiple HxW"):
        v2.RandomCrop(8)(image, turned)
    xywh = tv_tensors.BoundingBoxes(
        torch.tensor([[4.0, 4.0, 30.0, 30.0], [30.0, 10.0, 12.0, 20.0]]),
        format="XYXY",
        canvas_size=(H, W),
    )
    with pytest.raises(ValueError, match=r"BoundingBoxes\[1\] \[30.0, 10.0, 12.0, 20.0\] in XYXY"):
        transform(image, xywh)
    for fmt in ("XYXY", "XYWH", "CXCYWH"):
        lost = tv_tensors.BoundingBoxes(
            torch.tensor([[4.0, 4.0, 30.0, 30.0], [float("nan"), 10.0, 12.0, 20.0]]),
            format=fmt,
            canvas_size=(H, W),
        )
        with pytest.raises(ValueError, match=r"BoundingBoxes\[1\] \[nan, .* not finite"):
            transform(image, lost)


def test_torchvision_plain_tensors_and_pil_as_torchvision_takes_them(gl, rng):
    """Without a tv_tensors.Image, Video or PIL image, the first plain tensor is the image
    and the others pass through untouched (torchvision's rule); with one, every plain tensor
    passes through."""
    transform = MLSTransform("grid", **GRID)
    image = torch.from_numpy(rng.random((3, H, W), dtype=np.float32))
    other = torch.from_numpy(rng.random((3, H, W), dtype=np.float32))
    torch.manual_seed(2)
    out_image, out_other = transform(image, other)
    assert type(out_image) is torch.Tensor and not torch.equal(out_image, image)
    assert out_other is other
    pil = PIL.Image.fromarray(rng.integers(0, 255, (H, W, 3), dtype=np.uint8))
    mask = tv_tensors.Mask(torch.from_numpy((object_image() > 0).astype(np.int64)))
    torch.manual_seed(2)
    out_pil, out_mask, out_plain = transform(pil, mask, image)
    assert isinstance(out_pil, PIL.Image.Image) and out_pil.size == (W, H)
    assert isinstance(out_mask, tv_tensors.Mask) and out_mask.dtype == torch.int64
    assert out_plain is image


def test_torchvision_a_bilevel_pil_image(gl):
    """PIL's mode "1" (torchvision's own RandomAffine keeps it): its pixels move with nearest
    sampling, as the object's pixels do in a float image."""
    bilevel = PIL.Image.fromarray(object_image() > 0)
    assert bilevel.mode == "1"
    torch.manual_seed(7)
    out = MLSTransform("grid", **GRID)(bilevel)
    torch.manual_seed(7)
    grey = MLSTransform("grid", **GRID, warp_options={"interpolation": "nearest"})(
        tv_tensors.Image(image_tensor(object_image()))
    )
    assert isinstance(out, PIL.Image.Image) and out.mode == "1" and out.size == (W, H)
    np.testing.assert_array_equal(np.asarray(out), grey.numpy()[0] > 0.5)
    assert v2.RandomAffine(10)(bilevel).mode == "1"


@pytest.mark.parametrize("dtype", ["bool", "int64", "uint8"])
def test_torchvision_masks_and_images_keep_their_types(gl, dtype):
    labels = torch.from_numpy((object_image() > 0).astype(np.uint8) * 3).to(getattr(torch, dtype))
    image = tv_tensors.Image(image_tensor(object_image()))
    torch.manual_seed(4)
    out_image, out_mask = MLSTransform("grid", **GRID)(image, tv_tensors.Mask(labels))
    assert isinstance(out_image, tv_tensors.Image) and out_image.dtype == torch.float32
    assert isinstance(out_mask, tv_tensors.Mask) and out_mask.dtype == labels.dtype
    assert set(torch.unique(out_mask).tolist()) == set(torch.unique(labels).tolist())
    np.testing.assert_array_equal(out_mask.numpy() != 0, out_image.numpy()[0] > 0.5)


@pytest.mark.parametrize("dtype", ["int8", "int16", "int32", "int64", "uint32"])
def test_torchvision_integer_images_of_every_dtype(gl, dtype):
    """torchvision's transforms take integer images of any dtype and round what they
    interpolate: an image of int8 ... uint32 comes back of its dtype, its float64 warp
    rounded."""
    values = object_image() * 100 - (50 if dtype.startswith("int") else 0)
    image = tv_tensors.Image(image_tensor(values).to(getattr(torch, dtype)))
    torch.manual_seed(4)
    out = MLSTransform("grid", **GRID)(image)
    torch.manual_seed(4)
    exact = MLSTransform("grid", **GRID)(tv_tensors.Image(image_tensor(values).double()))
    assert isinstance(out, tv_tensors.Image) and out.dtype == image.dtype
    np.testing.assert_array_equal(out.numpy(), np.rint(exact.numpy()))


@pytest.mark.parametrize(
    ("dtype", "background", "message"),
    [
        ("uint8", 0.5, "not a value of uint8"),
        ("int16", 0.5, "not a value of int16"),  # warped as float64: its own rule all the same
        ("int32", (1.0, 2.5, 0.0), "not a value of int32"),
        ("int8", -200.0, r"outside -128\.\.127 of int8"),
        # warped as uint8, and not named so
        ("bool", 0.5, r"not a value of bool: 0\.5 is no whole number \(give one of 0\.\.1\)"),
    ],
)
def test_torchvision_a_background_is_a_value_of_the_image_s_own_dtype(
    gl, dtype, background, message
):
    """The adapter warps some integer dtypes as another (bool as uint8, int16 as float64);
    a background is checked against the image's own, as glmls.warp checks uint8's."""
    values = image_tensor(object_image()).expand(len(np.atleast_1d(background)), -1, -1)
    image = tv_tensors.Image(values.clone().to(getattr(torch, dtype)))
    transform = MLSTransform("grid", **GRID, warp_options={"background": background})
    with pytest.raises(ValueError, match=message):
        transform(image)


def test_torchvision_a_bool_image_moves_as_a_bilevel_one(gl):
    """A bool image tensor (torchvision's transforms keep its dtype) moves as PIL's mode "1":
    its pixels with nearest sampling."""
    mask = object_image() > 0
    torch.manual_seed(7)
    out = MLSTransform("grid", **GRID)(tv_tensors.Image(image_tensor(mask)))
    torch.manual_seed(7)
    bilevel = MLSTransform("grid", **GRID)(PIL.Image.fromarray(mask))
    assert isinstance(out, tv_tensors.Image) and out.dtype == torch.bool
    np.testing.assert_array_equal(out.numpy()[0], np.asarray(bilevel))
    assert out.any() and not out.all()


def test_torchvision_masks_with_large_labels(gl):
    """Instance ids beyond 2**24 in an int64 Mask come back bit for bit."""
    ids = (object_image() > 0).astype(np.int64) * (2**40 + 1)
    image = tv_tensors.Image(image_tensor(object_image()))
    torch.manual_seed(4)
    _, out = MLSTransform("grid", **GRID)(image, tv_tensors.Mask(torch.from_numpy(ids)))
    torch.manual_seed(4)
    _, small = MLSTransform("grid", **GRID)(image, tv_tensors.Mask(torch.from_numpy(ids > 0)))
    assert out.dtype == torch.int64
    np.testing.assert_array_equal(out.numpy(), small.numpy() * (2**40 + 1))


def test_torchvision_repr_shows_the_options_not_the_last_draw(gl):
    """torchvision's transforms show their parameters in their repr (a v2.Compose prints
    them); the last call's handles are no parameter."""
    transform = MLSTransform("grid", **GRID, warp_options={"transform": "rigid"})
    torch.manual_seed(0)
    transform(tv_tensors.Image(torch.zeros(8, 3, H, W)))
    shown = repr(v2.Compose([transform]))
    assert "rows=3, cols=3, displacement=0.06" in shown and "'rigid'" in shown
    assert "last_params" not in shown and len(shown) < 400


def test_torchvision_compose_with_sanitize_bounding_boxes(gl):
    """v2.Compose([MLSTransform, v2.SanitizeBoundingBoxes()]): a box the deformation leaves
    on the canvas stays with its label, a degenerate one goes with its label."""
    image = tv_tensors.Image(image_tensor(object_image()))
    boxes = tv_tensors.BoundingBoxes(
        torch.tensor([OBJECT_BOX, (0.0, 0.0, 0.5, 0.5)]), format="XYXY", canvas_size=(H, W)
    )
    pipeline = v2.Compose([MLSTransform("grid", **GRID), v2.SanitizeBoundingBoxes()])
    torch.manual_seed(5)
    out = pipeline({"image": image, "boxes": boxes, "labels": torch.tensor([1, 2])})
    assert out["labels"].tolist() == [1] and out["boxes"].shape == (1, 4)
    np.testing.assert_allclose(out["boxes"][0].numpy(), object_box(out["image"][0]), atol=1.0)


# --- torch tensors in and out of Augment ----------------------------------------------------


def test_augment_tensors_in_any_memory_layout(gl, rng):
    """channels_last, a permuted view and a strided slice are the same images as their
    contiguous copies; a tensor that requires grad comes back detached."""
    big = torch.from_numpy(rng.integers(0, 255, (2, 3, 2 * H, 2 * W), dtype=np.uint8))
    images = big[:, :, ::2, ::2]
    aug = Augment("grid", seed=1, **GRID)
    expected = aug(images.contiguous()).images
    for view in (
        images,
        images.contiguous(memory_format=torch.channels_last),
        images.transpose(2, 3).contiguous().transpose(2, 3),
    ):
        out = aug(view).images
        assert torch.equal(out, expected) and out.dtype == torch.uint8
    floats = (images.float() / 255).requires_grad_()
    points = torch.from_numpy(np.stack([SPOTS] * 2)).requires_grad_()
    out = aug(floats, keypoints=points)
    assert not out.images.requires_grad and out.keypoints.dtype == torch.float64
    torch.testing.assert_close(out.images * 255, expected.float(), atol=1.0, rtol=0)
    image = tv_tensors.Image(floats.detach()[0].clone().requires_grad_())
    moved = MLSTransform("grid", **GRID)(image)
    assert isinstance(moved, tv_tensors.Image) and not moved.requires_grad


def test_augment_integer_label_tensors_come_back_as_the_numpy_call_moves_them(gl):
    """Keypoints, boxes and polygons given as integer tensors (annotations at whole pixels)
    come back float64, equal to the numpy call's: cast back to their integer dtype they
    would be cut to whole pixels, a box's clipped edge at -0.5 to 0."""
    aug = Augment("grid", seed=1, **GRID)
    images = np.zeros((2, H, W, 3), np.uint8)
    points = np.array([[[20, 15], [41, 30]], [[12, 33], [W - 1, H - 1]]])
    boxes = np.array([[[18, 12, 45, 31]], [[0, 0, W - 1, H - 1]]])
    square = np.array([[18, 12], [45, 12], [45, 31], [18, 31]])
    expected = aug(images, keypoints=points, boxes=boxes, polygons=[[square]] * 2)
    out = aug(
        torch.from_numpy(images).permute(0, 3, 1, 2),
        keypoints=torch.from_numpy(points),
        boxes=torch.from_numpy(boxes.astype(np.int32)),
        polygons=[[torch.from_numpy(square)]] * 2,
    )
    assert out.keypoints.dtype == out.boxes.dtype == out.polygons[0][0].dtype == torch.float64
    np.testing.assert_array_equal(out.keypoints.numpy(), expected.keypoints)
    np.testing.assert_array_equal(out.keypoints_valid.numpy(), expected.keypoints_valid)
    np.testing.assert_array_equal(out.boxes.numpy(), expected.boxes)
    np.testing.assert_array_equal(out.polygons[1][0].numpy(), expected.polygons[1][0])
    assert out.boxes[1, 0, 0] == -0.5  # the image's edge, past the last pixel centre


def test_augment_tensors_of_the_wrong_rank_name_torchs_layout():
    aug = Augment("grid", seed=1)
    for shape in [(8,), (2, 2, 3, 8, 8)]:
        with pytest.raises(
            ValueError, match=re.escape(f"shape {shape}; expected a batch (N, C, H, W)")
        ):
            aug(torch.zeros(shape))
    with pytest.raises(ValueError, match=r"images\[1\] is a tensor of shape \(8,\)"):
        aug([torch.zeros(3, 8, 8), torch.zeros(8)])
    for shape in [(2, 5, 16, 20), (2, 16, 20, 3)]:  # channels last, or more than four
        with pytest.raises(ValueError, match=re.escape(f"shape {shape}; expected a batch (N, C")):
            aug(torch.zeros(shape, dtype=torch.uint8))
    with pytest.raises(ValueError, match=r"images\[0\] is a tensor of shape \(16, 20, 3\)"):
        aug([torch.zeros(16, 20, 3, dtype=torch.uint8)])


#: A canvas 8 px larger on every side: ``output_shape`` and ``origin`` among the warp options.
CANVAS = {"output_shape": (H + 16, W + 16), "origin": (-8.0, -8.0)}


def test_albumentations_on_a_canvas_of_another_size(gl):
    """With ``output_shape``, the image, mask, keypoints and boxes all land on the new
    canvas: albumentations' boxes are fractions of the output image's size."""
    transform = MLSDeform("grid", preset_options={"displacement": 0}, warp_options=CANVAS)
    compose = A.Compose(
        [transform],
        bbox_params=A.BboxParams(format="pascal_voc", label_fields=["labels"]),
        keypoint_params=A.KeypointParams(format="xy"),
        seed=0,
    )
    mask = (object_image() > 0).astype(np.uint8)
    out = compose(
        image=object_image(), mask=mask, bboxes=[OBJECT_BOX], labels=[1], keypoints=[SPOTS[0]]
    )
    assert out["image"].shape == out["mask"].shape == CANVAS["output_shape"]
    np.testing.assert_array_equal(out["mask"][8:-8, 8:-8], mask)
    np.testing.assert_allclose(out["keypoints"][0], SPOTS[0] + 8, atol=1e-3)
    np.testing.assert_allclose(out["bboxes"][0], np.add(OBJECT_BOX, 8), atol=1e-3)


def test_torchvision_on_a_canvas_of_another_size(gl):
    """With ``output_shape``, every input lands on the new canvas, the ``canvas_size`` of
    boxes and keypoints the output's, as torchvision's resizing transforms give them."""
    transform = MLSTransform("grid", displacement=0, warp_options=CANVAS)
    mask = torch.from_numpy((object_image() > 0).astype(np.uint8))
    boxes = tv_tensors.BoundingBoxes(torch.tensor([OBJECT_BOX]), format="XYXY", canvas_size=(H, W))
    points = tv_tensors.KeyPoints(torch.from_numpy(SPOTS[:1]), canvas_size=(H, W))
    torch.manual_seed(0)
    image, moved_mask, moved_boxes, moved_points = transform(
        tv_tensors.Image(image_tensor(object_image())), tv_tensors.Mask(mask), boxes, points
    )
    canvas = CANVAS["output_shape"]
    assert image.shape == (1, *canvas) and moved_mask.shape == canvas
    np.testing.assert_array_equal(moved_mask[8:-8, 8:-8].numpy(), mask.numpy())
    assert moved_boxes.canvas_size == canvas and moved_points.canvas_size == canvas
    np.testing.assert_allclose(moved_boxes[0].numpy(), np.add(OBJECT_BOX, 8), atol=1e-3)
    np.testing.assert_allclose(moved_points[0].numpy(), SPOTS[0] + 8, atol=1e-3)
    pil = transform(PIL.Image.fromarray(mask.numpy() * 255))
    assert pil.size == (canvas[1], canvas[0])
    batch = transform(tv_tensors.Image(torch.zeros(2, 3, H, W)))
    assert batch.shape == (2, 3, *canvas)
