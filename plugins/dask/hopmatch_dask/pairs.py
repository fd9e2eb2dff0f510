"""Pairs to match: the :class:`Pair` record and the PAIRS.csv reader."""

from __future__ import annotations

import csv
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hopmatch.errors import FileReadError, InvalidArgumentError, InvalidTypeError
from hopmatch.files import MAX_FILE_BYTES, read_input_bytes

__all__ = ["Pair", "PairsFileError", "as_pairs", "read_pairs"]

#: Names become file names: letters, digits, '.', '_', '-'; not starting with '.'.
_NAME = re.compile(r"^[A-Za-z0-9_-][A-Za-z0-9._-]*$")
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


def check_name(name: str, where: str = "name") -> str:
    """``name`` if it can name a result file, else ``InvalidArgumentError`` saying why."""
    if not isinstance(name, str) or not _NAME.match(name):
        raise InvalidArgumentError(
            f"{where}: {name!r} cannot name a result file; use letters, digits, '.', '_' and "
            "'-' (not starting with '.')"
        )
    if name.lower() in _RESERVED:
        raise InvalidArgumentError(f"{where}: {name!r} is reserved (DIR/summary.csv is the "
                                   "batch summary); choose another name")
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
                "own name (add a `name` column)"
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
    path = Path(path)
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
    rows = list(csv.reader(text.splitlines()))
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
            "hopmatch_dask.read_pairs(path)"
        )
    out = []
    for i, item in enumerate(pairs):
        if isinstance(item, Pair):
            out.append(item)
            continue
        if not isinstance(item, (tuple, list)) or len(item) not in (2, 3):
            raise InvalidTypeError(
                f"`pairs[{i}]` must be a Pair or a (left, right[, name]) tuple, got "
                f"{type(item).__name__}"
            )
        left, right = (os.fspath(v) if isinstance(v, os.PathLike) else v for v in item[:2])
        name = item[2] if len(item) == 3 else f"pair-{i:04d}"
        out.append(Pair(check_name(name, f"`pairs[{i}]`"), left, right))
    _unique([p.name for p in out], [f"`pairs[{i}]`" for i in range(len(out))])
    return out
