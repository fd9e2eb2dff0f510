"""The unrectified-pair check on real scenes: what it measures on rectified pairs and on
pairs whose right image is shifted vertically.

Run: ``python benchmarks/rectification_check.py`` (prints a Markdown table).

For each scene, the default detector's keypoints and descriptors go through
``hopmatch.matching.diagnostics.rectification_evidence`` (the check behind
``UnrectifiedPairWarning``, docs/robustness.md) with the right image shifted down by 0, 3 and
8 px. Each cell: median |dy| of the clear look-alikes (number counted, share within the 1 px
band). Rectified pairs should measure well below the 2 px threshold with most look-alikes
in the band; shifted ones about their shift with almost none in it.

``--chessboards`` measures the rectified chessboard pairs of
``../shared/data/opencv_stereo_calib`` (calibrated as in ``examples/stereo_calibration.py``)
instead: low-texture scenes where many look-alikes are wrong.

``--smoke``: motorcycle and, when present, Middlebury tsukuba only (with
``--chessboards``: the first two pairs); a check that the script works.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

import hopmatch
from hopmatch import datasets
from hopmatch.matching.diagnostics import RECTIFICATION_RATIO, rectification_evidence
from hopmatch.stereo import rectify

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import SMOKE_PAIRS, add_smoke_option, smoke_scenes  # noqa: E402


def pairs(chessboards: bool, smoke: bool = False):
    """``(name, left, right)`` of every scene, or of every rectified chessboard pair
    (``smoke``: :func:`_common.smoke_scenes`, or the first two pairs)."""
    if not chessboards:
        names = datasets.list_scenes()
        for name in smoke_scenes(names) if smoke else names:
            scene = datasets.load(name)
            yield name, scene.left, scene.right
        return
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
    import stereo_calibration as calib  # noqa: E402 (the example's own calibration)

    folder = datasets.shared_data_dir() / "opencv_stereo_calib"
    cal, _, _, used = calib.calibrate(folder)
    for i in used[:SMOKE_PAIRS] if smoke else used:
        left = cv2.imread(str(folder / f"left{i}.jpg"))
        right = cv2.imread(str(folder / f"right{i}.jpg"))
        left_r, right_r, _ = rectify(left, right, cal, alpha=0.0)
        yield f"chessboard {i}", left_r, right_r


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--chessboards", action="store_true",
                        help="the rectified chessboard pairs of ../shared/data instead")
    args = add_smoke_option(parser).parse_args(argv)
    det = hopmatch.DericheMoravecDetector()
    print(f"Clear look-alike ratio: {RECTIFICATION_RATIO}\n")
    print("| scene | 0 px | 3 px | 8 px | check time ms |")
    print("|---|---:|---:|---:|---:|")
    for name, left, right_image in pairs(args.chessboards, smoke=args.smoke):
        kl, dl = det.detectAndCompute(left)
        pl = cv2.KeyPoint_convert(kl)
        cells, times = [], []
        for shift in (0, 3, 8):
            right = np.roll(right_image, shift, axis=0)
            kr, dr = det.detectAndCompute(right)
            pr = cv2.KeyPoint_convert(kr)
            t0 = time.perf_counter()
            ev = rectification_evidence(pl, pr, dl, dr, 0.0, 0.25 * left.shape[1], 1.0)
            times.append(time.perf_counter() - t0)
            cells.append("n/a" if ev is None else f"{ev[0]:.2f} ({ev[1]}, {ev[2]:.0%})")
        print(f"| {name} | " + " | ".join(cells) + f" | {1e3 * min(times):.0f} |")


if __name__ == "__main__":
    main()
