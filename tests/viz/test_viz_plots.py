"""matplotlib plots of :mod:`hopmatch.viz.plots`: the energy of a run, precision against
correct matches, the error histogram; and what happens without matplotlib."""

from __future__ import annotations

import sys

import cv2
import numpy as np
import pytest

from hopmatch import viz

NO_MATPLOTLIB = ("matplotlib", "matplotlib.figure", "matplotlib.backends",
                 "matplotlib.backends.backend_agg")


def test_plot_energy(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    path = viz.plot_energy(np.linspace(0, -10, 50), tmp_path / "e.png")
    assert cv2.imread(str(path)) is not None
    for name in NO_MATPLOTLIB:
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(ImportError, match=r"pip install hopmatch\[all\]"):
        viz.plot_energy([1.0, 0.0], tmp_path / "f.png")
    assert not (tmp_path / "f.png").exists()


def test_plots_without_matplotlib(tmp_path, monkeypatch):
    for name in NO_MATPLOTLIB:
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(ImportError, match=r"pip install hopmatch\[all\]"):
        viz.plot_precision_vs_correct([], tmp_path / "a.png")
    with pytest.raises(ImportError, match=r"pip install hopmatch\[all\]"):
        viz.plot_error_histogram({"m": [0.1]}, tmp_path / "b.png")
    assert list(tmp_path.iterdir()) == []


def test_plot_rejects_rows_without_the_columns(tmp_path):
    pytest.importorskip("matplotlib")
    with pytest.raises(ValueError, match="correct@1"):
        viz.plot_precision_vs_correct([{"method": "m"}], tmp_path / "a.png")


def test_render_and_plot_write_the_same_bytes(tmp_path):
    pytest.importorskip("matplotlib")
    rows = [{"method": "a", "scene": "s", "correct@1": 40, "precision@1": 0.8},
            {"method": "b", "scene": "s", "correct@1": 7, "precision@1": float("nan")}]
    errors = {"a": [0.1, -0.7, 3.0], "b": []}
    trace = np.linspace(0, -3, 20)
    pairs = [(viz.render_energy(trace, "png"), viz.plot_energy(trace, tmp_path / "e.png")),
             (viz.render_precision_vs_correct(rows),
              viz.plot_precision_vs_correct(rows, tmp_path / "p.png")),
             (viz.render_error_histogram(errors),
              viz.plot_error_histogram(errors, tmp_path / "h.png"))]
    for data, path in pairs:
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and path.read_bytes() == data
    svg = viz.plot_energy([], tmp_path / "empty.SVG").read_bytes()
    assert b"<svg" in svg[:500]
    with pytest.raises(TypeError, match="errors_by_method"):
        viz.render_error_histogram([0.1, 0.2])


def test_precision_curves_plot(tmp_path):
    pytest.importorskip("matplotlib")
    rows = [{"method": "a", "parameter": "distance <=", "value": v, "correct@1": c,
             "precision@1": p} for v, c, p in ((0.01, 10, 1.0), (0.1, 90, 0.95))]
    rows.append({"method": "b", "parameter": "ratio <", "value": 0.8, "correct@1": 0,
                 "precision@1": float("nan")})
    path = viz.plot_precision_curves(rows, tmp_path / "c.png")
    assert cv2.imread(str(path)) is not None
    assert path.read_bytes() == viz.render_precision_curves(rows)
    with pytest.raises(ValueError, match="precision_curves"):
        viz.plot_precision_curves([{"method": "m"}], tmp_path / "d.png")
    assert not (tmp_path / "d.png").exists()
