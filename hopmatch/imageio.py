"""Reading image files with errors that name the file (one home for the CLI and plugins)."""

from __future__ import annotations

import contextlib
import errno
import os
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

from .errors import InvalidArgumentError

__all__ = ["ImageReadError", "read_image"]


class ImageReadError(InvalidArgumentError):
    """An image file is missing, unreadable or not an image OpenCV can decode.

    ``path`` and ``problem`` hold the two halves of the message ``"<path>: <problem>"``.

    Examples
    --------
    >>> err = ImageReadError("left.png", "no such file")
    >>> str(err), isinstance(err, ValueError)
    ('left.png: no such file', True)
    """

    def __init__(self, path, problem: str):
        self.path = os.fspath(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


def os_reason(exc: OSError) -> str:
    """A short, plain reason for an ``OSError`` ("permission denied", ...)."""
    return {
        errno.ENOTDIR: "a part of the path is a file, not a folder",
        errno.EEXIST: "a file of that name exists",
        errno.EACCES: "permission denied",
        errno.EPERM: "permission denied",
        errno.EROFS: "read-only file system",
        errno.ENOSPC: "no space left on the device",
        errno.ENOENT: "no such file or folder",
    }.get(exc.errno, exc.strerror or str(exc))


def read_image(path) -> np.ndarray:
    """Read an image file as ``cv2.imread(path, IMREAD_ANYDEPTH | IMREAD_ANYCOLOR)`` would,
    but raise :class:`ImageReadError` naming ``path`` instead of returning None.

    OpenCV's log messages and what its decoders print on file descriptor 2 (libpng does)
    are kept off the terminal; the decoder's text is added to the error instead.

    Examples
    --------
    >>> read_image("no/such/file.png")
    Traceback (most recent call last):
    ...
    hopmatch.imageio.ImageReadError: no/such/file.png: no such file
    """
    p = Path(path)
    if not p.exists():
        raise ImageReadError(path, "no such file")
    if p.is_dir():
        raise ImageReadError(path, "is a folder, not an image file")
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise ImageReadError(path, f"cannot read the file: {os_reason(exc)}") from None
    if not data:
        raise ImageReadError(path, "is empty (0 bytes), not an image")
    with _captured_fd2() as captured:
        log = cv2.utils.logging
        old = log.getLogLevel()
        log.setLogLevel(log.LOG_LEVEL_SILENT)
        try:
            image = cv2.imdecode(np.frombuffer(data, np.uint8),
                                 cv2.IMREAD_ANYDEPTH | cv2.IMREAD_ANYCOLOR)
        except cv2.error:
            image = None
        finally:
            log.setLogLevel(old)
    if image is None or image.size == 0:
        detail = " ".join(captured.get("text", "").split())
        raise ImageReadError(path, "is not an image OpenCV can read (corrupt, truncated or of "
                                   "an unsupported format)" + (f" [{detail}]" if detail else ""))
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
