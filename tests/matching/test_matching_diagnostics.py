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
    # PTS matched to themselves: the coarse pass finds disparity 0, widened by
    # RANGE_MARGIN of the width + RANGE_PIXELS (hopmatch.matching.disparity_range)
    from hopmatch.matching import disparity_range as dr
    assert res.config.max_disparity == 200 * dr.RANGE_MARGIN + dr.RANGE_PIXELS
    # and min_disparity None (no floor): the same margin below 0
    assert res.config.min_disparity == -res.config.max_disparity
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


# --------------------------------------------------------------------------------------
# A pair that is not a stereo pair (issue 19, point 6)
# --------------------------------------------------------------------------------------


def _object_and_scene():
    """find_obj.py's situation, as box.png / box_in_scene.png: a 324 x 223 object (a crop
    of motorcycle) and a 512 x 384 scene (scikit-image's coffee) holding it rotated by 25
    degrees and scaled by 0.75."""
    import cv2
    from skimage import data

    from hopmatch.datasets import load_motorcycle

    obj = cv2.cvtColor(load_motorcycle().left, cv2.COLOR_BGR2GRAY)[150:373, 200:524]
    scene = cv2.cvtColor(cv2.resize(data.coffee(), (512, 384)), cv2.COLOR_RGB2GRAY)
    M = cv2.getRotationMatrix2D((162, 111), 25, 0.75)
    M[:, 2] += (120, 90)
    warped = cv2.warpAffine(obj, M, (512, 384))
    inside = cv2.warpAffine(np.full_like(obj, 255), M, (512, 384)) > 0
    scene[inside] = warped[inside]
    return obj, scene


def _caught(call):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = call()
    return out, caught


def test_object_and_scene_warn_once_that_they_are_no_stereo_pair():
    """The find_obj.py flow with hopmatch's classes: no match, and one warning that says
    the pair is not a stereo pair and what to try (beside the one about image sizes)."""
    from hopmatch.matching.diagnostics import NotStereoPairWarning

    obj, scene = _object_and_scene()
    detector = hopmatch.DericheMoravecDetector.create()
    kp1, des1 = detector.detectAndCompute(obj, None)
    kp2, des2 = detector.detectAndCompute(scene, None)
    matcher = hopmatch.HopfieldMatcher.create()
    matcher.setPairInfo(kp1, kp2, obj.shape[::-1], scene.shape[::-1])
    pairs, caught = _caught(lambda: matcher.knnMatch(des1, des2, k=2))
    good = [m for m, n in pairs if m.distance < 0.75 * n.distance]
    assert len(good) < 10
    hits = [w for w in caught if w.category is NotStereoPairWarning]
    assert len(hits) == 1, [str(w.message) for w in caught]
    text = str(hits[0].message)
    assert text.startswith("the pair does not look like a stereo pair")
    assert "left image first" in text and "setFundamentalMatrix" in text
    assert "findHomography" in text
    assert hits[0].filename == __file__  # at the user's line
    assert issubclass(NotStereoPairWarning, hopmatch.errors.HopmatchWarning)


def test_two_unrelated_images_of_one_size_warn():
    from hopmatch.matching.diagnostics import NotStereoPairWarning

    obj, scene = _object_and_scene()
    res, caught = _caught(lambda: hopmatch.match_stereo(scene[:223, :324], obj))
    assert len(res.matches) < 10
    assert [w.category for w in caught] == [NotStereoPairWarning]


def test_stereo_pairs_are_not_called_unrelated(motorcycle):
    """Rectified, unrectified (rotated and shifted) and swapped views of one scene never get
    the warning; the unrectified one gets the rectification warning alone, the swapped one
    the warning that every disparity the range search found is negative (it is matched at
    them: min_disparity=None) alone."""
    import cv2

    from hopmatch.errors import DisparityRangeWarning, UnrectifiedPairWarning
    from hopmatch.matching.diagnostics import NotStereoPairWarning

    left, right = (cv2.cvtColor(img, cv2.COLOR_RGB2GRAY) for img in motorcycle[:2])
    h, w = left.shape
    M = cv2.getRotationMatrix2D((w / 2, h / 2), 4, 1.0)
    M[1, 2] += 20
    for l_img, r_img, expected in ((left, right, []),
                                   (left, cv2.warpAffine(right, M, (w, h)),
                                    [UnrectifiedPairWarning]),
                                   (right, left, [DisparityRangeWarning])):
        _, caught = _caught(lambda a=l_img, b=r_img: hopmatch.match_stereo(a, b))
        categories = [w.category for w in caught]
        assert NotStereoPairWarning not in categories
        assert categories == expected


@pytest.mark.shared_data
def test_raw_chessboard_photos_are_a_stereo_pair(shared_data):
    """Repetitive texture (OpenCV's raw calibration photos, a few matches): not called
    unrelated."""
    import cv2

    from hopmatch.matching.diagnostics import NotStereoPairWarning

    folder = shared_data / "opencv_stereo_calib"
    for n in ("01", "11"):
        left = cv2.imread(str(folder / f"left{n}.jpg"), cv2.IMREAD_GRAYSCALE)
        right = cv2.imread(str(folder / f"right{n}.jpg"), cv2.IMREAD_GRAYSCALE)
        _, caught = _caught(lambda a=left, b=right: hopmatch.match_stereo(a, b))
        assert NotStereoPairWarning not in [w.category for w in caught]


def test_the_pair_warning_waits_for_the_final_matches():
    """warn_about_pair: the network's diagnosis stands only while the final matches are
    still few (below RECTIFICATION_SUSPICIOUS of the keypoints); else the few-matches
    check is made, with the final count."""
    from hopmatch.matching.diagnostics import (
        RECTIFICATION_SUSPICIOUS,
        NotStereoPairWarning,
        warn_about_pair,
    )

    pts = np.zeros((1000, 2), np.float32)
    few = int(np.ceil(RECTIFICATION_SUSPICIOUS * len(pts)))  # the first count not few
    diagnosis = ("the pair does not look like a stereo pair", NotStereoPairWarning)
    calls = []

    def check(kept=None, exposure=""):
        calls.append(kept)
        return False

    for kept, warns, checked in ((few - 1, True, []), (few, False, [few]),
                                 (None, True, []), (5000, False, [5000])):
        calls.clear()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert warn_about_pair(diagnosis, check, pts, pts, kept=kept) is warns
        assert [w.category for w in caught] == ([NotStereoPairWarning] if warns else [])
        assert calls == checked
    calls.clear()
    assert warn_about_pair(None, check, pts, pts) is False and calls == [None]


def test_a_clipped_view_is_not_called_an_unrelated_pair():
    """warn_about_pair with an exposure note: a not-a-stereo-pair diagnosis gives way to
    the few-matches check, which gets the note as its cause; a rectification diagnosis
    still stands."""
    from hopmatch.errors import UnrectifiedPairWarning
    from hopmatch.matching.diagnostics import NotStereoPairWarning, warn_about_pair

    pts = np.zeros((1000, 2), np.float32)
    calls = []

    def check(kept=None, exposure=""):
        calls.append((kept, exposure))
        return True

    for category, warned, checked in ((NotStereoPairWarning, [], [(3, "it clips")]),
                                      (UnrectifiedPairWarning, [UnrectifiedPairWarning], [])):
        calls.clear()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert warn_about_pair(("words", category), check, pts, pts, kept=3,
                                   exposure="it clips")
        assert [w.category for w in caught] == warned and calls == checked


def test_the_exposure_note_names_the_view_that_clips():
    import cv2

    from hopmatch.matching.diagnostics import CLIPPED_SHARE, exposure_note

    rng = np.random.default_rng(0)
    left = rng.integers(0, 200, (120, 160)).astype(np.uint8)
    bright = left.copy()
    bright[:, : int(160 * (CLIPPED_SHARE + 0.1))] = 255
    note = exposure_note(left, bright)
    assert note.startswith("the right image") and "brightest" in note
    assert "overexposed" in note
    dark = left.copy()
    dark[left < 60] = 0  # the darker levels clip, wherever they lie
    assert exposure_note(dark, left).startswith("the left image")
    assert "darkest" in exposure_note(dark, left)
    # both views clip alike (a white sky in each), a view of one level, or neither clips
    assert exposure_note(bright, bright) == ""
    assert exposure_note(np.full_like(left, 7), bright) == ""
    assert exposure_note(left, left) == ""
    # a small clipped area is no cause
    little = left.copy()
    little[:, :8] = 255
    assert exposure_note(left, little) == ""
    # the black corners a warp leaves (hopmatch.feature.padding) are no exposure
    A = cv2.getRotationMatrix2D((80, 60), 8.0, 0.9)
    turned = cv2.warpAffine(np.maximum(left, 1), A, (160, 120))
    assert np.mean(turned == 0) >= CLIPPED_SHARE
    assert exposure_note(left, turned) == ""


@pytest.mark.shared_data
def test_an_overexposed_view_matched_by_the_guided_pass_is_a_stereo_pair(shared_data):
    """KITTI #70 with the right view brightened (gamma 0.5, gain 1.3, clipped): the
    network keeps few matches, the guided pass thousands; no warning calls the pair
    unrelated (one did, from the network's count, before 2026-12-05)."""
    from hopmatch import datasets
    from hopmatch.matching.diagnostics import NotStereoPairWarning

    scene = datasets.load("kitti2012/000070", shared_data)
    right = np.clip(255.0 * (scene.right / 255.0) ** 0.5 * 1.3, 0, 255).astype(np.uint8)
    res, caught = _caught(lambda: hopmatch.match_stereo(scene.left, right))
    n = min(len(res.points_left), len(res.points_right))
    assert len(res.network.query_idx) < 0.03 * n < len(res.query_idx)
    assert NotStereoPairWarning not in [w.category for w in caught]


# -- issue 20: no or almost no matches is warned about, with its likely cause ----------------


def _noise(seed=0, shape=(200, 260)):
    import cv2

    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.uniform(0, 255, shape).astype(np.float32), (0, 0), 1.5)
    return cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)


def _few(call):
    from hopmatch.errors import FewMatchesWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = call()
    hits = [str(w.message) for w in caught if issubclass(w.category, FewMatchesWarning)]
    return res, hits


def test_few_matches_warns_for_an_unrelated_pair():
    left, right = _noise(), _noise(9)
    res, hits = _few(lambda: hopmatch.match_stereo(left, right, max_disparity=16))
    # the one few-matches warning is its most specific kind: not a stereo pair
    assert len(res.matches) < 5 and len(hits) == 1
    assert hits[0].startswith("the pair does not look like a stereo pair")
    assert f"and {len(res.matches)} matches were found" in hits[0]


def test_few_matches_names_a_gain_mismatch():
    left = _noise()
    right = np.roll(left, -6, axis=1)
    res, hits = _few(lambda: hopmatch.hopfield_match(*_features(left, right), max_disparity=16))
    assert hits == [] and len(res.query_idx) > 100  # a good pair: silent
    pts_l, pts_r, d_l, d_r = _features(left, right)
    res, hits = _few(lambda: hopmatch.hopfield_match(pts_l, pts_r, d_l, d_r * 0.3,
                                                     max_disparity=16))
    assert len(res.query_idx) < 5 and len(hits) == 1
    assert "0.302 times the contrast" in hits[0] and "gain or exposure" in hits[0]


def test_few_matches_measures_the_gain_on_look_alikes():
    """Two views of one gain whose right one also sees much flat texture (many weak
    keypoints, as a wall seen by one camera only): the medians of all windows differ 4
    times, the look-alikes' windows do not, and the warning names the true cause."""
    from hopmatch.matching.diagnostics import contrast_ratio

    left = _noise()
    pts_l, pts_r, d_l, d_r = _features(left, np.roll(left, -6, axis=1))
    n = 4 * len(d_r)
    weak = np.tile(d_r, (4, 1))[:n] * 0.1  # low-contrast windows, on rows the left lacks
    far = np.c_[np.tile(pts_r[:, 0], 4)[:n], np.full(n, 5000.0, np.float32)]
    t_pts = np.concatenate((pts_r, far.astype(np.float32)))
    t_d = np.concatenate((d_r, weak.astype(d_r.dtype)))
    assert contrast_ratio(d_l, t_d) < 1 / 1.5  # the old measure: a gain mismatch
    res, hits = _few(lambda: hopmatch.hopfield_match(pts_l, t_pts, d_l, t_d,
                                                     max_disparity=16, input_bias=-1e300))
    assert len(hits) == 1 and "kept no neuron active" in hits[0], hits
    assert "gain" not in hits[0]


def test_few_matches_other_causes():
    left = _noise()
    pts_l, pts_r, d_l, d_r = _features(left, np.roll(left, -6, axis=1))
    for params, words in [({"neighbour_width": 0, "neighbour_height": 0}, "no candidate has a "
                           "neighbour"), ({"input_bias": -1e300}, "kept no neuron active"),
                          ({"min_disparity": 20, "max_disparity": 40}, "search window")]:
        res, hits = _few(lambda: hopmatch.hopfield_match(pts_l, pts_r, d_l, d_r, **params))
        assert len(hits) == 1 and words in hits[0], (params, hits)
    # too few keypoints to judge: silent
    res, hits = _few(lambda: hopmatch.hopfield_match(pts_l[:40], pts_r[:40], d_l[:40],
                                                     d_r[:40], min_disparity=20,
                                                     max_disparity=40))
    assert hits == []


def test_few_matches_with_a_matrix_that_is_not_the_pairs_f():
    """A fundamental_matrix whose epipolar lines miss the right image (the identity, a
    homography: not a fundamental matrix at all) is named as the cause, with how many lines
    miss; the pair's own F matches, and a matrix whose lines cross the image but along the
    wrong rows gets the network's cause with a word about the matrix (before 2026-12-06:
    "check that the pair is rectified" and "try the defaults")."""
    from hopmatch.matching.diagnostics import lines_missing_image

    left = _noise()
    right = np.roll(left, -6, axis=1)
    rows = np.array([[0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # x_r^T F x_l = y_l - y_r
    homography = np.array([[1, 0.01, 3], [0, 1, 2], [1e-5, 0, 1.0]])
    for matrix in (np.eye(3), homography):
        res, hits = _few(lambda m=matrix: hopmatch.match_stereo(left, right, max_disparity=16,
                                                                fundamental_matrix=m))
        assert len(res.query_idx) == 0
        assert len(hits) == 1 and "epipolar lines of" in hits[0] \
            and "miss the right image" in hits[0] and "`fundamental_matrix`" in hits[0], hits
    res, hits = _few(lambda: hopmatch.match_stereo(left, right, max_disparity=16,
                                                   fundamental_matrix=rows))
    assert len(res.query_idx) > 100 and hits == []
    # rows 60 px apart: the lines of the top 30 % miss the image, the others find no partner
    shifted = np.array([[0, 0, 0], [0, 0, -1.0], [0, 1.0, -60.0]])
    res, hits = _few(lambda: hopmatch.match_stereo(left, right, max_disparity=16,
                                                   fundamental_matrix=shifted))
    assert hits and "miss the right image" not in hits[0] \
        and "`fundamental_matrix` is this pair's" in hits[0], hits
    # a matrix match_stereo(rectified=False) estimated is not called the caller's
    from hopmatch.matching.diagnostics import few_matches_cause

    pl, pr, dl, dr = _features(left, right)
    res = hopmatch.hopfield_match(pl, pr, dl, dr, image_size=(260, 200), max_disparity=16,
                                  fundamental_matrix=np.eye(3))
    assert len(res.neuron_left) == 0
    for given, words, not_words in ((True, "miss the right image", "estimated"),
                                    (False, "estimated from the pair (result.geometry)",
                                     "`fundamental_matrix`")):
        cause = few_matches_cause(res, dl, dr, res.config, pl, pr, fundamental=np.eye(3),
                                  train_size=(260, 200), fundamental_given=given)
        assert words in cause and not_words not in cause, cause
    # the count itself: lines y = y_l (crossing a 100 x 50 image) for y_l < 50, else not
    pts = np.array([[10, 5], [10, 49], [10, 50], [10, 400]], np.float32)
    assert lines_missing_image(rows, pts, (100, 50)) == 2
    assert lines_missing_image(np.zeros((3, 3)), pts, (100, 50)) == 4  # a = b = 0


def _features(left, right):
    det = hopmatch.DericheMoravecDetector()
    pl, _, dl, _ = det.detect_and_describe(left)
    pr, _, dr, _ = det.detect_and_describe(right)
    return pl, pr, dl, dr


@pytest.mark.parametrize("rectified", [True, False])
def test_few_matches_are_counted_on_what_match_stereo_returns(motorcycle, monkeypatch,
                                                             rectified):
    """match_stereo judges "few matches" on the matches it returns, the guided pass's
    included, not on the network's share of them: with a floor between the two counts
    it does not warn (it did before 2026-12-04, when the network's check warned "only 28
    matches" on chessboard pairs that ended with 340), with a floor above both it warns
    once and gives both counts. The same for an unrectified pair (its aligned rows)."""
    import cv2

    from hopmatch.errors import FewMatchesWarning
    from hopmatch.matching import diagnostics

    left, right = (cv2.cvtColor(img, cv2.COLOR_RGB2GRAY) for img in motorcycle[:2])
    if not rectified:
        h, w = left.shape
        right = cv2.warpAffine(right, cv2.getRotationMatrix2D((w / 2, h / 2), 2, 1.0),
                               (w, h))
    one = {"rectified": rectified, "both_features": False}  # both: the first run's count
    res, caught = _caught(lambda: hopmatch.match_stereo(left, right, **one))
    assert not [w for w in caught if issubclass(w.category, FewMatchesWarning)]
    n_net, n_all = len(res.network.query_idx), len(res.query_idx)
    assert 0 < n_net < n_all
    between, above = (n_net + n_all) // 2, n_all + 1
    for floor, warned in ((between, False), (above, True)):
        monkeypatch.setattr(diagnostics, "FEW_MATCHES_FLOOR", floor)
        again, caught = _caught(lambda: hopmatch.match_stereo(left, right, **one))
        assert len(again.query_idx) == n_all
        few = [str(w.message) for w in caught if issubclass(w.category, FewMatchesWarning)]
        if warned:
            assert len(few) == 1 and few[0].startswith(
                f"only {n_all} matches ({n_net} from the network) for "), few
        else:
            assert few == []
