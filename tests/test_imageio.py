"""Tests of hopmatch.imageio: read_image on good, missing, empty, corrupt and unreadable
files, its flags, the kind of each error, and the silencing of what decoders print."""

from __future__ import annotations

import errno
import os
import time
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np
import pytest

import hopmatch.files
from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.imageio import DEFAULT_FLAGS, KINDS, ImageReadError, os_reason, read_image


@pytest.fixture
def files(tmp_path):
    """Good and bad image files: grey, BGRA, 16-bit, garbage, truncated, empty, a folder."""
    rng = np.random.default_rng(3)
    grey = rng.integers(0, 256, (20, 30), dtype=np.uint8)
    bgra = rng.integers(0, 256, (20, 30, 4), dtype=np.uint8)
    deep = rng.integers(0, 65536, (20, 30), dtype=np.uint16)
    paths = {name: tmp_path / f"{name}.png" for name in
             ("grey", "bgra", "deep", "garbage", "truncated", "empty")}
    assert cv2.imwrite(str(paths["grey"]), grey)
    assert cv2.imwrite(str(paths["bgra"]), bgra)
    assert cv2.imwrite(str(paths["deep"]), deep)
    paths["garbage"].write_bytes(b"this is not an image at all")
    data = paths["grey"].read_bytes()
    paths["truncated"].write_bytes(data[: len(data) // 2])
    paths["empty"].write_bytes(b"")
    paths["folder"] = tmp_path / "a_folder.png"
    paths["folder"].mkdir()
    return paths, {"grey": grey, "bgra": bgra, "deep": deep}


class TestGoodFiles:
    def test_default_flags_keep_depth_and_channels(self, files):
        paths, arrays = files
        assert DEFAULT_FLAGS == cv2.IMREAD_ANYDEPTH | cv2.IMREAD_ANYCOLOR
        np.testing.assert_array_equal(read_image(paths["grey"]), arrays["grey"])
        deep = read_image(paths["deep"])
        assert deep.dtype == np.uint16
        np.testing.assert_array_equal(deep, arrays["deep"])
        # as cv2.imread with the same flags: alpha dropped
        np.testing.assert_array_equal(read_image(paths["bgra"]),
                                      cv2.imread(str(paths["bgra"]), DEFAULT_FLAGS))

    @pytest.mark.parametrize("flags", [cv2.IMREAD_UNCHANGED, cv2.IMREAD_ANYCOLOR,
                                       cv2.IMREAD_GRAYSCALE, cv2.IMREAD_COLOR])
    @pytest.mark.parametrize("name", ["grey", "bgra", "deep"])
    def test_flags_as_cv2_imread(self, files, name, flags):
        paths, _ = files
        expected = cv2.imread(str(paths[name]), flags)
        got = read_image(paths[name], flags)
        assert got.dtype == expected.dtype and got.shape == expected.shape
        np.testing.assert_array_equal(got, expected)

    def test_unchanged_keeps_alpha(self, files):
        paths, arrays = files
        np.testing.assert_array_equal(read_image(paths["bgra"], cv2.IMREAD_UNCHANGED),
                                      arrays["bgra"])

    def test_str_and_non_ascii_paths(self, files, tmp_path):
        paths, arrays = files
        odd = tmp_path / "gauche-é-左.png"
        odd.write_bytes(paths["grey"].read_bytes())
        np.testing.assert_array_equal(read_image(str(odd)), arrays["grey"])

    @pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
    def test_named_pipe_is_refused_before_it_is_opened(self, tmp_path):
        """Issue 20: a pipe with no writer blocked ``open()`` forever (a whole batch with
        it). A pipe is refused from its ``stat``, never opened, whoever writes to it."""
        fifo = tmp_path / "pipe.png"
        os.mkfifo(fifo)
        t0 = time.perf_counter()
        with pytest.raises(ImageReadError) as exc:
            read_image(fifo)
        assert time.perf_counter() - t0 < 1.0
        assert exc.value.kind == "special" and "named pipe (FIFO)" in exc.value.problem
        assert "save the data to a file first" in exc.value.problem


BAD = [  # (key of the file, kind, words of the message)
    ("missing", "missing", "no such file"),
    ("folder", "folder", "is a folder, not an image file"),
    ("empty", "empty", "is empty (0 bytes), not an image"),
    ("garbage", "undecodable", "is not an image OpenCV can read"),
    ("truncated", "undecodable", "is not an image OpenCV can read"),
]


class TestBadFiles:
    @pytest.mark.parametrize("key, kind, words", BAD, ids=[b[0] for b in BAD])
    def test_error_names_the_file_and_the_kind(self, files, tmp_path, key, kind, words):
        paths, _ = files
        path = paths.get(key, tmp_path / "missing.png")
        with pytest.raises(ImageReadError) as exc:
            read_image(path)
        err = exc.value
        assert isinstance(err, InvalidArgumentError) and isinstance(err, ValueError)
        assert err.kind == kind and kind in KINDS
        assert err.path == str(path) and words in err.problem
        assert str(err) == f"{path}: {err.problem}"

    def test_unreadable(self, files, monkeypatch):
        paths, _ = files

        real_open = os.open

        def refuse(path, flags, *args):  # as for a file of another user (the tests run as root)
            if os.fspath(path) == str(paths["grey"]):
                raise PermissionError(errno.EACCES, "Permission denied", str(path))
            return real_open(path, flags, *args)

        monkeypatch.setattr(hopmatch.files.os, "open", refuse)
        with pytest.raises(ImageReadError, match="cannot read the file: permission denied") as exc:
            read_image(paths["grey"])
        assert exc.value.kind == "unreadable"

    def test_decoder_output_goes_into_the_message_not_the_terminal(self, files, capfd):
        paths, _ = files
        with pytest.raises(ImageReadError) as exc:
            read_image(paths["truncated"])
        out, err = capfd.readouterr()
        assert out == "" and err == ""
        assert exc.value.problem.startswith("is not an image OpenCV can read (corrupt, truncated")

    def test_argument_types(self, files):
        paths, _ = files
        with pytest.raises(InvalidTypeError, match="`path`"):
            read_image(42)
        with pytest.raises(InvalidTypeError, match="`flags`"):
            read_image(paths["grey"], flags="unchanged")

    def test_error_without_kind(self):
        err = ImageReadError("left.png", "no such file")
        assert err.kind is None and str(err) == "left.png: no such file"


class TestFileDescriptor2:
    def test_restored_after_every_outcome(self, files):
        paths, _ = files
        before = os.fstat(2)
        for key in ("grey", "garbage", "truncated", "empty"):
            try:
                read_image(paths[key])
            except ImageReadError:
                pass
        after = os.fstat(2)
        assert (after.st_dev, after.st_ino) == (before.st_dev, before.st_ino)

    def test_concurrent_reads(self, files):
        """Threads reading good and corrupt files at once get the right answers, and leave
        descriptor 2 where it was."""
        paths, arrays = files
        before = os.fstat(2)

        def one(i):
            if i % 2:
                with pytest.raises(ImageReadError, match="not an image OpenCV can read"):
                    read_image(paths["truncated"])
                return True
            return np.array_equal(read_image(paths["grey"]), arrays["grey"])

        with ThreadPoolExecutor(4) as ex:
            assert all(ex.map(one, range(200)))
        after = os.fstat(2)
        assert (after.st_dev, after.st_ino) == (before.st_dev, before.st_ino)


def test_os_reason():
    assert os_reason(PermissionError(errno.EACCES, "Permission denied")) == "permission denied"
    assert os_reason(OSError(errno.ENOSPC, "No space")) == "no space left on the device"
    assert os_reason(OSError(errno.EIO, "Input/output error")) == "Input/output error"


# -- issue 20: special files, sizes and pixels are refused before anything is decoded -------


def _png_header(width: int, height: int, bitdepth: int = 8, colour: int = 0) -> bytes:
    """A PNG of one IHDR chunk announcing ``width x height`` and a short broken IDAT: a
    decoder would need gigabytes for it, the header check needs none."""
    import struct
    import zlib

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    ihdr = struct.pack(">IIBBBBB", width, height, bitdepth, colour, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64))
            + chunk(b"IEND", b""))


class TestLimits:
    @pytest.mark.parametrize("name, data", [
        ("png", _png_header(30000, 30000)),
        ("png16rgb", _png_header(16000, 16000, 16, 2)),
        ("pgm", b"P5\n60000 60000\n255\n" + b"\0" * 64),
        ("ppm", b"P6\n40000 40000\n65535\n" + b"\0" * 64),
        ("pam", b"P7\nWIDTH 50000\nHEIGHT 50000\nDEPTH 1\nMAXVAL 255\nTUPLTYPE GRAYSCALE\n"
                b"ENDHDR\n" + b"\0" * 64),
        ("hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 40000 +X 40000\n" + b"\0" * 64),
    ])
    def test_pixels_are_refused_from_the_header(self, tmp_path, monkeypatch, name, data):
        path = tmp_path / f"big.{name}"
        path.write_bytes(data)
        decoded = []
        monkeypatch.setattr(cv2, "imdecode", lambda *a: decoded.append(a))
        t0 = time.perf_counter()
        with pytest.raises(ImageReadError) as exc:
            read_image(path)
        assert time.perf_counter() - t0 < 1.0 and decoded == []
        err = exc.value
        assert err.kind == "too_many_pixels" and "more than max_pixels=50000000" in err.problem
        assert "by its header" in err.problem and "max_pixels=" in err.problem

    def test_pixel_limit_is_a_parameter(self, files):
        paths, arrays = files
        with pytest.raises(ImageReadError, match=r"20 = 600 pixels.*max_pixels=599"):
            read_image(paths["grey"], max_pixels=599)
        np.testing.assert_array_equal(read_image(paths["grey"], max_pixels=600), arrays["grey"])
        np.testing.assert_array_equal(read_image(paths["grey"], max_pixels=None), arrays["grey"])
        with pytest.raises(InvalidArgumentError, match="`max_pixels`"):
            read_image(paths["grey"], max_pixels=0)
        with pytest.raises(InvalidTypeError, match="`max_bytes`"):
            read_image(paths["grey"], max_bytes=1.5)

    def test_bytes_limit(self, files, tmp_path):
        paths, _ = files
        size = paths["grey"].stat().st_size
        with pytest.raises(ImageReadError) as exc:
            read_image(paths["grey"], max_bytes=size - 1)
        assert exc.value.kind == "too_large" and "max_bytes" in exc.value.problem
        sparse = tmp_path / "sparse.png"
        with open(sparse, "wb") as fh:
            fh.truncate(40 * 2**30)
        t0 = time.perf_counter()
        with pytest.raises(ImageReadError, match="40.0 GiB") as exc:
            read_image(sparse)
        assert exc.value.kind == "too_large" and time.perf_counter() - t0 < 1.0

    @pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero here")
    def test_devices_and_sockets(self, tmp_path):
        import socket

        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(tmp_path / "s.png"))
        for path, words in (("/dev/zero", "a character device"),
                            (tmp_path / "s.png", "a socket")):
            t0 = time.perf_counter()
            with pytest.raises(ImageReadError) as exc:
                read_image(path)
            assert exc.value.kind == "special" and words in exc.value.problem
            assert time.perf_counter() - t0 < 1.0

    def test_symlink_loop_and_long_name_are_not_missing_files(self, tmp_path):
        (tmp_path / "loop.png").symlink_to(tmp_path / "loop.png")
        with pytest.raises(ImageReadError) as exc:
            read_image(tmp_path / "loop.png")
        assert exc.value.kind == "unreadable" and "symbolic link loop" in exc.value.problem
        with pytest.raises(ImageReadError) as exc:
            read_image(tmp_path / ("a" * 300 + ".png"))
        assert exc.value.kind == "unreadable" and "too long" in exc.value.problem

    def test_header_size(self, files):
        from hopmatch.imageio import header_size

        paths, _ = files
        assert header_size(paths["grey"].read_bytes()) == (30, 20)
        assert header_size(cv2.imencode(".jpg", np.zeros((7, 9), np.uint8))[1].tobytes()) == (9, 7)
        assert header_size(cv2.imencode(".tiff", np.zeros((7, 9), np.uint8))[1].tobytes()) == (9, 7)
        assert header_size(b"garbage") is None

    def test_header_size_leaves_the_warning_filters_alone(self, files, monkeypatch):
        """The process-wide filters are not thread-local: a header read that changed them
        (``warnings.catch_warnings``) would drop another thread's warnings meanwhile."""
        import warnings

        from hopmatch.imageio import header_size

        def refuse(*args, **kwargs):
            raise AssertionError("header_size changed the process-wide warning filters")

        monkeypatch.setattr(warnings, "catch_warnings", refuse)
        monkeypatch.setattr(warnings, "simplefilter", refuse)
        monkeypatch.setattr(warnings, "filterwarnings", refuse)
        paths, _ = files
        assert header_size(paths["grey"].read_bytes()) == (30, 20)
        for ext in (".jpg", ".tiff", ".bmp", ".webp"):
            data = cv2.imencode(ext, np.zeros((7, 9), np.uint8))[1].tobytes()
            assert header_size(data) == (9, 7), ext
