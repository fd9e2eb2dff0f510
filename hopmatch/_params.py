"""Parameters of the cv2-like classes: validation, get/set accessors, FileStorage I/O.

A class lists its parameters once, as :class:`Param` specs in ``PARAMS``; this module gives
it keyword construction with validation, ``getX``/``setX`` accessors named as OpenCV names
them (``window_size`` -> ``getWindowSize``), ``write``/``read`` through ``cv2.FileStorage``,
``__repr__``, equality of configuration and pickling.

Each :class:`Param` says what it takes (``kind``, ``choices``, ``optional``) and what it
means (``doc``), so that the command line builds its options from these fields alone; the
validator factories (:func:`integer`, :func:`real`, :func:`boolean`, :func:`choice`) return
:class:`Check` objects carrying them, and every error a check raises has
:attr:`~hopmatch.errors.HopmatchError.argument` set to the parameter's name.
"""

from __future__ import annotations

import inspect
import numbers
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import cv2

from ._validate import as_flag, as_int, as_real
from .errors import FileReadError, HopmatchError, InvalidArgumentError, InvalidTypeError
from .files import MAX_TEXT_BYTES, atomic_path, check_input_file, check_storage_nesting

_NONE_MARK = "__none__"

#: Integers FileStorage stores as numbers: those of int32. Others are written as decimal
#: strings (some cv2 bindings write Python ints beyond int32 as ``true``, and every one
#: reads numbers back as float64, exact only within 2**53), and read back exactly.
_INT32 = (-(2**31), 2**31 - 1)
#: Largest integer a FileStorage number holds exactly (it is read as a float64).
_EXACT_INT = 2**53
_DECIMAL = re.compile(r"^[+-]?[0-9]+$")


#: The kinds of parameter value (:attr:`Param.kind`).
KINDS = ("int", "float", "bool", "choice", "text")


@dataclass(frozen=True)
class Check:
    """A parameter validator, as the factories :func:`integer`, :func:`real`,
    :func:`boolean` and :func:`choice` make it.

    ``check(name, value)`` returns the normalised value or raises a
    :class:`~hopmatch.errors.HopmatchError` whose :attr:`~hopmatch.errors.HopmatchError.argument`
    is ``name``. The attributes say what it accepts, so that callers (the command line, the
    docs) need not guess it by trying values.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`: ``"int"``, ``"float"``, ``"bool"``, ``"choice"`` (one of
        ``choices``) or ``"text"``.
    func : callable
        ``func(name, value) -> value``, the check itself.
    choices : tuple of str
        The accepted values of a ``"choice"``; empty otherwise.
    optional : bool
        None is accepted (and kept).
    lo, hi : number or None
        The bounds of an ``"int"`` or ``"float"`` (None: int64's or the float range);
        ``lo_open``: ``lo`` itself is refused.
    """

    kind: str
    func: Callable[[str, Any], Any]
    choices: tuple = ()
    optional: bool = False
    lo: Any = None
    hi: Any = None
    lo_open: bool = False

    def __call__(self, name: str, value):
        try:
            return self.func(name, value)
        except HopmatchError as exc:
            if exc.argument is None:
                exc.argument = name
            raise


@dataclass(frozen=True)
class Param:
    """One parameter: its name, default and a validator returning the normalised value.

    Attributes
    ----------
    name : str
        The keyword (``window_size``); accessors are ``getWindowSize``/``setWindowSize``.
    default : object
        The value when not given (None: unset, for optional parameters).
    check : callable
        ``check(name, value) -> normalised value``; a :class:`Check` from one of the
        factories (:func:`integer`, :func:`real`, :func:`boolean`, :func:`choice`) or any
        function raising :class:`~hopmatch.errors.HopmatchError`.
    doc : str
        One-paragraph description. When empty, :class:`Configurable` subclasses fill it
        from the ``Parameters`` section of their numpydoc docstring.
    kind, choices, optional
        As :class:`Check`'s; taken from ``check`` when it is one, else ``kind`` follows the
        type of ``default`` (``"text"`` when None) unless given.
    """

    name: str
    default: Any
    check: Callable[[str, Any], Any]
    doc: str = ""
    kind: str = ""
    choices: tuple = ()
    optional: bool | None = None

    def __post_init__(self):
        check = self.check if isinstance(self.check, Check) else None
        kind = self.kind or (check.kind if check else _kind_of(self.default))
        if kind not in KINDS:
            raise InvalidArgumentError(f"`kind` must be one of {list(KINDS)}, got {kind!r}",
                                       argument="kind")
        object.__setattr__(self, "kind", kind)
        if not self.choices and check:
            object.__setattr__(self, "choices", check.choices)
        if self.optional is None:
            object.__setattr__(self, "optional", check.optional if check else self.default is None)


def _kind_of(default) -> str:
    if isinstance(default, bool):
        return "bool"
    if isinstance(default, numbers.Integral):
        return "int"
    if isinstance(default, numbers.Real):
        return "float"
    return "text"


def camel(name: str) -> str:
    """``window_size`` -> ``WindowSize``."""
    return "".join(part[:1].upper() + part[1:] for part in name.split("_"))


def numpydoc_parameters(doc: str | None) -> dict[str, str]:
    """The description of each name of the numpydoc ``Parameters`` section of ``doc``, on
    one line, without double backticks (``"a, b : int"`` gives both names the text)."""
    out, names, text, inside = {}, [], [], False

    def flush():
        description = " ".join(text).replace("``", "").strip()
        for n in names:
            out[n] = description

    for line in inspect.cleandoc(doc or "").splitlines():
        stripped = line.strip()
        if stripped == "Parameters":
            inside = True
            continue
        if not inside or set(stripped) == {"-"}:
            continue
        indent = len(line) - len(line.lstrip())
        if stripped and indent == 0 and " : " in stripped:
            flush()
            names = [n.strip() for n in stripped.split(" : ")[0].split(",")]
            text = []
        elif stripped and indent == 0:  # next section
            break
        elif stripped:
            text.append(stripped)
    flush()
    return out


# -- validators --------------------------------------------------------------------------


def integer(lo: int | None = None, hi: int | None = None, *, odd: bool = False,
            optional=False) -> Check:
    """A parameter check: an integer in ``[lo, hi]`` (and int64), see :func:`as_int`."""
    def check(name, value):
        return as_int(value, name, lo=lo, hi=hi, odd=odd, optional=optional)

    return Check("int", check, optional=bool(optional), lo=lo, hi=hi)


def real(lo=None, hi=None, *, lo_open=False, optional=False) -> Check:
    """A parameter check: a finite number in ``[lo, hi]``, see :func:`as_real`."""
    def check(name, value):
        return as_real(value, name, lo=lo, hi=hi, lo_open=lo_open, optional=optional)

    return Check("float", check, optional=bool(optional), lo=lo, hi=hi, lo_open=lo_open)


def boolean() -> Check:
    """A parameter check: :func:`~hopmatch._validate.as_flag` (True, False, NumPy's bools,
    and the integers 0 and 1, as FileStorage stores booleans)."""
    return Check("bool", lambda name, value: as_flag(value, name))


def choice(*options: str) -> Check:
    """A parameter check: one of the strings ``options``."""
    def check(name, value):
        if not isinstance(value, str):
            raise InvalidTypeError(f"`{name}` must be one of {list(options)}, got {value!r}")
        if value not in options:
            raise InvalidArgumentError(f"`{name}` must be one of {list(options)}, got {value!r}")
        return value

    return Check("choice", check, choices=tuple(options))


# -- the base class ----------------------------------------------------------------------


class Configurable:
    """Base of the cv2-like classes. Subclasses set ``PARAMS`` and ``DEFAULT_NAME``."""

    PARAMS: tuple[Param, ...] = ()
    DEFAULT_NAME: str = "hopmatch_Configurable"
    #: Named parameter sets (a ``preset`` parameter selects one); explicit keywords win.
    PRESETS: dict[str, dict[str, Any]] = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "PARAMS" in cls.__dict__:  # a Param without doc takes the class docstring's text
            docs = numpydoc_parameters(cls.__doc__)
            if any(not p.doc and docs.get(p.name) for p in cls.PARAMS):
                cls.PARAMS = tuple(
                    replace(p, doc=docs[p.name]) if not p.doc and docs.get(p.name) else p
                    for p in cls.PARAMS)
        for p in cls.PARAMS:
            getter_name, setter_name = "get" + camel(p.name), "set" + camel(p.name)
            if getter_name not in cls.__dict__:
                setattr(cls, getter_name, _make_getter(p.name))
            if setter_name not in cls.__dict__:
                setattr(cls, setter_name, _make_setter(p.name))

    def _init_params(self, params: dict[str, Any]) -> None:
        self._params = resolve_params(self.PARAMS, self.PRESETS, params, type(self).__name__)
        self._check_consistency()

    def _set_param(self, name: str, value) -> None:
        spec = next(p for p in self.PARAMS if p.name == name)
        self._params[name] = spec.check(name, value)

    def _check_consistency(self) -> None:
        """Checks across parameters (subclasses override)."""

    def _on_params_changed(self) -> None:
        """Called after a setter changed a parameter (subclasses override)."""

    @classmethod
    def create(cls, **params):
        """cv2-style factory: ``X.create(**params)`` is ``X(**params)``."""
        return cls(**params)

    def get_params(self) -> dict[str, Any]:
        """All parameters as a dict (a copy)."""
        return dict(self._params)

    def getDefaultName(self) -> str:  # noqa: N802 (cv2 naming)
        """The name used as the FileStorage node (no dot, as FileStorage keys cannot hold one)."""
        return self.DEFAULT_NAME

    # -- FileStorage ---------------------------------------------------------------------
    def write(self, fs, name: str | None = None) -> None:
        """Write every parameter to ``fs``: a path (``.yml``, ``.yaml``, ``.xml``, ``.json``)
        or an open ``cv2.FileStorage``. A path is written atomically (temporary file, then
        rename), so a failed write never leaves a half-written file; a folder that cannot
        be written raises :class:`~hopmatch.errors.FileWriteError` naming ``path``.

        Every value round-trips exactly through :meth:`read`: integers outside int32 are
        stored as decimal strings (``seed: "9223372036854775807"``), floats with 17
        significant digits."""
        node = name or self.getDefaultName()
        if isinstance(fs, (str, os.PathLike)):
            path = Path(fs)
            if path.suffix.lower() not in (".yml", ".yaml", ".xml", ".json"):
                raise InvalidArgumentError(
                    f"`fs` path must end in .yml, .yaml, .xml or .json, got {str(path)!r}"
                )
            if not path.parent.is_dir():
                raise InvalidArgumentError(f"`fs`: folder {str(path.parent)!r} does not exist",
                                           argument="fs")
            with atomic_path(path, "fs") as tmp:
                out = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
                self._write_node(out, node)
                out.release()
            return
        if not isinstance(fs, cv2.FileStorage):
            raise InvalidTypeError(
                f"`fs` must be a path or a cv2.FileStorage, got {type(fs).__name__}")
        if not fs.isOpened():
            raise InvalidArgumentError("`fs` is a cv2.FileStorage that is not open for writing")
        try:
            self._write_node(fs, node)
        except cv2.error:  # opened for reading: OpenCV asserts write_mode
            raise InvalidArgumentError(
                "`fs` is a cv2.FileStorage open for reading, not writing (open it with "
                "cv2.FILE_STORAGE_WRITE)", argument="fs") from None

    def _write_node(self, fs, node: str) -> None:
        fs.startWriteStruct(node, cv2.FileNode_MAP)
        fs.write("format", 1)
        for p in self.PARAMS:
            value = self._params[p.name]
            if value is None:
                fs.write(p.name, _NONE_MARK)
            elif isinstance(value, bool):
                fs.write(p.name, int(value))
            elif isinstance(value, int):
                if _INT32[0] <= value <= _INT32[1]:
                    fs.write(p.name, int(value))
                else:
                    fs.write(p.name, str(int(value)))
            elif isinstance(value, float):
                fs.write(p.name, float(value))
            else:
                fs.write(p.name, str(value))
        fs.endWriteStruct()

    def read(self, fs, name: str | None = None) -> None:
        """Read parameters written by :meth:`write` from a path, a ``cv2.FileStorage`` or a
        ``cv2.FileNode``. Values are validated as if passed to the constructor."""
        node_name = name or self.getDefaultName()
        if isinstance(fs, (str, os.PathLike)):
            try:
                check_input_file(fs, MAX_TEXT_BYTES, argument="fs")
                check_storage_nesting(fs, argument="fs")
            except FileReadError as exc:
                if exc.problem == "no such file":  # the words of before
                    raise InvalidArgumentError(f"`fs`: no such file {str(fs)!r}",
                                               argument="fs") from None
                raise InvalidArgumentError(f"`fs`: {str(fs)!r} {exc.problem}",
                                           argument="fs") from None
            try:
                storage = cv2.FileStorage(str(fs), cv2.FILE_STORAGE_READ)
            except (cv2.error, SystemError) as exc:  # SystemError: some cv2 builds on garbage
                detail = getattr(exc, "err", None) or str(exc)
                raise InvalidArgumentError(f"`fs`: {str(fs)!r} is not a readable FileStorage file: "
                                           f"{detail}") from None
            try:
                self.read(storage, name)
            finally:
                storage.release()
            return
        if isinstance(fs, cv2.FileStorage):
            root = fs.root()  # getNode() of a root that is not a map is a cv2.error
            node = fs.getNode(node_name) if root.isMap() else root
            if not root.isMap() or node.empty():
                node = root
                if not node.isMap() or node.getNode(self.PARAMS[0].name).empty():
                    raise InvalidArgumentError(f"`fs` holds no node named {node_name!r}",
                                               argument="fs")
        elif isinstance(fs, cv2.FileNode):
            node = fs
        else:
            raise InvalidTypeError(
                f"`fs` must be a path, a cv2.FileStorage or a cv2.FileNode, got {type(fs).__name__}"
            )
        if not node.isMap():
            raise InvalidTypeError(
                f"`fs`: node {node_name!r} holds {_node_kind(node)}; expected a map of "
                f"parameters (see {type(self).__name__}().write(path) for the format)",
                argument="fs")
        values = {}
        for p in self.PARAMS:
            sub = node.getNode(p.name)
            if sub.empty():
                continue
            if sub.isString():
                text = sub.string()
                values[p.name] = None if text == _NONE_MARK else text
                if p.kind == "int" and _DECIMAL.match(text):
                    values[p.name] = int(text)  # beyond int32, as write() stores it
            elif sub.isInt():
                number = sub.real()
                if p.kind == "int" and abs(number) >= _EXACT_INT:  # 2**53 + 1 reads as 2**53
                    raise InvalidArgumentError(
                        f"`fs`: parameter `{p.name}` holds the integer {number:.17g}, beyond "
                        f"the 2**53 that cv2.FileStorage reads exactly; write it as a string "
                        f"(\"{int(number)}\"), as {type(self).__name__}().write() does",
                        argument="fs")
                values[p.name] = int(number)
            elif sub.isReal():
                values[p.name] = float(sub.real())
                if p.kind == "int" and values[p.name].is_integer() \
                        and abs(values[p.name]) <= _EXACT_INT:
                    values[p.name] = int(values[p.name])  # "5." or "5.0" for an integer
            else:  # a sequence, a map or an empty value: not a parameter value
                kind = _node_kind(sub)
                raise InvalidTypeError(
                    f"`fs`: parameter `{p.name}` holds {kind}; expected a single number or "
                    f"string (see {type(self).__name__}().write(path) for the format)"
                )
            if isinstance(p.default, float) and isinstance(values[p.name], int):
                values[p.name] = float(values[p.name])
            # booleans are stored as 0/1 and checked by the parameter's own validator, which
            # refuses any other integer
        merged = dict(self._params)
        merged.update(values)
        old = self._params
        try:
            self._init_params(merged)
        except Exception:
            self._params = old  # a bad file leaves the object as it was
            raise

    # -- cv2.Algorithm housekeeping ------------------------------------------------------
    def save(self, filename) -> None:
        """``cv2.Algorithm.save``: :meth:`write` to a ``.yml``/``.yaml``/``.xml``/``.json``
        file, under :meth:`getDefaultName`."""
        self.write(filename)

    def load(self, filename) -> None:
        """Read the parameters :meth:`save` wrote (see :meth:`read`)."""
        self.read(filename)

    def clear(self) -> None:
        """``cv2.Algorithm.clear``: nothing to forget here (subclasses that keep data
        between calls override it)."""

    # -- Python protocols ----------------------------------------------------------------
    def __repr__(self) -> str:
        defaults = {p.name: p.check(p.name, p.default) if p.default is not None else None
                    for p in self.PARAMS}
        changed = ", ".join(
            f"{p.name}={self._params[p.name]!r}" for p in self.PARAMS
            if self._params[p.name] != defaults[p.name]
        )
        return f"{type(self).__name__}({changed})"

    def __getstate__(self):
        return {"params": dict(self._params)}

    def __setstate__(self, state):
        self._init_params(state_params(self, state))


def _node_kind(node) -> str:
    """What a FileNode holds, in words."""
    if node.isSeq():
        return "a sequence"
    if node.isMap():
        return "a map"
    if node.isString():
        return "a string"
    if node.isInt() or node.isReal():
        return "a number"
    return "no value"


def state_params(obj, state) -> dict:
    """The parameter dict of a pickled state, checked (a corrupt or foreign pickle raises
    :class:`InvalidArgumentError` instead of a KeyError)."""
    if not isinstance(state, dict) or not isinstance(state.get("params"), dict):
        raise InvalidArgumentError(
            f"cannot restore a {type(obj).__name__} from {type(state).__name__} state: "
            "expected {'params': {...}} as written by pickling one"
        )
    return state["params"]




def _make_getter(name):
    def getter(self):
        return self._params[name]

    getter.__name__ = "get" + camel(name)
    getter.__doc__ = f"Return ``{name}``."
    return getter


def _make_setter(name):
    def setter(self, value):
        old = dict(self._params)
        self._set_param(name, value)
        if name == "preset":  # a preset sets its whole parameter set
            for key, preset_value in self.PRESETS.get(self._params["preset"], {}).items():
                self._set_param(key, preset_value)
        try:
            self._check_consistency()
        except Exception:
            self._params = old
            raise
        self._on_params_changed()

    setter.__name__ = "set" + camel(name)
    setter.__doc__ = f"Set ``{name}`` (validated as in the constructor)."
    return setter


def resolve_params(specs: tuple[Param, ...], presets: dict[str, dict[str, Any]],
                   values: dict[str, Any], owner: str) -> dict[str, Any]:
    """Every parameter of ``specs``, checked: the defaults, then the values of the preset
    that ``values["preset"]`` names (if given), then ``values`` themselves (explicit keywords
    win). Unknown names raise :class:`InvalidArgumentError` naming ``owner``."""
    by_name = {p.name: p for p in specs}
    unknown = sorted(set(values) - set(by_name))
    if unknown:
        raise InvalidArgumentError(
            f"{owner} got unknown parameter(s) {unknown}; valid parameters are "
            f"{sorted(by_name)}"
        )
    out = {p.name: p.check(p.name, p.default) if p.default is not None else None
           for p in specs}
    if "preset" in values:
        out["preset"] = by_name["preset"].check("preset", values["preset"])
        for name, value in presets.get(out["preset"], {}).items():
            out[name] = by_name[name].check(name, value)
    for name, value in values.items():
        out[name] = by_name[name].check(name, value)
    return out
