"""hopmatch.feature.gradient's intensity normalisation (issue 20): points, descriptors and
matches independent of the images' gain and dtype."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch.feature.gradient import (
    INTENSITY_RANGE,
    intensity_spread,
    normalised_intensity,
)


def _pair(seed=0, shape=(200, 260), shift=6):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.uniform(0, 255, shape).astype(np.float32), (0, 0), 1.5)
    img = cv2.normalize(img, None, 10, 245, cv2.NORM_MINMAX).astype(np.uint8)
    return img, np.roll(img, -shift, axis=1)


def test_spread_follows_gain_not_offset_or_dtype():
    left, _ = _pair()
    base = intensity_spread(left.astype(np.float32))
    assert intensity_spread(left.astype(np.float32) * 3 + 100) == pytest.approx(3 * base)
    assert intensity_spread(left.astype(np.uint16) * 257) == pytest.approx(257 * base)
    out = normalised_intensity(left)
    assert out.dtype == np.float32 and intensity_spread(out) == pytest.approx(INTENSITY_RANGE)
    flat = np.full((10, 10), 7, np.uint8)
    np.testing.assert_array_equal(normalised_intensity(flat), flat.astype(np.float32))


def test_spread_ignores_the_black_fill_of_a_warped_view():
    """A view warped with cv2.warpAffine's black border (rectification, a rotation) keeps
    the spread of its content: counted in, 4 % of fill pixels moved the 1st percentile
    to 0 and gave two views of equal gain scales 1.4x apart (the unrectified-path test pair)."""
    left, _ = _pair()
    h, w = left.shape
    A = cv2.getRotationMatrix2D((w / 2, h / 2), 5.0, 1.03)
    A[1, 2] += 12
    warped = cv2.warpAffine(left, A, (w, h), flags=cv2.INTER_LINEAR)
    assert (warped == 0).mean() > 0.04
    assert intensity_spread(warped) == pytest.approx(intensity_spread(left), rel=0.03)
    # an image that is mostly one level (two levels only) keeps the plain percentiles
    binary = np.zeros((40, 40), np.uint8)
    binary[:, 30:] = 200
    assert intensity_spread(binary) == 200.0



@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("case", ["texture", "black fill", "two levels", "flat", "tiny",
                                  "large", "sparse levels"])
def test_histogram_spread_equals_the_percentile_of_the_grey_levels(dtype, case):
    """The 8- and 16-bit path (a histogram) gives np.percentile's result on the same grey
    levels as float32 to the last bit: the float path is its reference."""
    rng = np.random.default_rng(len(case) + 7 * np.dtype(dtype).itemsize)
    top = np.iinfo(dtype).max
    shape = {"tiny": (1, 3), "large": (1500, 1100)}.get(case, (97, 131))
    img = rng.integers(0, top, shape, endpoint=True).astype(dtype)
    if case == "black fill":
        img[:, :40] = 0
    elif case == "two levels":
        img = np.where(rng.random(shape) < 0.3, 0, top // 3).astype(dtype)
    elif case == "flat":
        img[:] = top // 2
    elif case == "sparse levels":
        img = (rng.integers(0, 5, shape) * (top // 5)).astype(dtype)
    assert intensity_spread(img) == intensity_spread(img.astype(np.float32))


@pytest.mark.parametrize("label, make", [
    ("uint16 x257", lambda r: r.astype(np.uint16) * 257),
    ("float32 in [0, 1]", lambda r: r.astype(np.float32) / 255),
    ("half gain", lambda r: (r // 2).astype(np.uint8)),
    ("0.75 gain", lambda r: (r * 0.75).astype(np.uint8)),
    ("gain 2, float32", lambda r: r.astype(np.float32) * 2),
    ("offset", lambda r: (r.astype(np.int16) - 100)),
])
def test_matches_do_not_depend_on_the_right_images_gain_or_dtype(label, make):
    """Before issue 20 the first three gave 0 matches (and no warning), 0.75 gain 60 %."""
    left, right = _pair()
    with warnings.catch_warnings():
        warnings.simplefilter("error", hopmatch.errors.HopmatchWarning)
        want = hopmatch.match_stereo(left, right, max_disparity=16)
        got = hopmatch.match_stereo(left, make(right), max_disparity=16)
    assert len(want.matches) > 500
    assert len(got.matches) >= 0.9 * len(want.matches), label
    assert np.mean(np.abs(got.disparities - 6) <= 1) > 0.97


@pytest.mark.parametrize("rectified", [True, False])
def test_matches_do_not_depend_on_the_scale_of_float_images(rectified):
    """Float32 pairs whose grey levels are scaled by 1e36 down to 1e-40 (subnormal) match
    as the same pair at scale 1, with no RuntimeWarning: before 2026-12-06 levels below
    about 1e-8 gave no match (the refinement's and the half-window test's flat-window
    floors are absolute), 1e-40 overflowed the normalisation's factor and the bootstrap's
    stretch to uint8, and 1e38 overflowed the sharpness measure's sums."""
    left, right = (im.astype(np.float32) for im in _pair())
    kw = {"max_disparity": 16} if rectified else {"rectified": False}
    want = hopmatch.match_stereo(left, right, **kw)
    assert len(want.matches) > 500
    for scale in (1e36, 1e-10, 1e-25, 1e-40):
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            warnings.simplefilter("error", hopmatch.errors.HopmatchWarning)
            got = hopmatch.match_stereo((left * np.float32(scale)).astype(np.float32),
                                        (right * np.float32(scale)).astype(np.float32), **kw)
        assert abs(len(got.matches) - len(want.matches)) <= 0.01 * len(want.matches), scale
        assert np.mean(np.abs(got.disparities - 6) <= 1) > 0.97, scale


def test_measurable_gray_normalises_only_float_images_of_tiny_spread():
    from hopmatch.feature.gradient import MIN_MEASURED_SPREAD, measurable_gray
    left, _ = _pair()
    assert measurable_gray(left) is left
    ordinary = left.astype(np.float32) / 255
    assert measurable_gray(ordinary) is ordinary
    tiny = (left.astype(np.float64) * (0.1 * MIN_MEASURED_SPREAD / 255)).astype(np.float32)
    np.testing.assert_allclose(measurable_gray(tiny), normalised_intensity(left), rtol=1e-5)
    flat = np.full((10, 10), 1e-20, np.float32)
    assert measurable_gray(flat) is flat


def test_sharpness_and_bootstrap_stretch_hold_at_float32_extremes():
    """The sharpness ratio and the bootstrap's uint8 stretch do not depend on the scale of
    the grey levels, up to float32's largest and down to its subnormals (references: the
    same image at scale 1)."""
    from hopmatch.feature.sharpness import sharpness
    from hopmatch.matching.geometry import to_uint8
    left, _ = _pair()
    base = left.astype(np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        big = (left.astype(np.float64) * (3e38 / 255)).astype(np.float32)
        assert sharpness(big) == pytest.approx(sharpness(base), rel=1e-5)
        sub = (left.astype(np.float64) * (1e-40 / 255)).astype(np.float32)
        stretched = to_uint8(sub)
    want = to_uint8(base)
    assert np.mean(np.abs(stretched.astype(int) - want.astype(int)) <= 1) > 0.999


def test_both_images_as_floats_in_unit_range_match_as_uint8():
    left, right = _pair()
    want = hopmatch.match_stereo(left, right, max_disparity=16)
    got = hopmatch.match_stereo(left.astype(np.float32) / 255, right.astype(np.float32) / 255,
                                max_disparity=16)
    assert abs(len(got.matches) - len(want.matches)) <= 0.02 * len(want.matches)


# ---- the float32 Canny-Deriche kernel against OpenCV's filter (issue 17) ----

from concurrent.futures import ThreadPoolExecutor  # noqa: E402

from hopmatch.feature import gradient as _gradient  # noqa: E402
from hopmatch.feature.gradient import deriche_magnitude  # noqa: E402

#: max |ours - cv2| / max |cv2| allowed between the float32 kernel and cv2.ximgproc
AGREEMENT = 1e-4


def _relative(got, want):
    return float(np.abs(got.astype(np.float64) - want).max() / np.abs(want).max())


def _gray(bgr):
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) if bgr.ndim == 3 else bgr


@pytest.mark.parametrize("alpha, omega", [(1.0, 0.001), (0.5, 0.1), (2.0, 1e-4), (0.1, 0.001),
                                          (5.0, 0.5), (14.0, 0.001)])
def test_kernel_agrees_with_opencv_on_motorcycle(motorcycle, alpha, omega):
    left = np.ascontiguousarray(motorcycle[0][..., ::-1])
    gray = normalised_intensity(_gray(left))
    want = deriche_magnitude(gray, alpha, omega, method="opencv")
    got = deriche_magnitude(gray, alpha, omega)
    assert got.dtype == np.float32 and got.shape == gray.shape
    assert _relative(got, want) <= AGREEMENT
    strong = want > 0.01 * want.max()  # per pixel, where G is not negligible
    assert np.max(np.abs(got - want)[strong] / want[strong]) <= 1e-3


def test_kernel_agrees_with_opencv_on_a_shared_scene(shared_data):
    from hopmatch.datasets import load_scene

    scene = load_scene(shared_data / "middlebury" / "tsukuba")
    for img in (scene.left, scene.right):
        gray = normalised_intensity(_gray(img))
        for alpha in (0.7, 1.0, 1.5):
            want = deriche_magnitude(gray, alpha, 0.001, method="opencv")
            assert _relative(deriche_magnitude(gray, alpha, 0.001), want) <= AGREEMENT


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float32])
@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (8, 1), (5, 5), (31, 17), (64, 97)])
def test_kernel_agrees_with_opencv_on_random_images(shape, dtype):
    rng = np.random.default_rng(shape[0] * 100 + shape[1])
    img = rng.uniform(0, 200, shape).astype(dtype)
    for raw in (img, normalised_intensity(img)):
        for alpha, omega in ((1.0, 0.001), (0.3, 0.2), (3.0, 0.001)):
            want = deriche_magnitude(raw, alpha, omega, method="opencv")
            assert _relative(deriche_magnitude(raw, alpha, omega), want) <= AGREEMENT


def test_constant_image_keeps_opencvs_border_response():
    flat = np.full((20, 30), 137, np.uint8)
    want = deriche_magnitude(flat, 1.0, 0.001, method="opencv")
    assert want.max() > 0  # OpenCV's start-up values: a faint edge along the border
    assert _relative(deriche_magnitude(flat, 1.0, 0.001), want) <= AGREEMENT


def test_method_setting_and_small_alpha_fall_back_to_opencv(monkeypatch):
    rng = np.random.default_rng(3)
    img = rng.uniform(0, 255, (40, 50)).astype(np.float32)
    want = deriche_magnitude(img, 1.0, 0.001, method="opencv")
    monkeypatch.setattr(_gradient, "DERICHE_METHOD", "opencv")
    np.testing.assert_array_equal(deriche_magnitude(img, 1.0, 0.001), want)
    monkeypatch.setattr(_gradient, "DERICHE_METHOD", "numba")
    assert not np.array_equal(deriche_magnitude(img, 1.0, 0.001), want)
    small = _gradient.FLOAT32_MIN_ALPHA / 2
    np.testing.assert_array_equal(deriche_magnitude(img, small, 0.001),
                                  deriche_magnitude(img, small, 0.001, method="opencv"))


def test_kernel_is_deterministic_across_threads_and_shapes():
    """Each thread keeps its own intermediate images; shapes may change between calls."""
    rng = np.random.default_rng(4)
    images = [rng.uniform(0, 255, s).astype(np.float32) for s in [(60, 80), (33, 41)] * 4]
    alone = [deriche_magnitude(img, 1.0, 0.001) for img in images]
    with ThreadPoolExecutor(2) as pool:
        both = list(pool.map(lambda img: deriche_magnitude(img, 1.0, 0.001), images))
    for a, b in zip(alone, both):
        np.testing.assert_array_equal(a, b)
    assert not np.shares_memory(alone[0], alone[2])
