"""The paper's figures: Figure 5 (points over the gradient magnitude) and Figure 7 (numbered
matches), from :mod:`hopmatch.viz.figures` and from ``hopmatch match --figures``.

The command runs through its real entry point in subprocesses (``python -m hopmatch.cli``),
as in ``tests/cli/``.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from hopmatch import DericheMoravecDetector, deriche_gradient, match_stereo, viz
from hopmatch.errors import InvalidArgumentError, InvalidTypeError

CLI = [sys.executable, "-m", "hopmatch.cli"]
DISPARITY = 6
FIGURES = ["figure5_left.png", "figure5_right.png", "figure7.png"]
RED = [0, 0, 255]
YELLOW = [0, 255, 255]


def run(*args, timeout=180):
    return subprocess.run([*CLI, *map(str, args)], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, timeout=timeout)


def files_in(folder: Path) -> list[str]:
    """Every entry of ``folder`` (hidden temporary files included); [] if it does not exist."""
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


def texture(h=120, w=160, seed=1):
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur((rng.random((h, w)) * 255).astype(np.uint8), (3, 3), 0)


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """A random-texture rectified pair with disparity 6 everywhere, as PNG files."""
    folder = tmp_path_factory.mktemp("pair")
    left = texture()
    right = np.roll(left, -DISPARITY, axis=1)
    paths = {"left": folder / "left.png", "right": folder / "right.png"}
    assert cv2.imwrite(str(paths["left"]), left)
    assert cv2.imwrite(str(paths["right"]), right)
    return paths, left, right


# --------------------------------------------------------------------------------------
# hopmatch.viz.draw_keypoints_on_gradient (Figure 5)
# --------------------------------------------------------------------------------------


class TestDrawKeypointsOnGradient:
    def test_shape_dtype_and_a_cross_at_every_point(self):
        img = texture()
        det = DericheMoravecDetector.create(nms_size=15)
        kps = det.detect(img)
        assert len(kps) > 5
        fig = viz.draw_keypoints_on_gradient(img, kps, det)
        assert fig.shape == (*img.shape, 3) and fig.dtype == np.uint8
        for kp in kps:
            x, y = np.rint(kp.pt).astype(int)
            assert fig[y, x].tolist() == RED
            assert fig[y, x + 2].tolist() == RED and fig[y + 2, x].tolist() == RED

    def test_background_is_the_stretched_gradient_magnitude(self):
        img = np.zeros((40, 60), np.uint8)
        img[10:30, 20:40] = 200
        det = DericheMoravecDetector.create(alpha=2.0)
        fig = viz.draw_keypoints_on_gradient(img, np.zeros((0, 2), np.float32), det)
        g = deriche_gradient(img, alpha=2.0)
        grey = fig[:, :, 0].astype(float)
        assert (fig[:, :, 0] == fig[:, :, 1]).all() and (fig[:, :, 1] == fig[:, :, 2]).all()
        # bright on the edges, black on the flat parts, monotonic in G
        assert grey[g > 0.5 * g.max()].min() > 100
        assert grey[g < 1e-3 * g.max()].max() == 0
        assert np.corrcoef(grey.ravel(), np.minimum(g, np.percentile(g, 99.5)).ravel())[0, 1] \
            > 0.99

    def test_uses_the_detectors_gradient_parameters(self):
        img = texture(60, 80)
        a = viz.draw_keypoints_on_gradient(img, [], DericheMoravecDetector(alpha=0.5))
        b = viz.draw_keypoints_on_gradient(img, [], DericheMoravecDetector(alpha=3.0))
        assert not np.array_equal(a, b)
        default = viz.draw_keypoints_on_gradient(img, [])
        assert np.array_equal(default, viz.draw_keypoints_on_gradient(
            img, [], DericheMoravecDetector()))

    def test_flat_image_gives_finite_black_picture(self):
        fig = viz.draw_keypoints_on_gradient(np.full((20, 30), 7, np.uint8), [])
        assert fig.shape == (20, 30, 3) and not fig.any()

    @pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32, np.float64])
    def test_depths_and_colour(self, dtype):
        img = texture(40, 50).astype(dtype)
        pts = np.float32([[10, 12], [30.4, 20.6]])
        for image in (img, np.dstack([img] * 3)):
            fig = viz.draw_keypoints_on_gradient(image, pts)
            assert fig.shape == (40, 50, 3) and fig.dtype == np.uint8
            assert fig[12, 10].tolist() == RED and fig[21, 30].tolist() == RED

    def test_keypoint_objects_and_arrays_agree(self):
        img = texture(40, 50)
        pts = np.float32([[10, 12], [30, 20]])
        kps = [cv2.KeyPoint(float(x), float(y), 3) for x, y in pts]
        assert np.array_equal(viz.draw_keypoints_on_gradient(img, pts),
                              viz.draw_keypoints_on_gradient(img, kps))

    def test_wrong_input(self):
        img = texture(40, 50)
        with pytest.raises(InvalidTypeError, match="detector"):
            viz.draw_keypoints_on_gradient(img, [], detector="gradient")
        with pytest.raises((InvalidArgumentError, InvalidTypeError), match="keypoints"):
            viz.draw_keypoints_on_gradient(img, np.zeros((3, 3), np.float32))
        with pytest.raises((InvalidArgumentError, InvalidTypeError), match="image"):
            viz.draw_keypoints_on_gradient(np.zeros((2, 3, 4, 5)), [])


# --------------------------------------------------------------------------------------
# hopmatch.viz.draw_labelled_matches (Figure 7)
# --------------------------------------------------------------------------------------


def yellowish(pixels):
    """Label-coloured pixels. OpenCV 4 draws the Hershey digits in exact YELLOW; OpenCV 5's
    text renderer anti-aliases them whatever the line type, so shades near it count too."""
    pixels = np.asarray(pixels, dtype=np.int64)
    return (pixels[..., 0] < 110) & (pixels[..., 1] > 140) & (pixels[..., 2] > 140)


def label_pixels(fig, x, y, w=18, h=12):
    """Yellow pixels in the box up and right of (x, y), where the label of a point goes."""
    box = fig[max(y - h, 0):y + 1, x:x + w]
    return int(yellowish(box).sum())


class TestDrawLabelledMatches:
    def setup_method(self):
        self.left = texture(80, 100)
        self.right = np.roll(self.left, -DISPARITY, axis=1)
        self.pl = np.float32([[20, 20], [60, 40], [40, 65]])
        self.pr = self.pl - np.float32([DISPARITY, 0])

    def test_side_by_side_with_crosses_and_numbers_on_both_images(self):
        matches = np.array([[0, 0], [1, 1], [2, 2]])
        fig = viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr, matches)
        assert fig.shape == (80, 200, 3) and fig.dtype == np.uint8
        for (xl, yl), (xr, yr) in zip(self.pl.astype(int), self.pr.astype(int)):
            assert fig[yl, xl].tolist() == RED
            assert fig[yr, xr + 100].tolist() == RED
            assert label_pixels(fig, xl, yl) > 5
            assert label_pixels(fig, xr + 100, yr) > 5

    def test_numbers_follow_the_order_of_the_matches(self):
        """Reversing the matches reverses the numbers: the label drawn at a point moves
        with the match's rank, on both images."""
        forward = np.array([[0, 0], [1, 1], [2, 2]])
        a = viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr, forward)
        b = viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr, forward[::-1])

        def glyph(fig, i, side):
            x, y = (self.pl if side == 0 else self.pr)[i].astype(int)
            x += 100 * side
            return yellowish(fig[y - 12:y + 1, x:x + 18])

        def iou(p, q):  # anti-aliased text (OpenCV 5) blends with what lies under it
            return (p & q).sum() / max((p | q).sum(), 1)

        for side in (0, 1):
            labels_a = [glyph(a, i, side) for i in range(3)]
            labels_b = [glyph(b, i, side) for i in range(3)]
            same = [iou(labels_a[0], labels_b[2]),   # "1"
                    iou(labels_a[1], labels_b[1]),   # "2"
                    iou(labels_a[2], labels_b[0])]   # "3"
            different = [iou(labels_a[0], labels_a[1]), iou(labels_a[0], labels_a[2]),
                         iou(labels_a[1], labels_a[2])]
            assert min(same) > 0.6 and min(same) > max(different)

    def test_two_digit_labels_are_wider(self):
        pl = np.tile(np.float32([[30, 40]]), (12, 1))
        one = viz.draw_labelled_matches(self.left, self.right, pl[:1], pl[:1], [[0, 0]])
        twelve = viz.draw_labelled_matches(self.left, self.right, pl, pl,
                                           np.zeros((12, 2), int))
        assert label_pixels(twelve, 30, 40, w=30) > label_pixels(one, 30, 40, w=30)

    def test_dmatches_and_keypoints(self):
        kl = [cv2.KeyPoint(float(x), float(y), 3) for x, y in self.pl]
        kr = [cv2.KeyPoint(float(x), float(y), 3) for x, y in self.pr]
        dm = [cv2.DMatch(i, i, 0.1) for i in range(3)]
        a = viz.draw_labelled_matches(self.left, self.right, kl, kr, dm)
        b = viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr,
                                      np.array([[0, 0], [1, 1], [2, 2]]))
        assert np.array_equal(a, b)

    def test_no_matches_gives_the_two_images(self):
        fig = viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr,
                                        np.zeros((0, 2), int))
        assert np.array_equal(fig[:, :100, 0], self.left)
        assert np.array_equal(fig[:, 100:, 0], self.right)

    def test_different_sizes_gap_and_lines(self):
        right = self.right[:60, :90]
        fig = viz.draw_labelled_matches(self.left, right, self.pl, self.pr[:2], [[0, 0]],
                                        gap=10, draw_lines=True)
        assert fig.shape == (80, 200, 3)
        assert fig[20, 20 - DISPARITY + 110].tolist() == RED
        # the line joins the two points: red pixels in the gap, on row 20
        assert (np.all(fig[20, 100:110] == RED, axis=-1)).any()

    def test_labels_stay_inside_at_the_borders(self):
        pts = np.float32([[99, 0], [0, 79], [99, 79]])
        fig = viz.draw_labelled_matches(self.left, self.right, pts, pts,
                                        np.array([[0, 0], [1, 1], [2, 2]]))
        assert fig.shape == (80, 200, 3)
        assert yellowish(fig).sum() > 30

    def test_wrong_input(self):
        with pytest.raises(InvalidArgumentError, match="do not exist"):
            viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr, [[0, 3]])
        with pytest.raises(InvalidTypeError, match="matches"):
            viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr, [[0.5, 1]])
        with pytest.raises(InvalidArgumentError, match="gap"):
            viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr, [[0, 0]],
                                      gap=-1)
        with pytest.raises(InvalidArgumentError, match="font_scale"):
            viz.draw_labelled_matches(self.left, self.right, self.pl, self.pr, [[0, 0]],
                                      font_scale=0)


def test_figures_of_a_real_match():
    """Figure 7 of ``match_stereo``'s result: every match has its crosses."""
    left = texture()
    right = np.roll(left, -DISPARITY, axis=1)
    res = match_stereo(left, right, max_disparity=12)
    assert len(res.query_idx) > 20
    fig = viz.draw_labelled_matches(left, right, res.points_left, res.points_right,
                                    res.matches)
    assert fig.shape == (120, 320, 3)
    assert yellowish(fig).sum() > 5 * len(res.query_idx)
    # a few well-separated matches: a cross at both ends of each
    order = np.argsort(res.matched_left[:, 0] + 1000 * res.matched_left[:, 1])
    some = [res.matches[i] for i in order[::max(len(order) // 6, 1)]]
    fig = viz.draw_labelled_matches(left, right, res.points_left, res.points_right, some)
    for m in some:
        xl, yl = np.rint(res.points_left[m.queryIdx]).astype(int)
        xr, yr = np.rint(res.points_right[m.trainIdx]).astype(int)
        assert fig[yl, xl].tolist() == RED and fig[yr, xr + 160].tolist() == RED


# --------------------------------------------------------------------------------------
# hopmatch match --figures
# --------------------------------------------------------------------------------------


def test_match_figures_writes_the_three_pictures(pair, tmp_path):
    paths, left, right = pair
    out = tmp_path / "out"
    res = run("match", paths["left"], paths["right"], "--out", out, "--max-disparity", 12,
              "--figures")
    assert res.returncode == 0, res.stderr
    names = files_in(out)
    for name in FIGURES:
        assert name in names, names
        assert name in res.stdout  # listed in the "output:" line
    assert not [n for n in names if n.startswith(".")], names  # no temporary file left

    fig5l = cv2.imread(str(out / "figure5_left.png"), cv2.IMREAD_UNCHANGED)
    fig5r = cv2.imread(str(out / "figure5_right.png"), cv2.IMREAD_UNCHANGED)
    fig7 = cv2.imread(str(out / "figure7.png"), cv2.IMREAD_UNCHANGED)
    assert fig5l.shape == fig5r.shape == (120, 160, 3) and fig5l.dtype == np.uint8
    assert fig7.shape == (120, 320, 3)

    # the same pictures as the library draws, from the same matches
    with open(out / "matches.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) > 20
    result = match_stereo(left, right, max_disparity=12)
    assert len(result.query_idx) == len(rows)
    det = DericheMoravecDetector()
    assert np.array_equal(fig5l, viz.draw_keypoints_on_gradient(left, result.points_left, det))
    assert np.array_equal(fig5r,
                          viz.draw_keypoints_on_gradient(right, result.points_right, det))
    # figure7.png numbers a spread-out subset when the matches are many (issue 19)
    from hopmatch.cli.commands import FIGURE7_LABELS

    assert len(result.matches) > FIGURE7_LABELS
    assert np.array_equal(fig7, viz.draw_labelled_matches(
        left, right, result.points_left, result.points_right, result.matches,
        max_labels=FIGURE7_LABELS))

    run_json = json.loads((out / "run.json").read_text())
    assert run_json["parameters"]["figures"] is True
    assert set(FIGURES) <= set(run_json["outputs"])


def test_match_figures_follow_the_preset(pair, tmp_path):
    paths, left, right = pair
    out = tmp_path / "paper"
    res = run("match", paths["left"], paths["right"], "--out", out, "--preset", "paper",
              "--figures", "--no-draw", "--alpha", 0.5)
    assert res.returncode == 0, res.stderr
    assert set(FIGURES) <= set(files_in(out))
    assert "matches.png" not in files_in(out)  # --no-draw does not stop --figures
    det = DericheMoravecDetector(preset="paper", alpha=0.5)
    pts = match_stereo(left, right, preset="paper", alpha=0.5).points_left
    fig5l = cv2.imread(str(out / "figure5_left.png"))
    assert np.array_equal(fig5l, viz.draw_keypoints_on_gradient(left, pts, det))
    # the paper's detector finds fewer points than the default one
    assert len(pts) < len(match_stereo(left, right).points_left)


def test_match_without_figures_writes_none(pair, tmp_path):
    paths, _, _ = pair
    out = tmp_path / "plain"
    res = run("match", paths["left"], paths["right"], "--out", out, "--max-disparity", 12)
    assert res.returncode == 0, res.stderr
    assert not set(FIGURES) & set(files_in(out))
    assert json.loads((out / "run.json").read_text())["parameters"]["figures"] is False


def test_failed_run_with_figures_leaves_nothing(pair, tmp_path):
    paths, _, _ = pair
    out = tmp_path / "new" / "folder"
    res = run("match", paths["left"], paths["right"], "--out", out, "--figures",
              "--max-neurons", 1)
    assert res.returncode == 2, (res.stdout, res.stderr)
    assert "--max-neurons" in res.stderr
    assert not (tmp_path / "new").exists()


def test_help_lists_figures():
    res = run("match", "--help")
    assert res.returncode == 0
    assert "--figures" in res.stdout and "figure7.png" in res.stdout
