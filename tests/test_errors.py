"""The error vocabulary (hopmatch.errors): the ``argument`` attribute."""

from __future__ import annotations

import pickle

import pytest

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
