"""StereoHopfield, the cv2.StereoMatcher-like class (hopmatch/stereo_matcher.py; issue 19,
point 3): OpenCV's stereo_match flow with only the creation line changed, the fixed-point
convention of StereoBM/SGBM, the accessors, FileStorage and the errors."""

from __future__ import annotations

import pickle

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch import StereoHopfield
from hopmatch.errors import InvalidArgumentError, InvalidTypeError

DISPARITY = 6


@pytest.fixture(scope="module")
def pair():
    rng = np.random.default_rng(1)
    left = (rng.random((120, 160)) * 255).astype(np.uint8)
    return left, np.roll(left, -DISPARITY, axis=1)


# --------------------------------------------------------------------------------------
# OpenCV's samples/python/stereo_match.py flow, only the creation line changed
# --------------------------------------------------------------------------------------


def _ply_vertices(path) -> np.ndarray:
    lines = path.read_text().splitlines()
    end = lines.index("end_header")
    count = int(next(ln.split()[2] for ln in lines[:end] if ln.startswith("element vertex")))
    rows = np.array([ln.split() for ln in lines[end + 1:]], np.float64).reshape(-1, 6)
    assert len(rows) == count
    return rows


def test_opencv_stereo_match_flow_writes_the_matched_points(shared_data, tmp_path):
    """The steps of OpenCV's stereo_match.py on the aloe pair it uses (halved with pyrDown,
    disparities 16..111, compute / 16, a guessed Q, reprojectImageTo3D, the pixels
    ``disp > disp.min()`` into a PLY): the PLY holds one vertex per match, at the 3-D point
    of the match's disparity."""
    cv2.samples.addSamplesDataSearchPath(str(shared_data / "aloe"))
    imgL = cv2.pyrDown(cv2.imread(cv2.samples.findFile("aloeL.jpg")))
    imgR = cv2.pyrDown(cv2.imread(cv2.samples.findFile("aloeR.jpg")))
    min_disp = 16
    num_disp = 112 - min_disp
    stereo = hopmatch.StereoHopfield.create(minDisparity=min_disp, numDisparities=num_disp,
                                            blockSize=9)  # the one changed line
    disp = stereo.compute(imgL, imgR).astype(np.float32) / 16.0
    h, w = imgL.shape[:2]
    f = 0.8 * w
    Q = np.float32([[1, 0, 0, -0.5 * w], [0, -1, 0, 0.5 * h], [0, 0, 0, -f], [0, 0, 1, 0]])
    points = cv2.reprojectImageTo3D(disp, Q)
    colors = cv2.cvtColor(imgL, cv2.COLOR_BGR2RGB)
    mask = disp > disp.min()
    out_points, out_colors = points[mask], colors[mask]
    path = tmp_path / "out.ply"
    with open(path, "w") as fh:
        fh.write(f"ply\nformat ascii 1.0\nelement vertex {len(out_points)}\n"
                 "property float x\nproperty float y\nproperty float z\n"
                 "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n")
        for (x, y, z), (r, g, b) in zip(out_points.tolist(), out_colors.tolist()):
            fh.write(f"{x:f} {y:f} {z:f} {r:d} {g:d} {b:d}\n")

    result = stereo.getLastResult()
    pixels = {(int(round(x)), int(round(y))) for x, y in result.matched_left.tolist()}
    vertices = _ply_vertices(path)
    assert len(vertices) == int(mask.sum()) == len(pixels) > 2000
    assert np.isfinite(vertices).all()
    # every vertex is the reprojection of a matched pixel's disparity (to 1/16 px)
    rows, cols = np.nonzero(mask)
    assert {(int(c), int(r)) for r, c in zip(rows, cols)} == pixels
    d = disp[rows, cols]
    assert d.min() >= min_disp and d.max() <= min_disp + num_disp - 1
    expected = cv2.reprojectImageTo3D(disp, Q)[rows, cols]
    np.testing.assert_allclose(vertices[:, :3], expected, rtol=1e-5, atol=1e-5)
    # the unmatched pixels hold (minDisparity - 1), so `disp > disp.min()` is the matches
    assert disp.min() == min_disp - 1


# --------------------------------------------------------------------------------------
# compute: OpenCV's fixed-point convention, float32 on request
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("min_disp", [0, 2, -5])
def test_compute_is_cv16s_times_16_with_unmatched_at_min_minus_one(pair, min_disp):
    left, right = pair
    stereo = StereoHopfield.create(minDisparity=min_disp, numDisparities=16)
    disp = stereo.compute(left, right)
    assert disp.dtype == np.int16 and disp.shape == left.shape
    unmatched = (min_disp - 1) * 16
    res = stereo.getLastResult()
    cols = np.rint(res.matched_left[:, 0]).astype(int)
    rows = np.rint(res.matched_left[:, 1]).astype(int)
    assert len(res.matches) > 50
    assert (disp != unmatched).sum() == len({*zip(rows.tolist(), cols.tolist())})
    assert (disp[rows, cols] == np.rint(res.disparities * 16)).all()
    keep = np.ones(disp.shape, bool)
    keep[rows, cols] = False
    assert (disp[keep] == unmatched).all()
    assert np.median(disp[rows, cols]) == DISPARITY * 16


def test_compute_float32_on_request(pair):
    left, right = pair
    stereo = StereoHopfield.create(0, 16, 9)
    fixed = stereo.compute(left, right)
    for request in ({"dtype": np.float32}, {"dtype": cv2.CV_32F},
                    {"disparity": np.empty(left.shape, np.float32)}):
        disp = stereo.compute(left, right, **request)
        assert disp.dtype == np.float32
        np.testing.assert_allclose(disp, fixed / 16.0, atol=1 / 32)
        assert disp.min() == -1.0
    out = np.zeros(left.shape, np.int16)
    assert stereo.compute(left, right, out) is out and (out == fixed).all()
    assert stereo.compute(left, right, dtype=cv2.CV_16S).dtype == np.int16


def test_compute_equals_match_stereo_with_the_mapped_parameters(pair):
    left, right = pair
    stereo = StereoHopfield.create(minDisparity=2, numDisparities=10, blockSize=7,
                                   max_vertical=2.0)
    stereo.compute(left, right)
    mine = stereo.getLastResult()
    ref = hopmatch.match_stereo(left, right, min_disparity=2.0, max_disparity=11.0,
                                descriptor_size=7, max_vertical=2.0)
    assert (mine.query_idx == ref.query_idx).all() and (mine.train_idx == ref.train_idx).all()
    assert mine.network.config.max_disparity == 11.0


def test_zero_disparities_means_hopmatchs_own_range(pair):
    left, right = pair
    stereo = StereoHopfield.create()
    assert stereo.getNumDisparities() == 0 and stereo.pipeline_parameters()["max_disparity"] is None
    disp = stereo.compute(left, right)
    assert disp.min() == -16 and np.median(disp[disp >= 0]) == DISPARITY * 16


@pytest.mark.parametrize("kwargs, error, words", [
    ({"dtype": np.uint8}, InvalidArgumentError, "dtype"),
    ({"dtype": "fast"}, InvalidArgumentError, "dtype"),
    ({"disparity": np.zeros((120, 160), np.uint8)}, InvalidArgumentError, "int16"),
    ({"disparity": [[0]]}, InvalidTypeError, "NumPy array"),
    ({"disparity": np.zeros((120, 160), np.int16), "dtype": np.float32},
     InvalidArgumentError, "give one of them"),
    # before 2026-12-06 these two failed only when filled, with NumPy's bare ValueError
    ({"disparity": np.zeros((5, 5), np.int16)}, InvalidArgumentError,
     r"`disparity` must have the left image's shape \(120, 160\) \(H, W\), got \(5, 5\)"),
    ({"disparity": np.frombuffer(bytes(120 * 160 * 4), np.float32).reshape(120, 160)},
     InvalidArgumentError, "`disparity` must be writeable.*read-only"),
])
def test_compute_output_errors(pair, kwargs, error, words):
    with pytest.raises(error, match=words):
        StereoHopfield.create(0, 16).compute(*pair, **kwargs)


# --------------------------------------------------------------------------------------
# create, accessors, FileStorage
# --------------------------------------------------------------------------------------


def test_create_as_cv2_stereosgbm_create():
    s = StereoHopfield.create(16, 96, 7)
    assert (s.getMinDisparity(), s.getNumDisparities(), s.getBlockSize()) == (16, 96, 7)
    k = StereoHopfield.create(minDisparity=16, numDisparities=96, blockSize=7)
    assert k.get_params() == s.get_params()
    assert s.pipeline_parameters()["min_disparity"] == 16.0
    assert s.pipeline_parameters()["max_disparity"] == 111.0
    assert s.pipeline_parameters()["descriptor_size"] == 7
    assert not s.empty() and s.getDefaultName() == "hopmatch_StereoHopfield"


def test_setters_validate_and_map_to_the_pipeline():
    s = StereoHopfield.create()
    s.setMinDisparity(4)
    s.setNumDisparities(32)
    s.setBlockSize(11)
    s.setMaxVertical(2.0)
    p = s.pipeline_parameters()
    assert (p["min_disparity"], p["max_disparity"], p["descriptor_size"], p["max_vertical"]) \
        == (4.0, 35.0, 11, 2.0)
    with pytest.raises(InvalidArgumentError, match="`blockSize` must be odd"):
        s.setBlockSize(16)  # as cv2.StereoBM, the block must be odd
    assert s.getBlockSize() == 11
    with pytest.raises(InvalidArgumentError, match="numDisparities"):
        s.setNumDisparities(4000)  # (min + num - 1) * 16 would overflow CV_16S
    assert s.getNumDisparities() == 32


def test_sgbm_only_parameters_are_refused_with_the_valid_list():
    with pytest.raises(InvalidArgumentError, match=r"unknown parameter\(s\) \['P1'\].*blockSize"):
        StereoHopfield.create(0, 64, 9, P1=8 * 3 * 9)
    with pytest.raises(InvalidArgumentError, match="min_disparity"):
        StereoHopfield.create(min_disparity=3)  # the cv2 name replaces it


def test_paper_preset_maps_the_range():
    s = StereoHopfield.create(preset="paper")
    assert (s.getMinDisparity(), s.getNumDisparities()) == (-10, 41)
    assert s.getWindowSize() == 5 and s.getMaxVertical() == 15.0
    assert s.pipeline_parameters()["max_disparity"] == 30.0


def test_write_read_save_load_and_pickle(tmp_path):
    s = StereoHopfield.create(16, 96, 7, seed=3)
    s.write(str(tmp_path / "a.yml"))
    t = StereoHopfield.create()
    t.read(str(tmp_path / "a.yml"))
    assert t.get_params() == s.get_params()
    s.save(str(tmp_path / "b.xml"))
    u = StereoHopfield.create()
    u.load(str(tmp_path / "b.xml"))
    assert u.get_params() == s.get_params()
    fs = cv2.FileStorage(str(tmp_path / "a.yml"), cv2.FILE_STORAGE_READ)
    assert fs.getNode("hopmatch_StereoHopfield").getNode("numDisparities").real() == 96
    fs.release()
    assert pickle.loads(pickle.dumps(s)).get_params() == s.get_params()
