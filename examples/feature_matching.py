#!/usr/bin/env python
"""OpenCV's feature-matching tutorial, with hopmatch's detector and matcher.

This is the flow of OpenCV's Python tutorial "Feature Matching"
(``doc/py_tutorials/py_feature2d/py_matcher``): ``detectAndCompute`` on both images,
``knnMatch(des1, des2, k=2)`` with Lowe's ratio test drawn by ``cv.drawMatchesKnn``, then
``match(des1, des2)`` drawn by ``cv.drawMatches``. Only the lines that create the detector
and the matcher differ, plus one ``setPairInfo`` call that gives the matcher the keypoint
positions (its network needs the geometry, as OpenCV 5's ``LightGlueMatcher`` does).
``docs/migration.md`` shows the changed lines side by side.

The pair must be a rectified stereo pair (left image first). By default it is the
Middlebury 2014 motorcycle pair shipped with scikit-image
(``hopmatch.datasets.load_motorcycle``), whose ground truth lets the script also print
the precision of both match sets (disparity within 1 px, vertical offset at most 1 px).

Usage::

    python examples/feature_matching.py [LEFT RIGHT] [--out DIR]

    LEFT RIGHT   two images of a rectified pair (default: the motorcycle pair)
    --out DIR    where to write knn_matches.png and matches.png
                 (default: ./hopmatch-examples)

Prints the keypoint counts, the number of ratio-test and ``match`` matches and, on the
motorcycle pair, their precision. Exit status: 0 on success; 1 if a check fails (no
keypoints or matches, or on the motorcycle pair a precision below 90 % at 1 px); 2 for
bad input (an image that cannot be read).
"""

from __future__ import annotations

import argparse
import os
import sys

import cv2 as cv

import hopmatch
from hopmatch.datasets import load_motorcycle
from hopmatch.evaluate import score_matches
from hopmatch.stereo import matched_points

#: Goal on the motorcycle pair: fraction of matches within 1 px of the ground truth.
PRECISION_GOAL = 0.90


def load_pair(paths):
    """The two images and the ground truth (None for user images)."""
    if not paths:
        scene = load_motorcycle()
        return scene.left, scene.right, scene.disparity, "motorcycle (scikit-image)"
    images = []
    for path in paths:
        img = cv.imread(path, cv.IMREAD_COLOR)
        if img is None:
            raise FileNotFoundError(f"cannot read the image {path!r}")
        images.append(img)
    return images[0], images[1], None, f"{paths[0]} / {paths[1]}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("images", nargs="*", metavar="LEFT RIGHT",
                        help="a rectified pair (default: the motorcycle pair)")
    parser.add_argument("--out", default="hopmatch-examples",
                        help="output folder for the drawn matches")
    args = parser.parse_args(argv)
    if len(args.images) not in (0, 2):
        parser.error("give two images (LEFT RIGHT) or none")
    try:
        # queryImage = left, trainImage = right
        img1, img2, disparity, name = load_pair(args.images)
    except FileNotFoundError as exc:
        print(f"feature_matching: error: {exc}", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    print(f"pair: {name}, {img1.shape[1]}x{img1.shape[0]}")

    # --- OpenCV's tutorial from here on; the two creation lines and setPairInfo differ ---
    # Initiate the detector
    detector = hopmatch.DericheMoravecDetector.create()    # was: sift = cv.SIFT_create()

    # find the keypoints and descriptors
    kp1, des1 = detector.detectAndCompute(img1, None)
    kp2, des2 = detector.detectAndCompute(img2, None)

    # matcher with default params
    bf = hopmatch.HopfieldMatcher.create()                  # was: bf = cv.BFMatcher()
    bf.setPairInfo(kp1, kp2, img1.shape[1::-1], img2.shape[1::-1])  # new: the geometry
    matches = bf.knnMatch(des1, des2, k=2)

    # Apply ratio test
    good = []
    for m, n in matches:
        if m.distance < 0.75 * n.distance:
            good.append([m])

    # cv.drawMatchesKnn expects list of lists as matches.
    img3 = cv.drawMatchesKnn(img1, kp1, img2, kp2, good, None,
                             flags=cv.DrawMatchesFlags_NOT_DRAW_SINGLE_POINTS)

    # match() keeps one match per query (hopmatch always applies its left-right check,
    # as BFMatcher(crossCheck=True) does). Sort them by distance and draw the first 10.
    matches = bf.match(des1, des2)
    matches = sorted(matches, key=lambda x: x.distance)
    img4 = cv.drawMatches(img1, kp1, img2, kp2, matches[:10], None,
                          flags=cv.DrawMatchesFlags_NOT_DRAW_SINGLE_POINTS)
    # --- end of the tutorial's flow ---------------------------------------------------

    cv.imwrite(os.path.join(args.out, "knn_matches.png"), img3)
    cv.imwrite(os.path.join(args.out, "matches.png"), img4)
    print(f"keypoints: {len(kp1)} left, {len(kp2)} right")
    print(f"ratio-test matches: {len(good)} (knnMatch rows: one per left keypoint)")
    print(f"match matches: {len(matches)}")
    print(f"images: {os.path.join(args.out, 'knn_matches.png')}, "
          f"{os.path.join(args.out, 'matches.png')}")

    failures = []
    if not kp1 or not kp2:
        failures.append("no keypoints detected")
    if not good or not matches:
        failures.append("no matches")
    if disparity is not None:
        for label, ms in (("ratio-test", [g[0] for g in good]), ("match", matches)):
            left, right = matched_points(kp1, kp2, ms)
            score = score_matches(left, right, disparity, thresholds=(1.0,))
            p = score.precision[1.0]
            print(f"{label} precision (1 px): {p:.1%} of {score.n_scored} matches with "
                  "ground truth")
            if not p >= PRECISION_GOAL:
                failures.append(f"{label} precision {p:.1%} is below the goal "
                                f"{PRECISION_GOAL:.0%}")
    for failure in failures:
        print(f"feature_matching: FAILED: {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
