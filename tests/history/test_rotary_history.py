"""Rotary results through the session evaluation, the report and the history.

Two calibrations of one machine (linear tests of X and a rotary test of C), the C axis'
once-per-revolution error grown between them: ``evaluate session`` evaluates the rotary
test (``--units arcsec`` too), the report has its section (table, plot, verdict), and the
history's trend of ``C.A`` (the accuracy of the C axis, urad) shows the growth, equal to
what ISO 230-2 of each session gives.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from volcal.measure.rotary import RotaryAxisErrors
from volcal.measure.virtual import random_machine
from volcal_cli_helpers import run_volcal

pytest.importorskip("sqlalchemy")
TRAVEL = [[0, 400], [0, 300], [0, 200]]
TESTS = ["linear:x", "rotary:c"]


def _calibration(folder, once_urad, seed, date):
    from volcal.flow import Calibration

    machine = random_machine(TRAVEL, "XYFZ", seed=7)
    machine.rotary = {"c": RotaryAxisErrors("c", once_urad=once_urad, twice_urad=3.0,  # type: ignore[attr-defined]
                                            smooth_urad=(0.0, 10.0, 5.0),
                                            reversal_urad=4.0)}
    c = Calibration.plan(TRAVEL, steps=4, runs=3, tests=TESTS)
    c.simulate(machine=machine, seed=seed, noise_um=0.1)
    c.save(folder)
    toml = folder / "session.toml"
    toml.write_text(toml.read_text() + f"\n[calibration]\ndate = {date}\n")
    c.identify().to_json(folder / "model.json")
    return folder


def test_session_evaluation_report_and_trend_of_a_rotary_axis(tmp_path, monkeypatch, capsys):
    from volcal.history.api import History
    from volcal.report.pipeline import collect_inputs
    from volcal.report.sections import build_report
    from volcal.session.format import read_session
    from volcal.standards.session import evaluate_session

    a = _calibration(tmp_path / "a", 5.0, 1, "2026-01-10")
    b = _calibration(tmp_path / "b", 25.0, 2, "2026-08-10")
    ev = {k: evaluate_session(read_session(f)) for k, f in (("a", a), ("b", b))}
    A = {k: e.rotary["rotary-c"].iso.A for k, e in ev.items()}
    assert A["b"] > A["a"] + 25.0  # the once-per-revolution term grew by 20 urad (x 2 peak)
    assert ev["a"].rotary["rotary-c"].axis == "C" and "rotary-x" not in ev["a"].iso230_2
    # evaluate session: the rotary test beside the linear ones, in arcsec on request
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(a), "--json",
                                "--units", "arcsec")
    assert code == 0, err
    d = json.loads(out)
    assert d["rotary"]["rotary-c"]["unit"] == "arcsec"
    assert d["rotary"]["rotary-c"]["A"] == pytest.approx(A["a"] / 4.8481368110953599,
                                                         rel=1e-9)
    assert set(d["measurements"]) == {m for m in ev["a"].iso230_2}
    # the report's rotary section formats the same evaluation, with a verdict
    inp = collect_inputs(read_session(a), None, model_uncertainty=False, evaluation=ev["a"])
    inp.rotary_tolerance_urad = {"C": A["a"] + 1.0}
    sec = next(s for s in build_report(inp).sections if s.id == "rotary")
    assert sec.tables[0].rows[0][:3] == ["rotary-c", "C", f"{A['a']:.3f}"]
    assert sec.tables[-1].rows == [["rotary-c", "A", f"{A['a']:.3f}",
                                    f"{A['a'] + 1.0:.3f}", "pass"]]
    assert len(sec.figures) == 1 and "± 2 s" in sec.figures[0].caption
    # the history keeps C.A in urad; its trend is the two evaluations
    db = str(tmp_path / "h.sqlite")
    with History(db) as h:
        h.add(a, a / "model.json")
        h.add(b, b / "model.json")
        assert h.verify()[0]
        df = h.trend("VMC-1", "C.A")
    assert list(df["unit"]) == ["urad", "urad"]
    np.testing.assert_allclose(df["value"], [A["a"], A["b"]], rtol=1e-12)
    assert [str(d)[:10] for d in df["date"]] == ["2026-01-10", "2026-08-10"]
