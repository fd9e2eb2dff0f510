"""What the off-row matches on the rectified chessboards are, for given matcher parameters.

Run: ``python benchmarks/chessboard_dy.py [--band PX] [--params JSON] [--shift PX]``

The 13 pairs of ``../shared/data/opencv_stereo_calib`` are calibrated and rectified as in
``examples/stereo_calibration.py``, then matched with ``hopmatch.match_stereo`` and a search
band of ``--band`` px (default 4) plus the matcher parameters of ``--params`` (a JSON object,
e.g. ``'{"vertical_check": "multiple"}'``). Printed: the share of matches with
``|dy| <= 1 px`` over all pairs and on pair 01 (the example's figures), then each match
classified against the board plane. Homographies from the board grid (9 x 6 inner corners)
to the corners detected again in each rectified image say where the right point of a left
point on the board (grid square -1..9 x -1..6) must be; ``ex`` is the horizontal error of the
matched right point:

* ``off board``: the left point is not on the board (no plane to check against);
* ``other corner``: ``|ex| > 20`` px (half a square or more): a look-alike elsewhere on the
  repetitive board;
* ``along an edge``: ``3 < |ex| <= 20``: slid along an edge of a square;
* ``same point``: ``|ex| <= 3``: the right physical point (then ``|dy| > 1`` is a
  localisation error).

``--shift PX`` moves every right image down by PX px after rectification (a rectification
error), to see that the |dy| figure still measures the rectification.

``--smoke``: the calibration from every pair as above, then only the first two pairs
matched and classified (a check that the script works; "all pairs" then means those two).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
import stereo_calibration as calib  # noqa: E402 (the example's own calibration)
from _common import SMOKE_PAIRS, add_smoke_option, single_thread  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.stereo import rectify  # noqa: E402

CLASSES = ("off board", "other corner", "along an edge", "same point")


def _apply(h, pts):
    hom = np.c_[pts, np.ones(len(pts))] @ h.T
    return hom[:, :2] / hom[:, 2:]


def classify(pl, pr, cl, cr):
    """Class index (into CLASSES) of each match, from the corners ``cl``/``cr`` (54 x 2)."""
    grid = np.mgrid[0:calib.PATTERN[0], 0:calib.PATTERN[1]].T.reshape(-1, 2).astype(np.float64)
    hl, _ = cv2.findHomography(grid, cl.astype(np.float64))
    hr, _ = cv2.findHomography(grid, cr.astype(np.float64))
    u = _apply(np.linalg.inv(hl), pl)
    on = ((u[:, 0] >= -1) & (u[:, 0] <= calib.PATTERN[0]) & (u[:, 1] >= -1)
          & (u[:, 1] <= calib.PATTERN[1]))
    ex = np.abs(pr[:, 0] - _apply(hr, u)[:, 0])
    return np.where(~on, 0, np.where(ex > 20, 1, np.where(ex > 3, 2, 3)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--band", type=float, default=4.0, help="max_vertical (default 4)")
    ap.add_argument("--params", default="{}", help="matcher parameters (JSON object)")
    ap.add_argument("--shift", type=float, default=0.0,
                    help="move the rectified right images down by this many px")
    args = add_smoke_option(ap).parse_args(argv)
    single_thread()
    params = json.loads(args.params)
    folder = datasets.shared_data_dir() / "opencv_stereo_calib"
    cal, _, _, used = calib.calibrate(folder)
    if args.smoke:
        used = used[:SMOKE_PAIRS]
    counts = {name: np.zeros(len(CLASSES), dtype=int) for name in ("|dy| <= 1", "|dy| > 1")}
    all_dy, pair01 = [], None
    for i in used:
        left = cv2.imread(str(folder / f"left{i}.jpg"))
        right = cv2.imread(str(folder / f"right{i}.jpg"))
        left_r, right_r, _ = rectify(left, right, cal, alpha=0.0)
        if args.shift:
            shift = np.float32([[1, 0, 0], [0, 1, args.shift]])
            right_r = cv2.warpAffine(right_r, shift, right_r.shape[1::-1])
        res = hopmatch.match_stereo(left_r, right_r, max_vertical=args.band, **params)
        pl = res.matched_left.astype(np.float64)
        pr = res.matched_right.astype(np.float64)
        dy = np.abs(pl[:, 1] - pr[:, 1])
        all_dy.append(dy)
        if i == "01":
            pair01 = dy
        found = calib.rectified_corners(left_r, right_r)
        if found is None:
            continue
        cls = classify(pl, pr, *found)
        for name, sel in (("|dy| <= 1", dy <= 1.0), ("|dy| > 1", dy > 1.0)):
            counts[name] += np.bincount(cls[sel], minlength=len(CLASSES))
    dy = np.concatenate(all_dy)
    print(f"band {args.band:g} px, parameters {params}, right images shifted "
          f"{args.shift:g} px")
    print(f"all pairs: {np.mean(dy <= 1.0):.1%} of {len(dy)} matches with |dy| <= 1 px")
    if pair01 is not None:
        print(f"pair 01: {np.mean(pair01 <= 1.0):.1%} of {len(pair01)} matches with "
              "|dy| <= 1 px")
    for name, c in counts.items():
        print(f"matches with {name} px: {c.sum()}: "
              + ", ".join(f"{k} {v}" for k, v in zip(CLASSES, c)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
