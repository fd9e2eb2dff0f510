"""Property-based tests (hypothesis): random images, keypoints, masks and parameters, inside
and outside their ranges. Whatever comes in: no crash, no hang, no exception outside
hopmatch's vocabulary (docs/robustness.md), and every DMatch indexes valid keypoints."""

from __future__ import annotations

import os
import warnings

import cv2
import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra import numpy as hnp  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import DericheMoravecDetector, HopfieldMatcher  # noqa: E402
from hopmatch.errors import HopmatchError, HopmatchWarning  # noqa: E402

# 100 examples per test keep the file near 20 s; set HOPMATCH_HYPOTHESIS_EXAMPLES (and
# HOPMATCH_HYPOTHESIS_RANDOM=1 for fresh random examples) for a longer hunt.
SETTINGS = settings(max_examples=int(os.environ.get("HOPMATCH_HYPOTHESIS_EXAMPLES", 100)),
                    deadline=None,
                    derandomize=os.environ.get("HOPMATCH_HYPOTHESIS_RANDOM", "0") != "1",
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

DTYPES = [np.uint8, np.uint16, np.int16, np.float32, np.float64]


@st.composite
def images(draw, max_side=300):
    dtype = draw(st.sampled_from(DTYPES))
    h = draw(st.integers(1, max_side))
    w = draw(st.integers(1, max_side))
    channels = draw(st.sampled_from([None, 1, 3, 4]))
    shape = (h, w) if channels is None else (h, w, channels)
    kind = draw(st.sampled_from(["noise", "blocks", "flat", "special"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        lo, hi = int(info.min), int(info.max)
    else:
        lo, hi = -1e3, 1e3
    if kind == "noise":
        img = rng.uniform(lo, hi, shape)
    elif kind == "blocks":
        small = rng.uniform(lo, hi, (-(-h // 8), -(-w // 8)) + shape[2:])
        img = np.kron(small, np.ones((8, 8) + (1,) * (len(shape) - 2)))[:h, :w]
    elif kind == "flat":
        img = np.full(shape, rng.uniform(lo, hi))
    else:  # NaN / inf / extremes where floats allow
        img = rng.uniform(lo, hi, shape)
        if np.issubdtype(dtype, np.floating):
            special = draw(st.sampled_from([np.nan, np.inf, -np.inf, 3e38, 1e-40]))
            img.flat[rng.integers(0, img.size)] = special
    with np.errstate(invalid="ignore", over="ignore"):
        return np.ascontiguousarray(np.clip(img, lo, hi) if np.issubdtype(dtype, np.integer)
                                    else img).astype(dtype)


coordinates = st.one_of(
    st.floats(-50, 350, width=32),                       # inside and just outside
    st.sampled_from([np.nan, np.inf, -1e30, 1e30, 2.0**21, 0.0]),
)


@st.composite
def point_sets(draw, max_n=60):
    n = draw(st.integers(0, max_n))
    base = draw(hnp.arrays(np.float32, (n, 2), elements=st.floats(0, 200, width=32)))
    if n and draw(st.booleans()):  # duplicates
        base = np.concatenate([base, base[: draw(st.integers(1, n))]])
    if len(base) and draw(st.integers(0, 4)) == 0:  # a few wild coordinates
        wild = draw(st.lists(coordinates, min_size=1, max_size=3))
        for t, v in enumerate(wild):
            base[t % len(base), t % 2] = v
    return base


def _check_matches(matches, n_query, n_train):
    for m in matches:
        assert isinstance(m, cv2.DMatch)
        assert 0 <= m.queryIdx < n_query and 0 <= m.trainIdx < n_train
        assert np.isfinite(m.distance) and 0.0 <= m.distance <= 1.0


def _allowed(exc):
    """Only hopmatch's own errors may escape, and they are ValueError or TypeError."""
    return isinstance(exc, HopmatchError) and isinstance(exc, (ValueError, TypeError))


@SETTINGS
@given(image=images(), nms=st.integers(1, 7), on=st.sampled_from(["gradient", "intensity"]),
       use_mask=st.sampled_from([None, "random", "zero", "wrong"]), seed=st.integers(0, 99))
def test_detector_on_random_images(image, nms, on, use_mask, seed):
    det = DericheMoravecDetector(nms_size=nms, on=on, subpixel=use_mask != "random")
    h, w = image.shape[:2]
    rng = np.random.default_rng(seed)
    mask = {None: None, "random": (rng.random((h, w)) > 0.3).astype(np.uint8),
            "zero": np.zeros((h, w), bool), "wrong": np.ones((h + 1, w), np.uint8)}[use_mask]
    try:
        kps, desc = det.detectAndCompute(image, mask)
    except Exception as exc:  # noqa: BLE001
        assert _allowed(exc), repr(exc)
        return
    assert desc.dtype == np.float32 and desc.shape == (len(kps), det.descriptorSize())
    assert np.isfinite(desc).all()
    pts = np.array([kp.pt for kp in kps], np.float32).reshape(-1, 2)
    assert ((pts >= 0) & (pts <= np.array([w - 1, h - 1]))).all()
    if mask is not None and use_mask != "wrong" and len(pts):
        yx = np.rint(pts[:, ::-1]).astype(int)
        assert mask[yx[:, 0], yx[:, 1]].all()


@SETTINGS
@given(image=images(max_side=120), points=point_sets())
def test_compute_on_random_keypoints(image, points):
    det = DericheMoravecDetector()
    kps = [cv2.KeyPoint(float(x), float(y), 3.0) for x, y in points.tolist()]
    try:
        kept, desc = det.compute(image, kps)
    except Exception as exc:  # noqa: BLE001
        assert _allowed(exc), repr(exc)
        return
    assert len(kept) == len(desc) <= len(kps)
    assert desc.shape[1] == det.descriptorSize() and np.isfinite(desc).all()


matcher_params = st.fixed_dictionaries({}, optional={
    "max_disparity": st.one_of(st.none(), st.floats(-20, 400)),
    "min_disparity": st.floats(-50, 20),
    "max_vertical": st.one_of(st.floats(0, 30), st.just(-1.0), st.just(float("nan"))),
    "neighbour_width": st.floats(0, 100),
    "neighbour_height": st.floats(0, 100),
    "theta": st.floats(0, 20),
    "similarity_gate": st.one_of(st.none(), st.floats(0, 2)),
    "max_candidates": st.integers(-1, 5),
    "input_bias": st.floats(-5, 5),
    "initial_bias": st.one_of(st.none(), st.floats(-5, 5)),
    "seed": st.integers(-1, 2**63),
    "max_iterations": st.integers(0, 5000),
    "cross_check": st.booleans(),
    "shift_check": st.booleans(),
    "vertical_check": st.sampled_from(["multiple", "all", "nope"]),
    "preset": st.sampled_from(["default", "paper", "nope"]),
    "max_neurons": st.integers(1, 10**6),
})


@SETTINGS
@given(left=point_sets(), right=point_sets(), dim=st.sampled_from([0, 1, 9, 32]),
       binary=st.booleans(), params=matcher_params, k=st.integers(1, 5),
       use_mask=st.booleans(), seed=st.integers(0, 99))
def test_matcher_on_random_points(left, right, dim, binary, params, k, use_mask, seed):
    rng = np.random.default_rng(seed)
    dtype = np.uint8 if binary else np.float32
    dl = (rng.random((len(left), dim)) * 255).astype(dtype)
    dr = (rng.random((len(right), dim)) * 255).astype(dtype)
    mask = (rng.random((len(left), len(right))) > 0.2).astype(np.uint8) if use_mask else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HopmatchWarning)
        try:
            m = HopfieldMatcher(**params)
            m.setPairInfo(left, right, (320, 240), (320, 240))
            matches = m.match(dl, dr, mask)
            rows = m.knnMatch(dl, dr, k=k, mask=mask)
        except Exception as exc:  # noqa: BLE001
            assert _allowed(exc), repr(exc)
            return
    _check_matches(matches, len(left), len(right))
    if params.get("cross_check", True):  # the left-right check keeps one match per point
        assert len({d.queryIdx for d in matches}) == len(matches)
        assert len({d.trainIdx for d in matches}) == len(matches)
    assert len(rows) == len(left)
    for row in rows:
        _check_matches(row, len(left), len(right))
        assert len(row) <= k
    if mask is not None:
        assert all(mask[d.queryIdx, d.trainIdx] for d in matches)


@SETTINGS
@given(left=images(max_side=90), right=images(max_side=90),
       max_disparity=st.one_of(st.none(), st.floats(0, 200)))
def test_match_stereo_on_random_pairs(left, right, max_disparity):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HopmatchWarning)
        try:
            res = hopmatch.match_stereo(left, right, max_disparity=max_disparity)
        except Exception as exc:  # noqa: BLE001
            assert _allowed(exc), repr(exc)
            return
    _check_matches(res.matches, len(res.points_left), len(res.points_right))
    assert res.matched_left.shape == res.matched_right.shape == (len(res.matches), 2)
    assert np.isfinite(res.disparities).all()
