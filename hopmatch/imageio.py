"""Reading image files: the one place hopmatch opens and decodes them.

:func:`read_image` is used by the command line, the Dask plugin and the readers of
:mod:`hopmatch.datasets`. It raises :class:`ImageReadError` naming the file, and says in
``ImageReadError.kind`` which check failed, so that each caller can word the error in its
own terms.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import sys
import tempfile
import threading

import cv2
import numpy as np

from ._validate import DEFAULT_MAX_PIXELS, as_int, describe
from .errors import FileReadError, InvalidArgumentError, InvalidTypeError
from .files import MAX_FILE_BYTES, os_reason, read_input_bytes

__all__ = ["DEFAULT_FLAGS", "DEFAULT_MAX_PIXELS", "HEADER_FORMATS", "KINDS", "ImageReadError",
           "header_size", "os_reason", "read_image"]

#: The ``cv2.imread`` flags of :func:`read_image` by default: every channel and bit depth
#: as stored (grey stays ``(H, W)``, 16-bit stays uint16), alpha dropped.
DEFAULT_FLAGS = cv2.IMREAD_ANYDEPTH | cv2.IMREAD_ANYCOLOR

#: The values of :attr:`ImageReadError.kind`, and what each one means.
KINDS = {
    "missing": "no file or folder of that name",
    "folder": "the path names a folder",
    "special": "a named pipe, device or socket: refused before it is opened",
    "unreadable": "the operating system refused to read the file",
    "too_large": "the file holds more than max_bytes bytes",
    "empty": "the file holds 0 bytes",
    "too_many_pixels": "the header announces more than max_pixels pixels (not decoded)",
    "undecodable": "OpenCV cannot decode the bytes (corrupt, truncated, unsupported format)",
}

#: Formats whose size :func:`header_size` reads from the header through Pillow (those of
#: them that OpenCV decodes); PAM and Radiance HDR, which Pillow does not read, are parsed
#: here. Other formats are measured after decoding.
HEADER_FORMATS = ("PNG", "JPEG", "BMP", "DIB", "PPM", "TIFF", "WEBP", "JPEG2000", "SUN", "GIF",
                  "AVIF")

#: Serialises the redirection of file descriptor 2 and OpenCV's log level, both
#: process-wide, between threads reading images at the same time.
_DECODE_LOCK = threading.Lock()


class ImageReadError(FileReadError):
    """An image file is missing, not a regular file, too large, unreadable or not an image
    OpenCV can decode.

    ``path`` and ``problem`` hold the two halves of the message ``"<path>: <problem>"``;
    ``kind`` is one of the keys of :data:`KINDS` (``"missing"``, ``"folder"``,
    ``"special"``, ``"unreadable"``, ``"too_large"``, ``"empty"``, ``"too_many_pixels"``,
    ``"undecodable"``), or None when not given.

    Examples
    --------
    >>> err = ImageReadError("left.png", "no such file", kind="missing")
    >>> str(err), err.kind, err.argument, isinstance(err, ValueError)
    ('left.png: no such file', 'missing', 'path', True)
    """

    def __init__(self, path, problem: str, kind: str | None = None,
                 argument: str | None = "path"):
        super().__init__(path, problem, kind, argument)


_PAM = re.compile(rb"\AP7\s(?:.*?\s)?WIDTH\s+(\d+)\s+HEIGHT\s+(\d+)\s", re.S)
_HDR = re.compile(rb"\A#\?(?:RADIANCE|RGBE)\n.*?\n\n([-+])Y (\d+) ([-+])X (\d+)\n", re.S)


def header_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` announced by the header of an encoded image, without decoding
    it (Pillow opens files lazily: only the header is parsed); None when the format is
    not one of :data:`HEADER_FORMATS`, PAM or Radiance HDR, or Pillow is missing.

    Examples
    --------
    >>> header_size(b"P5\\n30000 20000\\n255\\n")
    (30000, 20000)
    >>> header_size(b"not an image") is None
    True
    """
    head = bytes(data[:4096])
    m = _PAM.match(head)
    if m:
        return int(m.group(1)), int(m.group(2))
    m = _HDR.match(head)
    if m:
        return int(m.group(4)), int(m.group(2))
    try:
        from PIL import Image
    except ImportError:  # pragma: no cover - Pillow comes with scikit-image
        return None
    Image.init()
    prefix = head[:16]
    for fmt in HEADER_FORMATS:
        if fmt not in Image.OPEN:
            continue
        factory, accept = Image.OPEN[fmt]
        try:
            if accept is not None and accept(prefix) is not True:
                continue
            # the plugin itself: no bomb check. Its warnings (a TIFF's odd metadata) are
            # let through: silencing them (warnings.catch_warnings) would change the
            # process-wide filters and drop other threads' warnings meanwhile
            im = factory(io.BytesIO(data), "")
            width, height = im.size
        except Exception:  # not this format after all, or a broken header
            continue
        return int(width), int(height)
    return None


def _pixel_problem(width: int, height: int, max_pixels: int, when: str) -> str:
    n = width * height
    return (f"is {width} x {height} = {n} pixels{when}, more than max_pixels={max_pixels}; "
            f"downscale it first, or raise the limit to max_pixels={n} or more (None: no "
            "limit)")


def read_image(path, flags: int = DEFAULT_FLAGS, *, max_pixels: int | None = DEFAULT_MAX_PIXELS,
               max_bytes: int | None = MAX_FILE_BYTES) -> np.ndarray:
    """Read an image file as ``cv2.imread(path, flags)`` would, but raise
    :class:`ImageReadError` naming ``path`` instead of returning None, and refuse files
    that are not regular, too large or announce too many pixels before decoding them.

    Parameters
    ----------
    path : str or os.PathLike
        The image file: a regular file. A folder, a named pipe (a pipe with no writer
        would block forever), a device (``/dev/zero`` never ends) or a socket is refused
        before it is opened.
    flags : int
        ``cv2.IMREAD_*`` flags, as for ``cv2.imread``; default :data:`DEFAULT_FLAGS`
        (``IMREAD_ANYDEPTH | IMREAD_ANYCOLOR``). ``cv2.IMREAD_UNCHANGED`` keeps alpha.
    max_pixels : int or None
        Largest ``width x height`` accepted, as the detector's parameter of that name
        (default :data:`~hopmatch._validate.DEFAULT_MAX_PIXELS`, 50 million); None: no
        limit. Read from the header (:func:`header_size`) before anything is decoded.
    max_bytes : int or None
        Largest file read, in bytes (default 1 GiB); None: no limit. Checked before the
        file is opened, and again while it is read.

    Returns
    -------
    image : ndarray
        What ``cv2.imdecode(bytes, flags)`` returns for the file's bytes.

    Raises
    ------
    ImageReadError
        The file is missing (``kind="missing"``), a folder (``"folder"``), a named pipe,
        device or socket (``"special"``), cannot be read (``"unreadable"``: permission,
        symbolic link loop, name too long), larger than ``max_bytes`` (``"too_large"``),
        empty (``"empty"``), of more than ``max_pixels`` pixels (``"too_many_pixels"``) or
        cannot be decoded (``"undecodable"``; what the decoder printed is added to the
        message).
    InvalidTypeError, InvalidArgumentError
        ``path`` is not a str or path, ``flags`` not an integer, ``max_pixels`` or
        ``max_bytes`` not a positive integer or None.

    Notes
    -----
    OpenCV's log messages, and what its decoders print on file descriptor 2 (libpng
    does), are kept off the terminal: while a file is decoded, descriptor 2 of the
    process points at a temporary file, so output of other threads to it in that
    moment is dropped as well. Concurrent calls take turns for that moment.

    Examples
    --------
    >>> read_image("no/such/file.png")
    Traceback (most recent call last):
    ...
    hopmatch.imageio.ImageReadError: no/such/file.png: no such file
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InvalidTypeError(f"`path` must be a str or os.PathLike, got {describe(path)}")
    flags = as_int(flags, "flags", lo=-1, hi=1023)  # cv2.IMREAD_* values and their sums
    max_pixels = as_int(max_pixels, "max_pixels", lo=1, optional=True)
    max_bytes = as_int(max_bytes, "max_bytes", lo=1, optional=True)
    try:
        data = read_input_bytes(path, max_bytes)
    except FileReadError as exc:
        problem = exc.problem
        if exc.kind == "too_large":
            problem += " (max_bytes; None: no limit)"
        raise ImageReadError(path, problem.replace("is a folder, not a file",
                                                   "is a folder, not an image file"),
                             kind=exc.kind) from None
    if not data:
        raise ImageReadError(path, "is empty (0 bytes), not an image", kind="empty")
    if max_pixels is not None:
        size = header_size(data)
        if size is not None and size[0] * size[1] > max_pixels:
            raise ImageReadError(path, _pixel_problem(*size, max_pixels, " by its header"),
                                 kind="too_many_pixels")
    image, captured = _decode(data, flags)
    if (image is None or image.size == 0) and flags != DEFAULT_FLAGS \
            and _decode(data, DEFAULT_FLAGS)[0] is not None:
        raise InvalidArgumentError(
            f"`flags`: OpenCV cannot decode {os.fspath(path)!r} with flags={flags}, but can "
            "with the default ones; use cv2.IMREAD_* values (e.g. cv2.IMREAD_UNCHANGED, "
            "cv2.IMREAD_GRAYSCALE)", argument="flags")
    if image is None or image.size == 0:
        detail = " ".join(captured.get("text", "").split())
        raise ImageReadError(path, "is not an image OpenCV can read (corrupt, truncated or of "
                                   "an unsupported format)" + (f" [{detail}]" if detail else ""),
                             kind="undecodable")
    if max_pixels is not None and image.shape[0] * image.shape[1] > max_pixels:
        raise ImageReadError(path, _pixel_problem(image.shape[1], image.shape[0], max_pixels,
                                                  ""), kind="too_many_pixels")
    return image


def _decode(data: bytes, flags: int):
    """``(cv2.imdecode(data, flags) or None, what the decoder printed)``, quietly."""
    with _DECODE_LOCK, _captured_fd2() as captured:
        log = cv2.utils.logging
        old = log.getLogLevel()
        log.setLogLevel(log.LOG_LEVEL_SILENT)
        try:
            image = cv2.imdecode(np.frombuffer(data, np.uint8), flags)
        except cv2.error:
            image = None
        finally:
            log.setLogLevel(old)
    return image, captured


@contextlib.contextmanager
def _captured_fd2():
    """Collect what C libraries write to file descriptor 2 into ``captured["text"]``."""
    captured: dict = {}
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, AttributeError, ValueError):  # no real fd 2: nothing to capture
        yield captured
        return
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield captured
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            captured["text"] = sink.read().decode("utf-8", "replace")[-300:]
