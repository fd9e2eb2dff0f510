"""What the command line tells the user: the status line, the summary, and errors.

Every bad input ends as one :class:`CLIError` (``<where>: <problem>``, where = the option or
file the user typed). Errors of the library are translated by :func:`explain`: through
their :attr:`~hopmatch.errors.HopmatchError.argument` when they carry one, else by finding
the argument names quoted in their message.
"""

from __future__ import annotations

import re
import sys

import click

from ..errors import HopmatchError

__all__ = ["CLIError", "EXIT_BAD_INPUT", "EXIT_INTERNAL", "Status", "click_error", "explain",
           "guard", "one_line", "say", "status", "strip_name"]

#: Exit status of bad input (as click's usage errors) and of unexpected failures.
EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 1


class CLIError(Exception):
    """A bad input: reported as ``hopmatch: error: <where>: <problem>``."""

    def __init__(self, where: str, problem: str, status: int = EXIT_BAD_INPUT):
        super().__init__(f"{where}: {problem}")
        self.where, self.problem, self.status = where, problem, status


# --------------------------------------------------------------------------------------
# Status line (stderr, terminals only) and summary (stdout)
# --------------------------------------------------------------------------------------


class Status:
    """One self-overwriting status line on stderr; silent unless stderr is a terminal."""

    def __init__(self):
        self.quiet = False
        self.shown = False

    @property
    def enabled(self) -> bool:
        try:
            return not self.quiet and sys.stderr.isatty()
        except (AttributeError, ValueError):
            return False

    def __call__(self, message: str) -> None:
        if self.enabled:
            sys.stderr.write(f"\r\033[Khopmatch: {message}...")
            sys.stderr.flush()
            self.shown = True

    def clear(self) -> None:
        if self.shown:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()
            self.shown = False


#: The status line of this process.
status = Status()


def say(ctx: click.Context, text: str = "") -> None:
    """Summary output on stdout (silenced by --quiet)."""
    if not (ctx.find_root().obj or {}).get("quiet"):
        click.echo(text)


def one_line(text: str) -> str:
    return " ".join(str(text).split())


# --------------------------------------------------------------------------------------
# Errors raised by the library, translated to "<option or file>: <problem>"
# --------------------------------------------------------------------------------------


def strip_name(message: str, name: str) -> str:
    """"`window_size` must be odd" -> "must be odd"."""
    prefix = f"`{name}` "
    return message[len(prefix):] if message.startswith(prefix) else message


def _bare(name: str) -> str:
    """A parameter name written without backticks, not inside a longer word or option."""
    return rf"(?<![\w`-]){re.escape(name)}(?![\w`])"


def _named_in_message(message: str, labels: dict):
    """``(name, label)`` of the argument named first in ``message``, or None.

    Names in backticks are found, and bare names (``max_neurons=1``) when they hold an
    underscore and label an option, so that words such as "on" or "seed" are left alone.
    """
    found = []
    for name, label in labels.items():
        if not name:
            continue
        pos = message.find(f"`{name}`")
        if pos >= 0:
            found.append((pos, name, label))
        elif "_" in name and label.startswith("--"):
            m = re.search(_bare(name), message)
            if m:
                found.append((m.start(), name, label))
    if not found:
        return None
    _, name, label = min(found)
    return name, label


def explain(exc: BaseException, labels: dict) -> CLIError:
    """Turn a hopmatch ValueError/TypeError into a CLIError naming the option or file.

    ``labels`` maps the argument names used in messages (```window_size```, ```left```)
    to what the user typed (``--window-size``, the file name); ``labels[""]`` is the
    fallback. The error's ``argument`` attribute chooses the label when it names one of
    ``labels``; otherwise the name quoted first in the message does. Every other name of
    ``labels`` in the problem is replaced by its label too.
    """
    message = str(exc)
    argument = getattr(exc, "argument", None)
    if argument and argument in labels:
        name, label = argument, labels[argument]
    else:
        named = _named_in_message(message, labels)
        if named is None:
            return CLIError(labels.get("", "input"), message)
        name, label = named
    problem = strip_name(message, name)
    if problem.startswith("("):  # "`max_disparity` (3.0) must ..." reads better whole
        problem = message
    for other, other_label in labels.items():
        if not other:
            continue
        problem = problem.replace(f"`{other}`", other_label)
        if "_" in other and other_label.startswith("--"):
            problem = re.sub(_bare(other), other_label, problem)
    return CLIError(label, problem)


def is_input_error(exc) -> bool:
    """hopmatch's own errors are input errors; a bare ValueError/TypeError from elsewhere
    is a bug and is reported as an internal error."""
    return isinstance(exc, HopmatchError)


def guard(outputs, labels: dict, body):
    """Run ``body()``; on any failure abort ``outputs`` (an :class:`Outputs` or None: this
    run's files are removed) and translate library errors with :func:`explain`."""
    try:
        return body()
    except BaseException as exc:
        if outputs is not None:
            outputs.abort()
        if isinstance(exc, (HopmatchError, ValueError, TypeError)) and not isinstance(
                exc, CLIError) and is_input_error(exc):
            raise explain(exc, labels) from exc
        raise


# --------------------------------------------------------------------------------------
# click's own errors
# --------------------------------------------------------------------------------------


def _param_hint(exc: click.ClickException) -> str | None:
    param = getattr(exc, "param", None)
    if param is not None:
        if isinstance(param, click.Option):
            return max(param.opts, key=len) if param.opts else param.name
        return param.human_readable_name
    hint = getattr(exc, "param_hint", None)
    if isinstance(hint, (list, tuple)):
        hint = " / ".join(hint)
    return hint


def click_error(exc: click.ClickException) -> CLIError:
    """A click usage error (unknown option, missing argument, bad value) as a CLIError."""
    if isinstance(exc, click.NoSuchOption):
        problem = "no such option"
        if exc.possibilities:
            problem += " (did you mean " + " or ".join(sorted(exc.possibilities)) + "?)"
        return CLIError(exc.option_name, problem)
    hint = _param_hint(exc)
    if isinstance(exc, click.MissingParameter):
        what = "argument" if isinstance(exc.param, click.Argument) else "option"
        where = getattr(exc.ctx, "command_path", None) or "hopmatch"
        return CLIError(hint or "command line", f"missing {what} (see '{where} --help')")
    if isinstance(exc, click.BadParameter) and hint:
        return CLIError(hint, one_line(exc.message))
    return CLIError("command line", one_line(exc.format_message()))
