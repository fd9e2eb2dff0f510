"""Pairs to match: the :class:`Pair` record and the PAIRS.csv reader."""

from __future__ import annotations

import csv
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hopmatch.errors import FileReadError, InvalidArgumentError, InvalidTypeError
from hopmatch.files import MAX_FILE_BYTES, NAME_MAX, read_input_bytes

__all__ = ["MAX_NAME_BYTES", "Pair", "PairsFileError", "as_pairs", "check_name",
           "read_pairs"]

#: Names become file names: letters, digits, '.', '_', '-'; not starting with '.'.
_NAME = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]*\Z")
#: Longest pair name: ``<name>.csv`` is a file name of at most ``NAME_MAX`` (255) bytes.
MAX_NAME_BYTES = NAME_MAX - len(".csv")
_RESERVED = {"summary"}
_COLUMNS = ("left", "right", "name")


class PairsFileError(InvalidArgumentError):
    """PAIRS.csv cannot be used; the message names the file and the line."""


@dataclass(frozen=True)
class Pair:
    """One rectified pair: ``left`` and ``right`` are image paths (read on the worker) or
    arrays; ``name`` names its result (``<name>.csv`` in a batch)."""

    name: str
    left: Any
    right: Any


def _shown(name) -> str:
    """``repr(name)``, cut to 60 characters for a message."""
    text = repr(name)
    return text if len(text) <= 60 else text[:57] + "..."


def check_name(name: str, where: str = "name", argument: str = "name") -> str:
    """``name`` if it can name a result file, else ``InvalidTypeError`` (not a str) or
    ``InvalidArgumentError`` saying why.

    A name is at most :data:`MAX_NAME_BYTES` characters of letters, digits, '.', '_' and
    '-', not starting with '.', and not ``summary`` (any case).

    Examples
    --------
    >>> check_name("scene-01")
    'scene-01'
    >>> try:
    ...     check_name("../up", "`pairs[0]`")
    ... except ValueError as exc:
    ...     print(exc.argument, "|", str(exc)[:45])
    name | `pairs[0]`: '../up' cannot name a result file
    """
    if not isinstance(name, str):
        raise InvalidTypeError(f"{where}: the name must be a str (it names the result file "
                               f"<name>.csv), got {type(name).__name__} {_shown(name)}",
                               argument=argument)
    if len(name.encode("utf-8", "surrogatepass")) > MAX_NAME_BYTES:
        raise InvalidArgumentError(
            f"{where}: the name {_shown(name)} is {len(name.encode('utf-8', 'surrogatepass'))}"
            f" bytes long; a name is at most {MAX_NAME_BYTES} (<name>.csv is a file name, "
            f"of at most {NAME_MAX} bytes)", argument=argument)
    if not _NAME.match(name):
        raise InvalidArgumentError(
            f"{where}: {_shown(name)} cannot name a result file; use letters, digits, '.', "
            "'_' and '-' (not starting with '.')", argument=argument)
    if name.lower() in _RESERVED:
        raise InvalidArgumentError(f"{where}: {name!r} is reserved (DIR/summary.csv is the "
                                   "batch summary); choose another name", argument=argument)
    return name


def _default_names(lefts: list[str]) -> list[str]:
    """Each left path relative to the folder common to all, suffix dropped, '/' -> '_'."""
    paths = [Path(p) for p in lefts]
    try:
        common = Path(os.path.commonpath([str(p.parent) for p in paths])) if paths else Path()
    except ValueError:  # mixed drives (Windows)
        common = Path()
    names = []
    for p in paths:
        try:
            rel = p.with_suffix("").relative_to(common)
        except ValueError:
            rel = Path(p.stem)
        names.append(re.sub(r"[^A-Za-z0-9._-]", "_", "_".join(rel.parts)).lstrip(".") or "pair")
    return names


def _unique(names: list[str], where: list[str]) -> None:
    seen: dict[str, str] = {}
    for name, at in zip(names, where):
        key = name.lower()  # case-insensitive file systems
        if key in seen:
            raise InvalidArgumentError(
                f"{at}: the name {name!r} is already used ({seen[key]}); every pair needs its "
                "own name (add a `name` column)", argument="pairs"
            )
        seen[key] = at


def read_pairs(path) -> list[Pair]:
    """Read PAIRS.csv: a header ``left,right[,name]``, then one pair per line.

    Relative image paths are taken relative to the CSV file's folder and returned absolute.
    Without a ``name`` column (or with an empty cell), a pair is named after its left image:
    its path relative to the folder common to all left images, suffix dropped, ``/`` -> ``_``
    (``scenes/a/im0.png``, ``scenes/b/im0.png`` -> ``a_im0``, ``b_im0``).

    Raises
    ------
    PairsFileError
        Missing or unreadable file, wrong header, empty cell, bad or repeated name; the
        message starts with ``<path> line N:`` where it can.
    """
    text_path = os.fspath(path) if isinstance(path, os.PathLike) else path
    if not isinstance(text_path, str):
        raise InvalidTypeError(f"`path` must be the path of PAIRS.csv (str or os.PathLike), "
                               f"got {type(path).__name__} {_shown(path)}", argument="path")
    if not text_path or "\0" in text_path:
        raise PairsFileError(f"{text_path!r}: is not a file name", argument="path")
    path = Path(text_path)
    label = str(path)
    try:  # a regular file of at most 1 GiB: a named pipe or a device is refused unopened
        text = read_input_bytes(path, MAX_FILE_BYTES).decode("utf-8-sig")
    except FileReadError as exc:
        problem = {"no such file": "no such file",
                   "is a folder, not a file": "is a folder, not a CSV file"}.get(exc.problem,
                                                                               exc.problem)
        raise PairsFileError(f"{label}: {problem}") from None
    except UnicodeDecodeError as exc:
        raise PairsFileError(f"{label}: cannot read the file: {exc}") from None
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    reader = csv.reader(text.splitlines())
    rows = []
    try:
        for row in reader:
            rows.append(row)
    except csv.Error as exc:  # a cell over the csv module's field limit (128 KiB)...
        raise PairsFileError(f"{label} line {reader.line_num}: cannot be read as CSV "
                             f"({exc}); is it a PAIRS.csv file?", argument="path") from None
    numbered = [(i + 1, [c.strip() for c in row]) for i, row in enumerate(rows)
                if any(c.strip() for c in row)]
    if not numbered:
        raise PairsFileError(f"{label}: is empty; expected a header line `left,right[,name]`")
    header_line, header = numbered[0]
    unknown = [c for c in header if c not in _COLUMNS]
    if unknown or "left" not in header or "right" not in header or len(set(header)) != len(header):
        raise PairsFileError(
            f"{label} line {header_line}: the header must name the columns left,right and "
            f"optionally name (in any order), got {','.join(header)!r}"
        )
    col = {c: header.index(c) for c in header}
    base = path.parent
    lefts, rights, names, where = [], [], [], []
    for line, row in numbered[1:]:
        at = f"{label} line {line}"
        if len(row) != len(header):
            raise PairsFileError(f"{at}: expected {len(header)} cells "
                                 f"({','.join(header)}), got {len(row)}")
        for c in ("left", "right"):
            if not row[col[c]]:
                raise PairsFileError(f"{at}: the `{c}` cell is empty")
        lefts.append(str((base / row[col["left"]]).absolute()))
        rights.append(str((base / row[col["right"]]).absolute()))
        names.append(row[col["name"]] if "name" in col else "")
        where.append(at)
    if not lefts:
        raise PairsFileError(f"{label}: holds a header but no pair")
    defaults = _default_names(lefts)
    names = [n or d for n, d in zip(names, defaults)]
    try:
        for n, at in zip(names, where):
            check_name(n, at)
        _unique(names, where)
    except InvalidArgumentError as exc:
        raise PairsFileError(str(exc)) from None
    return [Pair(n, l, r) for n, l, r in zip(names, lefts, rights)]


def as_pairs(pairs) -> list[Pair]:
    """``pairs`` (``Pair``, ``(left, right)`` or ``(left, right, name)`` items) as a list of
    :class:`Pair`; unnamed pairs are named ``pair-0000``, ``pair-0001``... by position.

    Examples
    --------
    >>> [p.name for p in as_pairs([("a/l.png", "a/r.png"), ("b/l.png", "b/r.png", "b")])]
    ['pair-0000', 'b']
    """
    if isinstance(pairs, (str, bytes, os.PathLike)):
        raise InvalidTypeError(
            "`pairs` must be a sequence of (left, right[, name]) items; to read PAIRS.csv use "
            "hopmatch_dask.read_pairs(path)", argument="pairs"
        )
    if isinstance(pairs, (Pair, Mapping, np.ndarray)) or not isinstance(pairs, Iterable):
        raise InvalidTypeError(
            f"`pairs` must be a sequence of Pair or (left, right[, name]) items, got "
            f"{type(pairs).__name__} {_shown(pairs)}", argument="pairs")
    out = []
    for i, item in enumerate(pairs):
        where = f"`pairs[{i}]`"
        if isinstance(item, Pair):
            name, left, right = item.name, item.left, item.right
        elif isinstance(item, (tuple, list)) and len(item) in (2, 3):
            left, right = item[:2]
            name = item[2] if len(item) == 3 else f"pair-{i:04d}"
        else:
            raise InvalidTypeError(
                f"{where} must be a Pair or a (left, right[, name]) tuple, got "
                f"{type(item).__name__}" + (f" of {len(item)} items"
                                            if isinstance(item, (tuple, list)) else ""),
                argument="pairs")
        check_name(name, where, argument="pairs")
        left, right = _image_item(left, where, "left"), _image_item(right, where, "right")
        if isinstance(item, Pair) and left is item.left and right is item.right:
            out.append(item)
        else:
            out.append(Pair(name, left, right))
    _unique([p.name for p in out], [f"`pairs[{i}]`" for i in range(len(out))])
    return out


def _image_item(value, where: str, side: str):
    """An image of a pair: a path (str, or os.PathLike as str) or a numpy array."""
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if isinstance(value, np.ndarray):
        return value
    if not isinstance(value, str):
        raise InvalidTypeError(f"{where}: the {side} image must be a path (str or "
                               "os.PathLike) or a numpy array, got "
                               f"{type(value).__name__} {_shown(value)}", argument="pairs")
    if not value or "\0" in value:
        raise InvalidArgumentError(f"{where}: the {side} image path {_shown(value)} is not a "
                                   "file name", argument="pairs")
    return value
