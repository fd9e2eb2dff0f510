"""hopmatch_gapi: G-API operations whose results equal the direct calls, bit for bit.

Skipped, with the plugin's own ImportError message, on an OpenCV without Python G-API
custom operations (the OpenCV 5 wheels).
"""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import cv2 as cv
import numpy as np
import pytest

import hopmatch
from hopmatch import datasets
from hopmatch.errors import InvalidArgumentError, InvalidTypeError

try:
    import hopmatch_gapi
except ImportError as exc:  # only the "no G-API custom ops" error skips; others fail
    if "G-API" not in str(exc):
        raise
    pytest.skip(str(exc), allow_module_level=True)

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "gapi_streaming.py"


def textured_pair(shift=6, shape=(120, 160), seed=1, bgr=False):
    rng = np.random.default_rng(seed)
    left = cv.GaussianBlur((rng.random(shape) * 255).astype(np.uint8), (3, 3), 0)
    right = np.roll(left, -shift, axis=1)
    if bgr:
        left, right = cv.cvtColor(left, cv.COLOR_GRAY2BGR), cv.cvtColor(right, cv.COLOR_GRAY2BGR)
    return left, right


def assert_same_as_match_stereo(out, left, right, **params):
    ref = hopmatch.match_stereo(left, right, **params)
    ml, mr, d = out
    assert ml.dtype == mr.dtype == d.dtype == np.float32
    assert ml.shape == ref.matched_left.shape and d.shape == ref.disparities.shape
    for got, want in zip((ml, mr, d), (ref.matched_left, ref.matched_right, ref.disparities)):
        assert cv.norm(got, want, cv.NORM_INF) == 0
        np.testing.assert_array_equal(got, want)


class TestMatchPair:
    def test_identical_to_match_stereo(self):
        left, right = textured_pair()
        out = hopmatch_gapi.match_pair(left, right, max_disparity=12)
        assert len(out[2]) > 20
        assert_same_as_match_stereo(out, left, right, max_disparity=12)

    def test_bgr_and_default_parameters(self):
        left, right = textured_pair(shift=4, shape=(96, 128), seed=3, bgr=True)
        assert_same_as_match_stereo(hopmatch_gapi.match_pair(left, right), left, right)

    def test_preset_and_detector_parameters_reach_the_kernels(self):
        left, right = textured_pair(seed=5)
        params = dict(preset="paper", max_disparity=10)
        assert_same_as_match_stereo(hopmatch_gapi.match_pair(left, right, **params),
                                    left, right, **params)

    def test_compiles_once_per_parameter_set(self):
        left, right = textured_pair(seed=7)
        hopmatch_gapi.match_pair(left, right, max_disparity=11)
        n = len(hopmatch_gapi.graph._CACHE)
        hopmatch_gapi.match_pair(right, left, max_disparity=11)
        assert len(hopmatch_gapi.graph._CACHE) == n

    def test_empty_result_keeps_shape_and_dtype(self):
        blank = np.zeros((64, 80), np.uint8)
        ml, mr, d = hopmatch_gapi.match_pair(blank, blank)
        assert ml.shape == (0, 2) and mr.shape == (0, 2) and d.shape == (0,)
        assert ml.dtype == mr.dtype == d.dtype == np.float32

    def test_shared_middlebury_scene(self, shared_data):
        scene = datasets.load("middlebury/tsukuba")
        out = hopmatch_gapi.match_pair(scene.left, scene.right)
        assert len(out[2]) > 100
        assert_same_as_match_stereo(out, scene.left, scene.right)

    def test_bad_parameters_raise_before_the_graph(self):
        left, right = textured_pair()
        with pytest.raises(InvalidArgumentError, match="unknown parameter.*max_disparty"):
            hopmatch_gapi.match_pair(left, right, max_disparty=3)
        with pytest.raises(InvalidArgumentError, match="window_size"):
            hopmatch_gapi.kernels(window_size=4)

    def test_errors_found_while_matching_are_hopmatchs_not_cv2s(self):
        """Raised inside the graph's kernel, hopmatch's errors came out as ``cv2.error:
        Python kernel failed with error!`` (before 2026-12-06); match_pair raises them as
        match_stereo does, and the same compiled graph then matches the next pair. (A range
        below ``min_disparity`` is now refused before the graph, as kernels() refuses it:
        test_plugin_gapi_input.py.)"""
        left, right = textured_pair()
        with pytest.raises(InvalidArgumentError, match="`left` and `right` must have the "
                                                       "same height.*got 120 and 100"):
            hopmatch_gapi.match_pair(left, right[:100], max_disparity=12)
        with pytest.raises(InvalidArgumentError, match=r"`max_disparity` \(-5.0\) must not "
                                                       r"be below `min_disparity` \(0.0\)"):
            hopmatch_gapi.match_pair(left, right, max_disparity=-5)
        assert_same_as_match_stereo(hopmatch_gapi.match_pair(left, right, max_disparity=12),
                                    left, right, max_disparity=12)

    def test_images_are_checked_before_the_graph(self):
        """What G-API cannot take gave ``cv2.error`` ("Image format is invalid", "Failed
        to obtain cv::Mat"); now hopmatch's own errors, naming the image."""
        left, _ = textured_pair()
        with pytest.raises(InvalidArgumentError, match="`right` must not be empty"):
            hopmatch_gapi.match_pair(left, np.zeros((0, 5), np.uint8))
        with pytest.raises(InvalidTypeError, match="`left` must be a numpy array"):
            hopmatch_gapi.match_pair([[1, 2]], left)


class TestOperations:
    def test_detect_node_equals_detect_points(self):
        left, _ = textured_pair()
        g = cv.GMat()
        pts, resp = hopmatch_gapi.GDetect.on(g)
        comp = cv.GComputation(cv.GIn(g), cv.GOut(pts, resp))
        got_pts, got_resp = comp.apply(cv.gin(left),
                                       args=cv.gapi.compile_args(hopmatch_gapi.kernels()))
        ref_pts, ref_resp, _ = hopmatch.DericheMoravecDetector().detect_points(left)
        got_pts = np.asarray(got_pts, np.float32).reshape(-1, 2)
        assert len(got_pts) > 20
        assert cv.norm(got_pts, ref_pts, cv.NORM_INF) == 0
        np.testing.assert_array_equal(np.asarray(got_resp, np.float32), ref_resp)

    def test_detect_then_match_points_equals_match_stereo(self):
        left, right = textured_pair(seed=11)
        gl, gr = cv.GMat(), cv.GMat()
        pl, _ = hopmatch_gapi.GDetect.on(gl)
        pr, _ = hopmatch_gapi.GDetect.on(gr)
        ml, mr, d = hopmatch_gapi.GMatchPoints.on(gl, pl, gr, pr)
        comp = cv.GComputation(cv.GIn(gl, gr), cv.GOut(ml, mr, d))
        out = comp.apply(cv.gin(left, right), args=cv.gapi.compile_args(
            hopmatch_gapi.kernels(max_disparity=12)))
        # the points of one detection: match_stereo's single run on them
        assert_same_as_match_stereo(hopmatch_gapi.as_arrays(*out), left, right,
                                    max_disparity=12, both_features=False)

    def test_match_points_takes_points_from_opencv_nodes(self):
        left, right = textured_pair(seed=13)
        gl, gr = cv.GMat(), cv.GMat()
        pl = cv.gapi.goodFeaturesToTrack(gl, 300, 0.01, 5.0)
        pr = cv.gapi.goodFeaturesToTrack(gr, 300, 0.01, 5.0)
        ml, mr, d = hopmatch_gapi.GMatchPoints.on(gl, pl, gr, pr)
        comp = cv.GComputation(cv.GIn(gl, gr), cv.GOut(ml, mr, d))
        ml, mr, d = hopmatch_gapi.as_arrays(*comp.apply(
            cv.gin(left, right), args=cv.gapi.compile_args(hopmatch_gapi.kernels(
                max_disparity=12))))
        assert len(d) > 20
        assert np.median(d) == pytest.approx(6.0, abs=0.5)
        np.testing.assert_array_equal(d, ml[:, 0] - mr[:, 0])

    def test_ready_graph(self):
        left, right = textured_pair(seed=17)
        comp = hopmatch_gapi.stereo_graph()
        assert isinstance(comp, cv.GComputation)
        out = comp.apply(cv.gin(left, right),
                         args=cv.gapi.compile_args(hopmatch_gapi.kernels(max_disparity=12)))
        assert_same_as_match_stereo(hopmatch_gapi.as_arrays(*out), left, right,
                                    max_disparity=12)

    def test_kernel_package(self):
        assert isinstance(hopmatch_gapi.kernels(), cv.GKernelPackage)
        assert hopmatch_gapi.kernels().size() == 3


def test_import_error_without_gapi_custom_ops(monkeypatch):
    """As on the OpenCV 5 wheels: the import fails, saying why and what to install."""
    monkeypatch.delattr(cv.gapi, "op")
    saved = {k: v for k, v in sys.modules.items() if k.split(".")[0] == "hopmatch_gapi"}
    for k in saved:
        del sys.modules[k]
    try:
        with pytest.raises(ImportError, match=r"G-API custom operations.*<5") as info:
            importlib.import_module("hopmatch_gapi")
        assert "cv2.gapi.op" in str(info.value) and cv.__version__ in str(info.value)
    finally:
        for k in [k for k in sys.modules if k.split(".")[0] == "hopmatch_gapi"]:
            del sys.modules[k]
        sys.modules.update(saved)


@pytest.mark.parametrize("mode", ["streaming", "apply"])
def test_streaming_example_runs(mode, tmp_path):
    proc = subprocess.run(
        [sys.executable, str(EXAMPLE), "--frames", "3", "--size", "192x144", "--mode", mode,
         "--verify"],
        capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.count("identical to match_stereo") == 3
    assert "frames per second" in proc.stdout
