"""Parameter specs (hopmatch._params): what each Param says it takes, and the errors of its
validator naming it through ``.argument``."""

from __future__ import annotations

import pytest

from hopmatch import DericheMoravecDetector, HopfieldMatcher
from hopmatch._params import KINDS, Check, Configurable, Param, boolean, choice, integer, real
from hopmatch.errors import HopmatchError, InvalidArgumentError, InvalidTypeError

ALL = DericheMoravecDetector.PARAMS + HopfieldMatcher.PARAMS


def test_the_factories_say_what_they_accept():
    assert (integer(0).kind, real().kind, boolean().kind, choice("a", "b").kind) == (
        "int", "float", "bool", "choice")
    assert choice("a", "b").choices == ("a", "b") and integer(0).choices == ()
    assert real(optional=True).optional and not real().optional
    assert integer(0, optional=True).optional and not boolean().optional
    assert all(isinstance(f, Check) for f in (integer(), real(), boolean(), choice("x")))


def test_every_parameter_has_a_kind_from_its_validator():
    for spec in ALL:
        assert spec.kind in KINDS, spec
        assert spec.kind == spec.check.kind, spec.name
        assert spec.choices == spec.check.choices
        assert spec.optional == spec.check.optional
        if spec.default is not None:
            assert spec.kind == {bool: "bool", int: "int", float: "float", str: "choice"}[
                type(spec.default)], spec.name
    by_name = {p.name: p for p in ALL}
    assert by_name["preset"].choices == ("default", "paper")
    assert by_name["on"].choices == ("gradient", "intensity")
    assert by_name["vertical_check"].choices == ("multiple", "all")
    assert by_name["max_disparity"].optional and by_name["similarity_gate"].optional
    assert not by_name["window_size"].optional
    assert by_name["window_size"].kind == "int" and by_name["alpha"].kind == "float"
    assert by_name["subpixel"].kind == "bool"


def test_docs_come_from_the_param_or_the_class_docstring():
    det = {p.name: p.doc for p in DericheMoravecDetector.PARAMS}
    assert det["window_size"].startswith("Odd side of the Moravec window of eq. 1")
    assert det["alpha"] == det["omega"]  # "alpha, omega : float" documents both
    assert "``" not in det["max_pixels"]
    mat = {p.name: p.doc for p in HopfieldMatcher.PARAMS}
    assert mat["vertical_check"].startswith("SPEC section 4's vertical test")


def test_a_param_with_a_plain_function_check():
    def even(name, value):
        if value % 2:
            raise InvalidArgumentError(f"`{name}` must be even, got {value}")
        return value

    assert Param("n", 2, even).kind == "int" and not Param("n", 2, even).optional
    assert Param("x", 0.5, even).kind == "float"
    assert Param("s", None, even).kind == "text" and Param("s", None, even).optional
    assert Param("n", None, even, kind="int", optional=False).kind == "int"
    with pytest.raises(InvalidArgumentError, match="kind"):
        Param("n", 1, even, kind="complex")


@pytest.mark.parametrize("check, value, error", [
    (integer(1, 99, odd=True), 4, InvalidArgumentError),
    (integer(0), "a", InvalidTypeError),
    (real(0.0, lo_open=True), 0.0, InvalidArgumentError),
    (real(), None, InvalidTypeError),
    (boolean(), 2, InvalidTypeError),
    (choice("a", "b"), "c", InvalidArgumentError),
    (choice("a", "b"), 1, InvalidTypeError),
])
def test_validator_errors_name_their_argument(check, value, error):
    with pytest.raises(error) as info:
        check("some_name", value)
    assert info.value.argument == "some_name"
    assert str(info.value).startswith("`some_name` ")


def test_class_errors_name_the_parameter():
    with pytest.raises(InvalidArgumentError) as info:
        DericheMoravecDetector(window_size=4)
    assert info.value.argument == "window_size"
    m = HopfieldMatcher()
    with pytest.raises(HopmatchError) as info:
        m.setSimilarityGate(-1)
    assert info.value.argument == "similarity_gate"
    with pytest.raises(InvalidArgumentError) as info:  # not about one parameter
        DericheMoravecDetector(window_sizes=3)
    assert info.value.argument is None


def test_subclass_docs_fill_only_empty_docs():
    class Thing(Configurable):
        """A thing.

        Parameters
        ----------
        size : int
            How big, in ``px``.
        name : str
            Ignored: the Param has its own doc.
        """

        PARAMS = (Param("size", 3, integer(1)), Param("name", "a", choice("a", "b"), "Own."),
                  Param("other", 1.0, real()))

        def __init__(self, **params):
            self._init_params(params)

    docs = {p.name: p.doc for p in Thing.PARAMS}
    assert docs == {"size": "How big, in px.", "name": "Own.", "other": ""}
    assert Thing(size=5).getSize() == 5
