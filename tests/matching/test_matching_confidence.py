"""The confidence of match_stereo's matches (hopmatch.matching.confidence): one scale for
both passes, and a ranking whose best k matches have non-increasing precision."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_pairs import occlusion_pair

import hopmatch
from hopmatch.matching import halves
from hopmatch.matching.confidence import (
    CURVATURE_FLOOR,
    FIELD_LIMIT,
    confidence_distances,
    fields_of_distances,
    match_confidence,
)
from hopmatch.matching.similarity import match_distance


def test_fields_of_distances_inverts_match_distance():
    u = np.array([-30.0, -FIELD_LIMIT, -3.0, -0.5, 0.0, 0.7, 4.0, FIELD_LIMIT, 40.0])
    d = match_distance(u).astype(np.float32)
    np.testing.assert_allclose(fields_of_distances(d), np.clip(u, -FIELD_LIMIT, FIELD_LIMIT),
                               atol=1e-3)


def test_confidence_grows_with_the_field_and_the_curvature():
    u = np.linspace(-15, 15, 61)
    k = np.geomspace(1e-5, 1e2, 57)
    p = match_confidence(u[:, None], k[None, :])
    assert np.all(np.diff(p, axis=0) >= 0) and np.all(np.diff(p, axis=1) >= 0)
    assert np.all((p > 0) & (p < 1))
    # NaN curvature (no fitted peak) counts as the floor; distances are 1 - p, float32
    assert match_confidence([1.0], [np.nan])[0] == match_confidence([1.0], [CURVATURE_FLOOR])[0]
    d = confidence_distances(u, np.full(len(u), 0.5))
    assert d.dtype == np.float32 and np.all(np.diff(d) <= 0)


@pytest.mark.parametrize("seed", [0, 1])
def test_keeping_the_best_k_gives_non_increasing_precision(seed, monkeypatch):
    """On a synthetic pair with occlusions, lenient settings (no similarity gate, input
    bias 0) let wrong matches through; sorted by distance, the precision of the best k
    (k = 10 %, 20 %, ..., 100 %) never increases, and the wrong ones come last. (Without
    the half-window test, which drops nearly all of these wrong matches:
    tests/matching/test_matching_halves.py.)"""
    monkeypatch.setattr(halves, "HALF_CHECK", False)
    left, right, gt = occlusion_pair(seed)
    res = hopmatch.match_stereo(left, right, max_disparity=24, input_bias=0.0,
                                similarity_gate=None)
    pl, pr = res.matched_left, res.matched_right
    g = gt[np.floor(pl[:, 1] + 0.5).astype(int), np.floor(pl[:, 0] + 0.5).astype(int)]
    ok = (np.abs((pl[:, 0] - pr[:, 0]) - g) <= 1) & (np.abs(pl[:, 1] - pr[:, 1]) <= 1)
    assert (~ok).sum() >= 10  # the case has wrong matches to rank
    assert {0, 1, 2, 3} <= set(np.unique(res.passes))  # matches of every pass of both runs
    c = ok[np.argsort(res.distances, kind="stable")]
    prec = [c[:max(1, round(f * len(c)))].mean() for f in np.arange(1, 11) / 10]
    assert all(a >= b for a, b in zip(prec, prec[1:])), prec
    assert prec[4] == 1.0 and prec[-1] < 1.0


def test_distances_are_one_scale_and_the_paper_keeps_the_field():
    left, right, _ = occlusion_pair(0)
    res = hopmatch.match_stereo(left, right, max_disparity=24, both_features=False)
    assert res.refinement is not None
    u = np.r_[fields_of_distances(res.network.distances), res.guided.fields]
    np.testing.assert_array_equal(res.distances,
                                  confidence_distances(u, res.refinement.curvature))
    off = hopmatch.match_stereo(left, right, max_disparity=24, refine=False,
                                both_features=False)
    np.testing.assert_array_equal(off.distances,
                                  np.r_[off.network.distances, off.guided.distances])
    paper = hopmatch.match_stereo(left, right, preset="paper")
    np.testing.assert_array_equal(paper.distances, paper.network.distances)
