"""DericheMoravecDetector: the cv2 Feature2D-like contract."""

from __future__ import annotations

import pickle

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch import DericheMoravecDetector
from hopmatch.errors import InvalidArgumentError, InvalidTypeError


@pytest.fixture(scope="module")
def textured():
    rng = np.random.default_rng(3)
    img = cv2.GaussianBlur((rng.random((120, 160)) * 255).astype(np.uint8), (0, 0), 1.5)
    return cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX)


def test_create_and_accessors_round_trip():
    det = DericheMoravecDetector.create(window_size=7, nms_size=9, on="intensity")
    assert det.getWindowSize() == 7 and det.getNmsSize() == 9 and det.getOn() == "intensity"
    det.setThreshold(12.5)
    assert det.getThreshold() == 12.5
    det.setSubpixel(False)
    assert det.getSubpixel() is False


@pytest.mark.parametrize(
    "kwargs, exc, words",
    [
        ({"window_size": 4}, InvalidArgumentError, "window_size"),
        ({"window_size": "5"}, InvalidTypeError, "window_size"),
        ({"nms_size": 0}, InvalidArgumentError, "nms_size"),
        ({"threshold": -1.0}, InvalidArgumentError, "threshold"),
        ({"window_sigma": -0.5}, InvalidArgumentError, "window_sigma"),
        ({"window_sigma": "gauss"}, InvalidTypeError, "window_sigma"),
        ({"threshold": float("nan")}, InvalidArgumentError, "threshold"),
        ({"alpha": 0.0}, InvalidArgumentError, "alpha"),
        ({"on": "edges"}, InvalidArgumentError, "'gradient', 'intensity'"),
        ({"subpixel": "yes"}, InvalidTypeError, "subpixel"),
        ({"windowsize": 5}, InvalidArgumentError, "windowsize"),
        ({"preset": "fast"}, InvalidArgumentError, "preset"),
        ({"max_features": True}, InvalidTypeError, "max_features"),
    ],
)
def test_invalid_parameters_are_named(kwargs, exc, words):
    with pytest.raises(exc, match=words):
        DericheMoravecDetector(**kwargs)


def test_failed_setter_keeps_old_value():
    det = DericheMoravecDetector(window_size=7)
    with pytest.raises(InvalidArgumentError):
        det.setWindowSize(6)
    assert det.getWindowSize() == 7


def test_detect_returns_real_keypoints(textured):
    det = DericheMoravecDetector()
    kps = det.detect(textured)
    assert isinstance(kps, tuple) and len(kps) > 20
    assert all(isinstance(k, cv2.KeyPoint) for k in kps)
    k = kps[0]
    assert k.size == det.getWindowSize() and k.angle == -1 and k.octave == 0 and k.class_id == -1
    responses = [kp.response for kp in kps]
    assert responses == sorted(responses, reverse=True)
    pts = cv2.KeyPoint_convert(kps)
    assert pts.dtype == np.float32
    margin = det.getWindowSize() // 2 + 1
    assert (pts >= margin - 0.5).all() and (pts[:, 0] <= 160 - 1 - margin + 0.5).all()


def test_detect_matches_the_pure_functions(textured):
    """The detector is the pure functions in a row: its grey levels normalised first
    (issue 20: normalised_intensity, so that gain and dtype do not matter), then G, V and
    the points."""
    from hopmatch._validate import as_gray_image
    from hopmatch.feature.gradient import normalised_intensity

    det = DericheMoravecDetector(subpixel=False)
    g = hopmatch.deriche_gradient(normalised_intensity(as_gray_image(textured)), det.getAlpha(),
                                  det.getOmega())
    v = hopmatch.moravec_response(g, det.getWindowSize())
    pts, resp = hopmatch.moravec_points(v, det.getNmsSize(), margin=det.getWindowSize() // 2 + 1)
    kps = det.detect(textured)
    np.testing.assert_array_equal(cv2.KeyPoint_convert(kps), pts)
    np.testing.assert_array_equal([k.response for k in kps], resp)


@pytest.mark.parametrize("alpha", [0.5, 1.0, 2.0])
def test_gradient_border_is_no_edge_and_equals_a_wide_border(textured, alpha):
    """The mirrored border (``border_width``) leaves the recursive filter's start-up below
    0.01 of G: a flat white image stays flat up to its edges (with no border the filter puts
    edges of about 150 there), and a textured image's gradient equals the one computed with
    an 80-px border to within 0.01."""
    flat = np.full((40, 50), 255, np.uint8)
    g_flat = hopmatch.deriche_gradient(flat, alpha)
    assert g_flat.max() < 0.01
    assert hopmatch.moravec_response(g_flat, 3).max() < 1e-6  # threshold: 1e-3
    assert DericheMoravecDetector(alpha=alpha).detect(flat) == ()
    bare = cv2.magnitude(cv2.ximgproc.GradientDericheX(flat, alpha, 0.001),
                         cv2.ximgproc.GradientDericheY(flat, alpha, 0.001))
    assert bare.max() > 50  # the test is not vacuous: without the border, strong edges

    def wide(img, b=80):
        p = cv2.copyMakeBorder(img, b, b, b, b, cv2.BORDER_REFLECT)
        return cv2.magnitude(cv2.ximgproc.GradientDericheX(p, alpha, 0.001),
                             cv2.ximgproc.GradientDericheY(p, alpha, 0.001))[b:-b, b:-b]

    g = hopmatch.deriche_gradient(textured, alpha)
    assert g.max() > 10
    np.testing.assert_allclose(g, wide(textured), rtol=0, atol=0.01)


def test_gaussian_window_matches_the_pure_functions(textured):
    from hopmatch._validate import as_gray_image
    from hopmatch.feature.gradient import normalised_intensity

    det = DericheMoravecDetector(window_sigma=0.85)
    assert det.getWindowSigma() == 0.85 and DericheMoravecDetector().getWindowSigma() == 0.0
    g = hopmatch.deriche_gradient(normalised_intensity(as_gray_image(textured)), det.getAlpha(),
                                  det.getOmega())
    v = hopmatch.moravec_response(g, det.getWindowSize(), window_sigma=0.85)
    pts, resp = hopmatch.moravec_points(v, det.getNmsSize(), threshold=det.getThreshold(),
                                        margin=det.getWindowSize() // 2 + 1, subpixel=True)
    kps = det.detect(textured)
    np.testing.assert_array_equal(cv2.KeyPoint_convert(kps), pts)
    np.testing.assert_array_equal([k.response for k in kps], resp)
    box = cv2.KeyPoint_convert(DericheMoravecDetector().detect(textured))
    assert len(box) != len(pts) or not np.array_equal(box, pts)


def test_colour_and_dtypes_convert_as_cv2(textured):
    det = DericheMoravecDetector(subpixel=False)
    grey = det.detect(textured)
    bgr = det.detect(cv2.cvtColor(textured, cv2.COLOR_GRAY2BGR))
    bgra = det.detect(cv2.cvtColor(textured, cv2.COLOR_GRAY2BGRA))
    as_float = det.detect(textured.astype(np.float32))
    expected = cv2.KeyPoint_convert(grey)
    for other in (bgr, bgra, as_float):
        np.testing.assert_array_equal(cv2.KeyPoint_convert(other), expected)
    assert len(det.detect(textured.astype(np.uint16) * 257)) > 0


def test_mask_restricts_points(textured):
    det = DericheMoravecDetector()
    mask = np.zeros(textured.shape, np.uint8)
    mask[:, :80] = 1
    pts = cv2.KeyPoint_convert(det.detect(textured, mask))
    assert len(pts) > 0 and (pts[:, 0] < 80.5).all()
    assert det.detect(textured, np.zeros(textured.shape, bool)) == ()


def test_list_of_images(textured):
    det = DericheMoravecDetector()
    out = det.detect([textured, textured[:, ::-1].copy()])
    assert isinstance(out, list) and len(out) == 2 and len(out[0]) > 0


def test_compute_drops_keypoints_whose_window_leaves_the_image(textured):
    det = DericheMoravecDetector(descriptor_size=9)
    kps = [cv2.KeyPoint(2.0, 50.0, 5), cv2.KeyPoint(80.0, 60.0, 5), cv2.KeyPoint(157.5, 10, 5)]
    kept, desc = det.compute(textured, kps)
    assert len(kept) == 1 and kept[0].pt == (80.0, 60.0)
    assert desc.shape == (1, 81) and desc.dtype == np.float32
    assert abs(float(desc.mean())) < 1e-3


def test_detect_and_compute_agrees_with_detect_then_compute(textured):
    det = DericheMoravecDetector()
    kps, desc = det.detectAndCompute(textured, None)
    kps2, desc2 = det.compute(textured, det.detect(textured))
    assert cv2.KeyPoint_convert(kps).tolist() == cv2.KeyPoint_convert(kps2).tolist()
    np.testing.assert_array_equal(desc, desc2)
    assert desc.shape == (len(kps), det.descriptorSize())
    kps3, desc3 = det.detectAndCompute(textured, None, useProvidedKeypoints=True, keypoints=kps)
    np.testing.assert_array_equal(desc3, desc)


def test_zero_keypoints_keep_shape():
    det = DericheMoravecDetector()
    blank = np.zeros((40, 50), np.uint8)
    kps, desc = det.detectAndCompute(blank, None)
    d = det.descriptorSize()
    assert kps == () and desc.shape == (0, d) and desc.dtype == np.float32
    assert det.compute(blank, [])[1].shape == (0, d)
    assert det.detect(np.zeros((1, 1), np.uint8)) == ()


def test_works_with_cv2_functions(textured):
    det = DericheMoravecDetector()
    kps = det.detect(textured)
    drawn = cv2.drawKeypoints(textured, kps, None)
    assert drawn.shape == textured.shape + (3,)
    sift_kps, sift_desc = cv2.SIFT_create().compute(textured, list(kps))
    assert sift_desc.shape[1] == 128 and len(sift_kps) > 0
    orb = cv2.ORB_create()
    orb_kps = orb.detect(textured, None)
    kept, desc = det.compute(textured, orb_kps)
    assert len(kept) == len(desc)


def test_feature2d_metadata():
    det = DericheMoravecDetector(descriptor_size=5)
    assert det.descriptorSize() == 25
    assert det.descriptorType() == cv2.CV_32F
    assert det.defaultNorm() == cv2.NORM_L1
    assert det.empty() is False
    assert "." not in det.getDefaultName()
    assert "descriptor_size=5" in repr(det)


@pytest.mark.parametrize("suffix", [".yml", ".xml", ".json"])
def test_filestorage_round_trip(tmp_path, suffix):
    det = DericheMoravecDetector(window_size=3, nms_size=11, threshold=4.5, on="intensity",
                                 subpixel=False, max_features=100)
    path = tmp_path / f"det{suffix}"
    det.write(path)
    other = DericheMoravecDetector()
    other.read(path)
    assert other.get_params() == det.get_params()
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_filestorage_into_open_storage(tmp_path):
    det = DericheMoravecDetector(alpha=2.5)
    path = str(tmp_path / "both.yml")
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    det.write(fs)
    fs.release()
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    other = DericheMoravecDetector()
    other.read(fs.getNode(det.getDefaultName()))
    assert other.getAlpha() == 2.5


def test_read_errors(tmp_path):
    det = DericheMoravecDetector()
    with pytest.raises(InvalidArgumentError, match="no such file"):
        det.read(tmp_path / "missing.yml")
    with pytest.raises(InvalidArgumentError, match=".yml"):
        det.write(tmp_path / "params.txt")
    bad = tmp_path / "bad.yml"
    bad.write_text("%YAML:1.0\n---\nhopmatch_DericheMoravecDetector:\n   window_size: 4\n")
    with pytest.raises(InvalidArgumentError, match="window_size"):
        det.read(bad)


def test_pickle_round_trip():
    det = DericheMoravecDetector(nms_size=13, on="intensity")
    other = pickle.loads(pickle.dumps(det))
    assert other.get_params() == det.get_params()


def test_paper_preset():
    det = DericheMoravecDetector(preset="paper")
    assert det.getNmsSize() == 20 and det.getSubpixel() is False
    det.setPreset("default")
    default = DericheMoravecDetector()
    assert det.getNmsSize() == default.getNmsSize() and det.getSubpixel() is True
    assert DericheMoravecDetector(preset="paper", nms_size=7).getNmsSize() == 7


@pytest.mark.parametrize(
    "image, exc, words",
    [
        ([[1, 2], [3, 4]], InvalidTypeError, "numpy array"),
        (np.zeros((10, 10), np.int64), InvalidTypeError, "dtype"),
        (np.zeros((10, 10), bool), InvalidTypeError, "dtype"),
        (np.zeros((10, 10, 2), np.uint8), InvalidArgumentError, "shape"),
        (np.zeros((0, 10), np.uint8), InvalidArgumentError, "empty"),
        (np.full((10, 10), np.nan, np.float32), InvalidArgumentError, "NaN"),
        (np.zeros((2, 10, 10), np.uint8), InvalidArgumentError, "shape"),
    ],
)
def test_bad_images(image, exc, words):
    with pytest.raises(exc, match=words):
        DericheMoravecDetector().detect(image)


def test_bad_masks(textured):
    det = DericheMoravecDetector()
    with pytest.raises(InvalidArgumentError, match="shape"):
        det.detect(textured, np.ones((10, 10), np.uint8))
    with pytest.raises(InvalidTypeError, match="dtype"):
        det.detect(textured, np.ones(textured.shape, np.float32))


def test_bad_keypoints(textured):
    det = DericheMoravecDetector()
    with pytest.raises(InvalidTypeError, match="keypoints"):
        det.compute(textured, [(1, 2)])
    with pytest.raises(InvalidTypeError, match="keypoints"):
        det.compute(textured, None)
