"""Smoke runs of every ``benchmarks/`` script, so that the figures the docs quote cannot
silently rot.

Each script runs with ``--smoke`` (tiny inputs: seconds, not minutes) in a subprocess from
the repository root. A test fails when the script exits with an error or when its output
lacks a line or column the README or the docs quote from it (a crash, a renamed column, a
changed row label).

- The five scripts behind ``docs/performance.md`` (``end_to_end.py --profile``,
  ``detector.py``, ``scale.py``, ``first_call.py``, ``threaded_share.py``) run through
  ``run_all.py --smoke``,
  which runs each of them with ``--smoke`` and prints the page: each section must have
  every line of the same section of ``docs/performance.md`` with the numbers masked
  (headings, table headers, row labels, the goals line), except the machine line and the
  profile's function rows, and ``docs/performance.md`` must be left as it was.
- The other scripts: the lines and table columns that docs/robustness.md,
  docs/parameters.md, docs/pipelines.md, docs/cluster.md and docs/results.md quote.
- ``chessboard_dy.py``, ``chessboard_geometry.py`` and ``rectification_check.py
  --chessboards`` need ``../shared/data``
  and skip without it; the scripts whose scene list grows with it (``tune.py``,
  ``rectification_check.py``, ``fingerprint.py``) run on motorcycle alone then.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from shared_data import SHARED_DATA

ROOT = Path(__file__).resolve().parents[2]
BENCHMARKS = ROOT / "benchmarks"
PERFORMANCE_MD = ROOT / "docs" / "performance.md"
#: Seconds a smoke run may take (the first one in a fresh environment compiles every Numba
#: kernel: about 30 s on a loaded 2-core machine).
TIMEOUT = 300
#: The scripts of docs/performance.md, as run_all.py runs them.
PERFORMANCE_SCRIPTS = ["end_to_end.py", "detector.py", "scale.py", "first_call.py",
                       "threaded_share.py"]
NUMBER = re.compile(r"-?\d+(?:[.,]\d+)*")


def run_script(script: str, *args: str, shared: bool = True) -> str:
    """stdout of ``python benchmarks/SCRIPT --smoke ARGS`` run from the repository root;
    the test fails, with stderr shown, unless it exits with 0. ``shared``: give it
    ``../shared/data`` when the tests have it (else it sees none)."""
    env = dict(os.environ)
    env.pop("HOPMATCH_SHARED_DATA", None)
    if shared and SHARED_DATA.is_dir():
        env["HOPMATCH_SHARED_DATA"] = str(SHARED_DATA)
    proc = subprocess.run([sys.executable, str(BENCHMARKS / script), "--smoke", *args],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=TIMEOUT)
    assert proc.returncode == 0, (f"benchmarks/{script} --smoke {' '.join(args)} exited with "
                                  f"{proc.returncode}:\n{proc.stderr}\n{proc.stdout}")
    return proc.stdout


def assert_lines(out: str, *patterns: str) -> None:
    """Every regular expression in ``patterns`` matches a whole line of ``out``."""
    lines = out.splitlines()
    missing = [p for p in patterns if not any(re.fullmatch(p, line) for line in lines)]
    assert not missing, "no line matches " + "\n".join(missing) + f"\nin the output:\n{out}"


def table_row(*cells: str) -> str:
    """A regular expression of a Markdown table row of ``cells`` (each a regex)."""
    return r"\| " + r" \| ".join(f"(?:{c})" for c in cells) + r" \|"


NUM = r"-?\d+(?:\.\d+)?"


# --------------------------------------------------------------------------------------
# run_all.py and the five scripts of docs/performance.md
# --------------------------------------------------------------------------------------


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _sections(page: str) -> dict[str, str]:
    """``{script name: its output}`` of a page written by ``run_all.py``."""
    parts = re.split(r"^`python benchmarks/(\S+)[^`]*`$", page, flags=re.M)
    return {name: body for name, body in zip(parts[1::2], parts[2::2])}


def _mask(line: str) -> str:
    """``line`` with every number replaced by ``#`` and a goal's verdict made neutral."""
    return NUMBER.sub("#", line.replace("NOT met", "met")).rstrip()


def _quoted_lines(section: str) -> list[str]:
    """The lines of a docs/performance.md section that a smoke run must print too, masked:
    all but the machine (it names this machine) and the profile's function rows (which
    functions lead depends on the run)."""
    return [_mask(line) for line in section.splitlines()
            if line.strip() and line.strip() != "---"
            and not line.startswith(("Machine:", "| `"))]


@pytest.fixture(scope="module")
def run_all_page():
    """The page ``run_all.py --smoke`` prints (docs/performance.md checked untouched)."""
    before = _digest(PERFORMANCE_MD)
    page = run_script("run_all.py")
    assert _digest(PERFORMANCE_MD) == before, "run_all.py --smoke changed docs/performance.md"
    return page


def test_run_all_smoke_prints_every_section(run_all_page):
    assert run_all_page.startswith("# Performance\n")
    assert "the figures mean nothing" in run_all_page
    assert list(_sections(run_all_page)) == PERFORMANCE_SCRIPTS
    assert "`python benchmarks/end_to_end.py --profile --smoke`" in run_all_page


def test_run_all_refuses_to_write_smoke_figures_to_the_docs():
    before = _digest(PERFORMANCE_MD)
    proc = subprocess.run([sys.executable, str(BENCHMARKS / "run_all.py"), "--smoke", "--out",
                           str(PERFORMANCE_MD)], cwd=ROOT, capture_output=True, text=True,
                          timeout=TIMEOUT)
    assert proc.returncode == 2 and "docs/performance.md" in proc.stderr, proc.stderr
    assert _digest(PERFORMANCE_MD) == before


def test_performance_md_names_the_scripts_run_all_runs():
    assert list(_sections(PERFORMANCE_MD.read_text(encoding="utf-8"))) == PERFORMANCE_SCRIPTS


@pytest.mark.parametrize("script", PERFORMANCE_SCRIPTS)
def test_smoke_section_has_the_lines_of_performance_md(run_all_page, script):
    doc = _sections(PERFORMANCE_MD.read_text(encoding="utf-8"))[script]
    smoke = {_mask(line) for line in _sections(run_all_page)[script].splitlines()}
    missing = [line for line in _quoted_lines(doc) if line not in smoke]
    assert not missing, (f"benchmarks/{script} --smoke no longer prints these lines of "
                         "docs/performance.md (numbers masked); regenerate the page with "
                         "`python benchmarks/run_all.py` if the change is meant:\n"
                         + "\n".join(missing)
                         + f"\n\nsmoke output:\n{_sections(run_all_page)[script]}")


def test_end_to_end_smoke_has_the_readme_rows(run_all_page):
    out = _sections(run_all_page)["end_to_end.py"]
    assert_lines(
        out,
        r"\| pipeline \| ms \| pairs/s \| hopmatch / pipeline \|",
        table_row(r"hopmatch\.match_stereo \(arrays\)", NUM, NUM, r"1\.00"),
        table_row(r"ORB\(3000\) \+ BFMatcher ratio 0\.75", NUM, NUM, NUM),
        table_row(r"SIFT \+ BFMatcher ratio 0\.75", NUM, NUM, NUM),
        rf"Goals \(issue 3\): <= 1\.0x ORB: {NUM}x \((NOT )?met\); <= 0\.10x SIFT: {NUM}x "
        rf"\((NOT )?met\); under 33 ms: {NUM} ms \((NOT )?met\)",
        r"\| function \| own ms per pair \| share \|",
    )


def test_detector_smoke_has_the_readme_rows(run_all_page):
    out = _sections(run_all_page)["detector.py"]
    assert_lines(
        out,
        r"\| method \| ms \| ratio hopmatch / method \|",
        table_row(r"hopmatch detect \(KeyPoints\)", NUM, r"1\.00"),
        table_row(r"of which Deriche gradient \(float32 kernel\)", NUM, NUM),
        table_row(r"Deriche gradient with cv2\.ximgproc \(the reference\)", NUM, NUM),
        table_row(r"cv2\.GFTTDetector \(\d+ points\)", NUM, NUM),
        table_row(r"skimage corner_moravec \+ corner_peaks", NUM, NUM),
        rf"Goal: Deriche gradient, one image, vs cv2\.GFTTDetector detection with the same "
        rf"number of points: <= 0\.5x: {NUM}x, (NOT )?met \(cv2\.ximgproc: {NUM}x\)",
        table_row(r"gradient \(defaults\)", r"\d+", r"\d+", NUM, r"True|False", r"\d+", NUM),
        table_row("true correspondent", *[NUM] * 7),
        table_row("chance", *[NUM] * 7),
    )


def test_scale_smoke_has_the_readme_columns(run_all_page):
    out = _sections(run_all_page)["scale.py"]
    assert_lines(
        out,
        r"SIFT detectAndCompute on both images: \d+ ms, \d+ keypoints per image, peak \d+ MB",
        r"\| keypoints / image \| matches \| neurons \| interactions \| total ms \| match ms \| "
        r"peak MB \| hopmatch / SIFT \|",
        table_row(*[NUM] * 8),
        rf"Growth of total time with keypoints \(log-log slope; 1\.0 = linear\): {NUM}",
    )
    assert len(re.findall(r"^\| \d+ \|", out, re.M)) == 2, out


def test_first_call_smoke_has_the_readme_rows(run_all_page):
    out = _sections(run_all_page)["first_call.py"]
    assert_lines(
        out,
        r"\| cache \| import ms \| warmup\(\) ms \| first match_stereo after warmup ms \|",
        table_row(r"cold \(compile\), warmup\(1\): one process", r"\d+", r"\d+", r"\d+"),
        table_row(r"cold, warmup\(\): two processes on two cores", r"\d+", r"\d+", r"\d+"),
        table_row(r"warm \(load from disk\)", r"\d+", r"\d+", r"\d+"),
    )


# --------------------------------------------------------------------------------------
# The other scripts
# --------------------------------------------------------------------------------------


def test_memory_smoke():
    """docs/robustness.md quotes its columns image .. time and its two kinds of rows."""
    out = run_script("memory.py")
    row = (r"\d+ x \d+", r"\d+ MB \(peak RSS \d+ MB\)", r"\d+ B", r"[\d,]+", r"[\d.]+ s")
    assert_lines(
        out,
        r"\| call \| image \| extra peak memory \| per pixel \| keypoints \| time \|",
        table_row("detectAndCompute", *row),
        table_row(r"match_stereo \(pair\)", *row),
    )


def test_compile_times_smoke():
    """The per-kernel compile-time tables issue 17's work quotes (benchmarks/compile_times.py)."""
    out = run_script("compile_times.py")
    assert_lines(
        out,
        r"## Cold warmup\(\): [\d.]+ s wall, [\d.]+ s CPU .*warm cache: [\d.]+ s wall.*",
        r"\| kernel \| signatures \| s \| share \|",
        r"### Compiler passes \([\d.]+ s in all, own time\)",
    )


def test_threaded_share_smoke():
    """The threaded share and Amdahl's bound issue 17's note quotes
    (benchmarks/threaded_share.py), its serial profile table, the helpers' wall time at one
    and two threads and the two concurrent copies of one kernel."""
    out = run_script("threaded_share.py")
    assert_lines(
        out,
        r"\| total, threads=1 \| [\d.]+ \|",
        r"Threaded share [\d.]+%; Amdahl's bound for 2 threads [\d.]+x .*",
        r"\| function \| own ms per pair \|",
        r"\| `guided_kernels.py:row_searches` \| [\d.]+ \| [\d.]+ \| [\d.]+x \|",
        r"\| outside them \| [\d.]+ \| [\d.]+ \| [\d.]+x \|",
        r"\| match_stereo \| [\d.]+ \| [\d.]+ \| [\d.]+x \|",
        r"Two copies of one kernel at once \(refine_rows, \d+ matches, best of \d+\): one copy "
        r"[\d.]+ ms, two copies in two threads [\d.]+ ms, efficiency [\d.]+",
    )


def test_quality_smoke():
    """The table of docs/results.md, one row per method of hopmatch.compare."""
    from hopmatch.compare import METHODS

    out = run_script("quality.py")
    assert_lines(
        out,
        r"\| scene \| method \| matches \| correct@1 \| precision@1 \| recall@1 \| time ms \|",
        *[table_row("motorcycle", re.escape(m), r"\d+", r"\d+", r"[\d.]+|–", r"[\d.]+|–",
                    r"\d+") for m in METHODS],
    )


@pytest.mark.parametrize("args", [(), ("--grid", json.dumps({"seed": [0, 1, 2]}))],
                         ids=["defaults", "grid"])
def test_tune_smoke(args):
    """docs/parameters.md quotes SIFT's counts, scenes passing, worst precision and
    ``scene: correct/precision``."""
    out = run_script("tune.py", *args)
    first = "defaults" if not args else re.escape("{'seed': 0}")
    assert_lines(
        out,
        r"SIFT \+ ratio \+ band, correct@1px: motorcycle: \d+(, .+: \d+)*",
        rf"{first}: \d+/\d+ pass, worst precision [\d.]+ \| motorcycle: \d+/[\d.]+( \(miss\))?"
        r"(, .+)*",
    )
    if args:  # --smoke keeps the first two combinations of the grid
        assert "{'seed': 1}:" in out and "{'seed': 2}" not in out, out
    if SHARED_DATA.is_dir():
        assert "tsukuba: " in out, out


def test_rectification_check_smoke():
    """docs/robustness.md quotes its table: median |dy| (count, share in band) per shift."""
    out = run_script("rectification_check.py")
    cell = r"(\d+\.\d\d \(\d+, \d+%\)|n/a)"
    assert_lines(
        out,
        r"Clear look-alike ratio: [\d.]+",
        r"\| scene \| 0 px \| 3 px \| 8 px \| check time ms \|",
        table_row("motorcycle", cell, cell, cell, r"\d+"),
    )
    if SHARED_DATA.is_dir():
        assert_lines(out, table_row(r"middlebury/tsukuba", cell, cell, cell, r"\d+"))


def test_rectification_check_wide_smoke():
    """docs/robustness.md and docs/pipelines.md quote its table: the share kept on the
    rows and the wide check on the rectified and the far-off pair."""
    out = run_script("rectification_check.py", "--wide")
    cell = r"(\d+\.\d\d \(\d+, \d+%\)|n/a)"
    assert_lines(
        out,
        r"\| scene \| kept on the rows \| on their rows \| rectified: 100 \| ms \| 100, 300 \| "
        r"ms \| far off: on their rows \| 100 \| ms \| 100, 300 \| ms \|",
        table_row("motorcycle", r"\d+\.\d%", r"\d\.\d\d", *(cell, r"\d+") * 2,
                  r"\d\.\d\d", *(cell, r"\d+") * 2),
    )


def test_rectification_check_costs_smoke():
    """docs/robustness.md quotes its table: the look-alike searches' times per scene."""
    out = run_script("rectification_check.py", "--costs")
    assert_lines(out, r"\| scene \| pairs in the wide band \| prior ms \| wide check ms \| "
                      r"stereo-pair check ms \| 2-D bootstrap ms \|",
                 table_row("motorcycle", r"\d+", *[r"\d+\.\d"] * 4))


def test_rectification_check_defaults_smoke(shared_data):
    """docs/robustness.md quotes its table: what the defaults do and cost on the rectified
    chessboard pairs against rectified=True."""
    out = run_script("rectification_check.py", "--defaults", "--chessboards")
    assert_lines(out, r"\| pair \| on the rows \| default \| search \| within 1 px of the row \| "
                      r"rows ms \| default ms \|",
                 table_row("chessboard 01", r"\d+", r"\d+", r"(rows|aligned|rectified|epipolar)",
                           r"(\d\.\d{3}|n/a)", r"\d+", r"\d+"))


def test_rectification_check_chessboards_smoke(shared_data):
    out = run_script("rectification_check.py", "--chessboards")
    cell = r"(\d+\.\d\d \(\d+, \d+%\)|n/a)"
    assert_lines(out, r"\| scene \| 0 px \| 3 px \| 8 px \| check time ms \|",
                 table_row("chessboard 01", cell, cell, cell, r"\d+"))


@pytest.mark.parametrize("args", [(), ("--band", "3", "--shift", "2", "--params",
                                       json.dumps({"vertical_check": "multiple"}))],
                         ids=["defaults", "options"])
def test_chessboard_dy_smoke(shared_data, args):
    """docs/pipelines.md and docs/parameters.md quote its |dy| shares and classification."""
    out = run_script("chessboard_dy.py", *args)
    counts = r"off board \d+, other corner \d+, along an edge \d+, same point \d+"
    assert_lines(
        out,
        r"band (4|3) px, parameters \{.*\}, right images shifted (0|2) px",
        r"all pairs: [\d.]+% of \d+ matches with \|dy\| <= 1 px",
        r"pair 01: [\d.]+% of \d+ matches with \|dy\| <= 1 px",
        rf"matches with \|dy\| <= 1 px: \d+: {counts}",
        rf"matches with \|dy\| > 1 px: \d+: {counts}",
    )


def test_chessboard_geometry_smoke(shared_data):
    """The session notes of issue 18 quote its columns."""
    out = run_script("chessboard_geometry.py")
    pair = (r"\| 0[12] \| (aligned|rectified|epipolar|-) \| \w+ \| [\d.]+% of \d+ \| "
            r"[\d.]+ / [\d.]+ \| [\d.]+ / [\d.]+ \| -?[\d.]+ \.\. -?[\d.]+ \| "
            r"-?[\d.]+ \.\. -?[\d.]+ \|")
    assert_lines(out, r"## Raw chessboard pairs: the geometry match_stereo\(rectified=False\) "
                      r"settles on", pair)
    assert len(re.findall(pair, out)) == 2
    area = (r"\| 0[12] \| [\d.]+% of \d+ \| ([\d.]+% of \d+|0 of 0) \| "
            r"([+-][\d.]+ \(\d+\)|-) \| ([+-][\d.]+ \(\d+\)|-) \|")
    assert_lines(out, r"## Raw chessboard pairs: the calibrated lines outside and inside the "
                      r"calibrated area",
                 r"calibrated area: the hull of the board corners of \d+ pairs, \d+% of the "
                 r"left image",
                 r"pooled: match_stereo [\d.]+% of \d+ on lines outside the calibrated area, "
                 r"[\d.]+% of \d+ inside; SIFT median signed distance [+-][\d.]+ px outside "
                 r"\(\d+\), [+-][\d.]+ px inside \(\d+\)")
    assert len(re.findall(area, out)) == 2
    on = r"([\d.]+% of \d+|0 of 0)"
    lens = table_row("0[12]", rf"[+-]{NUM} \({NUM}\)", rf"[+-]{NUM}", on, on, on)
    assert_lines(out, r"## Raw chessboard pairs: one lens-distortion parameter estimated from "
                      r"the pair",
                 rf"lam fitted to the calibration \(mean of both cameras\): [+-]{NUM}",
                 r"pooled: raw [\d.]+% of \d+; estimated lam [\d.]+% of \d+; calibration's "
                 r"lam [\d.]+% of \d+")
    assert len(re.findall(lens, out)) == 2


def test_dask_batch_smoke():
    """docs/cluster.md quotes its workers, pairs/s and speed-up columns."""
    pytest.importorskip("distributed")
    pytest.importorskip("hopmatch_dask")
    out = run_script("dask_batch.py")
    assert_lines(
        out,
        r"# hopmatch batch on a LocalCluster: 4 pairs of 160x120, max_disparity 16",
        r"\| workers \| cluster start \(s\) \| pairs/s \| speed-up \|",
        table_row("1", NUM, NUM, r"1\.00x"),
    )


def test_fingerprint_smoke():
    """Two lines per scene, ``name mode n_left n_right n_matches digest``."""
    out = run_script("fingerprint.py")
    scenes = ["motorcycle"] + (["middlebury/tsukuba"] if SHARED_DATA.is_dir() else [])
    expected = [rf"{re.escape(name)} +{mode} +\d+ +\d+ +\d+  [0-9a-f]{{16}}"
                for name in scenes for mode in ("defaults", "range")]
    lines = out.splitlines()
    assert len(lines) == len(expected), out
    for pattern, line in zip(expected, lines):
        assert re.fullmatch(pattern, line), f"{line!r} does not match {pattern!r}"


def test_refine_stages_smoke():
    """docs/parameters.md quotes its variant rows (the ablation of the refinement's second
    stage, issue 21) and its drift line."""
    out = run_script("refine_stages.py")
    labels = [r"first stage only \(7x7 square, linear\)", r"defaults \(both stages\)",
              "second stage with square windows", "second stage with uniform weights",
              "second stage with cubic interpolation", "second stage with 7x7 windows"]
    assert_lines(
        out,
        r"\| variant \| motorcycle \| correct \|",
        *[table_row(label, NUM, r"\d+") for label in labels],
        *[table_row(label, NUM) for label in labels],
        rf"drift of the errors' plane across the image width \(px\), defaults \(both "
        rf"stages\): motorcycle [+-]{NUM[1:]}",
    )


def test_wrong_matches_smoke():
    """docs/parameters.md quotes its columns and pooled line (the half-window test)."""
    out = run_script("wrong_matches.py")
    lines = out.splitlines()
    assert lines[0] == ("scene | scored | wrong | by pass 0/1 | err 1-2/2-5/>5 | sign +/- | "
                        "edge <=2 (all) | edge <=4 (all) | test drops wrong/correct")
    assert len(lines) == 3, out
    assert re.fullmatch(r"\S+ \| \d+ \| \d+ \| \d+/\d+ \| \d+/\d+/\d+ \| \d+/\d+ \| "
                        r"[\d.]+ \([\d.]+\) \| [\d.]+ \([\d.]+\) \| \d+/\d+", lines[1]), lines[1]
    assert re.fullmatch(r"pooled: \d+ scored, \d+ wrong; the test drops \d+ wrong and \d+ "
                        r"correct", lines[2]), lines[2]


def test_recall_losses_smoke():
    """docs/parameters.md quotes both tables' headers and pooled rows (issue 21's losses)."""
    out = run_script("recall_losses.py")
    lines = out.splitlines()
    assert lines[1] == ("scene | with gt | SGBM correct | hopmatch correct | lost | wrong | "
                        "no right kp | no candidate | net said no | sec. 4 | half-win net | "
                        "half-win guided")
    assert re.fullmatch(r"pooled( \| \d+){11}", lines[3]), lines[3]
    assert lines[6].startswith("scene | never matched | few neighbours | ")
    assert re.fullmatch(r"pooled( \| \d+){14}", lines[8]), lines[8]


def test_clipping_smoke():
    """docs/robustness.md quotes its table's columns and pooled lines (clipped exposures)."""
    lines = run_script("clipping.py").splitlines()
    assert lines[0] == ("| scene | gain | right pixels clipped | B / G / R | correct "
                        "unperturbed | of them unclipped | correct clipped |")
    for row in lines[2:4]:
        assert re.fullmatch(r"\| motorcycle \| [\d.]+ \| [\d.]+% \| \d+% / \d+% / \d+% \| "
                            r"\d+ \| \d+ \| \d+ \|", row), row
        unperturbed, unclipped = (int(v) for v in row.split(" | ")[4:6])
        assert 0 < unclipped <= unperturbed, row
    assert re.fullmatch(r"pooled, gain 1.3: \d+ correct unperturbed, \d+ of them with an "
                        r"unclipped right window, \d+ correct on the clipped pair", lines[5])


def test_recall_losses_oracle_prediction_predicts_the_truth():
    """``--oracle-prediction`` (docs/parameters.md quotes it): with the ground truth as
    the guided rounds' prediction, the lost points whose prediction was more than 1 px off
    all but vanish (the few left have no bilinear ground truth at the point)."""
    def pred_wrong(*args):
        lines = run_script("recall_losses.py", *args).splitlines()
        column = lines[6].split(" | ").index("off pred (pred wrong)")
        assert lines[8].startswith("pooled | ")
        return int(lines[8].split(" | ")[column])

    plain, oracle = pred_wrong(), pred_wrong("--oracle-prediction")
    assert plain >= 10 and oracle <= plain // 4, (plain, oracle)


def test_recall_losses_continuity_support_counts_subsets():
    """``--continuity-support`` (docs/parameters.md quotes it): the refused candidates, then
    each rule's: a subset of them (fewer for a larger group, right ones among them)."""
    lines = run_script("recall_losses.py", "--continuity-support").splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("## continuity: "))
    total, right = map(int, re.fullmatch(
        r"## continuity: (\d+) candidates the field refused \(left point never matched, "
        r"with ground truth\), (\d+) of them right \([\d.]+\)", lines[head]).groups())
    assert 0 < right <= total
    rules = [row.split(" | ") for row in lines[head + 2:head + 11]]
    assert [(r[0], r[1]) for r in rules] == [(k, f) for f in ("0.3", "0.5", "0.7")
                                             for k in ("3", "5", "8")]
    for f in range(3):
        counts = [int(r[2]) for r in rules[3 * f:3 * f + 3]]
        assert counts == sorted(counts, reverse=True) and counts[0] <= total, counts
    assert all(int(r[3]) <= int(r[2]) for r in rules)


def test_recall_losses_perturbed_maps_the_right_points_back():
    """``--perturb dy3``: SGBM still scores the unperturbed pair (same SGBM-correct count),
    and hopmatch's matches in the shifted right image are mapped back before scoring (not
    mapped, every one would be 3 px off and none correct)."""
    def pooled(*args):
        row = run_script("recall_losses.py", *args).splitlines()[3]
        return [int(v) for v in row.split(" | ")[1:]]

    plain, shifted = pooled(), pooled("--perturb", "dy3")
    assert shifted[1] == plain[1]
    assert shifted[2] >= 0.5 * plain[2] > 0, (plain, shifted)


def test_kernel_ab_smoke():
    """The kernel rows and the two-thread bound issue 17's speed work quotes
    (benchmarks/kernel_ab.py), with and without another checkout (this one, so the
    outputs must be identical)."""
    out = run_script("kernel_ab.py", "--against", str(ROOT))
    assert_lines(
        out,
        r"\| kernel call \| items \| CPU ms \| other CPU ms \| ratio \| outputs \|",
        table_row(r"refine_rows #1", r"\d+", NUM, NUM, NUM, "identical"),
        table_row(r"row_search #1", r"\d+", NUM, NUM, NUM, "identical"),
        rf"match_stereo\(threads=2\), 2 calls: .*speed-up \(CPU / calling thread\): {NUM} .*",
    )
    assert_lines(run_script("kernel_ab.py"), r"\| kernel call \| items \| CPU ms \|",
                 table_row(r"refine_rows #2", r"\d+", NUM))


def test_passes_grey_changes_and_grid_smoke():
    """docs/robustness.md ("JPEG, noise and blur") quotes passes.py's pooled lines with
    ``--grid`` and the grey-level perturbations, ``lr-`` ones on both views; an unknown or
    misapplied change is refused."""
    out = run_script("passes.py", "--grid", "--perturb", "lr-jpeg30+noise2", "blur1")
    assert_lines(
        out,
        r"## perturbation: lr-jpeg30\+noise2; params defaults",
        r"motorcycle \| \d+ \| \d+ \| [\d.]+ \| .* \| grid-locked \d+ of \d+ wrong \| steps by "
        r"phase: left \d:\d\.\d\d/\d:\d\.\d\d, right \d:\d\.\d\d/\d:\d\.\d\d",
        r"pooled: \d+ matches, \d+ correct, precision [\d.]+, worst [\d.]+ \(motorcycle\); "
        r"grid-locked \d+ of \d+ wrong",
        r"## perturbation: blur1; params defaults",
    )
    # the left view, saved as a JPEG (the right one has noise on top), has the block grid
    # at phase 7 along x and y; unperturbed, it has none
    rows = [line for line in out.splitlines() if line.startswith("motorcycle")]
    grid = [re.search(r"left (\d):([\d.]+)/(\d):([\d.]+),", row).groups() for row in rows]
    assert grid[0][0] == grid[0][2] == "7" and min(float(grid[0][1]), float(grid[0][3])) > 1.1
    assert max(float(grid[1][1]), float(grid[1][3])) < 1.1, rows[1]
    for bad in ("lr-gain0.5", "fog3", "crop1.5"):
        proc = subprocess.run([sys.executable, str(BENCHMARKS / "passes.py"), "--smoke",
                               "--perturb", bad], cwd=ROOT, capture_output=True, text=True,
                              timeout=TIMEOUT)
        assert proc.returncode != 0 and bad in proc.stderr, proc.stderr


def test_passes_both_features_smoke():
    """docs/parameters.md ("Points on both feature images") quotes ``--both-features``: the
    added matches are passes 2 and 3, SGBM is sampled at both runs' points, and ``--both``
    sets the module's constants (an unknown one is refused)."""
    out = run_script("passes.py", "--both-features", "--baselines", "--both",
                     '{"MIN_SUPPORT": 0}')
    assert_lines(
        out,
        r'## perturbation: none; params \{.both_features.: True\}; both feature images '
        r'\{"MIN_SUPPORT": 0\}',
        r"motorcycle \| \d+ \| \d+ \| [\d.]+ \| .*\b[23]: \d+/.* \| \d+ \| \d+ \| \d+",
        r"pooled: \d+ matches, \d+ correct, precision [\d.]+, .*SGBM \d+ \([\d.]+x\)",
    )
    proc = subprocess.run([sys.executable, str(BENCHMARKS / "passes.py"), "--smoke",
                           "--both", '{"NOPE": 1}'], cwd=ROOT, capture_output=True, text=True,
                          timeout=TIMEOUT)
    assert proc.returncode != 0 and "NOPE" in proc.stderr, proc.stderr


def test_passes_crop_cuts_the_right_view_only():
    """``crop0.1`` cuts the right-most tenth of the right view's columns (a right view of
    another width, docs/robustness.md), ``top6`` its top 6 rows (the right points then
    map back 6 px lower): the pair still matches."""
    sys.path.insert(0, str(BENCHMARKS))
    try:
        from passes import perturb
    finally:
        sys.path.remove(str(BENCHMARKS))
    right = np.zeros((40, 100, 3), np.uint8)
    cut, m = perturb(right, "dy1+crop0.1")
    assert cut.shape == (40, 90, 3) and cut.flags.c_contiguous and m[1, 2] == 1.0
    cut, m = perturb(right, "dy1+top6")  # rows cut off the top: y smaller by 6 after
    assert cut.shape == (34, 100, 3) and m[1, 2] == -5.0
    # left- moves the left view only, and says how
    from passes import perturb_left
    left = np.zeros((40, 100), np.uint8)
    left[10:20, 30:40] = 255
    moved, m_left = perturb_left(left, "left-dy2+rot1")
    assert m_left[1, 2] == 2.0 and np.array_equal(moved[12:22, 30:40], left[10:20, 30:40])
    assert np.array_equal(perturb(right, "left-dy2")[1], np.eye(3))
    out = run_script("passes.py", "--perturb", "crop0.1", "top6")
    assert_lines(out, r"## perturbation: crop0\.1; params defaults",
                 r"motorcycle \| [1-9]\d+ \| \d+ \| 0\.9\d+ \| .*",
                 r"## perturbation: top6; params defaults",
                 r"motorcycle \| [1-9]\d+ \| \d+ \| 0\.9\d+ \| .*")


def test_end_to_end_jpeg_smoke():
    """``--jpeg Q`` times every pipeline on JPEG inputs and says so in the heading."""
    out = run_script("end_to_end.py", "--jpeg", "75")
    assert_lines(
        out,
        r"## End to end on motorcycle \(\d+x\d+, grey, both images saved as JPEGs of quality "
        r"75\), single thread",
        table_row("drop-in: detectAndCompute x2 \\+ setPairInfo \\+ match", NUM, NUM, NUM, NUM),
    )


def test_textured_pair_smoke():
    """docs/parameters.md ("Disparity range") quotes its lines: keypoints and thinning,
    matches and precision, time and memory against SIFT; the smoke pair's plane is known,
    so its matches are scored and right."""
    out = run_script("textured_pair.py")
    lines = out.splitlines()
    assert lines[0].startswith("## A textured 600 x 400 pair (noise blurred by 1 px")
    assert re.fullmatch(r"keypoints \d+ / \d+; the network ran on (every left point|\d+ of "
                        r"\d+ left points \(thinned\)); range \[[\d.-]+, [\d.-]+\] px",
                        lines[2]), lines[2]
    got = re.fullmatch(r"matches (\d+); correct at 1 px (\d+) \(precision ([\d.]+)\)", lines[3])
    assert got and int(got[1]) > 1000 and float(got[3]) > 0.99, lines[3]
    assert re.fullmatch(r"time [\d.]+ s; peak memory \d+ MB; SIFT detectAndCompute on both "
                        r"images [\d.]+ s \(ratio [\d.]+\)", lines[4]), lines[4]
    assert lines[5].startswith("stages: detect_left ")


def test_thinned_network_smoke():
    """docs/parameters.md ("Disparity range") quotes its header and pooled line."""
    out = run_script("thinned_network.py")
    lines = out.splitlines()
    assert lines[0] == ("scene | defaults correct / precision | max_neurons = pairs / 4: left "
                        "points of the network | correct / precision")
    assert re.fullmatch(r"motorcycle \| \d+ / [\d.]+ \| (refused \(max_neurons=\d+\) \| -|"
                        r"\d+ of \d+ \| \d+ / [\d.]+)", lines[1]), lines[1]
    assert re.fullmatch(r"pooled over the \d+ scenes run both ways: defaults \d+ correct, "
                        r"thinned \d+ \([\d.]+x\)", lines[2]), lines[2]


def test_neighbour_density_smoke():
    """docs/parameters.md ("Sparse keypoints") quotes its columns: keypoints and median
    neighbours per detector, and the growth min_neighbours gives; the detector's own
    points are dense enough not to grow, nms_size 15's are not."""
    out = run_script("neighbour_density.py")
    cellre = r"\d+:[\d.]+(?: \(x[\d.]+\))?"
    assert_lines(out,
                 r"\| scene \| defaults \| nms_size 9 \| nms_size 15 \| max_features 2000 \| "
                 r"SIFT \| ORB\(3000\) \|",
                 table_row("motorcycle", r"\d+:[\d.]+", *[cellre] * 2, r"\d+:[\d.]+", cellre,
                           cellre))
    row = next(line for line in out.splitlines() if line.startswith("| motorcycle"))
    assert "(x" in row.split("|")[4], row  # nms_size 15 grows the window


def test_passes_size_and_mirror_make_consistent_scenes():
    """``size`` resizes a whole scene (its truth scaled with it), ``mirror`` swaps and
    mirrors the views of a scene with the right view's truth (docs/parameters.md, "Other
    image sizes, mirrored scenes..."): the truth of the scene made still maps each left
    pixel onto the same right pixel."""
    sys.path.insert(0, str(BENCHMARKS))
    try:
        from passes import mirrored_scene, resized_scene
    finally:
        sys.path.remove(str(BENCHMARKS))
    from hopmatch.datasets import StereoScene
    rng = np.random.default_rng(0)
    right = rng.integers(0, 256, (30, 80), dtype=np.uint8)
    d = np.zeros((30, 80), np.float32)
    d[:, :40], d[:, 40:] = 3.0, 7.0  # left (x, y) shows right (x - d, y)
    left = np.zeros_like(right)
    for x in range(80):
        left[:, x] = right[:, max(x - int(d[0, x]), 0)]
    d_right = np.full((30, 80), np.nan, np.float32)  # right (x, y) shows left (x + d, y)
    for x in range(80):
        d_right[:, max(x - int(d[0, x]), 0)] = d[0, x]
    scene = StereoScene("synthetic", left, right, d, None, "", disparity_right=d_right)
    mirrored = mirrored_scene(scene)
    assert mirrored_scene(dataclasses.replace(scene, disparity_right=None)) is None
    checked = 0
    for x in range(80):
        dm = mirrored.disparity[0, x]
        if np.isfinite(dm) and x - dm >= 0:
            assert np.array_equal(mirrored.left[:, x], mirrored.right[:, int(x - dm)])
            checked += 1
    assert checked > 60
    half = resized_scene(scene, "dy1+size0.5")
    assert half.left.shape == half.right.shape == half.disparity.shape == (15, 40)
    assert set(np.unique(half.disparity)) == {1.5, 3.5}
    assert resized_scene(scene, "dy1") is scene
    out = run_script("passes.py", "--perturb", "size0.5", "mirror")
    assert_lines(out, r"## perturbation: size0\.5; params defaults",
                 r"motorcycle \| [1-9]\d+ \| \d+ \| (0\.9\d\d|1\.000) \| .*",
                 r"pooled: .* worst [\d.]+ \(motorcycle\)",
                 r"## perturbation: mirror; params defaults",
                 r"pooled: no scene \(mirror needs a scene with disparity_right\)")
