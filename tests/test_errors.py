"""The error vocabulary (hopmatch.errors): the ``argument`` attribute, collect_warnings."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest

import hopmatch
from hopmatch import errors


@pytest.mark.parametrize("cls", [errors.HopmatchError, errors.InvalidArgumentError,
                                 errors.InvalidTypeError, errors.BudgetExceededError,
                                 errors.PairInfoError])
def test_argument_defaults_to_none_and_survives_pickling(cls):
    assert cls("message").argument is None
    exc = cls("`left` is wrong", argument="left")
    assert exc.argument == "left" and str(exc) == "`left` is wrong"
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is cls and back.argument == "left" and str(back) == str(exc)


def test_the_builtin_bases_are_kept():
    exc = errors.InvalidArgumentError("x", argument="a")
    assert isinstance(exc, ValueError) and exc.args == ("x",)
    assert isinstance(errors.InvalidTypeError("x"), TypeError)


# -- collect_warnings ----------------------------------------------------------------------

FLAT = np.zeros((64, 64), np.uint8)


def test_collect_warnings_keeps_hopmatch_warnings_instead_of_giving_them():
    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")
        with errors.collect_warnings() as caught:
            result = hopmatch.match_stereo(FLAT, FLAT)
            warnings.warn("not hopmatch's", RuntimeWarning)
    assert len(result.disparities) == 0
    assert [(c, m.split(":")[0]) for c, m in caught] == [(errors.FewMatchesWarning,
                                                           "no matches")]
    assert [w.category for w in shown] == [RuntimeWarning]  # others are given as usual


def test_collect_warnings_ignores_the_filters_and_the_items_give_them_later():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a worker's filters do not decide what travels
        with errors.collect_warnings() as caught:
            hopmatch.match_stereo(FLAT, FLAT)
            hopmatch.match_stereo(FLAT, FLAT)  # the same warning twice: kept twice
    assert len(caught) == 2 and caught[0] == caught[1]
    category, message = caught[0]
    with pytest.warns(errors.FewMatchesWarning) as given:
        caught[0]()
    assert str(given[0].message) == message
    assert given[0].filename == __file__  # attributed to the line that gave it


def test_collect_warnings_nests_and_holds_with_two_threads():
    left = (np.random.default_rng(0).random((60, 80)) * 255).astype(np.uint8)
    with errors.collect_warnings() as outer:
        with errors.collect_warnings() as inner:
            hopmatch.match_stereo(FLAT, FLAT, threads=2)
        hopmatch.match_stereo(left, np.zeros_like(left), threads=2)
    assert [c for c, _ in inner] == [errors.FewMatchesWarning]
    assert len(outer) == 1 and issubclass(outer[0].category, errors.FewMatchesWarning)


def test_a_block_that_raises_hands_its_warnings_to_no_one():
    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")
        with pytest.raises(KeyError), errors.collect_warnings():
            hopmatch.match_stereo(FLAT, FLAT)
            raise KeyError("boom")
    assert shown == []
