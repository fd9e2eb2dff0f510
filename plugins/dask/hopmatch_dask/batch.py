"""Batches on a Dask cluster: :func:`match_pairs` (Python) and :func:`run_batch` (files).

The client submits one task per pair; a worker reads the two images, matches them and sends
back the result, which the client alone writes, atomically (temporary name, then rename).
So a result file exists only when complete, each pair has at most one, a worker lost
mid-task costs nothing but the task (the scheduler runs it again on another worker), and a
rerun skips the pairs whose result is already there.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hopmatch.errors import FileWriteError, InvalidArgumentError, InvalidTypeError
from hopmatch.files import os_reason, write_text_atomic
from hopmatch.matching.stereo_match import stereo_pipeline

from .checks import (
    PROBE_TIMEOUT,
    SchedulerAddressError,
    check_client,
    check_cluster_options,
    check_env,
    check_images,
    check_out,
    check_progress,
    check_scheduler,
    check_workers,
    cores,
    describe,
    make_folder,
)
from .pairs import Pair, as_pairs
from .results import complete_rows, finished_counts, short_text, summary_table
from .tasks import batch_task, give_warnings, match_pair, warnings_text

__all__ = ["BatchReport", "Outcome", "PROBE_TIMEOUT", "SchedulerAddressError", "check_params",
           "check_scheduler", "local_cluster", "match_pairs", "run_batch"]

#: Seconds to wait for a scheduler given by address (after :func:`check_scheduler` found
#: that it accepts connections).
CONNECT_TIMEOUT = 30
#: Seconds between two writes of summary.csv during a batch (it is also written at the
#: end, and when the batch is interrupted): results finished before a hard kill are
#: recorded, hence not computed again.
SUMMARY_EVERY = 2.0


def check_params(params: Mapping, caller: str = "hopmatch_dask") -> dict:
    """``params`` if :func:`hopmatch.match_stereo` accepts them, else its error (raised here,
    on the client, before anything is submitted).

    ``params`` is a mapping of parameter names to values (else
    :class:`~hopmatch.errors.InvalidTypeError` naming ``params``). The parameters are shared
    between the detector and the matcher by the library's one rule,
    :func:`hopmatch.matching.stereo_match.stereo_pipeline`; an unknown name raises
    :class:`~hopmatch.errors.InvalidArgumentError` naming ``caller``. ``rectified``
    (``match_stereo``'s own argument) may be given too: ``False`` for unrectified pairs,
    whose geometry and disparity range are estimated (then without ``max_disparity``),
    ``True`` for the rows only, None (as left out) for match_stereo's own choice.

    Examples
    --------
    >>> check_params({"max_disparity": 16})
    {'max_disparity': 16}
    >>> try:
    ...     check_params({"max_disparity": "16"})
    ... except TypeError as exc:
    ...     print(exc.argument, "|", exc)
    max_disparity | `max_disparity` must be a number, got str '16'
    """
    if not isinstance(params, Mapping):
        raise InvalidTypeError(f"`params` must be a mapping of parameter names to values, got "
                               f"{describe(params)}", argument="params")
    rest = {k: v for k, v in params.items() if k != "rectified"}
    rectified = params.get("rectified")
    if rectified is not None and not isinstance(rectified, (bool, np.bool_)):
        raise InvalidTypeError(f"`rectified` must be None, True or False, got "
                               f"{describe(rectified)}", argument="rectified")
    stereo_pipeline(rest, caller)  # every value checked (types first) by its class
    if rectified is not None and not rectified and rest.get("max_disparity") is not None:
        raise InvalidArgumentError(
            f"{caller} got rectified=False and max_disparity={rest['max_disparity']!r}: "
            "the disparity range of an unrectified pair is found with its geometry; "
            "leave max_disparity=None", argument="max_disparity")
    return dict(params)


def _max_pixels(params: dict) -> int | None:
    """The detector's ``max_pixels`` for ``params`` (checked by :func:`check_params`)."""
    detector, _ = stereo_pipeline({k: v for k, v in params.items() if k != "rectified"})
    return detector.get_params()["max_pixels"]


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
        that fails raises its error from ``future.result()`` / ``bag.compute()``. The
        warnings matching gave on the worker (e.g. a
        :class:`~hopmatch.errors.FewMatchesWarning` for a pair without matches) are in
        ``result.warnings`` and given again (``warnings.warn``, same category and message)
        where the result arrives: ``future.result()``, ``client.gather``.

    Raises
    ------
    InvalidTypeError, InvalidArgumentError
        Before anything is submitted: bad ``pairs`` (their types, names, image types),
        ``client`` (not a running ``distributed.Client``) or parameters.
    BudgetExceededError
        An array image of more pixels than the detector's ``max_pixels`` (the parameters',
        else 50 million), before anything is sent.

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
    check_images(items, _max_pixels(params))
    if check_client(client) is not None:
        return [client.submit(match_pair, p, params, key=_key("hopmatch-pair", p, params),
                              pure=True) for p in items]
    import dask.bag as db

    return db.from_sequence(items, npartitions=max(1, len(items))).map(match_pair, params)


@dataclass
class Outcome:
    """What became of one pair of a batch (one line of summary.csv).

    ``status`` is ``"ok"`` (matched now), ``"skipped"`` (its complete result was already
    there), ``"failed"`` (``error`` says why) or ``"not run"`` (the batch was interrupted).
    ``warning`` holds the warnings matching gave for an ``ok`` pair (``"FewMatchesWarning:
    no matches: ..."``; several joined by ``" | "``), empty when there were none.
    """

    name: str
    status: str
    matches: int | None = None
    seconds: float | None = None
    error: str = ""
    worker: str = ""
    warning: str = ""


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

    ``workers`` is None or an int from 1 to :func:`~hopmatch_dask.checks.max_local_workers`
    (4 per core), else :class:`~hopmatch.errors.InvalidTypeError` /
    ``InvalidArgumentError`` naming ``workers``, before anything starts.
    OpenCV in each worker runs on one thread (``OPENCV_FOR_THREADS_NUM=1``): the workers
    already use every core, and OpenCV's own threads only add contention (measured by
    ``benchmarks/dask_batch.py``, see ``docs/cluster.md``).
    ``kwargs`` go to ``LocalCluster`` (``env``, None or a mapping, is merged); one that is
    no option of ``LocalCluster`` or of its workers raises ``InvalidTypeError`` naming it
    (:func:`~hopmatch_dask.checks.check_cluster_options`), before anything starts.
    """
    workers = check_workers(workers)
    env = check_env(kwargs.pop("env", None))
    check_cluster_options(kwargs)
    from distributed import LocalCluster

    if workers is None:
        workers = cores()
    env = {"OPENCV_FOR_THREADS_NUM": "1", **env}
    options = dict(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                   dashboard_address=None, env=env,
                   # the scheduler's small HTTP server (health, metrics): a free port on
                   # 127.0.0.1 rather than 8787, which another cluster may hold
                   scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})
    options.update(kwargs)
    return LocalCluster(**options)


@contextlib.contextmanager
def _connected(scheduler: str):
    """A client of the scheduler at ``scheduler`` (checked by :func:`check_scheduler`); a
    failure to connect raises :class:`SchedulerAddressError` naming the address."""
    from distributed import Client

    try:
        c = Client(scheduler, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as exc:
        raise SchedulerAddressError(
            f"`scheduler` {scheduler!r}: cannot connect to a Dask scheduler there "
            f"({short_text(f'{type(exc).__name__}: {exc}', 300)})",
            argument="scheduler") from None
    with c:
        yield c


@contextlib.contextmanager
def _local_client(workers):
    from distributed import Client

    with local_cluster(workers) as cluster, Client(cluster) as c:
        yield c


def _check_sources(client, scheduler, workers) -> None:
    """Refuse contradictory choices of the cluster, naming them."""
    if client is not None and scheduler is not None:
        raise InvalidArgumentError("give `client` or `scheduler`, not both (the client is "
                                   "already connected to its scheduler)", argument="scheduler")
    if workers is not None and (client is not None or scheduler is not None):
        given = "`client`" if client is not None else "`scheduler`"
        raise InvalidArgumentError(f"`workers` sets the size of the local cluster; it cannot "
                                   f"be given with {given} (size that cluster where it runs)",
                                   argument="workers")


def run_batch(pairs, out, *, client=None, scheduler: str | None = None,
              workers: int | None = None, progress=None, **params) -> BatchReport:
    """Match every pair on a Dask cluster and write ``out/<name>.csv`` and ``out/summary.csv``.

    Parameters
    ----------
    pairs : sequence of Pair, (left, right) or (left, right, name)
        Image paths the workers can read (see :func:`~hopmatch_dask.read_pairs`), or arrays.
    out : str or pathlib.Path
        Output folder (created if missing). Each result has the columns of
        ``hopmatch match``'s matches.csv.
    client : distributed.Client, optional
        Use this cluster (a running client). Else ``scheduler`` (an address such as
        ``tcp://10.0.0.5:8786``) is connected to, else a :func:`local_cluster` of
        ``workers`` processes is started and closed at the end. ``client``, ``scheduler``
        and ``workers`` exclude one another.
    progress : callable, optional
        Called as ``progress(outcome, done, total)`` after each pair.
    **params
        Detector and matcher parameters, as for :func:`hopmatch.match_stereo`.

    Returns
    -------
    BatchReport
        ``report.ok`` is True when every pair has its result.

    Raises
    ------
    InvalidTypeError, InvalidArgumentError
        A bad argument (``pairs``, a pair's name or images, ``out``, ``client``,
        ``scheduler``, ``workers``, ``progress``, a parameter), or contradictory ones.
    FileWriteError
        ``out`` cannot be a folder written to (an ``OSError`` too).
    SchedulerAddressError
        ``scheduler`` is not a ``tcp://`` or ``tls://`` address, or no scheduler answers
        there.
    BudgetExceededError
        An array image of more pixels than the detector's ``max_pixels``.

    All of them are raised before anything is written, started or submitted (a scheduler is
    connected to before ``out`` is created).

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
    times, 3 by default, then the pair fails with ``KilledWorker``). The warnings matching
    gave for a pair (a pair without matches gives a
    :class:`~hopmatch.errors.FewMatchesWarning` saying why) are given again on the client
    and recorded in the ``warning`` column of summary.csv.
    """
    params = check_params(params, "run_batch")
    items = as_pairs(pairs)
    check_images(items, _max_pixels(params))
    out = check_out(out)
    check_progress(progress)
    check_client(client)
    workers = check_workers(workers)
    _check_sources(client, scheduler, workers)
    if scheduler is not None:
        check_scheduler(scheduler)

    with contextlib.ExitStack() as stack:
        if scheduler is not None:  # connected before anything is written
            client = stack.enter_context(_connected(scheduler))
        make_folder(out)
        return _batch(items, out, params, progress, client, workers, stack)


def _batch(items, out: Path, params: dict, progress, client, workers, stack) -> BatchReport:
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
            if client is None:
                client = stack.enter_context(_local_client(workers))
            n_workers = len(client.nthreads())
            _run(client, todo, params, out, record)
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
                record(Outcome(p.name, "failed",
                               error=short_text(f"{type(exc).__name__}: {exc}")))
                continue
            finally:
                f.release()
            if r["status"] != "ok":
                record(Outcome(p.name, "failed", seconds=r.get("seconds"),
                               error=short_text(r.get("error", "")),
                               worker=r.get("worker", "")))
                continue
            try:
                write_text_atomic(out / f"{p.name}.csv", r["csv"])
            except OSError as exc:
                error = str(exc) if isinstance(exc, FileWriteError) else \
                    f"cannot write {out / (p.name + '.csv')}: {os_reason(exc)}"
                record(Outcome(p.name, "failed", seconds=r["seconds"], worker=r["worker"],
                               error=short_text(error)))
                continue
            caught = r.get("warnings", ())
            give_warnings(caught, stacklevel=5)  # _run, _batch, run_batch: the caller's line
            record(Outcome(p.name, "ok", r["matches"], r["seconds"], worker=r["worker"],
                           warning=warnings_text(caught)))
    finally:
        if futures:  # interrupted: do not leave work running on a shared cluster
            client.cancel(list(futures))
