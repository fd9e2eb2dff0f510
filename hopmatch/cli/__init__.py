"""The ``hopmatch`` command line: demo, match, detect, eval, warmup and batch.

Usage::

    hopmatch demo [--out DIR]
    hopmatch match LEFT RIGHT --out DIR [--preset default|paper] [--max-disparity N]
                   [--format csv|json] [--no-draw] [--plot-energy] [--figures]
                   [--window-size N ...]
    hopmatch detect IMAGE --out DIR [--window-size N ...]
    hopmatch eval [--scene NAME ...] [--method NAME ...] [--out DIR] [--docs] [--draw]
                  [--repeat N]
    hopmatch warmup                     (compile every Numba kernel into the cache now)
    hopmatch batch PAIRS.csv --out DIR [--scheduler ADDRESS] [--workers N]
                   [--window-size N ...]          (plugin hopmatch_dask: hopmatch[dask])
    hopmatch --version | --help | COMMAND --help

Every parameter of :class:`~hopmatch.DericheMoravecDetector` and
:class:`~hopmatch.HopfieldMatcher` is an option (``window_size`` -> ``--window-size``,
``subpixel`` -> ``--subpixel/--no-subpixel``), generated from their ``PARAMS`` (each
parameter's ``kind``, ``choices`` and ``doc``) and checked by the same validators as the
Python API. An option that is not given keeps the preset's value; ``none`` sets an optional
parameter (e.g. ``--similarity-gate none``) to None.

Bad input (missing or unreadable file, image OpenCV cannot decode, images of different
heights, unwritable output folder, invalid option value) gives one line on stderr,
``hopmatch: error: <file or option>: <problem>``, and exit status 2; ``--debug`` adds the
traceback. Outputs are written under temporary names in the output folder and renamed only
when the whole run succeeded, so a failed run leaves none of its files behind (and removes
the folders it created).

Progress is a status line on stderr, shown only when stderr is a terminal and not
``--quiet``. ``--quiet`` also silences the summary printed on stdout.

Modules: :mod:`~hopmatch.cli.options` (options generated from the parameters),
:mod:`~hopmatch.cli.outputs` (images in, staged output folder, run.json),
:mod:`~hopmatch.cli.reporting` (status line, errors), :mod:`~hopmatch.cli.group` (the
command group and its plugins), :mod:`~hopmatch.cli.commands` (demo, match, detect, warmup) and
:mod:`~hopmatch.cli.eval_command` (eval).
"""

from __future__ import annotations

import sys
import traceback

import click

from .._interrupts import keeps_interrupts
from ..errors import HopmatchError

# importing the commands registers them on the group; the names below are the public names
# of hopmatch.cli (the plugins import parameter_options, given_parameters and strip_name
# from here)
from .commands import demo, detect, match  # noqa: F401
from .eval_command import eval_  # noqa: F401
from .group import PluginGroup, cli  # noqa: F401
from .options import given_parameters, parameter_options  # noqa: F401
from .outputs import Outputs, Terminated, read_image, terminations_as_interrupts  # noqa: F401
from .reporting import (  # noqa: F401
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    CLIError,
    click_error,
    explain,
    one_line,
    status,
    strip_name,
)

__all__ = ["cli", "main"]

_NO_ARGS_IS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())  # click >= 8.2


def _debug_requested(argv) -> bool:
    for arg in argv:
        if arg == "--":
            return False
        if arg == "--debug":
            return True
    return False


def main(argv=None) -> int:
    """Run the command line; return the exit status (0 ok, 2 bad input, 1 internal error)."""
    args = list(sys.argv[1:] if argv is None else argv)
    debug = _debug_requested(args)
    try:
        with terminations_as_interrupts():  # SIGTERM/SIGHUP roll a run back as Ctrl-C does
            # Ctrl-C landing in a Numba kernel's return is a SystemError: made Ctrl-C again
            rv = keeps_interrupts(cli.main)(args=args, prog_name="hopmatch",
                                            standalone_mode=False)
        return rv if isinstance(rv, int) else 0
    except click.exceptions.Exit as exc:  # --help, --version
        return exc.exit_code
    except _NO_ARGS_IS_HELP as exc:
        exc.show()
        return exc.exit_code
    except (click.ClickException, CLIError, HopmatchError) as exc:
        status.clear()
        if isinstance(exc, click.ClickException):
            err = click_error(exc)
        elif isinstance(exc, CLIError):
            err = exc
        else:
            err = explain(exc, {})
        if debug:
            traceback.print_exc()
        click.echo(f"hopmatch: error: {err.where}: {one_line(err.problem)}", err=True)
        return err.status
    except (click.exceptions.Abort, KeyboardInterrupt) as exc:
        status.clear()
        cause = exc if isinstance(exc, Terminated) else exc.__cause__ or exc.__context__
        click.echo("hopmatch: interrupted", err=True)
        return 128 + cause.signum if isinstance(cause, Terminated) else 130
    except Exception as exc:  # a bug: one line unless --debug
        status.clear()
        if debug:
            traceback.print_exc()
        hint = "" if debug else " (run with --debug for the traceback)"
        click.echo(f"hopmatch: error: internal error: {type(exc).__name__}: "
                   f"{one_line(exc)}{hint}", err=True)
        return EXIT_INTERNAL
