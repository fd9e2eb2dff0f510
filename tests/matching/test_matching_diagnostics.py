"""The warnings of hopmatch.matching.diagnostics are reported at the caller's line, from
every entry point (the function, the class and match_stereo), and the resolved parameters
are recorded in the result."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import hopmatch
from hopmatch.errors import DisparityRangeWarning, ImageSizeWarning, InvalidArgumentError

RNG = np.random.default_rng(3)
PTS = RNG.uniform(5, 45, (40, 2)).astype(np.float32)
DESC = RNG.normal(size=(40, 25)).astype(np.float32)


def _warned(call, category):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call()
    hits = [w for w in caught if issubclass(w.category, category)]
    assert hits, f"no {category.__name__} among {[str(w.message) for w in caught]}"
    return hits[0]


def test_function_warns_at_the_caller():
    w = _warned(lambda: hopmatch.hopfield_match(PTS, PTS, DESC, DESC, image_size=(50, 50),
                                                max_disparity=60), DisparityRangeWarning)
    assert w.filename == __file__


@pytest.mark.parametrize("method", ["match", "run", "knnMatch", "radiusMatch"])
def test_class_warns_at_the_caller(method):
    m = hopmatch.HopfieldMatcher(max_disparity=60)
    m.setPairInfo(PTS, PTS, (50, 50), (50, 50))
    args = {"match": (), "run": (), "knnMatch": (2,), "radiusMatch": (0.5,)}[method]
    w = _warned(lambda: getattr(m, method)(DESC, DESC, *args), DisparityRangeWarning)
    assert w.filename == __file__


def test_match_stereo_warns_at_the_caller():
    img = (RNG.random((60, 80)) * 255).astype(np.uint8)
    w = _warned(lambda: hopmatch.match_stereo(img, img[:, :70], max_disparity=8),
                ImageSizeWarning)
    assert w.filename == __file__
    w = _warned(lambda: hopmatch.match_stereo(img, img, max_disparity=100),
                DisparityRangeWarning)
    assert w.filename == __file__


def test_resolved_parameters_are_recorded():
    res = hopmatch.hopfield_match(PTS, PTS, DESC, DESC, image_size=(200, 100))
    # PTS matched to themselves: the coarse pass finds disparity 0, widened by 1 % of the
    # width + 2 px (hopmatch.matching.disparity_range)
    assert res.config.max_disparity == 4.0 and res.config.min_disparity == 0.0
    assert res.config.theta == hopmatch.HopfieldMatcher().getTheta()
    paper = hopmatch.hopfield_match(PTS, PTS, DESC, DESC, preset="paper")
    assert paper.config.max_disparity == 30.0 and paper.config.preset == "paper"


def test_function_and_class_agree_bit_for_bit():
    a = hopmatch.hopfield_match(PTS, PTS - [3, 0], DESC, DESC, max_disparity=8, seed=4)
    m = hopmatch.HopfieldMatcher(max_disparity=8, seed=4)
    m.setPairInfo(PTS, PTS - [3, 0])
    b = m.run(DESC, DESC)
    assert a.config == b.config
    for name in ("query_idx", "train_idx", "distances", "fields", "state"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_function_names_its_own_arguments():
    with pytest.raises(InvalidArgumentError, match="hopfield_match got unknown"):
        hopmatch.hopfield_match(PTS, PTS, DESC, DESC, thetaa=1.0)
    with pytest.raises(hopmatch.errors.InvalidTypeError, match="`left_pts`"):
        hopmatch.hopfield_match("points", PTS, DESC, DESC)
    with pytest.raises(hopmatch.errors.InvalidTypeError, match="`fundamental_matrix`"):
        hopmatch.hopfield_match(PTS, PTS, DESC, DESC, fundamental_matrix="F")
