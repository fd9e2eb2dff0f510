"""Batches on a Dask cluster: :func:`match_pairs` (Python) and :func:`run_batch` (files).

The client submits one task per pair; a worker reads the two images, matches them and sends
back the result, which the client alone writes, atomically (temporary name, then rename).
So a result file exists only when complete, each pair has at most one, a worker lost
mid-task costs nothing but the task (the scheduler runs it again on another worker), and a
rerun skips the pairs whose result is already there.
"""

from __future__ import annotations

import contextlib
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.files import write_text_atomic
from hopmatch.matching.stereo_match import stereo_pipeline

from .pairs import Pair, as_pairs
from .results import complete_rows, finished_counts, summary_table
from .tasks import batch_task, match_pair

__all__ = ["BatchReport", "Outcome", "SchedulerAddressError", "check_params",
           "check_scheduler", "local_cluster", "match_pairs", "run_batch"]

#: Seconds to wait for a scheduler given by address.
CONNECT_TIMEOUT = 30
#: Seconds between two writes of summary.csv during a batch (it is also written at the
#: end, and when the batch is interrupted): results finished before a hard kill are
#: recorded, hence not computed again.
SUMMARY_EVERY = 2.0


def check_params(params: dict, caller: str = "hopmatch_dask") -> dict:
    """``params`` if :func:`hopmatch.match_stereo` accepts them, else its error (raised here,
    on the client, before anything is submitted).

    The parameters are shared between the detector and the matcher by the library's one rule,
    :func:`hopmatch.matching.stereo_match.stereo_pipeline`; an unknown name raises
    :class:`~hopmatch.errors.InvalidArgumentError` naming ``caller``. ``rectified``
    (``match_stereo``'s own argument) may be given too: ``False`` for unrectified pairs,
    whose geometry and disparity range are estimated (then without ``max_disparity``),
    ``True`` for the rows only, None (as left out) for match_stereo's own choice.
    """
    rest = {k: v for k, v in params.items() if k != "rectified"}
    if "rectified" in params:
        rectified = params["rectified"]
        if rectified is not None and not isinstance(rectified, (bool, np.bool_)):
            raise InvalidTypeError(
                f"`rectified` must be None, True or False, got {rectified!r}",
                argument="rectified")
        if rectified is not None and not rectified and rest.get("max_disparity") is not None:
            raise InvalidArgumentError(
                f"{caller} got rectified=False and max_disparity={rest['max_disparity']:g}: "
                "the disparity range of an unrectified pair is found with its geometry; "
                "leave max_disparity=None", argument="max_disparity")
    stereo_pipeline(rest, caller)
    return dict(params)


#: Seconds :func:`check_scheduler` waits for a TCP connection to the scheduler.
PROBE_TIMEOUT = 1.0


class SchedulerAddressError(InvalidArgumentError):
    """The scheduler address cannot be parsed, or nothing answers there."""


def check_scheduler(address: str, probe: bool = True) -> str:
    """``address`` if it is a Dask scheduler address that answers, else
    :class:`SchedulerAddressError` saying why, within about :data:`PROBE_TIMEOUT` seconds
    (instead of an internal error from ``distributed``, or a wait of
    :data:`CONNECT_TIMEOUT` seconds on a port where nothing listens).

    The scheme must be one ``distributed`` knows (``tcp://`` by default); a ``tcp://`` or
    ``tls://`` address must have a host and a numeric port, and, with ``probe``, accept a
    TCP connection.
    """
    import socket

    from distributed.comm import registry
    from distributed.comm.addressing import parse_address, parse_host_port

    if not isinstance(address, str) or not address.strip():
        raise SchedulerAddressError(f"`scheduler` must be an address such as "
                                    f"tcp://10.0.0.5:8786, got {address!r}",
                                    argument="scheduler")
    try:
        scheme, location = parse_address(address)
        registry.get_backend(scheme)
        host, port = parse_host_port(location, 8786) if scheme in ("tcp", "tls") else ("", 0)
    except (ValueError, TypeError) as exc:
        raise SchedulerAddressError(f"`scheduler` {address!r} is not a Dask scheduler "
                                    f"address ({' '.join(str(exc).split())}); expected "
                                    "e.g. tcp://10.0.0.5:8786", argument="scheduler") from None
    if scheme in ("tcp", "tls"):
        if not host:
            raise SchedulerAddressError(f"`scheduler` {address!r} names no host; expected "
                                        "e.g. tcp://10.0.0.5:8786", argument="scheduler")
        if not 0 < port < 65536:
            raise SchedulerAddressError(f"`scheduler` {address!r}: port {port} is not in "
                                        "[1, 65535]", argument="scheduler")
        if probe:
            try:
                socket.create_connection((host, port), timeout=PROBE_TIMEOUT).close()
            except OSError as exc:
                reason = exc.strerror or type(exc).__name__
                raise SchedulerAddressError(
                    f"`scheduler` {address!r}: cannot reach {host}:{port} ({reason}); is a "
                    "scheduler running there (dask scheduler --port ...)?",
                    argument="scheduler") from None
    return address


def _key(prefix: str, pair: Pair, params: dict) -> str:
    from dask.base import tokenize

    return f"{prefix}-{pair.name}-{tokenize(pair.left, pair.right, sorted(params.items()))}"


def match_pairs(pairs, client=None, **params):
    """Match many pairs on Dask.

    Parameters
    ----------
    pairs : sequence of Pair, (left, right) or (left, right, name)
        ``left``/``right`` are image paths (read by the workers) or arrays (sent to them).
    client : distributed.Client, optional
        Submit now to this cluster and return futures. Without it, nothing runs yet: a lazy
        ``dask.bag.Bag`` is returned, computed by whatever scheduler is active
        (``bag.compute()``; a ``distributed.Client`` made before is used by it).
    **params
        Detector and matcher parameters, as for :func:`hopmatch.match_stereo`.

    Returns
    -------
    list of distributed.Future or dask.bag.Bag
        One :class:`~hopmatch_dask.PairResult` per pair, in the order of ``pairs``. A pair
        that fails raises its error from ``future.result()`` / ``bag.compute()``.

    Examples
    --------
    >>> from distributed import Client, LocalCluster                     # doctest: +SKIP
    >>> with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, \\
    ...         Client(cluster) as client:                                # doctest: +SKIP
    ...     futures = match_pairs([("l0.png", "r0.png"), ("l1.png", "r1.png")], client,
    ...                           max_disparity=64)
    ...     results = client.gather(futures)
    """
    params = check_params(params, "match_pairs")
    items = as_pairs(pairs)
    if client is not None:
        return [client.submit(match_pair, p, params, key=_key("hopmatch-pair", p, params),
                              pure=True) for p in items]
    import dask.bag as db

    return db.from_sequence(items, npartitions=max(1, len(items))).map(match_pair, params)


@dataclass
class Outcome:
    """What became of one pair of a batch (one line of summary.csv).

    ``status`` is ``"ok"`` (matched now), ``"skipped"`` (its complete result was already
    there), ``"failed"`` (``error`` says why) or ``"not run"`` (the batch was interrupted).
    """

    name: str
    status: str
    matches: int | None = None
    seconds: float | None = None
    error: str = ""
    worker: str = ""


@dataclass
class BatchReport:
    """All outcomes of :func:`run_batch`, in the order of the pairs."""

    outcomes: list[Outcome]
    seconds: float
    out: Path
    workers: int = 0

    @property
    def ok(self) -> bool:
        """Every pair has its result (matched now or before)."""
        return all(o.status in ("ok", "skipped") for o in self.outcomes)

    def count(self, status: str) -> int:
        return sum(o.status == status for o in self.outcomes)


def local_cluster(workers: int | None = None, **kwargs):
    """A ``distributed.LocalCluster`` on this machine: ``workers`` processes (default: one
    per core) of one thread each, listening on 127.0.0.1 only, no dashboard.

    OpenCV in each worker runs on one thread (``OPENCV_FOR_THREADS_NUM=1``): the workers
    already use every core, and OpenCV's own threads only add contention (measured by
    ``benchmarks/dask_batch.py``, see ``docs/cluster.md``).
    ``kwargs`` go to ``LocalCluster`` (``env`` is merged).
    """
    from distributed import LocalCluster

    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") \
            else (os.cpu_count() or 1)
    env = {"OPENCV_FOR_THREADS_NUM": "1", **kwargs.pop("env", {})}
    options = dict(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                   dashboard_address=None, env=env,
                   # the scheduler's small HTTP server (health, metrics): a free port on
                   # 127.0.0.1 rather than 8787, which another cluster may hold
                   scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})
    options.update(kwargs)
    return LocalCluster(**options)


@contextlib.contextmanager
def _client_for(client, scheduler, workers):
    """The client to use: ``client``, one connected to ``scheduler``, or a local cluster's."""
    if client is not None:
        yield client
        return
    from distributed import Client

    if scheduler:
        with Client(scheduler, timeout=CONNECT_TIMEOUT) as c:
            yield c
        return
    with local_cluster(workers) as cluster, Client(cluster) as c:
        yield c


def run_batch(pairs, out, *, client=None, scheduler: str | None = None,
              workers: int | None = None, progress=None, **params) -> BatchReport:
    """Match every pair on a Dask cluster and write ``out/<name>.csv`` and ``out/summary.csv``.

    Parameters
    ----------
    pairs : sequence of Pair, (left, right) or (left, right, name)
        Image paths the workers can read (see :func:`~hopmatch_dask.read_pairs`).
    out : str or pathlib.Path
        Output folder (created if missing). Each result has the columns of
        ``hopmatch match``'s matches.csv.
    client : distributed.Client, optional
        Use this cluster. Else ``scheduler`` (an address such as ``tcp://10.0.0.5:8786``) is
        connected to, else a :func:`local_cluster` of ``workers`` processes is started and
        closed at the end.
    progress : callable, optional
        Called as ``progress(outcome, done, total)`` after each pair.
    **params
        Detector and matcher parameters, as for :func:`hopmatch.match_stereo`.

    Returns
    -------
    BatchReport
        ``report.ok`` is True when every pair has its result.

    Notes
    -----
    Pairs whose ``out/<name>.csv`` exists and is complete are skipped (not submitted), so
    rerunning an interrupted batch finishes it; complete means well formed and holding the
    number of matches that ``out/summary.csv`` recorded for the pair
    (:func:`~hopmatch_dask.results.complete_rows`; summary.csv is rewritten every
    :data:`SUMMARY_EVERY` seconds during the batch, at its end and when it is
    interrupted). Delete a result, or use another folder, to compute it again (e.g. with
    other parameters). A pair whose images cannot be read
    or matched is recorded as ``failed`` in summary.csv and the others go on. A worker lost
    mid-task has its tasks run again elsewhere (up to ``distributed.scheduler.allowed-failures``
    times, 3 by default, then the pair fails with ``KilledWorker``).
    """
    params = check_params(params, "run_batch")
    items = as_pairs(pairs)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    outcomes: dict[str, Outcome] = {}
    total, done = len(items), 0
    last_summary = [time.monotonic()]

    def ordered() -> list[Outcome]:
        return [outcomes.get(p.name) or Outcome(p.name, "not run") for p in items]

    def record(outcome: Outcome) -> None:
        nonlocal done
        outcomes[outcome.name] = outcome
        done += 1
        if progress is not None:
            progress(outcome, done, total)
        if outcome.status == "ok" and time.monotonic() - last_summary[0] >= SUMMARY_EVERY:
            write_text_atomic(out / "summary.csv", summary_table(ordered()))
            last_summary[0] = time.monotonic()

    todo = []
    recorded = finished_counts(out / "summary.csv")
    for p in items:
        # a pair the summary does not record as done (-1 rows) is computed again
        rows = complete_rows(out / f"{p.name}.csv", recorded.get(p.name, -1))
        if rows is None:
            todo.append(p)
        else:
            record(Outcome(p.name, "skipped", rows))
    n_workers = 0
    try:
        if todo:
            with _client_for(client, scheduler, workers) as c:
                n_workers = len(c.nthreads())
                _run(c, todo, params, out, record)
    finally:
        final = ordered()
        write_text_atomic(out / "summary.csv", summary_table(final))
    return BatchReport(final, time.perf_counter() - t0, out, n_workers)


def _run(client, todo: list[Pair], params: dict, out: Path, record) -> None:
    from distributed import as_completed

    futures = {}
    for p in todo:
        f = client.submit(batch_task, p, params, key=_key("hopmatch-batch", p, params),
                          pure=True, retries=0)
        futures[f] = p
    try:
        for f in as_completed(list(futures)):
            p = futures.pop(f)
            try:
                r = f.result()
            except Exception as exc:  # KilledWorker, a cancelled task, a lost cluster...
                record(Outcome(p.name, "failed", error=f"{type(exc).__name__}: "
                                                       f"{' '.join(str(exc).split())}"))
                continue
            finally:
                f.release()
            if r["status"] != "ok":
                record(Outcome(p.name, "failed", seconds=r.get("seconds"),
                               error=r.get("error", ""), worker=r.get("worker", "")))
                continue
            try:
                write_text_atomic(out / f"{p.name}.csv", r["csv"])
            except OSError as exc:
                record(Outcome(p.name, "failed", seconds=r["seconds"], worker=r["worker"],
                               error=f"cannot write {out / (p.name + '.csv')}: "
                                     f"{exc.strerror or exc}"))
                continue
            record(Outcome(p.name, "ok", r["matches"], r["seconds"], worker=r["worker"]))
    finally:
        if futures:  # interrupted: do not leave work running on a shared cluster
            client.cancel(list(futures))
