"""hopmatch._files: all-or-nothing writes (also re-exported by hopmatch.viz)."""

from __future__ import annotations

import os

import cv2
import numpy as np
import pytest

from hopmatch import _files, viz

IMG = np.zeros((40, 50), np.uint8)


def test_atomic_writers_leave_nothing_on_failure(tmp_path):
    path = viz.write_image_atomic(tmp_path / "a.png", IMG)
    assert cv2.imread(str(path), cv2.IMREAD_GRAYSCALE).shape == (40, 50)
    viz.write_text_atomic(tmp_path / "a.txt", "hello")
    assert (tmp_path / "a.txt").read_text() == "hello"
    with pytest.raises(ValueError, match="encode"):
        viz.write_image_atomic(tmp_path / "b.unknownext", IMG)
    with pytest.raises(OSError):  # the destination is a folder: os.replace fails
        (tmp_path / "dir.txt").mkdir()
        viz.write_text_atomic(tmp_path / "dir.txt", "x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.txt", "dir.txt"]


def test_viz_reexports_the_one_home():
    assert viz.write_text_atomic is _files.write_text_atomic
    assert viz.write_image_atomic is _files.write_image_atomic


def test_every_writer_creates_files_with_one_mode(tmp_path):
    """Text, images, FileStorage parameters and PLY clouds: 0o666 minus the umask."""
    import hopmatch
    from hopmatch.stereo import write_ply

    old = os.umask(0o022)
    try:
        _files.write_text_atomic(tmp_path / "t.txt", "x")
        _files.write_image_atomic(tmp_path / "i.png", IMG)
        hopmatch.HopfieldMatcher().write(str(tmp_path / "m.yml"))
        write_ply(tmp_path / "c.ply", np.zeros((3, 3), np.float32))
    finally:
        os.umask(old)
    modes = {p.name: p.stat().st_mode & 0o777 for p in tmp_path.iterdir()}
    assert modes == {"t.txt": 0o644, "i.png": 0o644, "m.yml": 0o644, "c.ply": 0o644}


def test_atomic_path_removes_the_temporary_file_on_interrupt(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with _files.atomic_path(tmp_path / "out.yml") as tmp:
            tmp.write_text("partial")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []
