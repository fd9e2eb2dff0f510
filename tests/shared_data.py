"""Where ../shared/data is, for the tests (a module, not conftest.py: the name ``conftest``
belongs to whichever of the tests' conftest files pytest imported last)."""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("HOPMATCH_SHARED_DATA", ROOT.parent / "shared" / "data"))
NO_SHARED_DATA = (
    f"../shared/data is absent (looked in {SHARED_DATA}); these tests need the shared stereo "
    "data beside the project, or HOPMATCH_SHARED_DATA pointing at it"
)
