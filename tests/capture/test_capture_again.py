"""``volcal capture --again``: a measurement whose first reading was missed is captured
again in its own session, the earlier capture kept in ``backup/``; a measurement left
unreadable makes the capture exit 1."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from volcal.capture.journal import journal_path
from volcal.capture.samples import LaserSample
from volcal.capture.sources import register_laser
from volcal.errors import VolcalInputError
from volcal.steps.capture import capture
from volcal_cli_helpers import run_volcal

from .conftest import FAST, FAST_CLI
from .fake_sources import Wrapped, accepted

MID = "linear-x1"


class _BlindFirst(Wrapped):
    """The simulated laser, silent while X stands at the test's first target (the beam
    not yet aligned when the program started)."""

    def alter(self, s: LaserSample) -> LaserSample | None:
        c = self.ctx.latest_control()
        first = self.ctx.measurements[0].dwells[0].target
        if c is not None and abs(c.positions.get("X", 1e9) - first[0]) < 0.01:
            return None
        return s


class _Silent(Wrapped):
    """A laser that never sends a reading (a wrong port, the wrong file)."""

    def alter(self, s: LaserSample) -> None:
        return None


@pytest.fixture(scope="module")
def clean(planned, tmp_path_factory) -> Path:
    """``linear-x1`` captured with nothing missed (the simulated laser, seed 0)."""
    out = tmp_path_factory.mktemp("clean") / "C"
    r = capture(planned, control="sim", laser="sim", measurement=[MID], output=out, **FAST)
    assert r.complete and not r.unreadable and r.outcomes[0].missed == []
    return out


def test_a_missed_first_reading_is_captured_again_in_place(planned, clean, tmp_path):
    from volcal.session.format import read_session

    register_laser("blind-first-test", _BlindFirst, "the simulated laser, blind at first")
    out = tmp_path / "S"
    r = capture(planned, control="sim", laser="blind-first-test", measurement=[MID],
                output=out, **FAST)
    assert r.complete and r.unreadable == (MID,)
    assert r.outcomes[0].missed[:1] == [2] and r.outcomes[0].accepted > 0
    assert any("the first reading (row 2)" in n and f"--measurement {MID} --again" in n
               for n in r.notes), r.notes
    with pytest.raises(VolcalInputError):
        read_session(out)  # what the capture said: the reader refuses the file
    before_csv = (out / f"{MID}.csv").read_bytes()
    before_journal = journal_path(out, MID).read_bytes()

    # a plain run again passes over it (its journal is complete); --again captures it
    r = capture(out, control="sim", laser="sim", measurement=[MID], **FAST)
    assert r.skipped == (MID,) and not r.outcomes
    r = capture(out, control="sim", laser="sim", measurement=[MID], again=True, **FAST)
    assert r.complete and not r.unreadable and r.outcomes[0].missed == []
    # the same file as a clean capture (same simulated machine and laser), read back
    assert (out / f"{MID}.csv").read_bytes() == (clean / f"{MID}.csv").read_bytes()
    assert read_session(out).get(MID).deviation[0] == 0.0
    # the earlier capture kept, byte for byte, with the session file
    (kept,) = (out / "backup").iterdir()
    assert (kept / f"{MID}.csv").read_bytes() == before_csv
    assert (kept / "capture" / f"{MID}.jsonl").read_bytes() == before_journal
    assert (kept / "session.toml").is_file()
    assert len(accepted(journal_path(out, MID))) == r.outcomes[0].planned  # a new journal
    assert any(f"kept in backup/{kept.name}/" in n for n in r.notes)


def test_killed_between_the_journal_and_the_file_the_same_call_starts_again(
        planned, clean, tmp_path, monkeypatch):
    """Killed after the journal was removed and before the planned file was written back:
    the file holds readings no journal holds, which a plain run refuses and ``--again``
    takes (kept in a second backup)."""
    import volcal.io.atomic as atomic

    out = tmp_path / "S"
    shutil.copytree(clean, out)
    real = atomic.write_text

    def killed(path, text, *a, **k):
        if Path(path).name == f"{MID}.csv":
            raise KeyboardInterrupt
        return real(path, text, *a, **k)

    monkeypatch.setattr(atomic, "write_text", killed)
    with pytest.raises(KeyboardInterrupt):
        capture(out, control="sim", laser="sim", measurement=[MID], again=True, **FAST)
    monkeypatch.setattr(atomic, "write_text", real)
    assert not journal_path(out, MID).exists()
    assert (out / f"{MID}.csv").read_bytes() == (clean / f"{MID}.csv").read_bytes()
    with pytest.raises(VolcalInputError, match="never overwritten|not in the journal|"
                                               "journal does not hold"):
        capture(out, control="sim", laser="sim", measurement=[MID], **FAST)
    r = capture(out, control="sim", laser="sim", measurement=[MID], again=True, **FAST)
    assert r.complete and not r.unreadable
    assert (out / f"{MID}.csv").read_bytes() == (clean / f"{MID}.csv").read_bytes()
    assert len(list((out / "backup").iterdir())) == 2


def test_command_line_exit_codes(planned, tmp_path, monkeypatch, capsys):
    register_laser("silent-test", _Silent, "a laser that sends nothing")
    out = tmp_path / "S"
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(planned), "--control", "sim",
                              "--laser", "silent-test", "--measurement", MID, "-o", str(out),
                              *FAST_CLI)
    assert code == 1 and "Traceback" not in err
    assert f"{MID}: no reading accepted" in err and "--again" in err
    assert f"error: {MID}: captured to the end, but unreadable" in err
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(out), "--control", "sim",
                              "--laser", "sim", "--again", *FAST_CLI)
    assert code == 2 and "--again needs --measurement" in err and "Traceback" not in err
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(out), "--control", "sim",
                              "--laser", "sim", "--again", "--measurement", "diag-ppp",
                              *FAST_CLI)
    assert code == 2 and "diag-ppp.csv" in err and "was never captured here" in err
    assert not (out / "backup").exists()  # refused before anything was written
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(planned), "--control", "sim",
                              "--laser", "sim", "--again", "--measurement", MID, "-o",
                              str(tmp_path / "NEW"), *FAST_CLI)
    assert code == 2 and "--again: --output " in err and "holds no capture" in err
    assert not (tmp_path / "NEW").exists()
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(out), "--control", "sim",
                              "--laser", "sim", "--again", "--measurement", MID, *FAST_CLI)
    assert code == 0, err
    assert f"{MID}: 16 of 16 readings recorded (16 accepted)" in o
    code, o, err = run_volcal(monkeypatch, capsys, "capture", str(out), "--control", "sim",
                              "--laser", "sim", "--window-deg", "-1", *FAST_CLI)
    assert code == 2 and "--window-deg -1" in err
