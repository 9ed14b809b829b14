"""A capture-order export (targets and errors only, as a laser records them) imports with
runs and directions inferred, and evaluates to ISO 230-2 like the explicit table."""

from __future__ import annotations

import numpy as np
import pytest

from volcal import evaluate_session
from volcal.importer import import_csv, parse_mapping
from volcal.session.format import read_session

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])
TARGETS = [0.0, 100.0, 200.0, 300.0]


def _cycle(runs=3):
    """Bidirectional runs with the end targets read twice (turn-around), ISO 230-2 order."""
    rng = np.random.default_rng(5)
    rows = []
    for r in range(1, runs + 1):
        for d, ts in (("+", TARGETS), ("-", TARGETS[::-1])):
            for t in ts:
                rows.append((t, r, d, round(0.01 * t + (1.5 if d == "-" else 0.0)
                                            + rng.normal(0, 0.2), 3)))
    return rows


def test_runs_and_directions_are_inferred_from_the_capture_order(tmp_path):
    rows = _cycle()
    plain = tmp_path / "capture.csv"  # position and error only, in capture order
    plain.write_text("Position (mm),Error (um)\n"
                     + "".join(f"{t:g},{e}\n" for t, _, _, e in rows))
    full = tmp_path / "full.csv"
    full.write_text("Position (mm),Run,Dir,Error (um)\n"
                    + "".join(f"{t:g},{r},{d},{e}\n" for t, r, d, e in rows))
    s = tmp_path / "S"
    r = import_csv(plain, parse_mapping("target=Position,deviation=Error"), "x", [0, 0, 0], s,
                   "capture", travel=TRAVEL)
    assert "3 run(s) inferred from the direction changes (a run is one + pass and one - pass)" \
        in r.notes
    import_csv(full, parse_mapping("target=Position,run=Run,direction=Dir,deviation=Error"),
               "x", [0, 0, 0], s, "explicit")
    sess = read_session(s)
    m = sess.get("capture")
    assert list(m.run) == [r for _, r, _, _ in rows]
    assert list(m.direction) == [d for _, _, d, _ in rows]
    ev = evaluate_session(sess)
    a, b = ev.iso230_2["capture"], ev.iso230_2["explicit"]
    for k in ("A", "E", "M", "R", "B"):
        assert getattr(a, k) == pytest.approx(getattr(b, k)), k
    assert a.B == pytest.approx(1.5, abs=0.5)  # the reversal we put in (B = max |B_i|)
