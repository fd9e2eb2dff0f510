"""One command-line option per parameter of the classes, generated from their ``PARAMS``.

Each :class:`~hopmatch._params.Param` says its ``kind`` (``int``, ``float``, ``bool``,
``choice``, ``text``), its ``choices``, whether it is ``optional`` and its ``doc``; the
option is built from these fields and its value checked by the parameter's own validator,
so that the command line accepts exactly what the Python API accepts.
"""

from __future__ import annotations

import click

from ..feature.detector import DericheMoravecDetector
from .reporting import plain_text, strip_name

__all__ = ["NONE", "ParamType", "PlainIntRange", "given_parameters", "option_name", "param_labels",
           "parameter_options", "plain_number"]

#: The value of ``--param none``: set an optional parameter to None.
NONE = object()

_METAVARS = {"int": "INT", "float": "FLOAT"}
_TYPE_NAMES = {"int": "integer", "float": "number"}


def option_name(name: str) -> str:
    """``window_size`` -> ``--window-size``."""
    return "--" + name.replace("_", "-")


def plain_number(text: str, kind: str):
    """``text`` (stripped) as an int (``kind`` "int") or a float, or None when it is not
    one. Python's ``int()`` and ``float()`` also read ``"1_0"`` as 10 and the digits of
    other scripts: an option takes plain ASCII numbers only."""
    if not text.isascii() or "_" in text:
        return None
    try:
        return int(text) if kind == "int" else float(text)
    except ValueError:
        return None


class PlainIntRange(click.IntRange):
    """:class:`click.IntRange` that takes plain ASCII integers only (:func:`plain_number`)."""

    def convert(self, value, param, ctx):  # noqa: D102 (click API)
        if isinstance(value, str) and plain_number(value.strip(), "int") is None:
            self.fail(f"{value!r} is not an integer", param, ctx)
        return super().convert(value, param, ctx)


class ParamType(click.ParamType):
    """Parses a string as the parameter's kind and runs the parameter's own validator."""

    def __init__(self, spec):
        self.spec = spec
        self.kind = spec.kind
        self.optional = spec.optional
        self.choices = spec.choices or None
        self.name = _TYPE_NAMES.get(self.kind, "text")

    def get_metavar(self, param, ctx=None):  # noqa: D102 (click API)
        if self.choices:
            return "[" + "|".join(self.choices) + "]"
        return _METAVARS.get(self.kind, "TEXT")

    def convert(self, value, param, ctx):  # noqa: D102 (click API)
        if value is NONE:
            return value
        if isinstance(value, str):
            text = value.strip()
            if self.optional and text.lower() == "none":
                return NONE
            if self.kind in ("int", "float"):
                number = plain_number(text, self.kind)
                if number is None:
                    self.fail(f"{value!r} is not " + ("an integer" if self.kind == "int"
                                                      else "a number"))
                value = number
        try:
            return self.spec.check(self.spec.name, value)
        except (TypeError, ValueError) as exc:
            self.fail(strip_name(str(exc), getattr(exc, "argument", None) or self.spec.name))


def _unique_specs(*classes):
    seen = {}
    for cls in classes:
        for spec in cls.PARAMS:
            seen.setdefault(spec.name, (spec, cls))
    return list(seen.values())


def _help(spec, cls, labels: dict) -> str:
    """The option's help: the parameter's ``doc`` as plain text (parameter names written as
    options), then ``[owner; default X]``."""
    shown = "None" if spec.default is None else repr(spec.default)
    if spec.name == "preset":
        text = ("Named parameter set of detector and matcher: 'paper' gives the paper's "
                f"section 4 settings; explicit options win [default {shown}")
    else:
        owner = "detector" if cls is DericheMoravecDetector else "matcher"
        doc = plain_text(spec.doc, labels).rstrip(".") if spec.doc else ""
        text = (doc + ". " if doc else "") + f"[{owner}; default {shown}"
    if spec.kind != "bool" and spec.optional:
        text += "; 'none' for None"
    return text + "]"


def parameter_options(*classes):
    """A decorator adding one option per parameter of ``classes`` (default None = not given;
    read the values with :func:`given_parameters`). Plugins' commands use it too, so that
    every command spells the options the same way.

    A parameter shared by several classes (``preset``) gets one option, described by the
    first class that has it. A ``bool`` parameter is a flag pair ``--name/--no-name``.
    """

    labels = param_labels(*classes)

    def decorate(func):
        for spec, cls in reversed(_unique_specs(*classes)):
            text = _help(spec, cls, labels)
            if spec.kind == "bool":
                name = spec.name.replace("_", "-")
                opt = click.option(f"--{name}/--no-{name}", spec.name, default=None, help=text)
            else:
                opt = click.option(option_name(spec.name), spec.name, type=ParamType(spec),
                                   default=None, help=text)
            func = opt(func)
        return func

    return decorate


def given_parameters(kwargs: dict, *classes) -> dict:
    """The parameters of ``classes`` given on the command line (None = not given), those
    of the first class first; ``--param none`` gives None."""
    out = {}
    for cls in classes:
        names = {p.name for p in cls.PARAMS}
        out.update({k: (None if v is NONE else v) for k, v in kwargs.items()
                    if k in names and v is not None})
    return out


def param_labels(*classes) -> dict:
    """``{parameter name: option}`` of ``classes``, for :func:`~hopmatch.cli.reporting.explain`."""
    return {p.name: option_name(p.name) for cls in classes for p in cls.PARAMS}
