"""Readers of stereo calibration files: Middlebury ``calib.txt`` (``cam0=[...]`` lines) and
KITTI ``calib.txt`` / ``calib_cam_to_cam`` style (``P0: ...`` lines).

Each raises :class:`hopmatch.errors.FileReadError` (an ``InvalidArgumentError``) naming the
file and what was expected when it is missing, unreadable or malformed, a value that is not
a finite number and a focal length or baseline that is not positive included
(``"<path>: not a valid <what> file: <problem>"``, as
:func:`hopmatch.datasets.readers.malformed_file` words it).
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ..files import MAX_TEXT_BYTES
from .readers import existing_file, malformed_file, read_text_file

__all__ = ["read_calibration", "read_kitti_calib", "read_middlebury_calib"]

def _check_finite(value, p: Path, what: str, where: str) -> None:
    """Refuse a number or matrix of the ``what`` file ``p`` holding NaN or an infinity
    (``float`` reads ``nan``, ``inf`` and numbers beyond the float range as such);
    ``where`` names the field."""
    arr = np.asarray(value, dtype=np.float64)
    bad = arr[~np.isfinite(arr)]
    if bad.size:
        raise malformed_file(p, what, f"{where} holds {float(bad[0])!r}, not a finite number")


def _check_positive(value: float, p: Path, what: str, where: str) -> float:
    """``value`` (a focal length or baseline of the ``what`` file ``p``, named by
    ``where``) when it is finite and > 0; else a :class:`FileReadError`."""
    if not (math.isfinite(value) and value > 0):
        raise malformed_file(p, what, f"{where} is {value!r}; it must be a finite number > 0")
    return value


def _parse_matrix(text: str, path, key: str) -> np.ndarray:
    rows = [r.split() for r in text.strip().split(";")]
    if any(len(r) != len(rows[0]) for r in rows):
        raise malformed_file(path, "Middlebury calibration", f"the rows of `{key}` have "
                             f"different lengths ({[len(r) for r in rows]})")
    try:
        return np.array([[float(v) for v in r] for r in rows], dtype=np.float64)
    except ValueError:
        raise malformed_file(path, "Middlebury calibration", f"`{key}` must be a matrix "
                             f"like '[f 0 cx; 0 f cy; 0 0 1]', got {text[:80]!r}") from None


def read_middlebury_calib(path) -> dict:
    """Read a Middlebury 2014 / MiddEval3 ``calib.txt``.

    Lines are ``key=value``; matrices are written ``[a b c; d e f; g h i]``::

        cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]
        cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]
        doffs=131.111
        baseline=193.001
        width=2964
        height=1988
        ndisp=280

    Depth is ``Z = baseline * f / (d + doffs)`` (baseline in mm gives Z in mm).

    Parameters
    ----------
    path : str or pathlib.Path
        The ``calib.txt`` file.

    Returns
    -------
    calib : dict
        Every key of the file: matrices as (3, 3) float64 ndarrays (``cam0``, ``cam1``),
        numbers as floats (``doffs``, ``baseline`` in mm, ``width``, ``height``,
        ``ndisp``, ``vmin``, ...). Added, derived from ``cam0``: ``focal_length``, ``cx``,
        ``cy`` (pixels).

    Raises
    ------
    FileReadError
        Missing file, a line without ``=``, a value that is neither a number nor a
        matrix, no 3x3 ``cam0`` / ``cam1``, a value that is not finite (``nan``, ``inf``,
        a number beyond the float range; the message names its key and line), or a focal
        length ``cam0[0, 0]`` or ``baseline`` that is not finite and > 0.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "calib.txt")
    >>> with open(path, "w") as f:
    ...     _ = f.write("cam0=[10 0 5; 0 10 4; 0 0 1]\\ncam1=[10 0 7; 0 10 4; 0 0 1]\\n"
    ...                 "doffs=2\\nbaseline=100\\nwidth=12\\nheight=9\\nndisp=16\\n")
    >>> c = read_middlebury_calib(path)
    >>> c["cam1"][0, 2], c["doffs"], c["focal_length"], c["ndisp"]
    (np.float64(7.0), 2.0, 10.0, 16.0)
    """
    p = existing_file(path, "Middlebury calibration", MAX_TEXT_BYTES)
    text = read_text_file(p, "Middlebury calibration")
    calib: dict = {}
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if "=" not in line:
            raise malformed_file(p, "Middlebury calibration",
                                 f"line {lineno}: expected 'key=value', got {line[:80]!r}")
        key, value = (s.strip() for s in line.split("=", 1))
        if value.startswith("["):
            if not value.endswith("]"):
                raise malformed_file(p, "Middlebury calibration",
                                     f"line {lineno}: matrix `{key}` is not closed with ']'")
            calib[key] = _parse_matrix(value[1:-1], p, key)
        else:
            try:
                calib[key] = float(value)
            except ValueError:
                raise malformed_file(p, "Middlebury calibration", f"line {lineno}: `{key}` "
                                     f"must be a number or a matrix, got {value[:80]!r}"
                                     ) from None
        _check_finite(calib[key], p, "Middlebury calibration", f"line {lineno}: `{key}`")
    for key in ("cam0", "cam1"):
        if not isinstance(calib.get(key), np.ndarray) or calib[key].shape != (3, 3):
            raise malformed_file(
                p, "Middlebury calibration", f"it must define `{key}` as a 3x3 matrix "
                "'[f 0 cx; 0 f cy; 0 0 1]'" + (f", got shape {calib[key].shape}" if key in
                                                calib and isinstance(calib[key], np.ndarray)
                                                else ""))
    what = "Middlebury calibration"
    calib["focal_length"] = _check_positive(float(calib["cam0"][0, 0]), p, what,
                                            "the focal length cam0[0, 0]")
    if isinstance(calib.get("baseline"), float):
        _check_positive(calib["baseline"], p, what, "`baseline`")
    calib["cx"] = float(calib["cam0"][0, 2])
    calib["cy"] = float(calib["cam0"][1, 2])
    return calib


def read_kitti_calib(path) -> dict:
    """Read a KITTI stereo ``calib.txt``: lines ``P0: p11 ... p34`` (3x4, row-major).

    Parameters
    ----------
    path : str or pathlib.Path
        The calibration file (KITTI stereo 2012 ``calib/*.txt``).

    Returns
    -------
    calib : dict
        ``P0`` .. ``P3`` as (3, 4) float64 ndarrays (0, 1: grey left/right; 2, 3: colour
        left/right); any other ``key: numbers`` line as a (3, 4) or (3, 3) array when it
        has 12 or 9 numbers, else a 1-D array. Derived for the grey pair P0/P1:
        ``focal_length`` and ``cx``, ``cy`` (pixels, from P0), and ``baseline`` in
        metres, ``(P0[0, 3] - P1[0, 3]) / P1[0, 0]``. Depth is
        ``Z = focal_length * baseline / d``.

    Raises
    ------
    FileReadError
        Missing file, a line that is not ``key: numbers``, or P0..P3 missing or not 12
        numbers; a value that is not finite (``nan``, ``inf``, a number beyond the float range;
        the message names its key and line), or a focal length ``P0[0, 0]``, ``P1[0, 0]``
        or a baseline that is not finite and > 0.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "calib.txt")
    >>> with open(path, "w") as f:
    ...     for i, tx in enumerate([0.0, -50.0, 4.0, -46.0]):
    ...         _ = f.write(f"P{i}: 100 0 60 {tx} 0 100 40 0 0 0 1 0\\n")
    >>> c = read_kitti_calib(path)
    >>> c["P1"].shape, c["focal_length"], c["baseline"]
    ((3, 4), 100.0, 0.5)
    """
    p = existing_file(path, "KITTI calibration", MAX_TEXT_BYTES)
    text = read_text_file(p, "KITTI calibration")
    calib: dict = {}
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line:
            continue
        key, sep, value = line.partition(":")
        try:
            if not sep:
                raise ValueError
            nums = np.array([float(v) for v in value.split()], dtype=np.float64)
        except ValueError:
            raise malformed_file(p, "KITTI calibration", f"line {lineno}: expected "
                                 f"'P0: 12 numbers', got {line[:80]!r}") from None
        key = key.strip()
        _check_finite(nums, p, "KITTI calibration", f"line {lineno}: `{key}`")
        if nums.size == 12:
            nums = nums.reshape(3, 4)
        elif nums.size == 9:
            nums = nums.reshape(3, 3)
        calib[key] = nums
    for key in ("P0", "P1", "P2", "P3"):
        if key not in calib or calib[key].shape != (3, 4):
            got = f"{calib[key].size} numbers" if key in calib else "nothing"
            raise malformed_file(p, "KITTI calibration", f"it must define `{key}` as a 3x4 "
                                 f"projection matrix (12 numbers), got {got}")
    p0, p1 = calib["P0"], calib["P1"]
    what = "KITTI calibration"
    calib["focal_length"] = _check_positive(float(p0[0, 0]), p, what, "the focal length P0[0, 0]")
    _check_positive(float(p1[0, 0]), p, what, "the focal length P1[0, 0]")
    calib["cx"] = float(p0[0, 2])
    calib["cy"] = float(p0[1, 2])
    with np.errstate(over="ignore", under="ignore"):  # refused below when not finite
        baseline = float((p0[0, 3] - p1[0, 3]) / p1[0, 0])
    calib["baseline"] = _check_positive(
        baseline, p, what, "the baseline (P0[0, 3] - P1[0, 3]) / P1[0, 0] (P1 is the right "
        "camera: P1[0, 3] = -f * baseline)")
    return calib


def read_calibration(path) -> dict:
    """Read a ``calib.txt`` of either format, told apart by its lines.

    A file with a ``P0:`` line is read with :func:`read_kitti_calib`, one with a
    ``cam0=`` line with :func:`read_middlebury_calib`.

    Parameters
    ----------
    path : str or pathlib.Path
        The calibration file.

    Returns
    -------
    calib : dict
        What the reader of its format returns.

    Raises
    ------
    FileReadError
        Missing or binary file, neither format, or as the reader of its format does.
    """
    p = existing_file(path, "calibration", MAX_TEXT_BYTES)
    head = read_text_file(p, "calibration")[:4096]
    if re.search(r"^\s*P0\s*:", head, re.M):
        return read_kitti_calib(p)
    if re.search(r"^\s*cam0\s*=", head, re.M):
        return read_middlebury_calib(p)
    raise malformed_file(p, "calibration", "it is neither KITTI ('P0: ...' lines) nor "
                         "Middlebury ('cam0=[...]' lines)")
