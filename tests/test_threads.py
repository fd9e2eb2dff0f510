"""hopmatch's thread setting (hopmatch._threads): the cv2-like API, and results that are
bit-identical for any thread count."""

from __future__ import annotations

from unittest import mock

import numpy as np
import pytest

import hopmatch
from hopmatch._threads import (
    map_chunks,
    map_ranges,
    resolve_threads,
    row_order,
    run_both,
    using_threads,
)
from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.matching import neighbourhood

FIELDS = ("points_left", "points_right", "responses_left", "responses_right", "query_idx",
          "train_idx", "distances", "passes")


@pytest.fixture
def restore_threads():
    yield
    hopmatch.setNumThreads(-1)


def test_set_and_get_num_threads_as_cv2(restore_threads):
    default = hopmatch.getNumThreads()
    assert default >= 1
    hopmatch.setNumThreads(3)
    assert hopmatch.getNumThreads() == 3
    hopmatch.setNumThreads(0)  # OpenCV's 0: sequential
    assert hopmatch.getNumThreads() == 1
    hopmatch.setNumThreads(-1)  # back to every core
    assert hopmatch.getNumThreads() == default
    with pytest.raises(InvalidTypeError, match="nthreads"):
        hopmatch.setNumThreads(2.0)


def test_resolve_threads_names_its_argument(restore_threads):
    hopmatch.setNumThreads(2)
    assert resolve_threads(None) == 2 and resolve_threads(5) == 5
    with pytest.raises(InvalidArgumentError, match="`threads`.*got 0"):
        resolve_threads(0)
    with pytest.raises(InvalidTypeError, match="`threads`"):
        resolve_threads(True)
    with pytest.raises(InvalidArgumentError, match="`threads`"):
        hopmatch.match_stereo(np.zeros((30, 30), np.uint8), np.zeros((30, 30), np.uint8),
                              threads=-2)


def test_map_chunks_equals_one_call():
    rng = np.random.default_rng(0)
    a, b = rng.random(2000), rng.random((2000, 3))

    def fn(x, y):
        return np.sqrt(x) * 3.0, (y * x[:, None]).sum(axis=1)

    for threads in (1, 2, 3, 7):
        for got, want in zip(map_chunks(fn, (a, b), threads), fn(a, b)):
            np.testing.assert_array_equal(got, want)
    with using_threads(4):
        np.testing.assert_array_equal(map_chunks(fn, (a, b))[0], fn(a, b)[0])


def test_map_chunks_in_row_order_equals_one_call():
    rng = np.random.default_rng(1)
    a, y = rng.random(3000), np.r_[rng.uniform(0, 500, 2999), np.nan]
    order = row_order(y)
    assert np.all(np.diff(np.floor(y[order][:-1])) >= 0) and np.isnan(y[order][-1])

    def fn(x, yy):  # the second output: whether fn saw its rows sorted by row
        rows = np.nan_to_num(np.floor(yy), nan=np.inf)
        return np.sqrt(x) * 3.0 + yy, np.r_[True, np.diff(rows) >= 0]

    assert not fn(a, y)[1].all()
    for threads in (1, 2, 3):
        got = map_chunks(fn, (a, y), threads, order=order)
        np.testing.assert_array_equal(got[0], fn(a, y)[0])
        assert got[1].all()


def test_map_ranges_cuts_contiguous_ranges_in_order():
    for n, threads in ((100, 4), (3000, 1), (3000, 2), (3000, 7)):
        parts = map_ranges(lambda lo, hi: (lo, hi), n, threads)
        assert parts[0][0] == 0 and parts[-1][1] == n
        assert all(p[1] == q[0] for p, q in zip(parts, parts[1:]))
        assert len(parts) == max(1, min(threads, n // 256))


@pytest.mark.parametrize("threads", [2, 3])
def test_neighbour_lists_and_planes_are_bit_identical_in_threads(threads):
    from hopmatch._kernels import guided as kg

    rng = np.random.default_rng(2)
    queries = rng.uniform(0, 400, (2000, 2)).astype(np.float32)
    matched = rng.uniform(0, 400, (3000, 2)).astype(np.float32)
    disp = 30 + 0.05 * matched[:, 0] + rng.normal(0, 0.3, 3000)
    h = np.float32(15)
    off, idx = kg.query_neighbours(queries, matched, h, h)
    off_t, idx_t = neighbourhood.query_neighbours(queries, matched, h, h, threads=threads)
    assert off[-1] > 10 * len(queries)
    np.testing.assert_array_equal(off_t, off)
    np.testing.assert_array_equal(idx_t, idx)
    want = kg.neighbour_planes(queries, off, idx, matched, disp, 2.0, 4)
    got = neighbourhood.neighbour_planes(queries, off, idx, matched, disp, 2.0, 4,
                                         threads=threads)
    assert np.count_nonzero(want[1]) > 1000
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)
    # in blocks of queries (local_planes: PLANE_BLOCK at a time), the same planes
    for block in (len(queries), 300, 7):
        with mock.patch.object(neighbourhood, "PLANE_BLOCK", block):
            blocked = neighbourhood.local_planes(queries, matched, h, h, disp, 2.0, 4,
                                                 threads=threads)
        for g, w in zip(blocked, want):
            np.testing.assert_array_equal(g, w)


def test_run_both_keeps_the_sequential_errors():
    def fails(what):
        raise ValueError(what)

    assert run_both(lambda: 1, lambda: 2, 2) == (1, 2)
    with pytest.raises(ValueError, match="first"):
        run_both(lambda: fails("first"), lambda: fails("second"), 2)
    with pytest.raises(ValueError, match="second"):
        run_both(lambda: 1, lambda: fails("second"), 2)


def test_match_stereo_is_bit_identical_for_any_thread_count(motorcycle):
    left, right, _ = motorcycle
    one = hopmatch.match_stereo(left, right, threads=1)
    assert len(one.query_idx) > 1000 and one.refinement is not None
    assert set(np.unique(one.passes)) == {0, 1, 2, 3}  # every pass of both_features' runs
    for threads in (2, 3, 4):  # 4: the two runs of both feature images on two each
        other = hopmatch.match_stereo(left, right, threads=threads)
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(other, name), getattr(one, name), name)
        np.testing.assert_array_equal(other.refinement.x, one.refinement.x)
        assert other.network.energy == one.network.energy


def test_the_matcher_is_bit_identical_for_any_thread_count(motorcycle, restore_threads):
    left, right, _ = motorcycle
    det = hopmatch.DericheMoravecDetector()
    kl, dl = det.detectAndCompute(left, None)
    kr, dr = det.detectAndCompute(right, None)
    out = []
    for threads in (1, 2):
        hopmatch.setNumThreads(threads)
        m = hopmatch.HopfieldMatcher()
        m.setPairInfo(kl, kr, left.shape[1::-1], right.shape[1::-1])
        out.append([(d.queryIdx, d.trainIdx, d.distance) for d in m.match(dl, dr)])
    assert out[0] == out[1] and len(out[0]) > 1000


def test_shift_minimal_is_the_same_in_threads():
    from hopmatch.matching.similarity import shift_minimal

    rng = np.random.default_rng(5)
    dl = rng.normal(size=(1500, 49)).astype(np.float32)
    dr = rng.normal(size=(1500, 49)).astype(np.float32)
    dl -= dl.mean(axis=1, keepdims=True)
    dr -= dr.mean(axis=1, keepdims=True)
    qi, ti = rng.permutation(1500), rng.permutation(1500)
    with using_threads(1):
        one = shift_minimal(dl, dr, qi, ti)
    assert 0 < one.sum() < len(one)
    bad = dr.copy()
    bad[ti[-1]] += 5.0  # one row, in the last range, is no window: every match passes
    for threads in (2, 3):
        with using_threads(threads):
            np.testing.assert_array_equal(shift_minimal(dl, dr, qi, ti), one)
            assert shift_minimal(dl, bad, qi, ti).all()
    with using_threads(1):
        assert shift_minimal(dl, bad, qi, ti).all()


@pytest.mark.parametrize("spread", [500.0, 1e6])
def test_row_order_is_the_stable_sort_of_the_rows(spread):
    """Rows spanning fewer than 2**16 values are sorted as uint16 offsets (radix sort),
    wider spans and NaN as floats: the same permutation either way."""
    rng = np.random.default_rng(6)
    y = rng.uniform(-spread, spread, 5000)
    y[::7] = np.floor(y[::7])  # ties on whole rows
    for ys in (y, np.r_[y, np.nan], y.astype(np.float32)):
        want = np.argsort(np.floor(np.asarray(ys, dtype=np.float64)), kind="stable")
        np.testing.assert_array_equal(row_order(ys), want)
    assert len(row_order(np.zeros(0))) == 0


@pytest.mark.parametrize("threads", [2, 3])
def test_candidate_pairs_are_bit_identical_in_threads(threads):
    """The band search cut into ranges of the left points' visit order: the same pairs in
    the same order, and the same budget refusal, with the same message."""
    from hopmatch.errors import BudgetExceededError
    from hopmatch.matching.candidates import candidate_pairs

    rng = np.random.default_rng(7)
    left = rng.uniform(0, 300, (3000, 2)).astype(np.float32)
    right = (left + rng.normal(0, 0.4, left.shape)).astype(np.float32)
    right[:, 0] -= 20
    contrasts = (rng.uniform(0.5, 2.0, 3000), rng.uniform(0.5, 2.0, 3000))
    for sort in (True, False):
        with using_threads(1):
            want = candidate_pairs(left, right, 0, 40, 1.0, 10**7, sort=sort,
                                   contrast_gate=(contrasts, 0.9))
        with using_threads(threads):
            got = candidate_pairs(left, right, 0, 40, 1.0, 10**7, sort=sort,
                                  contrast_gate=(contrasts, 0.9))
        assert len(want[0]) > 2 * len(left)
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)
    total = len(candidate_pairs(left, right, 0, 40, 1.0, 10**7)[0])
    for budget in (total, total - 1, total // 3):
        outcome = []
        for t in (1, threads):
            with using_threads(t):
                try:
                    outcome.append(len(candidate_pairs(left, right, 0, 40, 1.0, budget)[0]))
                except BudgetExceededError as exc:
                    outcome.append(str(exc))  # its count too: not the thread count's
        if budget >= total:
            assert outcome == [total, total]
        else:
            assert outcome[0] == outcome[1] and "or more" in outcome[0]
