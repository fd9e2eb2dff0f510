"""Checks of the arguments of :func:`~hopmatch_dask.run_batch`, :func:`~hopmatch_dask.match_pairs`
and :func:`~hopmatch_dask.local_cluster`, made on the client before anything starts: no
cluster is started, no folder created and nothing submitted for an argument they refuse.

Each error is one of :mod:`hopmatch.errors` (or :class:`SchedulerAddressError`); its message
names the argument, what was expected and what came, and ``argument`` holds that name.

Examples
--------
>>> check_workers(2)
2
>>> try:
...     check_workers(0)
... except ValueError as exc:
...     print(exc.argument, "|", exc)
workers | `workers` must be None or an int >= 1 (worker processes of the local cluster), got 0
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from hopmatch.errors import (
    BudgetExceededError,
    FileWriteError,
    InvalidArgumentError,
    InvalidTypeError,
)
from hopmatch.files import NAME_MAX, os_reason

__all__ = ["HANDSHAKE_TIMEOUT", "MAX_WORKERS_PER_CORE", "PROBE_TIMEOUT", "SCHEMES",
           "SchedulerAddressError", "check_client", "check_cluster_options", "check_env",
           "check_images", "check_out", "check_progress", "check_scheduler", "check_workers",
           "cores", "describe", "make_folder", "max_local_workers"]

#: A local cluster has at most this many worker processes per core this process may run on
#: (:func:`max_local_workers`): each worker is a process of about 100 MB that matches on one
#: thread, so more than a few per core only costs memory (and a mistyped count would start
#: processes until the machine runs out of it).
MAX_WORKERS_PER_CORE = 4
#: Seconds :func:`check_scheduler` waits for a TCP connection to the scheduler.
PROBE_TIMEOUT = 1.0
#: Seconds :func:`check_scheduler` waits for the scheduler's answer to Dask's handshake
#: (``distributed`` itself would wait for ever on a port where something listens but
#: does not answer).
HANDSHAKE_TIMEOUT = 5.0
#: Address schemes of the schedulers hopmatch_dask connects to (see docs/cluster.md).
SCHEMES = ("tcp", "tls")


class SchedulerAddressError(InvalidArgumentError):
    """The scheduler address cannot be parsed, is of a scheme hopmatch_dask does not use,
    or nothing answers there."""


def describe(value) -> str:
    """A short description of ``value`` for an error message."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    text = repr(value)
    if len(text) > 80:
        text = text[:77] + "..."
    return f"{type(value).__name__} {text}"


def cores() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not Linux
        return max(1, os.cpu_count() or 1)


def max_local_workers() -> int:
    """The most worker processes :func:`~hopmatch_dask.local_cluster` starts:
    :data:`MAX_WORKERS_PER_CORE` per core (:func:`cores`)."""
    return MAX_WORKERS_PER_CORE * cores()


def check_workers(workers, name: str = "workers") -> int | None:
    """``workers`` if it is None or an int in ``[1, max_local_workers()]``, else
    :class:`~hopmatch.errors.InvalidTypeError` / ``InvalidArgumentError`` naming ``name``."""
    if workers is None:
        return None
    expected = f"`{name}` must be None or an int >= 1 (worker processes of the local cluster)"
    if isinstance(workers, (bool, np.bool_)) or not isinstance(workers, (int, np.integer)):
        raise InvalidTypeError(f"{expected}, got {describe(workers)}", argument=name)
    workers = int(workers)
    if workers < 1:
        raise InvalidArgumentError(f"{expected}, got {workers}", argument=name)
    limit = max_local_workers()
    if workers > limit:
        digits = str(workers)
        shown = digits if len(digits) <= 12 else f"{digits[:12]}... ({len(digits)} digits)"
        raise InvalidArgumentError(
            f"`{name}` must be at most {limit} ({MAX_WORKERS_PER_CORE} processes per core "
            f"on the {cores()} cores here), got {shown}; for more workers, start a cluster "
            "and give its scheduler's address", argument=name)
    return workers


def check_env(env, name: str = "env") -> dict:
    """``env`` (None or a mapping of variable names to values) as a dict of strings."""
    if env is None:
        return {}
    if not isinstance(env, Mapping):
        raise InvalidTypeError(f"`{name}` must be None or a mapping of environment variable "
                               f"names to values, got {describe(env)}", argument=name)
    bad = [k for k in env if not isinstance(k, str) or not k or "=" in k or "\0" in k]
    if bad:
        raise InvalidArgumentError(f"`{name}`: {bad[0]!r} cannot name an environment "
                                   "variable", argument=name)
    return {k: str(v) for k, v in env.items()}


def _keyword_names(cls) -> tuple[set[str], bool] | None:
    """The keyword parameters of ``cls.__init__`` and whether it takes ``**kwargs``; None
    when its signature cannot be read."""
    import inspect

    try:
        params = inspect.signature(cls.__init__).parameters.values()
    except (TypeError, ValueError):
        return None
    names = {p.name for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    return names - {"self"}, any(p.kind is p.VAR_KEYWORD for p in params)


def check_cluster_options(options: dict) -> dict:
    """``options`` (keyword arguments for ``distributed.LocalCluster``) if each is a
    parameter of ``LocalCluster`` or of the workers it starts (a ``Nanny`` running a
    ``Worker``, both passing the rest to ``distributed.core.Server``; the
    ``worker_class`` given, if any), else :class:`~hopmatch.errors.InvalidTypeError`
    naming the first unknown one, with the closest known names. ``distributed`` itself
    takes a misspelled option only in each worker process, and fails there ("Nanny failed
    to start") after the scheduler and the other workers have started. A ``worker_class``
    of another kind that takes ``**kwargs`` is left to check its own options."""
    import difflib

    from distributed.core import Server
    from distributed.deploy.local import LocalCluster
    from distributed.nanny import Nanny
    from distributed.worker import Worker

    worker_class = options.get("worker_class")
    own = (worker_class if isinstance(worker_class, type)
           and worker_class not in (Nanny, Worker) else None)
    signatures = [_keyword_names(c) for c in (LocalCluster, Nanny, Worker, Server, own)
                  if c is not None]
    if any(sig is None for sig in signatures):
        return options  # a signature unread: anything may be an option
    if own is not None and signatures[-1][1]:
        return options  # a worker class of its own that takes **kwargs checks them
    known = set().union(*(names for names, _ in signatures))
    for key in options:
        if key not in known:
            near = difflib.get_close_matches(str(key), sorted(known), n=3)
            hint = f" (did you mean {' or '.join(map(repr, near))}?)" if near else ""
            raise InvalidTypeError(
                f"`{key}` is no option of distributed.LocalCluster or of its workers{hint}; "
                "local_cluster passes its keyword arguments to LocalCluster", argument=key)
    return options


def check_client(client, name: str = "client"):
    """``client`` if it is None or a running ``distributed.Client``."""
    if client is None:
        return None
    from distributed.client import Client

    if not isinstance(client, Client):
        hint = (" (to connect to a scheduler by its address, give scheduler=...)"
                if isinstance(client, str) else "")
        raise InvalidTypeError(f"`{name}` must be None or a distributed.Client, got "
                               f"{describe(client)}{hint}", argument=name)
    status = getattr(client, "status", None)
    if status != "running":
        raise InvalidArgumentError(f"`{name}` must be a running distributed.Client, got one "
                                   f"whose status is {status!r} (closed?)", argument=name)
    return client


def check_progress(progress, name: str = "progress"):
    """``progress`` if it is None or callable."""
    if progress is not None and not callable(progress):
        raise InvalidTypeError(f"`{name}` must be None or a callable progress(outcome, done, "
                               f"total), got {describe(progress)}", argument=name)
    return progress


def _refuse(path: str, reason: str, name: str):
    return FileWriteError(f"`{name}`: cannot use {path!r} as the output folder: {reason}",
                          argument=name)


def check_out(out, name: str = "out") -> Path:
    """``out`` as a Path, if it is a folder that can be written to, or a path where one can
    be created (its nearest existing ancestor a writable folder); ``out/summary.csv`` must
    not be a folder. Nothing is created.

    Raises
    ------
    InvalidTypeError
        ``out`` is not a str or ``os.PathLike`` (of a str).
    InvalidArgumentError
        ``out`` is empty or holds a NUL character.
    FileWriteError
        The file system refuses it (an existing file, a part of the path that is a file,
        permission denied, a name of more than 255 bytes...); also an ``OSError``.
    """
    text = os.fspath(out) if isinstance(out, os.PathLike) else out
    if not isinstance(text, str):
        raise InvalidTypeError(f"`{name}` must be a folder path (str or os.PathLike), got "
                               f"{describe(out)}", argument=name)
    if not text:
        raise InvalidArgumentError(f"`{name}` must name a folder, got an empty path (use "
                                   "'.' for the current folder)", argument=name)
    if "\0" in text:
        raise InvalidArgumentError(f"`{name}` is not a valid folder name (it holds a NUL "
                                   f"character): {text!r}", argument=name)
    path = Path(text)
    for part in path.parts:
        if len(os.fsencode(part)) > NAME_MAX:
            raise _refuse(text, f"a part of the path is longer than {NAME_MAX} bytes", name)
    existing = path
    while True:
        try:
            is_dir = existing.is_dir()
            exists = is_dir or existing.exists()
        except OSError as exc:
            raise _refuse(text, os_reason(exc), name) from None
        if exists or existing == existing.parent:
            break
        existing = existing.parent
    if not is_dir:
        where = "it exists and is not a folder" if existing == path else \
            f"{str(existing)!r} is a file, not a folder"
        raise _refuse(text, where, name)
    if not os.access(existing, os.W_OK | os.X_OK):
        what = "" if existing == path else f" in {str(existing)!r}"
        raise _refuse(text, f"permission denied{what}", name)
    if existing == path and (path / "summary.csv").is_dir():
        raise _refuse(text, "a folder stands where summary.csv should be written", name)
    return path


def make_folder(path: Path, name: str = "out") -> Path:
    """Create the folder ``path`` (checked by :func:`check_out`) if it is missing; a refusal
    of the system raises :class:`~hopmatch.errors.FileWriteError` naming ``name``."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _refuse(str(path), f"cannot create the folder: {os_reason(exc)}", name) from None
    return path


def check_images(pairs, max_pixels: int | None, name: str = "pairs") -> None:
    """Refuse, before anything is sent, an array image of more than ``max_pixels`` pixels
    (the detector's budget: ``max_pixels`` of the parameters, else
    ``hopmatch.DericheMoravecDetector``'s default) with
    :class:`~hopmatch.errors.BudgetExceededError` naming the pair. ``pairs`` are
    :class:`~hopmatch_dask.Pair` objects (checked by :func:`~hopmatch_dask.as_pairs`);
    image files are checked from their header by the worker that reads them."""
    if max_pixels is None:
        return
    for i, pair in enumerate(pairs):
        for side in ("left", "right"):
            image = getattr(pair, side)
            if isinstance(image, np.ndarray) and image.ndim >= 2:
                n = int(image.shape[0]) * int(image.shape[1])
                if n > max_pixels:
                    raise BudgetExceededError(
                        f"`{name}[{i}]` ({pair.name!r}): the {side} image has "
                        f"{image.shape[0]} x {image.shape[1]} = {n} pixels, more than "
                        f"max_pixels={max_pixels}; downscale it first, or raise the limit "
                        f"(max_pixels={n} or more)", argument=name)


def check_scheduler(address: str, probe: bool = True) -> str:
    """``address`` if it is a Dask scheduler address that answers, else
    :class:`SchedulerAddressError` saying why, within about :data:`PROBE_TIMEOUT` seconds
    (instead of an internal error from ``distributed``, or a wait of
    ``CONNECT_TIMEOUT`` seconds on a port where nothing listens).

    The scheme must be one of :data:`SCHEMES` (``tcp://``, ``tls://``; distributed's
    ``inproc://``, ``ucx://``, ``ws://`` and ``wss://`` are refused); the address must have
    a host and a numeric port, and, with ``probe``, accept a TCP connection.
    """
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    if not isinstance(address, str) or not address.strip():
        raise SchedulerAddressError(f"`scheduler` must be an address such as "
                                    f"tcp://10.0.0.5:8786, got {describe(address)}",
                                    argument="scheduler")
    shown = address if len(address) <= 200 else address[:197] + "..."
    try:
        scheme, location = parse_address(address)
    except (ValueError, TypeError) as exc:
        raise SchedulerAddressError(f"`scheduler` {shown!r} is not a Dask scheduler "
                                    f"address ({' '.join(str(exc).split())}); expected "
                                    "e.g. tcp://10.0.0.5:8786", argument="scheduler") from None
    if scheme not in SCHEMES:
        raise SchedulerAddressError(
            f"`scheduler` {shown!r}: unknown address scheme {scheme!r} for hopmatch_dask; "
            f"expected {' or '.join(s + '://' for s in SCHEMES)} (e.g. tcp://10.0.0.5:8786)",
            argument="scheduler")
    try:
        host, port = parse_host_port(location, 8786)
    except (ValueError, TypeError) as exc:
        raise SchedulerAddressError(f"`scheduler` {shown!r} is not a Dask scheduler "
                                    f"address ({' '.join(str(exc).split())}); expected "
                                    "e.g. tcp://10.0.0.5:8786", argument="scheduler") from None
    if not host:
        raise SchedulerAddressError(f"`scheduler` {shown!r} names no host; expected "
                                    "e.g. tcp://10.0.0.5:8786", argument="scheduler")
    if not 0 < port < 65536:
        raise SchedulerAddressError(f"`scheduler` {shown!r}: port {port} is not in "
                                    "[1, 65535]", argument="scheduler")
    if probe:
        try:
            socket.create_connection((host, port), timeout=PROBE_TIMEOUT).close()
        except (OSError, ValueError, UnicodeError) as exc:
            reason = getattr(exc, "strerror", None) or type(exc).__name__
            raise SchedulerAddressError(
                f"`scheduler` {shown!r}: cannot reach {host}:{port} ({reason}); is a "
                "scheduler running there (dask scheduler --port ...)?",
                argument="scheduler") from None
        problem = _handshake(address, HANDSHAKE_TIMEOUT)
        if problem:
            raise SchedulerAddressError(
                f"`scheduler` {shown!r}: {host}:{port} accepts connections but {problem}; is "
                "it a Dask scheduler's address?", argument="scheduler")
    return address


def _handshake(address: str, timeout: float) -> str:
    """Why Dask's handshake with ``address`` failed within ``timeout`` seconds ("" when it
    worked). Run on a thread of its own, with its own event loop: callable from code that
    runs in an event loop (a notebook), and never waits longer than ``timeout``."""
    import asyncio
    import threading

    from distributed.comm import connect
    from distributed.security import Security

    outcome: list = []

    async def shake():
        args = Security().get_connection_args("client")
        comm = await asyncio.wait_for(connect(address, timeout=timeout, **args), timeout)
        await comm.close()

    def run():
        try:
            asyncio.run(shake())
        except BaseException as exc:  # noqa: BLE001 - reported to the caller's thread
            outcome.append(exc)
        else:
            outcome.append(None)

    thread = threading.Thread(target=run, name="hopmatch-dask-handshake", daemon=True)
    thread.start()
    thread.join(timeout + 2.0)
    if not outcome:
        return f"gave no Dask handshake within {timeout:g} s"
    exc = outcome[0]
    if exc is None:
        return ""
    if isinstance(exc, (asyncio.TimeoutError, TimeoutError)):
        return f"gave no Dask handshake within {timeout:g} s"
    return f"the Dask handshake failed ({type(exc).__name__}: {' '.join(str(exc).split())[:200]})"
