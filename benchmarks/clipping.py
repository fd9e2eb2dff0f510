"""How much of what match_stereo loses to a brighter, clipped right view the clipping itself
destroys.

Run: ``python benchmarks/clipping.py [--gains 1.15 1.3] [--scenes NAME ...] [--smoke]``

For every scene (motorcycle and, with ``../shared/data`` or ``HOPMATCH_SHARED_DATA``, every
scene there; defaults, as ``benchmarks/passes.py`` runs them) and every gain g, the right
image is multiplied by g and clipped to 8 bits (``passes.py --perturb gainG``). Printed per
scene and gain: the fraction of the right image's pixels that clip (in any colour channel,
and in each of B, G and R);
the correct matches (1 px, :func:`hopmatch.evaluate.score_matches`) of the unperturbed pair;
of those, how many
keep a right window (the detector's descriptor size) with under 5 % clipped pixels at gain g
(*unclipped*: a rough measure of what the clipping leaves of them; windows clipped in part
still match now and then, and the clipped pair has other matches); and the correct matches
of the clipped pair. Then the pooled counts. Single thread. ``--smoke``:
motorcycle's centre crop only (figures mean nothing).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, single_thread, smoke_scene  # noqa: E402
from passes import perturb  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.evaluate import score_matches  # noqa: E402

#: A right window with at least this fraction of clipped pixels counts as destroyed.
CLIPPED_WINDOW = 0.05


def correct_flags(res, disparity) -> tuple[np.ndarray, np.ndarray]:
    """``(right points, correct flag)`` of each match of ``res`` at 1 px."""
    sc = score_matches(res.matched_left, res.matched_right, disparity, thresholds=(1.0,))
    ok = np.zeros(len(res.matched_left), dtype=bool)
    ok[sc.scored] = np.abs(sc.errors) <= 1.0
    dy = np.abs(res.matched_left[:, 1] - res.matched_right[:, 1])
    return res.matched_right, ok & (dy <= 1.0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gains", nargs="*", type=float, default=[1.15, 1.3])
    ap.add_argument("--scenes", nargs="*", help="scene names (default: all available)")
    args = add_smoke_option(ap).parse_args(argv)
    single_thread()
    names = ["motorcycle"] if args.smoke else (args.scenes or datasets.list_scenes())
    window = hopmatch.DericheMoravecDetector().getDescriptorSize()
    print("| scene | gain | right pixels clipped | B / G / R | correct unperturbed | "
          "of them unclipped | correct clipped |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    tot = np.zeros((len(args.gains), 3), dtype=np.int64)
    for n in names:
        scene = datasets.load(n)
        if args.smoke:
            scene = smoke_scene(scene)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", hopmatch.errors.HopmatchWarning)
            right_pts, ok = correct_flags(hopmatch.match_stereo(scene.left, scene.right),
                                          scene.disparity)
        h, w = scene.right.shape[:2]
        x = np.clip(np.round(right_pts[:, 0]).astype(int), 0, w - 1)
        y = np.clip(np.round(right_pts[:, 1]).astype(int), 0, h - 1)
        for k, g in enumerate(args.gains):
            right, _ = perturb(scene.right, f"gain{g:g}")
            clipped = (right >= 255) & (scene.right < 255)
            channels = ("-" if clipped.ndim == 2 else  # each colour channel's share
                        " / ".join(f"{clipped[..., c].mean():.0%}" for c in range(3)))
            clipped = clipped if clipped.ndim == 2 else clipped.any(axis=2)  # any channel
            share = cv2.blur(clipped.astype(np.float32), (window, window))
            unclipped = ok & (share[y, x] < CLIPPED_WINDOW)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", hopmatch.errors.HopmatchWarning)
                _, ok_g = correct_flags(hopmatch.match_stereo(scene.left, right),
                                        scene.disparity)
            cells = (int(ok.sum()), int(unclipped.sum()), int(ok_g.sum()))
            tot[k] += cells
            print(f"| {n} | {g:g} | {clipped.mean():.1%} | {channels} | "
                  + " | ".join(map(str, cells)) + " |", flush=True)
    for k, g in enumerate(args.gains):
        print(f"pooled, gain {g:g}: {tot[k, 0]} correct unperturbed, {tot[k, 1]} of them with "
              f"an unclipped right window, {tot[k, 2]} correct on the clipped pair")
    return 0


if __name__ == "__main__":
    sys.exit(main())
