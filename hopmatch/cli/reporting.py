"""What the command line tells the user: the status line, the summary, warnings and errors.

Every bad input ends as one :class:`CLIError` (``<where>: <problem>``, where = the option or
file the user typed). Errors of the library are translated by :func:`explain`: through
their :attr:`~hopmatch.errors.HopmatchError.argument` when they carry one, else by finding
the argument names quoted in their message. An ``OSError`` about a file (a name too long, a
loop of links...) is bad input too.

Warnings of the library are printed as one line each, ``hopmatch: warning: <message>``
(:func:`cli_warnings`), with the advice they give in Python terms (``max_vertical=1``,
``setFundamentalMatrix(F)``) put in the command line's (``--max-vertical 1``,
``--fundamental-matrix FILE``): :func:`cli_text`. Help texts come from docstrings and go
through :func:`plain_text` (no Sphinx roles, no backticks).
"""

from __future__ import annotations

import contextlib
import re
import sys
import warnings

import click

from ..errors import HopmatchError, HopmatchWarning

__all__ = ["CLIError", "CLI_ADVICE", "EXIT_BAD_INPUT", "EXIT_INTERNAL", "Status",
           "cli_text", "cli_warnings", "click_error", "explain", "guard", "one_line",
           "plain_text", "say", "status", "strip_name", "warning_line"]

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
# Plain text: docstrings and library messages as the command line shows them
# --------------------------------------------------------------------------------------

_ROLE = re.compile(r":[a-z]+(?::[a-z]+)?:`([^`]*)`")


def _role_text(match: re.Match) -> str:
    target = match.group(1)
    named = re.match(r"^(.*?)\s*<[^>]*>$", target)  # :role:`text <target>`
    if named:
        return named.group(1)
    if target.startswith("~"):
        return target[1:].rsplit(".", 1)[-1]
    return target.lstrip("!")


def plain_text(text: str, labels: dict | None = None) -> str:
    """``text`` (numpydoc / Sphinx) as plain text, for ``--help`` and messages.

    ``:func:`~hopmatch.feature.moravec_response``` becomes ``moravec_response`` (as Sphinx
    shows it), ``:class:`hopmatch.errors.X``` ``hopmatch.errors.X``, ````x```` ``x``; with
    ``labels`` (``{parameter name: option}``), parameter names are written as their
    options (``window_sigma > 0`` -> ``--window-sigma > 0``). Whitespace is collapsed.

    Examples
    --------
    >>> plain_text("see :func:`~hopmatch.feature.moravec_response` and ``docs/x.md``")
    'see moravec_response and docs/x.md'
    >>> plain_text("about 20 more with ``window_sigma > 0``", {"window_sigma": "--window-sigma"})
    'about 20 more with --window-sigma > 0'
    """
    out = _ROLE.sub(_role_text, str(text)).replace("``", "")
    out = re.sub(r"(?<!`)`([^`]+)`(?!`)", r"\1", out)
    for name, label in (labels or {}).items():
        if "_" in name and label.startswith("--"):
            out = re.sub(_bare(name), label, out)
    return one_line(out)


#: Python advice of the library's warnings, and what to do on the command line instead
#: (applied in order by :func:`cli_text`; the generic names come last).
CLI_ADVICE = (
    ("rectify the pair (hopmatch.stereo.rectify), call setFundamentalMatrix(F), or let "
     "match_stereo estimate its geometry (rectified=False)",
     "rectify the images first (cv2.stereoRectify and cv2.remap, with the calibration), "
     "give the pair's fundamental matrix with --fundamental-matrix FILE, or let hopmatch "
     "estimate it with --unrectified"),
    ("its epipolar geometry estimated from the images (rectified=False; "
     "result.fundamental_matrix, result.geometry); pass rectified=True to search its rows "
     "anyway",
     "its epipolar geometry estimated from the images as --unrectified does (F in "
     "fundamental_matrix.txt); give a disparity range (--max-disparity) to search its rows "
     "anyway"),
    ("crop or downscale the pair, or rectify it and pass rectified=True",
     "crop or downscale the images, or rectify them and match them without --unrectified"),
    ("rectify the pair first or call setFundamentalMatrix(F)",
     "rectify the images first (cv2.stereoRectify and cv2.remap), or give the pair's "
     "fundamental matrix with --fundamental-matrix FILE"),
    ("rectify them (hopmatch.stereo.rectify or rectify_uncalibrated) or give their "
     "fundamental matrix (setFundamentalMatrix(F))",
     "rectify them first (cv2.stereoRectify with a calibration, "
     "cv2.stereoRectifyUncalibrated without) or give their fundamental matrix with "
     "--fundamental-matrix FILE"),
    ("setFundamentalMatrix(F)", "--fundamental-matrix FILE"),
    ("fundamental_matrix=F", "--fundamental-matrix FILE"),
    ("hopmatch.stereo.rectify_uncalibrated", "cv2.stereoRectifyUncalibrated"),
    ("hopmatch.stereo.rectify", "cv2.stereoRectify and cv2.remap"),
    ("DericheMoravecDetector.create(", "("),
)


def cli_text(message: str, labels: dict) -> str:
    """A library message in command-line terms: :data:`CLI_ADVICE` applied, then every
    name of ``labels`` (parameters -> options, ``left``/``right`` -> the files) written as
    the user typed it, ``name=value`` as ``--name value``; on one line."""
    out = one_line(message)
    for python, cli in CLI_ADVICE:
        out = out.replace(python, cli)
    for name, label in labels.items():
        if not name:
            continue
        if label.startswith("--"):
            out = re.sub(rf"(?<![\w`-]){re.escape(name)}=(?=[^\s=])", f"{label} ", out)
        out = out.replace(f"`{name}`", label)
        if "_" in name and label.startswith("--"):
            out = re.sub(_bare(name), label, out)
    return out


def warning_line(message, category, labels: dict, where: str = "") -> str:
    """``hopmatch: warning: <message in CLI terms>``; warnings of other libraries keep
    their category's name; ``where`` (``file:line``, with --debug) is appended."""
    text = cli_text(str(message), labels)
    if not issubclass(category, HopmatchWarning):
        text = f"{category.__name__}: {text}"
    return f"hopmatch: warning: {text}" + (f" ({category.__name__} at {where})" if where
                                           else "")


@contextlib.contextmanager
def cli_warnings(labels: dict, debug: bool = False):
    """Show every warning raised inside as one :func:`warning_line` on stderr (after
    clearing the status line), instead of Python's ``file:line: Category: message`` and
    source line. ``labels`` is read when a warning comes, so that a command can add its
    files to it; the warning filters in force (``-W``, ``PYTHONWARNINGS``) still apply."""
    def show(message, category, filename, lineno, file=None, line=None):
        status.clear()
        where = f"{filename}:{lineno}" if debug else ""
        click.echo(warning_line(message, category, labels, where), err=True)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


# --------------------------------------------------------------------------------------
# Errors raised by the library, translated to "<option or file>: <problem>"
# --------------------------------------------------------------------------------------


def strip_name(message: str, name: str) -> str:
    """``message`` without its leading "`name` " or "`name`: ".

    Examples
    --------
    >>> strip_name("`window_size` must be odd", "window_size")
    'must be odd'
    >>> strip_name("`out`: a file stands there", "out")
    'a file stands there'
    """
    for prefix in (f"`{name}`: ", f"`{name}` "):
        if message.startswith(prefix):
            return message[len(prefix):]
    return message


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
    ``labels`` in the problem is replaced by its label too, and the library's Python advice
    by its command-line form (:data:`CLI_ADVICE`).
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
    for python, cli in CLI_ADVICE:
        problem = problem.replace(python, cli)
    return CLIError(label, problem)


def is_input_error(exc) -> bool:
    """hopmatch's own errors are input errors; a bare ValueError/TypeError from elsewhere
    is a bug and is reported as an internal error."""
    return isinstance(exc, HopmatchError)


def os_error(exc: OSError, labels: dict) -> CLIError:
    """An ``OSError`` about a file the user named (a name too long, a loop of links, no
    permission...) as a :class:`CLIError` naming that file as the user typed it."""
    from ..imageio import os_reason

    name = exc.filename if exc.filename is not None else labels.get("", "input")
    typed = {str(v): v for v in labels.values()}
    return CLIError(typed.get(str(name), str(name)), os_reason(exc))


def guard(outputs, labels: dict, body):
    """Run ``body()``; on any failure abort ``outputs`` (an :class:`Outputs` or None: this
    run's files are removed) and translate library errors with :func:`explain` and errors
    of the file system about a named file with :func:`os_error`."""
    try:
        return body()
    except BaseException as exc:
        if outputs is not None:
            outputs.abort()
        if isinstance(exc, (HopmatchError, ValueError, TypeError)) and not isinstance(
                exc, CLIError) and is_input_error(exc):
            raise explain(exc, labels) from exc
        if isinstance(exc, OSError) and exc.filename is not None:
            raise os_error(exc, labels) from exc
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
