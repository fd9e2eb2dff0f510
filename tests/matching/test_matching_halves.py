"""The half-window test (hopmatch.matching.halves): its kernel against the NumPy reference,
and what it drops on a synthetic pair with a depth edge."""

from __future__ import annotations

import naive_guided as ng
import numpy as np
import pytest
from synthetic_pairs import occlusion_pair, texture

import hopmatch
from hopmatch._kernels import halves as kh
from hopmatch.matching import halves

H, W = 120, 200
#: The foreground square's columns in the left image, and the two disparities.
FG = (60, 120)
D_BG, D_FG = 4, 10


def layered_pair():
    """A textured background at disparity D_BG behind a textured square (rows 20-100,
    columns FG of the left image) at D_FG: ``(left, right)`` float64, rendered pixel by
    pixel (the square hides the background in the right image where it covers it)."""
    bg, fg = texture(H, W + 40, 1), texture(H, W + 40, 2)
    left = np.empty((H, W))
    right = np.empty((H, W))
    for y in range(H):
        inside = 20 <= y < 100
        for x in range(W):
            left[y, x] = fg[y, x] if inside and FG[0] <= x < FG[1] else bg[y, x]
            xs = x + D_FG  # the left column the right pixel x shows if it is foreground
            right[y, x] = (fg[y, xs] if inside and FG[0] <= xs < FG[1] else bg[y, x + D_BG])
    return left, right


@pytest.mark.parametrize("seed", [0, 1])
def test_the_wrong_matches_beside_an_occluding_edge_are_dropped(seed, monkeypatch):
    """With lenient settings (no similarity gate, input bias 0) about 25 wrong matches get
    through on the occlusion pair, the background beside the rectangle matched with its
    disparity; the half-window test drops nearly all of them for a few correct ones."""
    left, right, gt = occlusion_pair(seed)

    def counts():
        res = hopmatch.match_stereo(left, right, max_disparity=24, input_bias=0.0,
                                    similarity_gate=None)
        pl, pr = res.matched_left, res.matched_right
        g = gt[np.floor(pl[:, 1] + 0.5).astype(int), np.floor(pl[:, 0] + 0.5).astype(int)]
        ok = (np.abs((pl[:, 0] - pr[:, 0]) - g) <= 1) & (np.abs(pl[:, 1] - pr[:, 1]) <= 1)
        return int((~ok).sum()), int(ok.sum())

    wrong_on, correct_on = counts()
    monkeypatch.setattr(halves, "HALF_CHECK", False)
    wrong_off, correct_off = counts()
    assert wrong_off >= 15
    assert wrong_on <= 0.2 * wrong_off
    assert correct_on >= 0.98 * correct_off


def test_kernel_matches_the_reference():
    rng = np.random.default_rng(5)
    img_l, img_r = texture(50, 80, 3), texture(50, 80, 4)
    img_r[10:30, 40:60] = 77.0  # a flat patch: halves without contrast
    left = np.c_[rng.uniform(-2, 82, 300), rng.uniform(-2, 52, 300)]
    right = left + rng.uniform(-3, 3, (300, 2))
    right[:40] = left[:40] + [-0.25, 0.0]
    for radius in (2, 4):
        got = kh.half_windows(img_l.astype(np.float32), img_r.astype(np.float32),
                              left, right, radius)
        want = ng.half_windows(img_l.astype(np.float32), img_r.astype(np.float32),
                               left, right, radius)
        for g, w in zip(got, want):
            np.testing.assert_array_equal(np.isnan(g), np.isnan(w))
            assert np.isfinite(g).sum() > 50
            np.testing.assert_allclose(g[np.isfinite(g)], w[np.isfinite(w)], atol=1e-9)


def test_identical_windows_correlate_and_a_flat_half_scores_zero():
    img = texture(40, 60, 6).astype(np.float32)
    flat = img.copy()
    flat[:, :30] = 50.0
    pts = np.array([[30.0, 20.0], [25.3, 18.6]])
    z_l, z_r, s_l, s_r = halves.half_window_zncc(img, img, pts, pts)
    np.testing.assert_allclose(np.r_[z_l, z_r], 1.0, atol=1e-9)
    assert (s_l > 1).all() and (s_r > 1).all()
    z_l, z_r, s_l, s_r = halves.half_window_zncc(flat, flat, pts[:1], pts[:1])
    assert z_l[0] == 0.0 and s_l[0] == 0.0 and z_r[0] == pytest.approx(1.0)


def test_a_window_across_the_depth_edge_at_the_foreground_disparity_is_dropped():
    left, right = layered_pair()
    # background points beside the square (2 px right of its right edge, rows inside it)
    # matched with the foreground's disparity: the square's edge fills the left half and
    # matches, the background half does not
    edge = np.array([[FG[1] + 1.3, y + 0.4] for y in range(30, 90, 6)])
    # correct matches well inside the square and on the background far from it
    inside = np.array([[90.2 + (y % 3), y + 0.4] for y in range(30, 90, 6)])
    outside = np.array([[160.7, y + 0.4] for y in range(10, 110, 6)])
    pts = np.r_[edge, inside, outside]
    disp = np.r_[np.full(len(edge), D_FG), np.full(len(inside), D_FG),
                 np.full(len(outside), D_BG)]
    right_pts = pts - np.c_[disp, np.zeros(len(pts))]
    drop = halves.straddling(left, right, pts, right_pts)
    # the background half correlates with background 6 px away only by chance
    assert drop[:len(edge)].sum() >= 0.8 * len(edge)
    assert not drop[len(edge):].any()
    z_l, z_r, _, _ = halves.half_window_zncc(left, right, edge, right_pts[:len(edge)])
    assert (z_l > z_r).all() and np.median(z_l) > 0.7 and np.median(z_r) < 0.2


def test_a_half_without_contrast_is_not_judged():
    left, right = layered_pair()
    pts = np.array([[40.4, 60.2], [150.6, 50.3]])
    right_pts = pts - [D_BG, 0.0]
    lf, rf = left.copy(), right.copy()
    lf[:, :int(pts[0, 0])] = 90.0  # the first point's left half flat in both images
    rf[:, :int(pts[0, 0] - D_BG)] = 90.0
    rf[40:70, 147:153] = texture(30, 6, 9)  # the second's right half no longer matches
    drop = halves.straddling(lf, rf, pts, right_pts)
    np.testing.assert_array_equal(drop, [False, True])


def test_match_stereo_drops_exactly_the_straddling_matches(monkeypatch):
    left, right = layered_pair()
    left8, right8 = left.astype(np.uint8), right.astype(np.uint8)
    # a stricter threshold than the default, so that this clean pair has matches to drop
    monkeypatch.setattr(halves, "HALF_MIN_ZNCC", 0.97)
    one = {"max_disparity": 16, "threads": 1, "both_features": False}  # one run's arrays
    on = hopmatch.match_stereo(left8, right8, **one)
    monkeypatch.setattr(halves, "HALF_CHECK", False)
    off = hopmatch.match_stereo(left8, right8, **one)
    drop = halves.straddling(left8, right8, off.matched_left, off.matched_right)
    assert 0 < drop.sum() < len(drop) // 4
    np.testing.assert_array_equal(on.matched_left, off.matched_left[~drop])
    np.testing.assert_array_equal(on.passes, off.passes[~drop])
    np.testing.assert_array_equal(on.distances, off.distances[~drop])
    np.testing.assert_array_equal(on.refinement.x, off.refinement.x[~drop])
    kept_net = ~drop[off.passes == 0]
    np.testing.assert_array_equal(on.matched_right[on.passes == 0],
                                  off.matched_right[off.passes == 0][kept_net])
    np.testing.assert_array_equal(on.matched_right[on.passes == 1],
                                  off.matched_right[off.passes == 1][~drop[off.passes == 1]])
    # the arrays stay consistent: one appended right point per guided match
    k = int((on.passes == 1).sum())
    assert len(on.guided.query_idx) == k
    assert len(on.points_right) == on.n_detected_right + k
    assert len(on.responses_right) == len(on.points_right)
    np.testing.assert_array_equal(on.train_idx[on.passes == 1],
                                  on.n_detected_right + np.arange(k))
    # a detected right point no kept match uses is back where it was detected
    used = np.zeros(on.n_detected_right, bool)
    used[on.train_idx[on.passes == 0]] = True
    plain = hopmatch.match_stereo(left8, right8, refine=False, **one)
    np.testing.assert_array_equal(on.points_right[:on.n_detected_right][~used],
                                  plain.points_right[:plain.n_detected_right][~used])
