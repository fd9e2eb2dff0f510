"""The unrectified-pair check on real scenes: what it measures on rectified pairs and on
pairs whose right image is shifted vertically.

Run: ``python benchmarks/rectification_check.py [--wide | --defaults | --costs]
[--chessboards] [--smoke]`` (prints a Markdown table).

For each scene, the default detector's keypoints and descriptors go through
``hopmatch.matching.diagnostics.rectification_evidence`` (the check behind
``UnrectifiedPairWarning``, docs/robustness.md) with the right image shifted down by 0, 3 and
8 px. Each cell: median |dy| of the clear look-alikes (number counted, share within the 1 px
band). Rectified pairs should measure well below the 2 px threshold with most look-alikes
in the band; shifted ones about their shift with almost none in it.

``--wide`` measures, for each scene, what ``match_stereo``'s default (``rectified=None``)
decides on: the share of the keypoints the network keeps on the rows
(``result.passes == 0``; the wide check runs below ``RECTIFICATION_SUSPICIOUS``, or below
``UNRECTIFIED_SUSPICIOUS`` when fewer than ``UNRECTIFIED_ROWS_SHARE`` of the row-offset
prior's look-alikes lie on their rows: "on their rows", ``vertical.rows_share_of``), and
``wide_rectification_evidence`` (64 rows, the disparity range the rows were searched in;
cells as above, in-band share below ``UNRECTIFIED_MAX_IN_BAND`` switches) with 100 points
and with 100 then 300, with its time, on the rectified pair and on its right image
rotated 5 degrees, shifted 30 px down and scaled 1.03 (``cv2.warpAffine``); with
``--chessboards``, of those pairs.

``--chessboards`` measures the rectified chessboard pairs of
``../shared/data/opencv_stereo_calib`` (calibrated as in ``examples/stereo_calibration.py``)
instead: low-texture scenes where many look-alikes are wrong.

``--defaults`` runs ``match_stereo`` with its defaults on each pair (one thread, best of 3
after one untimed call) and with ``rectified=True``: matches on the rows, matches by
default, how the default searched (``rows``, or ``result.geometry.search`` when it matched
the pair as unrectified), the share of the default's matches within 1 px of their row, and
both times: what ``rectified=None``'s switch and its fallback (a pair below 3 % kept on
its rows is matched as unrectified too, docs/robustness.md) cost on rectified pairs.

``--costs`` times (best of 3, one thread) the searches for each left point's clear best
look-alike, on each scene's default keypoints over a quarter of the width: the row-offset
prior that every rectified pair's network starts with (``vertical.prior_look_alikes``,
rows of +-1 px), the wide check (``clear_look_alikes`` in 64 rows, 300 left points, what
``wide_rectification_evidence`` does at most), the stereo-pair check
(``stereo_pair_evidence``) and the two-dimensional bootstrap of
``HopfieldMatcher.estimateFundamentalMatrix`` (``geometry.descriptor_correspondences``);
run it in two checkouts to compare them.

``--smoke``: motorcycle and, when present, Middlebury tsukuba only (with
``--chessboards``: the first two pairs); a check that the script works.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
import warnings
from pathlib import Path

import cv2
import numpy as np

import hopmatch
from hopmatch import datasets
from hopmatch.matching.candidates import candidate_pairs
from hopmatch.matching.diagnostics import (
    RECTIFICATION_MAX_PAIRS,
    RECTIFICATION_RATIO,
    RECTIFICATION_SAMPLE,
    STEREO_SAMPLE,
    STEREO_WINDOW,
    clear_look_alikes,
    rectification_evidence,
    stereo_pair_evidence,
    wide_rectification_evidence,
)
from hopmatch.matching.disparity_range import search_range
from hopmatch.matching.geometry import descriptor_correspondences
from hopmatch.matching.vertical import prior_look_alikes, rows_share_of
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


def far_off(image):
    """``image`` rotated 5 degrees about its centre, shifted 30 px down, scaled 1.03."""
    h, w = image.shape[:2]
    A = cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), 5.0, 1.03)
    A[1, 2] += 30
    return cv2.warpAffine(image, A, (w, h), flags=cv2.INTER_LINEAR)


def wide_table(det, smoke: bool, chessboards: bool) -> None:
    """The ``--wide`` table (of the rectified chessboard pairs with ``chessboards``)."""
    print("| scene | kept on the rows | on their rows | rectified: 100 | ms | 100, 300 | ms | "
          "far off: on their rows | 100 | ms | 100, 300 | ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, left, right_image in pairs(chessboards, smoke=smoke):
        res = hopmatch.match_stereo(left, right_image, rectified=True)
        kept = (res.passes == 0).sum() / min(len(res.points_left), res.n_detected_right)
        config = res.network.config  # the range the rows were searched in
        kl, dl = det.detectAndCompute(left)
        pl = cv2.KeyPoint_convert(kl)
        cells = [f"{kept:.1%}"]
        for right in (right_image, far_off(right_image)):
            kr, dr = det.detectAndCompute(right)
            pr = cv2.KeyPoint_convert(kr)
            # the look-alikes of the row-offset prior, in the range it searches
            looks = prior_look_alikes(pl, pr, dl, dr, *search_range(
                dataclasses.replace(config, max_disparity=None, min_disparity=0.0),
                left.shape[1::-1], pl, pr), config.max_vertical)
            cells.append(f"{rows_share_of(looks, config.max_vertical):.2f}")
            for sizes in ((STEREO_SAMPLE,), (STEREO_SAMPLE, RECTIFICATION_SAMPLE)):
                t0 = time.perf_counter()
                ev = wide_rectification_evidence(pl, pr, dl, dr, config.min_disparity,
                                                 config.max_disparity, config.max_vertical,
                                                 sizes)
                took = time.perf_counter() - t0
                cells.append("n/a" if ev is None else f"{ev[0]:.2f} ({ev[1]}, {ev[2]:.0%})")
                cells.append(f"{1e3 * took:.0f}")
        print(f"| {name} | " + " | ".join(cells) + " |")


def costs_table(det, smoke: bool) -> None:
    """The ``--costs`` table."""
    print("| scene | pairs in the wide band | prior ms | wide check ms | stereo-pair check ms | "
          "2-D bootstrap ms |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, left, right in pairs(False, smoke=smoke):
        pl, _, dl, _ = det.detect_and_describe(left)
        pr, _, dr, _ = det.detect_and_describe(right)
        width = left.shape[1]
        calls = (lambda: prior_look_alikes(pl, pr, dl, dr, 0.0, 0.25 * width, 1.0),
                 lambda: clear_look_alikes(pl, pr, dl, dr, 0.0, 0.25 * width, STEREO_WINDOW,
                                           RECTIFICATION_SAMPLE),
                 lambda: stereo_pair_evidence(pl, pr, dl, dr, 0.0, 0.25 * width),
                 lambda: descriptor_correspondences(pl, pr, dl, dr, left.shape[1::-1][:2]))
        sample = np.unique(np.linspace(0, len(pl) - 1, min(len(pl), RECTIFICATION_SAMPLE))
                           .astype(np.int64))
        n = len(candidate_pairs(np.ascontiguousarray(pl[sample]), pr, 0.0, 0.25 * width,
                                STEREO_WINDOW, RECTIFICATION_MAX_PAIRS * 100)[0])
        cells = [str(n)]
        for call in calls:
            call()
            best = float("inf")
            for _ in range(3):
                t0 = time.perf_counter()
                call()
                best = min(best, time.perf_counter() - t0)
            cells.append(f"{1e3 * best:.1f}")
        print(f"| {name} | " + " | ".join(cells) + " |")


def defaults_table(smoke: bool, chessboards: bool) -> None:
    """The ``--defaults`` table."""
    print("| pair | on the rows | default | search | within 1 px of the row | rows ms | "
          "default ms |")
    print("|---|---:|---:|---|---:|---:|---:|")
    for name, left, right in pairs(chessboards, smoke=smoke):
        cells = []
        for rectified in (True, None):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", hopmatch.errors.HopmatchWarning)
                hopmatch.match_stereo(left, right, rectified=rectified)
                times = []
                for _ in range(3):
                    t0 = time.perf_counter()
                    res = hopmatch.match_stereo(left, right, rectified=rectified)
                    times.append(time.perf_counter() - t0)
            cells.append((res, min(times)))
        (rows, t_rows), (auto, t_auto) = cells
        dy = np.abs(auto.matched_left[:, 1] - auto.matched_right[:, 1])
        share = f"{np.mean(dy <= 1.0):.3f}" if len(dy) else "n/a"
        search = "rows" if auto.geometry is None else auto.geometry.search
        print(f"| {name} | {len(rows.query_idx)} | {len(auto.query_idx)} | {search} | {share} "
              f"| {1e3 * t_rows:.0f} | {1e3 * t_auto:.0f} |")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--chessboards", action="store_true",
                        help="the rectified chessboard pairs of ../shared/data instead")
    parser.add_argument("--wide", action="store_true",
                        help="what match_stereo's rectified=None decides on (docs/pipelines.md)")
    parser.add_argument("--costs", action="store_true",
                        help="time the look-alike searches of the checks and the 2-D bootstrap")
    parser.add_argument("--defaults", action="store_true",
                        help="match_stereo's defaults against rectified=True, and their time")
    args = add_smoke_option(parser).parse_args(argv)
    det = hopmatch.DericheMoravecDetector()
    if args.costs:
        hopmatch.setNumThreads(1)
        cv2.setNumThreads(1)
        return costs_table(det, args.smoke)
    if args.defaults:
        hopmatch.setNumThreads(1)
        cv2.setNumThreads(1)
        return defaults_table(args.smoke, args.chessboards)
    if args.wide:
        hopmatch.setNumThreads(1)
        cv2.setNumThreads(1)
        return wide_table(det, args.smoke, args.chessboards)
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
