"""The ``hopmatch`` command line: demo, match, detect and eval.

Usage::

    hopmatch demo [--out DIR]
    hopmatch match LEFT RIGHT --out DIR [--preset default|paper] [--max-disparity N]
                   [--format csv|json] [--no-draw] [--plot-energy] [--figures]
                   [--window-size N ...]
    hopmatch detect IMAGE --out DIR [--window-size N ...]
    hopmatch eval [--scene NAME ...] [--method NAME ...] [--out DIR] [--docs] [--draw]
                  [--repeat N]
    hopmatch --version | --help | COMMAND --help

Every parameter of :class:`~hopmatch.DericheMoravecDetector` and
:class:`~hopmatch.HopfieldMatcher` is an option (``window_size`` -> ``--window-size``,
``subpixel`` -> ``--subpixel/--no-subpixel``), generated from their ``PARAMS`` and checked
by the same validators as the Python API. An option that is not given keeps the preset's
value; ``none`` sets an optional parameter (e.g. ``--similarity-gate none``) to None.

Bad input (missing or unreadable file, image OpenCV cannot decode, images of different
heights, unwritable output folder, invalid option value) gives one line on stderr,
``hopmatch: error: <file or option>: <problem>``, and exit status 2; ``--debug`` adds the
traceback. Outputs are written under temporary names in the output folder and renamed only
when the whole run succeeded, so a failed run leaves none of its files behind (and removes
the folders it created).

Progress is a status line on stderr, shown only when stderr is a terminal and not
``--quiet``. ``--quiet`` also silences the summary printed on stdout.
"""

from __future__ import annotations

import csv
import importlib
import io
import json
import os
import platform
import re
import sys
import time
import traceback
from datetime import datetime, timezone
from pathlib import Path

import click
import cv2
import numpy as np

import hopmatch

from . import imageio
from .errors import HopmatchError
from .feature.detector import DericheMoravecDetector
from .matching.matcher import HopfieldMatcher, resolve_max_disparity
from .matching.stereo_match import match_stereo
from . import viz

__all__ = ["cli", "main"]

#: Exit status of bad input (as click's usage errors) and of unexpected failures.
EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 1

_NONE = object()
_NO_ARGS_IS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())  # click >= 8.2  # "--param none": set an optional parameter to None


class CLIError(Exception):
    """A bad input: reported as ``hopmatch: error: <where>: <problem>``."""

    def __init__(self, where: str, problem: str, status: int = EXIT_BAD_INPUT):
        super().__init__(f"{where}: {problem}")
        self.where, self.problem, self.status = where, problem, status


# --------------------------------------------------------------------------------------
# Status line (stderr, terminals only)
# --------------------------------------------------------------------------------------


class _Status:
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


_status = _Status()


def _say(ctx: click.Context, text: str = "") -> None:
    """Summary output on stdout (silenced by --quiet)."""
    if not (ctx.find_root().obj or {}).get("quiet"):
        click.echo(text)


# --------------------------------------------------------------------------------------
# Parameter options, generated from the classes' PARAMS
# --------------------------------------------------------------------------------------


def _option_name(name: str) -> str:
    return "--" + name.replace("_", "-")


def _kind(spec) -> type:
    if isinstance(spec.default, bool):
        return bool
    if spec.default is not None:
        return type(spec.default)
    for kind, probe in ((float, 0.5), (int, 1)):
        try:
            spec.check(spec.name, probe)
            return kind
        except (TypeError, ValueError):
            pass
    return str


def _accepts_none(spec) -> bool:
    try:
        spec.check(spec.name, None)
        return True
    except (TypeError, ValueError):
        return False


def _choices(spec) -> tuple[str, ...] | None:
    """The options of a ``choice(...)`` validator (for help text only)."""
    for cell in getattr(spec.check, "__closure__", None) or ():
        value = cell.cell_contents
        if isinstance(value, tuple) and value and all(isinstance(v, str) for v in value):
            return value
    return None


def _strip_name(message: str, name: str) -> str:
    """"`window_size` must be odd" -> "must be odd"."""
    prefix = f"`{name}` "
    return message[len(prefix):] if message.startswith(prefix) else message


class _ParamType(click.ParamType):
    """Parses a string as the parameter's type and runs the parameter's own validator."""

    def __init__(self, spec):
        self.spec = spec
        self.kind = _kind(spec)
        self.optional = _accepts_none(spec)
        self.choices = _choices(spec) if self.kind is str else None
        self.name = {int: "integer", float: "number"}.get(self.kind, "text")

    def get_metavar(self, param, ctx=None):  # noqa: D102 (click API)
        if self.choices:
            return "[" + "|".join(self.choices) + "]"
        return {int: "INT", float: "FLOAT"}.get(self.kind, "TEXT")

    def convert(self, value, param, ctx):  # noqa: D102 (click API)
        if value is _NONE:
            return value
        if isinstance(value, str):
            text = value.strip()
            if self.optional and text.lower() == "none":
                return _NONE
            if self.kind is int:
                try:
                    value = int(text)
                except ValueError:
                    self.fail(f"{value!r} is not an integer")
            elif self.kind is float:
                try:
                    value = float(text)
                except ValueError:
                    self.fail(f"{value!r} is not a number")
        try:
            return self.spec.check(self.spec.name, value)
        except (TypeError, ValueError) as exc:
            self.fail(_strip_name(str(exc), self.spec.name))


def _docstring_params(cls) -> dict:
    """The description of each parameter in a numpydoc ``Parameters`` section of ``cls``."""
    lines = (cls.__doc__ or "").splitlines()
    out, names, text, inside = {}, [], [], False

    def flush():
        description = " ".join(text).replace("``", "").strip()
        for n in names:
            out[n] = description
    for line in lines:
        stripped = line.strip()
        if stripped == "Parameters":
            inside = True
            continue
        if not inside or set(stripped) == {"-"}:
            continue
        indent = len(line) - len(line.lstrip())
        if stripped and indent <= 4 and " : " in stripped:
            flush()
            names = [n.strip() for n in stripped.split(" : ")[0].split(",")]
            text = []
        elif stripped and indent <= 4:  # next section
            break
        elif stripped:
            text.append(stripped)
    flush()
    return out


def _unique_specs(*classes):
    seen = {}
    for cls in classes:
        for spec in cls.PARAMS:
            seen.setdefault(spec.name, (spec, cls))
    return list(seen.values())


def parameter_options(*classes):
    """A decorator adding one option per parameter of ``classes`` (default None = not given;
    read the values with :func:`given_parameters`). Plugins' commands use it too, so that
    every command spells the options the same way."""

    docs = {}
    for cls in classes:
        for name, text in _docstring_params(cls).items():
            docs.setdefault(name, text)

    def decorate(func):
        for spec, cls in reversed(_unique_specs(*classes)):
            owner = "both" if spec.name == "preset" else (
                "detector" if cls is DericheMoravecDetector else "matcher")
            shown = "None" if spec.default is None else repr(spec.default)
            doc = spec.doc or docs.get(spec.name, "")
            text = (doc.rstrip(".") + ". " if doc else "") + f"[{owner}; default {shown}"
            if spec.name == "preset":
                text = ("Named parameter set of detector and matcher; explicit options win "
                        f"[default {shown}")
            if _kind(spec) is not bool and _accepts_none(spec):
                text += "; 'none' for None"
            text += "]"
            if _kind(spec) is bool:
                name = spec.name.replace("_", "-")
                opt = click.option(f"--{name}/--no-{name}", spec.name, default=None, help=text)
            else:
                opt = click.option(_option_name(spec.name), spec.name, type=_ParamType(spec),
                                   default=None, help=text)
            func = opt(func)
        return func

    return decorate


def given_parameters(kwargs: dict, cls) -> dict:
    """The parameters of ``cls`` given on the command line (None = not given)."""
    names = {p.name for p in cls.PARAMS}
    return {k: (None if v is _NONE else v) for k, v in kwargs.items()
            if k in names and v is not None}


# --------------------------------------------------------------------------------------
# Input and output
# --------------------------------------------------------------------------------------


def read_image(path: str) -> np.ndarray:
    """:func:`hopmatch.imageio.read_image`, its error as a :class:`CLIError`."""
    try:
        return imageio.read_image(path)
    except imageio.ImageReadError as exc:
        raise CLIError(exc.path, exc.problem) from None


class Outputs:
    """The output folder of one run: files are staged under temporary names, then renamed.

    ``open()`` creates the folder (and missing parents) and checks it is writable;
    ``add()`` writes a file under a hidden temporary name; ``commit()`` renames them all;
    ``abort()`` removes the temporary files and the folders ``open()`` created (if empty).
    """

    def __init__(self, folder: str):
        self.label = folder
        self.path = Path(folder)
        self.created: list[Path] = []
        self.staged: list[tuple[Path, Path]] = []
        self.names: list[str] = []

    def open(self) -> None:
        if self.path.exists() and not self.path.is_dir():
            raise CLIError(self.label, "exists and is not a folder")
        missing, q = [], self.path.absolute()
        while not q.exists() and q.parent != q:
            missing.append(q)
            q = q.parent
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            self._remove_created(missing)
            raise CLIError(self.label, f"cannot create the folder: {imageio.os_reason(exc)}") from None
        self.created = missing
        try:
            os.unlink(viz.write_temp(self.path, "write-test", b""))
        except OSError as exc:
            self.abort()
            raise CLIError(self.label, f"cannot write in the folder: {imageio.os_reason(exc)}") from None

    def add(self, name: str, data: bytes) -> None:
        try:
            tmp = viz.write_temp(self.path, name, data)
        except OSError as exc:
            raise CLIError(str(self.path / name), f"cannot write: {imageio.os_reason(exc)}") from None
        self.staged.append((tmp, self.path / name))
        self.names.append(name)

    def add_text(self, name: str, text: str) -> None:
        self.add(name, text.encode("utf-8"))

    def add_image(self, name: str, image: np.ndarray) -> None:
        self.add(name, viz.encode_image(image, Path(name).suffix))

    def commit(self) -> None:
        done = []
        try:
            for tmp, final in self.staged:
                os.replace(tmp, final)
                done.append(final)
        except OSError as exc:
            for final in done:
                _unlink(final)
            self.abort()
            raise CLIError(self.label, f"cannot rename the finished files: {imageio.os_reason(exc)}") \
                from None
        self.staged = []

    def abort(self) -> None:
        for tmp, _ in self.staged:
            _unlink(tmp)
        self.staged = []
        self._remove_created(self.created)
        self.created = []

    @staticmethod
    def _remove_created(folders) -> None:
        for folder in folders:  # deepest first
            try:
                folder.rmdir()
            except OSError:
                break


def _unlink(path: Path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def _f32_strings(values) -> list[str]:
    """Shortest decimal strings that read back as the same float32 values."""
    return [str(v) for v in np.asarray(values, dtype=np.float32).reshape(-1)]


def _table(columns: dict, fmt: str) -> str:
    """CSV (with a header) or a JSON list of objects, from equal-length float columns."""
    names = list(columns)
    cols = [_f32_strings(columns[n]) for n in names]
    rows = list(zip(*cols)) if cols else []
    if fmt == "json":
        records = [{n: float(v) for n, v in zip(names, row)} for row in rows]
        return json.dumps(records, indent=1) + "\n"
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(names)
    writer.writerows(rows)
    return buf.getvalue()


def _versions() -> dict:
    import numba

    return {
        "hopmatch": hopmatch.__version__,
        "opencv": cv2.__version__,
        "numpy": np.__version__,
        "numba": numba.__version__,
        "python": platform.python_version(),
    }


def _image_info(path: str, image: np.ndarray) -> dict:
    return {"path": str(Path(path).absolute()), "shape": list(image.shape),
            "dtype": str(image.dtype)}


def _ms(seconds: float) -> float:
    return round(seconds * 1000.0, 3)


def _run_json(command: str, **sections) -> str:
    doc = {"command": command, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
           "versions": _versions(), **sections}
    return json.dumps(doc, indent=2, default=str) + "\n"


# --------------------------------------------------------------------------------------
# Errors raised by the library, translated to "<option or file>: <problem>"
# --------------------------------------------------------------------------------------


def _explain(exc: BaseException, labels: dict) -> CLIError:
    """Turn a hopmatch ValueError/TypeError into a CLIError naming the option or file.

    ``labels`` maps the argument names used in messages (```window_size```, ```left```)
    to what the user typed (``--window-size``, the file name); ``labels[""]`` is the
    fallback. Parameter names written bare (``max_neurons=1``) are found too when they
    hold an underscore (so that words such as "on" or "seed" are left alone).
    """
    message = str(exc)
    found = []
    for name, label in labels.items():
        if not name:
            continue
        pos = message.find(f"`{name}`")
        if pos >= 0:
            found.append((pos, name, label))
        elif "_" in name and label.startswith("--"):
            m = re.search(rf"(?<![\w`-]){re.escape(name)}(?![\w`])", message)
            if m:
                found.append((m.start(), name, label))
    if not found:
        return CLIError(labels.get("", "input"), message)
    _, name, label = min(found)
    problem = _strip_name(message, name)
    if problem.startswith("("):  # "`max_disparity` (3.0) must ..." reads better whole
        problem = message
    for other, other_label in labels.items():
        if not other:
            continue
        problem = problem.replace(f"`{other}`", other_label)
        if "_" in other and other_label.startswith("--"):
            problem = re.sub(rf"(?<![\w`-]){re.escape(other)}(?![\w`])", other_label, problem)
    return CLIError(label, problem)


def _param_labels(*classes) -> dict:
    return {p.name: _option_name(p.name) for cls in classes for p in cls.PARAMS}


# --------------------------------------------------------------------------------------
# The commands
# --------------------------------------------------------------------------------------


def _print_version(ctx, param, value):
    if not value or ctx.resilient_parsing:
        return
    v = _versions()
    click.echo(f"hopmatch {v['hopmatch']} (opencv {v['opencv']}, numpy {v['numpy']}, "
               f"numba {v['numba']}, python {v['python']})")
    ctx.exit(0)


class _PluginGroup(click.Group):
    """The command group, plus commands that live in plugins (``hopmatch batch`` is
    ``hopmatch_dask.cli.batch``), imported only when used so that the other commands do not
    pay for importing Dask."""

    PLUGINS = {"batch": ("hopmatch_dask.cli", "batch", "hopmatch[dask]")}

    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | set(self.PLUGINS))

    def get_command(self, ctx, name):
        cmd = super().get_command(ctx, name)
        if cmd is None and name in self.PLUGINS:
            module, attr, extra = self.PLUGINS[name]
            try:
                cmd = getattr(importlib.import_module(module), attr)
            except ImportError as exc:
                raise click.UsageError(
                    f"`hopmatch {name}` needs its plugin: pip install '{extra}' ({exc})"
                ) from None
        return cmd


@click.group(cls=_PluginGroup,
             context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True,
              callback=_print_version, help="Show the versions and exit.")
@click.option("--quiet", "-q", is_flag=True,
              help="No progress line on stderr and no summary on stdout (errors still shown).")
@click.option("--debug", is_flag=True, help="Show the full traceback of errors.")
@click.pass_context
def cli(ctx, quiet, debug):
    """Sparse stereo matching: Moravec points on a Canny-Deriche gradient, matched by a
    Hopfield network (Achour & Mahiddine, 2002).

    Run 'hopmatch demo' for a first look, 'hopmatch COMMAND --help' for the options.
    """
    ctx.obj = {"quiet": quiet, "debug": debug}
    _status.quiet = quiet


def _correct_mask(result, disparity_gt, tolerance: float = 1.0):
    """(correct, known, score) of each match against ground truth, at ``tolerance`` px."""
    from .evaluate import score_matches

    ml, mr = result.matched_left, result.matched_right
    score = score_matches(ml, mr, disparity_gt, thresholds=(tolerance,))
    known = np.asarray(score.scored, dtype=bool)
    correct = np.zeros(len(ml), dtype=bool)
    idx = np.flatnonzero(known)
    dy = np.abs(ml[idx, 1] - mr[idx, 1])
    correct[idx] = (np.abs(score.errors) <= tolerance) & (dy <= tolerance)
    return correct, known, score


def _match_table(result, fmt: str) -> str:
    ml, mr = result.matched_left, result.matched_right
    return _table({
        "left_x": ml[:, 0], "left_y": ml[:, 1], "right_x": mr[:, 0], "right_y": mr[:, 1],
        "disparity": result.disparities, "distance": result.distances,
    }, fmt)


def _draw_match_images(outputs, left, right, result, correct=None, known=None,
                       max_disparity=None):
    _status("drawing matches")
    pic = viz.draw_matches(left, right, result.points_left, result.points_right,
                           np.stack([result.query_idx, result.train_idx], axis=1),
                           correct, known=known)
    outputs.add_image("matches.png", pic)
    _status("drawing disparities")
    disp = viz.draw_disparity(left, result.matched_left, result.disparities, max_disparity)
    outputs.add_image("disparity.png", disp)


def _draw_paper_figures(outputs, left, right, result, detector):
    """The paper's Figure 5 (points over the gradient image, each side) and Figure 7
    (numbered matches), staged with the other outputs."""
    _status("drawing the paper's figures")
    outputs.add_image("figure5_left.png",
                      viz.draw_keypoints_on_gradient(left, result.points_left, detector))
    outputs.add_image("figure5_right.png",
                      viz.draw_keypoints_on_gradient(right, result.points_right, detector))
    outputs.add_image("figure7.png", viz.draw_labelled_matches(
        left, right, result.points_left, result.points_right,
        np.stack([result.query_idx, result.train_idx], axis=1)))


def _counts(result) -> dict:
    net = result.network
    return {
        "keypoints_left": int(len(result.points_left)),
        "keypoints_right": int(len(result.points_right)),
        "neurons": int(len(net.neuron_left)),
        "interactions": int(net.n_interactions),
        "matches": int(len(result.query_idx)),
        "iterations": int(net.iterations),
        "sweeps": int(net.sweeps),
        "converged": bool(net.converged),
    }


def _guard(outputs: Outputs | None, labels: dict, body):
    """Run ``body()``; on any failure remove this run's files, translate library errors."""
    try:
        return body()
    except BaseException as exc:
        if outputs is not None:
            outputs.abort()
        if isinstance(exc, (HopmatchError, ValueError, TypeError)) and not isinstance(
                exc, CLIError) and _is_input_error(exc):
            raise _explain(exc, labels) from exc
        raise


def _is_input_error(exc) -> bool:
    # hopmatch's own errors are input errors; a bare ValueError/TypeError from elsewhere
    # is a bug and is reported as an internal error.
    return isinstance(exc, HopmatchError)


@cli.command()
@click.option("--out", "-o", default="hopmatch-demo", show_default=True, metavar="DIR",
              help="Output folder (created if missing).")
@click.pass_context
def demo(ctx, out):
    """Match the built-in motorcycle pair (Middlebury 2014, via scikit-image).

    Writes matches.png (green: correct within 1 px of the ground truth, red: wrong,
    grey: no ground truth), disparity.png, matches.csv and run.json into DIR, and prints
    the counts, the precision and the time.
    """
    from .datasets import load_motorcycle

    t_start = time.perf_counter()
    _status("loading the motorcycle pair")
    scene = load_motorcycle()
    outputs = Outputs(out)
    outputs.open()

    def body():
        _status("compiling the Numba kernels (cached after the first run)")
        t_warm = hopmatch.warmup()
        _status("matching")
        t0 = time.perf_counter()
        result = match_stereo(scene.left, scene.right)
        t_match = time.perf_counter() - t0
        correct, known, score = _correct_mask(result, scene.disparity)
        t1 = time.perf_counter()
        _draw_match_images(outputs, scene.left, scene.right, result, correct, known)
        outputs.add_text("matches.csv", _match_table(result, "csv"))
        t_out = time.perf_counter() - t1
        counts = _counts(result)
        counts.update(matches_with_ground_truth=int(score.n_scored),
                      correct_at_1px=int(correct.sum()))
        precision = float(score.precision[1.0])
        outputs.add_text("run.json", _run_json(
            "demo",
            inputs={"scene": scene.name, "source": scene.source,
                    "size": list(scene.image_size)},
            parameters={"detector": DericheMoravecDetector().get_params(),
                        "matcher": HopfieldMatcher().get_params()},
            counts=counts,
            precision_at_1px=None if np.isnan(precision) else precision,
            timings_ms={"warmup": _ms(t_warm), **{k: _ms(v) for k, v in result.timings.items()},
                        "match_stereo": _ms(t_match), "draw_and_write": _ms(t_out),
                        "total": _ms(time.perf_counter() - t_start)},
            outputs=outputs.names + ["run.json"],
        ))
        outputs.commit()
        _status.clear()
        w, h = scene.image_size
        detect_ms = _ms(result.timings["detect_left"] + result.timings["detect_right"])
        _say(ctx, f"scene: motorcycle ({w} x {h}, Middlebury 2014 via scikit-image)")
        _say(ctx, f"keypoints: {counts['keypoints_left']} left, {counts['keypoints_right']} right")
        _say(ctx, f"matches: {counts['matches']}")
        _say(ctx, f"correct@1px: {counts['correct_at_1px']} of {score.n_scored} with ground truth")
        _say(ctx, f"precision: {precision:.3f}")
        _say(ctx, f"time: {_ms(t_match):.0f} ms (detection {detect_ms:.0f} ms, matching "
                  f"{_ms(result.timings['match']):.0f} ms; Numba load/compile "
                  f"{_ms(t_warm):.0f} ms before)")
        _say(ctx, f"output: {outputs.path} ({', '.join(outputs.names)})")

    _guard(outputs, {}, body)


@cli.command()
@click.argument("left", metavar="LEFT")
@click.argument("right", metavar="RIGHT")
@click.option("--out", "-o", required=True, metavar="DIR",
              help="Output folder (created if missing; an existing one is reused).")
@click.option("--format", "fmt", type=click.Choice(["csv", "json"]), default="csv",
              show_default=True, help="matches.csv or matches.json.")
@click.option("--no-draw", is_flag=True, help="Do not write matches.png and disparity.png.")
@click.option("--plot-energy", is_flag=True,
              help="Record the network energy and plot it to energy.png (needs matplotlib).")
@click.option("--figures", is_flag=True,
              help="Also draw the paper's figures: figure5_left.png, figure5_right.png "
                   "(points over the gradient magnitude) and figure7.png (numbered matches).")
@parameter_options(DericheMoravecDetector, HopfieldMatcher)
@click.pass_context
def match(ctx, left, right, out, fmt, no_draw, plot_energy, figures, **params):
    """Match a rectified stereo pair LEFT RIGHT (image files of the same height).

    Writes matches.csv (left_x,left_y,right_x,right_y,disparity,distance; or matches.json),
    matches.png and disparity.png (unless --no-draw), energy.png (--plot-energy),
    figure5_left.png, figure5_right.png and figure7.png (--figures) and run.json
    (parameters, versions, timings, counts) into DIR.
    """
    t_start = time.perf_counter()
    det_given = given_parameters(params, DericheMoravecDetector)
    match_given = given_parameters(params, HopfieldMatcher)
    labels = {"": f"{left}, {right}", "left": left, "right": right, **_param_labels(DericheMoravecDetector,
                                                             HopfieldMatcher)}
    # configuration first: a bad combination fails before any file is touched
    detector = _guard(None, labels, lambda: DericheMoravecDetector(**det_given))
    matcher = _guard(None, labels, lambda: HopfieldMatcher(**match_given))
    if plot_energy:
        import importlib.util

        if importlib.util.find_spec("matplotlib") is None:
            raise CLIError("--plot-energy", "needs matplotlib: pip install hopmatch[all]")
    _status("reading the images")
    img_l, img_r = read_image(left), read_image(right)
    if img_l.shape[0] != img_r.shape[0]:
        raise CLIError(right, f"height {img_r.shape[0]} differs from the height of {left} "
                              f"({img_l.shape[0]}); LEFT and RIGHT must be a rectified pair")
    t_read = time.perf_counter() - t_start
    outputs = Outputs(out)
    outputs.open()

    def body():
        _status("compiling the Numba kernels (cached after the first run)")
        t_warm = hopmatch.warmup()
        _status("detecting and matching")
        t0 = time.perf_counter()
        result = match_stereo(img_l, img_r, record_energy=plot_energy,
                              **{**det_given, **match_given})
        t_match = time.perf_counter() - t0
        t1 = time.perf_counter()
        outputs.add_text(f"matches.{fmt}", _match_table(result, fmt))
        max_disp = matcher.getMaxDisparity()
        if not no_draw:
            _draw_match_images(outputs, img_l, img_r, result, max_disparity=max_disp)
        if plot_energy:
            _status("plotting the energy")
            outputs.add("energy.png", viz.render_energy(result.network.energy_trace, "png"))
        if figures:
            _draw_paper_figures(outputs, img_l, img_r, result, detector)
        t_out = time.perf_counter() - t1
        counts = _counts(result)
        used = resolve_max_disparity(max_disp, img_l.shape[1::-1], result.points_left,
                                     result.points_right)
        outputs.add_text("run.json", _run_json(
            "match",
            inputs={"left": _image_info(left, img_l), "right": _image_info(right, img_r)},
            parameters={"given": {k: v for k, v in {**det_given, **match_given}.items()},
                        "detector": detector.get_params(), "matcher": matcher.get_params(),
                        "max_disparity_used": used, "record_energy": plot_energy,
                        "format": fmt, "draw": not no_draw, "figures": figures},
            counts=counts,
            energy=float(result.network.energy),
            timings_ms={"read": _ms(t_read), "warmup": _ms(t_warm), **{k: _ms(v) for k, v in result.timings.items()},
                        "match_stereo": _ms(t_match), "draw_and_write": _ms(t_out),
                        "total": _ms(time.perf_counter() - t_start)},
            outputs=outputs.names + ["run.json"],
        ))
        outputs.commit()
        _status.clear()
        _say(ctx, f"keypoints: {counts['keypoints_left']} left, {counts['keypoints_right']} right")
        _say(ctx, f"matches: {counts['matches']}")
        if counts["matches"]:
            _say(ctx, f"median disparity: {float(np.median(result.disparities)):g} px")
        detect_ms = _ms(result.timings["detect_left"] + result.timings["detect_right"])
        _say(ctx, f"time: {_ms(t_match):.0f} ms (detection {detect_ms:.0f} ms, matching "
                  f"{_ms(result.timings['match']):.0f} ms; Numba load/compile "
                  f"{_ms(t_warm):.0f} ms before)")
        _say(ctx, f"output: {outputs.path} ({', '.join(outputs.names)})")

    _guard(outputs, labels, body)


@cli.command()
@click.argument("image", metavar="IMAGE")
@click.option("--out", "-o", required=True, metavar="DIR",
              help="Output folder (created if missing; an existing one is reused).")
@click.option("--no-draw", is_flag=True, help="Do not write keypoints.png.")
@parameter_options(DericheMoravecDetector)
@click.pass_context
def detect(ctx, image, out, no_draw, **params):
    """Detect Moravec points on IMAGE.

    Writes keypoints.csv (x,y,response,size), keypoints.png (unless --no-draw) and
    run.json into DIR.
    """
    t_start = time.perf_counter()
    given = given_parameters(params, DericheMoravecDetector)
    labels = {"": image, "image": image, **_param_labels(DericheMoravecDetector)}
    detector = _guard(None, labels, lambda: DericheMoravecDetector(**given))
    _status("reading the image")
    img = read_image(image)
    outputs = Outputs(out)
    outputs.open()

    def body():
        _status("detecting")
        t0 = time.perf_counter()
        kps = detector.detect(img)
        t_detect = time.perf_counter() - t0
        pts = cv2.KeyPoint_convert(list(kps)).reshape(-1, 2) if kps else np.zeros((0, 2))
        outputs.add_text("keypoints.csv", _table({
            "x": pts[:, 0], "y": pts[:, 1], "response": [k.response for k in kps],
            "size": [k.size for k in kps]}, "csv"))
        if not no_draw:
            outputs.add_image("keypoints.png", viz.draw_keypoints(img, kps))
        outputs.add_text("run.json", _run_json(
            "detect",
            inputs={"image": _image_info(image, img)},
            parameters={"given": given, "detector": detector.get_params()},
            counts={"keypoints": len(kps)},
            timings_ms={"detect": _ms(t_detect), "total": _ms(time.perf_counter() - t_start)},
            outputs=outputs.names + ["run.json"],
        ))
        outputs.commit()
        _status.clear()
        _say(ctx, f"keypoints: {len(kps)}")
        _say(ctx, f"time: {_ms(t_detect):.0f} ms")
        _say(ctx, f"output: {outputs.path} ({', '.join(outputs.names)})")

    _guard(outputs, labels, body)


def _scene_file_name(scene: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", scene)


def _project_docs() -> Path:
    """``docs/`` of the source tree hopmatch runs from (``--docs`` needs a checkout)."""
    root = Path(hopmatch.__file__).resolve().parents[1]
    if not (root / "pyproject.toml").is_file():
        raise CLIError("--docs", f"needs a source checkout of hopmatch (no pyproject.toml in "
                                 f"{str(root)!r}); use --out DIR instead")
    return root / "docs"


def _method_help() -> str:
    from .compare import METHODS

    return ", ".join(METHODS)


@cli.command("eval")
@click.option("--scene", "scenes", multiple=True, metavar="NAME",
              help="Scene to run on (repeatable): 'motorcycle' or a folder of ../shared/data "
                   "such as 'middlebury/tsukuba' [default: motorcycle; with --docs: every "
                   "scene].")
@click.option("--method", "methods", multiple=True, metavar="NAME",
              help="Method to run (repeatable) [default: all]: " + _method_help() + ".")
@click.option("--out", "-o", default=None, metavar="DIR",
              help="Output folder (created if missing) [default: hopmatch-eval; with --docs "
                   "only when given].")
@click.option("--docs", is_flag=True,
              help="Regenerate docs/results.md and docs/img/*.png of this source tree.")
@click.option("--draw", is_flag=True,
              help="Also draw the matches of every scene and method "
                   "(matches_<scene>_<method>.png in DIR).")
@click.option("--repeat", type=click.IntRange(min=1), default=None, metavar="N",
              help="Time each method N times per scene and keep the shortest "
                   "[default: 1; with --docs: 3].")
@click.pass_context
def eval_(ctx, scenes, methods, out, docs, draw, repeat):
    """Compare hopmatch with OpenCV's matchers on scenes with ground truth.

    Runs every method (detection on both images + matching, one thread, timed in this
    run) on every scene, scores the matches against the ground truth at 0.5, 1 and 2 px,
    prints the table (scene x method: matches, correct@1, precision@1, recall@1, time ms)
    and writes results.md, results.csv, precision_vs_correct.png and error_histogram.png
    into DIR. With --docs it rewrites docs/results.md and docs/img/*.png instead.
    """
    import importlib.util

    from . import compare as cmp
    from .datasets import list_scenes, load

    t_start = time.perf_counter()
    if importlib.util.find_spec("matplotlib") is None:
        raise CLIError("eval", "the plots need matplotlib: pip install hopmatch[all]")
    for m in methods:
        if m not in cmp.METHODS:
            raise CLIError("--method", f"unknown method {m!r}; valid methods are "
                                       f"{', '.join(cmp.METHODS)}")
    available = list_scenes()
    for name in scenes:
        if name not in available:
            raise CLIError("--scene", f"unknown scene {name!r}; available: "
                                      f"{', '.join(available)}")
    scene_names = list(dict.fromkeys(scenes)) or (
        cmp.docs_scenes(available) if docs else ["motorcycle"])
    method_names = list(dict.fromkeys(methods)) or list(cmp.METHODS)
    docs_dir = _project_docs() if docs else None
    if out is None and not docs:
        out = "hopmatch-eval"
    if repeat is None:
        repeat = 3 if docs else 1

    loaded = []
    for name in scene_names:
        _status(f"loading {name}")
        loaded.append(_guard(None, {"": name}, lambda n=name: load(n)))

    targets = []
    if out is not None:
        targets.append(Outputs(out))
    if docs_dir is not None:
        doc_out, img_out = Outputs(str(docs_dir)), Outputs(str(docs_dir / "img"))
        targets += [doc_out, img_out]
    opened = []
    try:
        for target in targets:
            target.open()
            opened.append(target)
    except CLIError:
        for target in opened:
            target.abort()
        raise

    def body():
        rows = cmp.compare(loaded, method_names, progress=_status, repeat=repeat)
        by_key = {(r["scene"], r["method"]): r for r in rows}
        scene_of = {s.name: s for s in loaded}
        all_errors = cmp.errors_by_method(rows)
        n = len(loaded)
        pooled = (f"Absolute disparity error of the scored matches "
                  f"({'all ' + str(n) + ' scenes pooled' if n > 1 else loaded[0].name})")
        _status("plotting")
        prec_png = viz.render_precision_vs_correct(rows)
        hist_png = viz.render_error_histogram(all_errors, title=pooled)
        if out is not None:
            target = targets[0]
            target.add_text("results.md", cmp.format_markdown(rows))
            target.add_text("results.csv", cmp.format_csv(rows))
            target.add("precision_vs_correct.png", prec_png)
            target.add("error_histogram.png", hist_png)
            if draw:
                for r in rows:
                    _status(f"drawing {r['scene']}: {r['method']}")
                    target.add_image(f"matches_{_scene_file_name(r['scene'])}_{r['method']}.png",
                                     cmp.draw_row(r, scene_of[r["scene"]]))
        if docs_dir is not None:
            pictures = {"img/precision_vs_correct.png":
                        "Precision@1 against correct@1, one point per method and scene",
                        "img/error_histogram.png": pooled}
            img_out.add("precision_vs_correct.png", prec_png)
            img_out.add("error_histogram.png", hist_png)
            if "motorcycle" in scene_of and n > 1:
                img_out.add("error_histogram_motorcycle.png", viz.render_error_histogram(
                    cmp.errors_by_method(rows, "motorcycle"),
                    title="Absolute disparity error of the scored matches (motorcycle)"))
                pictures["img/error_histogram_motorcycle.png"] = (
                    "Absolute disparity error of the scored matches (motorcycle)")
            for scene, method in cmp.DOC_DRAWINGS:
                if (scene, method) not in by_key:
                    continue
                _status(f"drawing {scene}: {method}")
                file = f"matches_{_scene_file_name(scene)}_{method}.png"
                img_out.add_image(file, cmp.draw_row(by_key[scene, method], scene_of[scene]))
                pictures[f"img/{file}"] = (f"{method} on {scene}: correct within 1 px green, "
                                           "wrong red, no ground truth grey")
            doc_out.add_text("results.md", cmp.format_results_doc(
                rows, loaded, pictures=pictures, machine=cmp.machine_description(),
                created=datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                elapsed=time.perf_counter() - t_start, repeat=repeat))
        for target in targets:
            target.commit()
        _status.clear()
        _say(ctx, cmp.format_markdown(rows).rstrip("\n"))
        _say(ctx)
        for target in targets:
            _say(ctx, f"output: {target.path} ({', '.join(target.names)})")

    def guarded():
        try:
            body()
        except BaseException:
            for target in targets[1:]:
                target.abort()
            raise

    _guard(targets[0] if targets else None, {"": ", ".join(scene_names)}, guarded)


# --------------------------------------------------------------------------------------
# Entry point
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


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _click_error(exc: click.ClickException) -> CLIError:
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
        return CLIError(hint, _one_line(exc.message))
    return CLIError("command line", _one_line(exc.format_message()))


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
        rv = cli.main(args=args, prog_name="hopmatch", standalone_mode=False)
        return rv if isinstance(rv, int) else 0
    except click.exceptions.Exit as exc:  # --help, --version
        return exc.exit_code
    except _NO_ARGS_IS_HELP as exc:
        exc.show()
        return exc.exit_code
    except (click.ClickException, CLIError, HopmatchError) as exc:
        _status.clear()
        if isinstance(exc, click.ClickException):
            err = _click_error(exc)
        elif isinstance(exc, CLIError):
            err = exc
        else:
            err = _explain(exc, {})
        if debug:
            traceback.print_exc()
        click.echo(f"hopmatch: error: {err.where}: {_one_line(err.problem)}", err=True)
        return err.status
    except click.exceptions.Abort:
        _status.clear()
        click.echo("hopmatch: interrupted", err=True)
        return 130
    except Exception as exc:  # a bug: one line unless --debug
        _status.clear()
        if debug:
            traceback.print_exc()
        hint = "" if debug else " (run with --debug for the traceback)"
        click.echo(f"hopmatch: error: internal error: {type(exc).__name__}: "
                   f"{_one_line(exc)}{hint}", err=True)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
