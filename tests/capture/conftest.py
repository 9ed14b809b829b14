"""A small planned session for the capture tests (built once per module)."""

from __future__ import annotations

from pathlib import Path

import pytest

#: Program and rule options that keep a simulated capture short: 2 s dwells, 0.6 s stable
#: windows polled every 50 ms.
FAST = {"dwell_s": 2.0, "stable_s": 0.6, "max_gap_s": 0.3, "poll_s": 0.05}
FAST_CLI = ["--dwell-s", "2", "--stable-s", "0.6", "--max-gap-s", "0.3", "--poll-s", "0.05"]


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A planned session: linear tests (3 steps, 2 runs) and body diagonals, 200x150x100."""
    from volcal.steps.plan import plan

    out = tmp_path_factory.mktemp("capture") / "S"
    plan((( 0.0, 200.0), (0.0, 150.0), (0.0, 100.0)), steps=3, tests="linear,diagonal",
         runs=2, output=out)
    return out
