"""``make demo`` run twice into one folder (session 20: the second run failed at its live
capture, "out/capture: holds a volcal session ...: volcal plan does not replace it")."""

from __future__ import annotations

from volcal.demo import DEMO_TRAVEL, _capture
from volcal.measure.virtual import random_machine
from volcal.session.errortable import write_error_table


def test_the_live_capture_runs_again_and_keeps_the_last_one(tmp_path):
    s = tmp_path / "session"  # the demo's session: only its truth table is read here
    vm = random_machine(DEMO_TRAVEL, "XYFZ", 3)
    (s / "truth").mkdir(parents=True)
    write_error_table(vm, s / "truth" / "machine.csv")
    first = _capture(tmp_path / "capture", s, vm)
    again = _capture(tmp_path / "capture", s, vm)
    for lines in (first, again):
        assert lines[0].startswith("capture: diag-ppp live (5 of 5 dwells accepted, 0 missed)")
    # the first capture, its journal with it, is in the backup: the second one is its own
    (backup,) = (tmp_path / "capture" / "backup").iterdir()
    assert (backup / "capture" / "diag-ppp.jsonl").is_file()
    kept = (backup / "diag-ppp.csv").read_text().splitlines()
    assert len(kept) == 6 and all(row.split(",")[3] for row in kept[1:])  # its 5 readings
