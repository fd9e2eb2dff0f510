"""Detector benchmark: speed against OpenCV and scikit-image peers, and repeatability.

Run: ``python benchmarks/detector.py`` (single thread; prints Markdown tables;
``--smoke``: the same tables on a 240 x 160 crop of motorcycle, one timing run, five rows
of each parameter table (the first three and the last two): a check that the script works,
figures meaningless).

- Time of ``DericheMoravecDetector.detect`` on the motorcycle left image against
  ``cv2.GFTTDetector`` asked for the same number of points, and against scikit-image's
  ``corner_moravec`` + ``corner_peaks`` (goals: <= 1.5x GFTT, <= 0.05x scikit-image); the
  Deriche gradient alone (float32 kernel, and ``cv2.ximgproc`` for reference) against
  the same GFTT detection (goal: <= 0.5x).
- Repeatability on motorcycle ground truth (``hopmatch.evaluate.repeatability``, 1 px):
  defaults, then a grid over parameters including gradient vs intensity input, then the
  window weights of eq. 1 (``window_sigma``, box vs Gaussian) and a relative threshold.
  Denser right keypoints raise this metric trivially, so the second table also gives the
  right point count and the *chance* level: the same measure with every true
  correspondent moved 4 px (mean of the four axis directions).
- Where the defaults' misses are: nearest-right-point distances against chance, and the
  detector's self-repeatability under a sub-pixel translation.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import cv2
import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import (  # noqa: E402
    add_smoke_option,
    best_time,
    machine,
    motorcycle_bgr,
    single_thread,
)

import hopmatch  # noqa: E402
from hopmatch.evaluate import _gt_at, repeatability  # noqa: E402
from hopmatch.feature.gradient import deriche_magnitude  # noqa: E402


def speed(left, repeat: int = 7) -> None:
    grey = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY)
    det = hopmatch.DericheMoravecDetector()
    n = len(det.detect(grey))
    gftt = cv2.GFTTDetector_create(maxCorners=n, qualityLevel=1e-4, minDistance=2)

    from skimage.feature import corner_moravec, corner_peaks

    t_hop = best_time(lambda: det.detect(grey), repeat=repeat)
    t_pts = best_time(lambda: det.detect_points(grey), repeat=repeat)
    alpha, omega = det.getAlpha(), det.getOmega()
    t_der = best_time(lambda: hopmatch.deriche_gradient(grey, alpha, omega), repeat=repeat)
    t_der_cv = best_time(lambda: deriche_magnitude(grey, alpha, omega, method="opencv"),
                         repeat=repeat)
    t_gftt = best_time(lambda: gftt.detect(grey), repeat=repeat)
    t_sk = best_time(lambda: corner_peaks(corner_moravec(grey, 5), min_distance=2),
                     repeat=min(repeat, 2))
    print(f"## Detector speed, motorcycle left {grey.shape[1]}x{grey.shape[0]}, {n} points\n")
    print("| method | ms | ratio hopmatch / method |")
    print("|---|---:|---:|")
    print(f"| hopmatch detect (KeyPoints) | {t_hop * 1e3:.1f} | 1.00 |")
    print(f"| hopmatch detect_points (arrays) | {t_pts * 1e3:.1f} | {t_hop / t_pts:.2f} |")
    print(f"| of which Deriche gradient (float32 kernel) | {t_der * 1e3:.1f} | "
          f"{t_hop / t_der:.2f} |")
    print(f"| Deriche gradient with cv2.ximgproc (the reference) | {t_der_cv * 1e3:.1f} | "
          f"{t_hop / t_der_cv:.2f} |")
    print(f"| cv2.GFTTDetector ({n} points) | {t_gftt * 1e3:.1f} | {t_hop / t_gftt:.2f} |")
    print(f"| skimage corner_moravec + corner_peaks | {t_sk * 1e3:.1f} | {t_hop / t_sk:.3f} |")
    print()
    ratio = t_der / t_gftt
    print(f"Goal: Deriche gradient, one image, vs cv2.GFTTDetector detection with the same "
          f"number of points: <= 0.5x: {ratio:.2f}x, {'met' if ratio <= 0.5 else 'NOT met'} "
          f"(cv2.ximgproc: {t_der_cv / t_gftt:.2f}x)\n")


def _sample(rows: list, smoke: bool) -> list:
    """``rows``, or with ``smoke`` its first three and last two."""
    return rows[:3] + rows[-2:] if smoke and len(rows) > 5 else rows


def repeatability_grid(left, right, disp, smoke: bool = False) -> None:
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
    for i, p in enumerate(_sample(rows, smoke)):
        det = hopmatch.DericheMoravecDetector(**p)
        pl, _, _ = det.detect_points(left)
        pr, _, _ = det.detect_points(right)
        frac, _, _ = repeatability(pl, pr, disp, tolerance=1.0)
        tag = " (defaults)" if i == 0 else ""
        print(f"| {p['on']}{tag} | {p['window_size']} | {p['nms_size']} | {p['alpha']} | "
              f"{p['subpixel']} | {len(pl)} | {frac:.3f} |")
    print()


def _chance(left_pts, right_pts, disp, shift: float = 4.0) -> float:
    """Repeatability when each true correspondent is moved ``shift`` px along each axis."""
    d = _gt_at(left_pts, disp)
    ok = np.isfinite(d)
    target = np.column_stack([left_pts[ok, 0] - d[ok], left_pts[ok, 1]]).astype(np.float64)
    tree = cKDTree(right_pts.astype(np.float64))
    steps = [(shift, 0), (-shift, 0), (0, shift), (0, -shift)]
    return float(np.mean([(tree.query(target + s)[0] <= 1.0).mean() for s in steps]))


def miss_diagnosis(left, right, disp) -> None:
    """Where the defaults' misses are: distance from each true correspondent to the nearest
    right point, against the same distances from points 4 px away (chance), and the
    detector's own stability under a sub-pixel translation (no ground truth involved)."""
    det = hopmatch.DericheMoravecDetector()
    pl, _, _ = det.detect_points(left)
    pr, _, _ = det.detect_points(right)
    d = _gt_at(pl, disp)
    ok = np.isfinite(d)
    target = np.column_stack([pl[ok, 0] - d[ok], pl[ok, 1]]).astype(np.float64)
    tree = cKDTree(pr.astype(np.float64))
    edges = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0, np.inf]
    actual = np.histogram(tree.query(target)[0], edges)[0] / ok.sum()
    chance = np.mean([np.histogram(tree.query(target + s)[0], edges)[0]
                      for s in [(4, 0), (-4, 0), (0, 4), (0, -4)]], axis=0) / ok.sum()
    print("## Where the misses are (defaults, motorcycle)\n")
    print("Distance from each true correspondent to the nearest right point, as a fraction of "
          f"the {int(ok.sum())} left points with ground truth; *chance*: the same from points "
          "4 px away.\n")
    print("| distance (px) | " + " | ".join(f"{a:g}-{b:g}" for a, b in zip(edges, edges[1:]))
          + " |")
    print("|---|" + "---:|" * (len(edges) - 1))
    print("| true correspondent | " + " | ".join(f"{v:.3f}" for v in actual) + " |")
    print("| chance | " + " | ".join(f"{v:.3f}" for v in chance) + " |")
    grey = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY)
    print("\nSelf-repeatability under a pure sub-pixel translation of the left image "
          "(cv2.warpAffine, INTER_CUBIC), points 10 px from the border:\n")
    print("| translation (px) | window_sigma | within 0.5 px | within 1 px | within 2 px |")
    print("|---|---:|---:|---:|---:|")
    for ws in (0.0, 0.85):
        det = hopmatch.DericheMoravecDetector(window_sigma=ws)
        p0, _, _ = det.detect_points(grey)
        h, w = grey.shape
        inner = p0[(p0[:, 0] > 10) & (p0[:, 0] < w - 11) & (p0[:, 1] > 10) & (p0[:, 1] < h - 11)]
        for tx, ty in ((0.5, 0.0), (0.5, 0.25)):
            shifted = cv2.warpAffine(grey, np.float32([[1, 0, tx], [0, 1, ty]]), (w, h),
                                     flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
            p1, _, _ = det.detect_points(shifted)
            dist = cKDTree(p1.astype(np.float64)).query(inner + [tx, ty])[0]
            print(f"| ({tx:g}, {ty:g}) | {ws:g} | {(dist <= 0.5).mean():.3f} | "
                  f"{(dist <= 1).mean():.3f} | {(dist <= 2).mean():.3f} |")
    print()


def window_weights_table(left, right, disp, smoke: bool = False) -> None:
    print("## Window weights of eq. 1 (window_sigma) and thresholds, motorcycle, 1 px\n")
    print("| window_size | window_sigma | relative_threshold | points (left / right) | "
          "repeatability | chance (targets moved 4 px) |")
    print("|---:|---:|---:|---:|---:|---:|")
    rows = [{}]
    rows += [{"window_sigma": s} for s in (0.5, 0.7, 0.85, 1.0, 1.5)]
    rows += [{"window_size": 5}, {"window_size": 5, "window_sigma": 1.1}]
    rows += [{"relative_threshold": 5e-4}, {"relative_threshold": 5e-4, "window_sigma": 0.85}]
    for p in _sample(rows, smoke):
        det = hopmatch.DericheMoravecDetector(**p)
        pl, _, _ = det.detect_points(left)
        pr, _, _ = det.detect_points(right)
        frac, _, _ = repeatability(pl, pr, disp, tolerance=1.0)
        q = det.get_params()
        print(f"| {q['window_size']} | {q['window_sigma']:g} | {q['relative_threshold']:g} | "
              f"{len(pl)} / {len(pr)} | {frac:.3f} | {_chance(pl, pr, disp):.3f} |")
    print()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args = add_smoke_option(parser).parse_args(argv)
    single_thread()
    hopmatch.warmup()
    left, right, disp = motorcycle_bgr(smoke=args.smoke)
    print(f"Machine: {machine()}\n")
    speed(left, repeat=1 if args.smoke else 7)
    repeatability_grid(left, right, disp, smoke=args.smoke)
    window_weights_table(left, right, disp, smoke=args.smoke)
    miss_diagnosis(left, right, disp)


if __name__ == "__main__":
    main()
