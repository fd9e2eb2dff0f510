"""Reading image files: the one place hopmatch opens and decodes them.

:func:`read_image` is used by the command line, the Dask plugin and the readers of
:mod:`hopmatch.datasets`. It raises :class:`ImageReadError` naming the file, and says in
``ImageReadError.kind`` which check failed, so that each caller can word the error in its
own terms.
"""

from __future__ import annotations

import contextlib
import errno
import os
import sys
import tempfile
import threading
from pathlib import Path

import cv2
import numpy as np

from ._validate import as_int, describe
from .errors import InvalidArgumentError, InvalidTypeError

__all__ = ["DEFAULT_FLAGS", "KINDS", "ImageReadError", "os_reason", "read_image"]

#: The ``cv2.imread`` flags of :func:`read_image` by default: every channel and bit depth
#: as stored (grey stays ``(H, W)``, 16-bit stays uint16), alpha dropped.
DEFAULT_FLAGS = cv2.IMREAD_ANYDEPTH | cv2.IMREAD_ANYCOLOR

#: The values of :attr:`ImageReadError.kind`, and what each one means.
KINDS = {
    "missing": "no file or folder of that name",
    "folder": "the path names a folder",
    "unreadable": "the operating system refused to read the file",
    "empty": "the file holds 0 bytes",
    "undecodable": "OpenCV cannot decode the bytes (corrupt, truncated, unsupported format)",
}

#: Serialises the redirection of file descriptor 2 and OpenCV's log level, both
#: process-wide, between threads reading images at the same time.
_DECODE_LOCK = threading.Lock()


class ImageReadError(InvalidArgumentError):
    """An image file is missing, unreadable or not an image OpenCV can decode.

    ``path`` and ``problem`` hold the two halves of the message ``"<path>: <problem>"``;
    ``kind`` is one of the keys of :data:`KINDS` (``"missing"``, ``"folder"``,
    ``"unreadable"``, ``"empty"``, ``"undecodable"``), or None when not given.

    Examples
    --------
    >>> err = ImageReadError("left.png", "no such file", kind="missing")
    >>> str(err), err.kind, isinstance(err, ValueError)
    ('left.png: no such file', 'missing', True)
    """

    def __init__(self, path, problem: str, kind: str | None = None):
        self.path = os.fspath(path)
        self.problem = problem
        self.kind = kind
        super().__init__(f"{self.path}: {problem}")


def os_reason(exc: OSError) -> str:
    """A short, plain reason for an ``OSError`` ("permission denied", ...).

    Examples
    --------
    >>> os_reason(PermissionError(errno.EACCES, "Permission denied"))
    'permission denied'
    """
    return {
        errno.ENOTDIR: "a part of the path is a file, not a folder",
        errno.EEXIST: "a file of that name exists",
        errno.EACCES: "permission denied",
        errno.EPERM: "permission denied",
        errno.EROFS: "read-only file system",
        errno.ENOSPC: "no space left on the device",
        errno.ENOENT: "no such file or folder",
    }.get(exc.errno, exc.strerror or str(exc))


def read_image(path, flags: int = DEFAULT_FLAGS) -> np.ndarray:
    """Read an image file as ``cv2.imread(path, flags)`` would, but raise
    :class:`ImageReadError` naming ``path`` instead of returning None.

    Parameters
    ----------
    path : str or os.PathLike
        The image file. Anything readable as a byte stream is accepted (a named pipe
        such as ``/dev/fd/63`` included); a folder is not.
    flags : int
        ``cv2.IMREAD_*`` flags, as for ``cv2.imread``; default :data:`DEFAULT_FLAGS`
        (``IMREAD_ANYDEPTH | IMREAD_ANYCOLOR``). ``cv2.IMREAD_UNCHANGED`` keeps alpha.

    Returns
    -------
    image : ndarray
        What ``cv2.imdecode(bytes, flags)`` returns for the file's bytes.

    Raises
    ------
    ImageReadError
        The file is missing (``kind="missing"``), a folder (``"folder"``), cannot be read
        (``"unreadable"``), is empty (``"empty"``) or cannot be decoded
        (``"undecodable"``; what the decoder printed is added to the message).
    InvalidTypeError
        ``path`` is not a str or path, or ``flags`` not an integer.

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
    flags = as_int(flags, "flags")
    p = Path(path)
    if not p.exists():
        raise ImageReadError(path, "no such file", kind="missing")
    if p.is_dir():
        raise ImageReadError(path, "is a folder, not an image file", kind="folder")
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise ImageReadError(path, f"cannot read the file: {os_reason(exc)}",
                             kind="unreadable") from None
    if not data:
        raise ImageReadError(path, "is empty (0 bytes), not an image", kind="empty")
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
    if image is None or image.size == 0:
        detail = " ".join(captured.get("text", "").split())
        raise ImageReadError(path, "is not an image OpenCV can read (corrupt, truncated or of "
                                   "an unsupported format)" + (f" [{detail}]" if detail else ""),
                             kind="undecodable")
    return image


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
