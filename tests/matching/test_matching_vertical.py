"""The residual vertical-offset model: a robust plane recovers an injected rotation."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch import datasets
from hopmatch.matching import vertical
from hopmatch.matching.disambiguate import vertically_consistent
from hopmatch.matching.vertical import (
    PLANE_MIN_MATCHES,
    RowOffset,
    fit_row_offset,
    row_offset_prior,
)


def rotated_offsets(points, degrees, centre, shift=0.0):
    """``yl - yr`` when the right image is the left one rotated by ``degrees`` about
    ``centre`` and moved down by ``shift`` (right = R (left - centre) + centre)."""
    t = math.radians(degrees)
    x, y = points[:, 0] - centre[0], points[:, 1] - centre[1]
    yr = centre[1] + math.sin(t) * x + math.cos(t) * y + shift
    return points[:, 1] - yr


def test_plane_recovers_an_injected_rotation_despite_outliers():
    rng = np.random.default_rng(0)
    pts = np.c_[rng.uniform(0, 1200, 800), rng.uniform(0, 400, 800)]
    dy = rotated_offsets(pts, 0.2, (600, 200), shift=0.3) + rng.normal(0, 0.1, 800)
    bad = rng.random(800) < 0.2
    dy[bad] += rng.uniform(-6, 6, bad.sum())
    model = fit_row_offset(pts, dy)
    t = math.radians(0.2)
    assert model.b == pytest.approx(-math.sin(t), abs=2e-4)
    assert model.c == pytest.approx(1 - math.cos(t), abs=2e-4)
    truth = rotated_offsets(pts, 0.2, (600, 200), shift=0.3)
    assert np.abs(model.at(pts) - truth).max() < 0.05
    # the plane keeps the correct pairs at the sides that the median rejects
    plane = vertically_consistent(dy, 1.0, pts)
    median = vertically_consistent(dy, 1.0)
    assert plane[~bad].all() and not median[~bad].all()


def reference_plane(left, dy):
    """:func:`fit_row_offset` written plainly with ``np.median`` (no weights)."""
    p, dy = np.asarray(left, np.float64), np.asarray(dy, np.float64)
    cx, cy = (float(v) for v in np.median(p, axis=0))
    design = np.c_[np.ones(len(dy)), p[:, 0] - cx, p[:, 1] - cy]
    coef = np.array([float(np.median(dy)), 0.0, 0.0])
    for _ in range(vertical.PLANE_ITERATIONS):
        res = dy - design @ coef
        scale = max(1.4826 * float(np.median(np.abs(res - np.median(res)))), 1e-3)
        r = res / (vertical.PLANE_TUKEY * scale)
        sw = np.sqrt(np.where(np.abs(r) < 1.0, (1.0 - r * r) ** 2, 0.0))
        coef = np.linalg.lstsq(design * sw[:, None], dy * sw, rcond=None)[0]
    return RowOffset(float(coef[0]), float(coef[1]), float(coef[2]), cx, cy)


@pytest.mark.parametrize("n", [PLANE_MIN_MATCHES, PLANE_MIN_MATCHES + 1, 801, 2000])
def test_plane_is_bit_identical_to_the_numpy_reference(n):
    """The fit's own median (odd and even counts) is ``np.median``, bit for bit."""
    rng = np.random.default_rng(n)
    pts = np.c_[rng.uniform(0, 1200, n), rng.uniform(0, 400, n)]
    dy = rotated_offsets(pts, 0.3, (600, 200)) + rng.normal(0, 0.2, n)
    dy[rng.random(n) < 0.2] += 4.0
    assert fit_row_offset(pts, dy) == reference_plane(pts, dy)


def test_few_matches_give_the_median():
    pts = np.c_[np.arange(10.0), np.arange(10.0)]
    dy = np.linspace(-1, 1, 10) + 0.25
    assert PLANE_MIN_MATCHES > 10
    model = fit_row_offset(pts, dy)
    assert model == RowOffset(float(np.median(dy)))
    np.testing.assert_array_equal(vertically_consistent(dy, 1.0, pts),
                                  vertically_consistent(dy, 1.0))


def test_collinear_points_give_the_median():
    pts = np.c_[np.arange(100.0), np.zeros(100)]
    model = fit_row_offset(pts, np.full(100, 0.4))
    assert model.b == 0.0 and model.c == 0.0 and model.a == pytest.approx(0.4)


def test_match_stereo_measures_the_rotation_of_a_pair():
    """A pair whose right image is rotated 0.3 degree: the model match_stereo searched
    along has the rotation's slope, and the guided and refined matches follow it."""
    rng = np.random.default_rng(2)
    tex = cv2.GaussianBlur(rng.normal(size=(240, 480)), (0, 0), 1.2)
    left = np.clip((tex - tex.min()) / np.ptp(tex) * 220 + 15, 0, 255).astype(np.uint8)
    m = cv2.getRotationMatrix2D((239.5, 119.5), -0.3, 1.0)  # cv2: positive = anticlockwise
    m[0, 2] -= 8.0  # disparity 8
    right = cv2.warpAffine(left, m, (480, 240), flags=cv2.INTER_CUBIC,
                           borderMode=cv2.BORDER_REFLECT)
    res = hopmatch.match_stereo(left, right, max_disparity=16, max_vertical=2.0)
    slope = res.row_offset.b  # d(yl - yr)/dx
    assert slope == pytest.approx(-math.sin(math.radians(0.3)), abs=5e-4)
    ml, mr = res.matched_left, res.matched_right
    hom = np.c_[ml, np.ones(len(ml))] @ m.T  # where each left point lands in the right
    assert np.median(np.abs(hom[:, 1] - mr[:, 1])) < 0.1


def test_a_pair_rotated_by_degrees_is_not_searched_along_rows():
    """Past about a degree the offset is no rectification residual: match_stereo keeps the
    network's matches only (rectify the pair or pass its fundamental matrix)."""
    rng = np.random.default_rng(2)
    tex = cv2.GaussianBlur(rng.normal(size=(240, 480)), (0, 0), 1.2)
    left = np.clip((tex - tex.min()) / np.ptp(tex) * 220 + 15, 0, 255).astype(np.uint8)
    m = cv2.getRotationMatrix2D((239.5, 119.5), -3.0, 1.0)
    m[0, 2] -= 8.0
    right = cv2.warpAffine(left, m, (480, 240), flags=cv2.INTER_CUBIC,
                           borderMode=cv2.BORDER_REFLECT)
    res = hopmatch.match_stereo(left, right, max_disparity=16, max_vertical=2.0,
                                both_features=False)  # one run's arrays
    assert res.row_offset is not None and not res.row_offset.is_residual()
    assert res.guided is None and res.refinement is None
    np.testing.assert_array_equal(res.query_idx, res.network.query_idx)


def shifted_texture_pair(dy, degrees=0.0, disparity=8.0, seed=5):
    """A textured pair whose right image is the left moved ``disparity`` px left, ``dy`` px
    down and rotated ``degrees`` about the centre; the 2 x 3 map from left to right."""
    rng = np.random.default_rng(seed)
    tex = cv2.GaussianBlur(rng.normal(size=(240, 480)), (0, 0), 1.2)
    left = np.clip((tex - tex.min()) / np.ptp(tex) * 220 + 15, 0, 255).astype(np.uint8)
    m = cv2.getRotationMatrix2D((239.5, 119.5), -degrees, 1.0)
    m[0, 2] -= disparity
    m[1, 2] += dy
    right = cv2.warpAffine(left, m, (480, 240), flags=cv2.INTER_CUBIC,
                           borderMode=cv2.BORDER_REFLECT)
    return left, right, m


@pytest.mark.parametrize("dy, degrees", [(1.5, 0.0), (-2.5, 0.0), (0.0, 0.4), (1.0, -0.3)])
def test_row_offset_prior_recovers_an_injected_offset(dy, degrees):
    """The prior measured from look-alikes before the network has the injected shift and
    slope (within 0.3 px at the left points, the look-alikes being whole-pixel-ish)."""
    left, right, m = shifted_texture_pair(dy, degrees)
    det = hopmatch.DericheMoravecDetector()
    kl, dl = det.detectAndCompute(left, None)
    kr, dr = det.detectAndCompute(right, None)
    q, t = cv2.KeyPoint_convert(kl), cv2.KeyPoint_convert(kr)
    prior = row_offset_prior(q, t, dl, dr, 0.0, 16.0, 1.0)
    assert prior is not None
    truth = q[:, 1] - (np.c_[q, np.ones(len(q))] @ m.T)[:, 1]  # yl - yr at each left point
    assert np.median(np.abs(prior.offset.at(q) - truth)) < 0.3
    assert prior.disparity == pytest.approx(8.0, abs=1.0)
    if degrees == 0.0:  # a shift asks for no slope: the constant model is taken
        assert prior.offset.b == 0.0 and prior.offset.c == 0.0


def test_the_prior_samples_more_points_when_few_look_alikes_are_clear(monkeypatch):
    """When the first sample gives fewer clear look-alikes than a plane needs (here: a
    first sample of 40 points, at most 40 look-alikes), the sample doubles until it
    does, and the rotation's plane is found."""
    monkeypatch.setattr(vertical, "PRIOR_SAMPLE", 40)
    left, right, m = shifted_texture_pair(0.0, 0.4)
    det = hopmatch.DericheMoravecDetector()
    kl, dl = det.detectAndCompute(left, None)
    kr, dr = det.detectAndCompute(right, None)
    q, t = cv2.KeyPoint_convert(kl), cv2.KeyPoint_convert(kr)
    assert len(q) > 4 * 40
    prior = row_offset_prior(q, t, dl, dr, 0.0, 16.0, 1.0)
    assert prior is not None and prior.offset.b != 0.0
    truth = q[:, 1] - (np.c_[q, np.ones(len(q))] @ m.T)[:, 1]
    assert np.median(np.abs(prior.offset.at(q) - truth)) < 0.3


def test_a_rectified_pair_gets_no_prior():
    left, right, _ = shifted_texture_pair(0.0)
    det = hopmatch.DericheMoravecDetector()
    kl, dl = det.detectAndCompute(left, None)
    kr, dr = det.detectAndCompute(right, None)
    prior = row_offset_prior(cv2.KeyPoint_convert(kl), cv2.KeyPoint_convert(kr), dl, dr,
                             0.0, 16.0, 1.0)
    assert prior is None
    res = hopmatch.match_stereo(left, right, max_disparity=16)
    assert res.network.row_prior is None


@pytest.mark.parametrize("dy, degrees", [(1.5, 0.0), (0.0, 0.4)])
def test_match_stereo_follows_rows_offset_beyond_its_band(dy, degrees):
    """A residual vertical offset beyond the 1 px band (1.5 px, or 0.4 degree across 480
    px): before the prior most true partners lay outside the band. Now the band follows
    the offset: as many correct matches (2-D, within 1 px of where the map puts each
    left point) as on the unshifted pair, give or take 15 %, at >= 0.97 precision; right
    points are reported in the right image as given."""
    base_l, base_r, base_m = shifted_texture_pair(0.0)
    left, right, m = shifted_texture_pair(dy, degrees)

    def correct(res, m):
        hom = np.c_[res.matched_left, np.ones(len(res.query_idx))] @ m.T
        return np.hypot(*(hom - res.matched_right).T) <= 1.0

    base = correct(hopmatch.match_stereo(base_l, base_r, max_disparity=16), base_m)
    res = hopmatch.match_stereo(left, right, max_disparity=16)
    ok = correct(res, m)
    assert ok.sum() >= 0.85 * base.sum()
    assert ok.mean() >= 0.97
    assert res.network.row_prior is not None
    np.testing.assert_array_equal(res.matched_right, res.points_right[res.train_idx])


def test_a_plane_the_rows_fit_as_well_is_not_taken(shared_data):
    """KITTI #70 as it is: the look-alikes' robust plane reaches 1 px at a corner, but fits
    hardly more of them within 0.5 px than the plain rows do (54 % against 51 %): no prior
    (with the median-shift rule alone it was taken, and cost 23 % of the correct matches,
    benchmarks/passes.py)."""
    scene = datasets.load("kitti2012/000070")
    res = hopmatch.match_stereo(scene.left, scene.right)
    assert res.network.row_prior is None


def test_a_rotation_of_one_and_a_half_degrees_is_followed():
    """Below about 2 degrees (MAX_RESIDUAL_SLOPE) the prior follows a rotation: the guided
    pass and the refinement run along the plane's rows."""
    left, right, m = shifted_texture_pair(0.0, 1.5)
    res = hopmatch.match_stereo(left, right, max_disparity=16)
    assert res.network.row_prior is not None and res.network.row_prior.offset.is_residual()
    assert res.refinement is not None
    truth = (np.c_[res.matched_left, np.ones(len(res.matched_left))] @ m.T)
    assert np.mean(np.abs(truth - res.matched_right).max(axis=1) <= 1.0) > 0.95


def test_row_plane_residual_tells_a_keystone_from_noise():
    """Rows offset by a plane plus noise: the plane leaves the noise and the quadratic
    surface finds no structure beyond it; rows offset by a keystone (``k x y``, a verged
    rig's): the plane leaves it and the quadratic surface takes it out (curve near its
    90th percentile)."""
    from hopmatch.matching.vertical import row_plane_residual

    rng = np.random.default_rng(0)
    pts = rng.uniform([0, 0], [640, 480], (600, 2))
    u, v = (pts - pts.mean(axis=0)).T
    noise = 0.3 * rng.standard_normal(600)
    residual, curve = row_plane_residual(pts, 0.5 + 0.002 * u - 0.001 * v + noise)
    assert 0.3 < residual < 0.7 and curve < 0.1
    keystone = 3e-5 * u * v
    residual, curve = row_plane_residual(pts, 0.5 + keystone)
    assert residual > 1.2 and curve > 0.9 * np.percentile(np.abs(keystone), 90)
    assert row_plane_residual(pts[:7], keystone[:7]) == (0.0, 0.0)
