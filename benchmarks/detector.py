"""Detector benchmark: speed against OpenCV and scikit-image peers, and repeatability.

Run: ``python benchmarks/detector.py`` (single thread; prints Markdown tables).

- Time of ``DericheMoravecDetector.detect`` on the motorcycle left image against
  ``cv2.GFTTDetector`` asked for the same number of points, and against scikit-image's
  ``corner_moravec`` + ``corner_peaks`` (goals: <= 1.5x GFTT, <= 0.05x scikit-image).
- Repeatability on motorcycle ground truth (``hopmatch.evaluate.repeatability``, 1 px):
  defaults, then a grid over parameters including gradient vs intensity input.
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_time, machine, motorcycle_bgr, single_thread  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch.evaluate import repeatability  # noqa: E402


def speed(left) -> None:
    grey = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY)
    det = hopmatch.DericheMoravecDetector()
    n = len(det.detect(grey))
    gftt = cv2.GFTTDetector_create(maxCorners=n, qualityLevel=1e-4, minDistance=2)

    from skimage.feature import corner_moravec, corner_peaks

    t_hop = best_time(lambda: det.detect(grey))
    t_pts = best_time(lambda: det.detect_points(grey))
    t_der = best_time(lambda: hopmatch.deriche_gradient(grey, det.getAlpha(), det.getOmega()))
    t_gftt = best_time(lambda: gftt.detect(grey))
    t_sk = best_time(lambda: corner_peaks(corner_moravec(grey, 5), min_distance=2), repeat=2)
    print(f"## Detector speed, motorcycle left {grey.shape[1]}x{grey.shape[0]}, {n} points\n")
    print("| method | ms | ratio hopmatch / method |")
    print("|---|---:|---:|")
    print(f"| hopmatch detect (KeyPoints) | {t_hop * 1e3:.1f} | 1.00 |")
    print(f"| hopmatch detect_points (arrays) | {t_pts * 1e3:.1f} | {t_hop / t_pts:.2f} |")
    print(f"| of which Deriche gradient (cv2.ximgproc) | {t_der * 1e3:.1f} | {t_hop / t_der:.2f} |")
    print(f"| cv2.GFTTDetector ({n} points) | {t_gftt * 1e3:.1f} | {t_hop / t_gftt:.2f} |")
    print(f"| skimage corner_moravec + corner_peaks | {t_sk * 1e3:.1f} | {t_hop / t_sk:.3f} |")
    print()


def repeatability_grid(left, right, disp) -> None:
    print("## Repeatability on motorcycle (1 px, hopmatch.evaluate.repeatability)\n")
    print("| on | window_size | nms_size | alpha | subpixel | points (left) | repeatability |")
    print("|---|---:|---:|---:|---|---:|---:|")
    default = hopmatch.DericheMoravecDetector()
    rows = [default.get_params()]
    for on, ws, nms, alpha, sub in itertools.product(
            ["gradient", "intensity"], [3, 5], [5, 9, 20], [0.7, 1.0, 2.0], [True, False]):
        if on == "intensity" and alpha != 1.0:
            continue
        p = default.get_params()
        p.update(on=on, window_size=ws, nms_size=nms, alpha=alpha, subpixel=sub)
        rows.append(p)
    for i, p in enumerate(rows):
        det = hopmatch.DericheMoravecDetector(**p)
        pl, _, _ = det.detect_points(left)
        pr, _, _ = det.detect_points(right)
        frac, _, _ = repeatability(pl, pr, disp, tolerance=1.0)
        tag = " (defaults)" if i == 0 else ""
        print(f"| {p['on']}{tag} | {p['window_size']} | {p['nms_size']} | {p['alpha']} | "
              f"{p['subpixel']} | {len(pl)} | {frac:.3f} |")
    print()


def main() -> None:
    single_thread()
    hopmatch.warmup()
    left, right, disp = motorcycle_bgr()
    print(f"Machine: {machine()}\n")
    speed(left)
    repeatability_grid(left, right, disp)


if __name__ == "__main__":
    main()
