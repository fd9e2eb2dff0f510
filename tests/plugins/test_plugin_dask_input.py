"""hopmatch_dask: bad input is refused at the boundary, before a cluster starts, a folder is
created or anything is submitted; errors are hopmatch's and name the argument.

Most tests replace ``distributed.LocalCluster`` and ``distributed.Client`` with stubs that
fail the test if called (``no_cluster``): a refusal must come before either. The few that
need a cluster share one LocalCluster of one worker process with one thread.
"""

from __future__ import annotations

import csv
import inspect
import socket
import threading
import warnings

import cv2
import numpy as np
import pytest

distributed = pytest.importorskip("distributed", reason="needs dask[distributed] "
                                  "(pip install 'hopmatch[all]')")

import hopmatch  # noqa: E402
import hopmatch_dask  # noqa: E402
from hopmatch.errors import (  # noqa: E402
    BudgetExceededError,
    FewMatchesWarning,
    FileWriteError,
    InvalidArgumentError,
    InvalidTypeError,
)
from hopmatch_dask import (  # noqa: E402
    Pair,
    PairsFileError,
    as_pairs,
    match_pairs,
    read_pairs,
    run_batch,
)
from hopmatch_dask.batch import SchedulerAddressError, check_scheduler  # noqa: E402
from hopmatch_dask.checks import max_local_workers  # noqa: E402
from hopmatch_dask.results import (  # noqa: E402
    MAX_MESSAGE_CHARS,
    complete_rows,
    finished_counts,
    matches_table,
    summary_table,
)

PARAMS = {"max_disparity": 8}
TIMEOUT = 60


def _textured(seed=0, shape=(48, 64)):
    rng = np.random.default_rng(seed)
    left = cv2.GaussianBlur((rng.random(shape) * 255).astype(np.uint8), (3, 3), 0)
    return left, np.roll(left, -3, axis=1)


L, R = _textured()
BLANK = np.zeros((48, 64), np.uint8)


@pytest.fixture
def no_cluster(monkeypatch):
    """Fail the test if a cluster is started or a client made."""
    def refuse(*args, **kwargs):
        raise AssertionError("a cluster was started or a client made before the refusal")

    monkeypatch.setattr(distributed, "LocalCluster", refuse)
    monkeypatch.setattr(distributed, "Client", refuse)


@pytest.fixture
def hopmatch_main(monkeypatch):
    from hopmatch import cli as hcli
    from hopmatch_dask.cli import batch

    monkeypatch.setitem(hcli.cli.commands, "batch", batch)
    return hcli.main


@pytest.fixture
def images(tmp_path):
    """One textured pair as PNG files."""
    cv2.imwrite(str(tmp_path / "l.png"), L)
    cv2.imwrite(str(tmp_path / "r.png"), R)
    return str(tmp_path / "l.png"), str(tmp_path / "r.png")


# -- finding 1: workers --------------------------------------------------------------------


class TestWorkers:
    @pytest.mark.parametrize("workers, error", [
        (0, InvalidArgumentError), (-1, InvalidArgumentError), (10**6, InvalidArgumentError),
        (1.5, InvalidTypeError), ("1", InvalidTypeError), (True, InvalidTypeError)])
    def test_run_batch_refuses_bad_workers_before_any_cluster(self, no_cluster, tmp_path,
                                                              images, workers, error):
        with pytest.raises(error) as info:
            run_batch([(*images, "p")], tmp_path / "out", workers=workers, **PARAMS)
        assert info.value.argument == "workers" and "`workers`" in str(info.value)
        assert not (tmp_path / "out").exists()

    @pytest.mark.parametrize("workers", [0, -2, 1.5, "1", False, max_local_workers() + 1])
    def test_local_cluster_refuses_bad_workers(self, no_cluster, workers):
        with pytest.raises((InvalidArgumentError, InvalidTypeError), match="`workers`"):
            hopmatch_dask.local_cluster(workers)

    @pytest.mark.parametrize("value", ["99999999999999999999999", "0"])
    def test_cli_refuses_bad_workers(self, hopmatch_main, no_cluster, tmp_path, images,
                                     capsys, value):
        (tmp_path / "p.csv").write_text(f"left,right\n{images[0]},{images[1]}\n")
        status = hopmatch_main(["batch", str(tmp_path / "p.csv"), "--out",
                                str(tmp_path / "out"), "--workers", value])
        err = capsys.readouterr().err
        assert status == 2 and err.startswith("hopmatch: error: --workers: "), err
        assert not (tmp_path / "out").exists()


# -- findings 3, 4, 7: pair names ------------------------------------------------------------


class TestNames:
    @pytest.mark.parametrize("name", ["../escaped", "summary", "SUMMARY", "a\x00b", "x/y", "",
                                      ".hidden", "x\n", "n" * 252])
    def test_pair_instances_get_the_name_check(self, no_cluster, tmp_path, images, name):
        with pytest.raises(InvalidArgumentError) as info:
            run_batch([Pair(name, *images)], tmp_path / "out", **PARAMS)
        assert info.value.argument == "pairs" and "`pairs[0]`" in str(info.value)
        assert len(str(info.value)) < 400  # a long name is cut in the message
        assert not (tmp_path / "out").exists() and not (tmp_path / "escaped.csv").exists()

    def test_names_of_up_to_251_bytes_are_accepted(self, images):
        assert as_pairs([Pair("n" * 251, *images)])[0].name == "n" * 251
        with pytest.raises(InvalidArgumentError, match="at most 251"):
            as_pairs([(*images, "n" * 140_000)])

    @pytest.mark.parametrize("name", [1, None, b"x", ("a",)])
    def test_non_text_names(self, images, name):
        with pytest.raises(InvalidTypeError, match="the name must be a str") as info:
            as_pairs([Pair(name, *images)])
        assert info.value.argument == "pairs"
        with pytest.raises(InvalidTypeError, match="the name must be a str"):
            as_pairs([(*images, name)])

    def test_long_names_in_pairs_csv(self, tmp_path):
        (tmp_path / "p.csv").write_text("left,right,name\na.png,b.png," + "n" * 300 + "\n")
        with pytest.raises(PairsFileError, match="line 2: the name .* is 300 bytes long"):
            read_pairs(tmp_path / "p.csv")


# -- finding 5: out --------------------------------------------------------------------------


class TestOut:
    @pytest.mark.parametrize("out, error", [
        (None, InvalidTypeError), (5, InvalidTypeError), (b"out", InvalidTypeError),
        ("", InvalidArgumentError), ("a\x00b", InvalidArgumentError)])
    def test_bad_values(self, no_cluster, images, out, error):
        with pytest.raises(error) as info:
            run_batch([(*images, "p")], out, **PARAMS)
        assert info.value.argument == "out" and "`out`" in str(info.value)

    def test_empty_out_does_not_write_in_the_working_folder(self, no_cluster, images,
                                                            tmp_path, monkeypatch):
        monkeypatch.chdir(tmp_path)
        with pytest.raises(InvalidArgumentError, match="empty path"):
            run_batch([(*images, "p")], "", **PARAMS)
        assert not (tmp_path / "summary.csv").exists() and not (tmp_path / "p.csv").exists()

    @pytest.mark.parametrize("where", ["file", "under a file", "summary.csv is a folder"])
    def test_file_system_refusals(self, no_cluster, images, tmp_path, where):
        (tmp_path / "f").write_text("x")
        out = {"file": tmp_path / "f", "under a file": tmp_path / "f" / "sub",
               "summary.csv is a folder": tmp_path / "out"}[where]
        if where == "summary.csv is a folder":
            (out / "summary.csv").mkdir(parents=True)
        with pytest.raises(FileWriteError) as info:
            run_batch([(*images, "p")], out, **PARAMS)
        assert isinstance(info.value, OSError) and info.value.argument == "out"
        assert str(out) in str(info.value)
        assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
            ["f", "l.png", "r.png"] + (["out"] if where == "summary.csv is a folder" else []))

    def test_a_refused_mkdir_is_a_file_write_error(self, no_cluster, images, tmp_path,
                                                   monkeypatch):
        def refuse(self, *args, **kwargs):
            raise PermissionError(13, "Permission denied", str(self))

        monkeypatch.setattr(type(tmp_path), "mkdir", refuse)
        with pytest.raises(FileWriteError, match="cannot create the folder: permission denied"):
            run_batch([(*images, "p")], tmp_path / "out", **PARAMS)

    def test_cli_names_out(self, hopmatch_main, no_cluster, images, tmp_path, capsys):
        (tmp_path / "p.csv").write_text(f"left,right\n{images[0]},{images[1]}\n")
        status = hopmatch_main(["batch", str(tmp_path / "p.csv"), "--out", ""])
        err = capsys.readouterr().err
        assert status == 2 and err.startswith("hopmatch: error: --out: "), err
        assert "empty path" in err


# -- finding 6: warnings of a pair ---------------------------------------------------------


class TestWarnings:
    def test_run_batch_records_and_gives_the_warnings(self, client, tmp_path):
        out = tmp_path / "out"
        pairs = [(BLANK, BLANK, "blank1"), (L, R, "textured"), (BLANK, BLANK, "blank2")]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            report = run_batch(pairs, out, client=client, **PARAMS)
        assert report.ok
        by_name = {o.name: o for o in report.outcomes}
        for name in ("blank1", "blank2"):  # the same warning twice on one worker: both kept
            assert by_name[name].matches == 0
            assert by_name[name].warning.startswith("FewMatchesWarning: no matches")
        assert by_name["textured"].warning == ""
        given = [w for w in caught if issubclass(w.category, FewMatchesWarning)]
        assert len(given) == 2 and str(given[0].message).startswith("no matches")
        with open(out / "summary.csv", newline="") as fh:
            rows = {r["name"]: r for r in csv.DictReader(fh)}
        assert rows["blank1"]["status"] == "ok" and rows["blank1"]["error"] == ""
        assert rows["blank1"]["warning"] == by_name["blank1"].warning
        # results stay those of match_stereo, and the summary is still read back on reruns
        ref = hopmatch.match_stereo(L, R, **PARAMS)
        assert (out / "textured.csv").read_text() == matches_table(
            ref.matched_left, ref.matched_right, ref.disparities, ref.distances)
        assert finished_counts(out / "summary.csv") == {"blank1": 0, "textured": len(
            ref.disparities), "blank2": 0}

    def test_match_pairs_results_carry_and_give_the_warnings(self, client):
        futures = match_pairs([(BLANK, BLANK), (L, R)], client, **PARAMS)
        with pytest.warns(FewMatchesWarning, match="no matches"):
            blank = futures[0].result(timeout=TIMEOUT)
        assert [c for c, _ in blank.warnings] == [FewMatchesWarning]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            textured = futures[1].result(timeout=TIMEOUT)
        assert textured.warnings == () and caught == []
        np.testing.assert_array_equal(textured.disparities,
                                      hopmatch.match_stereo(L, R, **PARAMS).disparities)

    def test_in_process_results_warn_once(self):
        """A bag computed in this process: the warning reaches the caller once, directly."""
        bag = match_pairs([(BLANK, BLANK)], **PARAMS)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            (result,) = bag.compute(scheduler="sync")
        assert len([w for w in caught if issubclass(w.category, FewMatchesWarning)]) == 1
        assert len(result.disparities) == 0

    def test_the_command_prints_the_warning_of_a_pair(self, hopmatch_main, client, tmp_path,
                                                      capsys):
        cv2.imwrite(str(tmp_path / "blank.png"), BLANK)
        (tmp_path / "p.csv").write_text("left,right,name\nblank.png,blank.png,b\n")
        status = hopmatch_main(["batch", str(tmp_path / "p.csv"), "--out",
                                str(tmp_path / "out"), "--scheduler", client.scheduler.address])
        err = capsys.readouterr().err
        assert status == 0, err
        assert "warning: b: FewMatchesWarning: no matches" in err
        assert "FewMatchesWarning: no matches" in (tmp_path / "out" / "summary.csv").read_text()

    def test_old_summaries_are_still_read(self, tmp_path):
        (tmp_path / "summary.csv").write_text("name,status,matches,seconds,error\n"
                                              "a,ok,12,0.5,\nb,failed,,,boom\n")
        assert finished_counts(tmp_path / "summary.csv") == {"a": 12}


# -- findings 7, 8: fields over the csv module's limit ------------------------------------


class TestLongFields:
    def test_an_unreadable_summary_is_treated_as_empty(self, tmp_path):
        (tmp_path / "summary.csv").write_text("name,status,matches\np0,ok," + "x" * 200_000
                                              + "\n")
        assert finished_counts(tmp_path / "summary.csv") == {}

    def test_recorded_texts_are_cut(self, tmp_path):
        outcome = hopmatch_dask.Outcome("p", "failed", error="e" * 200_000,
                                        warning="w" * 200_000)
        (tmp_path / "summary.csv").write_text(summary_table([outcome]))
        with open(tmp_path / "summary.csv", newline="") as fh:
            (row,) = csv.DictReader(fh)
        assert len(row["error"]) == len(row["warning"]) == MAX_MESSAGE_CHARS

    def test_pairs_csv_with_a_huge_cell(self, hopmatch_main, tmp_path, capsys):
        path = tmp_path / "p.csv"
        path.write_text("left,right\na.png,b.png\n" + "x" * 200_000 + ",b.png\n")
        with pytest.raises(PairsFileError, match=r"p\.csv line 3: cannot be read as CSV"):
            read_pairs(path)
        status = hopmatch_main(["batch", str(path), "--out", str(tmp_path / "out")])
        assert status == 2 and "line 3" in capsys.readouterr().err


# -- findings 9, 10: the scheduler ---------------------------------------------------------


class TestScheduler:
    @pytest.mark.parametrize("address", ["nonsense://::x", "tcp://127.0.0.1:1", 5,
                                         "inproc://xyz", "ws://127.0.0.1:1", ""])
    def test_run_batch_checks_the_scheduler_before_writing(self, no_cluster, tmp_path, images,
                                                           address):
        with pytest.raises(SchedulerAddressError) as info:
            run_batch([(*images, "p")], tmp_path / "out", scheduler=address, **PARAMS)
        assert info.value.argument == "scheduler"
        assert not (tmp_path / "out").exists()

    def test_a_port_that_is_not_a_scheduler(self, no_cluster, tmp_path, images, monkeypatch):
        """Something listens but does not speak Dask (distributed would wait for its
        handshake for ever): SchedulerAddressError, and nothing written."""
        from hopmatch_dask import checks

        server = socket.create_server(("127.0.0.1", 0))
        threading.Thread(target=server.accept, daemon=True).start()
        monkeypatch.setattr(checks, "HANDSHAKE_TIMEOUT", 0.5)
        address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
        try:
            with pytest.raises(SchedulerAddressError, match="no Dask handshake") as info:
                run_batch([(*images, "p")], tmp_path / "out", scheduler=address, **PARAMS)
        finally:
            server.close()
        assert address in str(info.value) and info.value.argument == "scheduler"
        assert not (tmp_path / "out").exists()

    def test_a_failed_connection_names_the_scheduler(self, client, tmp_path, images,
                                                     monkeypatch):
        """The address answered the checks, then the client could not connect."""
        def fail(*args, **kwargs):
            raise OSError("Timed out trying to connect")

        monkeypatch.setattr(distributed, "Client", fail)
        address = client.scheduler.address
        with pytest.raises(SchedulerAddressError, match="cannot connect") as info:
            run_batch([(*images, "p")], tmp_path / "out", scheduler=address, **PARAMS)
        assert address in str(info.value)
        assert not (tmp_path / "out").exists()

    @pytest.mark.parametrize("address", ["inproc://xyz", "ucx://127.0.0.1:1",
                                         "ws://127.0.0.1:1", "wss://127.0.0.1:1"])
    def test_unsupported_schemes(self, hopmatch_main, tmp_path, images, capsys, address):
        with pytest.raises(SchedulerAddressError, match="expected tcp:// or tls://"):
            check_scheduler(address)
        (tmp_path / "p.csv").write_text(f"left,right\n{images[0]},{images[1]}\n")
        status = hopmatch_main(["batch", str(tmp_path / "p.csv"), "--out",
                                str(tmp_path / "out"), "--scheduler", address])
        assert status == 2 and "--scheduler" in capsys.readouterr().err


# -- finding 11: the client, and contradictory choices --------------------------------------


class TestClient:
    @pytest.mark.parametrize("value", [5, "tcp://127.0.0.1:1", object()])
    def test_client_must_be_a_client(self, no_cluster, tmp_path, images, value):
        with pytest.raises(InvalidTypeError) as info:
            match_pairs([images], value, **PARAMS)
        assert info.value.argument == "client"
        with pytest.raises(InvalidTypeError, match="`client`"):
            run_batch([images], tmp_path / "out", client=value, **PARAMS)
        assert not (tmp_path / "out").exists()

    def test_a_closed_client(self, client, tmp_path, images):
        closed = distributed.Client(client.scheduler.address, timeout=TIMEOUT)
        closed.close()
        with pytest.raises(InvalidArgumentError, match="running") as info:
            match_pairs([images], closed, **PARAMS)
        assert info.value.argument == "client"
        with pytest.raises(InvalidArgumentError, match="running"):
            run_batch([images], tmp_path / "out", client=closed, **PARAMS)
        assert not (tmp_path / "out").exists()

    def test_contradictory_choices(self, client, tmp_path, images):
        cases = [(dict(client=client, scheduler=client.scheduler.address), "scheduler"),
                 (dict(client=client, workers=1), "workers"),
                 (dict(scheduler="tcp://127.0.0.1:1", workers=1), "workers")]
        for kwargs, argument in cases:
            with pytest.raises(InvalidArgumentError) as info:
                run_batch([images], tmp_path / "out", **kwargs, **PARAMS)
            assert info.value.argument == argument, kwargs
        assert not (tmp_path / "out").exists()


# -- findings 13, 14, 15, 16, 17: pairs, read_pairs, params, progress ----------------------


class TestArguments:
    @pytest.mark.parametrize("pairs", [None, 5, Pair("a", "l.png", "r.png"), {"a": 1}])
    def test_pairs_must_be_a_sequence(self, no_cluster, tmp_path, pairs):
        for call in (lambda: as_pairs(pairs), lambda: match_pairs(pairs, **PARAMS),
                     lambda: run_batch(pairs, tmp_path / "out", **PARAMS)):
            with pytest.raises(InvalidTypeError, match="`pairs` must be a sequence") as info:
                call()
            assert info.value.argument == "pairs"

    @pytest.mark.parametrize("path", [None, 3, b"x.csv"])
    def test_read_pairs_path_type(self, path):
        with pytest.raises(InvalidTypeError, match="`path` must be") as info:
            read_pairs(path)
        assert info.value.argument == "path"

    @pytest.mark.parametrize("params", [None, [1], "x", 5])
    def test_check_params_needs_a_mapping(self, params):
        with pytest.raises(InvalidTypeError, match="`params` must be a mapping") as info:
            hopmatch_dask.check_params(params)
        assert info.value.argument == "params"

    @pytest.mark.parametrize("value", ["12", [12], 1j])
    def test_values_are_checked_before_they_are_formatted(self, value):
        with pytest.raises(InvalidTypeError, match="`max_disparity` must be a number") as info:
            hopmatch_dask.check_params({"rectified": False, "max_disparity": value})
        assert info.value.argument == "max_disparity"
        with pytest.raises(InvalidArgumentError, match="max_disparity=12.5"):
            hopmatch_dask.check_params({"rectified": False, "max_disparity": 12.5})

    def test_progress_must_be_callable(self, no_cluster, tmp_path, images):
        with pytest.raises(InvalidTypeError, match="`progress`") as info:
            run_batch([images], tmp_path / "out", progress=5, **PARAMS)
        assert info.value.argument == "progress"
        assert not (tmp_path / "out").exists()


# -- findings 18, 19: images checked on the client -----------------------------------------


class TestImages:
    @pytest.mark.parametrize("item", [(None, R), (1, 2), (b"a.png", "b.png"), ([[1, 2]], R),
                                      (L, {"x": 1})])
    def test_image_types_are_checked_on_the_client(self, no_cluster, tmp_path, item):
        with pytest.raises(InvalidTypeError, match=r"`pairs\[0\]`: the (left|right) image") \
                as info:
            match_pairs([item], **PARAMS)  # a lazy bag: refused now, not at compute time
        assert info.value.argument == "pairs"
        with pytest.raises(InvalidTypeError):
            run_batch([item], tmp_path / "out", **PARAMS)
        assert not (tmp_path / "out").exists()

    def test_huge_arrays_are_refused_before_they_are_sent(self, no_cluster, tmp_path,
                                                          monkeypatch):
        huge = np.broadcast_to(np.uint8(7), (60000, 60000))  # 3.6 GB if serialised
        with pytest.raises(BudgetExceededError, match=r"`pairs\[1\]` \('big'\)") as info:
            match_pairs([(L, R), (L, huge, "big")], **PARAMS)
        assert info.value.argument == "pairs"
        with pytest.raises(BudgetExceededError, match="max_pixels=50000000"):
            run_batch([(huge, R, "big")], tmp_path / "out", **PARAMS)
        with pytest.raises(BudgetExceededError, match="max_pixels=1000"):
            match_pairs([(L, R)], max_pixels=1000, **PARAMS)
        assert not (tmp_path / "out").exists()

    def test_huge_arrays_are_not_submitted(self, client, monkeypatch):
        monkeypatch.setattr(client, "submit", lambda *a, **k: pytest.fail("submitted"))
        huge = np.broadcast_to(np.uint8(7), (60000, 60000))
        with pytest.raises(BudgetExceededError):
            match_pairs([(huge, huge)], client, **PARAMS)


# -- finding 20 -----------------------------------------------------------------------------


class TestMinor:
    @pytest.mark.parametrize("expected", ["1", 1.0, True])
    def test_complete_rows_checks_expected(self, tmp_path, expected):
        path = tmp_path / "p.csv"
        path.write_text(matches_table([[10, 5]], [[4, 5]], [6], [0.25]))
        assert complete_rows(path, 1) == 1 and complete_rows(path, 2) is None
        with pytest.raises(InvalidTypeError, match="`expected`") as info:
            complete_rows(path, expected)
        assert info.value.argument == "expected"

    def test_local_cluster_env(self, monkeypatch):
        seen = {}
        monkeypatch.setattr(distributed, "LocalCluster", lambda **kw: seen.update(kw))
        hopmatch_dask.local_cluster(1, env=None)
        assert seen["env"] == {"OPENCV_FOR_THREADS_NUM": "1"} and seen["n_workers"] == 1
        hopmatch_dask.local_cluster(1, env={"A": "b"})
        assert seen["env"] == {"OPENCV_FOR_THREADS_NUM": "1", "A": "b"}
        with pytest.raises(InvalidTypeError, match="`env`"):
            hopmatch_dask.local_cluster(1, env=5)

    def test_local_cluster_options(self, no_cluster):
        """Options of LocalCluster, of the Nanny and Worker it starts and of their Server
        pass; a misspelled one is refused before any process starts (distributed only
        failed in each worker: "Nanny failed to start")."""
        from distributed.core import Server
        from distributed.deploy.local import LocalCluster
        from distributed.nanny import Nanny
        from distributed.worker import Worker

        options = {"n_workers": 1, "memory_limit": "1GB", "lifetime": "1h",
                   "connection_limit": 10, "silence_logs": 40}
        for key, cls in (("n_workers", LocalCluster), ("memory_limit", Nanny),
                         ("lifetime", Worker), ("connection_limit", Server)):
            assert key in inspect.signature(cls.__init__).parameters
        assert hopmatch_dask.checks.check_cluster_options(options) == options
        with pytest.raises(InvalidTypeError, match="did you mean 'n_workers'") as info:
            hopmatch_dask.local_cluster(1, n_wokers=2)
        assert info.value.argument == "n_wokers" and "`n_wokers`" in str(info.value)

        class Custom(Worker):  # a worker class of its own: its options too
            def __init__(self, *args, colour="red", **kwargs):
                super().__init__(*args, **kwargs)

        class Strict(Worker):
            def __init__(self, scheduler_ip=None, *, colour="red"):
                super().__init__(scheduler_ip)

        assert hopmatch_dask.checks.check_cluster_options(
            {"worker_class": Custom, "anything": 1}) == {"worker_class": Custom,
                                                          "anything": 1}
        assert hopmatch_dask.checks.check_cluster_options({"worker_class": Strict,
                                                           "colour": "blue"})
        with pytest.raises(InvalidTypeError, match="`colur`"):
            hopmatch_dask.checks.check_cluster_options({"worker_class": Strict,
                                                        "colur": "blue"})
