"""The float32 Canny-Deriche kernel (``hopmatch._kernels.deriche``, SPEC section 1, item 1)
against OpenCV's recursions written out in ``tests/naive.py`` and against
``cv2.ximgproc.GradientDericheX/Y`` itself. Small images: this file also runs with
``NUMBA_DISABLE_JIT=1``."""

from __future__ import annotations

import cv2
import naive
import numpy as np
import pytest

from hopmatch._kernels import deriche as _kd
from hopmatch.feature.gradient import deriche_components

#: max |ours - reference| / max |reference| allowed (issue 17); measured about 1e-6 and less
TOLERANCE = 1e-4
PARAMETERS = [(1.0, 0.001), (0.5, 0.3), (3.0, 1e-4), (2.0, 1.0), (0.3, 0.01)]


def _relative(got, want):
    return float(np.abs(got.astype(np.float64) - want).max() / max(np.abs(want).max(), 1e-30))


def test_coefficients_are_opencvs():
    for alpha, omega in PARAMETERS:
        np.testing.assert_allclose(_kd.coefficients(alpha, omega),
                                   naive.deriche_coefficients(alpha, omega), rtol=1e-15)


@pytest.mark.parametrize("alpha, omega", PARAMETERS)
@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (5, 1), (2, 2), (3, 5), (7, 4), (12, 9)])
@pytest.mark.parametrize("border", [0, 2, 9])
def test_components_equal_the_recursions_written_out(shape, alpha, omega, border):
    """No mirror (border 0) shows OpenCV's start-up values: they differ between its row and
    column filters, and a kernel that got one wrong is off by tens of grey levels here."""
    rng = np.random.default_rng(shape[0] * 31 + shape[1] + border)
    img = rng.uniform(0, 255, shape).astype(np.float32)
    gx0, gy0 = naive.deriche_padded_xy(img, alpha, omega, border)
    g, gx, gy = deriche_components(img, alpha, omega, components=True, border=border)
    assert g.dtype == gx.dtype == gy.dtype == np.float32 and g.shape == shape
    if shape == (1, 1) and border == 0:  # a single sample: both derivatives are 0
        assert float(gx[0, 0]) == pytest.approx(0, abs=1e-3)
        assert float(gy[0, 0]) == pytest.approx(0, abs=1e-3)
        return
    scale = max(np.abs(gx0).max(), np.abs(gy0).max())
    assert np.abs(gx - gx0).max() <= TOLERANCE * scale
    assert np.abs(gy - gy0).max() <= TOLERANCE * scale
    assert np.abs(g - np.hypot(gx0, gy0)).max() <= TOLERANCE * scale


@pytest.mark.parametrize("alpha, omega", PARAMETERS)
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_components_equal_opencv(alpha, omega, dtype):
    rng = np.random.default_rng(1)
    img = rng.uniform(0, 250, (17, 23)).astype(dtype)
    for border in (0, 4):
        padded = cv2.copyMakeBorder(img, border, border, border, border, cv2.BORDER_REFLECT)
        gx0 = cv2.ximgproc.GradientDericheX(padded, alpha, omega)
        gy0 = cv2.ximgproc.GradientDericheY(padded, alpha, omega)
        crop = (slice(border, border + 17), slice(border, border + 23))
        g, gx, gy = deriche_components(img, alpha, omega, components=True, border=border)
        assert _relative(gx, gx0[crop]) <= TOLERANCE
        assert _relative(gy, gy0[crop]) <= TOLERANCE
        assert _relative(g, cv2.magnitude(gx0, gy0)[crop]) <= TOLERANCE


def test_a_constant_image_gives_opencvs_border_response():
    """float32 filters ``image - offset`` and adds the constant's exact response back: a
    flat image still gives OpenCV's small start-up edges (its own max |G| is the scale)."""
    img = np.full((9, 11), 200.0, np.float32)
    gx0, gy0 = naive.deriche_padded_xy(img, 1.0, 0.001, 0)
    g, gx, gy = deriche_components(img, 1.0, 0.001, components=True, border=0)
    assert np.abs(gx0).max() > 1
    assert _relative(gx, gx0) <= TOLERANCE and _relative(gy, gy0) <= TOLERANCE
    gx0, gy0 = naive.deriche_padded_xy(img, 1.0, 0.001, 14)
    g, gx, gy = deriche_components(img, 1.0, 0.001, components=True, border=14)
    assert _relative(g, np.hypot(gx0, gy0)) <= TOLERANCE


def test_subnormal_decay_is_flushed_and_nan_kept():
    """A long flat run after an edge decays the recursions' states into subnormal numbers,
    which the kernel flushes to 0 (many times faster); NaN coefficients stay NaN, so that
    extreme parameters are still seen (``check_finite_gradient``)."""
    img = np.zeros((400, 4), np.float32)  # the pass runs down axis 0
    img[:3] = 255
    none = np.empty((0, 0), np.float32)
    out_d, out_s = np.empty_like(img), np.empty_like(img)

    def run(coeffs):
        _kd.deriche_pass(img, img, 0, coeffs, True, np.float32(0), out_d, out_s,
                         np.empty((2, 400)), none, np.float32(0), none)

    run(_kd.coefficients(1.0, 0.001))
    for out in (out_d, out_s):
        assert np.all((out == 0) | (np.abs(out) >= np.finfo(np.float32).tiny))
        assert (out[150:] == 0).all() and np.abs(out[:3]).max() > 1
    coeffs = _kd.coefficients(1.0, 0.001)
    coeffs[1] = np.nan
    run(coeffs)
    assert np.isnan(out_d[1:]).all() and np.isnan(out_s[1:]).all()
