#!/usr/bin/env python
"""Metric depth from hopmatch's matches on KITTI, checked against the LiDAR ground truth.

On KITTI stereo 2012 training pair #000070 (``../shared/data/kitti2012/000070``: the
rectified grey pair ``left.png``/``right.png``, 1241 x 376, ``calib.txt`` and the sparse
LiDAR disparity ``disp_noc.png``), read with ``hopmatch.datasets.load``, whose
``read_kitti_calib`` gives the grey pair's focal length f and baseline B from P0/P1:

1. ``hopmatch.match_stereo`` with default parameters (``max_disparity`` a quarter of the
   width, 310 px, i.e. depths down to f B / 310 = 1.25 m; the ground truth's largest
   disparity is 123 px);
2. depth ``Z = f B / d`` of every match (``hopmatch.stereo.depth_from_disparity``);
3. the ground-truth depth at each matched left point (nearest pixel of the LiDAR
   disparity, converted the same way) where the LiDAR has a value; the relative error
   ``|Z - Z_gt| / Z_gt``.

Usage::

    python examples/kitti_depth.py [--out DIR]

    --out DIR   where to write kitti_depth.csv (x, y, disparity, depth, ground-truth depth
                of every match; metres) (default ./hopmatch-examples)

Prints f, B, the number of matches and of matches with LiDAR ground truth, the median
relative depth error and the fraction of matches within 5 %. Checks: median relative
error at most 5 % and at least 90 % of the matches within 5 %. Exit status: 0 when they
pass, 1 when one fails, 2 when ``../shared/data`` (or ``$HOPMATCH_SHARED_DATA``) or the
KITTI scene is missing.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

import hopmatch
from hopmatch.datasets import load, shared_data_dir
from hopmatch.errors import InvalidArgumentError
from hopmatch.stereo import depth_from_disparity

SCENE = "kitti2012/000070"
MEDIAN_GOAL = 0.05   #: largest median relative depth error
WITHIN = 0.05        #: relative error counted as "within"
WITHIN_GOAL = 0.90   #: smallest fraction of matches within WITHIN


def find_scene(name: str):
    """The scene ``name`` of the shared stereo data (``hopmatch.datasets.shared_data_dir``),
    or None after a message saying what is missing."""
    try:
        return load(name, root=shared_data_dir())
    except InvalidArgumentError as exc:
        print(f"kitti_depth: error: {exc}", file=sys.stderr)
        return None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="hopmatch-examples", help="output folder")
    args = parser.parse_args(argv)

    scene = find_scene(SCENE)
    if scene is None:
        return 2
    os.makedirs(args.out, exist_ok=True)
    f = scene.calibration["focal_length"]
    baseline = scene.calibration["baseline"]
    w, h = scene.image_size
    print(f"scene: {scene.name}, {w}x{h}")
    print(f"focal length: {f:.3f} px, baseline: {baseline:.4f} m")

    res = hopmatch.match_stereo(scene.left, scene.right)
    depth = depth_from_disparity(res.disparities, focal=f, baseline=baseline)
    cols = np.clip(np.rint(res.matched_left[:, 0]).astype(int), 0, w - 1)
    rows = np.clip(np.rint(res.matched_left[:, 1]).astype(int), 0, h - 1)
    d_gt = scene.disparity[rows, cols]
    has_gt = np.isfinite(d_gt) & (d_gt > 0)
    depth_gt = np.full(len(depth), np.nan, np.float32)
    depth_gt[has_gt] = depth_from_disparity(d_gt[has_gt], focal=f, baseline=baseline)
    rel = np.abs(depth[has_gt] - depth_gt[has_gt]) / depth_gt[has_gt]
    median = float(np.median(rel)) if rel.size else float("nan")
    within = float(np.mean(rel <= WITHIN)) if rel.size else float("nan")

    print(f"matches: {len(depth)}, {int(has_gt.sum())} with LiDAR ground truth")
    if rel.size:
        print(f"depth of matches with ground truth: {depth_gt[has_gt].min():.1f}.."
              f"{depth_gt[has_gt].max():.1f} m (LiDAR)")
    print(f"median relative depth error: {median:.2%}")
    print(f"within 5%: {within:.1%}")

    out = os.path.join(args.out, "kitti_depth.csv")
    table = np.column_stack([res.matched_left, res.disparities, depth, depth_gt])
    np.savetxt(out, table, fmt="%.4f", delimiter=",", comments="",
               header="x,y,disparity_px,depth_m,depth_gt_m")
    print(f"table: {out}")

    failures = []
    if not median <= MEDIAN_GOAL:
        failures.append(f"median relative depth error {median:.2%} is above {MEDIAN_GOAL:.0%}")
    if not within >= WITHIN_GOAL:
        failures.append(f"only {within:.1%} of the matches are within {WITHIN:.0%} of the "
                        f"LiDAR depth (goal {WITHIN_GOAL:.0%})")
    for failure in failures:
        print(f"kitti_depth: FAILED: {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
