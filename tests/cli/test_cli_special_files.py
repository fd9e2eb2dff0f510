"""The command line on special files and impossible outputs (issue 20), each run in a
subprocess with a time limit: named pipes, devices, sockets, sparse files, image headers
announcing billions of pixels, symbolic link loops, names over 255 bytes, outputs inside a
file or in an unwritable folder, a broken --scheduler. Each gives one line
``hopmatch: error: <file or option>: <problem>`` and exit status 2 in seconds, never a hang,
an unbounded read or an internal error."""

from __future__ import annotations

import os
import socket
import struct
import sys
import time
import zlib

import pytest
from cli_helpers import assert_bad_input, files_in, run

#: Seconds a refused command may take, start-up of the interpreter included (a hang, a read
#: of /dev/zero or a decode of 900 million pixels takes far longer).
LIMIT = 60


def _png_header(width, height):
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0,
                                                              0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b""))


@pytest.fixture(scope="module")
def special(tmp_path_factory):
    d = tmp_path_factory.mktemp("special")
    out = {}
    if hasattr(os, "mkfifo"):
        os.mkfifo(d / "pipe.png")
        out["fifo"] = d / "pipe.png"
    if hasattr(socket, "AF_UNIX"):
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(d / "sock.png"))
        out["socket"] = d / "sock.png"
        out["_socket_object"] = sock
    with open(d / "sparse.png", "wb") as fh:
        fh.truncate(40 * 2**30)
    out["sparse"] = d / "sparse.png"
    (d / "huge.png").write_bytes(_png_header(30000, 30000))
    out["huge"] = d / "huge.png"
    (d / "loop.png").symlink_to(d / "loop.png")
    out["loop"] = d / "loop.png"
    out["long"] = d / ("a" * 300 + ".png")
    if os.path.exists("/dev/zero"):
        out["zero"] = "/dev/zero"
    return out


def _timed(*args):
    t0 = time.perf_counter()
    res = run(*args, timeout=LIMIT)
    return res, time.perf_counter() - t0


CASES = [  # (key of the file, words of the problem)
    ("fifo", "is a named pipe (FIFO), not a regular file"),
    ("zero", "is a character device, not a regular file"),
    ("socket", "is a socket, not a regular file"),
    ("sparse", "is 40.0 GiB"),
    ("huge", "is 30000 x 30000 = 900000000 pixels by its header, more than --max-pixels=50000000"),
    ("loop", "symbolic link loop"),
    ("long", "the name is too long"),
]


@pytest.mark.parametrize("key, words", CASES, ids=[c[0] for c in CASES])
@pytest.mark.parametrize("command", ["match", "detect"])
def test_input_files(special, pair, tmp_path, command, key, words):
    if key not in special:
        pytest.skip(f"no {key} on this system")
    path = special[key]
    args = ([command, path, pair["right"]] if command == "match" else [command, path])
    res, seconds = _timed(*args, "-o", tmp_path / "out")
    line = assert_bad_input(res, str(path)[:60], words)
    assert "create(--" not in line and "internal error" not in line
    assert seconds < LIMIT
    assert files_in(tmp_path) == []  # nothing created for a refused input


def test_max_pixels_option_raises_the_header_limit(special, tmp_path):
    res = run("detect", special["huge"], "-o", tmp_path / "out", "--max-pixels", 10**9,
              timeout=LIMIT)
    # allowed by the header now, then refused by the decoder (the IDAT is 64 bytes)
    assert_bad_input(res, str(special["huge"]), "is not an image OpenCV can read")


def test_outputs_that_cannot_be(pair, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    for out, words in [(tmp_path / ("o" * 300), "the name"),
                       (blocker / "sub", "not a folder"),
                       (blocker, "exists and is not a folder")]:
        res, _ = _timed("match", pair["left"], pair["right"], "-o", out)
        assert_bad_input(res, words)
    assert files_in(tmp_path) == ["a_file"] and blocker.read_text() == "x"
    if sys.platform.startswith("linux") and os.path.isdir("/proc/self"):
        res, _ = _timed("match", pair["left"], pair["right"], "-o", "/proc/self")
        assert_bad_input(res, "/proc/self", "cannot write")


def test_bad_float_and_integer_options(pair, tmp_path):
    for option, value in [("--alpha", "5e-324"), ("--max-iterations", str(10**30)),
                          ("--seed", str(2**64)), ("--max-vertical", "1e400")]:
        res, _ = _timed("match", pair["left"], pair["right"], "-o", tmp_path / "o", option,
                        value)
        line = assert_bad_input(res, option)
        assert "internal error" not in line
    assert files_in(tmp_path) == []


# -- hopmatch batch (plugin hopmatch_dask) ---------------------------------------------------

dask = pytest.importorskip("distributed")


def test_batch_scheduler_addresses(pair, tmp_path):
    pairs = tmp_path / "pairs.csv"
    pairs.write_text(f"left,right\n{pair['left']},{pair['right']}\n")
    for address, words in [("nonsense://::x", "unknown address scheme 'nonsense'"),
                           ("tcp://", "names no host"),
                           ("tcp://a:b", "is not a Dask scheduler address"),
                           ("tcp://127.0.0.1:1", "cannot reach 127.0.0.1:1")]:
        res, seconds = _timed("batch", pairs, "-o", tmp_path / "out", "--scheduler", address)
        assert_bad_input(res, "--scheduler", words)
        assert seconds < 20  # no 30 s connection timeout


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_batch_with_a_fifo(special, pair, tmp_path):
    res, _ = _timed("batch", special["fifo"], "-o", tmp_path / "out")
    assert_bad_input(res, "named pipe")
    pairs = tmp_path / "pairs.csv"
    pairs.write_text(f"left,right,name\n{pair['left']},{pair['right']},good\n"
                     f"{special['fifo']},{pair['right']},bad\n")
    res = run("batch", pairs, "-o", tmp_path / "out2", "--workers", 1, "--max-disparity", 12,
              timeout=240)
    assert res.returncode == 3, res.stderr  # ran to its end, one pair failed
    summary = (tmp_path / "out2" / "summary.csv").read_text()
    assert "good,ok," in summary and "bad,failed" in summary and "named pipe" in summary
