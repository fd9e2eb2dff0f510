"""Pictures that read at 100 % (hopmatch.viz.overview; issue 19, point 4): a spread-out
subset of the matches as lines coloured by disparity, the rest as dots, a caption; the
left image's keypoints coloured by disparity beside a colour bar in pixels."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch import viz
from hopmatch.errors import InvalidArgumentError
from hopmatch.evaluate import correct_matches, score_matches
from hopmatch.viz.overview import (
    WRONG,
    disparity_scale,
    draw_colour_bar,
    nice_ticks,
    spread_subset,
)


@pytest.fixture(scope="module")
def motorcycle_run():
    scene = hopmatch.datasets.load_motorcycle()
    res = hopmatch.match_stereo(scene.left, scene.right)
    score = score_matches(res.matched_left, res.matched_right, scene.disparity,
                          thresholds=(1.0,))
    correct, known = correct_matches(score, res.matched_left, res.matched_right, 1.0)
    return scene, res, correct, known


def _pairs(res):
    return np.stack([res.query_idx, res.train_idx], axis=1)


# --------------------------------------------------------------------------------------
# Scale, ticks, subset
# --------------------------------------------------------------------------------------


def test_nice_ticks_are_round_and_inside():
    assert nice_ticks(0, 66) == [0.0, 20.0, 40.0, 60.0]
    assert nice_ticks(-10, 30, 5) == [-10.0, 0.0, 10.0, 20.0, 30.0]
    for lo, hi in ((0, 1), (16, 111), (0.2, 0.9), (-3, 250)):
        ticks = nice_ticks(lo, hi)
        assert 2 <= len(ticks) <= 6 and lo - 1e-9 <= ticks[0] and ticks[-1] <= hi + 1e-9
    assert nice_ticks(5, 5) == [5.0]


def test_disparity_scale_ignores_a_few_outliers():
    d = np.r_[np.linspace(0, 60, 2000), [400.0, 500.0]]
    lo, hi = disparity_scale(d)
    assert lo == 0.0 and 60 <= hi <= 70
    assert disparity_scale(d, 10, 90) == (10.0, 90.0)
    assert disparity_scale([]) == (0.0, 1.0)
    assert disparity_scale([-4.5, 3.0])[0] == -5.0


def test_spread_subset_one_line_per_band_across_the_width():
    rng = np.random.default_rng(0)
    pts = rng.uniform(0, 500, (3000, 2)).astype(np.float32)
    idx = spread_subset(pts, 50, 500)
    assert len(idx) == 50 and len(set(idx.tolist())) == 50
    bands = np.floor(pts[idx, 1] / 10.0)
    assert len(set(bands.tolist())) == 50  # never two lines in one band of rows
    assert np.ptp(pts[idx, 0]) > 400 and np.std(pts[idx, 0]) > 100  # not one column
    assert (spread_subset(pts, 50, 500) == idx).all()  # deterministic
    assert len(spread_subset(pts, 500, 500)) <= 500 // 6 + 1  # bands of 6 px at least
    assert len(spread_subset(pts[:0], 10)) == 0


# --------------------------------------------------------------------------------------
# The match picture
# --------------------------------------------------------------------------------------


def _changed_fraction(picture, left, right):
    """Share of the image area whose pixels differ from the grey, dimmed pair."""
    h, w = left.shape[:2]
    grey = [(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.float32) * 0.75)
            .astype(np.uint8) for img in (left, right)]
    base = cv2.cvtColor(np.hstack(grey), cv2.COLOR_GRAY2BGR)
    return float(np.mean(np.abs(picture[:h].astype(int) - base.astype(int)).max(axis=2) > 40))


def test_match_overview_reads_at_100_percent(motorcycle_run):
    """Today's drawMatches picture of the 2,137 matches covers most of the picture in
    lines; the overview leaves most of the image visible, draws at most one line per 8
    rows, and puts a caption with a colour bar below."""
    scene, res, correct, known = motorcycle_run
    pic = viz.draw_match_overview(scene.left, scene.right, res.points_left, res.points_right,
                                  _pairs(res), res.disparities, correct=correct, known=known)
    h, w = scene.left.shape[:2]
    assert pic.dtype == np.uint8 and pic.shape[1:] == (2 * w, 3) and pic.shape[0] > h + 40
    old = viz.draw_matches(scene.left, scene.right, res.points_left, res.points_right,
                           _pairs(res), correct, known=known)
    green = np.all(old == (0, 200, 0), axis=2).mean()
    assert green > 0.25  # the picture the issue shows: lines everywhere
    assert _changed_fraction(pic, scene.left, scene.right) < 0.25
    caption = pic[h:]
    assert (caption.max(axis=2) > 200).mean() > 0.005  # text and colour bar are drawn
    turbo = cv2.applyColorMap(np.arange(256, dtype=np.uint8).reshape(-1, 1),
                              cv2.COLORMAP_TURBO).reshape(-1, 3)
    bar_row = caption[-34 + 9, 8:200].astype(int)
    assert np.abs(bar_row[0] - turbo[0]).max() <= 6 and np.abs(bar_row[-1] - turbo[0]).max() > 60


def test_match_overview_colours_lines_by_disparity_and_marks_wrong_matches():
    img = np.full((100, 120), 128, np.uint8)
    left = np.float32([[30, 20], [60, 50], [90, 80]])
    right = left - np.float32([[5, 0], [20, 0], [10, 0]])
    correct = np.array([True, False, True])
    pic = viz.draw_match_overview(img, img, left, right, [[0, 0], [1, 1], [2, 2]],
                                  correct=correct, max_lines=3, min_disparity=0,
                                  max_disparity=20)
    colours = viz.disparity_colours([5.0, 20.0, 10.0], 0, 20)
    # the middle of each line has its disparity's colour
    for (xl, y), (xr, _), c in zip(left, right, colours):
        mid = pic[int(y), int((xl + xr + 120) / 2)].astype(int)
        assert np.abs(mid - c.astype(int)).max() <= 40, (mid, c)
    # the wrong match is marked on both images; the correct ones are not
    assert tuple(pic[50, 60]) == WRONG and tuple(pic[50, 40 + 120]) == WRONG
    assert tuple(pic[20, 30]) != WRONG


def test_match_overview_limits_the_lines():
    img = np.full((200, 200), 128, np.uint8)
    ys = np.repeat(np.arange(10, 190, 2), 3).astype(np.float32)
    xs = np.tile([50, 100, 150], len(ys) // 3).astype(np.float32)
    left = np.column_stack([xs, ys])
    pairs = np.column_stack([np.arange(len(left))] * 2)
    pic = viz.draw_match_overview(img, img, left, left - [8, 0], pairs, max_lines=5)
    # a line's pixels lie between the two images' points: count rows holding a line pixel
    # in the gap between the right end of the left image's points and the right image
    between = pic[:200, 200 - 40:200, :].astype(int)
    rows = np.flatnonzero((np.abs(between - 96).max(axis=2) > 30).any(axis=1))
    groups = 1 + int(np.sum(np.diff(rows) > 1)) if len(rows) else 0  # one per line
    assert groups == 5


def test_match_overview_errors_and_empty():
    img = np.zeros((40, 50), np.uint8)
    empty = viz.draw_match_overview(img, img, np.zeros((0, 2), np.float32),
                                    np.zeros((0, 2), np.float32), np.zeros((0, 2), int))
    assert empty.shape[1] == 100 and empty.shape[0] > 40
    with pytest.raises(InvalidArgumentError, match="one value per match"):
        viz.draw_match_overview(img, img, [[1, 1]], [[1, 1]], [[0, 0]], [1.0, 2.0])
    with pytest.raises(InvalidArgumentError, match="one flag per match"):
        viz.draw_match_overview(img, img, [[1, 1]], [[1, 1]], [[0, 0]],
                                correct=np.array([True, False]))


# --------------------------------------------------------------------------------------
# The keypoint picture with its colour bar
# --------------------------------------------------------------------------------------


def test_keypoint_disparities_with_a_colour_bar_in_pixels(motorcycle_run):
    scene, res, _, _ = motorcycle_run
    pic = viz.draw_keypoint_disparities(scene.left, res.matched_left, res.disparities)
    h, w = scene.left.shape[:2]
    assert pic.shape == (h, w + 80, 3)
    lo, hi = disparity_scale(res.disparities)
    # each dot has its disparity's colour (the nearest drawn last, on top)
    order = np.argsort(res.disparities, kind="stable")
    x, y = np.rint(res.matched_left[order[-1]]).astype(int)
    expected = viz.disparity_colours([res.disparities[order[-1]]], lo, hi)[0].astype(int)
    assert np.abs(pic[y, x].astype(int) - expected).max() <= 40
    # the bar runs from the top colour (hi, top) to the bottom one (lo)
    bar = pic[:, w + 6 + 8].astype(int)
    top, bottom = viz.disparity_colours([hi, lo], lo, hi).astype(int)
    rows = [r for r in range(h) if np.abs(bar[r] - top).max() <= 10]
    assert rows and min(rows) < 60
    assert any(np.abs(bar[r] - bottom).max() <= 10 for r in range(h - 60, h))
    # tick labels: light text right of the bar
    labels = pic[:, w + 6 + 16 + 7:, :].max(axis=2)
    assert (labels > 180).sum() > 50


def test_colour_bar_panels():
    assert draw_colour_bar(300, 0, 66).shape == (300, 80, 3)
    assert draw_colour_bar(20, 0, 66).shape == (20, 80, 3)  # too short: the title alone
    assert draw_colour_bar(420, 16, 111, vertical=False).shape == (34, 420, 3)


def test_keypoint_disparities_errors():
    img = np.zeros((30, 40), np.uint8)
    with pytest.raises(InvalidArgumentError, match="one value per point"):
        viz.draw_keypoint_disparities(img, [[1, 1]], [1.0, 2.0])
    with pytest.raises(InvalidArgumentError, match="NaN"):
        viz.draw_keypoint_disparities(img, [[1, 1]], [np.nan])
    assert viz.draw_keypoint_disparities(img, np.zeros((0, 2), np.float32), []).shape \
        == (30, 120, 3)


# --------------------------------------------------------------------------------------
# Figure 7 with thousands of matches
# --------------------------------------------------------------------------------------


def test_figure7_numbers_a_spread_out_subset():
    img = np.full((200, 200), 60, np.uint8)
    ys = np.repeat(np.arange(10, 190, 2), 2).astype(np.float32)
    left = np.column_stack([np.tile([60, 140], len(ys) // 2).astype(np.float32), ys])
    pairs = np.column_stack([np.arange(len(left))] * 2)
    every = viz.draw_labelled_matches(img, img, left, left, pairs)
    some = viz.draw_labelled_matches(img, img, left, left, pairs, max_labels=10)
    red = np.array(viz.FIGURE_POINT)
    assert (some == red).all(axis=2).sum() < 0.2 * (every == red).all(axis=2).sum()
    assert (viz.draw_labelled_matches(img, img, left, left, pairs, max_labels=len(left))
            == every).all()
    with pytest.raises(InvalidArgumentError, match="max_labels"):
        viz.draw_labelled_matches(img, img, left, left, pairs, max_labels=0)
