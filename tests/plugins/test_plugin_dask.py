"""hopmatch_dask: batches on a real scheduler and worker processes on 127.0.0.1.

One LocalCluster (2 worker processes, 1 thread each, no dashboard) serves the module; a
test kills one of its workers mid-batch (the nanny restarts it). Every wait has a timeout.
"""

from __future__ import annotations

import csv
import os
import signal
import time

import cv2
import numpy as np
import pytest

distributed = pytest.importorskip("distributed", reason="needs dask[distributed] "
                                  "(pip install 'hopmatch[all]')")

import hopmatch  # noqa: E402
import hopmatch_dask  # noqa: E402
from hopmatch_dask import Pair, read_pairs, run_batch  # noqa: E402
from hopmatch_dask.results import COLUMNS, matches_table  # noqa: E402

PARAMS = {"max_disparity": 16}
TIMEOUT = 60
DASK_WORKERS = 2  # the `client` fixture's cluster (tests/plugins/conftest.py)


def _pair_images(i: int, shape=(200, 260)):
    rng = np.random.default_rng(100 + i)
    left = cv2.GaussianBlur((rng.random(shape) * 255).astype(np.uint8), (3, 3), 0)
    return left, np.roll(left, -(3 + i % 8), axis=1)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """12 generated pairs, a corrupt image and a missing one, and PAIRS.csv files."""
    d = tmp_path_factory.mktemp("pairs")
    (d / "img").mkdir()
    good = []
    for i in range(12):
        left, right = _pair_images(i)
        cv2.imwrite(str(d / "img" / f"l{i:02d}.png"), left)
        cv2.imwrite(str(d / "img" / f"r{i:02d}.png"), right)
        good.append((f"img/l{i:02d}.png", f"img/r{i:02d}.png", f"p{i:02d}"))
    data = (d / "img" / "l00.png").read_bytes()
    (d / "img" / "corrupt.png").write_bytes(data[: len(data) // 3])  # truncated PNG
    bad = [("img/corrupt.png", "img/r00.png", "corrupt"), ("img/nothere.png", "img/r00.png",
                                                           "missing")]
    for name, rows in (("good.csv", good), ("mixed.csv", good[:3] + bad)):
        (d / name).write_text("left,right,name\n" + "".join(f"{a},{b},{c}\n" for a, b, c in rows))
    return d


def _expected_table(i: int) -> str:
    res = hopmatch.match_stereo(*_pair_images(i), **PARAMS)
    return matches_table(res.matched_left, res.matched_right, res.disparities, res.distances)


def _summary(out):
    with open(out / "summary.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _leftovers(out):
    return [p.name for p in out.iterdir() if p.name.startswith(".")]


class TestBatch:
    def test_every_pair_has_one_complete_result(self, client, dataset, tmp_path):
        pairs = read_pairs(dataset / "good.csv")
        report = run_batch(pairs, tmp_path / "out", client=client, **PARAMS)
        out = tmp_path / "out"
        assert report.ok and report.count("ok") == 12
        assert sorted(p.name for p in out.iterdir()) == sorted(
            [f"p{i:02d}.csv" for i in range(12)] + ["summary.csv"])
        for i in range(12):  # same bytes as matching directly
            assert (out / f"p{i:02d}.csv").read_text() == _expected_table(i)
        rows = _summary(out)
        assert list(rows[0]) == ["name", "status", "matches", "seconds", "error", "warning"]
        assert all(r["warning"] == "" for r in rows)  # textured pairs: nothing to warn about
        assert [r["name"] for r in rows] == [f"p{i:02d}" for i in range(12)]
        assert all(r["status"] == "ok" and int(r["matches"]) > 20 for r in rows)
        assert len({o.worker for o in report.outcomes}) == 2  # both workers took pairs

    def test_rerun_recomputes_nothing(self, client, dataset, tmp_path, monkeypatch):
        out = tmp_path / "out"
        pairs = read_pairs(dataset / "good.csv")
        run_batch(pairs, out, client=client, **PARAMS)
        stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("p*.csv")}
        submitted = []
        monkeypatch.setattr(client, "submit", lambda *a, **k: submitted.append(a))
        report = run_batch(pairs, out, client=client, **PARAMS)
        assert submitted == []
        assert report.ok and report.count("skipped") == 12
        assert {p.name: p.stat().st_mtime_ns for p in out.glob("p*.csv")} == stamps
        assert all(r["status"] == "skipped" for r in _summary(out))

    def test_damaged_result_is_computed_again(self, client, dataset, tmp_path):
        out = tmp_path / "out"
        pairs = read_pairs(dataset / "good.csv")[:4]
        run_batch(pairs, out, client=client, **PARAMS)
        text = (out / "p02.csv").read_text()
        (out / "p02.csv").write_text(text[: len(text) // 2])  # cut mid-line
        report = run_batch(pairs, out, client=client, **PARAMS)
        assert [o.status for o in report.outcomes] == ["skipped", "skipped", "ok", "skipped"]
        assert (out / "p02.csv").read_text() == text

    @pytest.mark.parametrize("damage", ["cut at a line boundary", "nan row", "inf row",
                                        "no summary entry"])
    def test_damage_a_parser_cannot_see_is_computed_again(self, client, dataset, tmp_path,
                                                          damage):
        """Issue 20: a file cut at a line boundary, or holding nan, was taken as complete
        on resume. Rows must be finite and as many as summary.csv recorded."""
        out = tmp_path / "out"
        pairs = read_pairs(dataset / "good.csv")[:3]
        run_batch(pairs, out, client=client, **PARAMS)
        text = (out / "p01.csv").read_text()
        lines = text.splitlines(keepends=True)
        if damage == "cut at a line boundary":
            (out / "p01.csv").write_text("".join(lines[:len(lines) // 2]))
        elif damage in ("nan row", "inf row"):
            lines[2] = ",".join([damage.split()[0]] * len(COLUMNS)) + "\n"
            (out / "p01.csv").write_text("".join(lines))
        else:  # the summary lost the pair (a hard kill before it was rewritten)
            summary = (out / "summary.csv").read_text().splitlines(keepends=True)
            (out / "summary.csv").write_text("".join(x for x in summary if "p01" not in x))
        report = run_batch(pairs, out, client=client, **PARAMS)
        assert [o.status for o in report.outcomes] == ["skipped", "ok", "skipped"]
        assert (out / "p01.csv").read_text() == text

    def test_special_result_files_are_not_read(self, client, dataset, tmp_path):
        out = tmp_path / "out"
        out.mkdir()
        if hasattr(os, "mkfifo"):
            os.mkfifo(out / "p00.csv")  # would block a reader forever
        report = run_batch(read_pairs(dataset / "good.csv")[:1], out, client=client, **PARAMS)
        assert report.ok and (out / "p00.csv").read_text() == _expected_table(0)

    def test_worker_killed_mid_batch(self, client, dataset, tmp_path):
        out = tmp_path / "out"
        pairs = [Pair(f"k{i:02d}", str(dataset / "img" / f"l{i:02d}.png"),
                      str(dataset / "img" / f"r{i:02d}.png")) for i in range(12)]
        killed = {}

        def kill_a_busy_worker(outcome, done, total):
            if killed:
                return
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                busy = {w: ks for w, ks in client.processing().items() if ks}
                if busy:
                    break
                time.sleep(0.01)
            assert busy, "no worker was processing a task after the first result"
            worker, keys = next(iter(busy.items()))
            pid = client.run(os.getpid, workers=[worker])[worker]
            os.kill(pid, signal.SIGKILL)  # a worker process this test's cluster started
            killed.update(pid=pid, names={str(k).split("-")[2] for k in keys})

        report = run_batch(pairs, out, client=client, progress=kill_a_busy_worker,
                           max_disparity=16)
        assert killed and killed["names"]
        assert report.ok, [o for o in report.outcomes if o.status != "ok"]
        # every pair ended with exactly one result, and it is the right one
        assert sorted(p.name for p in out.iterdir()) == sorted(
            [f"k{i:02d}.csv" for i in range(12)] + ["summary.csv"])
        for i in range(12):
            assert (out / f"k{i:02d}.csv").read_text() == _expected_table(i)
        # what the killed worker held was run again elsewhere
        by_name = {o.name: o for o in report.outcomes}
        for name in killed["names"]:
            assert not by_name[name].worker.endswith(f":{killed['pid']}")
        assert [r["name"] for r in _summary(out)] == [f"k{i:02d}" for i in range(12)]
        client.wait_for_workers(2, timeout=TIMEOUT)  # the nanny restarted it

    def test_corrupt_and_missing_pairs_are_reported(self, client, dataset, tmp_path):
        out = tmp_path / "out"
        report = run_batch(read_pairs(dataset / "mixed.csv"), out, client=client, **PARAMS)
        assert not report.ok
        status = {o.name: o for o in report.outcomes}
        assert [status[n].status for n in ("p00", "p01", "p02")] == ["ok"] * 3
        assert status["corrupt"].status == "failed"
        assert "corrupt.png: is not an image OpenCV can read" in status["corrupt"].error
        assert status["missing"].status == "failed"
        assert "nothere.png: no such file" in status["missing"].error
        rows = {r["name"]: r for r in _summary(out)}
        assert rows["corrupt"]["status"] == "failed" and rows["corrupt"]["matches"] == ""
        assert "no such file" in rows["missing"]["error"]
        assert not (out / "corrupt.csv").exists() and not (out / "missing.csv").exists()
        assert _leftovers(out) == []


class TestMatchPairs:
    def test_futures(self, client, dataset):
        pairs = [(str(dataset / "img" / f"l{i:02d}.png"), str(dataset / "img" / f"r{i:02d}.png"))
                 for i in range(3)]
        futures = hopmatch_dask.match_pairs(pairs, client, **PARAMS)
        assert all(isinstance(f, distributed.Future) for f in futures)
        results = [f.result(timeout=TIMEOUT) for f in futures]
        for i, r in enumerate(results):
            assert r.name == f"pair-{i:04d}"
            ref = hopmatch.match_stereo(*_pair_images(i), **PARAMS)
            np.testing.assert_array_equal(r.matched_left, ref.matched_left)
            np.testing.assert_array_equal(r.matched_right, ref.matched_right)
            np.testing.assert_array_equal(r.disparities, ref.disparities)
            assert r.to_csv() == _expected_table(i)

    def test_arrays_and_errors(self, client):
        left, right = _pair_images(4)
        ok, bad = hopmatch_dask.match_pairs([(left, right, "arr"), ("/nonexistent.png", right)],
                                            client=client, **PARAMS)
        assert ok.result(timeout=TIMEOUT).name == "arr"
        with pytest.raises(hopmatch_dask.ImageReadError, match="no such file"):
            bad.result(timeout=TIMEOUT)

    def test_lazy_bag_without_client(self):
        import dask

        left, right = _pair_images(5)
        bag = hopmatch_dask.match_pairs([(left, right)], **PARAMS)
        assert hasattr(bag, "compute") and hasattr(bag, "npartitions")
        (result,) = bag.compute(scheduler="sync")
        ref = hopmatch.match_stereo(left, right, **PARAMS)
        np.testing.assert_array_equal(result.disparities, ref.disparities)
        assert dask.is_dask_collection(bag)

    def test_bad_parameters_fail_on_the_client(self, client):
        with pytest.raises(ValueError, match="unknown parameter"):
            hopmatch_dask.match_pairs([("a.png", "b.png")], client, max_disparty=3)
        with pytest.raises(ValueError, match="window_size"):
            hopmatch_dask.match_pairs([("a.png", "b.png")], client, window_size=4)

    def test_parameters_are_split_by_the_library_rule(self, tmp_path):
        """check_params is match_stereo's split (split_parameters / stereo_pipeline)."""
        with pytest.raises(ValueError, match=r"run_batch got unknown parameter\(s\) \['nms'\]"):
            run_batch([("a.png", "b.png")], tmp_path / "out", nms=3)
        with pytest.raises(ValueError, match="match_pairs got unknown parameter") as info:
            hopmatch_dask.match_pairs([("a.png", "b.png")], nms=3)
        assert info.value.argument is None
        with pytest.raises(ValueError) as info:
            hopmatch_dask.check_params({"similarity_gate": -1.0})
        assert info.value.argument == "similarity_gate"
        params = {"preset": "paper", "window_size": 7, "max_disparity": 12.0}
        assert hopmatch_dask.check_params(params) == params

    def test_rectified_false_is_checked_on_the_client(self):
        """``rectified`` is match_stereo's own argument (``hopmatch batch --unrectified``)."""
        params = {"rectified": False, "window_size": 7}
        assert hopmatch_dask.check_params(params) == params
        with pytest.raises(ValueError, match="max_disparity") as info:
            hopmatch_dask.check_params({"rectified": False, "max_disparity": 12.0})
        assert info.value.argument == "max_disparity"
        with pytest.raises(TypeError, match="rectified") as info:
            hopmatch_dask.check_params({"rectified": "no"})
        assert info.value.argument == "rectified"


def test_a_worker_matches_an_unrectified_pair():
    """What ``hopmatch batch --unrectified`` runs on a worker: match_stereo(rectified=False);
    without it the worker's match_stereo finds the pair off its rows and does the same, and
    with rectified=True it searches the rows and finds little."""
    from hopmatch_dask.tasks import match_pair

    rng = np.random.default_rng(3)
    left = cv2.GaussianBlur(rng.random((300, 400)).astype(np.float32), (0, 0), 2.0)
    left = ((left - left.min()) / (left.max() - left.min()) * 255).astype(np.uint8)
    right = np.roll(left, -8, axis=1)
    right[:150] = np.roll(left, -16, axis=1)[:150]  # two depths: F is not degenerate
    A = cv2.getRotationMatrix2D((199.5, 149.5), 3.0, 1.0)
    right = cv2.warpAffine(right, A, (400, 300), flags=cv2.INTER_LINEAR)
    rows = match_pair(Pair("p", left, right), {"rectified": True})
    res = match_pair(Pair("p", left, right), {"rectified": False})
    assert len(res.matched_left) > 500
    assert len(res.matched_left) > 3 * len(rows.matched_left)
    with pytest.warns(hopmatch.errors.UnrectifiedPairWarning, match="matched as an unrectified"):
        plain = match_pair(Pair("p", left, right), {})
    np.testing.assert_array_equal(plain.matched_left, res.matched_left)

    """The plugin writes <name>.csv with the library's writer, as hopmatch match does."""
    from hopmatch import tables
    from hopmatch_dask import results

    assert results.matches_table is tables.matches_table
    assert results.COLUMNS == tables.MATCH_COLUMNS == tuple(
        "left_x left_y right_x right_y disparity distance".split())


class TestReadPairs:
    def test_relative_paths_and_default_names(self, tmp_path):
        (tmp_path / "a").mkdir()
        (tmp_path / "b").mkdir()
        (tmp_path / "p.csv").write_text("right,left\nb/im1.png,a/im0.png\nb/x1.png,b/im0.png\n")
        pairs = read_pairs(tmp_path / "p.csv")
        assert [p.name for p in pairs] == ["a_im0", "b_im0"]
        assert pairs[0].left == str(tmp_path / "a" / "im0.png")
        assert pairs[0].right == str(tmp_path / "b" / "im1.png")

    @pytest.mark.parametrize("text, message", [
        ("", "is empty"),
        ("left,rigth\na,b\n", "header must name the columns left,right"),
        ("left,right\n", "no pair"),
        ("left,right\na.png\n", "line 2: expected 2 cells"),
        ("left,right,name\na.png,,x\n", "line 2: the `right` cell is empty"),
        ("left,right,name\na.png,b.png,x\nc.png,d.png,X\n", "line 3: the name 'X' is already used"),
        ("left,right,name\na.png,b.png,summary\n", "reserved"),
        ("left,right,name\na.png,b.png,../up\n", "cannot name a result file"),
    ])
    def test_errors_name_file_and_line(self, tmp_path, text, message):
        (tmp_path / "p.csv").write_text(text)
        with pytest.raises(hopmatch_dask.PairsFileError, match=message):
            read_pairs(tmp_path / "p.csv")

    def test_missing_file(self, tmp_path):
        with pytest.raises(hopmatch_dask.PairsFileError, match="no such file"):
            read_pairs(tmp_path / "nope.csv")


class TestInputs:
    """Issue 20: PAIRS.csv and the images are regular files of bounded size, and the
    scheduler address is checked before anything is submitted."""

    def test_pairs_file_that_is_not_a_regular_file(self, tmp_path):
        if hasattr(os, "mkfifo"):
            os.mkfifo(tmp_path / "pipe.csv")
            with pytest.raises(hopmatch_dask.PairsFileError, match="named pipe"):
                read_pairs(tmp_path / "pipe.csv")
        with open(tmp_path / "sparse.csv", "wb") as fh:
            fh.truncate(40 * 2**30)
        t0 = time.perf_counter()
        with pytest.raises(hopmatch_dask.PairsFileError, match="40.0 GiB"):
            read_pairs(tmp_path / "sparse.csv")
        assert time.perf_counter() - t0 < 1.0

    def test_images_over_max_pixels_are_refused_from_the_header(self, tmp_path, monkeypatch):
        from hopmatch_dask.tasks import batch_task

        big = tmp_path / "big.png"
        assert cv2.imwrite(str(big), np.zeros((300, 400), np.uint8))
        decoded = []
        monkeypatch.setattr(cv2, "imdecode", lambda *a: decoded.append(a))
        r = batch_task(Pair("big", str(big), str(big)), {"max_pixels": 1000})
        assert r["status"] == "failed" and "more than max_pixels=1000" in r["error"]
        assert decoded == []

    @pytest.mark.parametrize("address, words", [
        ("nonsense://::x", "unknown address scheme"), ("tcp://", "names no host"),
        ("tcp://h:b", "not a Dask scheduler address"), ("tcp://127.0.0.1:1", "cannot reach"),
        ("tcp://127.0.0.1:99999", "not in [1, 65535]"), ("", "must be an address")])
    def test_check_scheduler(self, address, words):
        from hopmatch_dask.batch import SchedulerAddressError, check_scheduler

        t0 = time.perf_counter()
        with pytest.raises(SchedulerAddressError) as exc:
            check_scheduler(address)
        assert words in str(exc.value) and exc.value.argument == "scheduler"
        assert time.perf_counter() - t0 < 3.0

    def test_check_scheduler_accepts_a_running_one(self, client):
        from hopmatch_dask.batch import check_scheduler

        assert check_scheduler(client.scheduler.address) == client.scheduler.address


class TestCommandLine:
    @pytest.fixture
    def hopmatch_main(self, monkeypatch):
        """``hopmatch.cli.main`` with ``batch`` attached, as hopmatch.cli attaches it."""
        from hopmatch import cli as hcli
        from hopmatch_dask.cli import batch

        monkeypatch.setitem(hcli.cli.commands, "batch", batch)
        return hcli.main

    def test_batch_on_a_running_scheduler(self, hopmatch_main, client, dataset, tmp_path,
                                          capsys):
        out = tmp_path / "out"
        status = hopmatch_main(["batch", str(dataset / "mixed.csv"), "--out", str(out),
                                "--scheduler", client.scheduler.address,
                                "--max-disparity", "16"])
        captured = capsys.readouterr()
        assert status == 3, captured.err
        assert "pairs: 5 (3 matched, 0 already done, 2 failed)" in captured.out
        assert "failed: corrupt:" in captured.err
        assert [r["status"] for r in _summary(out)] == ["ok", "ok", "ok", "failed", "failed"]
        assert (out / "p01.csv").read_text() == _expected_table(1)
        with open(out / "p01.csv") as fh:
            assert next(csv.reader(fh)) == list(COLUMNS)

    def test_batch_on_an_embedded_local_cluster(self, hopmatch_main, dataset, tmp_path,
                                                capsys):
        (tmp_path / "two.csv").write_text(
            "left,right\n" + "".join(f"{dataset}/img/l{i:02d}.png,{dataset}/img/r{i:02d}.png\n"
                                     for i in range(2)))
        out = tmp_path / "out"
        status = hopmatch_main(["batch", str(tmp_path / "two.csv"), "-o", str(out),
                                "--workers", "1", "--max-disparity", "16"])
        captured = capsys.readouterr()
        assert status == 0, captured.err
        assert "local cluster of 1 workers" in captured.out
        assert (out / "l00.csv").read_text() == _expected_table(0)
        assert (out / "l01.csv").read_text() == _expected_table(1)
        status = hopmatch_main(["--quiet", "batch", str(tmp_path / "two.csv"), "-o", str(out)])
        assert status == 0 and capsys.readouterr().out == ""  # all skipped: no cluster started

    @pytest.mark.parametrize("args, where, problem", [
        (["batch", "{tmp}/nope.csv", "--out", "{tmp}/o"], "{tmp}/nope.csv", "no such file"),
        (["batch", "{csv}", "--out", "{tmp}/o", "--window-size", "4"], "--window-size",
         "must be odd"),
        (["batch", "{csv}", "--out", "{tmp}/o", "--workers", "2", "--scheduler",
          "tcp://127.0.0.1:1"], "command line", "cannot be used with --scheduler"),
        (["batch", "{csv}", "--out", "{csv}"], "--out", "exists and is not a folder"),
        (["batch", "{csv}", "--out", "{tmp}/o", "--unrectified", "--max-disparity", "12"],
         "--max-disparity", "rectified=False"),
    ])
    def test_bad_input(self, hopmatch_main, dataset, tmp_path, capsys, args, where, problem):
        fill = {"tmp": str(tmp_path), "csv": str(dataset / "good.csv")}
        status = hopmatch_main([a.format(**fill) for a in args])
        err = capsys.readouterr().err
        assert status == 2
        assert err.startswith(f"hopmatch: error: {where.format(**fill)}: "), err
        assert problem in err
