"""Rotary exports imported exactly: a vendor's long layout in arcsec with a header block,
a wide layout (one column per run and direction) in urad, actual angles in degrees, into a
planned or a new rotary measurement; bad units refused naming the column."""

from __future__ import annotations

import math

import numpy as np
import pytest

from volcal.session.format import read_session
from volcal_cli_helpers import run_volcal

ARCSEC = math.pi / 648000 * 1e6  # urad, written out here, not taken from volcal
TARGETS = [0.0, 52.5, 127.25, 233.0, 301.75, 360.0]
# error [arcsec] of run r, direction d, target i: a hand-made table
ERR = {(1, "+"): [0.0, 1.2, -0.8, 2.4, 1.1, 0.1], (1, "-"): [0.6, 1.9, -0.2, 3.1, 1.5, 0.7],
       (2, "+"): [0.1, 1.3, -0.7, 2.3, 1.0, 0.2], (2, "-"): [0.5, 2.0, -0.1, 3.2, 1.6, 0.6]}


def vendor_long(path):
    """A calibrator software's export: preamble, then Target (deg), Run, Dir, Error (arcsec)."""
    lines = ["Rotary axis calibration report", "Axis:;C", "Date:;20/11/2026",
             "Operator:;A. Tester", "", "Target (deg);Run;Dir;Error (arcsec)"]
    for r in (1, 2):
        for d in ("+", "-"):
            idx = range(len(TARGETS)) if d == "+" else reversed(range(len(TARGETS)))
            for i in idx:
                word = "Fwd" if d == "+" else "Rev"
                lines.append(f"{TARGETS[i]:g};{r};{word};{ERR[(r, d)][i]:.2f}".replace(".", ","))
    path.write_text("\n".join(lines) + "\n", encoding="cp1252")
    return path


def expected_long():
    t, dev = [], []
    for r in (1, 2):
        for d in ("+", "-"):
            idx = range(len(TARGETS)) if d == "+" else reversed(range(len(TARGETS)))
            for i in idx:
                t.append(TARGETS[i])
                dev.append(ERR[(r, d)][i] * ARCSEC)
    return np.array(t), np.array(dev)


def test_a_vendor_long_export_in_arcsec_is_imported_exactly(tmp_path, monkeypatch, capsys):
    code, out, err = run_volcal(
        monkeypatch, capsys, "import", str(vendor_long(tmp_path / "xr20.csv")), "--session",
        str(tmp_path / "s"), "--axis", "C", "--id", "rot-c", "--travel", "0:500,0:400,0:300",
        "--map", "target=Target,run=Run,direction=Dir,deviation=Error")
    assert code == 0, err
    assert "arcsec -> urad" in out
    s = read_session(tmp_path / "s")
    m = s.get("rot-c")
    t, dev = expected_long()
    assert m.kind == "rotary" and m.meta["axis"] == "c" and m.meta["modulo"] is True
    np.testing.assert_array_equal(m.columns["target_deg"], t)
    np.testing.assert_allclose(m.deviation, dev, rtol=0, atol=5e-7)  # the CSV's 6 decimals
    assert list(m.columns["direction"][:7]) == ["+"] * 6 + ["-"]
    assert s.calibration["operator"] == "A. Tester"
    assert s.meta["rotary_axes"] == [{"name": "c", "range_deg": [0.0, 360.0], "modulo": True}]
    # evaluated as the session's rotary test: B of the hand table (mean of runs) in urad
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "iso230-2",
                                str(tmp_path / "s" / "rot-c.csv"), "--json")
    assert code == 0, err
    import json

    d = json.loads(out)
    b = [np.mean([ERR[(r, "+")][i] - ERR[(r, "-")][i] for r in (1, 2)]) * ARCSEC
         for i in range(len(TARGETS))]
    assert d["B"] == pytest.approx(max(abs(v) for v in b), abs=1e-5)


def test_a_wide_export_in_urad_fills_a_planned_rotary_test(tmp_path, monkeypatch, capsys):
    code, out, err = run_volcal(monkeypatch, capsys, "plan", "-o", str(tmp_path / "s"),
                                "--tests", "rotary:c", "--runs", "2", "--targets",
                                ",".join(f"{v:g}" for v in TARGETS))
    assert code == 0, err
    head = ["Target (deg)"] + [f"Run {r} {w} (urad)" for r in (1, 2) for w in ("up", "down")]
    lines = [",".join(head)]
    for i, tg in enumerate(TARGETS):
        lines.append(",".join([f"{tg:g}"] + [f"{ERR[(r, d)][i] * 4.0:.3f}"
                                             for r in (1, 2) for d in ("+", "-")]))
    f = tmp_path / "wide.csv"
    f.write_text("\n".join(lines) + "\n")
    code, out, err = run_volcal(monkeypatch, capsys, "import", str(f), "--session",
                                str(tmp_path / "s"), "--measurement", "rotary-c", "--map",
                                "target=Target,deviation=Run*")
    assert code == 0, err
    # the planned file held no reading: nothing "replaced" kept (session 20: it was read by
    # the linear reader, refused, and backed up as "the replaced readings of rotary-c")
    assert "replaced readings" not in out and not (tmp_path / "s" / "backup").exists()
    m = read_session(tmp_path / "s").get("rotary-c")
    t, dev = expected_long()
    np.testing.assert_array_equal(m.columns["target_deg"], t)
    np.testing.assert_allclose(m.deviation, dev / ARCSEC * 4.0, rtol=0, atol=5e-7)
    # imported again with --replace: these readings are kept
    code, out, err = run_volcal(monkeypatch, capsys, "import", str(f), "--session",
                                str(tmp_path / "s"), "--measurement", "rotary-c", "--map",
                                "target=Target,deviation=Run*", "--replace")
    assert code == 0 and "the replaced readings of rotary-c are kept in" in out, (out, err)
    # a wrong target is refused naming the row
    lines[3] = lines[3].replace("127.25", "127.5", 1)
    f.write_text("\n".join(lines) + "\n")
    code, out, err = run_volcal(monkeypatch, capsys, "import", str(f), "--session",
                                str(tmp_path / "s"), "--measurement", "rotary-c", "--map",
                                "target=Target,deviation=Run*", "--replace")
    assert code == 2 and "does not match the plan" in err and "wide.csv" in err


def test_actual_angles_in_degrees_and_the_opposite_sign(tmp_path, monkeypatch, capsys):
    """A ``reading=`` column holds the actual angle [deg]; ``--sign -`` flips an export of
    commanded - actual."""
    t, dev = expected_long()
    run = np.repeat([1, 2], 12)
    d = np.tile(["+"] * 6 + ["-"] * 6, 2)
    f = tmp_path / "actual.csv"
    f.write_text("Commanded (deg),Actual (deg),Run,Direction\n" + "".join(
        f"{a:g},{a + e / 1e6 * 180 / math.pi:.12f},{r},{x}\n"
        for a, e, r, x in zip(t, dev, run, d, strict=True)))
    code, out, err = run_volcal(monkeypatch, capsys, "import", str(f), "--session",
                                str(tmp_path / "s"), "--axis", "b", "--id", "rot-b",
                                "--travel", "0:500,0:400,0:300", "--map",
                                "target=Commanded,reading=Actual,run=Run,direction=Direction")
    assert code == 0, err
    m = read_session(tmp_path / "s").get("rot-b")
    np.testing.assert_allclose(m.deviation, dev, rtol=0, atol=2e-6)
    g = tmp_path / "neg.csv"
    g.write_text("Target (deg),Run,Direction,Error (urad)\n" + "".join(
        f"{a:g},{r},{x},{-e:.6f}\n" for a, e, r, x in zip(t, dev, run, d, strict=True)))
    code, out, err = run_volcal(monkeypatch, capsys, "import", str(g), "--session",
                                str(tmp_path / "s"), "--axis", "b", "--id", "rot-b2",
                                "--sign", "-", "--map",
                                "target=Target,run=Run,direction=Direction,deviation=Error")
    assert code == 0, err
    np.testing.assert_allclose(read_session(tmp_path / "s").get("rot-b2").deviation, dev,
                               rtol=0, atol=2e-6)


def test_a_target_in_mm_or_a_length_error_is_refused(tmp_path, monkeypatch, capsys):
    f = tmp_path / "mm.csv"
    f.write_text("Target (mm),Error (arcsec)\n0,0\n90,1\n180,2\n")
    code, out, err = run_volcal(monkeypatch, capsys, "import", str(f), "--session",
                                str(tmp_path / "s"), "--axis", "c", "--id", "r",
                                "--travel", "0:1,0:1,0:1", "--map",
                                "target=Target,deviation=Error")
    assert code == 2 and "names the unit 'mm'" in err and "Target" in err
    f.write_text("Target (deg),Error (um)\n0,0\n90,1\n180,2\n")
    code, out, err = run_volcal(monkeypatch, capsys, "import", str(f), "--session",
                                str(tmp_path / "s"), "--axis", "c", "--id", "r",
                                "--travel", "0:1,0:1,0:1", "--map",
                                "target=Target,deviation=Error")
    assert code == 2 and "angle unit" in err and "Traceback" not in err
