"""Nothing lost: a capture killed with SIGKILL and resumed gives the uninterrupted session."""

from __future__ import annotations

from pathlib import Path

import pytest

from volcal.steps.capture import capture

from .conftest import FAST, FAST_CLI
from .fake_sources import accepted, kill_capture_after

IDS = ["linear-x1", "diag-ppp"]


def _kill_after(planned: Path, out: Path, n: int, speed: float = 20.0) -> list[int]:
    """Start ``volcal capture`` in a process, SIGKILL it after ``n`` accepted points."""
    return kill_capture_after([str(planned), "--control", "sim", "--laser", "sim", "-o",
                               str(out), *[a for i in IDS for a in ("--measurement", i)],
                               *FAST_CLI, "--speed", str(speed)],
                              out / "capture" / "linear-x1.jsonl", n)


@pytest.fixture(scope="module")
def uninterrupted(planned, tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "A"
    assert capture(planned, control="sim", laser="sim", measurement=IDS, output=out,
                   **FAST).complete
    return out


def test_sigkill_in_the_middle_and_resume_give_the_same_session(planned, uninterrupted,
                                                                tmp_path):
    out = tmp_path / "B"
    before = _kill_after(planned, out, 4)
    assert 4 <= len(before) < 16 and before == list(range(len(before)))
    r = capture(planned, control="sim", laser="sim", measurement=IDS, output=out, **FAST)
    assert r.complete
    after = accepted(out / "capture" / "linear-x1.jsonl")
    assert sorted(after) == list(range(16))  # no point lost, none twice
    assert r.outcomes[0].replayed >= len(before)
    for mid in IDS:
        assert (out / f"{mid}.csv").read_text() == (uninterrupted / f"{mid}.csv").read_text()
    assert (out / "session.toml").read_text() == (uninterrupted / "session.toml").read_text()
    assert not list(out.glob(".*.tmp"))  # no temporary file left by the kill


@pytest.mark.slow
@pytest.mark.parametrize("n", [1, 7, 12, 15])
def test_sigkill_anywhere_and_resume_give_the_same_session(planned, uninterrupted, tmp_path,
                                                          n):
    """Killed after n points, resumed, killed again, resumed (make study)."""
    out = tmp_path / "B"
    _kill_after(planned, out, n)
    if n < 15:
        _kill_after(planned, out, n + 1)
    assert capture(planned, control="sim", laser="sim", measurement=IDS, output=out,
                   **FAST).complete
    assert sorted(accepted(out / "capture" / "linear-x1.jsonl")) == list(range(16))
    for mid in IDS:
        assert (out / f"{mid}.csv").read_text() == (uninterrupted / f"{mid}.csv").read_text()
