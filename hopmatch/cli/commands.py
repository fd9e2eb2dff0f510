"""The commands ``demo``, ``match`` and ``detect`` (``eval`` is in
:mod:`hopmatch.cli.eval_command`)."""

from __future__ import annotations

import time

import click
import cv2
import numpy as np

import hopmatch

from .. import viz
from .._tables import format_table, matches_table
from ..evaluate import correct_matches, score_matches
from ..feature.detector import DericheMoravecDetector
from ..matching.matcher import HopfieldMatcher
from ..matching.stereo_match import match_stereo, stereo_pipeline
from .group import cli
from .options import given_parameters, param_labels, parameter_options
from .outputs import Outputs, image_info, ms, read_image, run_json
from .reporting import CLIError, guard, say, status

__all__ = ["demo", "detect", "match"]


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


def _draw_match_images(outputs, left, right, result, correct=None, known=None,
                       max_disparity=None):
    status("drawing matches")
    pic = viz.draw_matches(left, right, result.points_left, result.points_right,
                           np.stack([result.query_idx, result.train_idx], axis=1),
                           correct, known=known)
    outputs.add_image("matches.png", pic)
    status("drawing disparities")
    disp = viz.draw_disparity(left, result.matched_left, result.disparities, max_disparity)
    outputs.add_image("disparity.png", disp)


def _draw_paper_figures(outputs, left, right, result, detector):
    """The paper's Figure 5 (points over the gradient image, each side) and Figure 7
    (numbered matches), staged with the other outputs."""
    status("drawing the paper's figures")
    outputs.add_image("figure5_left.png",
                      viz.draw_keypoints_on_gradient(left, result.points_left, detector))
    outputs.add_image("figure5_right.png",
                      viz.draw_keypoints_on_gradient(right, result.points_right, detector))
    outputs.add_image("figure7.png", viz.draw_labelled_matches(
        left, right, result.points_left, result.points_right,
        np.stack([result.query_idx, result.train_idx], axis=1)))


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
              help="Output folder (created if missing).")
@click.pass_context
def demo(ctx, out):
    """Match the built-in motorcycle pair (Middlebury 2014, via scikit-image).

    Writes matches.png (green: correct within 1 px of the ground truth, red: wrong,
    grey: no ground truth), disparity.png, matches.csv and run.json into DIR, and prints
    the counts, the precision and the time.
    """
    from ..datasets import load_motorcycle

    t_start = time.perf_counter()
    status("loading the motorcycle pair")
    scene = load_motorcycle()
    outputs = Outputs(out)
    outputs.open()

    def body():
        status("compiling the Numba kernels (cached after the first run)")
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
                        "total": ms(time.perf_counter() - t_start)},
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
        _say_times(ctx, result, t_match, t_warm)
        say(ctx, f"output: {outputs.path} ({', '.join(outputs.names)})")

    guard(outputs, {}, body)


# --------------------------------------------------------------------------------------
# match
# --------------------------------------------------------------------------------------


@cli.command()
@click.argument("left", metavar="LEFT")
@click.argument("right", metavar="RIGHT")
@click.option("--out", "-o", required=True, metavar="DIR",
              help="Output folder (created if missing; an existing one is reused).")
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
def match(ctx, left, right, out, fmt, no_draw, plot_energy, figures, **params):
    """Match a rectified stereo pair LEFT RIGHT (image files of the same height).

    Writes matches.csv (left_x,left_y,right_x,right_y,disparity,distance; or matches.json),
    matches.png and disparity.png (unless --no-draw), energy.png (--plot-energy),
    figure5_left.png, figure5_right.png and figure7.png (--figures) and run.json
    (parameters, versions, timings, counts) into DIR.
    """
    t_start = time.perf_counter()
    given = given_parameters(params, DericheMoravecDetector, HopfieldMatcher)
    labels = {"": f"{left}, {right}", "left": left, "right": right,
              **param_labels(DericheMoravecDetector, HopfieldMatcher)}
    # configuration first: a bad combination fails before any file is touched
    detector, matcher = guard(None, labels, lambda: stereo_pipeline(given, "hopmatch match"))
    if plot_energy:
        import importlib.util

        if importlib.util.find_spec("matplotlib") is None:
            raise CLIError("--plot-energy", "needs matplotlib: pip install hopmatch[all]")
    status("reading the images")
    pixels = detector.getMaxPixels()  # images over it are refused from their header
    img_l, img_r = read_image(left, pixels), read_image(right, pixels)
    if img_l.shape[0] != img_r.shape[0]:
        raise CLIError(right, f"height {img_r.shape[0]} differs from the height of {left} "
                              f"({img_l.shape[0]}); LEFT and RIGHT must be a rectified pair")
    t_read = time.perf_counter() - t_start
    outputs = Outputs(out)
    outputs.open()

    def body():
        status("compiling the Numba kernels (cached after the first run)")
        t_warm = hopmatch.warmup()
        status("detecting and matching")
        t0 = time.perf_counter()
        result = match_stereo(img_l, img_r, record_energy=plot_energy, detector=detector,
                              matcher=matcher)
        t_match = time.perf_counter() - t0
        t1 = time.perf_counter()
        outputs.add_text(f"matches.{fmt}", _match_table(result, fmt))
        max_disp = matcher.getMaxDisparity()
        if not no_draw:
            _draw_match_images(outputs, img_l, img_r, result, max_disparity=max_disp)
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
                        "format": fmt, "draw": not no_draw, "figures": figures},
            counts=counts,
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
        _say_times(ctx, result, t_match, t_warm)
        say(ctx, f"output: {outputs.path} ({', '.join(outputs.names)})")

    guard(outputs, labels, body)


# --------------------------------------------------------------------------------------
# detect
# --------------------------------------------------------------------------------------


@cli.command()
@click.argument("image", metavar="IMAGE")
@click.option("--out", "-o", required=True, metavar="DIR",
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
    labels = {"": image, "image": image, **param_labels(DericheMoravecDetector)}
    detector = guard(None, labels, lambda: DericheMoravecDetector(**given))
    status("reading the image")
    img = read_image(image, detector.getMaxPixels())
    outputs = Outputs(out)
    outputs.open()

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
