"""The similarity kernels (``hopmatch._kernels.similarity``, eqs. 7-9) against direct NumPy
sums and the references of ``tests/naive.py``."""

from __future__ import annotations

import naive
import numpy as np
import pytest
from network_problems import make_problem

from hopmatch._kernels import similarity as _k
from hopmatch.errors import BudgetExceededError
from hopmatch.matching.network import candidate_pairs, shift_minimal, similarity_distance


class TestSimilarity:
    def test_normalised_difference(self):
        rng = np.random.default_rng(0)
        a = rng.normal(size=(20, 25)).astype(np.float32)
        b = rng.normal(size=(30, 25)).astype(np.float32)
        ni = rng.integers(0, 20, 200).astype(np.int32)
        nk = rng.integers(0, 30, 200).astype(np.int32)
        sa, sb = _k.row_mean_abs(a), _k.row_mean_abs(b)
        assert np.allclose(sa, np.abs(a.astype(np.float64)).mean(axis=1), rtol=1e-12)
        got = _k.normalised_difference(a, b, ni, nk, sa, sb, 1e-6, np.inf, 1.0)
        m = np.abs(a[ni].astype(np.float64) - b[nk]).mean(axis=1)
        want = m / (0.5 * (sa[ni] + sb[nk]) + 1e-6)
        assert got.dtype == np.float64
        assert np.allclose(got, want, rtol=1e-12, atol=0)

    @pytest.mark.parametrize("tol", [1.0, 1.1, 1.5])
    def test_gain_tolerance_equals_reference(self, tol):
        """Eq. 7 with the right window scaled by the contrast ratio clipped to [1/t, t]
        (tests/naive.py), and a right window at a gain within t of the left compares as
        equal: distance 0 up to rounding."""
        rng = np.random.default_rng(7)
        a = rng.normal(size=(20, 25)).astype(np.float32)
        b = np.concatenate([a * np.float32(g) for g in (0.5, 0.95, 1.0, 1.08, 1.3, 3.0)]
                           + [rng.normal(size=(20, 25)).astype(np.float32)])
        ni = np.repeat(np.arange(20, dtype=np.int32), 7)
        nk = (ni + 20 * np.tile(np.arange(7, dtype=np.int32), 20)).astype(np.int32)
        got = similarity_distance(a, b, ni, nk, gain_tolerance=tol)
        want = [naive.similarity(a[i], b[k], gain_tolerance=tol) for i, k in zip(ni, nk)]
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
        gains = np.tile([0.5, 0.95, 1.0, 1.08, 1.3, 3.0, np.nan], 20)
        inside = np.abs(np.log(gains)) <= np.log(tol) + 1e-9
        assert (got[inside] < 1e-5).all()
        assert (got[~inside & np.isfinite(gains)] > 0.01).all()

    @pytest.mark.parametrize("gate, tol", [(0.0, 1.0), (0.3, 1.0), (0.9, 1.0), (1.1, 1.0),
                                           (0.05, 1.1), (0.3, 1.1), (0.3, 2.0)])
    def test_gate_keeps_exactly_the_pairs_within_it(self, gate, tol):
        rng = np.random.default_rng(4)
        a = rng.normal(size=(30, 81)).astype(np.float32)
        b = np.concatenate([a + rng.normal(scale=s, size=a.shape).astype(np.float32)
                            for s in (0.0, 0.2, 0.5, 2.0)])
        b[::7] *= 3.0                                   # contrast changes: the lower bound
        ni = np.repeat(np.arange(30, dtype=np.int32), 40)
        nk = rng.integers(0, len(b), len(ni)).astype(np.int32)
        full = similarity_distance(a, b, ni, nk, gain_tolerance=tol)
        gated = similarity_distance(a, b, ni, nk, gate, gain_tolerance=tol)
        within = full <= gate
        assert 0 < within.sum() < len(ni) or gate == 0.0
        assert np.array_equal(gated[within], full[within])   # exact, not approximate
        assert (gated[~within] > gate).all()
        assert np.isinf(gated[~within]).any()                    # some skipped by the bound

    @pytest.mark.parametrize("gate, tol", [(0.0, 1.0), (0.3, 1.0), (0.9, 1.0), (np.inf, 1.0),
                                           (0.3, 1.1), (0.9, 1.5)])
    def test_band_leaves_out_exactly_the_pairs_the_contrast_bound_rejects(self, gate, tol):
        """``contrast_gate`` drops, before they are written, the band pairs whose contrasts
        alone put them past the gate: what is left is every pair whose similarity can be
        within the gate, and the budget still counts the whole band."""
        from hopmatch.matching.network import window_contrasts

        left, right, dl, dr = make_problem(6, 80, 90)
        dr[::5] *= 3.0  # contrast changes
        contrasts = window_contrasts(dl, dr)
        ni, nk = candidate_pairs(left, right, 0.0, 20.0, 2.0, 10**6)
        gi, gk = candidate_pairs(left, right, 0.0, 20.0, 2.0, 10**6,
                                 contrast_gate=(contrasts, gate), gain_tolerance=tol)
        sim = similarity_distance(dl, dr, ni, nk, gate, gain_tolerance=tol)
        plain = set(zip(ni.tolist(), nk.tolist()))
        kept = set(zip(gi.tolist(), gk.tolist()))
        assert kept <= plain and len(gi) == len(kept)
        assert {pair for pair, v in zip(zip(ni.tolist(), nk.tolist()), sim) if v <= gate} \
            <= kept
        assert kept == {pair for pair, v in zip(zip(ni.tolist(), nk.tolist()), sim)
                        if np.isfinite(v) or gate == np.inf}
        if 0.0 < gate < np.inf:
            assert 0 < len(kept) < len(plain)
        with pytest.raises(BudgetExceededError, match=f"would have {len(ni)} neurons"):
            candidate_pairs(left, right, 0.0, 20.0, 2.0, len(ni) - 1,
                            contrast_gate=(contrasts, gate))

    @pytest.mark.parametrize("size", [3, 5, 9])
    def test_shift_minimal_equals_reference(self, size):
        rng = np.random.default_rng(size)
        g = rng.uniform(0, 50, (40, 60)).astype(np.float32)
        ys, xs = rng.integers(size, 40 - size, 300), rng.integers(size + 1, 60 - size - 1, 300)
        shift = rng.integers(-1, 2, 300)                  # right windows 0 or 1 px off
        from hopmatch.feature import gradient_windows
        a = gradient_windows(g, np.column_stack([xs, ys]).astype(np.float32), size)
        b = gradient_windows(g, np.column_stack([xs + shift, ys]).astype(np.float32), size)
        qi = np.arange(300)
        got = shift_minimal(a, b, qi, qi)
        want = naive.shift_minimal(a, b, qi, qi)
        assert np.array_equal(got, want)
        assert got[shift == 0].all() and not got[shift != 0].all()

    def test_shift_minimal_passes_descriptors_that_are_not_windows(self):
        rng = np.random.default_rng(0)
        sift_like = rng.uniform(0, 1, (20, 128)).astype(np.float32)
        assert shift_minimal(sift_like, sift_like[::-1], np.arange(20), np.arange(20)).all()
        # square rows (9 x 9) that are not zero-mean: only the matched rows are tested, and
        # one that fails, even the last, lets every match pass
        rng = np.random.default_rng(1)
        windows = rng.normal(size=(30, 81)).astype(np.float32)
        windows -= windows.mean(axis=1, keepdims=True)
        shifted = np.roll(windows.reshape(30, 9, 9), 1, axis=2).reshape(30, 81)
        qi = np.arange(10)
        assert not shift_minimal(windows, shifted, qi, qi).all()  # windows: tested
        offset = windows.copy()
        offset[25] += 5.0                                         # a row with a mean
        assert np.array_equal(shift_minimal(offset, shifted, qi, qi),
                              shift_minimal(windows, shifted, qi, qi))  # row 25 unmatched
        last = np.r_[qi, 25]
        assert shift_minimal(offset, np.r_[shifted[:10], shifted[25:26]],
                             last, np.arange(11)).all()

    def test_hamming_fraction(self):
        rng = np.random.default_rng(1)
        a = rng.integers(0, 256, (20, 32)).astype(np.uint8)
        b = rng.integers(0, 256, (30, 32)).astype(np.uint8)
        b[3] = a[4]
        b[5] = ~a[6]
        ni = np.concatenate([[4, 6], rng.integers(0, 20, 200)]).astype(np.int32)
        nk = np.concatenate([[3, 5], rng.integers(0, 30, 200)]).astype(np.int32)
        got = _k.hamming_fraction(a, b, ni, nk)
        want = np.unpackbits(a[ni] ^ b[nk], axis=1).sum(axis=1) / 256.0
        assert np.array_equal(got, want)
        assert got[0] == 0.0 and got[1] == 1.0

    @pytest.mark.parametrize("dtype", [np.float32, np.uint8])
    def test_similarity_distance_equals_reference(self, dtype):
        rng = np.random.default_rng(2)
        if dtype == np.uint8:
            a = rng.integers(0, 256, (10, 16)).astype(np.uint8)
            b = rng.integers(0, 256, (12, 16)).astype(np.uint8)
        else:
            a = rng.normal(size=(10, 16)).astype(np.float32)
            b = rng.normal(size=(12, 16)).astype(np.float32)
        ni = rng.integers(0, 10, 50).astype(np.int32)
        nk = rng.integers(0, 12, 50).astype(np.int32)
        got = similarity_distance(a, b, ni, nk)
        want = [naive.similarity(a[i], b[k]) for i, k in zip(ni, nk)]
        assert np.allclose(got, want, rtol=1e-9)
