"""The command ``eval``: hopmatch beside OpenCV's matchers (:mod:`hopmatch.compare`) on
scenes with ground truth, as tables and plots, or as ``docs/results.md``."""

from __future__ import annotations

import re
import time
from datetime import datetime, timezone
from pathlib import Path

import click

import hopmatch

from .. import viz
from .group import cli
from .options import PlainIntRange
from .outputs import Outputs
from .reporting import CLIError, guard, say, status

__all__ = ["eval_"]


def _scene_file_name(scene: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", scene)


def _project_docs() -> Path:
    """``docs/`` of the source tree hopmatch runs from (``--docs`` needs a checkout)."""
    root = Path(hopmatch.__file__).resolve().parents[1]
    if not (root / "pyproject.toml").is_file():
        raise CLIError("--docs", f"needs a source checkout of hopmatch (no pyproject.toml in "
                                 f"{str(root)!r}); use --out DIR instead")
    return root / "docs"


def _method_help() -> str:
    from ..compare import METHODS

    return ", ".join(METHODS)


@cli.command("eval")
@click.option("--scene", "scenes", multiple=True, metavar="NAME",
              help="Scene to run on (repeatable): 'motorcycle' or a folder of ../shared/data "
                   "such as 'middlebury/tsukuba' [default: motorcycle; with --docs: every "
                   "scene].")
@click.option("--method", "methods", multiple=True, metavar="NAME",
              help="Method to run (repeatable) [default: all]: " + _method_help() + ".")
@click.option("--out", "-o", default=None, metavar="DIR",
              help="Output folder (created if missing) [default: hopmatch-eval; with --docs "
                   "only when given].")
@click.option("--docs", is_flag=True,
              help="Regenerate docs/results.md and docs/img/*.png of this source tree.")
@click.option("--draw", is_flag=True,
              help="Also draw the matches of every scene and method "
                   "(matches_<scene>_<method>.png in DIR).")
@click.option("--repeat", type=PlainIntRange(min=1), default=None, metavar="N",
              help="Time each method N times per scene and keep the shortest "
                   "[default: 1; with --docs: 3].")
@click.pass_context
def eval_(ctx, scenes, methods, out, docs, draw, repeat):
    """Compare hopmatch with OpenCV's matchers on scenes with ground truth.

    Runs every method (detection on both images + matching, one thread, timed in this
    run) on every scene, scores the matches against the ground truth at 0.5, 1 and 2 px,
    prints the table (scene x method: matches, correct@1, precision@1, recall@1, time ms)
    and writes results.md, results.csv, precision_vs_correct.png and error_histogram.png
    into DIR, and precision_curves.png (precision against correct matches as hopmatch's
    distance threshold, SIFT's ratio and SGBM's uniqueness ratio move) when one of
    those methods runs. With --docs it rewrites docs/results.md and docs/img/*.png instead.
    """
    import importlib.util

    from .. import compare as cmp
    from ..datasets import list_scenes, load

    t_start = time.perf_counter()
    if importlib.util.find_spec("matplotlib") is None:
        raise CLIError("eval", "the plots need matplotlib: pip install hopmatch[all]")
    for m in methods:
        if m not in cmp.METHODS:
            raise CLIError("--method", f"unknown method {m!r}; valid methods are "
                                       f"{', '.join(cmp.METHODS)}")
    available = list_scenes()
    for name in scenes:
        if name not in available:
            raise CLIError("--scene", f"unknown scene {name!r}; available: "
                                      f"{', '.join(available)}")
    scene_names = list(dict.fromkeys(scenes)) or (
        cmp.docs_scenes(available) if docs else ["motorcycle"])
    method_names = list(dict.fromkeys(methods)) or list(cmp.METHODS)
    docs_dir = _project_docs() if docs else None
    if out is None and not docs:
        out = "hopmatch-eval"
    if repeat is None:
        repeat = 3 if docs else 1

    loaded = []
    for name in scene_names:
        status(f"loading {name}")
        loaded.append(guard(None, {"": name}, lambda n=name: load(n)))

    targets = []
    if out is not None:
        targets.append(Outputs(out))
    if docs_dir is not None:
        doc_out, img_out = Outputs(str(docs_dir)), Outputs(str(docs_dir / "img"))
        targets += [doc_out, img_out]
    opened = []
    try:
        for target in targets:
            target.open()
            opened.append(target)
    except CLIError:
        for target in opened:
            target.abort()
        raise

    def body():
        rows = cmp.compare(loaded, method_names, progress=status, repeat=repeat)
        by_key = {(r["scene"], r["method"]): r for r in rows}
        scene_of = {s.name: s for s in loaded}
        all_errors = cmp.errors_by_method(rows)
        n = len(loaded)
        pooled = (f"Absolute disparity error of the scored matches "
                  f"({'all ' + str(n) + ' scenes pooled' if n > 1 else loaded[0].name})")
        curve_rows = cmp.precision_curves(loaded, method_names, progress=status)
        status("plotting")
        prec_png = viz.render_precision_vs_correct(rows)
        curve_png = viz.render_precision_curves(curve_rows) if curve_rows else None
        hist_png = viz.render_error_histogram(all_errors, title=pooled)
        if out is not None:
            target = targets[0]
            target.add_text("results.md", cmp.format_markdown(rows))
            target.add_text("results.csv", cmp.format_csv(rows))
            target.add("precision_vs_correct.png", prec_png)
            target.add("error_histogram.png", hist_png)
            if curve_png is not None:
                target.add("precision_curves.png", curve_png)
            if draw:
                for r in rows:
                    status(f"drawing {r['scene']}: {r['method']}")
                    target.add_image(f"matches_{_scene_file_name(r['scene'])}_{r['method']}.png",
                                     cmp.draw_row(r, scene_of[r["scene"]]))
        if docs_dir is not None:
            pictures = {"img/precision_vs_correct.png":
                        "Precision@1 against correct@1, one point per method and scene",
                        "img/error_histogram.png": pooled}
            img_out.add("precision_vs_correct.png", prec_png)
            img_out.add("error_histogram.png", hist_png)
            if curve_png is not None:
                img_out.add("precision_curves.png", curve_png)
                pictures["img/precision_curves.png"] = (
                    "Precision@1 against correct@1 as each method's threshold moves "
                    "(hopmatch: distance, SIFT + band: Lowe ratio, SGBM: uniqueness ratio), "
                    "all scenes pooled")
            if "motorcycle" in scene_of and n > 1:
                img_out.add("error_histogram_motorcycle.png", viz.render_error_histogram(
                    cmp.errors_by_method(rows, "motorcycle"),
                    title="Absolute disparity error of the scored matches (motorcycle)"))
                pictures["img/error_histogram_motorcycle.png"] = (
                    "Absolute disparity error of the scored matches (motorcycle)")
            for scene, method in cmp.DOC_DRAWINGS:
                if (scene, method) not in by_key:
                    continue
                status(f"drawing {scene}: {method}")
                file = f"matches_{_scene_file_name(scene)}_{method}.png"
                img_out.add_image(file, cmp.draw_row(by_key[scene, method], scene_of[scene]))
                pictures[f"img/{file}"] = (
                    f"{method} on {scene}: every match a dot coloured by disparity, a "
                    "spread-out subset as lines, a magenta cross on each wrong one (beyond "
                    "1 px)")
            doc_out.add_text("results.md", cmp.format_results_doc(
                rows, loaded, pictures=pictures, curves=curve_rows,
                machine=cmp.machine_description(),
                created=datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                elapsed=time.perf_counter() - t_start, repeat=repeat))
        for target in targets:
            target.commit()
        status.clear()
        say(ctx, cmp.format_markdown(rows).rstrip("\n"))
        say(ctx)
        for target in targets:
            say(ctx, f"output: {target.path} ({', '.join(target.names)})")

    def guarded():
        try:
            body()
        except BaseException:
            for target in targets[1:]:
                target.abort()
            raise

    guard(targets[0] if targets else None, {"": ", ".join(scene_names)}, guarded)
