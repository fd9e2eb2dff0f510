"""Quality against ground truth: the matcher's goals, measured on real scenes.

A match is correct when |(xl - xr) - d_gt| <= 1 px and |yl - yr| <= 1 px
(``hopmatch.evaluate.score_matches``); precision = correct / matches with ground truth.
"""

from __future__ import annotations

import pytest

import hopmatch
from hopmatch import datasets
from hopmatch.compare import METHODS
from hopmatch.evaluate import score_matches

SHARED_SCENES = [
    "middlebury/tsukuba", "middlebury/venus", "middlebury/sawtooth", "middlebury/bull",
    "middlebury/poster", "middlebury/barn1", "middlebury/barn2", "middlebury/art",
    "middlebury/books", "middlebury/dolls", "aloe", "kitti2012/000070",
]


def sift_ratio_band(scene):
    """SIFT + BFMatcher knnMatch ratio 0.75 (``hopmatch.compare``'s ``sift-ratio``), scored;
    the rectified band filter of the issue's baseline only removes matches that cannot be
    correct, so its correct count is the same."""
    res = METHODS["sift-ratio"](scene)
    return score_matches(res.left_pts, res.right_pts, scene.disparity)


def hopmatch_score(scene, **params):
    res = hopmatch.match_stereo(scene.left, scene.right, **params)
    return score_matches(res.matched_left, res.matched_right, scene.disparity)


def test_motorcycle_goal():
    """Issue goal: precision >= 0.97 with >= 800 correct matches, default parameters."""
    score = hopmatch_score(datasets.load_motorcycle())
    assert score.precision[1.0] >= 0.97, score.as_dict()
    assert score.correct[1.0] >= 800, score.as_dict()


def test_motorcycle_beats_sift_and_paper_preset():
    scene = datasets.load_motorcycle()
    ours = hopmatch_score(scene)
    sift = sift_ratio_band(scene)
    paper = hopmatch_score(scene, preset="paper")
    assert ours.correct[1.0] > sift.correct[1.0] and ours.precision[1.0] > sift.precision[1.0]
    assert ours.precision[1.0] > paper.precision[1.0]


@pytest.mark.parametrize("name", SHARED_SCENES)
def test_shared_scene_goal(shared_data, name):
    """Goal on scenes the defaults must generalise to: precision >= 0.95 and at least as
    many correct matches as SIFT + ratio test + rectified band."""
    scene = datasets.load(name, root=shared_data)
    ours = hopmatch_score(scene)
    sift = sift_ratio_band(scene)
    assert ours.precision[1.0] >= 0.95, (name, ours.as_dict())
    assert ours.correct[1.0] >= sift.correct[1.0], (name, ours.correct, sift.correct)
