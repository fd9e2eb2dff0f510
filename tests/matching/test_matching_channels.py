"""hopmatch.matching.channels: a second grey version of a colour pair whose views clip
different channels (``channel_clip_share``), and the match with more pairs kept."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest
from synthetic_pairs import texture

import hopmatch
from hopmatch._warnings import deferred_warnings, deferring, warn
from hopmatch.errors import FewMatchesWarning, InvalidArgumentError, NotStereoPairWarning
from hopmatch.matching import channels

DISPARITY = 8


def warm_pair(gain=1.4, h=160, w=240):
    """A warm colour scene (B about 100, G about 190, R about 200, an independent texture
    in each) and its right view, shifted by DISPARITY px and brightened by ``gain``: G and
    R clip over most of the right view, B nowhere."""
    planes = [texture(h, w + DISPARITY, seed=s, sigma=1.5) - 120 for s in (1, 2, 3)]
    scene = np.stack([100 + 0.4 * planes[0], 190 + 0.4 * planes[1], 200 + 0.4 * planes[2]],
                     axis=2)
    left = np.clip(scene[:, :w] + 0.5, 0, 255).astype(np.uint8)
    right = np.clip(scene[:, DISPARITY:] * gain + 0.5, 0, 255).astype(np.uint8)
    return left, right


def test_the_channels_one_view_clips_are_left_out():
    left, right = warm_pair()
    assert (right[..., 1:] == 255).mean() > 0.5 and (right[..., 0] == 255).mean() == 0
    assert channels.channels_kept(left, right, 0.15, 10**8) == (0,)
    # either view: the share is of one view's pixels more than of the other's
    assert channels.channels_kept(right, left, 0.15, 10**8) == (0,)
    # uint16 and BGRA alike
    wide = [v.astype(np.uint16) * 257 for v in (left, right)]
    assert channels.channels_kept(*wide, 0.15, 10**8) == (0,)
    bgra = [cv2.cvtColor(v, cv2.COLOR_BGR2BGRA) for v in (left, right)]
    assert channels.channels_kept(*bgra, 0.15, 10**8) == (0,)


@pytest.mark.parametrize("case", ["grey", "float", "same", "all", "share", "big", "dtypes"])
def test_no_second_grey_version_unless_one_or_two_channels_clip_apart(case):
    left, right = warm_pair()
    share, max_pixels = 0.15, 10**8
    if case == "grey":
        left, right = (cv2.cvtColor(v, cv2.COLOR_BGR2GRAY) for v in (left, right))
    elif case == "float":
        left, right = left.astype(np.float32), right.astype(np.float32)
    elif case == "same":  # both views clip alike
        right = np.roll(left, -DISPARITY, axis=1)  # the same clipped shares
    elif case == "all":  # every channel clips apart: nothing left to make grey levels of
        right = np.clip(right.astype(np.float64) * 3.0, 0, 255).astype(np.uint8)
    elif case == "share":
        share = None
    elif case == "big":  # match_stereo refuses it before any work
        max_pixels = left.shape[0] * left.shape[1] - 1
    else:
        right = right.astype(np.uint16)
    assert channels.channels_kept(left, right, share, max_pixels) is None


def test_grey_of_channels_is_the_weighted_sum_of_those_channels():
    left, _ = warm_pair()
    np.testing.assert_array_equal(channels.grey_of_channels(left, (0,)), left[..., 0])
    w = np.array(channels.GREY_WEIGHTS)[[0, 2]]
    want = (left[..., [0, 2]].astype(np.float64) @ (w / w.sum()))
    got = channels.grey_of_channels(left, (0, 2))
    assert got.dtype == np.uint8 and got.shape == left.shape[:2]
    assert np.abs(got - want).max() <= 0.5 + 1e-6
    # all three: cv2's own grey levels (its fixed-point rounding, within one level)
    full = channels.grey_of_channels(left, (0, 1, 2)).astype(int)
    assert np.abs(full - cv2.cvtColor(left, cv2.COLOR_BGR2GRAY)).max() <= 1


def test_match_stereo_keeps_the_match_on_the_unclipped_channel():
    left, right = warm_pair()
    res = hopmatch.match_stereo(left, right, max_disparity=16)
    grey = [cv2.cvtColor(v, cv2.COLOR_BGR2GRAY) for v in (left, right)]
    with pytest.warns(NotStereoPairWarning):  # the usual grey levels lost the texture
        usual = hopmatch.match_stereo(*grey, max_disparity=16)
    assert res.grey_channels == (0,) and usual.grey_channels is None
    assert len(res.query_idx) > 2 * max(len(usual.query_idx), 50)
    d = res.disparities
    assert np.mean(np.abs(d - DISPARITY) <= 1) > 0.97
    # the same as matching the blue channels themselves
    blue = hopmatch.match_stereo(left[..., 0].copy(), right[..., 0].copy(), max_disparity=16)
    np.testing.assert_array_equal(blue.matched_right, res.matched_right)
    # off (and in the paper's preset): the usual grey levels only
    with pytest.warns(NotStereoPairWarning):
        off = hopmatch.match_stereo(left, right, max_disparity=16, channel_clip_share=None)
    assert off.grey_channels is None
    np.testing.assert_array_equal(off.matched_right, usual.matched_right)
    paper = hopmatch.match_stereo(left, right, preset="paper")
    assert paper.grey_channels is None


def test_a_pair_that_clips_alike_is_matched_as_before():
    left, right = warm_pair(gain=1.0)
    res = hopmatch.match_stereo(left, right, max_disparity=16)
    grey = hopmatch.match_stereo(*(cv2.cvtColor(v, cv2.COLOR_BGR2GRAY) for v in (left, right)),
                                 max_disparity=16)
    assert res.grey_channels is None
    np.testing.assert_array_equal(res.matched_right, grey.matched_right)


def test_only_the_kept_match_gives_its_warnings():
    """The usual grey levels of the clipped pair find few matches (a FewMatchesWarning);
    the blue channel finds many: the warning of the discarded match is not given."""
    left, right = warm_pair(gain=1.8)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        usual = hopmatch.match_stereo(*(cv2.cvtColor(v, cv2.COLOR_BGR2GRAY)
                                        for v in (left, right)), max_disparity=16)
    assert any(issubclass(w.category, FewMatchesWarning) for w in seen), len(usual.query_idx)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        res = hopmatch.match_stereo(left, right, max_disparity=16)
    assert res.grey_channels == (0,)
    assert not [w for w in seen if issubclass(w.category, hopmatch.errors.HopmatchWarning)]


def test_bad_input_is_refused_as_without_the_step():
    left, right = warm_pair()
    with pytest.raises(InvalidArgumentError, match="channel_clip_share"):
        hopmatch.match_stereo(left, right, channel_clip_share=0.0)
    with pytest.raises(InvalidArgumentError, match="`right`"):
        hopmatch.match_stereo(left, right[..., :2])


def test_deferred_warnings_are_kept_until_given():
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with deferred_warnings() as pending:
            warn("later", FewMatchesWarning)
        assert not seen and len(pending) == 1
        pending[0]()
    assert [str(w.message) for w in seen] == ["later"]
    assert seen[0].filename == __file__  # attributed to the line that gave it


def test_deferring_appends_to_a_list_or_gives_now_and_drops_on_an_error():
    later = []
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with deferring(None):
            warn("now", FewMatchesWarning)
        assert [str(w.message) for w in seen] == ["now"]
        with deferring(later):
            warn("later", FewMatchesWarning)
        with pytest.raises(RuntimeError), deferring(later):
            warn("dropped", FewMatchesWarning)
            raise RuntimeError("a step that fails")
        assert len(seen) == 1 and len(later) == 1
        later[0](kept=3, exposure="")  # as the matching steps call their lists' items
    assert [str(w.message) for w in seen] == ["now", "later"]
