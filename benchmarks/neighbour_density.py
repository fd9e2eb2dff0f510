"""How many neighbours the network's left points have, detector by detector (the
``min_neighbours`` rule, docs/parameters.md, "Sparse keypoints").

Run: ``python benchmarks/neighbour_density.py [--scenes NAME ...] [--smoke]``

For motorcycle and every scene of ``../shared/data`` (or ``$HOPMATCH_SHARED_DATA``), the
left image's keypoints from: hopmatch's detector with its defaults, with ``nms_size`` 9 and
15, and with ``max_features=2000``; SIFT (``cv2.SIFT_create()``); ORB
(``cv2.ORB_create(3000)``). For each, ``N:m`` (``xF``): N keypoints, m the median number of
other keypoints in the network's default 40 x 20 px window
(:func:`hopmatch.matching.neighbourhood.median_neighbours`), and F the factor by which
``min_neighbours``'s default (8) grows the window and theta for them (nothing when it
does not). ``--smoke``: motorcycle's centre crop (figures meaningless).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, single_thread, smoke_scene  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.matching.neighbourhood import grown_for_density, median_neighbours  # noqa: E402
from hopmatch.matching.params import matcher_config  # noqa: E402

#: Column label and keypoint source of each column.
DETECTORS = (
    ("defaults", lambda g: hopmatch.DericheMoravecDetector.create().detect_points(g)[0]),
    ("nms_size 9", lambda g: hopmatch.DericheMoravecDetector.create(nms_size=9)
     .detect_points(g)[0]),
    ("nms_size 15", lambda g: hopmatch.DericheMoravecDetector.create(nms_size=15)
     .detect_points(g)[0]),
    ("max_features 2000", lambda g: hopmatch.DericheMoravecDetector.create(
        max_features=2000).detect_points(g)[0]),
    ("SIFT", lambda g: cv2.KeyPoint_convert(cv2.SIFT_create().detect(g, None))),
    ("ORB(3000)", lambda g: cv2.KeyPoint_convert(cv2.ORB_create(3000).detect(g, None))),
)


def cell(points, config) -> str:
    points = np.asarray(points, dtype=np.float32).reshape(-1, 2)
    if len(points) < 2:
        return f"{len(points)}:-"
    median = median_neighbours(points, config.neighbour_width, config.neighbour_height, 1000)
    _, factor = grown_for_density(config, points)
    return f"{len(points)}:{median:g}" + (f" (x{factor:.2f})" if factor > 1.0 else "")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", help="scene names (default: all available)")
    args = add_smoke_option(ap).parse_args(argv)
    single_thread()
    names = args.scenes or (["motorcycle"] if args.smoke else datasets.list_scenes())
    config = matcher_config({})
    print("## Keypoints : median neighbours in the 40 x 20 px window (x growth with "
          "min_neighbours=8)\n")
    print("| scene | " + " | ".join(label for label, _ in DETECTORS) + " |")
    print("|---" * (len(DETECTORS) + 1) + "|")
    for name in names:
        scene = datasets.load(name)
        if args.smoke:
            scene = smoke_scene(scene)
        grey = scene.left if scene.left.ndim == 2 else cv2.cvtColor(scene.left,
                                                                  cv2.COLOR_RGB2GRAY)
        print(f"| {name} | " + " | ".join(cell(detect(grey), config)
                                          for _, detect in DETECTORS) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
