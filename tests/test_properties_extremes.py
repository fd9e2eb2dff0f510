"""Hypothesis at the extremes (issue 20): every parameter of both classes and the scalar
arguments of every public function, given integers up to and beyond int64, denormals,
NaN, infinities, huge floats, bools, strings and None. Whatever comes: a result, or a
hopmatch error (a ValueError or TypeError) naming the argument, raised within a second;
never an OverflowError, IndexError, cv2.error, Numba error or a hang. Accepted parameter
values survive FileStorage (write/read) unchanged."""

from __future__ import annotations

import math
import os
import time
import warnings

import cv2
import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import hopmatch  # noqa: E402
import hopmatch.imageio  # noqa: E402
from hopmatch import stereo  # noqa: E402
from hopmatch.errors import HopmatchError  # noqa: E402

SETTINGS = settings(max_examples=int(os.environ.get("HOPMATCH_HYPOTHESIS_EXAMPLES", 150)),
                    deadline=None,
                    derandomize=os.environ.get("HOPMATCH_HYPOTHESIS_RANDOM", "0") != "1",
                    suppress_health_check=[HealthCheck.too_slow,
                                           HealthCheck.function_scoped_fixture])

INT64 = 2**63
EDGES = [0, 1, -1, 2, 3, 5, 99, 999, 1000, 2**31 - 1, 2**31, 2**53 + 1, INT64 - 1, INT64,
         -INT64, -INT64 - 1, 2**64, 10**30, 0.0, -0.0, 5e-324, -5e-324, 1e-310, 2.2e-308,
         1e-30, 0.5, 1e19, 3.5e38, 1e300, 1.7976931348623157e308, -1.7976931348623157e308,
         math.inf, -math.inf, math.nan, True, False, None, "", "1", "x", np.int64(7),
         np.float32(0.25), np.uint64(2**64 - 1)]
#: Anything a caller might pass as a number.
EXTREME = st.one_of(st.sampled_from(EDGES), st.integers(-(2**70), 2**70),
                    st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True))

RNG = np.random.default_rng(0)
IMG = cv2.GaussianBlur((RNG.random((48, 64)) * 255).astype(np.uint8), (3, 3), 0)
SHIFTED = np.roll(IMG, -3, axis=1)  # a right view: disparity 3
PTS = RNG.uniform(5, 40, (40, 2)).astype(np.float32)
DESC = RNG.normal(size=(40, 25)).astype(np.float32)


def _outcome(call, name=None):
    """Run ``call``: its result, or None after a hopmatch error (asserting that it is a
    ValueError/TypeError naming ``name`` when given, raised within a second). NumPy's
    RuntimeWarnings (an overflow in a float32 cast...) are errors: a value at the edge of
    its range gets a result or a hopmatch error, not NumPy's noise."""
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", hopmatch.errors.HopmatchWarning)
            warnings.simplefilter("error", RuntimeWarning)
            return call()
    except HopmatchError as exc:
        assert isinstance(exc, (ValueError, TypeError)), type(exc)
        assert time.perf_counter() - t0 < 1.0, f"refused after {time.perf_counter() - t0} s"
        if name is not None:
            assert exc.argument == name or f"`{name}`" in str(exc) or name in str(exc), exc
        return None


def _same(a, b) -> bool:
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a)
                      and math.isnan(b))


@pytest.mark.parametrize("cls", [hopmatch.DericheMoravecDetector, hopmatch.HopfieldMatcher])
@SETTINGS
@given(data=st.data(), value=EXTREME)
def test_every_class_parameter(cls, data, value, tmp_path_factory):
    spec = data.draw(st.sampled_from(cls.PARAMS))
    name = spec.name
    obj = _outcome(lambda: cls(**{name: value}), None)
    if obj is None:
        return
    # a value the constructor took: the setter takes it, FileStorage keeps it
    other = cls()
    _outcome(lambda: getattr(other, "set" + "".join(p.title() for p in name.split("_")))(value))
    path = tmp_path_factory.mktemp("fs") / "p.yml"
    obj.write(str(path))
    back = cls()
    back.read(str(path))
    assert all(_same(back.get_params()[k], v) for k, v in obj.get_params().items())
    # and the object works (or refuses its input by name) within the time limit
    if cls is hopmatch.DericheMoravecDetector:
        _outcome(lambda: obj.detectAndCompute(IMG, None))
    else:
        obj.setPairInfo(PTS, PTS - [4, 0], (64, 48), (64, 48))
        _outcome(lambda: obj.match(DESC, DESC))


FUNCTIONS = {
    "deriche_gradient.alpha": lambda v: hopmatch.deriche_gradient(IMG, alpha=v),
    "deriche_gradient.omega": lambda v: hopmatch.deriche_gradient(IMG, omega=v),
    "moravec_response.window_size": lambda v: hopmatch.moravec_response(IMG, window_size=v),
    "moravec_response.window_sigma": lambda v: hopmatch.moravec_response(IMG, window_sigma=v),
    "moravec_points.nms_size": lambda v: hopmatch.moravec_points(IMG.astype(np.float32),
                                                                 nms_size=v),
    "moravec_points.threshold": lambda v: hopmatch.moravec_points(IMG.astype(np.float32),
                                                                  threshold=v),
    "moravec_points.relative_threshold": lambda v: hopmatch.moravec_points(
        IMG.astype(np.float32), relative_threshold=v),
    "moravec_points.margin": lambda v: hopmatch.moravec_points(IMG.astype(np.float32),
                                                               margin=v),
    "moravec_points.max_features": lambda v: hopmatch.moravec_points(IMG.astype(np.float32),
                                                                     max_features=v),
    "gradient_windows.size": lambda v: hopmatch.gradient_windows(IMG.astype(np.float32),
                                                                 PTS, v),
    "gradient_windows.points": lambda v: hopmatch.gradient_windows(
        IMG.astype(np.float32), [[v, v]], 5),
    "hopfield_match.max_disparity": lambda v: hopmatch.hopfield_match(PTS, PTS, DESC, DESC,
                                                                      max_disparity=v),
    "hopfield_match.fundamental_matrix": lambda v: hopmatch.hopfield_match(
        PTS, PTS, DESC, DESC, max_disparity=8,
        fundamental_matrix=[[0, 0, 0], [0, 0, -1], [0, 1, v]]),
    "hopfield_match.image_size": lambda v: hopmatch.hopfield_match(PTS, PTS, DESC, DESC,
                                                                   image_size=(v, v)),
    "knnMatch.k": lambda v: _matcher().knnMatch(DESC, DESC, v),
    "radiusMatch.maxDistance": lambda v: _matcher().radiusMatch(DESC, DESC, v),
    "match_stereo.max_pixels": lambda v: hopmatch.match_stereo(IMG, IMG, max_pixels=v),
    # the seeds search the whole range: 1e300 overflowed its column count, 1e12 its memory
    "match_stereo.max_disparity": lambda v: hopmatch.match_stereo(IMG, SHIFTED,
                                                                  max_disparity=v),
    "match_stereo.min_disparity": lambda v: hopmatch.match_stereo(IMG, SHIFTED,
                                                                  min_disparity=v,
                                                                  max_disparity=1e12),
    "epipolar_distances.F": lambda v: stereo.epipolar_distances(
        PTS, PTS, [[0, 0, 0], [0, 0, -1], [0, 1, v]]),
    "epipolar_distance_matrix.max_pairs": lambda v: stereo.epipolar_distance_matrix(
        PTS, PTS, np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0.0]]), max_pairs=v),
    "estimate_fundamental.threshold": lambda v: stereo.estimate_fundamental(
        PTS, PTS - [4, 0], threshold=v),
    "estimate_fundamental.confidence": lambda v: stereo.estimate_fundamental(
        PTS, PTS - [4, 0], confidence=v),
    "estimate_fundamental.method": lambda v: stereo.estimate_fundamental(PTS, PTS - [4, 0],
                                                                         method=v),
    "depth_from_disparity.focal": lambda v: stereo.depth_from_disparity(
        np.ones((4, 4), np.float32), focal=v, baseline=1.0),
    "depth_from_disparity.baseline": lambda v: stereo.depth_from_disparity(
        np.ones((4, 4), np.float32), focal=1.0, baseline=v),
    "depth_from_disparity.doffs": lambda v: stereo.depth_from_disparity(
        np.ones((4, 4), np.float32), focal=1.0, baseline=1.0, doffs=v),
    "sparse_disparity_image.shape": lambda v: stereo.sparse_disparity_image(
        PTS, np.ones(len(PTS), np.float32), (v, 64)),
    "keypoints_and_matches.size": lambda v: stereo.keypoints_and_matches(PTS, PTS, size=v),
    "read_image.flags": lambda v: hopmatch.imageio.read_image(_image_file(), flags=v),
    "read_image.max_pixels": lambda v: hopmatch.imageio.read_image(_image_file(),
                                                                   max_pixels=v),
    "read_image.max_bytes": lambda v: hopmatch.imageio.read_image(_image_file(), max_bytes=v),
}


def _matcher():
    m = hopmatch.HopfieldMatcher(max_disparity=8)
    m.setPairInfo(PTS, PTS - [4, 0])
    return m


_FILE = {}


def _image_file():
    if "path" not in _FILE:
        import tempfile

        _FILE["path"] = os.path.join(tempfile.mkdtemp(), "img.png")
        cv2.imwrite(_FILE["path"], IMG)
    return _FILE["path"]


@pytest.mark.parametrize("target", sorted(FUNCTIONS))
@SETTINGS
@given(value=EXTREME)
def test_every_public_function_scalar(target, value):
    name = target.split(".")[1]
    if name in ("points", "F", "fundamental_matrix", "image_size", "shape") or \
            target.startswith("estimate_fundamental"):
        name = None  # an array built from the value, or OpenCV finding no F: named otherwise
    _outcome(lambda: FUNCTIONS[target](value), name)
