"""Files: all-or-nothing writes, and the checks every file read goes through.

Every file hopmatch writes (parameters, PLY clouds, calibrations, pictures, tables) goes
through this module: it is written to a hidden temporary file in the destination folder,
created as ``open(path, "w")`` would create it (mode 0o666 minus the umask), and moved onto
its name with ``os.replace`` only once complete. On any exception, ``KeyboardInterrupt``
included, the temporary file is removed and the destination is left as it was. A failure
raises :class:`~hopmatch.errors.FileWriteError` (an ``InvalidArgumentError`` and an
``OSError``) naming the destination, never the temporary file.

Every file hopmatch reads (images, FileStorage parameters, calibrations, PFM, tables) is
checked first by :func:`check_input_file`, before it is opened: it must be a regular file
(not a folder, named pipe, device or socket) of at most ``max_bytes`` bytes, else
:class:`~hopmatch.errors.FileReadError` says which of these it is.
:func:`read_input_bytes` then reads it without ever blocking and never past ``max_bytes``.

Public so that the plugins (``plugins/``) read and write as the package does.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

from ._validate import describe
from .errors import FileReadError, FileWriteError, InvalidArgumentError, InvalidTypeError

__all__ = [
    "MAX_FILE_BYTES",
    "MAX_TEXT_BYTES",
    "READ_KINDS",
    "atomic_path",
    "MAX_STORAGE_NESTING",
    "check_input_file",
    "check_output_path",
    "check_storage_nesting",
    "encode_image",
    "new_temporary_file",
    "os_reason",
    "read_input_bytes",
    "read_input_text",
    "write_bytes_atomic",
    "write_image_atomic",
    "write_temp",
    "write_text_atomic",
]

#: Largest file read whole by default (images, PFM disparities, tables): 1 GiB. A 16-bit
#: colour image of the detector's default 50 million pixels is 300 MB uncompressed.
MAX_FILE_BYTES = 2**30
#: Largest text file of parameters or calibration read (FileStorage, calib.txt): 64 MiB.
MAX_TEXT_BYTES = 2**26

#: What :attr:`hopmatch.errors.FileReadError.kind` can be, and what each means.
READ_KINDS = {
    "missing": "no file or folder of that name (or a broken symbolic link)",
    "folder": "the path names a folder",
    "special": "a named pipe, device or socket: not a regular file",
    "unreadable": "the operating system refused the path (permission, symbolic link loop, "
                  "name too long...)",
    "too_large": "the file holds more bytes than the reader's limit",
    "too_deep": "a FileStorage file nests sequences, maps or elements so deep that "
                "OpenCV's parser crashes on it, or a meta.json nests arrays or objects "
                "deeper than hopmatch.datasets.catalogue.MAX_META_DEPTH",
}

#: Most brackets, braces and angle brackets in all (:func:`storage_nesting_bound`) of a
#: file that ``cv2.FileStorage`` parses without a check in a separate process
#: (:func:`check_storage_nesting`): OpenCV's parsers recurse once per level of nesting and
#: overflow the stack, a segmentation fault, somewhere between 20,000 and 50,000 levels
#: (OpenCV 4.14); hopmatch's own files hold a few dozen at most.
MAX_STORAGE_NESTING = 256

#: Longest file name (one path component), in bytes, on the usual file systems.
NAME_MAX = 255


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
        errno.ELOOP: "a symbolic link loop (too many levels of symbolic links)",
        errno.ENAMETOOLONG: f"the name is too long (more than {NAME_MAX} bytes in one part "
                            "of the path, or 4096 in all)",
        errno.EISDIR: "is a folder",
    }.get(exc.errno, exc.strerror or str(exc))


def _special_kind(mode: int) -> str:
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _size_text(n: int) -> str:
    for unit, size in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n} bytes"


def _stat_problem(path, st, max_bytes: int | None):
    """``(kind, problem)`` of a file whose ``os.stat`` is ``st``, or None when it is fine."""
    if stat.S_ISDIR(st.st_mode):
        return "folder", "is a folder, not a file"
    if not stat.S_ISREG(st.st_mode):
        return "special", (f"is {_special_kind(st.st_mode)}, not a regular file; hopmatch "
                           "reads only regular files (save the data to a file first)")
    if max_bytes is not None and st.st_size > max_bytes:
        return "too_large", (f"is {_size_text(st.st_size)} ({st.st_size} bytes), more than "
                             f"the {_size_text(max_bytes)} this reader takes at most")
    return None


def check_input_file(path, max_bytes: int | None = MAX_FILE_BYTES, *,
                     argument: str | None = None) -> os.stat_result:
    """Check, without opening it, that ``path`` names a regular file of at most
    ``max_bytes`` bytes (None: any size); return its ``os.stat`` (links followed).

    Raises
    ------
    FileReadError
        ``kind`` ``"missing"`` (no such file, a broken symbolic link, a part of the path
        that is a file), ``"folder"``, ``"special"`` (named pipe, device, socket),
        ``"unreadable"`` (permission, symbolic link loop, name too long) or
        ``"too_large"``; ``argument`` is set on it.
    InvalidTypeError
        ``path`` is not a str or ``os.PathLike``.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InvalidTypeError(f"`{argument or 'path'}` must be a str or os.PathLike, got "
                               f"{describe(path)}", argument=argument)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        broken = os.path.islink(path)
        raise FileReadError(path, "is a symbolic link to a missing file" if broken
                            else "no such file", kind="missing", argument=argument) from None
    except NotADirectoryError:
        raise FileReadError(path, "no such file: a part of the path is a file, not a folder",
                            kind="missing", argument=argument) from None
    except OSError as exc:
        raise FileReadError(path, f"cannot read the file: {os_reason(exc)}",
                            kind="unreadable", argument=argument) from None
    except ValueError:  # an embedded NUL character
        raise FileReadError(path, "is not a valid file name (it holds a NUL character)",
                            kind="missing", argument=argument) from None
    problem = _stat_problem(path, st, max_bytes)
    if problem is not None:
        raise FileReadError(path, problem[1], kind=problem[0], argument=argument)
    return st


def storage_nesting_bound(text: bytes) -> int:
    """An upper bound of how deep the flow sequences and maps (YAML, JSON) and the XML
    elements of a text can nest: its ``[``, ``{`` and ``<`` characters, all counted. YAML's
    block nesting (by indentation) is not counted: within :data:`MAX_TEXT_BYTES` it cannot
    pass about 11,500 levels, which OpenCV parses (measured: 11,000 levels, a 60 MB file)."""
    return text.count(b"[") + text.count(b"{") + text.count(b"<")


#: A Python program that opens the FileStorage file ``sys.argv[1]`` for reading and exits.
_PARSE_IN_CHILD = "import sys, cv2; cv2.FileStorage(sys.argv[1], cv2.FILE_STORAGE_READ).release()"


def check_storage_nesting(path, *, argument: str | None = None) -> None:
    """Refuse a file for ``cv2.FileStorage`` whose nesting crashes OpenCV's parser, before
    it is parsed in this process: a text of a few hundred kilobytes nested 50,000 deep
    overflows the parser's stack (a segmentation fault). A file of at most
    :data:`MAX_STORAGE_NESTING` brackets, braces and angle brackets in all
    (:func:`storage_nesting_bound`; hopmatch's own files hold a few) cannot nest deeper
    and passes at once; a file of more is parsed first in a child Python process, and
    refused if that process dies of a signal or does not finish within a minute (a parser
    that refuses the file with an error, as OpenCV 5's does past its own depth limit,
    passes here: the caller's parse then raises that error). The file is read as
    :func:`read_input_bytes` reads it, at most :data:`MAX_TEXT_BYTES`.

    Raises
    ------
    FileReadError
        ``kind`` ``"too_deep"``, or those of :func:`read_input_bytes`.
    """
    text = read_input_bytes(path, MAX_TEXT_BYTES, argument=argument)
    if storage_nesting_bound(text) <= MAX_STORAGE_NESTING:
        return
    try:
        child = subprocess.run([sys.executable, "-c", _PARSE_IN_CHILD, os.fspath(path)],
                               stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, timeout=60)
        crashed = child.returncode < 0
    except (OSError, subprocess.SubprocessError):
        crashed = True
    if crashed:
        raise FileReadError(path, "nests its sequences, maps or elements so deep that "
                            "OpenCV's FileStorage parser crashes on it (tried in a separate "
                            "process); is it the file you meant?", kind="too_deep",
                            argument=argument)


def read_input_bytes(path, max_bytes: int | None = MAX_FILE_BYTES, *,
                     argument: str | None = None) -> bytes:
    """The bytes of the regular file ``path`` (:func:`check_input_file`), read without
    blocking and never past ``max_bytes``: the file is opened non-blocking and checked
    again through the open descriptor, so a path swapped for a named pipe or a device in
    between is refused as well, and a file that grows while read is refused as too large.
    """
    check_input_file(path, max_bytes, argument=argument)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) \
        | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise FileReadError(path, f"cannot read the file: {os_reason(exc)}",
                            kind="unreadable", argument=argument) from None
    try:
        problem = _stat_problem(path, os.fstat(fd), max_bytes)
        if problem is not None:
            raise FileReadError(path, problem[1], kind=problem[0], argument=argument)
        limit = None if max_bytes is None else max_bytes + 1
        chunks, total = [], 0
        while limit is None or total < limit:
            chunk = os.read(fd, 1 << 24 if limit is None else min(1 << 24, limit - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    except OSError as exc:
        raise FileReadError(path, f"cannot read the file: {os_reason(exc)}",
                            kind="unreadable", argument=argument) from None
    finally:
        os.close(fd)
    if max_bytes is not None and total > max_bytes:
        raise FileReadError(path, f"grew past the {_size_text(max_bytes)} this reader takes at "
                                  "most while it was read", kind="too_large", argument=argument)
    return b"".join(chunks)


def read_input_text(path, max_bytes: int | None = MAX_TEXT_BYTES, *, encoding="utf-8",
                    argument: str | None = None) -> str:
    """:func:`read_input_bytes` decoded (universal newlines, as ``Path.read_text``);
    ``UnicodeDecodeError`` passes through for the caller to word."""
    data = read_input_bytes(path, max_bytes, argument=argument)
    return data.decode(encoding).replace("\r\n", "\n").replace("\r", "\n")


def check_output_path(path, name: str = "path") -> Path:
    """``path`` as a Path that a file can be written to: its folder exists, no folder
    stands at ``path`` and its name is at most :data:`NAME_MAX` bytes; else
    :class:`FileWriteError` naming ``path`` (``argument`` = ``name``)."""
    path = Path(path)
    folder = path.parent
    if len(os.fsencode(path.name)) > NAME_MAX:
        raise FileWriteError(f"`{name}`: cannot write {str(path)!r}: the file name is too "
                             f"long ({len(os.fsencode(path.name))} bytes long, more than the "
                             f"{NAME_MAX} a file system allows)", argument=name)
    try:
        is_dir = folder.is_dir()
    except OSError as exc:
        raise FileWriteError(f"`{name}`: cannot write {str(path)!r}: {os_reason(exc)}",
                             argument=name) from None
    if not is_dir:
        raise FileWriteError(
            f"`{name}`: the folder {str(folder)!r} of {str(path)!r} does not exist"
            + (" (it is a file)" if folder.exists() else ""), argument=name)
    if path.is_dir():
        raise FileWriteError(f"`{name}`: cannot write {str(path)!r}: a folder of that name "
                             "is there", argument=name)
    return path


def _write_error(path, name: str, exc: OSError) -> FileWriteError:
    err = FileWriteError(f"`{name}`: cannot write {str(path)!r}: {os_reason(exc)}",
                         argument=name)
    err.errno, err.strerror, err.filename = exc.errno, exc.strerror, os.fspath(path)
    return err


def _temporary_name(name: str, suffix: str) -> str:
    """``.{name}.<random>.tmp{suffix}``, ``name`` cut so that the whole stays within
    :data:`NAME_MAX` bytes (a destination name of 250 bytes is valid; its temporary name
    must be too)."""
    room = NAME_MAX - len(os.fsencode(f"..{'0' * 8}.tmp{suffix}"))
    while len(os.fsencode(name)) > room and name:
        name = name[:-1]
    return f".{name}.{secrets.token_hex(4)}.tmp{suffix}"


def new_temporary_file(folder, name: str, suffix: str = "") -> tuple[int, Path]:
    """Create ``folder/.{name}.<random>.tmp{suffix}`` exclusively; return ``(fd, path)``.

    The file is created with mode 0o666 minus the umask (``tempfile.mkstemp`` would give
    0o600), so a renamed result has the permissions any other new file of the user has.
    ``name`` is shortened when needed so that the temporary name fits in
    :data:`NAME_MAX` bytes. ``OSError`` passes through (callers name the destination).
    """
    folder = Path(folder)
    for _ in range(100):
        tmp = folder / _temporary_name(name, suffix)
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
    format. On any exception it is removed and ``path`` is left as it was. A destination
    that cannot be written (:func:`check_output_path`, or the system's refusal) raises
    :class:`FileWriteError` naming ``path`` and ``name``.
    """
    path = check_output_path(path, name)
    suffix = "".join(path.suffixes[-2:]) if path.suffix == ".gz" else path.suffix
    try:
        fd, tmp = new_temporary_file(path.parent, path.name, suffix)
    except OSError as exc:
        raise _write_error(path, name, exc) from None
    os.close(fd)
    try:
        yield tmp
        try:
            os.replace(tmp, path)
        except OSError as exc:
            raise _write_error(path, name, exc) from None
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_temp(folder, name: str, data: bytes) -> Path:
    """Write ``data`` to a new hidden temporary file in ``folder`` and return its path.

    The name is ``.{name}.<random>.tmp``; the data is flushed to disk; nothing is left
    behind if writing fails (``OSError`` passes through).
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


def write_bytes_atomic(path, data: bytes, name: str = "path") -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder + ``os.replace``.

    Raises :class:`FileWriteError` (an ``OSError``) naming ``path`` when it cannot be
    written; the destination is then left as it was."""
    path = check_output_path(path, name)
    try:
        tmp = write_temp(path.parent, path.name, data)
    except OSError as exc:
        raise _write_error(path, name, exc) from None
    try:
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise _write_error(path, name, exc) from None
        raise
    return path


def write_text_atomic(path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (temporary file in the same folder, then rename).

    Raises :class:`~hopmatch.errors.InvalidTypeError` when ``text`` is not a str (bytes go
    to :func:`write_bytes_atomic`) and :class:`~hopmatch.errors.InvalidArgumentError` for
    an ``encoding`` Python does not know or that cannot encode ``text``, before anything
    is written."""
    if not isinstance(text, str):
        raise InvalidTypeError(f"`text` must be a str (write bytes with write_bytes_atomic), "
                               f"got {describe(text)}", argument="text")
    if not isinstance(encoding, str):
        raise InvalidTypeError(f"`encoding` must be a str, got {describe(encoding)}",
                               argument="encoding")
    try:
        data = text.encode(encoding)
    except LookupError:
        raise InvalidArgumentError(f"`encoding`: unknown encoding {encoding!r}",
                                   argument="encoding") from None
    except UnicodeEncodeError as exc:
        raise InvalidArgumentError(f"`text` cannot be encoded as {encoding!r}: {exc.reason} "
                                   f"at position {exc.start}", argument="text") from None
    return write_bytes_atomic(path, data)


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

    Unlike ``cv2.imwrite``, failure raises (:class:`FileWriteError`, an ``OSError``, or
    ``InvalidArgumentError`` for an unknown suffix) instead of returning False, and never
    leaves a partial file.
    """
    path = Path(path)
    return write_bytes_atomic(path, encode_image(image, path.suffix or ".png"))
