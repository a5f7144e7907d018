"""The adapters of glmls.augment against their libraries' own contracts: what albumentations
and torchvision do with their built-in distortions (A.GridDistortion, v2.ElasticTransform),
MLSDeform and MLSTransform do in the same pipelines: the same call forms and targets, outputs
of the same types, dtypes and shapes, and the libraries' own filtering of boxes."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("NO_ALBUMENTATIONS_UPDATE", "1")  # no version check over the network

A = pytest.importorskip("albumentations", reason="albumentations not installed (the extra)")
torch = pytest.importorskip("torch", reason="torch not installed (the torch extra)")
tv_tensors = pytest.importorskip("torchvision.tv_tensors", reason="torchvision not installed")


from torchvision.transforms import v2  # noqa: E402

from glmls.augment.albumentations import MLSDeform  # noqa: E402
from glmls.augment.torchvision import MLSTransform  # noqa: E402

#: A draw that moves every point 6 px to the left (a similarity MLS of a translation).
SHIFT = 6.0


def shifted_left(shape: tuple[int, int]) -> dict:
    height, width = shape
    src = [[0.0, 0.0], [width - 1.0, 0.0], [0.0, height - 1.0], [width - 1.0, height - 1.0]]
    dst = [[x - SHIFT, y] for x, y in src]
    return {
        "preset": "grid",
        "config": {},
        "seed": 0,
        "index": 0,
        "shape": [height, width],
        "src": src,
        "dst": dst,
        "options": {"transform": "similarity", "interpolation": "linear", "border": "edge"},
    }


class ShiftLeft(MLSDeform):
    """MLSDeform with a fixed draw: everything 6 px to the left."""

    def get_params_dependent_on_data(self, params, data):
        return {"mls": shifted_left(tuple(params["shape"][:2]))}


@pytest.mark.parametrize("channels", [5, 8])
def test_albumentations_images_of_any_number_of_channels(gl, rng, channels):
    """albumentations' distortions take any number of channels (multispectral images);
    MLSDeform deforms them all by one map, as it deforms 4 or fewer."""
    image = rng.integers(0, 255, (24, 32, channels), dtype=np.uint8)
    transform = MLSDeform("grid", preset_options={"displacement": 0.05})
    out = A.Compose([transform], seed=2)(image=image)["image"]
    assert out.shape == image.shape and out.dtype == image.dtype
    assert A.Compose([A.GridDistortion(p=1)], seed=2)(image=image)["image"].shape == out.shape
    draw = transform.get_applied_params()["mls"]
    for k in range(0, channels, 3):  # any group of channels is the image's part
        part = image[..., k : k + 3]
        expected = transform.augment.replay([part], [draw]).images[0]
        np.testing.assert_array_equal(out[..., k : k + 3], expected)


@pytest.mark.parametrize("min_visibility, kept", [(0.6, False), (0.4, True)])
def test_albumentations_min_visibility_sees_boxes_pushed_out(gl, min_visibility, kept):
    """A box pushed half out of the image by the deformation has half its area visible:
    albumentations' min_visibility compares the box the transform returns with what is left
    after clipping it, so the transform must not clip it first."""
    image = np.zeros((24, 32, 3), np.uint8)
    compose = A.Compose(
        [ShiftLeft()],
        bbox_params=A.BboxParams(
            format="pascal_voc", label_fields=["labels"], min_visibility=min_visibility
        ),
    )
    out = compose(image=image, bboxes=[(2.0, 10.0, 10.0, 20.0)], labels=[7])
    if kept:
        np.testing.assert_allclose(out["bboxes"], [[0.0, 10.0, 4.0, 20.0]], atol=1e-3)
        assert list(out["labels"]) == [7]
    else:
        assert len(out["bboxes"]) == 0 and len(out["labels"]) == 0


def test_torchvision_a_video_is_one_sample(gl, rng):
    """torchvision transforms a Video's frames alike (v2.ElasticTransform does): one draw for
    the whole clip, its frames moved together; only an Image batch draws per sample."""
    frame = torch.from_numpy(rng.integers(0, 255, (3, 24, 32), dtype=np.uint8))
    video = tv_tensors.Video(frame.expand(4, 3, 24, 32).clone())
    transform = MLSTransform("grid", displacement=0.08)
    torch.manual_seed(0)
    out = transform(video)
    assert isinstance(out, tv_tensors.Video) and out.shape == video.shape
    assert len(transform.last_params) == 1
    assert all(torch.equal(out[0], out[k]) for k in range(1, 4))
    assert not torch.equal(out[0], frame)
    elastic = v2.ElasticTransform(alpha=50.0)(video)
    assert all(torch.equal(elastic[0], elastic[k]) for k in range(1, 4))
    batch = transform(tv_tensors.Image(video.as_subclass(torch.Tensor)))
    assert len(transform.last_params) == 4 and not torch.equal(batch[0], batch[1])


@pytest.mark.parametrize("kind", ["tensor", "image"])
def test_torchvision_images_with_more_leading_dimensions(gl, rng, kind):
    """torchvision's geometric transforms take plain tensors and Images (..., C, H, W) with
    any number of leading dimensions (v2.RandomAffine, v2.ElasticTransform keep the shape):
    so does MLSTransform, the first dimension the batch (a draw per sample) and the ones
    after it a sample's (its frames moved by its one draw, as a Video's)."""
    clip = torch.from_numpy(rng.integers(0, 255, (3, 24, 32), dtype=np.uint8))
    data = torch.stack([clip.expand(2, 3, 24, 32)] * 3)  # (N=3, T=2, C, H, W)
    given = data if kind == "tensor" else tv_tensors.Image(data)
    mask = tv_tensors.Mask(torch.ones(3, 24, 32, dtype=torch.uint8))  # the batch's
    for theirs in (v2.RandomAffine(degrees=10), v2.ElasticTransform(alpha=50.0)):
        assert theirs(given).shape == given.shape
    transform = MLSTransform("grid", displacement=0.08)
    torch.manual_seed(0)
    out, out_mask = transform(given, mask)
    assert type(out) is type(given) and out.shape == given.shape and out.dtype == given.dtype
    assert out_mask.shape == mask.shape and len(transform.last_params) == 3
    for k, draw in enumerate(transform.last_params):
        expected = transform.augment.replay(clip.permute(1, 2, 0).numpy()[None], [draw])
        for frame in out[k]:
            np.testing.assert_array_equal(frame.permute(1, 2, 0).numpy(), expected.images[0])
    assert not torch.equal(out[0], out[1])
    deeper = MLSTransform("grid")(data[None])  # (1, N, T, C, H, W): one sample
    assert deeper.shape == (1, *data.shape)


def test_torchvision_a_tensor_of_one_dimension_is_refused():
    """torchvision refuses an image tensor of fewer than two dimensions; so does MLSTransform,
    naming the shapes it takes."""
    with pytest.raises(TypeError, match="at least two dimensions"):
        v2.RandomAffine(degrees=10)(torch.zeros(8))
    with pytest.raises(ValueError, match=r"at least two dimensions.*got shape \(8,\)"):
        MLSTransform("grid")(torch.zeros(8))


@pytest.mark.parametrize("shape", [(5, 16, 20), (2, 6, 16, 20)])
def test_torchvision_images_of_any_number_of_channels(gl, rng, shape):
    image = tv_tensors.Image(torch.from_numpy(rng.random(shape, dtype=np.float32)))
    torch.manual_seed(1)
    out = MLSTransform("grid", displacement=0.05)(image)
    assert isinstance(out, tv_tensors.Image) and out.shape == image.shape
    assert out.dtype == image.dtype
    assert v2.ElasticTransform(alpha=20.0, sigma=2.0)(image).shape == out.shape


@pytest.mark.parametrize(
    "mode, expected", [("soft", [0.0, 10.0, 4.0, 20.0]), (None, [-4.0, 10.0, 4.0, 20.0])]
)
def test_torchvision_boxes_clamped_by_their_clamping_mode(gl, mode, expected):
    """torchvision clamps transformed boxes to the canvas as their ``clamping_mode`` says:
    ``None`` leaves them as they are (for v2.SanitizeBoundingBoxes or the user to judge)."""
    transform = MLSTransform("grid")
    transform.augment.draw = lambda shapes, **_: [shifted_left(tuple(s)) for s in shapes]
    image = tv_tensors.Image(torch.zeros(3, 24, 32, dtype=torch.uint8))
    for fmt in ("XYXY", "XYWH", "CXCYWH"):
        xyxy = torch.tensor([[2.0, 10.0, 10.0, 20.0]])
        boxes = tv_tensors.BoundingBoxes(
            v2.functional.convert_bounding_box_format(xyxy, old_format="XYXY", new_format=fmt),
            format=fmt,
            canvas_size=(24, 32),
            clamping_mode=mode,
        )
        _, out = transform(image, boxes)
        assert out.format == boxes.format and out.canvas_size == (24, 32)
        assert out.clamping_mode == mode
        back = v2.functional.convert_bounding_box_format(
            out.as_subclass(torch.Tensor), old_format=fmt, new_format="XYXY"
        )
        np.testing.assert_allclose(back.numpy(), [expected], atol=1e-3)


@pytest.mark.parametrize(
    "fmt, given",
    [("XYWH", [18, 13, 27, 19]), ("CXCYWH", [32, 22, 27, 19]), ("CXCYWH", [31, 21, 28, 20])],
)
def test_torchvision_integer_boxes_go_through_float_as_torchvisions_own(gl, fmt, given):
    """torchvision's own transforms take integer boxes as float, in their format, and cast
    the result in their format: an odd width in CXCYWH keeps its half pixel until then."""
    image = tv_tensors.Image(torch.zeros(3, 40, 60, dtype=torch.uint8))
    outs = {}
    for dtype in (torch.int64, torch.float32):
        boxes = tv_tensors.BoundingBoxes(
            torch.tensor([given], dtype=dtype), format=fmt, canvas_size=(40, 60)
        )
        torch.manual_seed(5)
        outs[dtype] = MLSTransform("grid", displacement=0.05)(image, boxes)[1]
    assert (
        outs[torch.int64].dtype == torch.int64
        and outs[torch.int64].format == outs[torch.float32].format
    )
    expected = outs[torch.float32].as_subclass(torch.Tensor).to(torch.int64)
    assert outs[torch.int64].tolist() == expected.tolist()


@pytest.mark.parametrize(
    "edit, error, message",
    [
        (lambda d: d.pop("shape"), ValueError, r"params\[0\] has no 'shape'"),
        (
            lambda d: d.__setitem__("shape", [24.0, 32.0]),
            TypeError,
            r"params\[0\]\['shape'\] must be \[H, W\], integers >= 1",
        ),
        (lambda d: d.__setitem__("options", None), TypeError, r"params\[0\]\['options'\]"),
    ],
)
@pytest.mark.parametrize("target", ["keypoints", "bboxes", "mask", "image"])
def test_albumentations_an_edited_record_is_refused_for_every_target(
    gl, target, edit, error, message
):
    """A record edited in A.ReplayCompose's replay dict (or written by hand) reaches each
    apply_to_* of MLSDeform: every target names the bad entry, as the image does."""
    transform = MLSDeform()
    transform.set_random_seed(0)
    draw = transform.get_params_dependent_on_data({"shape": (24, 32)}, {})["mls"]
    edit(draw)
    data = {
        "keypoints": np.array([[4.0, 5.0]]),
        "bboxes": np.array([[0.1, 0.2, 0.5, 0.6]]),
        "mask": np.ones((24, 32), np.uint8),
        "image": np.zeros((24, 32, 3), np.uint8),
    }[target]
    apply = transform.apply if target == "image" else getattr(transform, f"apply_to_{target}")
    with pytest.raises(error, match=message):
        apply(data, mls=draw)


@pytest.mark.parametrize("mode", ["RGB", "L", "LA", "CMYK", "YCbCr", "P", "I;16", "I", "F"])
def test_torchvision_pil_images_keep_their_mode(gl, rng, mode):
    """torchvision gives a PIL image back in its mode (v2.ElasticTransform keeps CMYK and
    YCbCr); a palette image's indices are labels, moved with nearest sampling, its palette
    kept."""
    PIL = pytest.importorskip("PIL.Image")
    image = PIL.fromarray(rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)).convert(mode)
    torch.manual_seed(2)
    out = MLSTransform("grid", displacement=0.05)(image)
    assert isinstance(out, PIL.Image) and out.mode == mode and out.size == image.size
    assert np.asarray(out).dtype == np.asarray(image).dtype
    assert not np.array_equal(np.asarray(out), np.asarray(image))
    if mode == "P":
        assert out.getpalette() == image.getpalette()
        assert set(np.unique(out).tolist()) <= set(np.unique(image).tolist())
    if mode in ("CMYK", "YCbCr"):
        assert v2.ElasticTransform(alpha=20.0, sigma=2.0)(image).mode == mode


@pytest.mark.parametrize("dtype", ["float16", "bfloat16"])
def test_augment_half_precision_tensors(gl, rng, dtype):
    """torch's half-precision images (mixed-precision training) go through float32 and come
    back in their dtype, keypoints too."""
    from glmls.augment import Augment

    images = torch.from_numpy(rng.random((2, 3, 16, 24), dtype=np.float32))
    points = torch.tensor([[[4.0, 4.0]], [[10.0, 8.0]]])
    aug = Augment("grid", seed=1)
    half = getattr(torch, dtype)
    out = aug(images.to(half), keypoints=points.to(half))
    assert out.images.dtype == half and out.images.shape == images.shape
    assert out.keypoints.dtype == half
    full = aug(images.to(half).float(), keypoints=points.to(half).float())
    torch.testing.assert_close(out.images, full.images.to(half))
    torch.testing.assert_close(out.keypoints, full.keypoints.to(half))


def test_augment_a_list_of_tensors_in_torchs_layout(gl, rng):
    """A ragged batch as a list of (C, H, W) or (H, W) tensors: each in torch's layout, as
    one tensor of the batch is, and back as a list of tensors of their dtypes."""
    from glmls.augment import Augment

    first = torch.from_numpy(rng.integers(0, 255, (3, 16, 24), dtype=np.uint8))
    second = torch.from_numpy(rng.random((20, 12), dtype=np.float32))
    aug = Augment("grid", seed=4)
    out = aug([first, second], keypoints=[torch.zeros(1, 2), torch.ones(2, 2)])
    assert isinstance(out.images, list) and len(out.images) == 2
    assert out.images[0].shape == first.shape and out.images[0].dtype == torch.uint8
    assert out.images[1].shape == second.shape and out.images[1].dtype == torch.float32
    alone = aug(first[None], indices=[0])
    assert torch.equal(out.images[0], alone.images[0])
    assert [type(k).__name__ for k in out.keypoints] == ["Tensor", "Tensor"]
    assert [tuple(k.shape) for k in out.keypoints] == [(1, 2), (2, 2)]
    assert all(v.dtype == torch.bool for v in out.keypoints_valid)
    boxes = [torch.tensor([[2.0, 2.0, 9.0, 9.0]]), torch.zeros(0, 4, dtype=torch.float64)]
    boxed = aug([first, second], boxes=boxes)
    assert [b.dtype for b in boxed.boxes] == [torch.float32, torch.float64]
    assert [tuple(v.shape) for v in boxed.boxes_valid] == [(1,), (0,)]
    again = aug.replay([first, second], out.params)
    assert all(torch.equal(a, b) for a, b in zip(again.images, out.images, strict=True))


@pytest.mark.parametrize("container", [list, tuple])
def test_augment_masks_as_a_list_of_tensors_of_one_shape(gl, rng, container):
    """Each image's mask tensor in a list (or tuple), all of one shape and dtype: back as a
    list of tensors, each the numpy call's mask, of its dtype."""
    from glmls.augment import Augment

    images = torch.from_numpy(rng.integers(0, 255, (2, 3, 16, 24), dtype=np.uint8))
    labels = rng.integers(0, 4, (2, 16, 24)).astype(np.uint8)
    aug = Augment("grid", seed=4)
    out = aug(images, masks=container(torch.from_numpy(m) for m in labels))
    plain = aug(np.moveaxis(images.numpy(), 1, -1), masks=list(labels))
    assert isinstance(out.masks, list) and len(out.masks) == 2
    for got, expected in zip(out.masks, plain.masks, strict=True):
        assert isinstance(got, torch.Tensor) and got.dtype == torch.uint8
        np.testing.assert_array_equal(got.numpy(), expected)


@pytest.mark.parametrize("dtype", ["float16", "bfloat16"])
def test_torchvision_half_precision_inputs(gl, rng, dtype):
    half = getattr(torch, dtype)
    image = tv_tensors.Image(torch.from_numpy(rng.random((3, 16, 20), dtype=np.float32)).to(half))
    points = tv_tensors.KeyPoints(torch.tensor([[4.0, 5.0]], dtype=half), canvas_size=(16, 20))
    boxes = tv_tensors.BoundingBoxes(
        torch.tensor([[2.0, 2.0, 9.0, 9.0]], dtype=half), format="XYXY", canvas_size=(16, 20)
    )
    torch.manual_seed(3)
    out_image, out_points, out_boxes = MLSTransform("grid", displacement=0.05)(image, points, boxes)
    assert out_image.dtype == half and out_points.dtype == half and out_boxes.dtype == half
    assert isinstance(out_image, tv_tensors.Image) and out_image.shape == image.shape


@pytest.mark.parametrize("fmt", ["XYWHR", "CXCYWHR", "XYXYXYXY"])
def test_torchvision_rotated_boxes(gl, fmt):
    """torchvision's rotated formats (v2.ElasticTransform takes them): the box's corners
    move through the map, the box comes back in its format."""
    F = v2.functional
    transform = MLSTransform("grid")
    transform.augment.draw = lambda shapes, **_: [shifted_left(tuple(s)) for s in shapes]
    image = tv_tensors.Image(torch.zeros(3, 32, 40, dtype=torch.uint8))
    given = torch.tensor([[20.0, 10.0, 6.0, 4.0, 30.0]])
    shifted = given - torch.tensor([SHIFT, 0, 0, 0, 0])
    boxes = tv_tensors.BoundingBoxes(
        F.convert_bounding_box_format(given, old_format="XYWHR", new_format=fmt),
        format=fmt,
        canvas_size=(32, 40),
    )
    _, out = transform(image, boxes)
    assert isinstance(out, tv_tensors.BoundingBoxes) and out.format == boxes.format
    expected = F.convert_bounding_box_format(shifted, old_format="XYWHR", new_format=fmt)
    torch.testing.assert_close(out.as_subclass(torch.Tensor), expected, atol=2e-3, rtol=0)
    elastic = v2.ElasticTransform(alpha=5.0, sigma=2.0)(image, boxes)[1]
    assert elastic.shape == out.shape and elastic.format == out.format


def test_torchvision_several_batch_labels_each_follow_every_sample(gl):
    """Two (N, H, W) masks (a semantic and an instance one) and two (N, P, 2) keypoint sets
    for a batch of N = 2 are each the batch's, as one of them alone is: not one per sample
    (sample 1's labels moved by sample 0's draw)."""
    height, width = 32, 48
    images = tv_tensors.Image(torch.randint(0, 255, (2, 3, height, width), dtype=torch.uint8))
    mask = torch.zeros(2, height, width, dtype=torch.uint8)
    mask[:, 8:24, 10:30] = 1
    points = torch.tensor([[[20.0, 15.0]], [[20.0, 15.0]]])
    transform = MLSTransform(displacement=0.1)

    def keypoints():
        return tv_tensors.KeyPoints(points.clone(), canvas_size=(height, width))

    torch.manual_seed(0)
    _, one_mask, one_points = transform(images, tv_tensors.Mask(mask), keypoints())
    assert not torch.equal(one_points[0], one_points[1])  # the samples' draws differ
    torch.manual_seed(0)
    out = transform(
        images, tv_tensors.Mask(mask), tv_tensors.Mask(mask.clone()), keypoints(), keypoints()
    )
    for got, expected in zip(out[1:], (one_mask, one_mask, one_points, one_points), strict=True):
        assert torch.equal(got, expected)
    # per sample: (P, 2) keypoints, one each in order, move with their own sample
    torch.manual_seed(0)
    _, first, second = transform(
        images,
        tv_tensors.KeyPoints(points[0], canvas_size=(height, width)),
        tv_tensors.KeyPoints(points[1], canvas_size=(height, width)),
    )
    assert torch.equal(first, one_points[0]) and torch.equal(second, one_points[1])


def test_torchvision_a_nan_keypoint_stays_nan(gl):
    # a missing landmark's usual mark passes through, as torchvision's own transforms carry it
    height, width = 32, 48
    image = tv_tensors.Image(torch.zeros(3, height, width, dtype=torch.uint8))
    points = torch.tensor([[float("nan"), float("nan")], [10.0, 10.0]])
    torch.manual_seed(0)
    _, moved = MLSTransform()(image, tv_tensors.KeyPoints(points, canvas_size=(height, width)))
    torch.manual_seed(0)
    _, alone = MLSTransform()(image, tv_tensors.KeyPoints(points[1:], canvas_size=(height, width)))
    assert torch.isnan(moved[0]).all() and torch.equal(moved[1:], alone)


@pytest.mark.parametrize("batched", [False, True])
def test_torchvision_landmarks_skip_a_missing_landmark(gl, batched):
    # the landmarks preset's handles are the landmarks there are: a NaN one (missing) is no
    # handle and comes back NaN, the others move as they would without it
    height, width = 32, 48
    nan = float("nan")
    points = torch.tensor([[10.0, 12.0], [nan, nan], [30.0, 20.0]])
    image = torch.zeros(3, height, width, dtype=torch.uint8)
    if batched:
        image, points = image[None].repeat(2, 1, 1, 1), points[None].repeat(2, 1, 1)
    transform = MLSTransform("landmarks", displacement=2.0, units="pixels")
    torch.manual_seed(0)
    _, moved = transform(
        tv_tensors.Image(image), tv_tensors.KeyPoints(points, canvas_size=(height, width))
    )
    torch.manual_seed(0)
    present = points[..., [0, 2], :]
    _, alone = transform(
        tv_tensors.Image(image), tv_tensors.KeyPoints(present, canvas_size=(height, width))
    )
    assert torch.isnan(moved[..., 1, :]).all()
    assert torch.equal(moved[..., [0, 2], :], alone)
    assert (moved[..., [0, 2], :] - present).abs().max() > 0  # the landmarks did move


@pytest.mark.parametrize("preset", ["grid", "landmarks"])
def test_albumentations_a_nan_keypoint_stays_nan(gl, preset):
    # as A.Affine and the flips carry a NaN (missing) keypoint; the landmarks preset takes
    # no handle from it, so the others move as they would without it
    image = np.zeros((32, 48, 3), np.uint8)
    nan = float("nan")
    options = {"displacement": 2, "units": "pixels"}

    def run(points):
        compose = A.Compose(
            [MLSDeform(preset, preset_options=options)],
            keypoint_params=A.KeypointParams(format="xy", remove_invisible=False),
            seed=0,
        )
        return np.asarray(compose(image=image, keypoints=points)["keypoints"])

    moved = run([(10.0, 12.0), (nan, nan), (30.0, 20.0)])
    alone = run([(10.0, 12.0), (30.0, 20.0)])
    assert np.isnan(moved[1]).all()
    np.testing.assert_array_equal(moved[[0, 2]], alone)


@pytest.mark.parametrize("output_shape", [None, (30, 40)])
def test_torchvision_an_empty_batch_gives_an_empty_batch(gl, output_shape):
    """Empty on the output's canvas, as v2.Resize gives them: images and masks of that size,
    keypoints with that canvas_size."""
    options = None if output_shape is None else {"output_shape": output_shape}
    canvas = output_shape or (16, 24)
    images = tv_tensors.Image(torch.zeros(0, 3, 16, 24, dtype=torch.uint8))
    points = tv_tensors.KeyPoints(torch.zeros(0, 2, 2), canvas_size=(16, 24))
    masks = tv_tensors.Mask(torch.zeros(0, 16, 24))
    out, masks, points = MLSTransform(warp_options=options)(images, masks, points)
    assert isinstance(out, tv_tensors.Image) and out.shape == (0, 3, *canvas)
    assert out.dtype == torch.uint8
    assert isinstance(masks, tv_tensors.Mask) and masks.shape == (0, *canvas)
    assert isinstance(points, tv_tensors.KeyPoints) and points.shape == (0, 2, 2)
    assert tuple(points.canvas_size) == canvas
    resized = v2.Resize(canvas)(images, masks, points)
    assert [tuple(x.shape) for x in resized] == [(0, 3, *canvas), (0, *canvas), (0, 2, 2)]


def test_torchvision_one_label_object_for_every_sample_moves_with_each(gl):
    """``[boxes] * N`` (one object at N places, as torchvision's tree_flatten keeps them):
    each place moves with its own sample, as N copies would; the landmarks preset takes one
    KeyPoints object for every sample too."""
    images = tv_tensors.Image(torch.zeros(3, 3, 32, 48, dtype=torch.uint8))
    box = tv_tensors.BoundingBoxes(
        torch.tensor([[10.0, 8.0, 40.0, 30.0]]), format="XYXY", canvas_size=(32, 48)
    )
    mask = tv_tensors.Mask(torch.zeros(32, 48, dtype=torch.uint8))
    mask[8:30, 10:40] = 1
    transform = MLSTransform(displacement=0.1)
    torch.manual_seed(0)
    shared = transform(images, *([box] * 3), *([mask] * 3))[1:]
    torch.manual_seed(0)
    copies = transform(images, *[box.clone() for _ in range(3)], *[mask.clone() for _ in range(3)])
    for got, want in zip(shared, copies[1:], strict=True):
        torch.testing.assert_close(got, want, rtol=0, atol=0)
    assert not torch.equal(shared[0], shared[1])  # each sample's own draw
    points = tv_tensors.KeyPoints(torch.tensor([[10.0, 10.0], [30.0, 20.0]]), canvas_size=(32, 48))
    torch.manual_seed(1)
    moved = MLSTransform("landmarks")(images, *([points] * 3))[1:]
    torch.manual_seed(1)
    want = MLSTransform("landmarks")(images, *[points.clone() for _ in range(3)])[1:]
    for got, expected in zip(moved, want, strict=True):
        torch.testing.assert_close(got, expected, rtol=0, atol=0)


def test_torchvision_a_bad_box_names_its_sample(gl):
    images = tv_tensors.Image(torch.zeros(3, 1, 16, 24))
    good = torch.tensor([[1.0, 1.0, 5.0, 5.0], [2.0, 2.0, 6.0, 6.0]])
    bad = torch.tensor([[1.0, 1.0, 5.0, 5.0], [6.0, 2.0, 2.0, 6.0]])
    boxes = [
        tv_tensors.BoundingBoxes(b, format="XYXY", canvas_size=(16, 24)) for b in (good, good, bad)
    ]
    with pytest.raises(ValueError, match=r"^sample 2's BoundingBoxes\[1\] \[6.0, 2.0, 2.0, 6.0\]"):
        MLSTransform()(images, *boxes)


def test_augment_polygons_of_tensors_come_back_as_tensors(gl):
    from glmls.augment import Augment

    images = torch.randint(0, 255, (2, 3, 32, 32), dtype=torch.uint8)
    polygon = torch.tensor([[4.0, 4.0], [20.0, 4.0], [20.0, 20.0]])
    given = [[polygon], [polygon.double(), polygon]]
    augment = Augment("grid", seed=1)
    result = augment(images, polygons=given)
    as_arrays = augment(images, polygons=[[p.numpy() for p in shapes] for shapes in given])
    for got, expected, inputs in zip(result.polygons, as_arrays.polygons, given, strict=True):
        for tensor, array, one in zip(got, expected, inputs, strict=True):
            assert isinstance(tensor, torch.Tensor) and tensor.dtype == one.dtype
            np.testing.assert_allclose(tensor.numpy(), array, rtol=0, atol=1e-5)


@pytest.mark.parametrize("output_shape", [None, (20, 30)])
def test_torchvision_a_sample_without_instances_keeps_its_empty_masks(gl, output_shape):
    """A detection sample without objects has a Mask (0, H, W) (a batch's (N, 0, H, W)), as
    v2.RandomRotation gives it back: empty on the output's canvas, of its dtype; so too an
    image of no channels."""
    options = None if output_shape is None else {"output_shape": output_shape}
    canvas = output_shape or (16, 24)
    transform = MLSTransform(warp_options=options)
    image = tv_tensors.Image(torch.randint(0, 255, (3, 16, 24), dtype=torch.uint8))
    out, masks = transform(image, tv_tensors.Mask(torch.zeros(0, 16, 24, dtype=torch.bool)))
    assert isinstance(masks, tv_tensors.Mask) and masks.shape == (0, *canvas)
    assert masks.dtype == torch.bool and out.shape == (3, *canvas)
    batch = torch.zeros(2, 3, 16, 24)
    _, masks = transform(batch, tv_tensors.Mask(torch.zeros(2, 0, 16, 24, dtype=torch.uint8)))
    assert isinstance(masks, tv_tensors.Mask) and masks.shape == (2, 0, *canvas)
    bare = transform(tv_tensors.Image(torch.zeros(0, 16, 24)))
    assert isinstance(bare, tv_tensors.Image) and bare.shape == (0, *canvas)


@pytest.mark.parametrize("output_shape", [None, (20, 30)])
def test_albumentations_a_mask_of_no_layers_stays_empty(gl, rng, output_shape):
    """A (H, W, 0) mask (no instances) comes back (H', W', 0) of its dtype, the image
    deformed as without it."""
    options = None if output_shape is None else {"output_shape": output_shape}
    canvas = output_shape or (16, 24)
    image = rng.integers(0, 255, (16, 24, 3), dtype=np.uint8)
    compose = A.Compose([MLSDeform(warp_options=options)], seed=3)
    out = compose(image=image, mask=np.zeros((16, 24, 0), np.uint16))
    assert out["mask"].shape == (*canvas, 0) and out["mask"].dtype == np.uint16
    alone = A.Compose([MLSDeform(warp_options=options)], seed=3)(image=image)
    np.testing.assert_array_equal(out["image"], alone["image"])
