"""volcal.evaluate_session: one definition of every index, checked by hand."""

from __future__ import annotations

import numpy as np
import pytest

from volcal import evaluate_session
from volcal.plan.planner import plan_session
from volcal.report.pipeline import collect_inputs
from volcal.session.format import read_session, write_session

TRAVEL = [[0.0, 400.0], [0.0, 300.0], [0.0, 200.0]]
# deviation [um] by target index, the same on every run and direction: Dx(x) known exactly
SHAPE = {"X": [0.0, 3.0, 1.0], "Y": [0.0, -4.0, 0.0], "Z": [12.0, 0.0, 0.0]}


def _session(tmp_path):
    s = plan_session(TRAVEL, "XYFZ", 2, ("linear",), runs=2, name="HAND")
    for m in s.measurements:
        k = int(np.argmax(np.ptp(m.positions, axis=0)))
        t = m.positions[:, k]
        idx = np.searchsorted(np.unique(t), t)
        m.deviation = np.asarray(SHAPE["XYZ"[k]])[idx]
    write_session(s, tmp_path / "S")
    return read_session(tmp_path / "S")


def test_elv_is_the_rss_of_the_hand_computed_positioning_ranges(tmp_path):
    s = _session(tmp_path)
    ev = evaluate_session(s)
    # ELx = max Dx - min Dx = 3, ELy = 4, ELz = 12 -> ELv = sqrt(9 + 16 + 144) = 13
    assert ev.elv_source == "measured"
    assert ev.elv == pytest.approx({"ELx": 3.0, "ELy": 4.0, "ELz": 12.0, "ELv": 13.0})
    assert ev.to_dict()["ELv"] == pytest.approx(13.0)
    first = {}
    for mid, r in ev.iso230_2.items():
        first.setdefault(ev.axis[mid], r.M)
    assert first == pytest.approx({"X": 3.0, "Y": 4.0, "Z": 12.0})
    # the report shows the same numbers (one definition)
    assert collect_inputs(s).elv == ev.elv
    assert len(repr(ev)) < 200


def test_unmeasured_tests_are_skipped_and_named(tmp_path):
    s = _session(tmp_path)
    s.measurements[0].deviation = None
    ev = evaluate_session(s)
    assert ev.skipped == {s.measurements[0].id: "no readings yet"}


def test_verdicts_judge_the_evaluation_without_evaluating_again(tmp_path, monkeypatch):
    """The per-axis verdict takes ISO 230-2 A from the session's one evaluation: by hand,
    every run reads the same, so s = 0 and A = E = the range of the shape (X 3, Y 4,
    Z 12 um); the verdict evaluates nothing itself, and the evaluation is frozen."""
    import dataclasses

    from volcal.standards import iso230_2
    from volcal.standards.tolerance import parse_tolerance
    from volcal.standards.verdict import verdicts

    s = _session(tmp_path)
    ev = evaluate_session(s)
    calls = []
    monkeypatch.setattr(iso230_2, "evaluate", lambda *a, **k: calls.append(a))
    vs = verdicts(parse_tolerance("X=3,Y=3.9,Z=12"), ev)
    assert [(v.quantity, v.before_um, v.before) for v in vs] == [
        ("X: ISO 230-2 A (3 tests)", pytest.approx(3.0), "pass"),
        ("Y: ISO 230-2 A (3 tests)", pytest.approx(4.0), "fail"),
        ("Z: ISO 230-2 A (3 tests)", pytest.approx(12.0), "pass")]
    assert calls == []
    with pytest.raises(dataclasses.FrozenInstanceError):
        ev.elv = None  # type: ignore[misc]
    # the guarded rule needs U: this evaluation had no budget
    from volcal.errors import VolcalInputError
    from volcal.standards.tolerance import Tolerance

    with pytest.raises(VolcalInputError, match="--budget FILE"):
        verdicts(Tolerance(None, {"X": 3.0}, rule="guarded"), ev)
