"""Plots of a run and of a comparison, drawn with matplotlib.

matplotlib is imported when a plot is drawn, not with this module (``pip install
hopmatch[all]``); without it the functions raise ``ImportError`` saying so, and write
nothing. The figures are made with matplotlib's object API on an Agg canvas: pyplot's
global state and backend are never touched.

Each plot comes in two forms: ``render_*`` returns the encoded file as bytes (``fmt``:
``"png"``, ``"pdf"``, ``"svg"``...), and ``plot_*`` writes it atomically
(:func:`hopmatch.files.write_bytes_atomic`) to a path whose suffix picks the format.
Before anything is plotted, ``plot_*`` refuse a ``path`` that is not a ``str`` or
``os.PathLike`` (``InvalidTypeError``), whose folder is missing
(:class:`~hopmatch.errors.FileWriteError`) or whose suffix names no format matplotlib
writes (``InvalidArgumentError``), and ``render_*`` such a ``fmt``.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._validate import as_array, as_real, describe
from ..errors import InvalidArgumentError, InvalidTypeError
from ..files import check_output_path, write_bytes_atomic

__all__ = [
    "ERROR_BINS",
    "plot_energy",
    "plot_error_histogram",
    "plot_precision_curves",
    "plot_precision_vs_correct",
    "render_energy",
    "render_error_histogram",
    "render_precision_curves",
    "render_precision_vs_correct",
]

#: Default bin edges of the error histogram, in pixels (|error|).
ERROR_BINS = (0.0, 0.5, 1.0, 2.0, 4.0, 8.0, np.inf)

#: Scatter markers of the methods, in order (cycled).
_MARKERS = "os^Dv<>pP*Xh"


# --------------------------------------------------------------------------------------
# matplotlib plumbing
# --------------------------------------------------------------------------------------


def _figure(size, what: str = "plotting"):
    """A new matplotlib ``Figure`` of ``size`` inches at 100 dpi on its own Agg canvas.

    Raises ``ImportError`` ("``what`` needs matplotlib: pip install hopmatch[all] ...")
    when matplotlib is missing.
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise ImportError(
            f"{what} needs matplotlib: pip install hopmatch[all] (or pip install matplotlib)"
        ) from None
    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)  # no pyplot: the global backend is left alone
    return fig


def _encode(fig, fmt: str, *, tight_box: bool = True) -> bytes:
    """``fig`` laid out (``tight_layout``) and saved as ``fmt``; with ``tight_box`` the
    saved area grows to hold artists outside the axes (a legend beside them)."""
    fig.tight_layout()
    buf = io.BytesIO()
    if tight_box:
        fig.savefig(buf, format=fmt, bbox_inches="tight")
    else:
        fig.savefig(buf, format=fmt)
    return buf.getvalue()


def _as_path(path) -> Path:
    """``path`` (a ``str`` or ``os.PathLike``) as a Path that a file can be written to
    (:func:`hopmatch.files.check_output_path`), checked before anything is plotted."""
    if not isinstance(path, (str, os.PathLike)):
        raise InvalidTypeError(f"`path` must be a str or os.PathLike, got {describe(path)}",
                               argument="path")
    return check_output_path(path)


def _format_of(path: Path) -> str:
    """The format named by ``path``'s suffix (``"png"`` without one), checked by
    :func:`_check_format` under the name ``path``."""
    return _check_format(path.suffix.lstrip(".").lower() or "png", "path")


def _check_format(fmt, name: str = "fmt") -> str:
    """``fmt`` if matplotlib can save a figure in it (``"png"``, ``"pdf"``, ``"svg"``...).

    Raises ``InvalidTypeError`` (not a string) or ``InvalidArgumentError`` (a format
    matplotlib does not write, listing those it does) naming ``name``, and ``ImportError``
    when matplotlib is missing.
    """
    if not isinstance(fmt, str):
        raise InvalidTypeError(f"`{name}` must be a format name such as 'png', got "
                               f"{describe(fmt)}", argument=name)
    try:
        from matplotlib.backend_bases import FigureCanvasBase
    except ImportError:
        raise ImportError(
            "plotting needs matplotlib: pip install hopmatch[all] (or pip install matplotlib)"
        ) from None
    known = FigureCanvasBase.get_supported_filetypes()
    if fmt not in known:
        what = f"the suffix of `{name}`" if name == "path" else f"`{name}`"
        raise InvalidArgumentError(
            f"{what} must name a format matplotlib writes ({', '.join(sorted(known))}), "
            f"got {fmt!r}", argument=name)
    return fmt


def _as_rows(rows) -> list:
    """``rows`` (an iterable of mappings, checked by the caller) as a list."""
    if isinstance(rows, (str, bytes, Mapping)) or not hasattr(rows, "__iter__"):
        raise InvalidTypeError(
            f"`rows` must be an iterable of mappings (as hopmatch.compare returns), got "
            f"{describe(rows)}", argument="rows")
    return list(rows)


def _tab_colours(n: int) -> list:
    """``n`` RGBA colours of matplotlib's ``tab10`` (``tab20`` beyond 10), cycled."""
    from matplotlib import colormaps

    cmap = colormaps["tab20" if n > 10 else "tab10"]
    return [cmap(i % cmap.N) for i in range(n)]


# --------------------------------------------------------------------------------------
# Energy of a run
# --------------------------------------------------------------------------------------


def render_energy(trace, fmt: str = "png") -> bytes:
    """The energy plot of :func:`plot_energy` as encoded bytes (``fmt``: png, pdf, svg...).

    Raises
    ------
    InvalidTypeError
        ``trace`` is not numbers, or ``fmt`` not a string.
    InvalidArgumentError
        ``fmt`` is not a format matplotlib writes.
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    fig = _figure((6.4, 3.6), "plotting the energy")
    fmt = _check_format(fmt)
    trace = as_array(trace, "trace", "an array of energies", finite=False).reshape(-1)
    ax = fig.add_subplot(1, 1, 1)
    if trace.size:
        ax.plot(np.arange(1, trace.size + 1), trace, lw=1.0, color="tab:blue")
    else:
        ax.text(0.5, 0.5, "no energy recorded", ha="center", va="center",
                transform=ax.transAxes)
    ax.set_xlabel("iteration (left point visited)")
    ax.set_ylabel("energy (eq. 11)")
    ax.set_title("Hopfield network energy")
    ax.grid(True, alpha=0.3)
    return _encode(fig, fmt, tight_box=False)


def plot_energy(trace, path) -> Path:
    """Plot the network energy (eq. 11) after each iteration and save it (atomically) to
    ``path``.

    Parameters
    ----------
    trace : (T,) float ndarray
        ``NetworkResult.energy_trace`` (run with ``record_energy=True``).
    path : str or os.PathLike
        Output file; its suffix picks the format (``.png``, ``.pdf``, ``.svg``).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    path = _as_path(path)
    write_bytes_atomic(path, render_energy(trace, _format_of(path)))
    return path


# --------------------------------------------------------------------------------------
# Comparison of methods
# --------------------------------------------------------------------------------------


def render_precision_vs_correct(rows, threshold: float = 1.0, fmt: str = "png",
                                title: str | None = None) -> bytes:
    """The plot of :func:`plot_precision_vs_correct` as encoded bytes.

    Raises
    ------
    InvalidArgumentError
        A row is not a mapping with ``method``, ``correct@t`` and ``precision@t``;
        ``threshold`` is not finite; ``fmt`` is not a format matplotlib writes.
    InvalidTypeError
        ``rows`` is not an iterable, ``threshold`` not a number, ``fmt`` not a string.
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    threshold = as_real(threshold, "threshold")
    fmt = _check_format(fmt)
    key_c, key_p = f"correct@{threshold:g}", f"precision@{threshold:g}"
    rows = _as_rows(rows)
    for row in rows:
        if not isinstance(row, Mapping) or not {"method", key_c, key_p} <= set(row):
            raise InvalidArgumentError(
                f"each row must be a mapping with 'method', {key_c!r} and {key_p!r} (as "
                f"hopmatch.compare.compare returns), got {describe(row)}"
            )
    fig = _figure((7.0, 4.6))
    ax = fig.add_subplot(1, 1, 1)
    methods = list(dict.fromkeys(row["method"] for row in rows))
    cmap = _tab_colours(len(methods))
    for k, method in enumerate(methods):
        pts = [(row[key_c], row[key_p]) for row in rows
               if row["method"] == method and not np.isnan(row[key_p])]
        if not pts:
            continue
        x, y = zip(*pts)
        ax.scatter(np.maximum(x, 1), y, label=method, color=cmap[k],
                   marker=_MARKERS[k % len(_MARKERS)], s=36, alpha=0.85,
                   edgecolors="black" if method.startswith("hopmatch") else "none",
                   linewidths=0.6)
    if not rows:
        ax.text(0.5, 0.5, "no results", ha="center", va="center", transform=ax.transAxes)
    ax.set_xscale("log")
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel(f"correct matches (within {threshold:g} px; log scale)")
    ax.set_ylabel(f"precision@{threshold:g}")
    n_scenes = len({row.get("scene") for row in rows})
    ax.set_title(title or f"Precision@{threshold:g} against correct@{threshold:g} "
                          f"({n_scenes} scene{'s' if n_scenes != 1 else ''})", fontsize=11)
    ax.grid(True, alpha=0.3, which="both")
    if methods:
        ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, frameon=False)
    return _encode(fig, fmt)


def plot_precision_vs_correct(rows, path, threshold: float = 1.0,
                              title: str | None = None) -> Path:
    """Scatter precision against the number of correct matches, one point per method and
    scene, and save it (atomically) to ``path``.

    Parameters
    ----------
    rows : sequence of mapping
        Rows of :func:`hopmatch.compare.compare` (or any mappings with ``method``,
        ``correct@t`` and ``precision@t``; ``scene`` is used for the title).
    path : str or os.PathLike
        Output file; its suffix picks the format (``.png``, ``.pdf``, ``.svg``).
    threshold : float
        The tolerance ``t`` of the columns plotted.
    title : str, optional

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InvalidArgumentError
        A row lacks one of the columns.
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    path = _as_path(path)
    write_bytes_atomic(path, render_precision_vs_correct(rows, threshold, _format_of(path),
                                                         title))
    return path


def render_precision_curves(rows, fmt: str = "png", title: str | None = None) -> bytes:
    """Precision@1 against correct@1 as each method's threshold moves, one line per
    method (rows of :func:`hopmatch.compare.precision_curves`: ``method``, ``parameter``,
    ``value``, ``correct@1``, ``precision@1``), each point labelled with its threshold;
    returns the encoded file.

    Raises
    ------
    InvalidArgumentError
        A row is not a mapping with those keys, or ``fmt`` is not a format matplotlib
        writes.
    InvalidTypeError
        ``rows`` is not an iterable, or ``fmt`` not a string.
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    fmt = _check_format(fmt)
    keys = {"method", "parameter", "value", "correct@1", "precision@1"}
    rows = _as_rows(rows)
    for row in rows:
        if not isinstance(row, Mapping) or not keys <= set(row):
            raise InvalidArgumentError(
                f"each row must be a mapping with {sorted(keys)} (as "
                f"hopmatch.compare.precision_curves returns), got {describe(row)}")
    fig = _figure((7.4, 4.8))
    ax = fig.add_subplot(1, 1, 1)
    methods = list(dict.fromkeys(row["method"] for row in rows))
    cmap = _tab_colours(len(methods))
    for k, method in enumerate(methods):
        mine = [r for r in rows if r["method"] == method and not np.isnan(r["precision@1"])]
        if not mine:
            continue
        x = np.maximum([r["correct@1"] for r in mine], 1)
        y = [r["precision@1"] for r in mine]
        ax.plot(x, y, marker=_MARKERS[k % len(_MARKERS)], color=cmap[k], markersize=4,
                label=f"{method} ({mine[0]['parameter']} ...)")
        for r, xi, yi in zip(mine, x, y):
            ax.annotate(f"{r['value']:g}", (xi, yi), textcoords="offset points",
                        xytext=(3, 3), fontsize=6, color=cmap[k])
    if not rows:
        ax.text(0.5, 0.5, "no results", ha="center", va="center", transform=ax.transAxes)
    ax.set_xscale("log")
    ax.set_xlabel("correct matches within 1 px, all scenes pooled (log scale)")
    ax.set_ylabel("precision@1 (pooled)")
    ax.set_title(title or "Precision against correct matches as each method's threshold "
                          "moves", fontsize=11)
    ax.grid(True, alpha=0.3, which="both")
    if methods:
        ax.legend(loc="lower left", fontsize=8, frameon=False)
    return _encode(fig, fmt)


def plot_precision_curves(rows, path, title: str | None = None) -> Path:
    """:func:`render_precision_curves` saved (atomically) to ``path``; its suffix picks the
    format. Returns the path."""
    path = _as_path(path)
    write_bytes_atomic(path, render_precision_curves(rows, _format_of(path), title))
    return path


def render_error_histogram(errors_by_method, bins=ERROR_BINS, fmt: str = "png",
                           title: str | None = None) -> bytes:
    """The plot of :func:`plot_error_histogram` as encoded bytes.

    Raises
    ------
    InvalidTypeError
        ``errors_by_method`` is not a mapping, or ``fmt`` not a string.
    InvalidArgumentError
        ``fmt`` is not a format matplotlib writes.
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    from ..evaluate import error_histogram  # scipy, only when a histogram is drawn

    fmt = _check_format(fmt)
    if not isinstance(errors_by_method, Mapping):
        raise InvalidTypeError(
            "`errors_by_method` must be a mapping {method name: errors}, got "
            f"{describe(errors_by_method)}"
        )
    hists = {}
    for name, err in errors_by_method.items():
        counts, edges = error_histogram(err, bins=bins)
        hists[name] = counts / max(int(counts.sum()), 1)
    fig = _figure((8.0, 4.2))
    ax = fig.add_subplot(1, 1, 1)
    if hists:
        labels = [f"{a:g}–{b:g}" if np.isfinite(b) else f"≥ {a:g}"
                  for a, b in zip(edges[:-1], edges[1:])]
        n = len(hists)
        width = 0.8 / n
        colours = _tab_colours(n)
        x = np.arange(len(labels))
        for k, (name, frac) in enumerate(hists.items()):
            ax.bar(x - 0.4 + (k + 0.5) * width, frac, width, label=name, color=colours[k])
        ax.set_xticks(x, labels)
        ax.legend(loc="upper right", fontsize=8, ncol=2 if n > 6 else 1, frameon=False)
    else:
        ax.text(0.5, 0.5, "no errors", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("|disparity error| (px)")
    ax.set_ylabel("fraction of scored matches")
    ax.set_title(title or "Disparity error histogram")
    ax.grid(True, axis="y", alpha=0.3)
    return _encode(fig, fmt)


def plot_error_histogram(errors_by_method, path, bins=ERROR_BINS,
                         title: str | None = None) -> Path:
    """Histogram of absolute disparity errors, one group of bars per bin and one bar per
    method (fraction of that method's scored matches), saved (atomically) to ``path``.

    Parameters
    ----------
    errors_by_method : mapping of str to (N,) array_like
        Signed or absolute disparity errors (e.g. ``MatchScore.errors``) per method.
    path : str or os.PathLike
        Output file; its suffix picks the format.
    bins : (B + 1,) sequence of float
        Bin edges on ``|error|`` (see :func:`hopmatch.evaluate.error_histogram`).
    title : str, optional

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InvalidTypeError
        ``errors_by_method`` is not a mapping.
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    path = _as_path(path)
    write_bytes_atomic(path, render_error_histogram(errors_by_method, bins, _format_of(path),
                                                    title))
    return path
