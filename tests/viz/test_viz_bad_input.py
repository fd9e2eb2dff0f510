"""Bad input to the drawing parameters of :mod:`hopmatch.viz`: colours, radii, marker
sizes, gaps, colour-bar lengths, scales, tick counts, plot formats and paths get
hopmatch's own errors naming the argument (before 2027-01 they were cv2.error, NumPy's
ValueError, MemoryError or an out-of-memory kill), and pictures of images of any size the
matcher accepts draw (the overview's colour bar was a NumPy broadcast error below about
24 x 24 pixels)."""

from __future__ import annotations

import tracemalloc

import cv2
import numpy as np
import pytest

from hopmatch import viz
from hopmatch.errors import BudgetExceededError, InvalidArgumentError, InvalidTypeError
from hopmatch.viz.draw import MAX_DRAW_SIZE, as_colour
from hopmatch.viz.overview import disparity_scale, draw_colour_bar, nice_ticks, spread_subset

IMG = np.zeros((50, 60), np.uint8)
KP = [cv2.KeyPoint(10, 10, 5)]
DM = [cv2.DMatch(0, 0, 0.1)]

# --------------------------------------------------------------------------------------
# Pictures of tiny images
# --------------------------------------------------------------------------------------

TINY = [(1, 1), (2, 2), (20, 20), (400, 1), (1, 400)]


@pytest.mark.parametrize("with_match", [False, True], ids=["empty", "one_match"])
def test_pictures_of_tiny_images(with_match):
    grey = int(200 * 0.75)
    for h, w in TINY:
        image = np.full((h, w), 200, np.uint8)
        pts = np.float32([[0, 0]]) if with_match else np.zeros((0, 2), np.float32)
        pairs = [[0, 0]] if with_match else []
        pic = viz.draw_match_overview(image, image, pts, pts, pairs)
        assert pic.dtype == np.uint8 and pic.ndim == 3 and pic.shape[2] == 3
        assert pic.shape[1] == 2 * w and pic.shape[0] >= h + 34  # images over a caption
        if not with_match:  # the images themselves, dimmed, at the top
            assert (pic[:h] == grey).all()
        pic = viz.draw_keypoint_disparities(image, pts, [1.0] if with_match else [])
        assert pic.shape == (h, w + 80, 3) and pic.dtype == np.uint8


def test_horizontal_colour_bar_of_every_length_fits():
    for length in range(1, 80):
        bar = draw_colour_bar(length, 0, 66, vertical=False)
        assert bar.shape == (34, length, 3) and bar.dtype == np.uint8
    # wide enough: the bar is drawn (TURBO colours, not the grey panel)
    bar = draw_colour_bar(40, 0, 66, vertical=False)
    assert (bar[10, 8:8 + 24].astype(int).std(axis=1) > 20).any()


def test_caption_text_is_left_out_only_when_too_narrow():
    pts = np.float32([[5, 5]])
    narrow = viz.draw_match_overview(np.zeros((10, 10), np.uint8), np.zeros((10, 10),
                                     np.uint8), pts, pts, [[0, 0]])
    wide = viz.draw_match_overview(np.zeros((10, 300), np.uint8), np.zeros((10, 300),
                                   np.uint8), pts, pts, [[0, 0]])
    assert narrow.shape[0] == 10 + 34  # no text: every line would be cut
    assert wide.shape[0] > 10 + 34 + 18  # text lines over the bar


# --------------------------------------------------------------------------------------
# Colours
# --------------------------------------------------------------------------------------

COLOUR_CALLS = {
    "draw_keypoints": lambda c: viz.draw_keypoints(IMG, KP, color=c),
    "draw_keypoints_on_gradient": lambda c: viz.draw_keypoints_on_gradient(IMG, KP, color=c),
    "draw_labelled_matches": lambda c: viz.draw_labelled_matches(IMG, IMG, KP, KP, DM,
                                                                 color=c),
    "draw_labelled_matches (label)": lambda c: viz.draw_labelled_matches(
        IMG, IMG, KP, KP, DM, label_color=c),
}


@pytest.mark.parametrize("call", COLOUR_CALLS.values(), ids=COLOUR_CALLS.keys())
@pytest.mark.parametrize("bad, error", [
    ("red", InvalidTypeError), (None, InvalidTypeError), (255, InvalidTypeError),
    ((0, "a", 0), InvalidTypeError), ((True, 0, 0), InvalidTypeError),
    ((), InvalidArgumentError), ((1, 2, 3, 4, 5), InvalidArgumentError),
    ((300, 0, 0), InvalidArgumentError), ((-1, 0, 0), InvalidArgumentError),
    ((np.nan, 0, 0), InvalidArgumentError),
])
def test_bad_colours_are_refused_by_name(call, bad, error):
    with pytest.raises(error, match=r"`(label_)?color` must be a colour"):
        call(bad)


def test_colours_as_opencv_takes_them():
    assert as_colour([0, 128.4, 255], "c") == (0, 128, 255)
    assert as_colour(np.array([1, 2, 3, 4], np.uint8), "c") == (1, 2, 3, 4)
    assert as_colour((7,), "c") == (7,)
    a = viz.draw_keypoints(IMG, KP, color=(0, 0, 255))
    assert (viz.draw_keypoints(IMG, KP, color=np.float32([0, 0, 255])) == a).all()
    assert (a[..., 2] > 100).any() and not a[..., :2].any()  # red, anti-aliased


# --------------------------------------------------------------------------------------
# Radii, marker sizes, keypoint sizes
# --------------------------------------------------------------------------------------

SIZE_CALLS = {
    "radius": lambda r: viz.draw_disparity(IMG, np.float32([[10, 10]]), [1.0], radius=r),
    "radius ": lambda r: viz.draw_keypoint_disparities(IMG, [[10, 10]], [1.0], radius=r),
    "marker_size": lambda r: viz.draw_keypoints_on_gradient(IMG, KP, marker_size=r),
}


@pytest.mark.parametrize("name", SIZE_CALLS)
@pytest.mark.parametrize("bad, error", [
    (-1, InvalidArgumentError), (MAX_DRAW_SIZE + 1, InvalidArgumentError),
    (2**40, InvalidArgumentError), ("a", InvalidTypeError), (2.5, InvalidTypeError),
    (None, InvalidTypeError),
])
def test_bad_sizes_are_refused_by_name(name, bad, error):
    with pytest.raises(error, match=rf"`{name.strip()}` must be"):
        SIZE_CALLS[name](bad)


def test_sizes_at_their_bounds_draw():
    assert viz.draw_disparity(IMG, np.float32([[10, 10]]), [1.0], radius=0).shape \
        == (50, 60, 3)
    big = viz.draw_keypoint_disparities(IMG, [[10, 10]], [1.0], radius=MAX_DRAW_SIZE)
    assert big[:, :60].any(axis=2).all()  # one dot over the whole picture
    with pytest.raises(InvalidArgumentError, match="`marker_size`"):
        viz.draw_keypoints_on_gradient(IMG, KP, marker_size=0)


@pytest.mark.parametrize("size", [1e30, 1e9, -5.0, float("nan"), float("inf")])
def test_keypoints_too_large_to_draw_are_clipped(size):
    kps = [cv2.KeyPoint(10, 10, size), cv2.KeyPoint(30, 25, 40, 30)]
    pic = viz.draw_keypoints(IMG, kps)
    assert pic.shape == (50, 60, 3) and pic.dtype == np.uint8
    # the caller's keypoint is untouched (its size is a float32)
    assert kps[0].size == np.float32(size) or np.isnan(size)
    clipped = min(max(0.0, size), 2.0 * MAX_DRAW_SIZE) if not np.isnan(size) else 0.0
    # drawn as OpenCV draws a keypoint of the clipped size; the other one as it is
    want = cv2.drawKeypoints(cv2.cvtColor(IMG, cv2.COLOR_GRAY2BGR),
                             [cv2.KeyPoint(10, 10, clipped), kps[1]], None,
                             color=(0, 255, 0), flags=cv2.DrawMatchesFlags_DRAW_RICH_KEYPOINTS)
    assert (pic == want).all()


# --------------------------------------------------------------------------------------
# Sizes of the picture
# --------------------------------------------------------------------------------------


def test_a_gap_too_large_is_refused_before_allocating():
    tracemalloc.start()
    try:
        with pytest.raises(BudgetExceededError, match=r"`gap` = 1000000000 would make a "
                                                      r"50 x 1000000120 picture") as info:
            viz.draw_labelled_matches(IMG, IMG, KP, KP, DM, gap=10**9)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert isinstance(info.value, InvalidArgumentError) and info.value.argument == "gap"
    assert peak < 50 * 2**20


@pytest.mark.parametrize("kwargs, error, name", [
    ({"gap": "a"}, InvalidTypeError, "gap"), ({"gap": 2.5}, InvalidTypeError, "gap"),
    ({"gap": 2**70}, InvalidArgumentError, "gap"),
    ({"font_scale": "a"}, InvalidTypeError, "font_scale"),
    ({"font_scale": None}, InvalidTypeError, "font_scale"),
    ({"max_labels": "a"}, InvalidTypeError, "max_labels"),
    ({"max_labels": 1.5}, InvalidTypeError, "max_labels"),
])
def test_labelled_matches_parameters_are_refused_by_name(kwargs, error, name):
    with pytest.raises(error, match=f"`{name}`"):
        viz.draw_labelled_matches(IMG, IMG, KP, KP, DM, **kwargs)


@pytest.mark.parametrize("kwargs, error, name", [
    ({"length": 0}, InvalidArgumentError, "length"),
    ({"length": -5}, InvalidArgumentError, "length"),
    ({"length": "a"}, InvalidTypeError, "length"),
    ({"length": 10**12}, BudgetExceededError, "length"),
    ({"length": 10**12, "vertical": False}, BudgetExceededError, "length"),
    ({"lo": 5.0, "hi": 5.0}, InvalidArgumentError, "hi"),
    ({"lo": np.nan}, InvalidArgumentError, "lo"),
    ({"hi": "a"}, InvalidTypeError, "hi"),
    ({"lo": -1e308, "hi": 1e308}, InvalidArgumentError, "hi"),
    ({"title": 3}, InvalidTypeError, "title"),
    ({"footer": None}, InvalidTypeError, "footer"),
])
def test_colour_bar_arguments_are_refused_by_name(kwargs, error, name):
    args = {"length": 100, "lo": 0.0, "hi": 10.0, **kwargs}
    with pytest.raises(error, match=f"`{name}`"):
        draw_colour_bar(**args)


# --------------------------------------------------------------------------------------
# Scales, ticks, subsets, flags
# --------------------------------------------------------------------------------------


def test_nice_ticks_refuses_absurd_tick_counts_and_survives_huge_ranges():
    with pytest.raises(InvalidArgumentError, match="`max_ticks`"):
        nice_ticks(0, 1, 10**12)  # was a list of 10**12 floats: killed for lack of memory
    with pytest.raises(InvalidTypeError, match="`lo`"):
        nice_ticks("a", 1)
    assert nice_ticks(-1e308, 1e308) == [-1e308, 1e308]  # was an OverflowError
    assert nice_ticks(0, 66) == [0.0, 20.0, 40.0, 60.0]


def test_disparity_scale_bounds():
    with pytest.raises(InvalidTypeError, match="`min_disparity`"):
        disparity_scale([1.0], "a")
    with pytest.raises(InvalidArgumentError, match="`max_disparity`"):
        disparity_scale([1.0], 0, np.inf)
    with pytest.raises(InvalidArgumentError, match="disparity scale must be finite"):
        disparity_scale([1.0], -1e308, 1e308)  # was an OverflowError in the colour bar
    with pytest.raises(InvalidArgumentError, match="disparity scale must be finite"):
        disparity_scale([1e308], -1e308)
    with pytest.raises(InvalidTypeError, match="`disparities`"):
        disparity_scale("abc")


def test_overview_and_disparity_pictures_refuse_bad_parameters_by_name():
    pts = [[1, 1]]
    calls = [
        (InvalidTypeError, "`max_lines`",
         lambda: viz.draw_match_overview(IMG, IMG, pts, pts, [[0, 0]], max_lines="a")),
        (InvalidTypeError, "`min_disparity`",
         lambda: viz.draw_match_overview(IMG, IMG, pts, pts, [[0, 0]], min_disparity="a")),
        (InvalidTypeError, "`correct`",
         lambda: viz.draw_match_overview(IMG, IMG, pts, pts, [[0, 0]], correct="a")),
        (InvalidTypeError, "`known`",
         lambda: viz.draw_match_overview(IMG, IMG, pts, pts, [[0, 0]],
                                         correct=[True], known=[0.5])),
        (InvalidTypeError, "`max_disparity`",
         lambda: viz.draw_disparity(IMG, pts, [1.0], max_disparity="a")),
        (InvalidArgumentError, "`min_disparity`",
         lambda: viz.draw_disparity(IMG, pts, [1.0], min_disparity=np.nan)),
        # an inverted scale would colour everything alike, silently
        (InvalidArgumentError, "`max_disparity` must be greater than `min_disparity`",
         lambda: viz.draw_disparity(IMG, pts, [1.0], max_disparity=2, min_disparity=5)),
        (InvalidArgumentError, "`max_disparity` must be greater than `min_disparity`",
         lambda: viz.draw_keypoint_disparities(IMG, pts, [1.0], max_disparity=5,
                                               min_disparity=5)),
        (InvalidArgumentError, "`max_disparity` must be greater than the scale's bottom",
         lambda: viz.draw_match_overview(IMG, IMG, pts, pts, [[0, 0]], max_disparity=-3)),
        (InvalidTypeError, "`disparities`", lambda: viz.disparity_colours("a", 0, 1)),
        (InvalidArgumentError, "`lo`", lambda: viz.disparity_colours([1.0], np.nan, 1)),
        (InvalidTypeError, "`n`", lambda: spread_subset(pts, "a")),
        (InvalidArgumentError, "`height`", lambda: spread_subset(pts, 3, np.nan)),
    ]
    for error, name, call in calls:
        with pytest.raises(error, match=name):
            call()


# --------------------------------------------------------------------------------------
# Plots
# --------------------------------------------------------------------------------------


def test_plot_arguments_are_refused_by_name(tmp_path):
    pytest.importorskip("matplotlib")
    with pytest.raises(InvalidTypeError, match="`trace`"):
        viz.render_energy("abc")
    with pytest.raises(InvalidArgumentError, match="`fmt` must name a format"):
        viz.render_energy([1.0, 0.0], fmt="xyz")
    with pytest.raises(InvalidTypeError, match="`fmt`"):
        viz.render_precision_curves([], fmt=None)
    with pytest.raises(InvalidTypeError, match="`threshold`"):
        viz.render_precision_vs_correct([], threshold="a")
    with pytest.raises(InvalidTypeError, match="`rows`"):
        viz.render_precision_curves(5)
    with pytest.raises(InvalidArgumentError, match="suffix of `path`"):
        viz.plot_error_histogram({"m": [0.1]}, tmp_path / "h.xyz")
    with pytest.raises(InvalidTypeError, match="`path`"):
        viz.plot_energy([1.0, 0.0], 5)
    assert list(tmp_path.iterdir()) == []
