#!/usr/bin/env python
"""Uncalibrated stereo: match, fundamental matrix by RANSAC, rectify, match again.

On Middlebury's Aloe pair (``../shared/data/aloe``, 1282 x 1110, as shipped in OpenCV's
``samples/data``, with ground-truth disparity), read with ``hopmatch.datasets.load("aloe")``:

1. ``hopmatch.match_stereo`` on the pair as it is. ``max_disparity`` is set from the
   scene: 1.1 x the largest ground-truth disparity (211 px, so 232 px); hopmatch's
   default, a quarter of the width (320 px), would also cover it.
2. ``F`` by RANSAC from those matches (``hopmatch.stereo.estimate_fundamental``,
   threshold 1 px); the inlier ratio is printed.
3. ``cv2.stereoRectifyUncalibrated`` + ``warpPerspective``
   (``hopmatch.stereo.rectify_uncalibrated``) with the inliers, then ``match_stereo``
   again on the rectified pair. A projective rectification does not keep disparities: the
   disparity range of the rectified pair is read from the RANSAC inliers mapped through
   the homographies (plus 10 % of the span on each side), not from the ground truth.
4. ``match_stereo(..., fundamental_matrix=F)`` on the pair as it is: the same matcher
   searching along the epipolar lines of ``F`` instead of image rows.

Aloe is already rectified, so every match set is scored against the ground truth with
``hopmatch.evaluate.score_matches`` (disparity within 1 px, vertical offset at most 1 px):
the matches of step 1 and 4 directly, those of step 3 after mapping both points back
through the inverse homographies (matches mapped outside the image are dropped).

Usage::

    python examples/uncalibrated.py [--out DIR]

    --out DIR   where to write uncalibrated_rectified.png (the rectified pair side by
                side with a line every 40 rows; default ./hopmatch-examples)

Checks: RANSAC inlier ratio at least 80 %; each of the three match sets at least 90 %
correct at 1 px. Exit status: 0 when they pass, 1 when one fails (the message says
which), 2 when ``../shared/data`` (or ``$HOPMATCH_SHARED_DATA``) or the aloe scene is
missing.
"""

from __future__ import annotations

import argparse
import os
import sys

import cv2
import numpy as np

import hopmatch
from hopmatch.datasets import load, shared_data_dir
from hopmatch.errors import InvalidArgumentError
from hopmatch.evaluate import score_matches
from hopmatch.stereo import estimate_fundamental, rectify_uncalibrated

SCENE = "aloe"
INLIER_GOAL = 0.80     #: fraction of matches consistent with F (1 px)
PRECISION_GOAL = 0.90  #: fraction of matches within 1 px of the ground truth


def find_scene(name: str):
    """The scene ``name`` of the shared stereo data (``hopmatch.datasets.shared_data_dir``),
    or None after a message saying what is missing."""
    try:
        return load(name, root=shared_data_dir())
    except InvalidArgumentError as exc:
        print(f"uncalibrated: error: {exc}", file=sys.stderr)
        return None


def transform(points, h):
    """``(N, 2)`` points through the homography ``h`` (``cv2.perspectiveTransform``)."""
    if len(points) == 0:
        return np.zeros((0, 2), np.float32)
    pts = np.asarray(points, np.float64).reshape(-1, 1, 2)
    return cv2.perspectiveTransform(pts, h).reshape(-1, 2).astype(np.float32)


def report(label, left, right, disparity):
    """Print and return the precision at 1 px of a match set."""
    s = score_matches(left, right, disparity, thresholds=(1.0,))
    p = s.precision[1.0]
    print(f"{label}: {s.n_matches} matches, {s.n_scored} with ground truth, "
          f"{p:.1%} within 1 px")
    return p


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="hopmatch-examples", help="output folder")
    args = parser.parse_args(argv)

    scene = find_scene(SCENE)
    if scene is None:
        return 2
    os.makedirs(args.out, exist_ok=True)
    gt = scene.disparity
    w, h = scene.image_size
    max_gt = float(np.nanmax(gt))
    max_disparity = 1.1 * max_gt
    print(f"scene: {scene.name}, {w}x{h}, ground truth {np.nanmin(gt):.0f}..{max_gt:.0f} px")
    print(f"max_disparity: {max_disparity:.1f} px (1.1 x the largest ground-truth disparity)")

    # 1. match the pair as it is
    first = hopmatch.match_stereo(scene.left, scene.right, max_disparity=max_disparity)
    p_first = report("first match", first.matched_left, first.matched_right, gt)

    # 2. F by RANSAC
    F, inliers = estimate_fundamental(first.matched_left, first.matched_right,
                                      threshold=1.0)
    inlier_ratio = float(inliers.mean())
    print(f"RANSAC inliers: {inliers.sum()} of {len(inliers)} ({inlier_ratio:.1%})")

    # 3. rectify without calibration and match again
    left_in, right_in = first.matched_left[inliers], first.matched_right[inliers]
    left_r, right_r, H1, H2 = rectify_uncalibrated(scene.left, scene.right, left_in,
                                                   right_in, F)
    rl, rr = transform(left_in, H1), transform(right_in, H2)
    d_in = rl[:, 0] - rr[:, 0]
    margin = 0.1 * float(d_in.max() - d_in.min())
    d_lo, d_hi = float(d_in.min()) - margin, float(d_in.max()) + margin
    print(f"rectified inliers: |dy| median {np.median(np.abs(rl[:, 1] - rr[:, 1])):.2f} px, "
          f"disparity {d_in.min():.1f}..{d_in.max():.1f} px")
    print(f"rectified search range: {d_lo:.1f}..{d_hi:.1f} px")
    second = hopmatch.match_stereo(left_r, right_r, min_disparity=d_lo, max_disparity=d_hi)
    back_l = transform(second.matched_left, np.linalg.inv(H1))
    back_r = transform(second.matched_right, np.linalg.inv(H2))
    inside = ((back_l >= 0).all(axis=1) & (back_l[:, 0] <= w - 1) & (back_l[:, 1] <= h - 1))
    print(f"rectified disparities: median {np.median(second.disparities):.1f} px "
          f"(original pair: median {np.median(first.disparities):.1f} px)")
    p_second = report("re-match on the rectified pair (mapped back)", back_l[inside],
                      back_r[inside], gt)

    # 4. match along the epipolar lines of F on the pair as it is
    third = hopmatch.match_stereo(scene.left, scene.right, fundamental_matrix=F,
                                  max_disparity=max_disparity)
    p_third = report("match with fundamental_matrix=F", third.matched_left,
                     third.matched_right, gt)

    sbs = np.hstack([left_r, right_r])
    for y in range(20, sbs.shape[0], 40):
        cv2.line(sbs, (0, y), (sbs.shape[1] - 1, y), (0, 255, 0), 1)
    out = os.path.join(args.out, "uncalibrated_rectified.png")
    cv2.imwrite(out, sbs)
    print(f"image: {out}")

    failures = []
    if not inlier_ratio >= INLIER_GOAL:
        failures.append(f"RANSAC inlier ratio {inlier_ratio:.1%} is below {INLIER_GOAL:.0%}")
    for label, p in (("first match", p_first), ("re-match", p_second),
                     ("match with F", p_third)):
        if not p >= PRECISION_GOAL:
            failures.append(f"{label}: {p:.1%} within 1 px, below {PRECISION_GOAL:.0%}")
    for failure in failures:
        print(f"uncalibrated: FAILED: {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
