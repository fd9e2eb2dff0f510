"""hopmatch._validate at the extremes (issue 20): integers beyond int64, fundamental matrices
of any scale, the pixel-budget hint, the denormal alpha of the Deriche border."""

from __future__ import annotations

import numpy as np
import pytest

import hopmatch
from hopmatch._validate import (
    F_NORM_RANGE,
    INT64_MAX,
    as_fundamental_matrix,
    as_int,
    check_pixel_budget,
)
from hopmatch.errors import BudgetExceededError, InvalidArgumentError

F_RECT = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)


@pytest.mark.parametrize("value", [2**63, 10**30, -(2**63) - 1, 2**64])
def test_integers_beyond_int64_are_refused_by_name(value):
    with pytest.raises(InvalidArgumentError, match=f"`seed` must be in .* got {value}"):
        as_int(value, "seed")
    assert as_int(INT64_MAX, "seed") == INT64_MAX


@pytest.mark.parametrize("scale", [1e-320, 1e-200, 1e-30, 1e-3, 1.0, 1e3, 1e30, 1e200, 1e300])
def test_fundamental_matrix_of_any_scale(scale):
    f = as_fundamental_matrix(F_RECT * scale)
    norm = np.linalg.norm(f)
    if F_NORM_RANGE[0] <= np.linalg.norm(F_RECT * scale) <= F_NORM_RANGE[1]:
        assert np.array_equal(f, F_RECT * scale)  # used as given: results bit-identical
    else:
        assert 0.5 <= norm < 1.0
        ratio = f[1, 2] / (F_RECT * scale)[1, 2]
        assert ratio == 2.0 ** np.round(np.log2(ratio))  # a power of two: exact


def test_fundamental_matrix_scale_does_not_change_matches():
    """F * 1e-200 underflowed every epipolar line to length 0 (no candidate), F * 1e200
    overflowed them (every point on every line): both now match as F does."""
    rng = np.random.default_rng(0)
    pts = rng.uniform(20, 120, (150, 2)).astype(np.float32)
    desc = rng.normal(size=(150, 25)).astype(np.float32)
    want = hopmatch.hopfield_match(pts, pts - [6, 0], desc, desc, max_disparity=16,
                                   fundamental_matrix=F_RECT)
    assert len(want.query_idx) > 50
    for scale in (1e-200, 1e-320, 1e200, 2.0**-60):
        got = hopmatch.hopfield_match(pts, pts - [6, 0], desc, desc, max_disparity=16,
                                      fundamental_matrix=F_RECT * scale)
        assert np.array_equal(got.query_idx, want.query_idx)
        assert np.array_equal(got.train_idx, want.train_idx)
        assert np.array_equal(got.distances, want.distances)


def test_pixel_budget_hint_reads_well_in_python_and_on_the_command_line():
    with pytest.raises(BudgetExceededError) as exc:
        check_pixel_budget((30000, 30000), 50_000_000)
    message = str(exc.value)
    assert "raise the limit to max_pixels=900000000 or more" in message
    assert "create(" not in message  # the CLI turned it into create(--max-pixels=...)


@pytest.mark.parametrize("alpha", [5e-324, 1e-310])
def test_denormal_alpha_is_the_deriche_error_not_an_overflow(alpha):
    from hopmatch.feature.gradient import border_width

    assert border_width(alpha) == 256 and border_width(1.0) == 14
    img = np.random.default_rng(0).integers(0, 255, (40, 40), dtype=np.uint8)
    with pytest.raises(InvalidArgumentError, match="alpha"):
        hopmatch.DericheMoravecDetector(alpha=alpha).detect(img)
