#!/usr/bin/env python
"""OpenCV's stereo_match sample flow with hopmatch's StereoMatcher-like class.

The steps of OpenCV's ``samples/python/stereo_match.py``: the aloe pair found with
``cv.samples.findFile`` and halved with ``cv.pyrDown``; a matcher for the disparity range
16..111 px; ``compute(imgL, imgR)`` divided by 16 (OpenCV's fixed point); a guessed ``Q``
matrix (focal 0.8 x width, the y axis turned up); ``cv.reprojectImageTo3D``; the pixels
``disp > disp.min()`` written as a coloured PLY point cloud. Only the line that creates the
matcher differs: ``hopmatch.StereoHopfield.create(...)`` where the sample calls
``cv.StereoSGBM_create(...)`` (``docs/migration.md``, "Replacing StereoSGBM"). hopmatch is a
sparse matcher: the PLY holds one point per match, not one per pixel.

The images come from the shared stereo data (``../shared/data/aloe``, or
``$HOPMATCH_SHARED_DATA/aloe``; the same files as OpenCV's ``samples/data``), added to
OpenCV's sample search path with ``cv.samples.addSamplesDataSearchPath``.

Usage::

    python examples/stereo_match.py [--data DIR] [--out DIR]

    --data DIR   the folder holding aloeL.jpg and aloeR.jpg (default: the shared data's
                 aloe scene)
    --out DIR    where to write out.ply (default: ./hopmatch-examples)

Prints the disparity image's type and value range, the number of matched pixels and of
PLY vertices and, when the folder is a scene with ground truth (a ``meta.json``, as the
shared aloe), the share of matched pixels within 1 px of it, beside the sample's own
``cv.StereoSGBM_create`` line run on the same images. Exit status: 0 on success; 1 if a
check fails (no matched pixel, a PLY whose vertex count differs from the matched pixels, or
a vertex that is not finite); 2 when the data folder is absent.
"""

from __future__ import annotations

import argparse
import os
import sys

import cv2 as cv
import numpy as np

import hopmatch
from hopmatch.datasets import shared_data_dir
from hopmatch.errors import InvalidArgumentError


def save_ply(path, points, colours):
    """An ASCII PLY of ``points`` (N, 3) with RGB ``colours`` (N, 3)."""
    points = np.asarray(points, np.float64).reshape(-1, 3)
    colours = np.asarray(colours).reshape(-1, 3).astype(np.int64)
    header = ("ply\nformat ascii 1.0\n"
              f"element vertex {len(points)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\n"
              "end_header\n")
    with open(path, "w") as fh:
        fh.write(header)
        for (x, y, z), (r, g, b) in zip(points.tolist(), colours.tolist()):
            fh.write(f"{x:f} {y:f} {z:f} {r:d} {g:d} {b:d}\n")


def read_ply_vertices(path) -> np.ndarray:
    """The (N, 6) vertex rows of an ASCII PLY written by :func:`save_ply`, checked against
    its header's ``element vertex`` count."""
    with open(path) as fh:
        lines = fh.read().splitlines()
    end = lines.index("end_header")
    count = int(next(ln.split()[2] for ln in lines[:end] if ln.startswith("element vertex")))
    rows = np.array([ln.split() for ln in lines[end + 1:]], np.float64).reshape(-1, 6)
    if len(rows) != count:
        raise ValueError(f"{path}: the header says {count} vertices, the body has {len(rows)}")
    return rows


def ground_truth_at_half_size(folder, shape) -> np.ndarray:
    """The scene's ground truth (left view, NaN = unknown) at the ``pyrDown`` size:
    sampled at every second pixel and halved."""
    from hopmatch.datasets import load_scene

    full = load_scene(folder).disparity
    return full[0::2, 0::2][: shape[0], : shape[1]] / 2.0


def within_one_pixel(disp, truth):
    """``(pixels with a disparity, those with ground truth, those within 1 px of it)``;
    a pixel has a disparity when it is above the map's minimum (the sample's mask)."""
    mask = disp > disp.min()
    err = np.abs(disp[mask] - truth[mask])
    known = np.isfinite(err)
    return int(mask.sum()), int(known.sum()), int((err[known] <= 1.0).sum())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default=None, help="folder with aloeL.jpg and aloeR.jpg")
    parser.add_argument("--out", default="hopmatch-examples", help="output folder")
    args = parser.parse_args(argv)
    try:
        data = args.data or os.path.join(shared_data_dir(), "aloe")
    except InvalidArgumentError as exc:
        print(f"stereo_match: error: {exc}", file=sys.stderr)
        return 2
    if not os.path.isfile(os.path.join(data, "aloeL.jpg")):
        print(f"stereo_match: error: no aloeL.jpg in {data!r}", file=sys.stderr)
        return 2
    cv.samples.addSamplesDataSearchPath(data)
    os.makedirs(args.out, exist_ok=True)

    # --- the flow of OpenCV's stereo_match.py; only the creation line differs ---
    imgL = cv.pyrDown(cv.imread(cv.samples.findFile("aloeL.jpg")))
    imgR = cv.pyrDown(cv.imread(cv.samples.findFile("aloeR.jpg")))

    min_disp = 16
    num_disp = 112 - min_disp
    stereo = hopmatch.StereoHopfield.create(minDisparity=min_disp, numDisparities=num_disp,
                                            blockSize=9)   # was: cv.StereoSGBM_create(...)

    raw = stereo.compute(imgL, imgR)
    disp = raw.astype(np.float32) / 16.0

    h, w = imgL.shape[:2]
    f = 0.8 * w  # a guess at the focal length, as in the sample
    Q = np.float32([[1, 0, 0, -0.5 * w],
                    [0, -1, 0, 0.5 * h],  # y axis up
                    [0, 0, 0, -f],
                    [0, 0, 1, 0]])
    points = cv.reprojectImageTo3D(disp, Q)
    colors = cv.cvtColor(imgL, cv.COLOR_BGR2RGB)
    mask = disp > disp.min()
    out_fn = os.path.join(args.out, "out.ply")
    save_ply(out_fn, points[mask], colors[mask])
    # --- end of the sample's flow ---

    matched = int(mask.sum())
    print(f"disparity: {raw.dtype}, {raw.shape[1]}x{raw.shape[0]}, "
          f"values {int(raw.min())}..{int(raw.max())} (x16; no match: {(min_disp - 1) * 16})")
    print(f"matched pixels: {matched} ({len(stereo.getLastResult().matches)} matches)")
    vertices = read_ply_vertices(out_fn)
    print(f"PLY: {out_fn}, {len(vertices)} vertices")
    if os.path.isfile(os.path.join(data, "meta.json")):
        truth = ground_truth_at_half_size(data, disp.shape)
        sgbm = cv.StereoSGBM_create(minDisparity=min_disp, numDisparities=num_disp,
                                    blockSize=16, P1=8 * 3 * 3**2, P2=32 * 3 * 3**2,
                                    disp12MaxDiff=1, uniquenessRatio=10,
                                    speckleWindowSize=100, speckleRange=32)
        dense = sgbm.compute(imgL, imgR).astype(np.float32) / 16.0
        for name, d in (("StereoHopfield", disp), ("StereoSGBM (the sample's line)", dense)):
            n, scored, good = within_one_pixel(d, truth)
            print(f"{name}: {n} pixels with a disparity, {good / max(scored, 1):.2%} of the "
                  f"{scored} with ground truth within 1 px")
    checks = [("matched pixels", matched > 0),
              ("PLY vertices = matched pixels", len(vertices) == matched),
              ("finite vertices", bool(np.isfinite(vertices).all()))]
    failed = [name for name, good in checks if not good]
    for name in failed:
        print(f"stereo_match: check FAILED: {name}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
