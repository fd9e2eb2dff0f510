"""match_stereo with ready detector and matcher instances."""

from __future__ import annotations

import numpy as np
import pytest

import hopmatch
from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.matching.stereo_match import split_parameters, stereo_pipeline

RNG = np.random.default_rng(1)
LEFT = (RNG.random((120, 160)) * 255).astype(np.uint8)
RIGHT = np.roll(LEFT, -6, axis=1)


def _same(a, b):
    for name in ("points_left", "points_right", "query_idx", "train_idx", "distances"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_instances_give_what_keywords_give():
    by_keywords = hopmatch.match_stereo(LEFT, RIGHT, max_disparity=12, nms_size=5, seed=3)
    det = hopmatch.DericheMoravecDetector(nms_size=5)
    mat = hopmatch.HopfieldMatcher(max_disparity=12, seed=3)
    _same(by_keywords, hopmatch.match_stereo(LEFT, RIGHT, detector=det, matcher=mat))
    assert mat.empty()  # its pair information is left untouched


def test_instances_and_their_keywords_do_not_mix():
    det = hopmatch.DericheMoravecDetector()
    with pytest.raises(InvalidArgumentError, match="`detector` instance.*nms_size"):
        hopmatch.match_stereo(LEFT, RIGHT, detector=det, nms_size=5)
    with pytest.raises(InvalidTypeError, match="`matcher` must be a HopfieldMatcher"):
        hopmatch.match_stereo(LEFT, RIGHT, matcher=object())


def test_split_parameters_is_the_one_rule():
    det, mat = split_parameters({"preset": "paper", "nms_size": 5, "theta": 3.0})
    assert det == {"preset": "paper", "nms_size": 5}
    assert mat == {"preset": "paper", "theta": 3.0}
    with pytest.raises(InvalidArgumentError, match="batch got unknown parameter"):
        split_parameters({"nope": 1}, caller="batch")
    d, m = stereo_pipeline({"nms_size": 5, "theta": 3.0})
    assert d.getNmsSize() == 5 and m.getTheta() == 3.0
