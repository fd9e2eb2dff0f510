"""Input and output of the commands: images read with errors naming the file, the output
folder staged so that a run leaves either all of its files or none (whatever signal
arrives), and run.json."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import platform
import secrets
import shutil
import signal
import threading
from datetime import datetime, timezone
from pathlib import Path

import cv2
import numpy as np

import hopmatch

from .. import imageio
from .._validate import DEFAULT_MAX_PIXELS
from ..files import NAME_MAX, encode_image
from .reporting import CLIError

__all__ = ["Outputs", "Terminated", "image_info", "ms", "raise_if_terminated", "read_image",
           "run_json", "signals_deferred", "terminations_as_interrupts", "versions"]

#: The signals a run turns into :class:`Terminated` (SIGINT is Python's KeyboardInterrupt
#: already) and that :func:`signals_deferred` holds back during the final renames: every
#: catchable signal whose default action ends the process (SIGQUIT's core dump included),
#: but for SIGPIPE (Python ignores it: a closed pipe is a BrokenPipeError) and the faults
#: of the process itself (SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGSYS, SIGTRAP), which
#: a handler cannot recover from. Only where the signal still has its default action: a
#: signal ignored by the parent (``nohup``'s SIGHUP) stays ignored, and one an embedding
#: program handles stays its own.
CAUGHT_SIGNALS = tuple(getattr(signal, n) for n in (
    "SIGTERM", "SIGHUP", "SIGQUIT", "SIGUSR1", "SIGUSR2", "SIGALRM", "SIGVTALRM", "SIGPROF",
    "SIGXCPU", "SIGXFSZ", "SIGPOLL", "SIGPWR", "SIGSTKFLT") if hasattr(signal, n))


def _defaults(signals) -> list[int]:
    """Those of ``signals`` whose handler is the default action now."""
    return [s for s in signals if signal.getsignal(s) == signal.SIG_DFL]


def read_image(path: str, max_pixels: int | None = DEFAULT_MAX_PIXELS) -> np.ndarray:
    """:func:`hopmatch.imageio.read_image`, its error as a :class:`CLIError`: a named pipe
    or device is refused before it is opened, an image of more than ``max_pixels`` pixels
    (the ``--max-pixels`` option) from its header, before it is decoded."""
    try:
        return imageio.read_image(path, max_pixels=max_pixels)
    except imageio.ImageReadError as exc:
        problem = exc.problem
        if exc.kind == "too_many_pixels":
            problem = problem.replace("max_pixels", "--max-pixels").replace(
                " (None: no limit)", "")
        raise CLIError(exc.path, problem) from None


# --------------------------------------------------------------------------------------
# Signals: SIGTERM, SIGHUP... end a run as Ctrl-C does; the final renames are not interrupted
# --------------------------------------------------------------------------------------


class Terminated(KeyboardInterrupt):
    """A signal of :data:`CAUGHT_SIGNALS` (SIGTERM, SIGHUP...) arrived: raised in the main
    thread, so that the run is rolled back as after Ctrl-C (``signum`` says which signal;
    the exit status is 128 + signum)."""

    def __init__(self, signum: int):
        super().__init__(f"signal {signum}")
        self.signum = signum


#: The signals :func:`_raise_terminated` received in this process's current run, in order.
_received: list[int] = []


def _raise_terminated(signum, frame):
    _received.append(signum)
    raise Terminated(signum)


def raise_if_terminated() -> None:
    """Raise :class:`Terminated` again for the first signal of the current run that
    :func:`terminations_as_interrupts` turned into one, if any: a handler that runs inside
    a finaliser or a garbage-collector callback has its exception printed by Python and
    dropped, and the run would go on as if the signal never came. :meth:`Outputs.commit`
    and the end of :func:`terminations_as_interrupts` call it, so that such a run still
    ends as interrupted, its files never placed."""
    if _received:
        raise Terminated(_received[0])


@contextlib.contextmanager
def terminations_as_interrupts():
    """While inside, SIGTERM, SIGHUP and the other :data:`CAUGHT_SIGNALS` that still have
    their default action raise :class:`Terminated` (a KeyboardInterrupt) in the main thread
    instead of ending the process at once, so that a run killed that way
    removes its staged files. Outside the main thread (where handlers cannot be set) it
    does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {}
    _received.clear()
    try:
        for signum in _defaults(CAUGHT_SIGNALS):
            old[signum] = signal.signal(signum, _raise_terminated)
        yield
        raise_if_terminated()  # a signal whose exception something swallowed
    finally:
        for signum, handler in old.items():
            signal.signal(signum, handler)
        _received.clear()  # said; a later run (in any thread) starts afresh


@contextlib.contextmanager
def signals_deferred():
    """Hold SIGINT and :data:`CAUGHT_SIGNALS` back while inside (main thread only; an
    ignored one stays ignored): each one that arrives is delivered again, to the handler of
    before, on the way out. For the few
    renames that make a run's files appear together."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []
    old = {}
    try:
        for signum in (signal.SIGINT, *CAUGHT_SIGNALS):
            if signal.getsignal(signum) in (signal.SIG_IGN, None):  # ignored: stays so
                continue
            old[signum] = signal.signal(signum, lambda n, f: pending.append(n))
        yield
    finally:
        for signum, handler in old.items():
            signal.signal(signum, handler)
        for signum in dict.fromkeys(pending):
            signal.raise_signal(signum)


# --------------------------------------------------------------------------------------
# The output folder
# --------------------------------------------------------------------------------------


def _too_long(path: Path) -> str | None:
    for part in path.parts:
        if len(os.fsencode(part)) > NAME_MAX:
            return (f"the name {part[:40]!r}... is too long ({len(os.fsencode(part))} bytes "
                    f"long, more than the {NAME_MAX} a file system allows)")
    return None


class Outputs:
    """The output folder of one run: all of its files appear, or none.

    ``open()`` checks the folder and makes a hidden staging folder: for a folder that does
    not exist yet, beside it (missing parents are created), to be renamed into place in one
    step; for an existing folder (reused), inside it. ``add()`` writes a file into the
    staging folder. ``commit()`` makes them appear: one rename of the staging folder, or,
    in a reused folder, the files this run replaces set aside (``run.json`` first), the new
    ones moved in (``run.json`` last), the old ones removed, all rolled back on any
    failure; SIGINT, SIGTERM and SIGHUP are held back meanwhile
    (:func:`signals_deferred`). So a folder with a ``run.json`` holds every file that
    ``run.json`` lists from that run, even after ``kill -9``. ``abort()`` removes the
    staging folder and the parents ``open()`` created (if empty).
    """

    def __init__(self, folder: str):
        self.label = folder
        self.path = Path(folder)
        self.created: list[Path] = []
        self.names: list[str] = []
        self.stage: Path | None = None
        self.fresh = False

    def open(self) -> None:
        problem = _too_long(self.path.absolute())
        if problem:
            raise CLIError(self.label, f"cannot create the folder: {problem}")
        try:
            if self.path.exists() and not self.path.is_dir():
                raise CLIError(self.label, "exists and is not a folder")
            self.fresh = not self.path.is_dir()
        except OSError as exc:
            raise CLIError(self.label, f"cannot use the folder: {imageio.os_reason(exc)}") \
                from None
        parent = self.path.absolute().parent if self.fresh else self.path
        if self.fresh:
            self._make_parents(parent)
        stem = self.path.absolute().name[:100]
        self.stage = parent / f".{stem}.hopmatch-{secrets.token_hex(4)}.tmp"
        try:
            os.mkdir(self.stage, 0o777)  # the umask applies: the folder's mode once renamed
        except OSError as exc:
            self.stage = None
            self.abort()
            what = "create the folder" if self.fresh else "write in the folder"
            raise CLIError(self.label, f"cannot {what}: {imageio.os_reason(exc)}") from None

    def _make_parents(self, parent: Path) -> None:
        missing, q = [], parent
        while not q.exists() and q.parent != q:
            missing.append(q)
            q = q.parent
        if not q.is_dir():
            raise CLIError(self.label, "cannot create the folder: a part of the path is a "
                                       "file, not a folder")
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            self._remove_created(missing)
            raise CLIError(self.label,
                           f"cannot create the folder: {imageio.os_reason(exc)}") from None
        self.created = missing

    def add(self, name: str, data: bytes) -> None:
        if self.stage is None:
            raise CLIError(self.label, "the output folder is not open")
        try:
            fd = os.open(self.stage / name, os.O_WRONLY | os.O_CREAT | os.O_EXCL
                         | getattr(os, "O_BINARY", 0), 0o666)
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        except OSError as exc:
            raise CLIError(str(self.path / name),
                           f"cannot write: {imageio.os_reason(exc)}") from None
        self.names.append(name)

    def add_text(self, name: str, text: str) -> None:
        self.add(name, text.encode("utf-8"))

    def add_image(self, name: str, image: np.ndarray) -> None:
        self.add(name, encode_image(image, Path(name).suffix))

    def commit(self) -> None:
        raise_if_terminated()  # terminated, though the exception got lost: place nothing
        with signals_deferred():
            if self.fresh:
                try:
                    os.rename(self.stage, self.path)
                except OSError as exc:
                    if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST) or \
                            not self.path.is_dir():
                        self.abort()
                        raise CLIError(self.label, "cannot rename the finished files into "
                                                   f"place: {imageio.os_reason(exc)}") from None
                    # made meanwhile (by a parallel run...): move the files in one by one
                else:
                    self.stage, self.created = None, []
                    return
            self._move_in()

    def _move_in(self) -> None:
        for name in self.names:
            final = self.path / name
            if final.is_dir() and not final.is_symlink():
                self.abort()
                raise CLIError(str(final), "is a folder; move it away or choose another --out")
        aside = self.stage / ".replaced"
        replaced, placed = [], []
        try:
            os.mkdir(aside)
            for name in sorted(self.names, key=lambda n: n != "run.json"):  # run.json first
                if os.path.lexists(self.path / name):
                    os.rename(self.path / name, aside / name)
                    replaced.append(name)
            for name in sorted(self.names, key=lambda n: n == "run.json"):  # run.json last
                os.rename(self.stage / name, self.path / name)
                placed.append(name)
        except BaseException as exc:
            for name in placed:
                with contextlib.suppress(OSError):
                    os.rename(self.path / name, self.stage / name)
            for name in replaced:
                with contextlib.suppress(OSError):
                    os.rename(aside / name, self.path / name)
            self.abort()
            if isinstance(exc, OSError):
                raise CLIError(self.label, "cannot rename the finished files: "
                                           f"{imageio.os_reason(exc)}") from None
            raise
        shutil.rmtree(self.stage, ignore_errors=True)
        self.stage, self.created = None, []

    def abort(self) -> None:
        if self.stage is not None:
            shutil.rmtree(self.stage, ignore_errors=True)
            self.stage = None
        self._remove_created(self.created)
        self.created = []

    @staticmethod
    def _remove_created(folders) -> None:
        for folder in folders:  # deepest first
            try:
                folder.rmdir()
            except OSError:
                break


# --------------------------------------------------------------------------------------
# run.json
# --------------------------------------------------------------------------------------


def versions() -> dict:
    """Versions of hopmatch, OpenCV, NumPy, Numba and Python."""
    import numba

    return {
        "hopmatch": hopmatch.__version__,
        "opencv": cv2.__version__,
        "numpy": np.__version__,
        "numba": numba.__version__,
        "python": platform.python_version(),
    }


def image_info(path: str, image: np.ndarray) -> dict:
    """Absolute path, shape and dtype of an input image."""
    return {"path": str(Path(path).absolute()), "shape": list(image.shape),
            "dtype": str(image.dtype)}


def ms(seconds: float) -> float:
    """Seconds as milliseconds, rounded to the microsecond."""
    return round(seconds * 1000.0, 3)


def run_json(command: str, **sections) -> str:
    """The text of run.json: the command, when, the versions, then ``sections``."""
    doc = {"command": command, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
           "versions": versions(), **sections}
    return json.dumps(doc, indent=2, default=str) + "\n"
