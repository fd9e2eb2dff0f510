"""What each part of the sub-pixel refinement brings: the median |disparity error| of the
correct matches on the float ground truth (issue 21), refinement variant by variant.

Run: ``python benchmarks/refine_stages.py [--scenes NAME ...] [--timing N] [--smoke]``

For each scene (default: motorcycle and the three ``middlebury2014/`` scenes, with
``../shared/data`` or ``HOPMATCH_SHARED_DATA``), ``match_stereo``'s defaults are run once
and the inputs of their refinement recorded (grey images, left points, starting right x,
right rows: network and guided matches). Each variant then refines the same inputs:
``first stage only`` (``slanted=False``: the 7 x 7 square, uniform, linear windows), the
defaults (both stages), and the defaults with one part of the second stage changed back
(``hopmatch.matching.refine``'s module constants, set for the row and restored). A match is
correct within 1 px (``passes.score``, ground truth bilinear at the sub-pixel left point).

It also prints, per scene, the median after removing from the errors the least-squares plane
``e = a + b x + c y`` over the correct matches: a diagnostic that separates the refinement's
own scatter from an image-wide trend of the error (the last line: how much that plane
changes across the image width; on Teddy about 0.3 px, which no local estimate can see),
never a figure to tune on. ``--timing N``: also, per scene, the best of N interleaved runs
(single thread) of the refinement with the first stage only and with both, and of
``match_stereo`` with the second stage off (``SLANT_PASSES = 0``) and on. ``--smoke``: the
built-in motorcycle on a centre crop.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import (  # noqa: E402
    add_smoke_option,
    best_times_interleaved,
    single_thread,
    smoke_scene,
)
from passes import bilinear_gt, score  # noqa: E402

import hopmatch  # noqa: E402
import hopmatch.matching.refine as refine_mod  # noqa: E402
import hopmatch.matching.stereo_match as stereo_mod  # noqa: E402
from hopmatch import datasets  # noqa: E402

SCENES = ["motorcycle", "middlebury2014/ArtL", "middlebury2014/MotorcycleE",
          "middlebury2014/Teddy"]

#: ``(row label, slanted, module constants of hopmatch.matching.refine set for the row)``.
VARIANTS = [
    ("first stage only (7x7 square, linear)", False, {}),
    ("defaults (both stages)", True, {}),
    ("second stage with square windows", True, {"SLANT_GRADIENT_LIMIT": 0.0}),
    ("second stage with uniform weights", True, {"SLANT_SIGMA": 0.0}),
    ("second stage with cubic interpolation", True, {"SLANT_CUBIC": True}),
    ("second stage with 7x7 windows", True, {"SLANT_RADIUS": 3}),
    ("second stage twice", True, {"SLANT_PASSES": 2}),
    ("second stage, step 0.5 two levels", True, {"SLANT_STEP": 0.5, "SLANT_LEVELS": 2}),
    ("second stage, planes in 21x21", True, {"SLANT_HALF_WINDOW": 10.0}),
    ("second stage, planes in 41x41", True, {"SLANT_HALF_WINDOW": 20.0}),
    ("second stage, sigma 2", True, {"SLANT_SIGMA": 2.0}),
    ("second stage, 9x9 sigma 2.5", True, {"SLANT_RADIUS": 4, "SLANT_SIGMA": 2.5}),
    ("second stage, tolerance 0.02 px", True, {"SLANT_TOL": 0.02}),
    ("second stage, tolerance 0.05 px", True, {"SLANT_TOL": 0.05}),
    ("second stage, 13x13 sigma 3.5", True, {"SLANT_RADIUS": 6, "SLANT_SIGMA": 3.5}),
]


def refinement_inputs(scene):
    """``(gray_l, gray_r, left, xr, yr)`` that ``match_stereo``'s defaults refine."""
    seen = {}
    original = stereo_mod.refine_disparities

    def record(gray_l, gray_r, left, xr, yr, **kw):
        seen["args"] = (gray_l, gray_r, np.array(left), np.array(xr), np.array(yr))
        return original(gray_l, gray_r, left, xr, yr, **kw)

    stereo_mod.refine_disparities = record
    try:
        hopmatch.match_stereo(scene.left, scene.right)
    finally:
        stereo_mod.refine_disparities = original
    return seen.get("args")


def errors(left, x, yr, disparity):
    """``(median |error|, detrended median, correct, drift)`` of refined right points;
    drift: the change of the errors' plane across the image width, in px."""
    right = np.c_[x, yr].astype(np.float32)
    _, correct, _, med = score(left, right, disparity)
    err = (left[:, 0].astype(np.float64) - x) - bilinear_gt(left, disparity)
    good = np.isfinite(err) & (np.abs(err) <= 1.0) & (np.abs(left[:, 1] - yr) <= 1.0)
    if good.sum() < 3:
        return med, float("nan"), correct, float("nan")
    a = np.c_[np.ones(good.sum()), left[good].astype(np.float64)]
    coef, *_ = np.linalg.lstsq(a, err[good], rcond=None)
    return (med, float(np.median(np.abs(err[good] - a @ coef))), correct,
            float(coef[1] * disparity.shape[1]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", help="scene names (default: the four of issue 21)")
    ap.add_argument("--timing", type=int, default=0, help="timing rounds (0: no timing)")
    args = add_smoke_option(ap).parse_args(argv)
    single_thread()
    names = ["motorcycle"] if args.smoke else (args.scenes or SCENES)
    inputs, scenes = {}, {}
    for n in names:
        scene = datasets.load(n)
        if args.smoke:
            scene = smoke_scene(scene)
        got = refinement_inputs(scene)
        if got is not None:
            inputs[n] = (got, scene.disparity)
            scenes[n] = scene
    print("median |disparity error| of the correct matches (px), per scene; correct matches "
          "in all")
    print("| variant | " + " | ".join(inputs) + " | correct |")
    print("|---|" + "---:|" * (len(inputs) + 1))
    detrended, drift = {}, {}
    for label, slanted, consts in VARIANTS:
        saved = {k: getattr(refine_mod, k) for k in consts}
        for k, v in consts.items():
            setattr(refine_mod, k, v)
        try:
            cells, total = [], 0
            for n, ((gl, gr, left, xr, yr), disparity) in inputs.items():
                ref = refine_mod.refine_disparities(gl, gr, left, xr, yr, slanted=slanted)
                med, det, correct, dx = errors(left, ref.x, yr, disparity)
                drift.setdefault(label, []).append(f"{dx:+.3f}")
                cells.append(f"{med:.3f}")
                total += correct
                detrended.setdefault(label, []).append(f"{det:.3f}")
        finally:
            for k, v in saved.items():
                setattr(refine_mod, k, v)
        print(f"| {label} | " + " | ".join(cells) + f" | {total} |", flush=True)
    print()
    print("detrended median (errors minus their least-squares plane in x, y; diagnostic)")
    print("| variant | " + " | ".join(inputs) + " |")
    print("|---|" + "---:|" * len(inputs))
    for label, cells in detrended.items():
        print(f"| {label} | " + " | ".join(cells) + " |")
    print()
    label = VARIANTS[1][0]
    print(f"drift of the errors' plane across the image width (px), {label}: "
          + ", ".join(f"{n} {d}" for n, d in zip(inputs, drift[label])))
    if args.timing > 0:
        print_timing(inputs, scenes, args.timing)
    return 0


def print_timing(inputs, scenes, rounds: int) -> None:
    """The ``--timing`` table: best of ``rounds`` interleaved runs, in ms."""

    def stereo(scene, passes):
        def run():
            saved = refine_mod.SLANT_PASSES
            refine_mod.SLANT_PASSES = passes
            try:
                hopmatch.match_stereo(scene.left, scene.right)
            finally:
                refine_mod.SLANT_PASSES = saved
        return run

    print()
    print(f"ms, best of {rounds} interleaved runs, one thread")
    print("| scene | matches | refinement, first stage | refinement, both | match_stereo, "
          "first stage | match_stereo, both |")
    print("|---|---:|---:|---:|---:|---:|")
    for n, ((gl, gr, left, xr, yr), _) in inputs.items():
        fns = {
            "r1": lambda: refine_mod.refine_disparities(gl, gr, left, xr, yr, slanted=False),
            "r2": lambda: refine_mod.refine_disparities(gl, gr, left, xr, yr),
            "s1": stereo(scenes[n], 0),
            "s2": stereo(scenes[n], refine_mod.SLANT_PASSES),
        }
        t = best_times_interleaved(fns, repeat=rounds)
        print(f"| {n} | {len(xr)} | " + " | ".join(f"{1000 * t[k]:.0f}" for k in fns) + " |",
              flush=True)


if __name__ == "__main__":
    sys.exit(main())
