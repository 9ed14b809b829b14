"""``volcal capture`` of an R-test killed and resumed (SIGKILL: no handler runs).

The capture runs as a user runs it, a process of its own with the simulated control at
20 times real time, killed once it has accepted three poses; the journal's last line may
be torn. A file of its own because it waits on real time: ``make test`` runs it in the
real-time process beside the two workers (the Makefile's REALTIME_TESTS).
"""

from __future__ import annotations

from volcal.capture.journal import journal_path
from volcal.steps.capture import capture

from .conftest import FAST, FAST_CLI
from .fake_sources import accepted, kill_capture_after
from .test_capture_rtest import RT, SEED, N, rt_planned  # noqa: F401 - the module's fixture


def test_sigkill_in_the_middle_and_resume_give_the_same_file(rt_planned, tmp_path):  # noqa: F811
    """Every pose once after the resume, the three sensors of each, and the uninterrupted
    capture's file byte for byte."""
    ref = tmp_path / "A"
    assert capture(rt_planned, control="sim", laser=f"sim:seed={SEED}", output=ref,
                   **FAST).complete
    out = tmp_path / "K"
    journal = journal_path(out, RT)
    kill_capture_after([str(rt_planned), "--control", "sim", "--laser", f"sim:seed={SEED}",
                        "-o", str(out), *FAST_CLI, "--speed", "20"], journal, 3)
    before = accepted(journal)
    assert 3 <= len(before) < N and before == list(range(len(before)))
    r = capture(rt_planned, control="sim", laser=f"sim:seed={SEED}", output=out, **FAST)
    assert r.complete and r.outcomes[0].replayed >= len(before)
    assert sorted(accepted(journal)) == list(range(N))  # none lost, none twice
    assert (out / f"{RT}.csv").read_text() == (ref / f"{RT}.csv").read_text()
