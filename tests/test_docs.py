"""The documentation site and the docstring examples, so that neither can rot.

- ``mkdocs build --strict`` of ``mkdocs.yml`` (mkdocs + mkdocstrings[python], the ``docs``
  and ``test`` extras) into a temporary folder: every page of the nav must exist, every
  docstring must parse as numpydoc, every API reference must resolve. The API pages must
  show the main classes and functions.
- Links from the pages to files of the repository outside ``docs/`` (``../examples/...``),
  which mkdocs can only report, must name files that exist.
- The Examples of every docstring of hopmatch and of its plugins run with :mod:`doctest`,
  module by module, with no failure, and at least ``MIN_EXAMPLES`` of them.
"""

from __future__ import annotations

import doctest
import importlib
import importlib.util
import io
import os
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PACKAGES = ("hopmatch", "hopmatch_gapi", "hopmatch_dask")
#: Fewer examples of hopmatch itself than this means docstrings lost their Examples (or
#: were not found); 175 when this was written.
MIN_EXAMPLES = 160


# --------------------------------------------------------------------------------------
# The site
# --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """Build the site once: (site folder, combined stdout + stderr of the build)."""
    out = tmp_path_factory.mktemp("site") / "site"
    res = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
         str(ROOT / "mkdocs.yml"), "--site-dir", str(out)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=300,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )
    assert res.returncode == 0, f"mkdocs build --strict failed:\n{res.stdout}"
    return out, res.stdout


def test_strict_build_succeeds(site):
    out, log = site
    assert (out / "index.html").is_file()
    assert not re.search(r"^(WARNING|ERROR)\b", log, re.M), log


@pytest.mark.parametrize("page", [
    "index", "method", "migration", "parameters", "cli", "results", "performance",
    "cluster", "gapi", "citations", "api",
])
def test_page_is_built(site, page):
    assert (site[0] / f"{page}.html").is_file(), f"docs/{page}.md is missing from the site"


API_OBJECTS = {
    "api.html": ["hopmatch.DericheMoravecDetector",
                 "hopmatch.DericheMoravecDetector.detectAndCompute",
                 "hopmatch.HopfieldMatcher", "hopmatch.HopfieldMatcher.setPairInfo",
                 "hopmatch.HopfieldMatcher.knnMatch", "hopmatch.match_stereo",
                 "hopmatch.hopfield_match", "hopmatch.StereoMatchResult",
                 "hopmatch.NetworkResult", "hopmatch.warmup", "hopmatch.StereoHopfield",
                 "hopmatch.StereoHopfield.compute"],
    "api-feature.html": ["hopmatch.deriche_gradient", "hopmatch.moravec_response",
                         "hopmatch.moravec_points", "hopmatch.gradient_windows"],
    "api-stereo.html": ["hopmatch.stereo.rectify", "hopmatch.stereo.triangulate_matches",
                        "hopmatch.stereo.StereoCalibration"],
    "api-datasets.html": ["hopmatch.datasets.load_scene", "hopmatch.datasets.StereoScene"],
    "api-evaluate.html": ["hopmatch.evaluate.score_matches", "hopmatch.evaluate.MatchScore"],
    "api-viz.html": ["hopmatch.viz.draw_matches", "hopmatch.viz.draw_keypoints_on_gradient",
                     "hopmatch.viz.draw_labelled_matches", "hopmatch.viz.draw_match_overview",
                     "hopmatch.viz.draw_keypoint_disparities"],
    "api-errors.html": ["hopmatch.errors.InvalidArgumentError",
                        "hopmatch.errors.BudgetExceededError"],
    "api-plugins.html": ["hopmatch_gapi.ops.GMatch", "hopmatch_gapi.kernels.kernels",
                         "hopmatch_dask.batch.run_batch", "hopmatch_dask.batch.match_pairs"],
}


@pytest.mark.parametrize("page", sorted(API_OBJECTS))
def test_api_pages_list_the_public_objects(site, page):
    html = (site[0] / page).read_text(encoding="utf-8")
    missing = [name for name in API_OBJECTS[page] if f'id="{name}"' not in html]
    assert not missing, f"{page} has no entry for {missing}"


def test_api_page_shows_docstrings(site):
    html = (site[0] / "api.html").read_text(encoding="utf-8")
    # numpydoc sections rendered, not shown as raw text
    assert "Parameters" in html and "Examples" in html
    assert "Moravec interest points on a Canny-Deriche gradient-magnitude image" in html
    assert "---------" not in html


def test_links_to_repository_files_exist(site):
    """Links mkdocs cannot resolve (files outside docs/) must name files of the repository."""
    _, log = site
    pattern = re.compile(
        r"Doc file '([^']+)' contains (?:an unrecognized relative link|a link) '([^']+)'")
    broken = []
    for page, link in pattern.findall(log):
        target = link.split("#", 1)[0]
        if not target or re.match(r"^[a-z]+:", target):
            continue
        path = (DOCS / page).parent / target
        if not path.exists():
            broken.append(f"docs/{page}: {link}")
    assert not broken, "links to files that do not exist:\n" + "\n".join(broken)


# --------------------------------------------------------------------------------------
# Doctests
# --------------------------------------------------------------------------------------


def _module_names() -> list[str]:
    """Every module of hopmatch and its plugins, found without importing the plugins."""
    names = []
    for package in PACKAGES:
        spec = importlib.util.find_spec(package)
        if spec is None:
            continue
        names.append(package)
        for info in pkgutil.walk_packages(spec.submodule_search_locations, package + "."):
            if "__pycache__" not in info.name:
                names.append(info.name)
    return sorted(names)


MODULES = _module_names()


def _run_doctests(name: str) -> tuple[int, int, str]:
    """(attempted, failed, report) of the docstring examples of module ``name``."""
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    report = io.StringIO()
    for test in finder.find(module, name):
        runner.run(test, out=report.write)
    failed, attempted = runner.summarize(verbose=False)
    return attempted, failed, report.getvalue()


@pytest.fixture(scope="module")
def doctest_results(tmp_path_factory):
    """Run the doctests of every module once, in a temporary working directory."""
    results = {}
    cwd = os.getcwd()
    os.chdir(tmp_path_factory.mktemp("doctest-cwd"))
    try:
        for name in MODULES:
            try:
                results[name] = _run_doctests(name)
            except ImportError as exc:
                if name.split(".")[0] == "hopmatch":
                    raise
                # hopmatch_gapi on OpenCV 5 (no Python G-API custom ops), or no dask
                results[name] = exc
    finally:
        os.chdir(cwd)
    return results


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(doctest_results, name):
    result = doctest_results[name]
    if isinstance(result, ImportError):
        pytest.skip(f"{name} cannot be imported here: {result}")
    attempted, failed, report = result
    assert failed == 0, f"{failed} of {attempted} docstring examples of {name} failed:\n{report}"


def test_enough_docstring_examples_ran(doctest_results):
    counts = {n: r[0] for n, r in doctest_results.items() if not isinstance(r, ImportError)}
    per_package = {}
    for name, n in counts.items():
        per_package[name.split(".")[0]] = per_package.get(name.split(".")[0], 0) + n
    assert per_package.get("hopmatch", 0) >= MIN_EXAMPLES, \
        f"only {per_package.get('hopmatch', 0)} docstring examples of hopmatch ran: {counts}"
    for plugin in ("hopmatch_gapi", "hopmatch_dask"):
        importable = plugin in counts  # the package itself; hopmatch_gapi is not on OpenCV 5
        if importable:
            assert per_package.get(plugin, 0) > 0, f"{plugin} has no docstring examples"
    # every public module of the package carries examples
    for name in ("hopmatch", "hopmatch.feature.detector", "hopmatch.feature.gradient",
                 "hopmatch.feature.moravec", "hopmatch.feature.descriptor",
                 "hopmatch.matching.matcher", "hopmatch.matching.stereo_match",
                 "hopmatch.stereo", "hopmatch.datasets", "hopmatch.evaluate", "hopmatch.viz",
                 "hopmatch.errors"):
        assert counts.get(name, 0) > 0, f"{name} has no docstring examples"


# --------------------------------------------------------------------------------------
# README: numbers a user can reproduce (issue 19, point 8)
# --------------------------------------------------------------------------------------


def test_readme_speed_table_leads_with_ratios():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index("**Speed**"):text.index("## Documentation")]
    header = next(ln for ln in section.splitlines() if ln.startswith("| measurement"))
    assert header.split("|")[2].strip() == "hopmatch / peer"
    rows = [ln for ln in section.splitlines() if ln.startswith("| ") and "x |" in ln]
    assert rows and all(re.search(r"\| \**[\d.]+x\** \|", ln) for ln in rows)
    words = " ".join(section.split())
    assert "depend on the machine" in words and "hopmatch demo" in words
