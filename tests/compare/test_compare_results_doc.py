"""docs/results.md as hopmatch eval --docs writes it (hopmatch.compare.results_doc)."""

from __future__ import annotations

from hopmatch import compare


class TestResultsDocOnTsukuba:
    def test_results_doc(self, tsukuba_rows):
        scene, rows = tsukuba_rows
        text = compare.format_results_doc(
            rows, [scene], pictures={"img/x.png": "a caption"},
            machine=compare.machine_description(), created="now", elapsed=1.0)
        assert compare.DOCS_COMMAND in text.splitlines()[2]
        assert "### middlebury/tsukuba" in text and "![a caption](img/x.png)" in text
        assert "0 .. ceil(1.1" in text and scene.source in text
