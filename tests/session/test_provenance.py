"""``volcal simulate`` never overwrites measured readings; ``--overwrite`` keeps a backup."""

from __future__ import annotations

import csv
import hashlib
import shutil
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "cli"))
from test_cli_bad_input import volcal  # noqa: E402

from cli_mutations import snapshot  # noqa: E402
from volcal.session.format import read_session  # noqa: E402
from volcal.session.provenance import readings_digest  # noqa: E402

TRAVEL = "0:400,0:300,0:200"


@pytest.fixture(scope="module")
def planned(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("p") / "P"
    r = volcal("plan", "--travel", TRAVEL, "--steps", "2", "--runs", "2",
               "--tests", "linear,diagonal", "-o", d)
    assert r.returncode == 0, r.stderr
    return d


def _edit_reading(p: Path, row: int = 3, value: str = "7.125") -> None:
    rows = list(csv.reader(p.open()))
    rows[row - 1][rows[0].index("deviation_um")] = value
    with p.open("w") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)


def test_simulate_records_provenance_and_may_simulate_again(planned, tmp_path):
    S = tmp_path / "S"
    shutil.copytree(planned, S)
    assert volcal("simulate", S, "--seed", "1").returncode == 0
    s = read_session(S)
    p = s.provenance
    assert p["readings"] == "simulated" and p["seed"] == 1 and p["noise_um"] == 0.5
    assert p["readings_sha256"] == readings_digest(read_session(S, require_deviation=False))
    first = (S / "diag-ppp.csv").read_text()
    r = volcal("simulate", S, "--seed", "2")
    assert r.returncode == 0, r.stderr
    assert (S / "diag-ppp.csv").read_text() != first
    assert not (S / "backup").exists()  # simulated readings replaced: nothing to keep


def test_a_simulated_multilateration_session_may_be_simulated_again(tmp_path):
    """A tracker's ``length_mm`` (8 decimals of mm) read back gives deviations that differ
    from the simulated ones in the sixth decimal of a um: the digest of the deviations
    did not match, so simulating such a session again was refused as "readings volcal
    simulate did not write" (found by session 26's random journeys). The digest is now of
    the reading column as written; for the other kinds it is what it was (a session
    simulated before keeps its provenance)."""
    import numpy as np

    S = tmp_path / "S"
    assert volcal("plan", "--travel", TRAVEL, "--steps", "3", "--runs", "2", "--tests",
                  "multilateration,linear:x,diagonal,rotary:c", "-o", S).returncode == 0
    assert volcal("simulate", S, "--seed", "1").returncode == 0
    s = read_session(S, require_deviation=False)
    assert s.provenance["readings_sha256"] == readings_digest(s)
    r = volcal("simulate", S, "--seed", "2")
    assert r.returncode == 0, r.stderr
    # the digest of the kinds other than multilateration: session 25's formula
    legacy = hashlib.sha256()
    for m in sorted(s.measurements, key=lambda m: m.id):
        if m.kind == "multilateration":
            continue
        legacy.update(m.id.encode() + b"\n")
        legacy.update(",".join("missed" if np.isnan(v) else f"{v:.6f}"
                               for v in m.deviation).encode() + b"\n")
    rest = type(s)(s.name, s.chain, s.travel,
                   [m for m in s.measurements if m.kind != "multilateration"])
    assert readings_digest(rest) == legacy.hexdigest()


@pytest.mark.parametrize("how", ["measured", "edited-after-simulate", "partly-measured"])
def test_simulate_refuses_measured_readings(planned, tmp_path, how):
    S = tmp_path / "S"
    shutil.copytree(planned, S)
    if how == "measured":  # readings without provenance: a copied measured session
        assert volcal("simulate", S, "--seed", "1").returncode == 0
        p = S / "session.toml"
        p.write_text(p.read_text().split("[provenance]")[0] + "[[measurements]]"
                     + p.read_text().split("[[measurements]]", 1)[1])
        shutil.rmtree(S / "truth")
    elif how == "edited-after-simulate":
        assert volcal("simulate", S, "--seed", "1").returncode == 0
        _edit_reading(S / "linear-x2.csv")
    else:
        rows = list(csv.reader((S / "linear-y1.csv").open()))
        j = rows[0].index("deviation_um")
        for i, x in enumerate(rows[1:]):
            x[j] = f"{0.5 * i:.3f}"
        with (S / "linear-y1.csv").open("w") as fh:
            csv.writer(fh, lineterminator="\n").writerows(rows)
    before = snapshot(S)
    r = volcal("simulate", S, "--seed", "3")
    assert r.returncode == 2
    msg = " ".join(r.stderr.split())
    assert "holds readings that `volcal simulate` did not write (" in msg
    assert ("simulating would overwrite them; nothing was changed. Use --overwrite to replace "
            "them (a backup is kept in backup/)") in msg
    if how == "partly-measured":
        assert "(linear-y1)" in msg
    assert snapshot(S) == before


def test_overwrite_keeps_a_backup(planned, tmp_path):
    S = tmp_path / "S"
    shutil.copytree(planned, S)
    assert volcal("simulate", S, "--seed", "1").returncode == 0
    _edit_reading(S / "linear-x2.csv")
    (S / "notes.txt").write_text("keep me")
    old = {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
           for p in S.iterdir() if p.is_file()}
    old_truth = (S / "truth" / "machine.csv").read_text()
    r = volcal("simulate", S, "--seed", "3", "--overwrite")
    assert r.returncode == 0, r.stderr
    backups = list((S / "backup").iterdir())
    assert len(backups) == 1
    b = backups[0]
    assert f"the old files are kept in {S / 'backup' / b.name}/" in " ".join(r.stdout.split())
    for name, digest in old.items():
        if name != "notes.txt":
            assert hashlib.sha256((b / name).read_bytes()).hexdigest() == digest, name
    assert (b / "truth" / "machine.csv").read_text() == old_truth
    assert (S / "notes.txt").read_text() == "keep me"
    assert "7.125" not in (S / "linear-x2.csv").read_text()
    assert read_session(S).provenance["seed"] == 3


def test_import_replace_keeps_the_replaced_readings(planned, tmp_path):
    from test_cli_bad_input import LASER_EXPORT, LASER_MAP

    S = tmp_path / "S"
    shutil.copytree(planned, S)
    assert volcal("simulate", S, "--seed", "1").returncode == 0
    (tmp_path / "laser.csv").write_text(LASER_EXPORT)
    old_csv = (S / "linear-x1.csv").read_bytes()
    old_toml = (S / "session.toml").read_bytes()
    r = volcal("import", tmp_path / "laser.csv", "--map", LASER_MAP, "--axis", "X",
               "--session", S, "--id", "linear-x1", "--replace")
    assert r.returncode == 0, r.stderr
    (b,) = list((S / "backup").iterdir())
    assert (b / "linear-x1.csv").read_bytes() == old_csv
    assert (b / "session.toml").read_bytes() == old_toml
    assert f"the replaced readings of linear-x1 are kept in {b}/" in " ".join(r.stdout.split())
    assert read_session(S).get("linear-x1").n == 12
    # replacing a planned (empty) measurement keeps no backup: nothing to lose
    P = tmp_path / "P"
    shutil.copytree(planned, P)
    r = volcal("import", tmp_path / "laser.csv", "--map", LASER_MAP, "--axis", "X",
               "--session", P, "--id", "linear-x1", "--replace")
    assert r.returncode == 0, r.stderr
    assert not (P / "backup").exists()


def test_import_never_overwrites_a_file_of_the_folder(planned, tmp_path):
    from test_cli_bad_input import LASER_EXPORT, LASER_MAP

    S = tmp_path / "S"
    shutil.copytree(planned, S)
    (S / "mine.csv").write_text("my notes\n")
    (tmp_path / "laser.csv").write_text(LASER_EXPORT)
    before = snapshot(S)
    r = volcal("import", tmp_path / "laser.csv", "--map", LASER_MAP, "--axis", "X",
               "--session", S, "--id", "mine")
    assert r.returncode == 2
    assert "'mine.csv' exists in the session and is not a measurement's file" in r.stderr
    assert snapshot(S) == before


def test_plan_into_a_planned_folder_keeps_other_files(planned, tmp_path):
    P = tmp_path / "P"
    shutil.copytree(planned, P)
    (P / "notes.txt").write_text("keep me")
    r = volcal("plan", "--travel", TRAVEL, "--steps", "3", "--tests", "diagonal", "-o", P)
    assert r.returncode == 2 and "--replace" in r.stderr  # issue 20: never silently
    r = volcal("plan", "--travel", TRAVEL, "--steps", "3", "--tests", "diagonal", "-o", P,
               "--replace")
    assert r.returncode == 0, r.stderr
    assert (P / "notes.txt").read_text() == "keep me"
    assert len(read_session(P, require_deviation=False).measurements) == 4
    (b,) = (P / "backup").iterdir()  # the old plan, moved aside
    assert (b / "session.toml").read_bytes() == (planned / "session.toml").read_bytes()
    # ... and never replaces a session with readings
    assert volcal("simulate", P).returncode == 0
    before = snapshot(P)
    r = volcal("plan", "--travel", TRAVEL, "-o", P)
    assert r.returncode == 2 and snapshot(P) == before
