"""``volcal capture`` of a rotary test (session 21): the axis turns, the calibrator reads.

The simulated control turns the rotary axis through the test's program (the turns and
the overrun of :func:`volcal.program.rotary.rotary_moves`); the simulated laser reads the
virtual rotary axis that ``volcal simulate --seed`` draws (its ``truth/setup.toml``), at
the control's actual angle, in the direction of the last turn. Each test checks the
capture against that truth: one row per dwell equal to it within the noise (the reversal
of the '-' readings included), the file read back by the rotary kind's reader, evaluated
to ISO 230-2, resumed after a SIGKILL, a missed dwell written ``missed``.
"""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from volcal.capture.journal import journal_path, read_journal
from volcal.capture.samples import LaserSample
from volcal.capture.sources import register_control, register_laser
from volcal.errors import VolcalInputError
from volcal.steps.capture import capture
from volcal.steps.plan import plan
from volcal_cli_helpers import run_volcal

from .conftest import FAST, FAST_CLI
from .fake_sources import NoRotary, Wrapped, accepted, kill_capture_after

TRAVEL = ((0.0, 200.0), (0.0, 150.0), (0.0, 100.0))
SEED = 3
ROT = "rotary-c"
N = 16  # 4 targets x 2 directions x 2 runs
# per sample 0.05 urad of laser noise; a deviation is the difference of two means of >= 25
# samples (0.6 s at 50 readings/s): sigma <= 0.05 * sqrt(2 / 25) = 0.014 urad
TOL_URAD = 5 * 0.014


@pytest.fixture(scope="module")
def rotary_planned(tmp_path_factory) -> Path:
    """Linear tests of X, then the C axis (full circle): 4 targets, 2 bidirectional runs.

    The linear tests come first so that the rotary axis is not the simulation's first draw:
    the capture must read the axis ``volcal simulate`` draws after them."""
    out = tmp_path_factory.mktemp("rotary") / "S"
    plan(TRAVEL, steps=3, tests="linear:x,rotary:c", runs=2, output=out)
    return out


@pytest.fixture(scope="module")
def truth(rotary_planned, tmp_path_factory) -> np.ndarray:
    """``volcal simulate --seed 3`` of a copy: the exact readings of its truth's C axis."""
    from volcal.measure.rotary import RotaryAxisErrors, RotarySetup, rotary_exact
    from volcal.session.format import read_session
    from volcal.steps.simulate import save, simulate

    sim = tmp_path_factory.mktemp("truth") / "S"
    shutil.copytree(rotary_planned, sim)
    save(simulate(sim, seed=SEED), sim)
    doc = tomllib.loads((sim / "truth" / "setup.toml").read_text())["setup"][ROT]
    ax = dict(doc["rotary_axis"])
    axis = RotaryAxisErrors(**{**ax, "range_deg": tuple(ax["range_deg"]),
                               "smooth_urad": tuple(ax["smooth_urad"])})
    setup = RotarySetup(axis, doc["eccentricity_mm"], doc["eccentricity_phase_rad"])
    m = read_session(rotary_planned, require_deviation=False).get(ROT)
    return rotary_exact(setup, m.columns["target_deg"], m.columns["direction"])


@pytest.fixture(scope="module")
def captured(rotary_planned, tmp_path_factory):
    """The rotary test captured alone, the laser sending arcseconds."""
    out = tmp_path_factory.mktemp("cap") / "C"
    r = capture(rotary_planned, control="sim", laser=f"sim:seed={SEED},unit=arcsec",
                measurement=[ROT], output=out, **FAST)
    return out, r


def test_one_row_per_dwell_equal_to_the_simulated_truth(captured, rotary_planned, truth):
    from volcal.session.format import read_session

    out, r = captured
    assert r.complete and [(o.measurement, o.accepted, o.missed, o.planned)
                           for o in r.outcomes] == [(ROT, N, [], N)]
    m = read_session(out).get(ROT)  # the rotary kind's reader accepts the captured file
    assert m.deviation[0] == 0.0
    assert np.max(np.abs(m.deviation - truth)) < TOL_URAD, m.deviation - truth
    assert np.max(np.abs(truth)) > 5.0  # an axis with errors of some urad: zeros would fail
    assert np.all(np.diff(m.columns["time_s"]) > 2.0)  # in order, one per dwell
    planned_rows = (rotary_planned / f"{ROT}.csv").read_text().splitlines()
    rows = (out / f"{ROT}.csv").read_text().splitlines()
    assert rows[0] == "target_deg,run,direction,deviation_urad,time_s"
    assert [x.split(",")[:3] for x in rows[1:]] == [x.split(",")[:3] for x in planned_rows[1:]]
    # the journal: the laser's samples in arcseconds, the accepted values in urad
    lines = journal_path(out, ROT).read_text().splitlines()
    laser = [x for x in lines if '"type":"laser"' in x]
    assert laser and all('"unit":"arcsec"' in x for x in laser)


def test_each_reading_is_approached_from_its_side_with_the_overrun(captured, rotary_planned):
    """The control's angle over the journal: the last 0.5 deg before each accepted window
    turns in the reading's direction; the axis went 2 deg past 0 and 360 (the overrun)."""
    import json

    from volcal.session.format import read_session

    out, _ = captured
    m = read_session(rotary_planned, require_deviation=False).get(ROT)
    recs = [json.loads(x) for x in journal_path(out, ROT).read_text().splitlines()]
    ctrl = [(x["t"], x["pos"]["C"]) for x in recs if x["type"] == "control"]
    t = np.array([c[0] for c in ctrl])
    c = np.array([c[1] for c in ctrl])
    # (the reversal of each overrun sampled every 50 ms: within 0.1 deg of its turn point)
    assert -2.01 < c.min() < -1.9 and 361.9 < c.max() < 362.01
    for a in (x for x in recs if x["type"] == "accepted"):
        i = a["reading"]
        target = m.columns["target_deg"][i]
        before = c[t < a["window"][0]]
        far = before[np.abs(before - target) > 0.5][-1]
        sign = 1.0 if m.columns["direction"][i] == "+" else -1.0
        assert sign * (target - far) > 0, (i, target, far)
        assert a["pos"][0] == pytest.approx(target, abs=0.005)


def test_the_captured_test_evaluates_to_iso230_2_as_its_truth(captured, truth, monkeypatch,
                                                                capsys):
    from volcal.session.format import read_session
    from volcal.standards.iso230_2_rotary import evaluate_rotary_measurement

    out, _ = captured
    m = read_session(out).get(ROT)
    got = evaluate_rotary_measurement(m)
    m.deviation = truth.copy()
    want = evaluate_rotary_measurement(m)
    for key in ("A", "E", "B", "M"):  # systematic, noise-free parameters: within the noise
        assert got.value(key) == pytest.approx(want.value(key), abs=3 * TOL_URAD), key
    assert want.value("B") > 1.0  # the axis' reversal is seen
    code, o, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(out))
    assert code == 0, err
    assert "rotary-c" in o and "Traceback" not in err


def test_a_full_circle_axis_reported_modulo_360_is_followed(rotary_planned, captured,
                                                             tmp_path):
    """A control reporting C in 0..360 (LinuxCNC's WRAPPED_ROTARY): -2 deg reads 358, 362
    reads 2; the capture follows the turn and takes the same readings."""
    out = tmp_path / "W"
    r = capture(rotary_planned, control="sim:wrap=1", laser=f"sim:seed={SEED},unit=arcsec",
                measurement=[ROT], output=out, **FAST)
    assert r.complete and r.outcomes[0].accepted == N
    assert (out / f"{ROT}.csv").read_text() == (captured[0] / f"{ROT}.csv").read_text()


def test_a_positions_only_control_takes_no_reading_at_the_operator_stop(rotary_planned,
                                                                          truth, tmp_path):
    """No program state (flags=0) and the axis at 90 deg before the program: the start
    turns down to 0 and on to -2 (the first reading's approach point), where the operator
    stop stands; before session 21's program the stop stood at 0, the first target,
    reached from above."""
    from volcal.session.format import read_session

    out = tmp_path / "F"
    r = capture(rotary_planned, control="sim:flags=0,home=100/75/0/90,stop_s=3",
                laser=f"sim:seed={SEED}", measurement=[ROT], output=out, **FAST)
    assert r.complete and r.outcomes[0].accepted == N, r.outcomes[0].reason
    m = read_session(out).get(ROT)
    assert np.max(np.abs(m.deviation - truth)) < TOL_URAD


class _Blind(Wrapped):
    """The simulated laser, silent while the axis stands at the test's second target."""

    def alter(self, s: LaserSample) -> LaserSample | None:
        c = self.ctx.latest_control()
        target = self.ctx.measurements[0].dwells[1].target[0]
        if c is not None and abs(c.positions.get("C", 0) - target) < 0.01:
            return None  # the beam is blocked at this angle
        return s


def test_a_missed_dwell_is_written_missed(rotary_planned, truth, tmp_path):
    from volcal.session.format import read_session

    register_laser("blind-rotary-test", _Blind, "the simulated laser, blind at one angle")
    out = tmp_path / "M"
    r = capture(rotary_planned, control="sim", laser=f"blind-rotary-test:seed={SEED}",
                measurement=[ROT], output=out, **FAST)
    planned = read_session(rotary_planned, require_deviation=False).get(ROT)
    rows = [i + 2 for i, t in enumerate(planned.columns["target_deg"])
            if t == planned.columns["target_deg"][1]]
    assert len(rows) == 4  # the second target: twice per run
    assert r.complete and r.outcomes[0].missed == rows
    assert any(f"{ROT}: missed at row(s) {', '.join(map(str, rows))}" in n for n in r.notes)
    lines = (out / f"{ROT}.csv").read_text().splitlines()
    assert [k for k, x in enumerate(lines) if x.split(",")[3] == "missed"] == [k - 1
                                                                              for k in rows]
    rec = read_journal(journal_path(out, ROT))
    assert {i + 2 for i in rec.missed} == set(rows)
    assert "no laser reading during the dwell" in rec.missed[rows[0] - 2]["reason"]
    m = read_session(out).get(ROT)  # read back: the missed rows left out, the others true
    keep = np.ones(N, bool)
    keep[np.array(rows) - 2] = False
    assert m.n == N - 4
    assert np.max(np.abs(m.deviation - truth[keep])) < TOL_URAD


def test_sigkill_in_the_middle_and_resume_give_the_same_file(rotary_planned, tmp_path):
    ref = tmp_path / "A"
    assert capture(rotary_planned, control="sim", laser=f"sim:seed={SEED}", measurement=[ROT],
                   output=ref, **FAST).complete
    out = tmp_path / "B"
    journal = out / "capture" / f"{ROT}.jsonl"
    kill_capture_after([str(rotary_planned), "--control", "sim", "--laser", f"sim:seed={SEED}",
                        "-o", str(out), "--measurement", ROT, *FAST_CLI, "--speed", "20"],
                       journal, 5)
    before = accepted(journal)
    assert 5 <= len(before) < N and before == list(range(len(before)))
    r = capture(rotary_planned, control="sim", laser=f"sim:seed={SEED}", measurement=[ROT],
                output=out, **FAST)
    assert r.complete and r.outcomes[0].replayed >= len(before)
    assert sorted(accepted(journal)) == list(range(N))  # none lost, none twice
    assert (out / f"{ROT}.csv").read_text() == (ref / f"{ROT}.csv").read_text()


def test_a_control_without_the_rotary_axis_is_refused_clearly(rotary_planned, tmp_path,
                                                               monkeypatch, capsys):
    register_control("xyz-only-test", NoRotary, "the simulated control, X Y Z only",
                     simulated=True)
    with pytest.raises(VolcalInputError, match=r"the control sample has no axis 'C' \(axes: "
                                               r"X, Y, Z\); a rotary test of axis C needs a "
                                               "control that reports it"):
        capture(rotary_planned, control="xyz-only-test", laser="sim", measurement=[ROT],
                output=tmp_path / "N", **FAST)
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(rotary_planned),
                              "--control", "sim", "--laser", "sim:unit=furlong",
                              "--measurement", ROT, "-o", str(tmp_path / "U"), *FAST_CLI)
    assert code == 2 and "unit='furlong' is not one of" in err and "arcsec" in err
    assert "Traceback" not in err and not (tmp_path / "U").exists()
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(rotary_planned),
                              "--control", "sim", "--laser", "sim:unit=um",
                              "--measurement", ROT, "-o", str(tmp_path / "V"), *FAST_CLI)
    assert code == 2 and "the laser sends 'um' readings; rotary-c measurement needs an " \
        "angle" in err and "Traceback" not in err


def _dwell_at(angle: float, t0: float, moving_from: float) -> list:
    """Control samples at 50 Hz: a turn from ``moving_from`` to ``angle`` (1 s), a 3 s
    dwell there; laser samples beside them."""
    from volcal.capture.samples import ControlSample

    out: list = []
    for k in range(200):
        t = t0 + k * 0.02
        f = min(k / 50.0, 1.0)
        c = moving_from + f * (angle - moving_from)
        pos = {"X": 100.0, "Y": 75.0, "Z": 0.0, "C": c % 360.0}  # a wrapped control
        out.append(ControlSample(t, pos, f < 1.0, True))
        out.append(LaserSample(t + 0.01, 3.0 + 0.01 * (k % 3), "urad"))
    return out


def test_a_resumed_capture_does_not_take_360_for_the_programs_first_reading():
    """Resumed with reading 1 (0 deg, '+') recorded, the program on: it dwells at 360 deg
    turning '+', which a wrapped control reports as 0, the first reading's angle and side.
    Taken for the program's restart, run 1's remaining readings would have been taken from
    the wrong dwells; the rule waits for the program's start pose (or the reading)."""
    from volcal.capture.plan import plan_measurement
    from volcal.capture.trigger import Note, Replayed, TriggerParams, TriggerRule
    from volcal.plan.planner import plan_session
    from volcal.program.steps import ProgramOptions

    s = plan_session(np.array(TRAVEL), tests=["rotary:c"], steps=2, runs=1)
    pm = plan_measurement(s.measurements[0], s.travel, ProgramOptions(dwell_s=2.0))
    assert [float(d.target[0]) for d in pm.dwells][2] == 360.0
    rule = TriggerRule(pm.dwells, TriggerParams(stable_s=0.6, max_gap_s=0.3), pm.waypoints,
                       "urad", done={0}, label=ROT, start=pm.start, frame=pm.frame)
    events = []
    for smp in _dwell_at(360.0, 0.0, 300.0):
        events += (rule.feed_control(smp) if hasattr(smp, "positions")
                   else rule.feed_laser(smp))
    assert not [e for e in events if isinstance(e, Replayed)], events
    assert any(isinstance(e, Note) and "resumed, waiting for reading 2" in e.text
               for e in events), events
    assert rule.cursor == 1
