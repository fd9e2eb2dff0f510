"""The commands ``demo``, ``match``, ``detect`` and ``warmup`` (``eval`` is in
:mod:`hopmatch.cli.eval_command`)."""

from __future__ import annotations

import time
from pathlib import Path

import click
import cv2
import numpy as np

import hopmatch

from .. import viz
from ..errors import FileReadError
from ..evaluate import correct_matches, score_matches
from ..feature.detector import DericheMoravecDetector
from ..matching.matcher import HopfieldMatcher
from ..matching.stereo_match import match_stereo, stereo_pipeline
from ..matching.unrectified import UNRECTIFIED_VERTICAL
from ..tables import format_table, matches_table
from .group import cli
from .options import PlainIntRange, given_parameters, param_labels, parameter_options
from .outputs import Outputs, image_info, ms, read_image, run_json
from .reporting import CLIError, guard, one_line, say, status

__all__ = ["demo", "detect", "match", "warmup"]


# --------------------------------------------------------------------------------------
# Helpers of the commands
# --------------------------------------------------------------------------------------


def _correct_mask(result, disparity_gt, tolerance: float = 1.0):
    """(correct, known, score) of each match against ground truth, at ``tolerance`` px."""
    ml, mr = result.matched_left, result.matched_right
    score = score_matches(ml, mr, disparity_gt, thresholds=(tolerance,))
    correct, known = correct_matches(score, ml, mr, tolerance)
    return correct, known, score


def _match_table(result, fmt: str) -> str:
    return matches_table(result.matched_left, result.matched_right, result.disparities,
                         result.distances, fmt)


#: How many matches figure7.png numbers at most (a spread-out subset beyond): the paper's
#: Figure 7 shows 33, and thousands of labels would cover one another.
FIGURE7_LABELS = 60


def _draw_match_images(outputs, left, right, result, correct=None, known=None):
    """matches.png (a spread-out subset of the matches as lines, every match as a dot,
    coloured by disparity, with a caption) and disparity.png (the left image's matched
    keypoints coloured by disparity, with a colour bar in pixels): hopmatch.viz.overview."""
    status("drawing matches")
    pairs = np.stack([result.query_idx, result.train_idx], axis=1)
    outputs.add_image("matches.png", viz.draw_match_overview(
        left, right, result.points_left, result.points_right, pairs, result.disparities,
        correct=correct, known=known))
    status("drawing disparities")
    outputs.add_image("disparity.png", viz.draw_keypoint_disparities(
        left, result.matched_left, result.disparities))


def _draw_paper_figures(outputs, left, right, result, detector):
    """The paper's Figure 5 (points over the gradient image, each side) and Figure 7
    (numbered matches, at most :data:`FIGURE7_LABELS` of them), staged with the other
    outputs."""
    status("drawing the paper's figures")
    outputs.add_image("figure5_left.png",
                      viz.draw_keypoints_on_gradient(left, result.points_left, detector))
    outputs.add_image("figure5_right.png",
                      viz.draw_keypoints_on_gradient(right, result.points_right, detector))
    outputs.add_image("figure7.png", viz.draw_labelled_matches(
        left, right, result.points_left, result.points_right,
        np.stack([result.query_idx, result.train_idx], axis=1), max_labels=FIGURE7_LABELS))


def _counts(result) -> dict:
    net = result.network
    return {
        "keypoints_left": int(len(result.points_left)),
        "keypoints_right": int(len(result.points_right)),
        "neurons": int(len(net.neuron_left)),
        "interactions": int(net.n_interactions),
        "matches": int(len(result.query_idx)),
        "iterations": int(net.iterations),
        "sweeps": int(net.sweeps),
        "converged": bool(net.converged),
    }


def _folder(ctx, param, value):
    """``--out``: refuse an empty name (an unset shell variable would otherwise write into
    the working directory)."""
    if value is not None and not str(value).strip():
        raise click.BadParameter("must name a folder, got an empty string", ctx, param)
    return value


def _labels(ctx, labels: dict) -> dict:
    """``labels`` merged into the run's labels, so that warnings name the user's files and
    options as errors do (:func:`~hopmatch.cli.reporting.cli_warnings`)."""
    root = ctx.find_root().obj
    if root is not None and "labels" in root:
        root["labels"].update(labels)
    return labels


def _open(outputs, labels) -> None:
    """``outputs.open()``, an OSError about the folder (a name too long...) as bad input."""
    guard(None, {**labels, "": outputs.label}, outputs.open)


def check_unrectified_options(given: dict, fundamental_file) -> None:
    """Refuse what ``--unrectified`` cannot be combined with (before any file is read):
    a known F, or a disparity range (the range of an unrectified pair is found in the
    frame its right image is aligned to)."""
    if fundamental_file is not None:
        raise click.UsageError("--unrectified estimates the fundamental matrix from the "
                               "pair; to match along a known one give only "
                               "--fundamental-matrix FILE")
    for name in ("min_disparity", "max_disparity"):
        if given.get(name) is not None:
            raise click.UsageError(
                f"--unrectified finds the disparity range with the geometry; leave "
                f"--{name.replace('_', '-')} out (got {given[name]:g})")


def fundamental_text(result) -> str:
    """``fundamental_matrix.txt``: the estimated F as ``np.savetxt`` writes it (readable
    by ``--fundamental-matrix``), ``x_right^T F x_left = 0``."""
    import io

    buf = io.StringIO()
    np.savetxt(buf, result.fundamental_matrix, fmt="%.12g",
               header="fundamental matrix estimated by hopmatch match --unrectified: "
                      "[xr, yr, 1] F [xl, yl, 1]^T = 0")
    return buf.getvalue()


def geometry_json(result) -> dict:
    """run.json's ``geometry`` of a run with one (``--unrectified``, a pair switched to it,
    or ``--fundamental-matrix`` with no range: ``source`` ``'given'``): F (or None) and how
    it was found or used."""
    g = result.geometry
    median = float(g.median_error)
    return {"fundamental_matrix": (None if g.fundamental is None
                                   else np.asarray(g.fundamental).tolist()),
            "correspondences": int(g.n_correspondences), "inliers": int(g.n_inliers),
            "median_epipolar_error_px": median if np.isfinite(median) else None,
            "source": g.source, "search": g.search, "reason": g.reason}


def geometry_line(result) -> str:
    """The line ``hopmatch match`` says about the geometry it found (``--unrectified``) or
    lined the rows up with (``--fundamental-matrix`` and no range)."""
    g = result.geometry
    if g.fundamental is None:
        return f"geometry: none found ({g.reason})"
    if g.source == "given":
        return (f"geometry: the given F, {g.n_inliers} of {g.n_correspondences} "
                f"correspondences on its lines, searched {g.search}")
    return (f"geometry: F from {g.n_inliers} of {g.n_correspondences} correspondences "
            f"(median epipolar error {g.median_error:.2f} px), searched {g.search}")


def read_fundamental_matrix(path: str) -> np.ndarray:
    """The 3 x 3 fundamental matrix of ``--fundamental-matrix FILE``: a text file of 9
    numbers (``np.savetxt(FILE, F)``), a ``.npy`` file (``np.save``), or a ``cv2.FileStorage``
    file (``.yml``/``.yaml``/``.xml``/``.json``) with a node ``F`` or ``fundamental_matrix``.
    The file is checked as every file hopmatch reads is (:mod:`hopmatch.files`: a regular
    file of at most ``MAX_TEXT_BYTES``; a FileStorage file nested too deep for OpenCV's
    parser is refused before it is parsed).

    Raises :class:`CLIError` naming the file when it cannot be read or holds no 3 x 3
    matrix of real numbers (the matrix itself is checked by ``match_stereo``)."""
    from ..files import MAX_TEXT_BYTES, check_input_file, check_storage_nesting
    from ..imageio import os_reason

    suffix = Path(path).suffix.lower()
    try:
        check_input_file(path, MAX_TEXT_BYTES, argument="--fundamental-matrix")
        if suffix in (".yml", ".yaml", ".xml", ".json"):
            check_storage_nesting(path, argument="--fundamental-matrix")
            fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
            try:
                node = fs.getNode("F") if fs.root().isMap() else fs.root()
                if node.empty():
                    node = fs.getNode("fundamental_matrix")
                value = None if node.empty() or not node.isMap() else node.mat()
            finally:
                fs.release()
            if value is None:
                raise CLIError(path, "holds no matrix named F or fundamental_matrix (an "
                                     "OpenCV matrix, as cv2.FileStorage.write(\"F\", F) "
                                     "writes it)")
        elif suffix == ".npy":
            value = np.load(path, allow_pickle=False)
        else:
            value = np.loadtxt(path, dtype=np.float64, ndmin=1)
    except CLIError:
        raise
    except FileReadError as exc:
        raise CLIError(path, exc.problem) from None
    except OSError as exc:
        raise CLIError(path, os_reason(exc) if exc.errno else str(exc)) from None
    except (ValueError, cv2.error, SystemError) as exc:  # SystemError: cv2 5 on bad files
        raise CLIError(path, f"is not a matrix file: {one_line(exc)[:200]}") from None
    value = np.asarray(value)
    if value.dtype.kind not in "biuf":
        raise CLIError(path, f"must hold real numbers, got an array of {value.dtype}")
    if value.size != 9:
        raise CLIError(path, f"must hold the 9 numbers of a 3 x 3 matrix, got {value.size}")
    return value.astype(np.float64).reshape(3, 3)


#: Timing rounds of the demo's steady-state figures (:func:`steady_state_times`).
STEADY_ROUNDS = 5


def steady_state_times(scene, rounds: int = STEADY_ROUNDS) -> tuple[float, float]:
    """``(hopmatch, ORB)`` seconds per pair on ``scene``, as the README's speed table
    measures them: best of ``rounds`` interleaved rounds, each timed call right after an
    untimed one of the same pipeline, on one OpenCV and one hopmatch thread, on the grey
    pair;
    ``match_stereo`` with its defaults against ``hopmatch eval``'s ``orb-ratio`` method
    (ORB(3000) + BFMatcher knnMatch k=2 + ratio test 0.75, detection included)."""
    from ..compare import METHODS

    orb = METHODS["orb-ratio"]
    gl, gr = (cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
              for img in (scene.left, scene.right))
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        best_hop = best_orb = float("inf")
        for _ in range(rounds):
            match_stereo(gl, gr, threads=1)
            t0 = time.perf_counter()
            match_stereo(gl, gr, threads=1)
            best_hop = min(best_hop, time.perf_counter() - t0)
            orb(scene)
            best_orb = min(best_orb, orb(scene).seconds)
    finally:
        cv2.setNumThreads(threads)
    return best_hop, best_orb


def _say_times(ctx, result, t_match: float, t_warm: float) -> None:
    detect_ms = ms(result.timings["detect_left"] + result.timings["detect_right"])
    say(ctx, f"time: {ms(t_match):.0f} ms (detection {detect_ms:.0f} ms, matching "
             f"{ms(result.timings['match']):.0f} ms; Numba load/compile "
             f"{ms(t_warm):.0f} ms before)")


# --------------------------------------------------------------------------------------
# demo
# --------------------------------------------------------------------------------------


@cli.command()
@click.option("--out", "-o", default="hopmatch-demo", show_default=True, metavar="DIR",
              callback=_folder, help="Output folder (created if missing).")
@click.pass_context
def demo(ctx, out):
    """Match the built-in motorcycle pair (Middlebury 2014, via scikit-image).

    Writes matches.png (matches coloured by disparity, wrong ones - more than 1 px off
    the ground truth - marked by magenta crosses), disparity.png (keypoints coloured by
    disparity, with a colour bar), matches.csv and run.json into DIR, and prints the
    counts, the precision, the time per pair in steady state and its ratio to ORB(3000) +
    BFMatcher with the ratio test, timed in the same run.
    """
    from ..datasets import load_motorcycle

    t_start = time.perf_counter()
    status("loading the motorcycle pair")
    scene = load_motorcycle()
    outputs = Outputs(out)
    _open(outputs, {})

    def body():
        status("loading the Numba kernels")
        t_warm = hopmatch.warmup()
        status("matching")
        t0 = time.perf_counter()
        result = match_stereo(scene.left, scene.right)
        t_match = time.perf_counter() - t0
        correct, known, score = _correct_mask(result, scene.disparity)
        t1 = time.perf_counter()
        _draw_match_images(outputs, scene.left, scene.right, result, correct, known)
        outputs.add_text("matches.csv", _match_table(result, "csv"))
        t_out = time.perf_counter() - t1
        status("timing hopmatch and ORB in steady state")
        t_steady, t_orb = steady_state_times(scene)
        counts = _counts(result)
        counts.update(matches_with_ground_truth=int(score.n_scored),
                      correct_at_1px=int(correct.sum()))
        precision = float(score.precision[1.0])
        outputs.add_text("run.json", run_json(
            "demo",
            inputs={"scene": scene.name, "source": scene.source,
                    "size": list(scene.image_size)},
            parameters={"detector": DericheMoravecDetector().get_params(),
                        "matcher": HopfieldMatcher().get_params()},
            counts=counts,
            precision_at_1px=None if np.isnan(precision) else precision,
            timings_ms={"warmup": ms(t_warm), **{k: ms(v) for k, v in result.timings.items()},
                        "match_stereo": ms(t_match), "draw_and_write": ms(t_out),
                        "steady_state": ms(t_steady), "orb_ratio_steady_state": ms(t_orb),
                        "total": ms(time.perf_counter() - t_start)},
            speed={"ratio_to_orb": round(t_steady / t_orb, 3), "rounds": STEADY_ROUNDS,
                   "threads": 1, "peer": "ORB(3000) + BFMatcher knnMatch k=2, ratio 0.75"},
            outputs=outputs.names + ["run.json"],
        ))
        outputs.commit()
        status.clear()
        w, h = scene.image_size
        say(ctx, f"scene: motorcycle ({w} x {h}, Middlebury 2014 via scikit-image)")
        say(ctx, f"keypoints: {counts['keypoints_left']} left, {counts['keypoints_right']} right")
        say(ctx, f"matches: {counts['matches']}")
        say(ctx, f"correct@1px: {counts['correct_at_1px']} of {score.n_scored} with ground truth")
        say(ctx, f"precision: {precision:.3f}")
        say(ctx, f"time: {ms(t_steady):.0f} ms per pair in steady state (best of "
                 f"{STEADY_ROUNDS} rounds, one thread; the first call took {ms(t_match):.0f} "
                 f"ms, after {ms(t_warm):.0f} ms of Numba loading or compiling)")
        say(ctx, f"speed: {t_steady / t_orb:.2f}x the time of ORB(3000) + BFMatcher ratio "
                 f"test ({ms(t_orb):.0f} ms), timed here in the same rounds; absolute times "
                 "depend on the machine, the ratio much less")
        say(ctx, f"output: {outputs.path} ({', '.join(outputs.names)})")

    guard(outputs, {}, body)


# --------------------------------------------------------------------------------------
# match
# --------------------------------------------------------------------------------------


@cli.command()
@click.argument("left", metavar="LEFT")
@click.argument("right", metavar="RIGHT")
@click.option("--out", "-o", required=True, metavar="DIR", callback=_folder,
              help="Output folder (created if missing; an existing one is reused).")
@click.option("--fundamental-matrix", "fundamental_file", metavar="FILE", default=None,
              help="Match an unrectified pair along the epipolar lines of this fundamental "
                   "matrix (x_right^T F x_left = 0, as cv2.findFundamentalMat returns it): "
                   "a text file of 9 numbers (np.savetxt), a .npy file, or a .yml/.xml/.json "
                   "cv2.FileStorage file with a node F. LEFT and RIGHT may then differ in "
                   "size.")
@click.option("--unrectified", is_flag=True,
              help="The pair is not rectified and its geometry is unknown (two photos, an "
                   "uncalibrated rig): estimate the fundamental matrix and the disparity "
                   "range from the pair (match_stereo(..., rectified=False)) and write F to "
                   "fundamental_matrix.txt. LEFT and RIGHT may then differ in size. Cannot "
                   "be combined with --fundamental-matrix, --min-disparity or "
                   "--max-disparity; --vertical-threshold defaults to 0.75 px. Without it, "
                   "a pair of one height found far from rectified (a warning says so) is "
                   "matched this way too, unless a disparity range or --preset paper is "
                   "given.")
@click.option("--format", "fmt", type=click.Choice(["csv", "json"]), default="csv",
              show_default=True, help="matches.csv or matches.json.")
@click.option("--no-draw", is_flag=True, help="Do not write matches.png and disparity.png.")
@click.option("--plot-energy", is_flag=True,
              help="Record the network energy and plot it to energy.png (needs matplotlib).")
@click.option("--figures", is_flag=True,
              help="Also draw the paper's figures: figure5_left.png, figure5_right.png "
                   "(points over the gradient magnitude) and figure7.png (numbered matches).")
@parameter_options(DericheMoravecDetector, HopfieldMatcher)
@click.pass_context
def match(ctx, left, right, out, fundamental_file, unrectified, fmt, no_draw, plot_energy,
          figures, **params):
    """Match a rectified stereo pair LEFT RIGHT (image files of the same height), or an
    unrectified one with --fundamental-matrix (F known) or --unrectified (F estimated).

    Writes matches.csv (left_x,left_y,right_x,right_y,disparity,distance; or matches.json),
    matches.png and disparity.png (unless --no-draw), energy.png (--plot-energy),
    figure5_left.png, figure5_right.png and figure7.png (--figures) and run.json
    (parameters, versions, timings, counts) into DIR.
    """
    t_start = time.perf_counter()
    given = given_parameters(params, DericheMoravecDetector, HopfieldMatcher)
    labels = _labels(ctx, {"": f"{left}, {right}", "left": left, "right": right,
                           **param_labels(DericheMoravecDetector, HopfieldMatcher)})
    # configuration first: a bad combination fails before any file is touched
    if unrectified:
        check_unrectified_options(given, fundamental_file)
    pipeline = dict(given)
    if unrectified:
        pipeline.setdefault("vertical_threshold", UNRECTIFIED_VERTICAL)
    detector, matcher = guard(None, labels,
                              lambda: stereo_pipeline(pipeline, "hopmatch match"))
    fundamental = None
    if fundamental_file is not None:
        labels["fundamental_matrix"] = fundamental_file
        fundamental = read_fundamental_matrix(fundamental_file)
    if plot_energy:
        import importlib.util

        if importlib.util.find_spec("matplotlib") is None:
            raise CLIError("--plot-energy", "needs matplotlib: pip install hopmatch[all]")
    status("reading the images")
    pixels = detector.getMaxPixels()  # images over it are refused from their header
    img_l, img_r = guard(None, labels, lambda: (read_image(left, pixels),
                                                read_image(right, pixels)))
    # two heights: the defaults match the pair as --unrectified does (match_stereo warns);
    # a range or the paper's preset searches rows, which two heights do not have
    rows_only = (given.get("max_disparity") is not None or "min_disparity" in given
                 or given.get("preset") == "paper")
    if (fundamental is None and not unrectified and rows_only
            and img_l.shape[0] != img_r.shape[0]):
        raise CLIError(right, f"height {img_r.shape[0]} differs from the height of {left} "
                              f"({img_l.shape[0]}); with a disparity range or the paper's "
                              "preset LEFT and RIGHT must be a rectified pair (or give "
                              "--fundamental-matrix FILE, or --unrectified)")
    t_read = time.perf_counter() - t_start
    outputs = Outputs(out)
    _open(outputs, labels)

    def body():
        status("loading the Numba kernels")
        t_warm = hopmatch.warmup()
        status("detecting and matching")
        t0 = time.perf_counter()
        # the parameters as keywords, not the instances: a pair that turns out far from
        # rectified then gets the unrectified defaults too (vertical_threshold)
        result = match_stereo(img_l, img_r, record_energy=plot_energy,
                              fundamental_matrix=fundamental,
                              rectified=False if unrectified else None, **pipeline)
        geometry = result.geometry  # estimated (--unrectified, or switched), or the F given
        estimated = geometry is not None and geometry.source != "given"
        t_match = time.perf_counter() - t0
        t1 = time.perf_counter()
        outputs.add_text(f"matches.{fmt}", _match_table(result, fmt))
        if estimated and result.fundamental_matrix is not None:
            outputs.add_text("fundamental_matrix.txt", fundamental_text(result))
        if not no_draw:
            _draw_match_images(outputs, img_l, img_r, result)
        if plot_energy:
            status("plotting the energy")
            outputs.add("energy.png", viz.render_energy(result.network.energy_trace, "png"))
        if figures:
            _draw_paper_figures(outputs, img_l, img_r, result, detector)
        t_out = time.perf_counter() - t1
        counts = _counts(result)
        used = result.network.config.max_disparity
        outputs.add_text("run.json", run_json(
            "match",
            inputs={"left": image_info(left, img_l), "right": image_info(right, img_r)},
            parameters={"given": dict(given),
                        "detector": detector.get_params(), "matcher": matcher.get_params(),
                        "max_disparity_used": used, "record_energy": plot_energy,
                        "fundamental_matrix": (None if fundamental is None
                                               else fundamental.tolist()),
                        "unrectified": unrectified, "geometry_estimated": estimated,
                        "format": fmt, "draw": not no_draw, "figures": figures},
            counts=counts,
            **({"geometry": geometry_json(result)} if geometry is not None else {}),
            energy=float(result.network.energy),
            timings_ms={"read": ms(t_read), "warmup": ms(t_warm),
                        **{k: ms(v) for k, v in result.timings.items()},
                        "match_stereo": ms(t_match), "draw_and_write": ms(t_out),
                        "total": ms(time.perf_counter() - t_start)},
            outputs=outputs.names + ["run.json"],
        ))
        outputs.commit()
        status.clear()
        say(ctx, f"keypoints: {counts['keypoints_left']} left, {counts['keypoints_right']} right")
        say(ctx, f"matches: {counts['matches']}")
        if counts["matches"]:
            say(ctx, f"median disparity: {float(np.median(result.disparities)):g} px")
        if geometry is not None:
            say(ctx, geometry_line(result))
        _say_times(ctx, result, t_match, t_warm)
        say(ctx, f"output: {outputs.path} ({', '.join(outputs.names)})")

    guard(outputs, labels, body)


# --------------------------------------------------------------------------------------
# detect
# --------------------------------------------------------------------------------------


@cli.command()
@click.argument("image", metavar="IMAGE")
@click.option("--out", "-o", required=True, metavar="DIR", callback=_folder,
              help="Output folder (created if missing; an existing one is reused).")
@click.option("--no-draw", is_flag=True, help="Do not write keypoints.png.")
@parameter_options(DericheMoravecDetector)
@click.pass_context
def detect(ctx, image, out, no_draw, **params):
    """Detect Moravec points on IMAGE.

    Writes keypoints.csv (x,y,response,size), keypoints.png (unless --no-draw) and
    run.json into DIR.
    """
    t_start = time.perf_counter()
    given = given_parameters(params, DericheMoravecDetector)
    labels = _labels(ctx, {"": image, "image": image, **param_labels(DericheMoravecDetector)})
    detector = guard(None, labels, lambda: DericheMoravecDetector(**given))
    status("reading the image")
    img = guard(None, labels, lambda: read_image(image, detector.getMaxPixels()))
    outputs = Outputs(out)
    _open(outputs, labels)

    def body():
        status("detecting")
        t0 = time.perf_counter()
        kps = detector.detect(img)
        t_detect = time.perf_counter() - t0
        pts = cv2.KeyPoint_convert(list(kps)).reshape(-1, 2) if kps else np.zeros((0, 2))
        outputs.add_text("keypoints.csv", format_table({
            "x": pts[:, 0], "y": pts[:, 1], "response": [k.response for k in kps],
            "size": [k.size for k in kps]}, "csv"))
        if not no_draw:
            outputs.add_image("keypoints.png", viz.draw_keypoints(img, kps))
        outputs.add_text("run.json", run_json(
            "detect",
            inputs={"image": image_info(image, img)},
            parameters={"given": given, "detector": detector.get_params()},
            counts={"keypoints": len(kps)},
            timings_ms={"detect": ms(t_detect), "total": ms(time.perf_counter() - t_start)},
            outputs=outputs.names + ["run.json"],
        ))
        outputs.commit()
        status.clear()
        say(ctx, f"keypoints: {len(kps)}")
        say(ctx, f"time: {ms(t_detect):.0f} ms")
        say(ctx, f"output: {outputs.path} ({', '.join(outputs.names)})")

    guard(outputs, labels, body)


# --------------------------------------------------------------------------------------
# warmup
# --------------------------------------------------------------------------------------


@cli.command()
@click.option("--processes", type=PlainIntRange(1, 4096), default=None, metavar="N",
              help="Python processes compiling at once (default: 2 on a machine with 2 or "
                   "more cores, else 1; more than 2 gains nothing).")
@click.pass_context
def warmup(ctx, processes):
    """Compile every Numba kernel now, for this CPU, and print the time it took.

    The machine code goes to Numba's cache (NUMBA_CACHE_DIR, or the package folder), so
    later runs load it instead of compiling. In a Docker image or a CI cache, run it once
    with NUMBA_CACHE_DIR set to a folder that ships with the image. With the cache on, a
    second Python process compiles half of the kernels meanwhile (--processes).
    """
    import os

    from .._config import CACHE

    status("loading or compiling the Numba kernels")
    seconds = hopmatch.warmup(processes)
    status.clear()
    where = (os.environ.get("NUMBA_CACHE_DIR") or "the package folder") if CACHE else None
    say(ctx, f"warmup: {seconds:.1f} s, "
             + (f"kernels cached in {where}" if where else
                "on-disk cache off (HOPMATCH_NUMBA_CACHE=0 or a read-only package folder): "
                "the kernels were compiled for this process only"))
