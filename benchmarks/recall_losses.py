"""Where match_stereo loses the left keypoints that StereoSGBM gets right, stage by stage.

Run: ``python benchmarks/recall_losses.py [--scenes NAME ...] [--perturb SPEC] [--guided JSON]
[--oracle-prediction] [--continuity-support] [--smoke]``

For every scene (motorcycle and, with ``../shared/data`` or ``HOPMATCH_SHARED_DATA``, every
scene there; defaults, as ``benchmarks/passes.py`` runs them) it takes the left keypoints
with ground truth that ``cv2.StereoSGBM`` sampled at them (``hopmatch.compare``'s ``sgbm``)
gets right (``|d - gt| <= 1``, :func:`hopmatch.evaluate.score_matches`), and of those that
``match_stereo`` leaves unmatched (*lost*) says where each was lost:

*network* (first table): ``no right kp``: no detected right keypoint lies within 1 px (x
and y, along the row the vertical model gives) of its true position, so the network cannot
match it; ``no candidate``: one does, but the network has no neuron for the pair (outside
the band or the disparity range, or the similarity gate); ``net said no``: the neuron is
there and ends inactive; ``sec. 4``: it ends active but the uniqueness, vertical or shift
checks after the network drop it; ``half-win net`` / ``half-win guided``: the network or
the guided pass matched it and the half-window test (:mod:`hopmatch.matching.halves`)
dropped it. Beside them, ``wrong``: left keypoints SGBM gets right that hopmatch matches
wrongly (not lost, but not correct either).

*guided pass* (second table), for the lost points no pass matched: the first test of
:func:`hopmatch.matching.guided.guided_search` that stops each, run once more on every
match found (network and guided, before the refinement) with the loosest settings any
round has (round 0's margin and field, the last round's window, the grey-level fallback
of ``match_stereo``'s defaults: a point G's search leaves weak counts at G's stage
unless the grey levels found a peak): ``few neighbours``,
``outside image``, ``flat window``, ``off prediction`` (split by whether the prediction
was within 1 px of the truth: ``off pred (pred ok)`` means the ZNCC peaks elsewhere
although the search was centred right), ``not a peak``, ``low ZNCC``, ``uniqueness
margin``, ``left-right check``, ``continuity``; and ``later rounds``: points that pass
those loosest settings but not the later rounds' (margin ``GUIDED_LATER_MARGIN``, field
``GUIDED_LATER_FIELD``), each counted again under the later settings' stage in
brackets... kept simple: ``later: margin`` and ``later: field``, or ``later: accepted``
(the rounds stopped before reaching it).

Last, hopmatch's pooled precision (correct of scored matches, as ``passes.py``).

``--oracle-prediction``: the guided rounds' predicted disparity at each left point (the
local plane of its matched neighbours) is replaced by the ground truth there
(:func:`passes.bilinear_gt`, where known), in every pass; what is then lost is lost to
the tests, not to the prediction.

``--continuity-support`` adds what the continuity test (the field, eq. 12) refuses: every
guided candidate the field left at or below 0 (a peak found, the field against it) whose
left point ends unmatched and has ground truth, with whether its disparity was right
(within 1 px of :func:`passes.bilinear_gt`), pooled over the scenes; then the precision
those candidates would have if a candidate were accepted on the support of its own surface
alone: the *group* being its matched neighbours (those the field counted, carried along
the local plane as the field does) whose disparity lies within 1 px of the candidate's,
accepted when the group has at least k members and at least a share f of the neighbours
(on the pair as shipped and with the defaults' own predictions, whatever ``--perturb`` and
``--oracle-prediction`` say).

``--guided`` sets module constants of :mod:`hopmatch.matching.guided` first, as in
``passes.py``. ``--perturb SPEC`` changes hopmatch's right image as ``passes.py
--perturb`` does (``vig0.4``, ``gain0.6``, ``rot0.3+dy1.5``...; SGBM still runs on the
unperturbed pair, so the lost points are the same ones): true right positions are mapped
into the perturbed image, matches back out of it before scoring. ``--smoke``: motorcycle's
centre crop only (figures mean nothing).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, single_thread, smoke_crop  # noqa: E402
from passes import bilinear_gt, perturb, unmap  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.compare import METHODS  # noqa: E402
from hopmatch.evaluate import correct_matches, score_matches  # noqa: E402
from hopmatch.feature.detector import DericheMoravecDetector  # noqa: E402
from hopmatch.matching import guided, guided_results  # noqa: E402
from hopmatch.matching.params import matcher_config  # noqa: E402
from hopmatch.matching.similarity import similarity_distance  # noqa: E402
from hopmatch.matching.stereo_match import (  # noqa: E402
    PASS_NETWORK,
    grey_fallback,
    match_detected,
)

NETWORK_COLUMNS = ("no right kp", "no candidate", "net said no", "sec. 4", "half-win net",
                   "half-win guided")
GUIDED_COLUMNS = (("few neighbours", "outside image", "flat window")
                  + ("off pred (pred wrong)", "off pred (pred ok)")
                  + ("not a peak", "low ZNCC", "uniqueness margin", "left-right check",
                     "continuity", "later: margin", "later: field", "later: accepted"))


def gt_at(points, disparity):
    """Ground truth at the nearest pixel of each point (NaN outside or unknown), as
    :func:`hopmatch.evaluate.score_matches` reads it."""
    h, w = disparity.shape
    x = np.floor(points[:, 0].astype(np.float64) + 0.5).astype(np.intp)
    y = np.floor(points[:, 1].astype(np.float64) + 0.5).astype(np.intp)
    out = np.full(len(points), np.nan)
    ok = (x >= 0) & (y >= 0) & (x < w) & (y < h)
    out[ok] = disparity[y[ok], x[ok]]
    out[~np.isfinite(out)] = np.nan
    return out


def correct_of(left, right, disparity):
    """(M,) bool: which matches are correct at 1 px (False where unscored)."""
    sc = score_matches(left, right, disparity, thresholds=(1.0,))
    ok, known = correct_matches(sc, left, right, 1.0)
    return ok & known


def index_of(points, query):
    """Row of ``points`` with exactly each (x, y) of ``query`` (-1 where none)."""
    key = {(float(x), float(y)): i for i, (x, y) in enumerate(points)}
    return np.array([key.get((float(x), float(y)), -1) for x, y in query], dtype=np.int64)


def detect(image):
    return DericheMoravecDetector().detect_and_describe(image, keep_gray=True)


def scene_losses(scene, spec=""):
    """``(counts of NETWORK_COLUMNS, counts of GUIDED_COLUMNS, lost, wrong, sgbm correct,
    hopmatch correct, keypoints with ground truth, hopmatch matches scored, seconds)`` of one
    pair, hopmatch's right image perturbed by ``spec`` (``passes.perturb``)."""
    t0 = time.perf_counter()
    right, warp = perturb(scene.right, spec) if spec else (scene.right, np.eye(3))
    found_l, found_r = detect(scene.left), detect(right)
    size = float(DericheMoravecDetector().getWindowSize())
    full = match_detected(found_l, found_r, matcher_config({}, "recall_losses"),
                          keypoint_size=size)
    raw = match_detected(found_l, found_r, matcher_config({"refine": False}, "recall_losses"),
                         keypoint_size=size)
    pts_l, _, desc_l, g_l, gray_l = found_l
    pts_r, _, desc_r, g_r, gray_r = found_r
    n_l = len(pts_l)
    disp = scene.disparity
    gt = gt_at(pts_l, disp)

    # SGBM at the same left keypoints
    sg = METHODS["sgbm"](scene)
    sgbm_ok = np.zeros(n_l, dtype=bool)
    if len(sg.left_pts):
        rows = index_of(pts_l, sg.left_pts)
        ok = correct_of(sg.left_pts, sg.right_pts, disp) & (rows >= 0)
        sgbm_ok[rows[ok]] = True

    def matched_correct(res):
        m = np.zeros(n_l, dtype=bool)
        c = np.zeros(n_l, dtype=bool)
        m[res.query_idx] = True
        c[res.query_idx] = correct_of(res.matched_left, unmap(res.matched_right, warp), disp)
        return m, c

    m_full, c_full = matched_correct(full)
    scored = score_matches(full.matched_left, unmap(full.matched_right, warp), disp,
                           thresholds=(1.0,)).n_scored
    m_raw, _ = matched_correct(raw)
    wrong = sgbm_ok & m_full & ~c_full
    lost = sgbm_ok & ~m_full
    net = raw.network
    on_net = np.zeros(n_l, dtype=bool)
    on_net[net.query_idx] = True
    half_net = lost & m_raw & on_net
    half_guided = lost & m_raw & ~on_net
    never = lost & ~m_raw

    # the network: is there a right keypoint at the true position, a neuron, an active one?
    offset = raw.row_offset.at(pts_l) if raw.row_offset is not None else np.zeros(n_l)
    true_x, true_y = pts_l[:, 0] - gt, pts_l[:, 1] - offset
    # where the perturbation put them (the identity when there is none)
    true_x, true_y = (np.c_[true_x, pts_l[:, 1], np.ones(n_l)] @ warp[:2].T).T
    order = np.argsort(pts_r[:, 1], kind="stable")
    ys = pts_r[order, 1]
    near_kp = np.zeros(n_l, dtype=bool)
    for i in np.flatnonzero(never):
        lo, hi = np.searchsorted(ys, [true_y[i] - 1.0, true_y[i] + 1.0 + 1e-6])
        cand = order[lo:hi]
        near_kp[i] = bool(np.any(np.abs(pts_r[cand, 0] - true_x[i]) <= 1.0))
    ni, nk = net.neuron_left.astype(np.int64), net.neuron_right.astype(np.int64)
    good = (np.abs(pts_r[nk, 0] - true_x[ni]) <= 1.0) & (np.abs(pts_r[nk, 1] - true_y[ni]) <= 1.0)
    has_neuron = np.bincount(ni[good], minlength=n_l) > 0
    has_active = np.bincount(ni[good & net.state], minlength=n_l) > 0
    no_kp = never & ~near_kp & ~has_neuron
    no_cand = never & ~no_kp & ~has_neuron
    said_no = never & has_neuron & ~has_active
    sec4 = never & has_active
    net_counts = [int(a.sum()) for a in (no_kp, no_cand, said_no, sec4, half_net, half_guided)]

    # the guided pass: what stops each never-matched point now, with every match as support
    config = net.config
    gm = raw.guided if raw.guided is not None else guided_results.empty_guided()
    qi, ti = raw.query_idx, raw.train_idx
    n_net = int(np.sum(raw.passes == PASS_NETWORK))
    msim = np.r_[similarity_distance(desc_l, desc_r, qi[:n_net].astype(np.int32),
                                     ti[:n_net].astype(np.int32),
                                     gain_tolerance=config.gain_tolerance), gm.similarity]
    window = (1.0 + guided.GUIDED_GROWTH) ** (max(int(guided.GUIDED_ROUNDS), 1) - 1)
    fallback = grey_fallback((gray_l, gray_r), (g_l, g_r), desc_l.shape[1])

    def stages(margin, min_field):
        s = guided.guided_search(pts_l, raw.points_right, desc_l, desc_r, g_l, g_r, qi, ti,
                                 offset, config, margin=margin, window=window,
                                 min_field=min_field, matched_similarity=msim,
                                 fallback=fallback)
        st = np.full(n_l, -1, dtype=np.int64)
        st[s.queries] = s.stage
        pred = np.full(n_l, np.nan)
        pred[s.queries] = s.predicted
        return st, pred

    loose, pred = stages(config.guided_margin, 0.0)
    strict, _ = stages(max(config.guided_margin, guided.GUIDED_LATER_MARGIN),
                       guided.GUIDED_LATER_FIELD)
    pred_ok = np.abs(pts_l[:, 0] - pred - true_x) <= 1.0
    g_counts = []
    for name in GUIDED_COLUMNS:
        if name.startswith("off pred"):
            sel = loose == guided_results.STAGE_OFF_PREDICTION
            sel &= pred_ok if name.endswith("(pred ok)") else ~pred_ok
        elif name.startswith("later: "):
            sel = loose == guided_results.STAGE_ACCEPTED
            sel &= strict == {"margin": guided_results.STAGE_MARGIN,
                              "field": guided_results.STAGE_CONTINUITY,
                              "accepted": guided_results.STAGE_ACCEPTED}[name[7:]]
        else:
            sel = loose == guided_results.GUIDED_STAGES.index(name)
        g_counts.append(int((never & sel).sum()))
    return (net_counts, g_counts, int(lost.sum()), int(wrong.sum()), int(sgbm_ok.sum()),
            int(c_full.sum()), int(np.isfinite(gt).sum()), int(scored),
            time.perf_counter() - t0)


@contextlib.contextmanager
def oracle_prediction(disparity):
    """Within the block, the guided rounds predict the ground truth ``disparity`` (read
    bilinearly at each query point, where known) instead of their neighbours' plane; the
    plane's gradient (the sheared windows, the field's slope) is kept."""
    planes = guided.neighbour_planes

    def truth_planes(queries, *args, **kwargs):
        pred, gx, gy = planes(queries, *args, **kwargs)
        truth = bilinear_gt(np.asarray(queries), disparity)
        known = np.isfinite(truth)
        return np.where(known, truth, pred), gx, gy

    guided.neighbour_planes = truth_planes
    try:
        yield
    finally:
        guided.neighbour_planes = planes


@contextlib.contextmanager
def refused_by_continuity(records: list):
    """Within the block, every call of the guided pass's field
    (``guided.continuity_fields``) appends to ``records`` one ``(left points, disparity,
    field, group, neighbours)`` tuple of arrays over the candidates it was given (those
    whose peak was found): the group being the neighbours whose disparity, carried along
    the call's gradient to the candidate, lies within 1 px of the candidate's."""
    fields = guided.continuity_fields

    def recorded(pts_q, xr, yr, sim_q, offsets, idx, rows, m_left, m_right, m_sim, theta,
                 slope, weight, bias, gx, gy, threads=None):
        u = fields(pts_q, xr, yr, sim_q, offsets, idx, rows, m_left, m_right, m_sim, theta,
                   slope, weight, bias, gx, gy, threads=threads)
        k = np.flatnonzero(np.isfinite(xr))
        d_q = pts_q[k, 0].astype(np.float64) - xr[k]
        group, size = np.zeros(len(k)), np.zeros(len(k))
        for t, q in enumerate(k):
            j = idx[offsets[rows[q]]:offsets[rows[q] + 1]]
            xj, yj = m_left[j, 0].astype(np.float64), m_left[j, 1].astype(np.float64)
            d_j = xj - m_right[j, 0] + gx[q] * (pts_q[q, 0] - xj) + gy[q] * (pts_q[q, 1] - yj)
            size[t], group[t] = len(j), np.count_nonzero(np.abs(d_j - d_q[t]) <= 1.0)
        records.append((pts_q[k].copy(), d_q, u[k], group, size))
        return u

    guided.continuity_fields = recorded
    try:
        yield
    finally:
        guided.continuity_fields = fields


def continuity_candidates(scene) -> np.ndarray:
    """``(group, neighbours, right)`` rows (float) of the candidates the field refused on
    ``scene`` (``--continuity-support``), each left point once (its first refusal)."""
    records = []
    with refused_by_continuity(records), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = hopmatch.match_stereo(scene.left, scene.right)
    matched = {(float(x), float(y)) for x, y in res.matched_left}
    seen, rows = set(), []
    for pts, d_q, u, group, size in records:
        truth = bilinear_gt(pts, scene.disparity)
        for i in np.flatnonzero((u <= 0.0) & np.isfinite(truth)):
            key = (float(pts[i, 0]), float(pts[i, 1]))
            if key in matched or key in seen:
                continue
            seen.add(key)
            rows.append((group[i], size[i], float(abs(d_q[i] - truth[i]) <= 1.0)))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def print_continuity_support(candidates: np.ndarray) -> None:
    group, size, right = candidates.T
    print(f"\n## continuity: {len(right)} candidates the field refused (left point never "
          f"matched, with ground truth), {int(right.sum())} of them right "
          f"({right.mean() if len(right) else float('nan'):.3f})")
    print("accepted on its own surface's support: group >= k | and >= f of the neighbours | "
          "candidates | right | precision")
    for f in (0.3, 0.5, 0.7):
        for k in (3, 5, 8):
            sel = (group >= k) & (group >= f * size)
            n = int(sel.sum())
            print(f"{k} | {f:g} | {n} | {int(right[sel].sum())} | "
                  f"{right[sel].mean() if n else float('nan'):.3f}")


def print_row(label, cells):
    print(f"{label} | " + " | ".join(str(c) for c in cells), flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", help="scene names (default: all available)")
    ap.add_argument("--perturb", default="", help="right-image perturbation (passes.py's)")
    ap.add_argument("--guided", default="{}",
                    help="constants of hopmatch.matching.guided to set (JSON object)")
    ap.add_argument("--oracle-prediction", action="store_true",
                    help="the guided rounds predict the ground truth (an upper bound)")
    ap.add_argument("--continuity-support", action="store_true",
                    help="also: how right the candidates the field refuses are, and on "
                    "their own surface's support alone")
    args = add_smoke_option(ap).parse_args(argv)
    single_thread()
    for name, value in json.loads(args.guided).items():
        if not (name.startswith("GUIDED_") and hasattr(guided, name)):
            raise SystemExit(f"--guided: hopmatch.matching.guided has no constant {name!r}")
        setattr(guided, name, value)
    names = ["motorcycle"] if args.smoke else (args.scenes or datasets.list_scenes())
    rows, refused = [], []
    for n in names:
        scene = datasets.load(n)
        if args.smoke:
            scene = dataclasses.replace(scene, left=smoke_crop(scene.left),
                                        right=smoke_crop(scene.right),
                                        disparity=smoke_crop(scene.disparity))
        with (oracle_prediction(scene.disparity) if args.oracle_prediction
              else contextlib.nullcontext()):
            rows.append((n, scene_losses(scene, args.perturb)))
        if args.continuity_support:  # the defaults' own predictions, whatever the options
            refused.append(continuity_candidates(scene))
    print("## network: where the lost points (SGBM right, hopmatch unmatched) were lost")
    print("scene | with gt | SGBM correct | hopmatch correct | lost | wrong | "
          + " | ".join(NETWORK_COLUMNS))
    tot = np.zeros(5 + len(NETWORK_COLUMNS), dtype=np.int64)
    for n, (nc, _, lost, wrong, sg, hc, known, _, _) in rows:
        cells = [known, sg, hc, lost, wrong, *nc]
        tot += cells
        print_row(n, cells)
    print_row("pooled", tot.tolist())
    print()
    print("## guided pass: the first test that stops the lost points no pass matched")
    print("scene | never matched | " + " | ".join(GUIDED_COLUMNS))
    tot = np.zeros(1 + len(GUIDED_COLUMNS), dtype=np.int64)
    for n, (nc, gc, *_) in rows:
        cells = [sum(nc[:4]), *gc]
        tot += cells
        print_row(n, cells)
    print_row("pooled", tot.tolist())
    correct, scored = sum(r[1][5] for r in rows), sum(r[1][7] for r in rows)
    print(f"\nhopmatch: {correct} correct of {scored} scored matches, precision "
          f"{correct / max(scored, 1):.4f}")
    print(f"{sum(r[1][-1] for r in rows):.1f} s")
    if args.continuity_support:
        print_continuity_support(np.concatenate(refused))
    return 0


if __name__ == "__main__":
    sys.exit(main())
