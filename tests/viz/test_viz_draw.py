"""OpenCV drawing of :mod:`hopmatch.viz.draw`: matches, sparse disparities, keypoints, and
the conversion of matches to index pairs."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from hopmatch import viz
from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.viz.draw import as_display_image, as_index_pairs


class TestViz:
    img = np.zeros((40, 50), np.uint8)
    pts = np.float32([[10, 10], [30, 20], [40, 30]])

    def test_draw_matches(self):
        pairs = np.array([[0, 0], [1, 1], [2, 2]])
        plain = viz.draw_matches(self.img, self.img, self.pts, self.pts, pairs)
        assert plain.shape == (40, 100, 3) and plain.dtype == np.uint8
        coloured = viz.draw_matches(self.img, self.img, self.pts, self.pts, pairs,
                                    np.array([True, False, False]),
                                    known=np.array([True, True, False]))
        # the lines run along rows 10, 20, 30 (anti-aliased: a little darker than the colour)
        b, g, r = (coloured[10, 20:50].astype(int).mean(axis=0))
        assert g > 150 and b == r == 0  # correct: green
        b, g, r = (coloured[20, 40:70].astype(int).mean(axis=0))
        assert r > 150 and b == g == 0  # wrong: red
        b, g, r = (coloured[30, 50:80].astype(int).mean(axis=0))
        assert b == g == r > 100  # no ground truth: grey
        with pytest.raises(ValueError, match="correct"):
            viz.draw_matches(self.img, self.img, self.pts, self.pts, pairs,
                             np.array([True, False]))
        with pytest.raises(ValueError, match="matches"):
            viz.draw_matches(self.img, self.img, self.pts, self.pts, np.array([[0, 5]]))

    def test_draw_disparity_and_keypoints(self):
        out = viz.draw_disparity(self.img, self.pts, [1.0, 2.0, 3.0], max_disparity=3)
        assert out.shape == (40, 50, 3)
        assert tuple(out[30, 40]) == tuple(
            cv2.applyColorMap(np.uint8([[255]]), cv2.COLORMAP_TURBO)[0, 0])
        empty = viz.draw_disparity(self.img, np.zeros((0, 2), np.float32), [])
        assert empty.shape == (40, 50, 3) and not empty.any()
        kps = viz.draw_keypoints(np.full((40, 50), 100, np.uint16), self.pts)
        assert kps.shape == (40, 50, 3) and kps.dtype == np.uint8


class TestInputs:
    def test_index_pairs_from_dmatches_lists_and_arrays_agree(self):
        want = np.array([[0, 1], [2, 0]], np.int64)
        dm = [cv2.DMatch(0, 1, 0.5), cv2.DMatch(2, 0, 0.1)]
        for matches in (dm, tuple(dm), [[0, 1], [2, 0]], want.astype(np.int32)):
            got = as_index_pairs(matches, 3, 2)
            assert got.dtype == np.int64 and np.array_equal(got, want)
        assert as_index_pairs([], 3, 2).shape == (0, 2)

    def test_index_pairs_refuse_bad_matches(self):
        with pytest.raises(InvalidArgumentError, match="do not exist"):
            as_index_pairs([[0, 2]], 3, 2)
        with pytest.raises(InvalidTypeError, match="matches"):
            as_index_pairs([[0.5, 1]], 3, 2)
        with pytest.raises(InvalidArgumentError, match="matches"):
            as_index_pairs(np.zeros((2, 3), int), 3, 2)

    def test_display_image(self):
        bgra = np.dstack([np.full((4, 5), v, np.uint8) for v in (1, 2, 3, 4)])
        out = as_display_image(bgra, "image")
        assert out.shape == (4, 5, 3) and out.flags.c_contiguous
        assert out[0, 0].tolist() == [1, 2, 3]
        ramp = np.linspace(-1.0, 1.0, 20, dtype=np.float32).reshape(4, 5)
        out = as_display_image(ramp, "image")
        assert out.dtype == np.uint8 and out.min() == 0 and out.max() == 255
        assert (out[..., 0] == out[..., 2]).all()
        with pytest.raises(InvalidArgumentError, match="image"):
            as_display_image(np.zeros((0, 5, 3), np.uint8), "image")


class TestHostileDrawingInputs:
    """Points OpenCV cannot draw (beyond +-2**20 px, the matcher's own bound) and
    disparities that are not numbers get hopmatch's errors naming the argument, from every
    drawing function; before 2026-12-06 a point at 4.6e18 px was a cv2.error and a string of
    disparities NumPy's bare ValueError."""

    img = np.zeros((40, 50), np.uint8)
    pts = np.float32([[10, 10], [30, 20], [40, 30]])
    far = np.float32([[10, 10], [2.0**62, 20], [40, 30]])
    pairs = np.array([[0, 0], [1, 1], [2, 2]])

    def test_far_points_are_refused_by_name(self):
        far_kps = [cv2.KeyPoint(float(x), float(y), 5) for x, y in self.far]
        calls = {
            "points": lambda p: viz.draw_disparity(self.img, p, [1.0, 2.0, 3.0]),
            "points ": lambda p: viz.draw_keypoint_disparities(self.img, p, [1.0, 2.0, 3.0]),
            "kps_l": lambda p: viz.draw_match_overview(self.img, self.img, p, self.pts,
                                                       self.pairs),
            "kps_r": lambda p: viz.draw_matches(self.img, self.img, self.pts, p, self.pairs),
            "kps_l ": lambda p: viz.draw_labelled_matches(self.img, self.img, p, self.pts,
                                                          self.pairs),
            "keypoints": lambda p: viz.draw_keypoints(self.img, p),
        }
        for name, call in calls.items():
            for far in (self.far, far_kps):
                with pytest.raises(InvalidArgumentError, match=rf"`{name.strip()}` holds a "
                                                               "coordinate of magnitude"):
                    call(far)
        # at the bound itself they draw (off the picture)
        edge = self.pts.copy()
        edge[1] = 2.0**20
        assert viz.draw_disparity(self.img, edge, [1.0, 2.0, 3.0]).shape == (40, 50, 3)

    @pytest.mark.parametrize("bad", ["abc", ["a", "b", "c"], [object()] * 3, [[1, 2], [3]]])
    def test_disparities_that_are_not_numbers_are_refused_by_name(self, bad):
        for call in (lambda: viz.draw_disparity(self.img, self.pts, bad),
                     lambda: viz.draw_keypoint_disparities(self.img, self.pts, bad),
                     lambda: viz.draw_match_overview(self.img, self.img, self.pts, self.pts,
                                                     self.pairs, bad)):
            with pytest.raises(InvalidTypeError, match="`disparities`"):
                call()

    def test_disparities_one_per_point_or_match(self):
        with pytest.raises(InvalidArgumentError, match=r"one value per point \(3\), got 2"):
            viz.draw_disparity(self.img, self.pts, [1.0, 2.0])
        with pytest.raises(InvalidArgumentError, match=r"one value per match \(3\), got 1"):
            viz.draw_match_overview(self.img, self.img, self.pts, self.pts, self.pairs, [1.0])
