"""``hopmatch batch``: match the pairs of PAIRS.csv on a Dask cluster.

The command is a click command that the ``hopmatch`` group loads when ``hopmatch batch`` is
first used (``hopmatch.cli.group.PluginGroup.PLUGINS``), so that the other commands do not
import Dask; without this package, ``hopmatch batch`` says what to install. Its detector and
matcher options are generated as those of ``hopmatch match``
(:func:`hopmatch.cli.parameter_options`).

It follows the conventions of ``hopmatch``: bad input raises ``click.BadParameter`` /
``click.UsageError`` naming the file or option (shown by ``hopmatch`` as
``hopmatch: error: <where>: <problem>``, exit status 2), the progress bar is on stderr and
only on a terminal, ``hopmatch --quiet`` silences it and the summary.

Exit status: 0 when every pair has its result, :data:`EXIT_PAIRS_FAILED` (3) when the batch
ran but some pairs failed (see DIR/summary.csv), 2 for bad input, 1 for internal errors.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import click

import hopmatch
from hopmatch.cli import given_parameters, one_line, parameter_options, strip_name
from hopmatch.errors import HopmatchError, HopmatchWarning

from .batch import check_params, check_scheduler, run_batch
from .checks import check_out, check_workers
from .pairs import read_pairs

__all__ = ["EXIT_PAIRS_FAILED", "batch"]

#: Exit status when the batch ran to its end but at least one pair failed.
EXIT_PAIRS_FAILED = 3


# --------------------------------------------------------------------------------------
# The command
# --------------------------------------------------------------------------------------


class _Progress:
    """A click progress bar on stderr, shown only on a terminal and when not quiet."""

    def __init__(self, total: int, enabled: bool):
        self.bar = None
        if enabled and total:
            self.bar = click.progressbar(length=total, label="matching", file=sys.stderr,
                                         show_pos=True, show_eta=True,
                                         item_show_func=lambda o: o)
            self.bar.__enter__()

    def __call__(self, outcome, done, total):
        if self.bar is not None:
            self.bar.update(1, f"{outcome.name}: {outcome.status}")

    def close(self):
        if self.bar is not None:
            self.bar.__exit__(None, None, None)
            self.bar = None


def _stderr_is_terminal() -> bool:
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


@click.command("batch")
@click.argument("pairs_csv", metavar="PAIRS.csv")
@click.option("--out", "-o", required=True, metavar="DIR",
              help="Output folder (created if missing; finished pairs in it are skipped).")
@click.option("--scheduler", metavar="ADDRESS",
              help="Address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: "
                   "start a local cluster on this machine).")
@click.option("--workers", type=click.IntRange(min=1), metavar="N",
              help="Worker processes of the local cluster [default: one per core; at most "
                   "4 per core].")
@click.option("--unrectified", is_flag=True,
              help="The pairs are not rectified and their geometry is unknown: estimate "
                   "each pair's fundamental matrix and disparity range from the pair, as "
                   "'hopmatch match --unrectified' (match_stereo(..., rectified=False)).")
@parameter_options(hopmatch.DericheMoravecDetector, hopmatch.HopfieldMatcher)
@click.pass_context
def batch(ctx, pairs_csv, out, scheduler, workers, unrectified, **params):
    """Match every pair listed in PAIRS.csv on a Dask cluster.

    PAIRS.csv has a header and the columns left,right and optionally name (relative paths
    are relative to PAIRS.csv's folder; without a name, a pair is named after its left
    image). Each pair is matched on a worker and written to DIR/<name>.csv (the columns of
    'hopmatch match': left_x,left_y,right_x,right_y,disparity,distance), then
    DIR/summary.csv lists name,status,matches,seconds,error,warning for all pairs
    (warning: why an ok pair has no or few matches).

    Results are written under a temporary name and renamed when complete; a rerun skips the
    pairs whose result is there. A pair that fails (missing or corrupt image...) is
    recorded in the summary and the batch goes on. Exit status: 0 when every pair has its
    result, 3 when some failed, 2 for bad input.

    Detector and matcher options are those of 'hopmatch match'.
    """
    quiet = bool((ctx.find_root().obj or {}).get("quiet"))
    given = given_parameters(params, hopmatch.DericheMoravecDetector, hopmatch.HopfieldMatcher)
    if unrectified:
        given["rectified"] = False
    if scheduler and workers:
        raise click.UsageError("--workers sets the size of the local cluster; it cannot be "
                               "used with --scheduler (size that cluster where it runs)")
    if scheduler is not None:
        try:
            check_scheduler(scheduler)
        except HopmatchError as exc:
            raise click.BadParameter(strip_name(one_line(exc), "scheduler"),
                                     param_hint="--scheduler") from None
    try:
        check_params(given, "hopmatch batch")
    except HopmatchError as exc:
        message = " ".join(str(exc).split())
        if exc.argument in given:  # about one option: name it, as hopmatch match does
            prefix = f"`{exc.argument}` "
            raise click.BadParameter(message[len(prefix):] if message.startswith(prefix)
                                     else message,
                                     param_hint="--" + exc.argument.replace("_", "-")) from None
        raise click.UsageError(message) from None
    try:
        pairs = read_pairs(pairs_csv)
    except HopmatchError as exc:
        message = str(exc)
        for prefix in (f"{pairs_csv}: ", f"{pairs_csv} ", f"{Path(pairs_csv)} "):
            if message.startswith(prefix):
                message = message[len(prefix):]
                break
        raise click.BadParameter(message, param_hint=pairs_csv) from None
    try:
        check_workers(workers)
    except HopmatchError as exc:
        raise click.BadParameter(strip_name(one_line(exc), "workers"),
                                 param_hint="--workers") from None
    try:
        check_out(out)
    except HopmatchError as exc:
        raise click.BadParameter(strip_name(one_line(exc), "out"), param_hint="--out") from None

    bar = _Progress(len(pairs), enabled=not quiet and _stderr_is_terminal())
    try:
        with warnings.catch_warnings():  # said per pair below (and in summary.csv)
            warnings.simplefilter("ignore", HopmatchWarning)
            report = run_batch(pairs, out, scheduler=scheduler, workers=workers, progress=bar,
                               **given)
    except HopmatchError as exc:
        if exc.argument in ("scheduler", "out"):  # unreachable scheduler, folder refused
            raise click.BadParameter(strip_name(one_line(exc), exc.argument),
                                     param_hint="--" + exc.argument) from None
        raise
    finally:
        bar.close()

    if not quiet:
        ok, skipped, failed = (report.count(s) for s in ("ok", "skipped", "failed"))
        click.echo(f"pairs: {len(pairs)} ({ok} matched, {skipped} already done, "
                   f"{failed} failed)")
        rate = f", {ok / report.seconds:.2f} pairs/s" if ok and report.seconds > 0 else ""
        where = scheduler or f"local cluster of {report.workers} workers"
        click.echo(f"time: {report.seconds:.1f} s on {where}{rate}")
        for o in report.outcomes:
            if o.status == "failed":
                click.echo(f"failed: {o.name}: {o.error}", err=True)
            elif o.warning:
                click.echo(f"warning: {o.name}: {o.warning}", err=True)
        click.echo(f"output: {report.out} (<name>.csv per pair, summary.csv)")
    return 0 if report.ok else EXIT_PAIRS_FAILED
