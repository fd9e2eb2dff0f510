"""hopmatch.feature.blocking: JPEG's block grid found, and no point detected where it is
the only texture (``DericheMoravecDetector(jpeg_guard=True)``)."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch.feature import blocking
from hopmatch.feature.gradient import INTENSITY_RANGE, intensity_spread


def _jpeg(image, quality):
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert ok
    return cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)


def _scene(seed=0, shape=(240, 320), disparity=5):
    """A rectified pair: smooth shading everywhere (what JPEG codes as nearly flat
    blocks), fine texture in one rectangle; the right view is the left moved by
    ``disparity`` px (``x_r = x_l - disparity``)."""
    rng = np.random.default_rng(seed)
    h, w = shape
    base = cv2.GaussianBlur(rng.uniform(0, 255, (h, w + 40)).astype(np.float32), (0, 0), 12)
    base = cv2.normalize(base, None, 80, 170, cv2.NORM_MINMAX)
    tex = cv2.GaussianBlur(rng.uniform(0, 255, base.shape).astype(np.float32), (0, 0), 1.2)
    tex = cv2.normalize(tex, None, -60, 60, cv2.NORM_MINMAX)
    inside = np.zeros(base.shape, np.float32)
    inside[60:180, 100:260] = 1.0
    img = np.clip(base + inside * tex, 0, 255).astype(np.uint8)
    return img[:, 20:20 + w], img[:, 20 + disparity:20 + disparity + w]


def test_the_grid_and_its_phase_are_found_in_jpegs_only():
    left, _ = _scene()
    assert blocking.block_grid(left) is None  # never compressed
    noise = np.random.default_rng(1).integers(0, 256, (120, 160), dtype=np.uint8)
    assert blocking.block_grid(noise) is None
    compressed = _jpeg(left, 40)
    assert blocking.block_grid(compressed) == (7, 7)  # steps between pixels 7 and 8
    # cropped after compression: the grid moves with the crop
    assert blocking.block_grid(compressed[3:, 5:]) == ((7 - 5) % 8, (7 - 3) % 8)
    assert blocking.block_grid(compressed[:12, :]) is None  # too small for two blocks
    assert blocking.block_grid(np.full((64, 64), 9, np.uint8)) is None  # flat: no step


def _grid_dominated_reference(gray, phases):
    """Pixel by pixel: the mean step across the grid's lines and the mean of the other
    steps in the REACH-square around each pixel (mirrored at the border as
    cv2.BORDER_REFLECT, numpy's 'symmetric'), and the test of grid_dominated."""
    img = gray.astype(np.float64) * (INTENSITY_RANGE / intensity_spread(gray))
    h, w = img.shape
    r = blocking.REACH // 2
    steps, on = [], []
    for axis, phase in ((1, phases[0]), (0, phases[1])):
        step = np.zeros((h, w))
        line = np.zeros((h, w), bool)
        valid = np.zeros((h, w), bool)
        if axis == 1:
            step[:, :-1] = np.abs(img[:, 1:] - img[:, :-1])
            line[:, [x for x in range(w - 1) if x % blocking.BLOCK == phase]] = True
            valid[:, :-1] = True
        else:
            step[:-1, :] = np.abs(img[1:, :] - img[:-1, :])
            line[[y for y in range(h - 1) if y % blocking.BLOCK == phase], :] = True
            valid[:-1, :] = True
        steps.append(np.pad(step, r, mode="symmetric"))
        on.append((np.pad(line, r, mode="symmetric"), np.pad(valid & ~line, r, mode="symmetric")))
    out = np.zeros((h, w), bool)
    margin = np.zeros((h, w))
    for y in range(h):
        for x in range(w):
            win = (slice(y, y + 2 * r + 1), slice(x, x + 2 * r + 1))
            g_sum = sum(s[win][a[win]].sum() for s, (a, _) in zip(steps, on))
            g_n = sum(a[win].sum() for a, _ in on)
            o_sum = sum(s[win][b[win]].sum() for s, (_, b) in zip(steps, on))
            o_n = sum(b[win].sum() for _, b in on)
            grid, other = g_sum / max(g_n, 1), o_sum / max(o_n, 1)
            bound = blocking.DOMINANCE * other + blocking.FLOOR
            out[y, x] = grid > bound
            margin[y, x] = abs(grid - bound)
    return out, margin


@pytest.mark.parametrize("quality", [30, 60])
def test_grid_dominated_equals_the_reference(quality):
    left, _ = _scene(seed=2, shape=(40, 56))
    gray = _jpeg(left, quality)
    phases = blocking.block_grid(gray) or (7, 7)
    got = blocking.grid_dominated(gray, phases)
    want, margin = _grid_dominated_reference(gray, phases)
    decided = margin > 1e-3  # float32 box sums against float64: ties may go either way
    assert decided.mean() > 0.99
    np.testing.assert_array_equal(got[decided], want[decided])
    assert want.any() and not want.all()


def test_detector_leaves_out_the_grid_only():
    left, _ = _scene()
    compressed = _jpeg(left, 30)
    allowed = blocking.block_artifact_mask(compressed)
    assert allowed is not None and 0.05 < 1 - allowed.mean() < 0.95
    guarded = hopmatch.DericheMoravecDetector(jpeg_guard=True)
    plain = hopmatch.DericheMoravecDetector(jpeg_guard=False)
    pts, _, _ = guarded.detect_points(compressed)
    every, _, _ = plain.detect_points(compressed)
    xi, yi = np.round(pts).astype(int).T
    assert allowed[yi, xi].all()  # no point where the grid is the only texture
    assert len(pts) < len(every)
    # the points kept are the plain detector's points where the grid does not dominate
    ex, ey = np.round(every).astype(int).T
    np.testing.assert_array_equal(pts, every[allowed[ey, ex]])
    # a user's mask still applies
    mask = np.zeros(compressed.shape, np.uint8)
    mask[:, :160] = 1
    masked, _, _ = guarded.detect_points(compressed, mask)
    assert len(masked) and (masked[:, 0] < 160).all()
    # an image with no grid is detected as before
    a, _, _ = guarded.detect_points(left)
    b, _, _ = plain.detect_points(left)
    np.testing.assert_array_equal(a, b)


def test_paper_preset_and_accessors():
    assert hopmatch.DericheMoravecDetector().getJpegGuard() is True
    paper = hopmatch.DericheMoravecDetector(preset="paper")
    assert paper.getJpegGuard() is False
    paper.setJpegGuard(True)
    assert paper.getJpegGuard() is True
    with pytest.raises(hopmatch.errors.InvalidTypeError, match="jpeg_guard"):
        hopmatch.DericheMoravecDetector(jpeg_guard="yes")


def test_jpeg_pair_matches_are_not_locked_to_the_grid():
    """Both views saved at JPEG quality 30: without the guard, most wrong matches sit at a
    disparity that is a multiple of 8 px (the grid, at the same place in both views); with
    it, few remain, and the right matches stay."""
    left, right = _scene()
    jl, jr = _jpeg(left, 30), _jpeg(right, 30)
    counts = {}
    for guard in (False, True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", hopmatch.errors.HopmatchWarning)
            res = hopmatch.match_stereo(jl, jr, max_disparity=40, jpeg_guard=guard)
        d = res.matched_left[:, 0] - res.matched_right[:, 0]
        wrong = np.abs(d - 5) > 1
        locked = wrong & (np.abs(d - 8 * np.round(d / 8)) < 0.5)
        counts[guard] = (int(locked.sum()), int((~wrong).sum()))
    (locked_off, right_off), (locked_on, right_on) = counts[False], counts[True]
    assert locked_off >= 40
    assert locked_on <= 0.25 * locked_off
    assert right_on >= 0.9 * right_off
