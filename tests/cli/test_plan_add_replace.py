"""``volcal plan`` over an existing session, ``--replace`` with its backup, ``--add``, and the
command ``volcal advise`` prints (issue 20, Deliver 6)."""

from __future__ import annotations

import json
import shlex
import shutil
from pathlib import Path

import numpy as np
import pytest
from test_cli_bad_input import volcal

from cli_mutations import snapshot
from volcal.plan.additions import candidate_additions
from volcal.session.format import read_session

TRAVEL = "0:400,0:300,0:200"


def _plan(folder: Path, *args: str) -> None:
    r = volcal("plan", "--travel", TRAVEL, "--steps", "3", "--runs", "2", *args, "-o", folder)
    assert r.returncode == 0, r.stderr


def test_plan_over_a_planned_session_is_refused(tmp_path):
    s = tmp_path / "S"
    _plan(s)
    (s / "notes.txt").write_text("hand-added test planned for Monday\n")
    before = snapshot(s)
    r = volcal("plan", "--travel", "0:800,0:600,0:500", "-o", s)
    assert r.returncode == 2
    assert " ".join(r.stderr.split()) == (
        f"error: {s}: holds a volcal session (17 measurements, 0 with readings): `volcal plan` "
        "does not replace it. Give --replace to replace it (its session.toml and measurement "
        f"CSVs are moved to backup/<UTC time>/), or add tests to it with `volcal plan --add {s} "
        "--tests ...`; nothing was changed")
    assert snapshot(s) == before


def test_replace_keeps_a_backup_that_restores_the_old_session(tmp_path):
    s = tmp_path / "S"
    _plan(s, "--tests", "diagonal,step-diagonal")
    assert volcal("simulate", s, "--seed", "4").returncode == 0
    old = read_session(s)
    old_bytes = {p.name: p.read_bytes() for p in s.iterdir() if p.is_file()}
    (s / "notes.txt").write_text("kept\n")
    r = volcal("plan", "--travel", TRAVEL, "--steps", "3", "--runs", "2", "--tests", "linear",
               "-o", s, "--replace")
    assert r.returncode == 0, r.stderr
    backups = list((s / "backup").iterdir())
    assert len(backups) == 1
    b = backups[0]
    assert f"the old session.toml and 8 measurement files are kept in {b}/" in \
        " ".join(r.stdout.split())
    # the old files moved, byte for byte; no orphan left; other files kept
    assert {p.name: p.read_bytes() for p in b.iterdir() if p.is_file()} == old_bytes
    assert (b / "truth" / "machine.csv").is_file() and not (s / "truth").exists()
    assert not list(s.glob("diag-*.csv")) and not list(s.glob("step-*.csv"))
    assert (s / "notes.txt").read_text() == "kept\n"
    new = read_session(s, require_deviation=False)
    assert [m.id for m in new.measurements] == [f"linear-{a}{i}" for a in "xyz" for i in (1, 2, 3)]
    # restore: copy the backup back over the session
    for f in s.glob("*.csv"):
        f.unlink()
    for f in b.iterdir():
        if f.is_file():
            shutil.copy2(f, s / f.name)
    back = read_session(s)
    assert [m.id for m in back.measurements] == [m.id for m in old.measurements] and \
        len(back.measurements) == 8
    for a, m in zip(back.measurements, old.measurements, strict=True):
        np.testing.assert_array_equal(a.positions, m.positions)
        np.testing.assert_array_equal(a.deviation, m.deviation)
    assert back.provenance == old.provenance


def test_plan_add_simulate_identify_round_trip(tmp_path):
    s = tmp_path / "S"
    _plan(s, "--tests", "step-diagonal,linear")
    r = volcal("simulate", s, "--seed", "2", "--noise-um", "0.2")
    assert r.returncode == 0, r.stderr
    csvs = {p.name: p.read_bytes() for p in s.glob("*.csv")}
    toml_before = (s / "session.toml").read_text()
    # a session holding readings: tests are added, nothing existing is touched
    r = volcal("plan", "--add", s, "--tests", "diagonal", "--tool-offset", "0,0,50",
               "--steps", "3")
    assert r.returncode == 0, r.stderr
    assert " ".join(r.stdout.split()) == (
        f"added 4 measurements, 16 readings to {s} (now 17): diag-ppp, diag-npp, diag-pnp, "
        "diag-ppn")
    assert {p.name: p.read_bytes() for p in s.glob("*.csv") if p.name in csvs} == csvs
    text = (s / "session.toml").read_text()
    old_digest = read_session(s, require_deviation=False).provenance["readings_sha256"]
    assert old_digest not in toml_before  # the digest now covers the added (empty) tests
    start = toml_before.index("[[measurements]]")
    assert text[start:].startswith(toml_before[start:])  # every old entry kept as written
    # a second add never reuses an id nor a file of the folder
    (s / "diag-npp-2.csv").write_text("a user's file\n")
    r = volcal("plan", "--add", s, "--tests", "diagonal", "--steps", "3")
    assert r.returncode == 0, r.stderr
    ses = read_session(s, require_deviation=False)
    ids = [m.id for m in ses.measurements]
    assert ids[-8:] == ["diag-ppp", "diag-npp", "diag-pnp", "diag-ppn",
                        "diag-ppp-2", "diag-npp-3", "diag-pnp-2", "diag-ppn-2"]
    assert (s / "diag-npp-2.csv").read_text() == "a user's file\n"
    np.testing.assert_array_equal(ses.get("diag-ppp").tool_offset, [0, 0, 50])
    np.testing.assert_array_equal(ses.get("diag-ppp-2").tool_offset, [0, 0, 0])
    assert ses.get("diag-ppp").deviation is None
    # simulate fills the new tests (the readings are still simulate's own), identify uses all
    r = volcal("simulate", s, "--seed", "2", "--noise-um", "0.2")
    assert r.returncode == 0, r.stderr
    r = volcal("identify", s, "-o", tmp_path / "M.json")
    assert r.returncode == 0, r.stderr
    model = json.loads((tmp_path / "M.json").read_text())
    used = set(model["session"]["measurements"]) if isinstance(
        model.get("session", {}).get("measurements"), list) else None
    text = json.dumps(model)
    for mid in ("diag-ppp", "diag-ppn-2", "diag-npp-3"):
        assert f'"{mid}"' in text
    if used is not None:
        assert {"diag-ppp", "diag-ppn-2"} <= used
    # the noise the fit finds is the simulated one: the added readings fit the model
    sigma = model["fit"]["sigma_um"]
    assert 0.15 < sigma < 0.3, sigma


@pytest.mark.parametrize("test,ids", [
    ("linear:y", ["linear-y1", "linear-y2", "linear-y3"]),
    ("face-diagonal:yz", ["face-yz-pp", "face-yz-np"]),
    ("face-step-diagonal:xz", ["fstep-xz-pp", "fstep-xz-np"]),
])
def test_one_axis_or_plane(tmp_path, test, ids):
    s = tmp_path / "S"
    r = volcal("plan", "--travel", TRAVEL, "--steps", "3", "--runs", "2", "--tests", test,
               "-o", s)
    assert r.returncode == 0, r.stderr
    assert [m.id for m in read_session(s, require_deviation=False).measurements] == ids


def test_advise_on_the_gantry_of_issue_20_prints_the_command_that_adds_it(tmp_path):
    """The finding: "advise recommends the 4 body diagonals with a tool offset of 150 mm in Z
    but no command can add them" (1200 x 800 x 600 mm gantry, FXYZ; 6 increments to keep the
    test short). The printed command adds exactly the tests advise evaluated."""
    g = tmp_path / "G"
    r = volcal("plan", "--travel", "0:1200,0:800,0:600", "--chain", "FXYZ", "--steps", "6",
               "--runs", "2", "-o", g)
    assert r.returncode == 0, r.stderr
    r = volcal("advise", g)
    assert r.returncode == 0, r.stderr
    lines = [ln[2:] for ln in r.stdout.splitlines() if ln.startswith("- ")]
    best = next(ln for ln in lines if ln.startswith("Best extra measurement: "))
    assert best.startswith("Best extra measurement: the 4 body diagonals with a tool offset of "
                           "150 mm in Z: volumetric ambiguity ")
    cmd = next(ln for ln in lines if ln.startswith("To add it: "))[len("To add it: "):]
    assert cmd == f"volcal plan --add {g} --tests diagonal --tool-offset 0,0,150 --steps 13"
    argv = shlex.split(cmd)
    assert argv[:2] == ["volcal", "plan"]
    r = volcal(*argv[1:])
    assert r.returncode == 0, r.stderr
    added = read_session(g, require_deviation=False).measurements[17:]
    assert [m.id for m in added] == ["diag-ppp-2", "diag-npp-2", "diag-pnp-2", "diag-ppn-2"]
    travel = np.array([[0, 1200], [0, 800], [0, 600.0]])
    want = next(a for a in candidate_additions(travel)
                if a.label == "the 4 body diagonals with a tool offset of 150 mm in Z")
    planned = want.plan(travel, "FXYZ", 13)
    assert len(added) == len(planned) == 4
    for a, m in zip(added, planned, strict=True):
        assert a.n == m.n == 14 and a.kind == m.kind == "diagonal"
        np.testing.assert_array_equal(a.tool_offset, [0, 0, 150])
        np.testing.assert_allclose(a.positions, m.positions, atol=1e-6)  # CSV: 6 decimals
