"""The drawing and atomic-writing helpers of :mod:`hopmatch.viz` that the commands rely on."""

from __future__ import annotations

import sys

import cv2
import numpy as np
import pytest

from hopmatch import viz


class TestViz:
    img = np.zeros((40, 50), np.uint8)
    pts = np.float32([[10, 10], [30, 20], [40, 30]])

    def test_draw_matches(self):
        pairs = np.array([[0, 0], [1, 1], [2, 2]])
        plain = viz.draw_matches(self.img, self.img, self.pts, self.pts, pairs)
        assert plain.shape == (40, 100, 3) and plain.dtype == np.uint8
        coloured = viz.draw_matches(self.img, self.img, self.pts, self.pts, pairs,
                                    np.array([True, False, False]),
                                    known=np.array([True, True, False]))
        # the lines run along rows 10, 20, 30 (anti-aliased: a little darker than the colour)
        b, g, r = (coloured[10, 20:50].astype(int).mean(axis=0))
        assert g > 150 and b == r == 0  # correct: green
        b, g, r = (coloured[20, 40:70].astype(int).mean(axis=0))
        assert r > 150 and b == g == 0  # wrong: red
        b, g, r = (coloured[30, 50:80].astype(int).mean(axis=0))
        assert b == g == r > 100  # no ground truth: grey
        with pytest.raises(ValueError, match="correct"):
            viz.draw_matches(self.img, self.img, self.pts, self.pts, pairs,
                             np.array([True, False]))
        with pytest.raises(ValueError, match="matches"):
            viz.draw_matches(self.img, self.img, self.pts, self.pts, np.array([[0, 5]]))

    def test_draw_disparity_and_keypoints(self):
        out = viz.draw_disparity(self.img, self.pts, [1.0, 2.0, 3.0], max_disparity=3)
        assert out.shape == (40, 50, 3)
        assert tuple(out[30, 40]) == tuple(
            cv2.applyColorMap(np.uint8([[255]]), cv2.COLORMAP_TURBO)[0, 0])
        empty = viz.draw_disparity(self.img, np.zeros((0, 2), np.float32), [])
        assert empty.shape == (40, 50, 3) and not empty.any()
        kps = viz.draw_keypoints(np.full((40, 50), 100, np.uint16), self.pts)
        assert kps.shape == (40, 50, 3) and kps.dtype == np.uint8

    def test_atomic_writers_leave_nothing_on_failure(self, tmp_path):
        path = viz.write_image_atomic(tmp_path / "a.png", self.img)
        assert cv2.imread(str(path), cv2.IMREAD_GRAYSCALE).shape == (40, 50)
        viz.write_text_atomic(tmp_path / "a.txt", "hello")
        assert (tmp_path / "a.txt").read_text() == "hello"
        with pytest.raises(ValueError, match="encode"):
            viz.write_image_atomic(tmp_path / "b.unknownext", self.img)
        with pytest.raises(OSError):  # the destination is a folder: os.replace fails
            (tmp_path / "dir.txt").mkdir()
            viz.write_text_atomic(tmp_path / "dir.txt", "x")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.txt", "dir.txt"]

    def test_plot_energy(self, tmp_path, monkeypatch):
        pytest.importorskip("matplotlib")
        path = viz.plot_energy(np.linspace(0, -10, 50), tmp_path / "e.png")
        assert cv2.imread(str(path)) is not None
        for name in ("matplotlib", "matplotlib.figure", "matplotlib.backends",
                     "matplotlib.backends.backend_agg"):
            monkeypatch.setitem(sys.modules, name, None)
        with pytest.raises(ImportError, match=r"pip install hopmatch\[all\]"):
            viz.plot_energy([1.0, 0.0], tmp_path / "f.png")
        assert not (tmp_path / "f.png").exists()
