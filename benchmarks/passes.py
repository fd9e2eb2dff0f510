"""Per-scene quality of match_stereo's defaults, pass by pass, against ground truth.

Run: ``python benchmarks/passes.py [--scenes NAME ...] [--perturb NAME ...] [--params JSON]
[--guided JSON] [--halves JSON] [--baselines] [--ranking] [--grid] [--refine-radius N]
[--both-features] [--both JSON] [--timing N] [--smoke]``

For every scene (motorcycle and, with ``../shared/data`` or ``HOPMATCH_SHARED_DATA``, every
scene there) it prints: matches, correct@1px and precision@1px
(:func:`hopmatch.evaluate.score_matches`), the same for each pass of ``result.passes``
when the result has them (0 network, 1 guided), the median absolute disparity error of the
correct matches (ground truth interpolated bilinearly at the sub-pixel left point, where its
four pixels are known: meaningful on the float ground truth of the 2014 scenes), and the
seconds of ``match_stereo`` (single thread). ``--baselines`` adds SIFT + ratio + band and
StereoSGBM sampled at the same left keypoints (``hopmatch.compare``), and the pooled ratio,
run on the same pair as hopmatch (with ``--perturb``, the perturbed one, their points
mapped back alike; until 2026-12-06 on the pair as shipped).
``--grid`` adds, per scene and pooled, how many of the wrong matches have a disparity
within 0.5 px of a nonzero multiple of 8 px (where JPEG's block grid, at the same place in
both views, puts them; docs/robustness.md, "JPEG, noise and blur"), and per scene each
image's strongest phase of grey-level steps along x and y with its ratio to the others'
(:func:`grid_strengths`).
``--ranking`` adds, per scene and pooled, the precision@1px of the best k % of the matches
by ``result.distances`` (k = 10, 20, 30, 50, 70, 90, 100; scored matches only), which a
confidence that ranks keeps (near) non-increasing in k.

``--guided`` sets module constants of :mod:`hopmatch.matching.guided` first (e.g.
``'{"GUIDED_SEED_ROUNDS": 0}'``; ``PLANE_PASS_*`` ones of :mod:`hopmatch.matching.plane_pass`,
the plane pass, other ``PLANE_*`` ones of :mod:`hopmatch.matching.planes`, the seeds'
receding planes), to measure the guided pass's settings one at a time;
``--halves`` those of :mod:`hopmatch.matching.halves` (``'{"HALF_CHECK": false}'``: without
the half-window test).

``--perturb`` applies a change to the right image before matching and maps the right
points back through it before scoring: ``dy0.5`` (shifted down by 0.5 px), ``dx20``
(shifted right by 20 px: every disparity 20 px smaller, the farther ones negative, as a
rectification that leaves the principal points apart gives them), ``gain0.7``
(intensities times 0.7), ``vig0.4`` (vignetting: times ``1 - 0.4 r^2``, r = 1 at the
corners), ``gamma1.5`` (``255 (I / 255) ** 1.5``), ``noise3`` (Gaussian noise of sigma 3
grey levels, seed 0), ``blur1`` (a Gaussian blur of sigma 1 px), ``jpeg75`` (saved as a JPEG
of quality 75 and read back), ``rot0.1`` (rotated 0.1 degree about the centre),
``scale0.999``, ``crop0.05`` (its right-most 5 % of columns cut off: a right view of
another width, applied last), ``top6`` (its top 6 rows cut off: a right view of another
height, applied last), or any combination joined by ``+``. ``lr-`` before
``noise``, ``blur`` or ``jpeg`` (``lr-jpeg75``...) applies that change to the left image as
well (its noise drawn with seed 1): the two views of one camera saved alike. ``left-``
before ``dy``, ``dx``, ``rot`` or ``scale`` (``left-rot3``) moves the left view instead,
its points mapped back before scoring too; before a grey-level change (``left-gain1.3``)
it changes the left view instead (noise with seed 1). ``size0.6`` resizes the whole scene
first (both views with ``cv2.INTER_AREA``, ``cv2.INTER_LINEAR`` when enlarging, the ground
truth to the same size with
``cv2.INTER_NEAREST`` and its disparities times 0.6), so that it is scored at that size,
as a data set shipped at that resolution would be: the held-out scenes come in sizes the
shared ones do not (Middlebury 2003 at quarter size, 450 x 375...). ``mirror`` makes a
scene nobody tuned on out of one that ships the right view's ground truth
(``disparity_right``; the other scenes are skipped): the left view is the right one
mirrored, the right view the left one mirrored, the truth the right view's mirrored (a
left-camera view of the mirrored world), applied first.

``--smoke``: motorcycle's centre crop only (figures mean nothing).

``--refine-radius N`` refines with that window half-side on every scene instead of the
size rule (``hopmatch.matching.stereo_match.refine_radius``; docs/parameters.md,
"Refinement window and image size").

``--both-features`` matches with ``both_features=True`` (the pair matched on the gradient
and again on grey levels, :mod:`hopmatch.matching.both_features`; the added matches are
passes 2 and 3; the default since 2026-12-07, so that the flag matters only after
``--params`` turned it off: ``--params '{"both_features": false}'`` is the single run);
``--both JSON`` sets that module's constants first (``'{"MIN_SUPPORT":
0}'``: every far match of the second run added, without the support test). With
``--baselines`` SGBM is then sampled at the left points of both runs (the second's farther
than ``SEPARATION`` px from the first's). docs/parameters.md, "Points on both feature
images".

``--timing N`` adds, per scene (unperturbed), what ``--guided`` costs: ``match_stereo``
run N times with the module's own constants and N times with ``--guided``'s, interleaved
in one process, timed by ``time.thread_time`` (one thread: a loaded machine's other
processes count less than in wall time); it prints the medians of both, of the guided
pass's share (the thread time of ``hopmatch.matching.guided.guided_rounds`` within them)
and of the paired differences.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import warnings
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import (  # noqa: E402
    add_refine_radius_option,
    add_smoke_option,
    as_jpeg,
    force_refine_radius,
    single_thread,
    smoke_scene,
)

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.compare import METHODS  # noqa: E402
from hopmatch.compare.methods import sgbm_uniqueness  # noqa: E402
from hopmatch.evaluate import score_matches  # noqa: E402
from hopmatch.feature import blocking  # noqa: E402
from hopmatch.matching import (  # noqa: E402
    both_features,
    guided,
    halves,
    plane_pass,
    planes,
)


def points_of_both(res) -> np.ndarray:
    """The left points of both runs of a ``both_features`` result: the first run's, and the
    second's farther than ``SEPARATION`` px from every one of them."""
    first = res.points_left[:len(res.points_left) - len(res.second.points_left)]
    return both_features.points_of_both(first, res.second.points_left)


def bilinear_gt(points: np.ndarray, disparity: np.ndarray) -> np.ndarray:
    """Ground truth interpolated bilinearly at each (x, y); NaN unless all four pixels are
    known."""
    h, w = disparity.shape
    x = points[:, 0].astype(np.float64)
    y = points[:, 1].astype(np.float64)
    x0 = np.floor(x).astype(np.intp)
    y0 = np.floor(y).astype(np.intp)
    out = np.full(len(points), np.nan)
    ok = (x0 >= 0) & (y0 >= 0) & (x0 + 1 < w) & (y0 + 1 < h)
    ax, ay = x[ok] - x0[ok], y[ok] - y0[ok]
    a, b = y0[ok], x0[ok]
    out[ok] = ((1 - ay) * ((1 - ax) * disparity[a, b] + ax * disparity[a, b + 1])
               + ay * ((1 - ax) * disparity[a + 1, b] + ax * disparity[a + 1, b + 1]))
    return out


def perturbation(spec: str, shape) -> np.ndarray:
    """2 x 3 affine matrix of a ``+``-joined perturbation spec (see the module doc); gain
    is handled by :func:`perturb`."""
    h, w = shape[:2]
    m = np.eye(3)
    for part in spec.split("+"):
        if not part:  # no perturbation
            continue
        if part.startswith("left-"):  # the left view's (:func:`perturb_left`)
            if not part[5:].startswith(("dy", "dx", "rot", "scale") + GREY_CHANGES):
                raise SystemExit(f"left- applies to dy, dx, rot, scale and the grey-level "
                                 f"changes only, got {part!r}")
            perturbation(part[5:], shape)
        elif part.startswith("dy"):
            m = np.array([[1, 0, 0], [0, 1, float(part[2:])], [0, 0, 1]]) @ m
        elif part.startswith("dx"):
            m = np.array([[1, 0, float(part[2:])], [0, 1, 0], [0, 0, 1]]) @ m
        elif part.startswith("rot") or part.startswith("scale"):
            angle = float(part[3:]) if part.startswith("rot") else 0.0
            scale = float(part[5:]) if part.startswith("scale") else 1.0
            r = np.vstack([cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), angle, scale),
                           [0, 0, 1]])
            m = r @ m
        elif part.startswith("crop"):
            if not 0.0 <= float(part[4:]) < 1.0:
                raise SystemExit(f"crop takes a fraction of the width in [0, 1), got {part!r}")
        elif part.startswith("top"):
            if not 0 <= int(part[3:]) < h:
                raise SystemExit(f"top takes a number of rows below the height, got {part!r}")
        elif part == "mirror":
            continue
        elif part.startswith("size"):
            if not 0.05 <= float(part[4:]) <= 4.0:
                raise SystemExit(f"size takes a factor in [0.05, 4], got {part!r}")
        elif not part.removeprefix("lr-").startswith(GREY_CHANGES):
            raise SystemExit(f"unknown perturbation {part!r}")
        elif part.startswith("lr-") and not part.startswith(LEFT_TOO):
            raise SystemExit(f"lr- applies to {', '.join(LEFT_TOO)} only, got {part!r}")
    return m


#: The perturbations that change grey levels only (the others move the right image), and
#: those of them that ``lr-`` may apply to the left image too.
GREY_CHANGES = ("gain", "vig", "gamma", "noise", "blur", "jpeg")
LEFT_TOO = ("lr-noise", "lr-blur", "lr-jpeg")


def grey_change(image: np.ndarray, part: str, seed: int) -> np.ndarray:
    """``image`` (uint8) changed by one grey-level perturbation ``part`` (no ``lr-``)."""
    if part.startswith("gain"):
        return np.clip(image.astype(np.float32) * float(part[4:]), 0, 255).astype(np.uint8)
    if part.startswith("vig"):  # vignetting: 1 - k r^2, r = 1 at the corners
        h, w = image.shape[:2]
        yy, xx = np.mgrid[:h, :w].astype(np.float32)
        r2 = ((xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2
                                                                   + ((h - 1) / 2) ** 2)
        fall = 1.0 - float(part[3:]) * r2
        return np.clip(image.astype(np.float32) * (fall if image.ndim == 2 else fall[..., None]),
                       0, 255).astype(np.uint8)
    if part.startswith("gamma"):
        return np.clip(255.0 * (image.astype(np.float32) / 255.0) ** float(part[5:]), 0,
                       255).astype(np.uint8)
    if part.startswith("noise"):
        noise = np.random.default_rng(seed).normal(0.0, float(part[5:]), image.shape)
        return np.clip(image.astype(np.float32) + noise, 0, 255).astype(np.uint8)
    if part.startswith("blur"):
        return cv2.GaussianBlur(image, (0, 0), float(part[4:]))
    if part.startswith("jpeg"):
        return as_jpeg(image, int(part[4:]))
    return image


def perturb(right: np.ndarray, spec: str):
    """``(perturbed right image, 3 x 3 matrix mapping original right (x, y) to it)``."""
    m = perturbation(spec, right.shape)
    out = right
    if not np.allclose(m, np.eye(3)):
        out = cv2.warpAffine(right, m[:2], right.shape[1::-1], flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REFLECT)
    for part in spec.split("+"):
        out = grey_change(out, part.removeprefix("lr-"), seed=0)
    for part in spec.split("+"):
        if part.startswith("crop"):
            out = np.ascontiguousarray(out[:, :out.shape[1] - int(round(float(part[4:])
                                                                     * out.shape[1]))])
        elif part.startswith("top"):  # rows cut off the top: right y smaller by that much
            out = np.ascontiguousarray(out[int(part[3:]):])
            m = np.array([[1, 0, 0], [0, 1, -float(part[3:])], [0, 0, 1]]) @ m
    return out, m


def perturb_left(left: np.ndarray, spec: str):
    """``(the left image with the left- and lr- parts of spec applied, 3 x 3 matrix
    mapping original left (x, y) to it)``: ``left-rot3`` (``left-dy2``...) moves the left
    view as ``rot3`` moves the right one, ``left-gain1.3`` (``left-`` before a grey-level
    change) changes the left view alone; ``lr-`` and ``left-`` grey changes draw their
    noise with seed 1."""
    m = perturbation("+".join(p[5:] for p in spec.split("+") if p.startswith("left-")),
                     left.shape)
    if not np.allclose(m, np.eye(3)):
        left = cv2.warpAffine(left, m[:2], left.shape[1::-1], flags=cv2.INTER_LINEAR,
                              borderMode=cv2.BORDER_REFLECT)
    for part in spec.split("+"):
        if part.startswith(("lr-", "left-")):
            left = grey_change(left, part.removeprefix("lr-").removeprefix("left-"), seed=1)
    return left, m


def mirrored_scene(scene):
    """``scene`` with its views swapped and mirrored left to right, its truth the right
    view's mirrored (``mirror`` in the module doc); None without ``disparity_right``."""
    if scene.disparity_right is None:
        return None
    flip = np.ascontiguousarray
    return dataclasses.replace(scene, left=flip(scene.right[:, ::-1]),
                               right=flip(scene.left[:, ::-1]),
                               disparity=flip(scene.disparity_right[:, ::-1]),
                               disparity_right=flip(scene.disparity[:, ::-1]),
                               disparity_all=None, nonoccluded_mask=None)


def resized_scene(scene, spec: str):
    """``scene`` resized by the ``size`` part of ``spec`` (the module doc), or as it is."""
    for part in spec.split("+"):
        if part.startswith("size"):
            f = float(part[4:])
            h, w = scene.left.shape[:2]
            size = (max(1, round(w * f)), max(1, round(h * f)))
            def resize(im):
                return cv2.resize(im, size, interpolation=cv2.INTER_AREA if f < 1
                                  else cv2.INTER_LINEAR)
            gt = cv2.resize(scene.disparity.astype(np.float32), size,
                            interpolation=cv2.INTER_NEAREST) * np.float32(size[0] / w)
            # the other truths are not resized: none of them is left at the old size
            return dataclasses.replace(scene, left=resize(scene.left),
                                       right=resize(scene.right), disparity=gt,
                                       disparity_right=None, disparity_all=None,
                                       nonoccluded_mask=None)
    return scene


def unmap(points: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Points of the perturbed right image mapped back to the original one."""
    inv = np.linalg.inv(m)
    hom = np.c_[points.astype(np.float64), np.ones(len(points))]
    return (hom @ inv.T)[:, :2].astype(np.float32)


def score(left, right, disparity):
    """``(matches, correct, precision, median |error| of correct matches, errors)``."""
    sc = score_matches(left, right, disparity, thresholds=(1.0,))
    if len(left) == 0:
        return 0, 0, float("nan"), float("nan")
    gt = bilinear_gt(left, disparity)
    err = (left[:, 0].astype(np.float64) - right[:, 0]) - gt
    dy = np.abs(left[:, 1] - right[:, 1])
    good = np.isfinite(err) & (np.abs(err) <= 1.0) & (dy <= 1.0)
    med = float(np.median(np.abs(err[good]))) if good.any() else float("nan")
    return len(left), sc.correct[1.0], sc.precision[1.0], med


def scored_correct(left, right, disparity):
    """``(score, correct)``: :func:`hopmatch.evaluate.score_matches` at 1 px and, per scored
    match, whether its disparity error and its ``|dy|`` are both within 1 px."""
    sc = score_matches(left, right, disparity, thresholds=(1.0,))
    dy = np.abs(left[sc.scored, 1] - right[sc.scored, 1])
    return sc, (np.abs(sc.errors) <= 1.0) & (dy <= 1.0)


def grid_locked(left, right, disparity) -> tuple[int, int]:
    """``(wrong matches whose disparity is within 0.5 px of a nonzero multiple of 8 px,
    wrong matches)``, wrong as :func:`score` counts them (scored, not correct at 1 px)."""
    sc, ok = scored_correct(left, right, disparity)
    wrong = ~ok
    d = (left[sc.scored, 0].astype(np.float64) - right[sc.scored, 0])[wrong]
    k = np.round(d / 8.0)
    return int(((k != 0) & (np.abs(d - 8.0 * k) <= 0.5)).sum()), int(wrong.sum())


def grid_strengths(image: np.ndarray) -> str:
    """``'p:r/q:s'``: along x then y, the phase modulo 8 with the largest mean grey-level
    step (:func:`hopmatch.feature.blocking.phase_steps`) and that step over the mean of the
    other seven phases' (a JPEG block grid when both reach ``blocking.GATE``)."""
    gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    cells = []
    for axis in (1, 0):
        steps = blocking.phase_steps(gray, axis)
        p = int(np.argmax(steps))
        cells.append(f"{p}:{steps[p] / ((steps.sum() - steps[p]) / 7):.2f}")
    return "/".join(cells)


#: The fractions of the matches, best first by distance, that ``--ranking`` scores.
RANK_FRACTIONS = (0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0)


def best_k_correct(distances, left, right, disparity):
    """``(correct flags, distances)`` of the scored matches, sorted by distance (stable)."""
    sc, ok = scored_correct(left, right, disparity)
    dist = np.asarray(distances)[sc.scored]
    order = np.argsort(dist, kind="stable")
    return ok[order], dist[order]


def precision_of_best(flags) -> list:
    """Precision of the best ``k`` of sorted correct ``flags``, k of :data:`RANK_FRACTIONS`."""
    n = len(flags)
    return [float(np.mean(flags[:max(1, round(f * n))])) if n else float("nan")
            for f in RANK_FRACTIONS]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", help="scene names (default: all available)")
    ap.add_argument("--perturb", nargs="*", default=[""], help="right-image perturbations")
    ap.add_argument("--params", default="{}", help="match_stereo parameters (JSON object)")
    ap.add_argument("--guided", default="{}",
                    help="constants of hopmatch.matching.guided to set (JSON object)")
    ap.add_argument("--halves", default="{}",
                    help="constants of hopmatch.matching.halves to set (JSON object)")
    ap.add_argument("--baselines", action="store_true", help="also SIFT and SGBM")
    ap.add_argument("--ranking", action="store_true",
                    help="also the precision of the best k %% by distance")
    ap.add_argument("--grid", action="store_true",
                    help="also the wrong matches at a disparity within 0.5 px of a nonzero "
                         "multiple of 8 px (JPEG's block grid)")
    ap.add_argument("--both-features", action="store_true",
                    help="match with both_features=True (both feature images)")
    ap.add_argument("--both", default="{}",
                    help="constants of hopmatch.matching.both_features to set (JSON object)")
    ap.add_argument("--timing", type=int, default=0,
                    help="also time --guided against the module's constants (N runs each)")
    args = add_smoke_option(add_refine_radius_option(ap)).parse_args(argv)
    single_thread()
    force_refine_radius(args.refine_radius)
    params = json.loads(args.params)
    if args.both_features:
        params["both_features"] = True
    for name, value in json.loads(args.both).items():
        if not (name.isupper() and hasattr(both_features, name)):
            raise SystemExit(f"--both: hopmatch.matching.both_features has no constant {name!r}")
        setattr(both_features, name, value)
    own = {}
    for name, value in json.loads(args.guided).items():
        module = constants_of(name)
        if module is None:
            raise SystemExit(f"--guided: hopmatch.matching.guided has no constant {name!r} "
                             "(nor hopmatch.matching.plane_pass or planes)")
        own[name] = getattr(module, name)
        setattr(module, name, value)
    for name, value in json.loads(args.halves).items():
        if not (name.startswith("HALF_") and hasattr(halves, name)):
            raise SystemExit(f"--halves: hopmatch.matching.halves has no constant {name!r}")
        setattr(halves, name, value)
    names = ["motorcycle"] if args.smoke else (args.scenes or datasets.list_scenes())
    if args.timing > 0:
        print_timing(names, params, own, json.loads(args.guided), args.timing)
    for spec in args.perturb:
        print(f"## perturbation: {spec or 'none'}; params {params or 'defaults'}"
              + (f"; both feature images {args.both}" if args.both_features else "")
              + (f"; guided {args.guided}" if args.guided != "{}" else "")
              + (f"; halves {args.halves}" if args.halves != "{}" else ""))
        print("scene | matches | correct | precision | med err | by pass (n/correct/prec/med)"
              " | ms" + (" | SIFT | SGBM" if args.baselines else ""))
        tot = {"m": 0, "c": 0, "s": 0, "sift": 0, "sgbm": 0}
        ran = 0
        worst = (float("nan"), "")  # the lowest precision and its scene
        ranked = []
        for n in names:
            scene = smoke_scene(datasets.load(n)) if args.smoke else datasets.load(n)
            if "mirror" in spec.split("+"):
                scene = mirrored_scene(scene)
                if scene is None:
                    continue
            scene = resized_scene(scene, spec)
            ran += 1
            right, m = perturb(scene.right, spec) if spec else (scene.right, np.eye(3))
            left, m_left = perturb_left(scene.left, spec)
            with warnings.catch_warnings():  # a 64 x 64 crop, to compile: warns of nothing real
                warnings.simplefilter("ignore", hopmatch.errors.HopmatchWarning)
                hopmatch.match_stereo(left[:64, :64], right[:64, :64], **params)
            t0 = time.perf_counter()
            res = hopmatch.match_stereo(left, right, **params)
            secs = time.perf_counter() - t0
            left_pts, right_pts = unmap(res.matched_left, m_left), unmap(res.matched_right, m)
            k, c, p, med = score(left_pts, right_pts, scene.disparity)
            sc = score_matches(left_pts, right_pts, scene.disparity, thresholds=(1.0,))
            tot["m"] += k
            tot["c"] += c
            tot["s"] += sc.n_scored
            if np.isfinite(p) and (not worst[1] or p < worst[0]):
                worst = (p, n)
            passes = getattr(res, "passes", None)
            cells = []
            if passes is not None:
                for v in np.unique(passes):
                    sel = passes == v
                    kk, cc, pp, mm = score(left_pts[sel], right_pts[sel], scene.disparity)
                    cells.append(f"{v}: {kk}/{cc}/{pp:.3f}/{mm:.3f}")
            row = (f"{n} | {k} | {c} | {p:.3f} | {med:.3f} | {'; '.join(cells)} | "
                   f"{1000 * secs:.0f}")
            if args.baselines:  # on the same (perturbed) pair, scored as hopmatch is
                pair = dataclasses.replace(scene, left=left, right=right)
                cs, cg = (score_matches(unmap(b.left_pts, m_left), unmap(b.right_pts, m),
                                        scene.disparity).correct[1.0]
                          for b in (METHODS["sift-ratio"](pair),
                                    sgbm_uniqueness(pair, 10, points_of_both(res))
                                    if res.second is not None else METHODS["sgbm"](pair)))
                tot["sift"] += cs
                tot["sgbm"] += cg
                row += f" | {cs}{'' if c >= cs else ' (miss)'} | {cg}"
            if args.grid:
                locked, wrong = grid_locked(left_pts, right_pts, scene.disparity)
                tot["locked"] = tot.get("locked", 0) + locked
                tot["wrong"] = tot.get("wrong", 0) + wrong
                row += (f" | grid-locked {locked} of {wrong} wrong | steps by phase: left "
                        f"{grid_strengths(left)}, right {grid_strengths(right)}")
            print(row, flush=True)
            if args.ranking:
                flags, dist = best_k_correct(res.distances, left_pts, right_pts,
                                             scene.disparity)
                ranked.append((flags, dist))
                print(f"  best k by distance ({'/'.join(f'{f:.0%}' for f in RANK_FRACTIONS)}):"
                      f" {' '.join(f'{p:.3f}' for p in precision_of_best(flags))}", flush=True)
        if ranked:
            # pooled: every scene's matches at its own rank fraction, merged by that fraction
            frac = np.concatenate([(np.arange(len(f)) + 0.5) / max(len(f), 1)
                                   for f, _ in ranked])
            flags = np.concatenate([f for f, _ in ranked])
            dist = np.concatenate([d for _, d in ranked])
            by_rank = precision_of_best(flags[np.argsort(frac, kind="stable")])
            by_dist = precision_of_best(flags[np.argsort(dist, kind="stable")])
            print(f"pooled best k by rank within each scene: "
                  f"{' '.join(f'{p:.4f}' for p in by_rank)}; by distance: "
                  f"{' '.join(f'{p:.4f}' for p in by_dist)}", flush=True)
        if not ran:  # every scene skipped (mirror: none ships the right view's truth)
            print("pooled: no scene (mirror needs a scene with disparity_right)\n", flush=True)
            continue
        pooled = tot["c"] / tot["s"] if tot["s"] else float("nan")
        line = (f"pooled: {tot['m']} matches, {tot['c']} correct, precision {pooled:.4f}, "
                f"worst {worst[0]:.3f} ({worst[1]})")
        if args.baselines:
            line += f"; SIFT {tot['sift']}, SGBM {tot['sgbm']} ({tot['c'] / tot['sgbm']:.2f}x)"
        if args.grid:
            line += f"; grid-locked {tot.get('locked', 0)} of {tot.get('wrong', 0)} wrong"
        print(line + "\n", flush=True)
    return 0


def constants_of(name: str):
    """The module whose constant ``--guided`` names: :mod:`hopmatch.matching.guided` for
    ``GUIDED_*``, :mod:`hopmatch.matching.plane_pass` for ``PLANE_PASS_*`` (the plane
    pass), :mod:`hopmatch.matching.planes` for the other ``PLANE_*`` (the seeds' receding
    planes); None when it has no such constant."""
    for prefix, module in (("GUIDED_", guided), ("PLANE_PASS_", plane_pass),
                           ("PLANE_", planes)):
        if name.startswith(prefix) and hasattr(module, name):
            return module
    return None


def print_timing(names, params, own: dict, changed: dict, runs: int) -> None:
    """The ``--timing`` lines: per scene, ``match_stereo`` with the constants ``own`` (the
    module's) and ``changed`` (``--guided``'s), ``runs`` interleaved runs each after one
    of each to warm up; medians of thread time, of the guided pass and of the paired
    differences (``changed`` minus ``own``), in ms."""
    print(f"## timing: --guided {json.dumps(changed)} against the module's "
          f"{json.dumps(own)}, {runs} interleaved runs each (thread time, one thread)")
    from hopmatch.matching import stereo_match

    rounds = stereo_match.guided_rounds
    spent = []

    def timed_rounds(*a, **k):
        t0 = time.thread_time()
        try:
            return rounds(*a, **k)
        finally:
            spent.append(time.thread_time() - t0)

    stereo_match.guided_rounds = timed_rounds
    for n in names:
        scene = datasets.load(n)
        times = {"own": [], "changed": []}
        guided_ms = {"own": [], "changed": []}
        for k in range(runs + 1):
            for label, values in (("own", own), ("changed", changed)):
                for name, value in values.items():
                    setattr(constants_of(name), name, value)
                spent.clear()
                t0 = time.thread_time()
                hopmatch.match_stereo(scene.left, scene.right, **params)
                if k:  # the first of each warms up
                    times[label].append(1000 * (time.thread_time() - t0))
                    guided_ms[label].append(1000 * sum(spent))
        diff = np.subtract(times["changed"], times["own"])
        print(f"{n}: match_stereo {np.median(times['own']):.1f} ms with the module's, "
              f"{np.median(times['changed']):.1f} ms with --guided (guided pass "
              f"{np.median(guided_ms['own']):.1f} / {np.median(guided_ms['changed']):.1f} "
              f"ms); paired difference: median {np.median(diff):+.1f} ms", flush=True)
    stereo_match.guided_rounds = rounds
    for name, value in changed.items():  # the table that follows runs with --guided's
        setattr(constants_of(name), name, value)
    print()


if __name__ == "__main__":
    sys.exit(main())
