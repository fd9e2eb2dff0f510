"""The unrectified-pair check on real scenes: what it measures on rectified pairs and on
pairs whose right image is shifted vertically.

Run: ``python benchmarks/rectification_check.py`` (prints a Markdown table).

For each scene, the default detector's keypoints and descriptors go through
``hopmatch.matching.matcher.rectification_evidence`` (the check behind
``UnrectifiedPairWarning``, docs/robustness.md) with the right image shifted down by 0, 3 and
8 px. Rectified pairs should measure well below the 2 px threshold, shifted ones about
their shift.
"""

from __future__ import annotations

import time

import cv2
import numpy as np

import hopmatch
from hopmatch import datasets
from hopmatch.matching.matcher import RECTIFICATION_RATIO, rectification_evidence


def main() -> None:
    det = hopmatch.DericheMoravecDetector()
    print(f"Clear look-alike ratio: {RECTIFICATION_RATIO}\n")
    print("| scene | 0 px | 3 px | 8 px | check time ms |")
    print("|---|---:|---:|---:|---:|")
    for name in datasets.list_scenes():
        scene = datasets.load(name)
        kl, dl = det.detectAndCompute(scene.left)
        pl = cv2.KeyPoint_convert(kl)
        cells, times = [], []
        for shift in (0, 3, 8):
            right = np.roll(scene.right, shift, axis=0)
            kr, dr = det.detectAndCompute(right)
            pr = cv2.KeyPoint_convert(kr)
            t0 = time.perf_counter()
            ev = rectification_evidence(pl, pr, dl, dr, 0.0, 0.25 * scene.left.shape[1], 1.0)
            times.append(time.perf_counter() - t0)
            cells.append("n/a" if ev is None else f"{ev[0]:.2f} ({ev[1]})")
        print(f"| {name} | " + " | ".join(cells) + f" | {1e3 * min(times):.0f} |")


if __name__ == "__main__":
    main()
