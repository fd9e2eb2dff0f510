"""JPEG's 8 x 8 block grid: where it is the only texture, no point is detected.

A JPEG image is coded in blocks of 8 x 8 pixels, quantised apart: every block boundary
carries a small step in grey level. Where a scene has texture those steps are lost in it;
where it has little (a wall, a low-texture Middlebury 2006 scene) the grid of steps is the
strongest structure left, and the Moravec points of its gradient sit on it. The grid lies at
the same image positions in both views of a pair, so such points match each other at a
disparity that is a multiple of 8 whatever the scene's: with both images of
``middlebury2006/midd2`` saved at JPEG quality 75, 198 of the 210 wrong matches found without
this guard had a disparity within 0.5 px of 8, 16, 24... px, and precision fell from 0.974
to 0.799 (docs/robustness.md, "JPEG, noise and blur").

:func:`block_grid` finds the grid (the column and row phases at which horizontal and
vertical grey-level steps are largest, when clearly larger than at the other seven
phases); :func:`grid_dominated` marks the pixels around which the steps across the grid's
lines are :data:`DOMINANCE` times those elsewhere (the window's texture is the grid's);
:func:`block_artifact_mask` combines the two into the mask of where points may be
detected (``DericheMoravecDetector(jpeg_guard=True)``, the default; docs/method.md).
"""

from __future__ import annotations

import cv2
import numpy as np

from .gradient import normalised_intensity

#: JPEG's block side (px).
BLOCK = 8
#: An image has a block grid when, along both axes, the mean grey-level step between the
#: columns (rows) of one phase modulo :data:`BLOCK` is at least GATE times the mean over
#: the other seven phases (docs/robustness.md, "JPEG, noise and blur", says which shared
#: images reach it).
GATE = 1.10
#: A pixel's neighbourhood is the grid's when the mean step across the grid's lines there
#: is more than DOMINANCE times the mean step between the other pixel pairs plus FLOOR
#: (grey levels of the image scaled to :data:`~hopmatch.feature.gradient.INTENSITY_RANGE`);
#: both chosen on the shared scenes saved as JPEGs (docs/robustness.md).
DOMINANCE = 4.0
FLOOR = 0.5
#: Side of that neighbourhood (px): two blocks and a pixel, so that it always spans two
#: lines of the grid in each direction.
REACH = 2 * BLOCK + 1
#: The grid is measured on every STRIDE-th row (for the column steps) and column (for the
#: row steps).
STRIDE = 4


def phase_steps(gray: np.ndarray, axis: int) -> np.ndarray:
    """``(BLOCK,)`` float64: the mean absolute grey-level step between neighbours along
    ``axis`` (1: between columns ``x`` and ``x + 1``, grouped by ``x % BLOCK``; 0: rows),
    on every :data:`STRIDE`-th line across it."""
    lines = gray[::STRIDE] if axis == 1 else gray[:, ::STRIDE]
    with np.errstate(over="ignore", invalid="ignore"):  # inf or NaN past float64: no grid
        steps = np.abs(np.diff(lines.astype(np.float64), axis=axis))
        profile = steps.mean(axis=1 - axis)
        return np.array([profile[p::BLOCK].mean() for p in range(BLOCK)])


def block_grid(gray: np.ndarray) -> tuple[int, int] | None:
    """``(column phase, row phase)`` of a JPEG block grid in the grey image ``gray``, or
    None when it has none: phase ``p`` along an axis means steps between pixels ``p`` and
    ``p + 1`` modulo :data:`BLOCK` (7 for a JPEG that was not cropped). The grid is there
    when, along both axes (JPEG's blocks are squares), one phase's mean step is at least
    :data:`GATE` times the mean of the other seven's."""
    h, w = gray.shape[:2]
    if min(h, w) < 2 * BLOCK + 1:
        return None
    phases = []
    for axis in (1, 0):
        steps = phase_steps(gray, axis)
        if not np.isfinite(steps).all():
            return None
        p = int(np.argmax(steps))
        rest = (steps.sum() - steps[p]) / (BLOCK - 1)
        if not (rest > 0.0 and steps[p] >= GATE * rest):
            return None
        phases.append(p)
    return phases[0], phases[1]


def _box(a: np.ndarray) -> np.ndarray:
    """Sums of ``a`` over the :data:`REACH`-square around each pixel, mirrored at the
    border (``cv2.BORDER_REFLECT``)."""
    return cv2.boxFilter(a, -1, (REACH, REACH), normalize=False,
                         borderType=cv2.BORDER_REFLECT)


def _step_counts(n: int, phase: int) -> tuple[np.ndarray, np.ndarray]:
    """``(on, off)``, each ``(n,)`` float32: how many of the :data:`REACH` indices around
    each index along an axis of ``n`` pixels (mirrored as ``cv2.BORDER_REFLECT``) start a
    step across the grid (``i % BLOCK == phase``, ``i < n - 1``) and how many start
    another step (``i < n - 1``)."""
    on = np.zeros((1, n), np.float32)
    on[0, phase:n - 1:BLOCK] = 1.0
    steps = np.zeros((1, n), np.float32)
    steps[0, :n - 1] = 1.0
    sums = [cv2.boxFilter(a, -1, (REACH, 1), normalize=False,
                          borderType=cv2.BORDER_REFLECT)[0] for a in (on, steps)]
    return sums[0], sums[1] - sums[0]


def grid_dominated(gray: np.ndarray, phases: tuple[int, int]) -> np.ndarray:
    """``(H, W)`` bool: where the mean absolute step across the grid's lines (columns
    ``x`` with ``x % BLOCK == phases[0]`` stepping to ``x + 1``, rows likewise with
    ``phases[1]``) within the :data:`REACH`-square around a pixel exceeds
    :data:`DOMINANCE` times the mean step between the square's other neighbouring pixels,
    plus :data:`FLOOR` (grey levels of
    :func:`~hopmatch.feature.gradient.normalised_intensity`). At most five float32 images at
    once (20 bytes per pixel; the detector's own peak is larger)."""
    h, w = gray.shape
    img = normalised_intensity(gray)
    # the steps to the right and down (0 past the last column and row), all of them and
    # those across the grid's lines; box sums are linear, so two of them do
    right = np.zeros((h, w), np.float32)
    right[:, :-1] = cv2.absdiff(img[:, 1:], img[:, :-1])
    down = np.zeros((h, w), np.float32)
    down[:-1, :] = cv2.absdiff(img[1:, :], img[:-1, :])
    del img
    on_cols = np.zeros(w, np.float32)
    on_cols[phases[0]::BLOCK] = 1.0
    on_rows = np.zeros(h, np.float32)
    on_rows[phases[1]::BLOCK] = 1.0
    every = _box(right + down)
    right *= on_cols[None, :]
    down *= on_rows[:, None]
    right += down
    del down
    grid_sum = _box(right)
    del right
    every -= grid_sum  # the other steps' sum
    on_x, off_x = _step_counts(w, phases[0])
    on_y, off_y = _step_counts(h, phases[1])
    # each of the square's REACH rows (columns) holds the same steps along x (y): it holds
    # REACH * n_grid steps across the grid's lines and REACH * n_other others, and
    # grid / n_grid > DOMINANCE * other / n_other + FLOOR * REACH, multiplied out:
    n_grid = np.maximum(np.add.outer(on_y, on_x), np.float32(1.0 / REACH))
    n_other = np.maximum(np.add.outer(off_y, off_x), np.float32(1.0 / REACH))
    grid_sum *= n_other
    every *= n_grid
    every *= np.float32(DOMINANCE)
    n_grid *= n_other
    n_grid *= np.float32(FLOOR * REACH)
    every += n_grid
    return grid_sum > every


def block_artifact_mask(gray: np.ndarray) -> np.ndarray | None:
    """Where points may be detected in the grey image ``gray`` (``(H, W)`` bool, False
    where :func:`grid_dominated`), or None when it has no block grid (:func:`block_grid`)
    or the grid dominates nowhere."""
    phases = block_grid(gray)
    if phases is None:
        return None
    dominated = grid_dominated(gray, phases)
    return ~dominated if dominated.any() else None
