"""hopmatch.files: all-or-nothing writes (also re-exported by hopmatch.viz), and the checks of
the files hopmatch reads (issue 20: no pipe, device or socket opened, sizes bounded)."""

from __future__ import annotations

import errno
import os
import socket
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from hopmatch import errors, files, viz
from hopmatch.errors import InvalidArgumentError

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
    assert viz.write_text_atomic is files.write_text_atomic
    assert viz.write_image_atomic is files.write_image_atomic


def test_every_writer_creates_files_with_one_mode(tmp_path):
    """Text, images, FileStorage parameters and PLY clouds: 0o666 minus the umask."""
    import hopmatch
    from hopmatch.stereo import write_ply

    old = os.umask(0o022)
    try:
        files.write_text_atomic(tmp_path / "t.txt", "x")
        files.write_image_atomic(tmp_path / "i.png", IMG)
        hopmatch.HopfieldMatcher().write(str(tmp_path / "m.yml"))
        write_ply(tmp_path / "c.ply", np.zeros((3, 3), np.float32))
    finally:
        os.umask(old)
    modes = {p.name: p.stat().st_mode & 0o777 for p in tmp_path.iterdir()}
    assert modes == {"t.txt": 0o644, "i.png": 0o644, "m.yml": 0o644, "c.ply": 0o644}


def test_atomic_path_removes_the_temporary_file_on_interrupt(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with files.atomic_path(tmp_path / "out.yml") as tmp:
            tmp.write_text("partial")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


# -- issue 20: the files hopmatch reads are checked before they are opened --------------



def _special_files(tmp_path):
    """(path, words of the problem) of every kind of file that is not a regular one."""
    out = []
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "pipe")
        out.append((tmp_path / "pipe", "a named pipe (FIFO)"))
    if os.path.exists("/dev/zero"):
        out.append((Path("/dev/zero"), "a character device"))
    if hasattr(socket, "AF_UNIX"):
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(tmp_path / "sock"))
        out.append((tmp_path / "sock", "a socket"))
    return out


class TestInputFiles:
    def test_regular_file(self, tmp_path):
        (tmp_path / "a.bin").write_bytes(b"abc")
        assert files.check_input_file(tmp_path / "a.bin").st_size == 3
        assert files.read_input_bytes(tmp_path / "a.bin") == b"abc"
        assert files.read_input_text(tmp_path / "a.bin") == "abc"

    def test_special_files_are_refused_without_being_opened(self, tmp_path, monkeypatch):
        opened = []
        real_open = os.open
        monkeypatch.setattr(files.os, "open", lambda p, *a: opened.append(p) or real_open(p, *a))
        for path, words in _special_files(tmp_path):
            t0 = time.perf_counter()
            with pytest.raises(errors.FileReadError) as exc:
                files.read_input_bytes(path, argument="fs")
            assert time.perf_counter() - t0 < 1.0
            err = exc.value
            assert isinstance(err, InvalidArgumentError) and isinstance(err, ValueError)
            assert err.kind == "special" and words in err.problem and err.argument == "fs"
            assert str(err).startswith(str(path))
        assert opened == []

    def test_missing_folder_loop_and_long_names(self, tmp_path):
        (tmp_path / "loop").symlink_to(tmp_path / "loop")
        (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
        (tmp_path / "a_file").write_text("x")
        cases = [
            (tmp_path / "missing", "missing", "no such file"),
            (tmp_path / "dangling", "missing", "symbolic link to a missing file"),
            (tmp_path / "a_file" / "below", "missing", "a part of the path is a file"),
            (tmp_path, "folder", "is a folder"),
            (tmp_path / "loop", "unreadable", "symbolic link loop"),
            (tmp_path / ("n" * 300), "unreadable", "the name is too long"),
        ]
        for path, kind, words in cases:
            with pytest.raises(errors.FileReadError) as exc:
                files.check_input_file(path)
            assert (exc.value.kind, words in exc.value.problem) == (kind, True), exc.value
            assert exc.value.kind in files.READ_KINDS

    def test_size_is_bounded_before_and_while_reading(self, tmp_path):
        big = tmp_path / "sparse.bin"
        with open(big, "wb") as fh:
            fh.truncate(40 * 2**30)  # 40 GiB, sparse: nothing is read
        t0 = time.perf_counter()
        with pytest.raises(errors.FileReadError, match=r"40\.0 GiB .* more than the 1\.0 GiB"):
            files.read_input_bytes(big)
        assert time.perf_counter() - t0 < 1.0
        (tmp_path / "small").write_bytes(b"x" * 100)
        with pytest.raises(errors.FileReadError) as exc:
            files.read_input_bytes(tmp_path / "small", max_bytes=99)
        assert exc.value.kind == "too_large"
        assert files.read_input_bytes(tmp_path / "small", max_bytes=100) == b"x" * 100

    def test_not_a_path(self):
        with pytest.raises(TypeError, match="`fs` must be a str or os.PathLike"):
            files.check_input_file(3, argument="fs")

    def test_os_reason(self):
        assert "loop" in files.os_reason(OSError(errno.ELOOP, "x"))
        assert "too long" in files.os_reason(OSError(errno.ENAMETOOLONG, "x"))


class TestWriteErrors:
    """Issue 20: a write that cannot happen raises FileWriteError (an InvalidArgumentError and
    an OSError) naming the destination, never the temporary file, and leaves nothing."""

    def _check(self, exc, path, words):
        err = exc.value
        assert isinstance(err, errors.FileWriteError)
        assert isinstance(err, InvalidArgumentError) and isinstance(err, OSError)
        assert str(path) in str(err) and words in str(err)
        assert ".tmp" not in str(err)

    def test_onto_a_folder(self, tmp_path):
        for write in (lambda p: files.write_text_atomic(p, "x"),
                      lambda p: files.write_image_atomic(p, IMG),
                      lambda p: viz.write_text_atomic(p, "x")):
            target = tmp_path / "dir.png"
            target.mkdir(exist_ok=True)
            with pytest.raises(errors.FileWriteError) as exc:
                write(target)
            self._check(exc, target, "a folder of that name")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.png"]

    def test_long_names(self, tmp_path):
        with pytest.raises(errors.FileWriteError) as exc:
            files.write_text_atomic(tmp_path / ("b" * 300), "x")
        self._check(exc, tmp_path / ("b" * 300), "300 bytes long, more than the 255")
        # a name of 250 bytes is valid: its temporary name is shortened to fit
        ok = files.write_text_atomic(tmp_path / ("c" * 250), "x")
        assert ok.read_text() == "x" and len(list(tmp_path.iterdir())) == 1

    def test_missing_folder(self, tmp_path):
        with pytest.raises(errors.FileWriteError, match="does not exist"):
            files.write_text_atomic(tmp_path / "no" / "a.txt", "x")

    @pytest.mark.skipif(not os.path.isdir("/proc/self"),
                        reason="needs Linux /proc (a folder nobody can write in, even root)")
    def test_unwritable_folder(self):
        with pytest.raises(errors.FileWriteError) as exc:
            files.write_text_atomic("/proc/self/hopmatch.txt", "x")
        self._check(exc, "/proc/self/hopmatch.txt", "cannot write")
        with pytest.raises(errors.FileWriteError) as exc:
            with files.atomic_path("/proc/self/p.yml", "fs"):
                pass
        assert exc.value.argument == "fs"


# --------------------------------------------------------------------------------------
# FileStorage files nested too deep for OpenCV's parser (a segmentation fault before)
# --------------------------------------------------------------------------------------

#: Texts nested 50,000 deep, each of which crashed ``cv2.FileStorage(path, READ)``.
DEEP_TEXTS = {
    "flow.yml": "%YAML:1.0\n---\na: " + "[" * 50_000 + "]" * 50_000 + "\n",
    "maps.yml": "%YAML:1.0\n---\na: " + "{b: " * 50_000 + "1" + "}" * 50_000 + "\n",
    "deep.xml": ('<?xml version="1.0"?>\n<opencv_storage>\n' + "<a>" * 50_000 + "1"
                 + "</a>" * 50_000 + "\n</opencv_storage>\n"),
    "deep.json": '{"a": ' + "[" * 100_000 + "]" * 100_000 + "}",
}


def test_the_nesting_bound_counts_every_opening_bracket():
    assert files.storage_nesting_bound(b"") == 0
    assert files.storage_nesting_bound(b"%YAML:1.0\n---\na: [ 1, 2 ]\nb: { c: 3 }\n") == 2
    assert files.storage_nesting_bound(b'<?xml version="1.0"?><s><a>1</a></s>') == 5


@pytest.mark.parametrize("name", sorted(DEEP_TEXTS))
def test_a_filestorage_file_nested_too_deep_is_refused_not_a_crash(tmp_path, name):
    """OpenCV 4's parser crashes on these (check_storage_nesting refuses them first),
    OpenCV 5's refuses them with an exception: either way a hopmatch error, quickly."""
    import hopmatch
    from hopmatch.stereo import StereoCalibration

    path = tmp_path / name
    path.write_text(DEEP_TEXTS[name])
    t0 = time.perf_counter()
    with pytest.raises(InvalidArgumentError) as exc:
        hopmatch.HopfieldMatcher.create().load(str(path))
    assert exc.value.argument == "fs" or "`fs`" in str(exc.value)
    with pytest.raises(InvalidArgumentError):
        StereoCalibration.from_file(path)
    assert time.perf_counter() - t0 < 10.0


#: Child programs standing for OpenCV's parser: one that crashes, one that refuses.
CRASHING_CHILD = "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)"
REFUSING_CHILD = "raise SystemExit(1)"


def test_the_nesting_check_refuses_what_crashes_its_child_and_only_that(tmp_path,
                                                                         monkeypatch):
    path = tmp_path / "many.yml"
    path.write_text("%YAML:1.0\n---\na: " + "[" * 300 + "]" * 300 + "\n")
    monkeypatch.setattr(files, "_PARSE_IN_CHILD", CRASHING_CHILD)
    with pytest.raises(errors.FileReadError) as exc:
        files.check_storage_nesting(path, argument="fs")
    assert exc.value.kind == "too_deep" and exc.value.argument == "fs"
    assert "crashes" in exc.value.problem
    monkeypatch.setattr(files, "_PARSE_IN_CHILD", REFUSING_CHILD)
    files.check_storage_nesting(path)  # the caller's own parse raises the parser's error
    few = tmp_path / "few.yml"
    few.write_text("%YAML:1.0\n---\na: [ 1, 2 ]\n")
    monkeypatch.setattr(files, "_PARSE_IN_CHILD", CRASHING_CHILD)
    files.check_storage_nesting(few)  # 1 bracket: no child at all


def test_a_filestorage_file_of_many_shallow_brackets_is_read_after_the_check(tmp_path):
    """More brackets than MAX_STORAGE_NESTING, two levels deep: checked in a child process,
    then read."""
    path = tmp_path / "many.yml"
    path.write_text("%YAML:1.0\n---\na: [ " + ", ".join(["[ 1 ]"] * 400) + " ]\nb: 7\n")
    assert files.storage_nesting_bound(path.read_bytes()) > files.MAX_STORAGE_NESTING
    files.check_storage_nesting(path)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert fs.getNode("b").real() == 7 and fs.getNode("a").size() == 400
    fs.release()
