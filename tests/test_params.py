"""Parameter specs (hopmatch._params): what each Param says it takes, and the errors of its
validator naming it through ``.argument``."""

from __future__ import annotations

import math
import os

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch import DericheMoravecDetector, HopfieldMatcher
from hopmatch._params import KINDS, Check, Configurable, Param, boolean, choice, integer, real
from hopmatch._validate import INT64_MAX, INT64_MIN
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


def test_boolean_parameters_take_what_as_flag_takes():
    # one rule for flags, whether a parameter or a call's argument (as_flag)
    check = boolean()
    for value in (True, False, np.bool_(True), np.bool_(False), 0, 1, np.int64(1)):
        out = check("flag", value)
        assert type(out) is bool and out == bool(value)
    for value in ("no", 2, -1, 0.0, None, np.array([True])):
        with pytest.raises(InvalidTypeError, match="`flag` must be True or False"):
            check("flag", value)
    m = HopfieldMatcher(cross_check=np.bool_(False))
    assert m.getCrossCheck() is False


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


# -- issue 20: FileStorage round trip of every parameter at its bounds ---------------------



def _extremes(spec):
    """The values at the edges of what ``spec`` accepts (int64 and float range included)."""
    check = spec.check
    if spec.kind == "int":
        lo = INT64_MIN if check.lo is None else max(check.lo, INT64_MIN)
        hi = INT64_MAX if check.hi is None else min(check.hi, INT64_MAX)
        values = [lo, hi, lo + 2, hi - 2, 2**31 - 1, 2**31, -(2**31) - 1, 2**53 + 1, 2**62 + 3]
        values = [v for v in values if lo <= v <= hi]
        if spec.name in ("window_size", "descriptor_size"):
            values = [v for v in values if v % 2]
    elif spec.kind == "float":
        big = 1.7976931348623157e308
        lo = -big if check.lo is None else float(check.lo)
        hi = big if check.hi is None else float(check.hi)
        low = math.nextafter(lo, math.inf) if check.lo_open else lo
        values = [low, hi, 5e-324, -5e-324, 0.1, 1 / 3, 2.0**-1074 * 3, 1e-310, -0.0]
        values = [v for v in values if low <= v <= hi]
    elif spec.kind == "bool":
        values = [True, False]
    else:
        values = list(spec.choices)
    if spec.optional:
        values.append(None)
    return values


@pytest.mark.parametrize("cls", [hopmatch.DericheMoravecDetector, hopmatch.HopfieldMatcher])
@pytest.mark.parametrize("ext", ["yml", "json", "xml"])
def test_filestorage_round_trip_at_every_bound(cls, ext, tmp_path):
    """Every parameter at its bounds (int64 for unbounded integers, the float range, the
    smallest denormal) comes back from write()/read() exactly; before issue 20 integers
    beyond 2**53 came back rounded (seed=2**63-1 as 2**63, refused) and, with some cv2
    builds, integers from 2**31 on as ``true``, i.e. 1."""
    tried = 0
    for spec in cls.PARAMS:
        if spec.name == "preset":
            continue
        for value in _extremes(spec):
            try:
                obj = cls(**{spec.name: value})
            except hopmatch.errors.HopmatchError:
                continue  # refused by a check across parameters (max < min disparity)
            path = tmp_path / f"{spec.name}.{ext}"
            obj.write(str(path))
            back = cls()
            back.read(str(path))
            got = back.get_params()[spec.name]
            assert got == value and type(got) is type(obj.get_params()[spec.name]), \
                (spec.name, value, got)
            tried += 1
    assert tried > 60


def _storage(tmp_path, text, ext="yml"):
    path = tmp_path / f"p.{ext}"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("body, words", [
    ("hopmatch_DericheMoravecDetector: [1, 2, 3]\n", "holds a sequence"),
    ("hopmatch_DericheMoravecDetector: 5\n", "holds a number"),
    ("hopmatch_DericheMoravecDetector: abc\n", "holds a string"),
])
def test_read_refuses_a_node_that_is_not_a_map(tmp_path, body, words):
    """Issue 20: these raised cv2.error (an assertion inside OpenCV)."""
    path = _storage(tmp_path, "%YAML:1.0\n---\n" + body)
    with pytest.raises(InvalidTypeError, match=f"`fs`: node .* {words}; expected a map") as e:
        hopmatch.DericheMoravecDetector().read(path)
    assert e.value.argument == "fs"


def test_read_of_other_roots_and_integers(tmp_path):
    with pytest.raises(InvalidArgumentError, match="holds no node named"):
        hopmatch.HopfieldMatcher().read(_storage(tmp_path, "%YAML:1.0\n--- [1, 2]\n"))
    with pytest.raises(InvalidTypeError, match="holds a sequence"):
        hopmatch.HopfieldMatcher().read(_storage(tmp_path, '{"hopmatch_HopfieldMatcher": [1]}',
                                                 "json"))
    # an integer FileStorage cannot read exactly (beyond 2**53) is refused, not rounded
    path = _storage(tmp_path, "%YAML:1.0\n---\nhopmatch_HopfieldMatcher:\n"
                              "  seed: 9007199254740993\n")
    with pytest.raises(InvalidArgumentError, match="beyond the 2\\*\\*53"):
        hopmatch.HopfieldMatcher().read(path)
    # as a string (what write() stores) it is exact; "5." for an integer is 5
    path = _storage(tmp_path, '%YAML:1.0\n---\nhopmatch_HopfieldMatcher:\n'
                              '  seed: "9007199254740993"\n  max_candidates: 5.\n')
    m = hopmatch.HopfieldMatcher()
    m.read(path)
    assert (m.getSeed(), m.getMaxCandidates()) == (9007199254740993, 5)


def test_read_refuses_special_files(tmp_path):
    (tmp_path / "loop.yml").symlink_to(tmp_path / "loop.yml")
    with pytest.raises(InvalidArgumentError, match="symbolic link loop"):
        hopmatch.HopfieldMatcher().read(str(tmp_path / "loop.yml"))
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "pipe.yml")
        with pytest.raises(InvalidArgumentError, match="named pipe"):
            hopmatch.HopfieldMatcher().read(str(tmp_path / "pipe.yml"))


def test_write_errors_name_the_destination(tmp_path):
    (tmp_path / "d.yml").mkdir()
    with pytest.raises(ValueError, match="d.yml.*a folder of that name") as e:
        hopmatch.HopfieldMatcher().write(str(tmp_path / "d.yml"))
    assert isinstance(e.value, OSError) and e.value.argument == "fs" and ".tmp" not in str(e.value)
    with pytest.raises(ValueError, match="more than the 255"):
        hopmatch.HopfieldMatcher().write(str(tmp_path / ("m" * 300 + ".yml")))


@pytest.mark.parametrize("cls", [hopmatch.HopfieldMatcher, hopmatch.DericheMoravecDetector])
def test_write_into_a_filestorage_open_for_reading_names_the_mode(tmp_path, cls):
    path = str(tmp_path / "p.yml")
    cls().save(path)
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    with pytest.raises(InvalidArgumentError, match="open for reading") as e:
        cls().write(fs)
    fs.release()
    assert e.value.argument == "fs"
