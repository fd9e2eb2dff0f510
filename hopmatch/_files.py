"""Files: all-or-nothing writes.

Every file hopmatch writes (parameters, PLY clouds, calibrations, pictures, tables) goes
through this module: it is written to a hidden temporary file in the destination folder,
created as ``open(path, "w")`` would create it (mode 0o666 minus the umask), and moved onto
its name with ``os.replace`` only once complete. On any exception, ``KeyboardInterrupt``
included, the temporary file is removed and the destination is left as it was.
"""

from __future__ import annotations

import contextlib
import os
import secrets
from pathlib import Path

import cv2
import numpy as np

from ._validate import describe
from .errors import InvalidArgumentError, InvalidTypeError

__all__ = [
    "atomic_path",
    "encode_image",
    "new_temporary_file",
    "write_bytes_atomic",
    "write_image_atomic",
    "write_temp",
    "write_text_atomic",
]


def new_temporary_file(folder, name: str, suffix: str = "") -> tuple[int, Path]:
    """Create ``folder/.{name}.<random>.tmp{suffix}`` exclusively; return ``(fd, path)``.

    The file is created with mode 0o666 minus the umask (``tempfile.mkstemp`` would give
    0o600), so a renamed result has the permissions any other new file of the user has.
    """
    folder = Path(folder)
    for _ in range(100):
        tmp = folder / f".{name}.{secrets.token_hex(4)}.tmp{suffix}"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0),
                         0o666)
            return fd, tmp
        except FileExistsError:  # pragma: no cover - 32 random bits collided
            continue
    raise FileExistsError(f"no free temporary name in {str(folder)!r}")  # pragma: no cover


@contextlib.contextmanager
def atomic_path(path, name: str = "path"):
    """Yield a new empty temporary path beside ``path``; move it onto ``path`` on success.

    For writers that need a file name (``cv2.FileStorage``, ``cv2.imwrite``): the temporary
    file keeps ``path``'s suffix (``.yml.gz`` included), from which such writers choose the
    format. On any exception it is removed and ``path`` is left as it was.
    """
    path = Path(path)
    folder = path.parent
    if not folder.is_dir():
        raise InvalidArgumentError(
            f"`{name}`: the folder {str(folder)!r} of {str(path)!r} does not exist"
        )
    suffix = "".join(path.suffixes[-2:]) if path.suffix == ".gz" else path.suffix
    fd, tmp = new_temporary_file(folder, path.name, suffix)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_temp(folder, name: str, data: bytes) -> Path:
    """Write ``data`` to a new hidden temporary file in ``folder`` and return its path.

    The name is ``.{name}.<random>.tmp``; the data is flushed to disk; nothing is left
    behind if writing fails.
    """
    fd, tmp = new_temporary_file(folder, name)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return tmp


def write_bytes_atomic(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder + ``os.replace``."""
    path = Path(path)
    tmp = write_temp(path.parent, path.name, data)
    try:
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def write_text_atomic(path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (temporary file in the same folder, then rename)."""
    return write_bytes_atomic(path, text.encode(encoding))


def encode_image(image, ext: str = ".png") -> bytes:
    """``image`` encoded with ``cv2.imencode`` for the extension ``ext`` (e.g. ``".png"``)."""
    if not isinstance(image, np.ndarray):
        raise InvalidTypeError(f"`image` must be a numpy array, got {describe(image)}")
    try:
        ok, buf = cv2.imencode(ext, image)
    except cv2.error as exc:
        raise InvalidArgumentError(f"cannot encode the image as {ext!r}: {exc.err}") from None
    if not ok:
        raise InvalidArgumentError(f"cannot encode the image as {ext!r}")
    return buf.tobytes()


def write_image_atomic(path, image) -> Path:
    """Encode ``image`` for ``path``'s suffix (``.png``, ``.jpg``...) and write it atomically.

    Unlike ``cv2.imwrite``, failure raises (``OSError``, or ``InvalidArgumentError`` for an
    unknown suffix) instead of returning False, and never leaves a partial file.
    """
    path = Path(path)
    return write_bytes_atomic(path, encode_image(image, path.suffix or ".png"))
