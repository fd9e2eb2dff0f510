"""Tests of hopmatch.stereo.ply: write_ply's content and its all-or-nothing writes."""

from __future__ import annotations

import os

import numpy as np
import pytest

from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.stereo import ply as ply_module
from hopmatch.stereo import write_ply


class TestWritePly:
    def test_content(self, tmp_path):
        xyz = np.array([[0, 0, 1], [0.5, -0.25, 2], [np.nan, 0, 0], [1, 2, 3]], np.float32)
        colors = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [1, 2, 3]], np.uint8)
        path = tmp_path / "cloud.ply"
        assert write_ply(path, xyz, colors) == 3
        lines = path.read_text().splitlines()
        end = lines.index("end_header")
        assert lines[0] == "ply" and lines[1] == "format ascii 1.0"
        assert "element vertex 3" in lines
        assert "property uchar red" in lines and "property float z" in lines
        rows = lines[end + 1:]
        assert rows == ["0 0 1 255 0 0", "0.5 -0.25 2 0 255 0", "1 2 3 1 2 3"]
        assert os.listdir(tmp_path) == ["cloud.ply"]

    def test_no_colours_and_empty(self, tmp_path):
        xyz = np.random.default_rng(0).normal(size=(50, 3)).astype(np.float32)
        path = tmp_path / "a.ply"
        assert write_ply(str(path), xyz) == 50
        lines = path.read_text().splitlines()
        rows = lines[lines.index("end_header") + 1:]
        assert len(rows) == 50 and "property uchar red" not in lines
        np.testing.assert_array_equal(np.array([r.split() for r in rows], np.float32), xyz)
        assert write_ply(tmp_path / "e.ply", np.zeros((0, 3))) == 0
        assert "element vertex 0" in (tmp_path / "e.ply").read_text()

    def test_bad_colours_leave_no_file(self, tmp_path):
        xyz = np.zeros((4, 3))
        with pytest.raises(InvalidArgumentError, match=r"`colors` must have shape \(4, 3\)"):
            write_ply(tmp_path / "c.ply", xyz, np.zeros((3, 3), np.uint8))
        with pytest.raises(InvalidTypeError, match="`colors` must have dtype uint8.*astype"):
            write_ply(tmp_path / "c.ply", xyz, np.zeros((4, 3)))
        with pytest.raises(InvalidArgumentError, match=r"`xyz` must have shape \(N, 3\)"):
            write_ply(tmp_path / "c.ply", np.zeros((4, 2)))
        assert os.listdir(tmp_path) == []

    def test_failure_while_writing_keeps_the_old_file(self, tmp_path, monkeypatch):
        path = tmp_path / "c.ply"
        path.write_text("old")

        def broken(fh, pts, cols):
            fh.write("ply\nformat ascii 1.0\nelement vertex")
            raise OSError("disk full")

        monkeypatch.setattr(ply_module, "_write_ply_body", broken)
        with pytest.raises(OSError, match="disk full"):
            write_ply(path, np.zeros((4, 3)))
        assert os.listdir(tmp_path) == ["c.ply"] and path.read_text() == "old"

    def test_missing_folder(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="does not exist"):
            write_ply(tmp_path / "no" / "c.ply", np.zeros((1, 3)))
