"""Readers of stereo ground-truth files: disparity maps, calibrations and scene images.

Every reader returns arrays in :mod:`hopmatch.datasets`'s conventions: disparity as a
float32 ``(H, W)`` array in pixels, for the left image, NaN where there is no ground truth;
images as ``cv2.imread`` gives them. Images are opened and decoded by
:func:`hopmatch.imageio.read_image`; the readers word its errors in their own terms.

Every reader raises :class:`hopmatch.errors.InvalidArgumentError` (a ``ValueError``)
naming the file and what was expected when a file is missing or malformed, and
:class:`hopmatch.errors.InvalidTypeError` when an argument has the wrong type.

References
----------
.. [1] D. Scharstein, R. Szeliski. A taxonomy and evaluation of dense two-frame stereo
       correspondence algorithms. IJCV 47(1/2/3):7-42, 2002.
.. [2] D. Scharstein et al. High-resolution stereo datasets with subpixel-accurate ground
       truth. GCPR 2014. (Middlebury 2014, PFM and ``calib.txt`` formats.)
.. [3] A. Geiger, P. Lenz, R. Urtasun. Are we ready for autonomous driving? The KITTI vision
       benchmark suite. CVPR 2012.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import cv2
import numpy as np

from .._validate import as_real, describe
from ..errors import FileReadError, InvalidArgumentError, InvalidTypeError
from ..files import (
    MAX_FILE_BYTES,
    MAX_TEXT_BYTES,
    check_input_file,
    read_input_bytes,
    read_input_text,
)
from ..imageio import ImageReadError, read_image

__all__ = [
    "as_path",
    "existing_file",
    "read_calibration",
    "read_kitti_calib",
    "read_kitti_disparity",
    "read_mask",
    "read_middlebury_calib",
    "read_middlebury_disparity",
    "read_pfm",
    "read_scene_disparity",
    "read_scene_image",
    "read_text_file",
]


# --------------------------------------------------------------------------------------
# Paths and images
# --------------------------------------------------------------------------------------


def as_path(path, name: str = "path") -> Path:
    """``path`` as a :class:`pathlib.Path`; anything but a str or path raises
    :class:`InvalidTypeError` naming ``name``."""
    if isinstance(path, Path):
        return path
    if isinstance(path, (str, os.PathLike)):
        return Path(path)
    raise InvalidTypeError(f"`{name}` must be a str or pathlib.Path, got {describe(path)}")


def existing_file(path, what: str, max_bytes: int | None = None) -> Path:
    """``path`` as a :class:`pathlib.Path` naming an existing regular file (of at most
    ``max_bytes`` bytes when given), checked without opening it
    (:func:`hopmatch.files.check_input_file`).

    Raises :class:`InvalidArgumentError` ``"<what> file '<path>' does not exist"``,
    ``"<what> path '<path>' is not a file"`` (a folder), ``"<what> path '<path>' is a named
    pipe (FIFO), not a regular file..."`` (pipes, devices, sockets), or says why the system
    refused it or that it is too large.
    """
    p = as_path(path)
    try:
        check_input_file(p, max_bytes)
    except FileReadError as exc:
        raise _file_error(p, what, exc) from None
    return p


def _file_error(p: Path, what: str, exc: FileReadError) -> InvalidArgumentError:
    """A :class:`FileReadError` worded as the readers word their errors."""
    if exc.kind == "missing" and exc.problem == "no such file":
        return InvalidArgumentError(f"{what} file {str(p)!r} does not exist")
    if exc.kind == "folder":
        return InvalidArgumentError(f"{what} path {str(p)!r} is not a file")
    if exc.kind == "special":
        return InvalidArgumentError(f"{what} path {str(p)!r} {exc.problem}")
    return InvalidArgumentError(f"{what} file {str(p)!r}: {exc.problem}")


def _read_bytes(path, what: str) -> bytes:
    p = as_path(path)
    try:
        return read_input_bytes(p, MAX_FILE_BYTES)
    except FileReadError as exc:
        raise _file_error(p, what, exc) from None


def read_text_file(path, what: str) -> str:
    """The text of a small file (at most ``MAX_TEXT_BYTES``, 64 MiB), checked as
    :func:`existing_file` checks it; errors name ``what`` and the file, a binary file
    included."""
    p = as_path(path)
    try:
        return read_input_text(p, MAX_TEXT_BYTES)
    except FileReadError as exc:
        raise _file_error(p, what, exc) from None
    except UnicodeDecodeError:
        raise InvalidArgumentError(f"{what} file {str(p)!r} is not a text file") from None


def _decode(path, flags: int, what: str) -> np.ndarray:
    """:func:`hopmatch.imageio.read_image` of an existing file, its errors worded as the
    other readers word theirs."""
    p = existing_file(path, what)
    try:
        return read_image(p, flags)
    except ImageReadError as exc:
        if exc.kind in ("unreadable", "too_large", "too_many_pixels"):
            raise InvalidArgumentError(f"{what} file {str(p)!r}: {exc.problem}") from None
        if exc.kind in ("empty", "undecodable"):
            raise InvalidArgumentError(
                f"{what} file {str(p)!r} could not be decoded as an image "
                "(expected a PNG, PGM/PPM or JPEG file)"
            ) from None
        existing_file(p, what)  # it vanished or changed since: say so in the same words
        raise


def read_scene_image(path, what: str = "image") -> np.ndarray:
    """An 8-bit image as ``cv2.imread(path)`` gives it, except that grey files stay grey.

    Parameters
    ----------
    path : str or pathlib.Path
        A PNG, PGM/PPM or JPEG file.
    what : str
        What the file is, for error messages (``"left image"``).

    Returns
    -------
    image : (H, W) or (H, W, 3) uint8 ndarray
        C-contiguous; grey files give ``(H, W)``, colour files BGR (alpha dropped),
        16-bit files are scaled to 8 bits as ``cv2.imread`` does.

    Raises
    ------
    InvalidArgumentError
        The file is missing, unreadable or cannot be decoded.
    """
    img = _decode(path, cv2.IMREAD_ANYCOLOR, what)
    if img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    return np.ascontiguousarray(img)


def read_mask(path, what: str = "non-occluded mask") -> np.ndarray:
    """A mask image as a bool ``(H, W)`` array: True where the stored value is not 0.

    A mask saved as equal colour channels is accepted; one with different channels
    raises :class:`InvalidArgumentError`, as do missing or undecodable files.
    """
    return _single_channel(_decode(path, cv2.IMREAD_UNCHANGED, what), path, what) != 0


def _single_channel(img: np.ndarray, path, what: str) -> np.ndarray:
    """Reduce a map stored as identical colour channels to (H, W); refuse real colour."""
    if img.ndim == 3:
        if img.shape[2] == 1 or all(
            np.array_equal(img[:, :, 0], img[:, :, c]) for c in range(1, min(img.shape[2], 3))
        ):
            return img[:, :, 0]
        raise InvalidArgumentError(
            f"{what} file {str(path)!r} must be a single-channel (grey) image, "
            f"got {img.shape[2]} channels with different values"
        )
    return img


def _to_disparity(raw: np.ndarray, scale: float, unknown_value) -> np.ndarray:
    disp = raw.astype(np.float32) / np.float32(scale)
    if unknown_value is not None:
        disp[raw == unknown_value] = np.nan
    disp[~np.isfinite(disp)] = np.nan
    return np.ascontiguousarray(disp, dtype=np.float32)


# --------------------------------------------------------------------------------------
# Disparity readers
# --------------------------------------------------------------------------------------


def read_middlebury_disparity(path, scale, unknown_value=0) -> np.ndarray:
    """Read a Middlebury 2001-2006 disparity map (8- or 16-bit PNG/PGM).

    ``disparity = stored value / scale``; pixels holding ``unknown_value`` become NaN.

    Parameters
    ----------
    path : str or pathlib.Path
        A single-channel PNG or PGM file (a grey map saved as 3 equal channels is
        accepted).
    scale : float
        Stored value per pixel of disparity: 8 for the 2001 scenes (16 for Tsukuba in
        the v2 evaluation form), 1 for full-size 2005/2006 scenes, 2 for half size, ...
    unknown_value : int or None
        Stored value that means "no ground truth" (0 in every Middlebury set); None
        when every pixel is known.

    Returns
    -------
    disparity : (H, W) float32 ndarray
        In pixels, for the left image; NaN = unknown.

    Raises
    ------
    InvalidArgumentError
        ``scale`` is not a finite number > 0, ``unknown_value`` not finite; the file is
        missing, cannot be decoded, holds colour, or not 8- or 16-bit integers.
    InvalidTypeError
        ``path`` is not a str or path, ``scale`` or ``unknown_value`` not a number.

    Examples
    --------
    >>> import tempfile, os, cv2, numpy as np
    >>> path = os.path.join(tempfile.mkdtemp(), "disp.png")
    >>> _ = cv2.imwrite(path, np.array([[0, 8], [16, 20]], np.uint8))
    >>> read_middlebury_disparity(path, scale=8)
    array([[nan, 1. ],
           [2. , 2.5]], dtype=float32)
    """
    scale = as_real(scale, "scale", lo=0.0, lo_open=True)
    as_real(unknown_value, "unknown_value", optional=True)
    raw = _decode(path, cv2.IMREAD_UNCHANGED, "Middlebury disparity")
    raw = _single_channel(raw, path, "Middlebury disparity")
    if raw.dtype not in (np.uint8, np.uint16):
        raise InvalidArgumentError(
            f"Middlebury disparity file {str(path)!r} must hold 8- or 16-bit integers, "
            f"got {raw.dtype}"
        )
    return _to_disparity(raw, scale, unknown_value)


_PFM_HEADER = re.compile(rb"\A(P[Ff])\s+(\d+)\s+(\d+)\s+([-+]?[0-9.]+(?:[eE][-+]?\d+)?)\s")


def read_pfm(path) -> np.ndarray:
    """Read a PFM file (Middlebury 2014 / MiddEval3 ``disp0.pfm``, ``disp0GT.pfm``).

    The header is ``Pf`` (grey) or ``PF`` (colour), then ``width height``, then a scale
    whose sign gives the byte order (negative: little-endian, positive: big-endian); its
    magnitude is not applied. Rows are stored bottom to top and are flipped here, so
    row 0 is the top of the image. Infinite values (Middlebury's "unknown") become NaN.

    Parameters
    ----------
    path : str or pathlib.Path
        The PFM file.

    Returns
    -------
    data : (H, W) or (H, W, 3) float32 ndarray
        Native byte order. Colour files keep the file's channel order (R, G, B); use
        ``data[..., ::-1]`` for cv2's BGR.

    Raises
    ------
    InvalidArgumentError
        Missing file, bad header, or fewer data bytes than the header announces.

    Examples
    --------
    >>> import tempfile, os, numpy as np
    >>> path = os.path.join(tempfile.mkdtemp(), "d.pfm")
    >>> rows = np.array([[3, np.inf], [1, 2]], "<f4")  # bottom row first in the file
    >>> with open(path, "wb") as f:
    ...     _ = f.write(b"Pf\\n2 2\\n-1.0\\n" + rows.tobytes())
    >>> read_pfm(path)
    array([[ 1.,  2.],
           [ 3., nan]], dtype=float32)
    """
    p = existing_file(path, "PFM", MAX_FILE_BYTES)
    blob = _read_bytes(p, "PFM")
    m = _PFM_HEADER.match(blob)
    if m is None:
        raise InvalidArgumentError(
            f"PFM file {str(p)!r} has no valid header: expected 'PF' or 'Pf', then "
            f"'width height', then a non-zero scale (got {blob[:32]!r})"
        )
    kind, width, height, scale = m.group(1), int(m.group(2)), int(m.group(3)), float(m.group(4))
    if width <= 0 or height <= 0:
        raise InvalidArgumentError(
            f"PFM file {str(p)!r} announces a size of {width}x{height}; both must be positive"
        )
    if scale == 0 or not math.isfinite(scale):
        raise InvalidArgumentError(
            f"PFM file {str(p)!r} has scale {scale}; expected a non-zero number whose sign "
            "gives the byte order (negative: little-endian)"
        )
    channels = 3 if kind == b"PF" else 1
    dtype = np.dtype("<f4") if scale < 0 else np.dtype(">f4")
    count = width * height * channels
    body = blob[m.end():]
    if len(body) < count * 4:
        raise InvalidArgumentError(
            f"PFM file {str(p)!r} is truncated: the header announces {width}x{height}x"
            f"{channels} float32 values ({count * 4} bytes), the file holds {len(body)}"
        )
    data = np.frombuffer(body, dtype=dtype, count=count).astype(np.float32)
    shape = (height, width, 3) if channels == 3 else (height, width)
    data = np.ascontiguousarray(data.reshape(shape)[::-1])
    data[np.isinf(data)] = np.nan
    return data


def read_kitti_disparity(path) -> np.ndarray:
    """Read a KITTI 2012/2015 disparity map: uint16 PNG, ``value / 256``, 0 = unknown.

    Parameters
    ----------
    path : str or pathlib.Path
        ``disp_noc/*.png`` or ``disp_occ/*.png``.

    Returns
    -------
    disparity : (H, W) float32 ndarray
        In pixels, for the left image; NaN where the file holds 0 (no LiDAR return).

    Raises
    ------
    InvalidArgumentError
        Missing file, undecodable file, or not a single-channel 16-bit image (an 8-bit
        file would silently give disparities 256 times too small).

    Examples
    --------
    >>> import tempfile, os, cv2, numpy as np
    >>> path = os.path.join(tempfile.mkdtemp(), "000000_10.png")
    >>> _ = cv2.imwrite(path, np.array([[0, 256, 640]], np.uint16))
    >>> read_kitti_disparity(path)
    array([[nan, 1. , 2.5]], dtype=float32)
    """
    raw = _decode(path, cv2.IMREAD_UNCHANGED, "KITTI disparity")
    if raw.ndim != 2 or raw.dtype != np.uint16:
        raise InvalidArgumentError(
            f"KITTI disparity file {str(path)!r} must be a single-channel 16-bit PNG "
            f"(value / 256, 0 = unknown), got shape {raw.shape} and dtype {raw.dtype}"
        )
    return _to_disparity(raw, 256.0, 0)



def read_scene_disparity(path, scale, unknown_value=0, pfm_unknown=None) -> np.ndarray:
    """Any disparity file of a scene: a PFM file, or an integer PNG/PGM.

    Parameters
    ----------
    path : str or pathlib.Path
        A ``.pfm`` file (read with :func:`read_pfm`; it must be grey, ``Pf``), or any
        other file, read with :func:`read_middlebury_disparity`.
    scale : float
        Stored value per pixel of disparity (> 0).
    unknown_value : number or None
        For PNG/PGM files: the stored value meaning "no ground truth".
    pfm_unknown : number or None
        For PFM files, whose ``inf`` already means unknown: a further stored value
        meaning it, or None.

    Returns
    -------
    disparity : (H, W) float32 ndarray
        ``stored value / scale``, in pixels; NaN = unknown.

    Raises
    ------
    InvalidArgumentError
        As the reader of the file's format does, or a colour PFM file.
    """
    path = as_path(path)
    if path.suffix.lower() == ".pfm":
        scale = as_real(scale, "scale", lo=0.0, lo_open=True)
        as_real(pfm_unknown, "pfm_unknown", optional=True)
        data = read_pfm(path)
        if data.ndim != 2:
            raise InvalidArgumentError(f"disparity file {str(path)!r} must be a grey 'Pf' PFM")
        if pfm_unknown is not None:
            data[data == pfm_unknown] = np.nan
        return np.ascontiguousarray(data / np.float32(scale), dtype=np.float32)
    return read_middlebury_disparity(path, scale, unknown_value)


# --------------------------------------------------------------------------------------
# Calibration readers
# --------------------------------------------------------------------------------------



def _parse_matrix(text: str, path, key: str) -> np.ndarray:
    rows = [r.split() for r in text.strip().split(";")]
    if any(len(r) != len(rows[0]) for r in rows):
        raise InvalidArgumentError(
            f"Middlebury calibration file {str(path)!r}: the rows of `{key}` have different "
            f"lengths ({[len(r) for r in rows]})"
        )
    try:
        return np.array([[float(v) for v in r] for r in rows], dtype=np.float64)
    except ValueError:
        raise InvalidArgumentError(
            f"Middlebury calibration file {str(path)!r}: `{key}` must be a matrix like "
            f"'[f 0 cx; 0 f cy; 0 0 1]', got {text!r}"
        ) from None


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
    InvalidArgumentError
        Missing file, a line without ``=``, a value that is neither a number nor a
        matrix, or no 3x3 ``cam0`` / ``cam1``.

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
            raise InvalidArgumentError(
                f"Middlebury calibration file {str(p)!r}, line {lineno}: expected "
                f"'key=value', got {line!r}"
            )
        key, value = (s.strip() for s in line.split("=", 1))
        if value.startswith("["):
            if not value.endswith("]"):
                raise InvalidArgumentError(
                    f"Middlebury calibration file {str(p)!r}, line {lineno}: matrix "
                    f"`{key}` is not closed with ']'"
                )
            calib[key] = _parse_matrix(value[1:-1], p, key)
        else:
            try:
                calib[key] = float(value)
            except ValueError:
                raise InvalidArgumentError(
                    f"Middlebury calibration file {str(p)!r}, line {lineno}: `{key}` must "
                    f"be a number or a matrix, got {value!r}"
                ) from None
    for key in ("cam0", "cam1"):
        if not isinstance(calib.get(key), np.ndarray) or calib[key].shape != (3, 3):
            raise InvalidArgumentError(
                f"Middlebury calibration file {str(p)!r} must define `{key}` as a 3x3 "
                f"matrix '[f 0 cx; 0 f cy; 0 0 1]'"
                + (f", got shape {calib[key].shape}" if key in calib and
                   isinstance(calib[key], np.ndarray) else "")
            )
    calib["focal_length"] = float(calib["cam0"][0, 0])
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
    InvalidArgumentError
        Missing file, a line that is not ``key: numbers``, or P0..P3 missing or not 12
        numbers.

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
            raise InvalidArgumentError(
                f"KITTI calibration file {str(p)!r}, line {lineno}: expected "
                f"'P0: 12 numbers', got {line[:80]!r}"
            ) from None
        key = key.strip()
        if nums.size == 12:
            nums = nums.reshape(3, 4)
        elif nums.size == 9:
            nums = nums.reshape(3, 3)
        calib[key] = nums
    for key in ("P0", "P1", "P2", "P3"):
        if key not in calib or calib[key].shape != (3, 4):
            got = f"{calib[key].size} numbers" if key in calib else "nothing"
            raise InvalidArgumentError(
                f"KITTI calibration file {str(p)!r} must define `{key}` as a 3x4 projection "
                f"matrix (12 numbers), got {got}"
            )
    p0, p1 = calib["P0"], calib["P1"]
    if p1[0, 0] == 0:
        raise InvalidArgumentError(f"KITTI calibration file {str(p)!r}: P1 has zero focal length")
    calib["focal_length"] = float(p0[0, 0])
    calib["cx"] = float(p0[0, 2])
    calib["cy"] = float(p0[1, 2])
    calib["baseline"] = float((p0[0, 3] - p1[0, 3]) / p1[0, 0])
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
    InvalidArgumentError
        Missing or binary file, neither format, or as the reader of its format does.
    """
    p = existing_file(path, "calibration", MAX_TEXT_BYTES)
    head = read_text_file(p, "calibration")[:4096]
    if re.search(r"^\s*P0\s*:", head, re.M):
        return read_kitti_calib(p)
    if re.search(r"^\s*cam0\s*=", head, re.M):
        return read_middlebury_calib(p)
    raise InvalidArgumentError(
        f"calibration file {str(p)!r} is neither KITTI ('P0: ...' lines) nor Middlebury "
        "('cam0=[...]' lines)"
    )
