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

from hopmatch._files import write_text_atomic
from hopmatch.matching.stereo_match import stereo_pipeline

from .pairs import Pair, as_pairs
from .results import complete_rows, summary_table
from .tasks import batch_task, match_pair

__all__ = ["BatchReport", "Outcome", "check_params", "local_cluster", "match_pairs",
           "run_batch"]

#: Seconds to wait for a scheduler given by address.
CONNECT_TIMEOUT = 30


def check_params(params: dict, caller: str = "hopmatch_dask") -> dict:
    """``params`` if :func:`hopmatch.match_stereo` accepts them, else its error (raised here,
    on the client, before anything is submitted).

    The parameters are shared between the detector and the matcher by the library's one rule,
    :func:`hopmatch.matching.stereo_match.stereo_pipeline`; an unknown name raises
    :class:`~hopmatch.errors.InvalidArgumentError` naming ``caller``.
    """
    stereo_pipeline(params, caller)
    return dict(params)


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
    rerunning an interrupted batch finishes it; delete a result, or use another folder,
    to compute it again (e.g. with other parameters). A pair whose images cannot be read
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

    def record(outcome: Outcome) -> None:
        nonlocal done
        outcomes[outcome.name] = outcome
        done += 1
        if progress is not None:
            progress(outcome, done, total)

    todo = []
    for p in items:
        rows = complete_rows(out / f"{p.name}.csv")
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
        ordered = [outcomes.get(p.name) or Outcome(p.name, "not run") for p in items]
        write_text_atomic(out / "summary.csv", summary_table(ordered))
    return BatchReport(ordered, time.perf_counter() - t0, out, n_workers)


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
