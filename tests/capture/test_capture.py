"""``volcal capture`` on the simulated control and laser: rows, truth, journal, refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from volcal.capture.journal import Journal, journal_path, read_journal
from volcal.capture.page.state import LiveState
from volcal.capture.samples import LaserSample
from volcal.capture.sources import SourceError, register_laser
from volcal.errors import VolcalInputError
from volcal.steps.capture import capture
from volcal_cli_helpers import run_volcal

from .conftest import FAST, FAST_CLI
from .fake_sources import Wrapped

IDS = ["linear-x1", "diag-ppp"]


def _truth(session: Path, mid: str) -> np.ndarray:
    """The exact readings of the random virtual machine (seed 0), from the first row [um]."""
    from volcal.measure.virtual import random_machine
    from volcal.session.format import read_session
    from volcal.session.kinds import kind_of

    s = read_session(session, require_deviation=False)
    m = s.get(mid)
    vm = random_machine(s.travel, s.chain, 0)
    return np.asarray(kind_of(m.kind).exact(vm, m))


@pytest.fixture(scope="module")
def captured(planned, tmp_path_factory):
    out = tmp_path_factory.mktemp("cap") / "C"
    r = capture(planned, control="sim", laser="sim", measurement=IDS, output=out, **FAST)
    return out, r


def test_one_row_per_dwell_equal_to_the_virtual_machine(captured, planned):
    from volcal.session.format import read_session

    out, r = captured
    assert r.complete and [o.measurement for o in r.outcomes] == IDS
    assert [(o.accepted, o.missed, o.planned) for o in r.outcomes] == [(16, [], 16), (4, [], 4)]
    s = read_session(out)  # the session's own reader accepts the captured files
    assert sorted(m.id for m in s.measurements) == sorted(IDS)
    for mid in IDS:
        m = s.get(mid)
        truth = _truth(planned, mid)
        # per sample: laser noise 0.05 um and the servo noise 0.1 um the laser sees; a
        # deviation is the difference of two means of >= 12 samples: sigma <= 0.046 um
        assert m.deviation[0] == 0.0
        assert np.max(np.abs(m.deviation - truth)) < 5 * 0.046, (mid, m.deviation - truth)
        assert np.all(np.diff(m.columns["time_s"]) > 2.0)  # in order, one per dwell
    planned_rows = (planned / "linear-x1.csv").read_text().splitlines()
    rows = (out / "linear-x1.csv").read_text().splitlines()
    assert [r.split(",")[:3] + r.split(",")[4:6] for r in rows[1:]] == \
        [r.split(",")[:3] + r.split(",")[4:6] for r in planned_rows[1:]]  # the planned rows


def test_the_journal_holds_every_sample_and_one_decision_per_dwell(captured):
    out, _ = captured
    lines = [json.loads(x) for x in journal_path(out, "linear-x1").read_text().splitlines()]
    types = [x["type"] for x in lines]
    assert types[0] == "start" and types[-1] == "end" and lines[-1]["reason"] == "complete"
    acc = [x for x in lines if x["type"] == "accepted"]
    assert [x["reading"] for x in acc] == list(range(16))
    assert types.count("control") > 500 and types.count("laser") > 500
    # an accepted value is the mean of the journaled laser samples of its window
    k = next(i for i, x in enumerate(lines) if x["type"] == "accepted" and x["reading"] == 5)
    a = lines[k]
    lo, hi = a["window"]
    vals = [x["v"] for x in lines[:k] if x["type"] == "laser" and lo <= x["t"] <= hi]
    assert len(vals) == a["n"] and np.mean(vals) == pytest.approx(a["value"], abs=1e-9)


def test_a_second_run_skips_and_changes_nothing(captured, planned):
    out, _ = captured
    before = {p.name: p.read_bytes() for p in out.glob("*.csv")}
    r = capture(planned, control="sim", laser="sim", measurement=IDS, output=out, **FAST)
    assert r.complete and r.skipped == tuple(IDS) and r.outcomes == ()
    assert before == {p.name: p.read_bytes() for p in out.glob("*.csv")}


def test_a_reading_not_in_the_journal_is_never_overwritten(planned, tmp_path):
    out = tmp_path / "C"
    r = capture(planned, control="sim", laser="sim", measurement=["diag-ppp"], output=out,
                **FAST)
    assert r.complete
    f = out / "diag-ppp.csv"
    lines = f.read_text().splitlines()
    lines[2] = lines[2].replace(lines[2].split(",")[3], "1.234500", 1)  # typed by someone
    f.write_text("\n".join(lines) + "\n")
    (out / "capture" / "diag-ppp.jsonl").rename(out / "capture" / "elsewhere.jsonl")
    text = f.read_text()
    with pytest.raises(VolcalInputError) as e:
        capture(out, control="sim", laser="sim", measurement=["diag-ppp"], **FAST)
    msg = str(e.value)
    assert "diag-ppp.csv, row 2, column 'deviation_um'" in msg and "never overwritten" in msg
    assert f.read_text() == text


class _Flaky(Wrapped):
    """The simulated laser, disconnected after ``n`` readings (a cable pulled)."""

    n = 400
    count = 0

    def alter(self, s: LaserSample) -> LaserSample:
        self.count += 1
        if self.count > self.n:
            raise SourceError("laser: connection reset")
        return s


def test_a_disconnected_laser_stops_and_the_capture_resumes(captured, planned, tmp_path):
    register_laser("flaky-test", _Flaky, "the simulated laser, disconnected (tests)")
    out = tmp_path / "C"
    r = capture(planned, control="sim", laser="flaky-test", measurement=IDS, output=out,
                **FAST)
    assert not r.complete and "disconnected: laser: connection reset" in r.outcomes[0].reason
    assert any("Run the same command again to resume" in n for n in r.notes)
    got = read_journal(journal_path(out, "linear-x1"))
    assert 0 < len(got.accepted) < 16
    page = LiveState("resumed")  # the technician's page (--serve) follows the resume
    r2 = capture(planned, control="sim", laser="sim", measurement=IDS, output=out,
                 observer=page, **FAST)
    assert r2.complete and r2.outcomes[0].replayed == len(got.accepted)
    ref, _ = captured
    for mid in IDS:  # the same session as the uninterrupted capture
        assert (out / f"{mid}.csv").read_text() == (ref / f"{mid}.csv").read_text()
    # the page shows every reading, those recorded before the resume too (before session
    # 22 it showed each such reading's number as its value, or raised IndexError at the
    # resumed start, stopping the capture, when a reading was missed before)
    from volcal.session.format import read_session

    shown = {m["id"]: [d["value"] for d in m["dwells"]]
             for m in page.snapshot()["measurements"]}
    for mid in IDS:
        assert np.allclose(shown[mid], read_session(out).get(mid).deviation, atol=1e-6)


def test_a_journal_line_cut_by_a_kill_is_dropped(tmp_path):
    p = tmp_path / "capture" / "m.jsonl"
    j = Journal(p)
    j.write("start", {"t": 0.0})
    j.write("accepted", {"reading": 0, "value": 1.5, "t": 1.0}, sync=True)
    j.close()
    with p.open("ab") as f:
        f.write(b'{"type":"accepted","reading":1,"val')  # killed in the middle of a line
    assert set(read_journal(p).accepted) == {0}
    j = Journal(p)  # reopened: the cut line is dropped before appending
    j.write("missed", {"reading": 1, "t": 2.0, "reason": "x"}, sync=True)
    j.close()
    rec = read_journal(p)
    assert set(rec.accepted) == {0} and set(rec.missed) == {1}
    lines = p.read_bytes().splitlines()
    assert len(lines) == 3 and all(json.loads(x) for x in lines)
    p.write_bytes(b'{"type":"start"}\nnot json\n{"type":"end"}\n')
    with pytest.raises(VolcalInputError, match="m.jsonl, row 2: damaged journal line"):
        read_journal(p)


def test_command_line(planned, tmp_path, monkeypatch, capsys):
    out = tmp_path / "C"
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(planned), "--control", "sim",
                              "--laser", "sim", "--measurement", "diag-ppp", "-o", str(out),
                              *FAST_CLI)
    assert code == 0, err
    assert "diag-ppp: 4 of 4 readings recorded (4 accepted)" in o and "captured ->" in o
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(planned), "--control",
                              "bogus", "--laser", "sim", *FAST_CLI)
    assert code == 2 and "unknown control source 'bogus': expected one of" in err
    assert "linuxcnc" in err and "sim" in err and "Traceback" not in err
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(planned), "--control", "sim",
                              "--laser", "sim", "--measurement", "nope", *FAST_CLI)
    assert code == 2 and "--measurement 'nope' is not in the session" in err
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(planned), "--control", "sim",
                              "--laser", "sim", "--stable-s", "3.5")
    assert code == 2 and "--stable-s 3.5 s does not fit in the programmed dwell of 4 s" in err
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(planned), "--control",
                              "sim:accel=fast", "--laser", "sim", *FAST_CLI)
    assert code == 2 and "accel='fast' is not a number" in err
