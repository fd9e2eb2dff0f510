"""Where match_stereo's wrong matches lie, and what the half-window test drops of them.

Run: ``python benchmarks/wrong_matches.py [--scenes NAME ...] [--smoke]``

For every scene (default: the weakest of ``benchmarks/passes.py``: tsukuba, midd2,
motorcycle, dolls, MotorcycleE, Teddy) it matches with the defaults but the half-window
test off (``hopmatch.matching.halves.HALF_CHECK = False``), scores the matches as
:func:`hopmatch.evaluate.score_matches` does at 1 px (wrong: disparity error above 1 px or
``|dy|`` above 1 px), and prints for the wrong ones: how many each pass made (0 network,
1 guided), their error (1-2, 2-5, above 5 px) and its sign (``+``: the disparity is too
large, a nearer surface's), their distance to a depth edge of the ground truth (a jump of
more than 2 px between neighbouring pixels; at most 2 and 4 px, with the share of all
scored matches so near), and how many of the wrong and of the correct ones the half-window
test (:func:`hopmatch.matching.halves.straddling`) would drop. Then the pooled counts.
Single thread.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, single_thread, smoke_scene  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.evaluate import score_matches  # noqa: E402
from hopmatch.feature.detector import DericheMoravecDetector  # noqa: E402
from hopmatch.matching import halves  # noqa: E402
from hopmatch.matching.stereo_match import half_window_radius, refine_radius  # noqa: E402

WEAK = ("middlebury/tsukuba", "middlebury2006/midd2", "motorcycle", "middlebury/dolls",
        "middlebury2014/MotorcycleE", "middlebury2014/Teddy")
#: A jump of the ground truth above this (px) between neighbouring pixels is a depth edge.
EDGE_JUMP = 2.0


def edge_distance(disparity: np.ndarray) -> np.ndarray:
    """Distance (px) of every pixel to the nearest depth edge of ``disparity`` (unknown
    pixels count as 0 disparity)."""
    d = np.nan_to_num(disparity, nan=0.0)
    edge = np.zeros(d.shape, bool)
    edge[:, 1:] |= np.abs(np.diff(d, axis=1)) > EDGE_JUMP
    edge[1:, :] |= np.abs(np.diff(d, axis=0)) > EDGE_JUMP
    return ndimage.distance_transform_edt(~edge)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", help="scene names (default: the weakest six)")
    args = add_smoke_option(ap).parse_args(argv)
    single_thread()
    halves.HALF_CHECK = False
    available = set(datasets.list_scenes())
    names = args.scenes or [n for n in WEAK if n in available]
    if args.smoke:
        names = names[:1]
    print("scene | scored | wrong | by pass 0/1 | err 1-2/2-5/>5 | sign +/- | "
          "edge <=2 (all) | edge <=4 (all) | test drops wrong/correct")
    tot = np.zeros(4, np.int64)
    for n in names:
        scene = datasets.load(n)
        scene = smoke_scene(scene) if args.smoke else scene
        res = hopmatch.match_stereo(scene.left, scene.right)
        left, right = res.matched_left, res.matched_right
        sc = score_matches(left, right, scene.disparity, thresholds=(1.0,))
        idx = np.flatnonzero(sc.scored)
        err = sc.errors.astype(np.float64)
        wrong = (np.abs(err) > 1.0) | (np.abs(left[idx, 1] - right[idx, 1]) > 1.0)
        xi = np.floor(left[idx, 0] + 0.5).astype(np.intp)
        yi = np.floor(left[idx, 1] + 0.5).astype(np.intp)
        near = edge_distance(scene.disparity)[yi, xi]
        grays = [DericheMoravecDetector().gray_and_feature_image(image, side)[0]
                 for image, side in ((scene.left, "left"), (scene.right, "right"))]
        radius = half_window_radius(refine_radius(grays[0].shape))
        drop = halves.straddling(grays[0], grays[1], left, right, radius=radius)[idx]
        w = wrong
        a = np.abs(err[w])
        passes = res.passes[idx]
        print(f"{n} | {len(idx)} | {w.sum()} | {(w & (passes == 0)).sum()}/"
              f"{(w & (passes == 1)).sum()} | {(a <= 2).sum()}/{((a > 2) & (a <= 5)).sum()}/"
              f"{(a > 5).sum()} | {(err[w] > 0).sum()}/{(err[w] < 0).sum()} | "
              f"{np.mean(near[w] <= 2) if w.any() else 0:.2f} ({np.mean(near <= 2):.2f}) | "
              f"{np.mean(near[w] <= 4) if w.any() else 0:.2f} ({np.mean(near <= 4):.2f}) | "
              f"{(drop & w).sum()}/{(drop & ~w).sum()}", flush=True)
        tot += [len(idx), w.sum(), (drop & w).sum(), (drop & ~w).sum()]
    print(f"pooled: {tot[0]} scored, {tot[1]} wrong; the test drops {tot[2]} wrong and "
          f"{tot[3]} correct")
    return 0


if __name__ == "__main__":
    sys.exit(main())
