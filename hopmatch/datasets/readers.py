"""Readers of stereo ground-truth files: disparity maps, calibrations and scene images.

Every reader returns arrays in :mod:`hopmatch.datasets`'s conventions: disparity as a
float32 ``(H, W)`` array in pixels, for the left image, NaN where there is no ground truth;
images as ``cv2.imread`` gives them. Images are opened and decoded by
:func:`hopmatch.imageio.read_image`; the readers word its errors in their own terms.

Every reader raises :class:`hopmatch.errors.InvalidArgumentError` (a ``ValueError``)
naming the file and what was expected when a file is missing or malformed, and
:class:`hopmatch.errors.InvalidTypeError` when an argument has the wrong type. A file that
is there but holds what its format cannot (a PFM header that is not one, a calibration value
that is not a finite number, a calibration whose focal length or baseline is not positive)
raises :class:`hopmatch.errors.FileReadError`, the ``InvalidArgumentError`` of files:
``"<path>: not a valid <what> file: <problem>"``.

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

from .._validate import FLOAT32_MAX, as_real, describe
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
    "SCALE_RANGE",
    "as_disparity_scale",
    "as_path",
    "as_pfm_value",
    "as_unknown_value",
    "existing_file",
    "malformed_file",
    "read_kitti_disparity",
    "read_mask",
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

    Raises :class:`~hopmatch.errors.FileReadError` (its ``kind`` that of
    :func:`~hopmatch.files.check_input_file`) ``"<path>: the <what> file does not exist"``,
    ``"<path>: the <what> path is not a file (it names a folder)"``, ``"<path>: the <what>
    path is a named pipe (FIFO), not a regular file..."`` (pipes, devices, sockets), or
    ``"<path>: <why the system refused it, or that it is too large> (the <what> file)"``.
    """
    p = as_path(path)
    try:
        check_input_file(p, max_bytes)
    except FileReadError as exc:
        raise _file_error(p, what, exc) from None
    return p


def _file_error(p: Path, what: str, exc: FileReadError) -> FileReadError:
    """``exc`` (a :class:`FileReadError`, its ``kind`` kept) worded to say which file it
    was: ``"<path>: the <what> file does not exist"``..."""
    if exc.kind == "missing" and exc.problem == "no such file":
        problem = f"the {what} file does not exist"
    elif exc.kind == "folder":
        problem = f"the {what} path is not a file (it names a folder)"
    elif exc.kind == "special":
        problem = f"the {what} path {exc.problem}"
    else:
        problem = f"{exc.problem} (the {what} file)"
    return FileReadError(p, problem, kind=exc.kind)


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
        raise FileReadError(p, f"the {what} file is not a text file") from None


def malformed_file(path, what: str, problem: str) -> FileReadError:
    """The error for a file that is there and readable but does not hold what a ``what``
    file should: a :class:`FileReadError` (an :class:`InvalidArgumentError`) whose message
    is ``"<path>: not a valid <what> file: <problem>"``."""
    return FileReadError(path, f"not a valid {what} file: {problem}")


def _decode(path, flags: int, what: str) -> np.ndarray:
    """:func:`hopmatch.imageio.read_image` of an existing file, its errors worded as the
    other readers word theirs."""
    p = existing_file(path, what)
    try:
        return read_image(p, flags)
    except ImageReadError as exc:
        if exc.kind in ("unreadable", "too_large", "too_many_pixels"):
            raise ImageReadError(p, f"{exc.problem} (the {what} file)", kind=exc.kind) from None
        if exc.kind in ("empty", "undecodable"):
            raise ImageReadError(
                p, f"the {what} file could not be decoded as an image (expected a PNG, "
                "PGM/PPM or JPEG file)", kind=exc.kind) from None
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
        raise malformed_file(path, what, "it must be a single-channel (grey) image, got "
                             f"{img.shape[2]} channels with different values")
    return img


#: The ``scale`` a disparity file may have (stored value per pixel of disparity), 2**-16 to
#: 2**16. Datasets use 1 to 256; within this range every 16-bit stored value gives a finite
#: float32 disparity and a stored 1 does not vanish to 0. Beyond it the float32 division
#: would overflow or every disparity round to 0: such a scale is a mistake.
SCALE_RANGE = (2.0**-16, 2.0**16)


def as_disparity_scale(scale, name: str = "scale") -> float:
    """``scale`` as a float within :data:`SCALE_RANGE`; else :class:`InvalidTypeError`
    (not a number) or :class:`InvalidArgumentError` naming ``name``."""
    v = as_real(scale, name, lo=0.0, lo_open=True)
    if not SCALE_RANGE[0] <= v <= SCALE_RANGE[1]:
        raise InvalidArgumentError(
            f"`{name}` (stored value per pixel of disparity) must be in [2**-16, 2**16] "
            f"(datasets use 1 to 256), got {v!r}"
        )
    return v


def as_pfm_value(value, name: str) -> float | None:
    """``value`` (or None) as a float a PFM file can hold: 0 or a magnitude float32 keeps,
    up to :data:`~hopmatch._validate.FLOAT32_MAX`, not rounded to 0 (a PFM value compared
    with it would otherwise match nothing, or every 0)."""
    v = as_real(value, name, optional=True)
    if v is not None and (abs(v) > FLOAT32_MAX or (v != 0 and np.float32(v) == 0)):
        raise InvalidArgumentError(
            f"`{name}` must be a value a PFM file can hold (float32: 0, or a magnitude in "
            f"[{float(np.finfo(np.float32).smallest_subnormal):.3g}, {FLOAT32_MAX:.3g}]), "
            f"got {v!r}"
        )
    return v


def as_unknown_value(value, name: str = "unknown_value", *, bits: int = 16,
                     of: str = "an 8- or 16-bit disparity file") -> float | None:
    """``value`` (or None) as a float that a pixel of an unsigned ``bits``-bit map can
    hold: an integer in ``[0, 2**bits - 1]``; any other value would mark nothing unknown.
    Else :class:`InvalidTypeError` (not a number) or :class:`InvalidArgumentError`
    naming ``name`` and, as ``of``, the file."""
    v = as_real(value, name, optional=True)
    top = 2**bits - 1
    if v is not None and (v != int(v) or not 0 <= v <= top):
        raise InvalidArgumentError(
            f"`{name}` must be an integer in [0, {top}], a value {of} can hold, got {v!r}"
        )
    return v


def _to_disparity(raw: np.ndarray, scale: float, unknown_value) -> np.ndarray:
    """``raw / scale`` as float32, NaN where ``raw`` holds ``unknown_value``; ``scale`` is
    within :data:`SCALE_RANGE` and ``raw`` 8- or 16-bit, so nothing overflows."""
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
        ``scale`` is not a finite number in [2**-16, 2**16] (:data:`SCALE_RANGE`),
        ``unknown_value`` not an integer the file's pixels can hold (0..255 for 8-bit files,
        0..65535 for 16-bit ones); the file is missing, cannot be decoded, holds colour, or
        not 8- or 16-bit integers.
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
    scale = as_disparity_scale(scale)
    unknown_value = as_unknown_value(unknown_value)
    raw = _decode(path, cv2.IMREAD_UNCHANGED, "Middlebury disparity")
    raw = _single_channel(raw, path, "Middlebury disparity")
    if raw.dtype not in (np.uint8, np.uint16):
        raise malformed_file(path, "Middlebury disparity",
                             f"it must hold 8- or 16-bit integers, got {raw.dtype}")
    bits = raw.dtype.itemsize * 8
    as_unknown_value(unknown_value, bits=bits,
                     of=f"the {bits}-bit Middlebury disparity file {str(path)!r}")
    return _to_disparity(raw, scale, unknown_value)


#: A PFM header: the magic, then three words (width, height, scale) each checked by
#: :func:`_pfm_header`, then the one whitespace byte before the data. Looked for in the
#: first :data:`_PFM_HEADER_BYTES` bytes.
_PFM_HEADER = re.compile(rb"\A(P[Ff])\s+(\S+)\s+(\S+)\s+(\S+)\s")
_PFM_HEADER_BYTES = 1 << 16
#: A decimal number as the scale of a PFM header may be written: ``-1``, ``1.0``, ``.5``,
#: ``-1e+00``.
_PFM_SCALE = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
#: Most digits of a width or height parsed as a number. A PFM this reader takes (at most
#: MAX_FILE_BYTES, 1 GiB) has at most 2**28 values, a 9-digit count; a longer number is
#: refused for its length (before ``int`` could refuse it past Python's 4300 digits).
_PFM_SIZE_DIGITS = 18


def _pfm_size(word: bytes, name: str, p: Path) -> int:
    """The width or height ``word`` of the PFM header of ``p``, a positive integer."""
    digits = word.lstrip(b"0")
    if not word.isdigit() or not digits:
        raise malformed_file(p, "PFM", f"the header's {name} must be a positive integer "
                                   f"(the header is 'PF' or 'Pf', then 'width height', then "
                                   f"a non-zero scale), got {word[:32]!r}")
    if len(digits) > _PFM_SIZE_DIGITS:
        raise malformed_file(p, "PFM", f"the header's {name} has {len(digits)} digits, more than "
                                   f"any PFM file of at most {MAX_FILE_BYTES} bytes can hold")
    return int(digits)


def _pfm_scale(word: bytes, p: Path) -> float:
    """The scale ``word`` of the PFM header of ``p``: a finite non-zero number."""
    scale = float(word) if _PFM_SCALE.fullmatch(word) else None
    if scale is None or scale == 0 or not math.isfinite(scale):
        got = word[:32] if scale is None else scale
        raise malformed_file(p, "PFM", f"the header's scale must be a finite non-zero number "
                                   f"whose sign gives the byte order (negative: "
                                   f"little-endian), got {got!r}")
    return scale


def _pfm_header(blob: bytes, p: Path) -> tuple[int, int, int, float, int]:
    """``(channels, width, height, scale, data offset)`` of the PFM file ``p``."""
    m = _PFM_HEADER.match(blob, 0, _PFM_HEADER_BYTES)
    if m is None:
        raise malformed_file(p, "PFM", "the header must be 'PF' or 'Pf', then 'width height', "
                                   f"then a non-zero scale, got {blob[:32]!r}")
    width = _pfm_size(m.group(2), "width", p)
    height = _pfm_size(m.group(3), "height", p)
    scale = _pfm_scale(m.group(4), p)
    return (3 if m.group(1) == b"PF" else 1), width, height, scale, m.end()


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
    FileReadError
        A header that is not 'PF'/'Pf', two positive integers and a finite non-zero
        number (the message says which part is wrong), or fewer data bytes than it
        announces.
    InvalidArgumentError
        Missing or unreadable file.

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
    channels, width, height, scale, start = _pfm_header(blob, p)
    dtype = np.dtype("<f4") if scale < 0 else np.dtype(">f4")
    count = width * height * channels
    body = blob[start:]
    if len(body) < count * 4:
        raise malformed_file(p, "PFM", f"the data is truncated: the header announces {width}x"
                                   f"{height}x{channels} float32 values ({count * 4} bytes), "
                                   f"the file holds {len(body)}")
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
        raise malformed_file(path, "KITTI disparity",
                             "it must be a single-channel 16-bit PNG (value / 256, 0 = "
                             f"unknown), got shape {raw.shape} and dtype {raw.dtype}")
    return _to_disparity(raw, 256.0, 0)



def read_scene_disparity(path, scale, unknown_value=0, pfm_unknown=None) -> np.ndarray:
    """Any disparity file of a scene: a PFM file, or an integer PNG/PGM.

    Parameters
    ----------
    path : str or pathlib.Path
        A ``.pfm`` file (read with :func:`read_pfm`; it must be grey, ``Pf``), or any
        other file, read with :func:`read_middlebury_disparity`.
    scale : float
        Stored value per pixel of disparity, in [2**-16, 2**16] (:data:`SCALE_RANGE`).
    unknown_value : number or None
        For PNG/PGM files: the stored value meaning "no ground truth".
    pfm_unknown : number or None
        For PFM files, whose ``inf`` already means unknown: a further stored value
        meaning it (one float32 can hold: :func:`as_pfm_value`), or None.

    Returns
    -------
    disparity : (H, W) float32 ndarray
        ``stored value / scale``, in pixels; NaN = unknown.

    Raises
    ------
    InvalidArgumentError
        As the reader of the file's format does, a colour PFM file, or a bad ``scale`` or
        ``pfm_unknown``.
    FileReadError
        As :func:`read_pfm` does, or a PFM value that divided by ``scale`` leaves the
        float32 range.
    """
    path = as_path(path)
    if path.suffix.lower() == ".pfm":
        scale = as_disparity_scale(scale)
        pfm_unknown = as_pfm_value(pfm_unknown, "pfm_unknown")
        data = read_pfm(path)
        if data.ndim != 2:
            raise malformed_file(path, "disparity", "it must be a grey 'Pf' PFM, got a colour "
                                 "'PF' one")
        if pfm_unknown is not None:
            data[data == np.float32(pfm_unknown)] = np.nan
        return _scaled_pfm(data, scale, path)
    return read_middlebury_disparity(path, scale, unknown_value)


def _scaled_pfm(data: np.ndarray, scale: float, path: Path) -> np.ndarray:
    """``data / scale`` as float32 for the PFM file ``path``; a value the division takes
    beyond the float32 range is refused (it is no disparity)."""
    with np.errstate(over="ignore"):
        disp = data / np.float32(scale)
    if np.isinf(disp).any():
        big = float(np.nanmax(np.abs(data)))
        raise malformed_file(path, "disparity", f"it holds a value of magnitude {big:.3g}, which "
                                            f"divided by `scale` {scale!r} is beyond the "
                                            f"float32 range (+-{FLOAT32_MAX:.3g})")
    return np.ascontiguousarray(disp, dtype=np.float32)
