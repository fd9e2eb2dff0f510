"""hopmatch._validate at the extremes (issue 20): integers beyond int64, fundamental matrices
of any scale, the pixel-budget hint, the denormal alpha of the Deriche border."""

from __future__ import annotations

import numpy as np
import pytest

import hopmatch
from hopmatch._validate import (
    F_NORM_RANGE,
    INT64_MAX,
    as_fundamental_matrix,
    as_int,
    check_pixel_budget,
)
from hopmatch.errors import BudgetExceededError, InvalidArgumentError

F_RECT = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)


@pytest.mark.parametrize("value", [2**63, 10**30, -(2**63) - 1, 2**64])
def test_integers_beyond_int64_are_refused_by_name(value):
    with pytest.raises(InvalidArgumentError, match=f"`seed` must be in .* got {value}"):
        as_int(value, "seed")
    assert as_int(INT64_MAX, "seed") == INT64_MAX


@pytest.mark.parametrize("scale", [1e-320, 1e-200, 1e-30, 1e-3, 1.0, 1e3, 1e30, 1e200, 1e300])
def test_fundamental_matrix_of_any_scale(scale):
    f = as_fundamental_matrix(F_RECT * scale)
    norm = np.linalg.norm(f)
    if F_NORM_RANGE[0] <= np.linalg.norm(F_RECT * scale) <= F_NORM_RANGE[1]:
        assert np.array_equal(f, F_RECT * scale)  # used as given: results bit-identical
    else:
        assert 0.5 <= norm < 1.0
        ratio = f[1, 2] / (F_RECT * scale)[1, 2]
        assert ratio == 2.0 ** np.round(np.log2(ratio))  # a power of two: exact


def test_fundamental_matrix_scale_does_not_change_matches():
    """F * 1e-200 underflowed every epipolar line to length 0 (no candidate), F * 1e200
    overflowed them (every point on every line): both now match as F does."""
    rng = np.random.default_rng(0)
    pts = rng.uniform(20, 120, (150, 2)).astype(np.float32)
    desc = rng.normal(size=(150, 25)).astype(np.float32)
    want = hopmatch.hopfield_match(pts, pts - [6, 0], desc, desc, max_disparity=16,
                                   fundamental_matrix=F_RECT)
    assert len(want.query_idx) > 50
    for scale in (1e-200, 1e-320, 1e200, 2.0**-60):
        got = hopmatch.hopfield_match(pts, pts - [6, 0], desc, desc, max_disparity=16,
                                      fundamental_matrix=F_RECT * scale)
        assert np.array_equal(got.query_idx, want.query_idx)
        assert np.array_equal(got.train_idx, want.train_idx)
        assert np.array_equal(got.distances, want.distances)


def test_pixel_budget_hint_reads_well_in_python_and_on_the_command_line():
    with pytest.raises(BudgetExceededError) as exc:
        check_pixel_budget((30000, 30000), 50_000_000)
    message = str(exc.value)
    assert "raise the limit to max_pixels=900000000 or more" in message
    assert "create(" not in message  # the CLI turned it into create(--max-pixels=...)


@pytest.mark.parametrize("alpha", [5e-324, 1e-310])
def test_denormal_alpha_is_the_deriche_error_not_an_overflow(alpha):
    from hopmatch.feature.gradient import border_width

    assert border_width(alpha) == 256 and border_width(1.0) == 14
    img = np.random.default_rng(0).integers(0, 255, (40, 40), dtype=np.uint8)
    with pytest.raises(InvalidArgumentError, match="alpha"):
        hopmatch.DericheMoravecDetector(alpha=alpha).detect(img)


def test_boolean_arguments_take_bools_and_0_or_1_only():
    """record_energy='x', compactResult='no' and useProvidedKeypoints='yes' were all read
    as True (a non-empty string is truthy)."""
    import cv2

    from hopmatch._validate import as_flag
    from hopmatch.errors import InvalidTypeError

    assert [as_flag(v, "f") for v in (True, False, np.bool_(True), 0, 1, np.int64(1))] == \
        [True, False, True, False, True, True]
    for bad in ("no", "x", 2, 0.5, None, [True]):
        with pytest.raises(InvalidTypeError, match="`f` must be True or False"):
            as_flag(bad, "f")
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur((rng.random((60, 80)) * 255).astype(np.uint8), (0, 0), 1.0)
    det = hopmatch.DericheMoravecDetector()
    with pytest.raises(InvalidTypeError, match="useProvidedKeypoints"):
        det.detectAndCompute(img, None, useProvidedKeypoints="yes")
    with pytest.raises(InvalidTypeError, match="record_energy"):
        hopmatch.match_stereo(img, np.roll(img, -3, axis=1), record_energy="x")
    kp, desc = det.detectAndCompute(img, None)
    m = hopmatch.HopfieldMatcher.create(max_disparity=8)
    m.setPairInfo(kp, kp, (80, 60), (80, 60))
    for call in (m.knnMatch, m.radiusMatch):
        with pytest.raises(InvalidTypeError, match="compactResult"):
            call(desc, desc, 1, compactResult="no")


def test_a_none_among_keypoints_is_named_not_read_as_a_point_at_the_origin():
    """cv2.KeyPoint_convert reads None as a keypoint at (0, 0)."""
    import cv2

    from hopmatch._validate import as_points
    from hopmatch.errors import InvalidTypeError

    with pytest.raises(InvalidTypeError, match="NoneType"):
        as_points([cv2.KeyPoint(1, 2, 3), None, cv2.KeyPoint(4, 5, 3)], "keypoints")
    at_origin = as_points([cv2.KeyPoint(0, 0, 3), cv2.KeyPoint(4, 5, 3)], "keypoints")
    assert at_origin.tolist() == [[0.0, 0.0], [4.0, 5.0]]


@pytest.mark.parametrize("dtype", [np.float32, np.uint8, np.float64])
def test_read_only_descriptors_and_points_come_back_writable(dtype):
    """Numba compiles its kernels again, seconds on a first call, for read-only arrays."""
    from hopmatch._validate import as_descriptors, as_points

    desc = np.ones((4, 9), dtype)
    desc.flags.writeable = False
    pts = np.ones((4, 2), np.float32)
    pts.flags.writeable = False
    assert as_descriptors(desc, "d").flags.writeable and as_points(pts, "p").flags.writeable
