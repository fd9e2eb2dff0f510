"""hopmatch_gapi on bad input (fuzzing findings 21-27): bounded graph cache, whatever the
kernel raises forwarded to match_pair's caller, checked as_arrays, match_stereo keywords
the plugin does not take, kernels() checked at once, checked ``Op.on``.

Skipped, as test_plugin_gapi.py is, on an OpenCV without Python G-API custom operations.
"""

from __future__ import annotations

import warnings
from collections import OrderedDict

import cv2 as cv
import numpy as np
import pytest

import hopmatch
from hopmatch.errors import FewMatchesWarning, InvalidArgumentError, InvalidTypeError

try:
    import hopmatch_gapi
except ImportError as exc:  # only the "no G-API custom ops" error skips; others fail
    if "G-API" not in str(exc):
        raise
    pytest.skip(str(exc), allow_module_level=True)

from hopmatch_gapi import graph as gapi_graph  # noqa: E402


def small_pair(seed=0, shape=(64, 64), shift=3):
    rng = np.random.default_rng(seed)
    left = cv.GaussianBlur((rng.random(shape) * 255).astype(np.uint8), (3, 3), 0)
    return left, np.roll(left, -shift, axis=1)


def assert_same_as_match_stereo(out, left, right, **params):
    ref = hopmatch.match_stereo(left, right, **params)
    for got, want in zip(out, (ref.matched_left, ref.matched_right, ref.disparities)):
        assert got.dtype == np.float32
        np.testing.assert_array_equal(got, want)


# -- 21: the cache of compiled graphs -----------------------------------------------------


class TestCache:
    def test_documented_small_size(self):
        assert 1 <= gapi_graph.CACHE_SIZE <= 16
        assert "CACHE_SIZE" in gapi_graph.match_pair.__doc__

    def test_bounded_least_recently_used_and_results_unchanged(self, monkeypatch):
        """300 parameter sets kept 300 compiled graphs (+90 MiB); now the last few."""
        monkeypatch.setattr(gapi_graph, "CACHE_SIZE", 3)
        monkeypatch.setattr(gapi_graph, "_CACHE", OrderedDict())
        left, right = small_pair()
        for i in range(6):
            out = hopmatch_gapi.match_pair(left, right, max_disparity=8 + i * 0.5)
            assert len(gapi_graph._CACHE) == min(i + 1, 3)
            assert_same_as_match_stereo(out, left, right, max_disparity=8 + i * 0.5)
        keys = list(gapi_graph._CACHE)  # 9.5, 10.0, 10.5: the oldest dropped first
        hopmatch_gapi.match_pair(left, right, max_disparity=9.5)  # used: kept
        hopmatch_gapi.match_pair(left, right, max_disparity=12)
        assert list(gapi_graph._CACHE) == [keys[2], keys[0], gapi_graph._key(
            {"max_disparity": 12})]
        again = hopmatch_gapi.match_pair(left, right, max_disparity=8)  # dropped: recompiled
        assert_same_as_match_stereo(again, left, right, max_disparity=8)
        assert len(gapi_graph._CACHE) == 3


# -- 22, 23: what the kernel raises reaches match_pair's caller ------------------------------


class TestForwardedFromTheKernel:
    @pytest.mark.parametrize("exc", [KeyboardInterrupt(), RuntimeError("boom"),
                                     MemoryError(), SystemExit(3)],
                             ids=lambda e: type(e).__name__)
    def test_any_exception_is_raised_as_itself(self, monkeypatch, exc):
        """Ctrl-C during match_pair gave ``cv2.error: Python kernel failed with error!``;
        the kernel now keeps whatever it raises and match_pair raises that object."""
        left, right = small_pair(seed=1)

        def interrupted(*args, **kwargs):
            raise exc

        with monkeypatch.context() as m:
            m.setattr(hopmatch, "match_stereo", interrupted)  # what the kernel calls
            with pytest.raises(type(exc)) as info:
                hopmatch_gapi.match_pair(left, right, max_disparity=9)
        assert info.value is exc
        # the same compiled graph then matches the next pair as before
        assert_same_as_match_stereo(hopmatch_gapi.match_pair(left, right, max_disparity=9),
                                    left, right, max_disparity=9)

    def test_warning_turned_into_an_error(self):
        """With warnings.simplefilter('error'), match_stereo raises FewMatchesWarning on a
        flat pair and match_pair raised cv2.error."""
        flat = np.zeros((48, 48), np.uint8)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(FewMatchesWarning) as direct:
                hopmatch.match_stereo(flat, flat)
            with pytest.raises(FewMatchesWarning) as graph:
                hopmatch_gapi.match_pair(flat, flat)
        assert str(graph.value) == str(direct.value)

    def test_warnings_reach_the_caller_as_from_match_stereo(self):
        flat = np.zeros((48, 48), np.uint8)
        seen = []
        for call in (hopmatch.match_stereo, hopmatch_gapi.match_pair):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                call(flat, flat)
            seen.append([(w.category, str(w.message)) for w in caught])
            # attributed to this line, not to a frame of hopmatch or of the plugin
            assert {w.filename for w in caught} == {__file__}, call
        assert seen[0] and seen[1] == seen[0]
        assert seen[0][0][0] is FewMatchesWarning


# -- 24: as_arrays ---------------------------------------------------------------------------


class TestAsArrays:
    @pytest.mark.parametrize("args, error, argument", [
        (([1, 2, 3], [], []), InvalidArgumentError, "ml"),
        ((None, None, None), InvalidTypeError, "ml"),
        (("ab", [], []), InvalidTypeError, "ml"),
        (([(1j, 2)], [(1, 2)], [1]), InvalidTypeError, "ml"),
        (([(1, 2)], [(True, False)], [1]), InvalidTypeError, "mr"),
        (([(1, 2)], [(1, 2)], ["x"]), InvalidTypeError, "disp"),
        (([(1, 2)], [(1, 2)], [[1, 2]]), InvalidArgumentError, "disp"),
        (([(1, 2)], [(1, 2), (3,)], [1]), InvalidTypeError, "mr"),
        ((np.zeros((2, 2, 2)), np.zeros((2, 2)), np.zeros(2)), InvalidArgumentError, "ml"),
        (([(np.nan, 2)], [(1, 2)], [1]), InvalidArgumentError, "ml"),
        (([(1, 2)], [(1, 2)], [1e300]), InvalidArgumentError, "disp"),
        (([(1, 2), (3, 4)], [(1, 2)], [5, 6, 7]), InvalidArgumentError, "mr"),
        (([(1, 2), (3, 4)], [(1, 2), (3, 4)], [5]), InvalidArgumentError, "disp"),
    ], ids=["flat-odd", "None", "str", "complex", "bool", "str-disp", "disp-2d", "ragged",
            "3d", "nan", "beyond-float32", "lengths-mr", "lengths-disp"])
    def test_refused_naming_the_argument(self, args, error, argument):
        with pytest.raises(error, match=f"`{argument}`") as info:
            hopmatch_gapi.as_arrays(*args)
        assert info.value.argument == argument

    def test_accepted_forms(self):
        ml, mr, d = hopmatch_gapi.as_arrays(np.ones((3, 1, 2)), ((1, 2), (3, 4), (5, 6)),
                                            np.arange(3).reshape(3, 1))
        assert ml.shape == mr.shape == (3, 2) and d.shape == (3,)
        assert ml.dtype == mr.dtype == d.dtype == np.float32
        assert [a.shape for a in hopmatch_gapi.as_arrays((), np.zeros((0, 2)), [])] == [
            (0, 2), (0, 2), (0,)]


# -- 25: match_stereo's keywords that are not taken -------------------------------------------


class TestKeywordsNotTaken:
    @pytest.mark.parametrize("name, value", [("rectified", True), ("rectified", False),
                                             ("fundamental_matrix", np.eye(3)),
                                             ("mask_left", None), ("threads", 1)])
    def test_refused_saying_why(self, name, value):
        left, right = small_pair()
        for call in (lambda: hopmatch_gapi.match_pair(left, right, **{name: value}),
                     lambda: hopmatch_gapi.kernels(**{name: value})):
            with pytest.raises(InvalidArgumentError,
                               match=f"does not take `{name}`.*hopmatch.match_stereo") as info:
                call()
            assert info.value.argument == name

    def test_docstrings_say_which_are_taken(self):
        for doc in (hopmatch_gapi.match_pair.__doc__, hopmatch_gapi.kernels.__doc__):
            assert "rectified" in doc and "fundamental_matrix" in doc and "not taken" in doc


# -- 26: kernels() checks at once what match_pair checks --------------------------------------


class TestKernelsCheckedAtOnce:
    @pytest.mark.parametrize("params", [dict(max_disparity=-5),
                                        dict(max_disparity=-5.0, min_disparity=0),
                                        dict(preset="paper", max_disparity=-20)])
    def test_range_below_min_disparity(self, params):
        """kernels(max_disparity=-5) was accepted and failed inside the user's graph."""
        with pytest.raises(InvalidArgumentError, match="must not be below `min_disparity`") \
                as info:
            hopmatch_gapi.kernels(**params)
        assert info.value.argument == "max_disparity"
        left, right = small_pair()
        with pytest.raises(InvalidArgumentError, match="must not be below `min_disparity`"):
            hopmatch_gapi.match_pair(left, right, **params)

    def test_negative_range_with_its_floor_is_taken(self):
        assert hopmatch_gapi.kernels(max_disparity=-5, min_disparity=-10).size() == 3

    @pytest.mark.parametrize("name", ["max_pixels", "max_neurons"])
    def test_budgets_refused_as_the_classes_refuse_them(self, name):
        """max_pixels=10 and max_neurons=1 are legal (the classes take them); 0 and None
        are not, and kernels() refuses them at once, naming them."""
        hopmatch.DericheMoravecDetector(max_pixels=10)
        hopmatch.HopfieldMatcher(max_neurons=1)
        assert hopmatch_gapi.kernels(**{name: 10 if name == "max_pixels" else 1}).size() == 3
        for bad, error in ((0, InvalidArgumentError), (None, InvalidTypeError)):
            with pytest.raises(error, match=f"`{name}`") as info:
                hopmatch_gapi.kernels(**{name: bad})
            assert info.value.argument == name


# -- 27: Op.on checks its arguments -------------------------------------------------------------


class TestOnChecksItsArguments:
    @pytest.mark.parametrize("call, argument", [
        (lambda: hopmatch_gapi.GMatch.on(1, 2), "left"),
        (lambda: hopmatch_gapi.GMatch.on(cv.GMat(), np.zeros((4, 4), np.uint8)), "right"),
        (lambda: hopmatch_gapi.GDetect.on(None), "image"),
        (lambda: hopmatch_gapi.GMatchPoints.on(cv.GMat(), cv.GArray.Float(), cv.GMat(),
                                               cv.GArray.Point2f()), "left_points"),
        (lambda: hopmatch_gapi.GMatchPoints.on(cv.GMat(), cv.GArray.Point2f(), cv.GMat(),
                                               [(1.0, 2.0)]), "right_points"),
    ], ids=["GMatch-int", "GMatch-ndarray", "GDetect-None", "float-points", "list-points"])
    def test_invalid_type_naming_the_argument(self, call, argument):
        """GMatch.on(1, 2) and GDetect.on(None) raised G-API's bare Exception."""
        with pytest.raises(InvalidTypeError, match=f"`{argument}` of G") as info:
            call()
        assert info.value.argument == argument

    def test_wrong_number_of_arguments(self):
        with pytest.raises(InvalidTypeError, match=r"GMatch.on\(left, right\).*'right'"):
            hopmatch_gapi.GMatch.on(cv.GMat())

    def test_graph_objects_by_keyword_too(self):
        left, right = small_pair(seed=2)
        gl, gr = cv.GMat(), cv.GMat()
        ml, mr, d = hopmatch_gapi.GMatch.on(gl, right=gr)
        comp = cv.GComputation(cv.GIn(gl, gr), cv.GOut(ml, mr, d))
        out = comp.apply(cv.gin(left, right), args=cv.gapi.compile_args(
            hopmatch_gapi.kernels(max_disparity=8)))
        assert_same_as_match_stereo(hopmatch_gapi.as_arrays(*out), left, right,
                                    max_disparity=8)
