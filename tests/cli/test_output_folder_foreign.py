"""Issue 25, finding 5: a command that replaces its output folder never deletes a file
volcal did not write there (a signed scan put into the report folder).

Without ``--replace`` it refuses, exit code 2 (a user error), naming the files, nothing
changed; with ``--replace`` they are moved into ``backup/<UTC time>/`` of the folder and
the output is written; re-running over its own output still works, and ``backup/``
survives it. Report, compensate and program through the command line; the same through
``volcal.Calibration``; the library function on its own.

The reports are written with blank figures and a stub PDF (tests/report_stubs.py): what
is checked is which files are kept, moved or replaced, not the drawing.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.io.folders import claim_folder, foreign_files, manifest_files
from volcal.io.paths import check_output_folder
from volcal_cli_helpers import run_volcal

SCAN = b"%PDF-1.4 signed scan of the certificate"


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A small simulated session and its model file."""
    from volcal.identify import identify
    from volcal.measure.simulate import SimulationOptions, simulate_session
    from volcal.measure.virtual import random_machine
    from volcal.plan.planner import plan_session
    from volcal.session.format import read_session, write_session

    travel = np.array([[0, 400], [0, 300], [0, 250]], float)
    s = plan_session(travel, "XYFZ", 4, ("diagonal", "linear"), 2, name="FOLDER-VMC")
    simulate_session(s, random_machine(travel, "XYFZ", seed=3, n_nodes=21),
                     SimulationOptions(noise_um=0.3, seed=3))
    folder = tmp_path_factory.mktemp("foreign") / "session"
    write_session(s, folder)
    r = identify(read_session(folder))
    path = folder.parent / "model.json"
    r.to_json(path)
    return folder, path


def _backups(folder: Path) -> list[Path]:
    return sorted((folder / "backup").iterdir()) if (folder / "backup").is_dir() else []


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_report_over_a_folder_with_a_foreign_file(model, tmp_path, monkeypatch, capsys,
                                                  blank_figures, stub_pdfs, model_u_once):
    session, mfile = model
    out = tmp_path / "R"
    args = ["report", str(session), "--model", str(mfile), "-o", str(out)]
    code, _, err = run_volcal(monkeypatch, capsys, *args)
    assert code == 0, err
    (out / "signed-certificate.pdf").write_bytes(SCAN)
    (out / "figures" / "my photo.jpg").write_bytes(b"jpeg")
    before = _snapshot(out)
    code, _, err = run_volcal(monkeypatch, capsys, *args)
    err = " ".join(err.split())
    assert code == 2 and "Traceback" not in err
    assert (f"{out}: holds 2 files volcal did not write there (figures/my photo.jpg, "
            "signed-certificate.pdf)") in err and "--replace" in err
    assert _snapshot(out) == before  # nothing deleted, nothing written

    code, _, err = run_volcal(monkeypatch, capsys, *args, "--replace")
    assert code == 0, err
    (b,) = _backups(out)
    assert re.fullmatch(r"\d{8}T\d{6}Z", b.name)
    assert (b / "signed-certificate.pdf").read_bytes() == SCAN
    assert (b / "figures" / "my photo.jpg").read_bytes() == b"jpeg"
    assert not (out / "signed-certificate.pdf").exists()
    assert (out / "report.pdf").read_bytes()[:5] == b"%PDF-"
    assert f"moved to {out / 'backup' / b.name}/" in " ".join(err.split())

    # its own output (and its backup/) again, without --replace: replaced, backup kept
    code, _, err = run_volcal(monkeypatch, capsys, *args)
    assert code == 0, err
    assert _backups(out) == [b] and (b / "signed-certificate.pdf").read_bytes() == SCAN
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no leftovers


def test_compensate_and_program_refuse_and_replace_the_same(model, tmp_path, monkeypatch,
                                                            capsys):
    session, mfile = model
    for cmd, extra in (("compensate", ["--format", "linuxcnc"]),
                       ("program", ["--dialect", "linuxcnc"])):
        out = tmp_path / cmd
        src = str(mfile) if cmd == "compensate" else str(session)
        args = [cmd, src, *extra, "-o", str(out)]
        code, _, err = run_volcal(monkeypatch, capsys, *args)
        assert code == 0, err
        code, _, err = run_volcal(monkeypatch, capsys, *args)  # its own output: replaced
        assert code == 0, err
        (out / "notes.txt").write_text("spindle warm-up 20 min", "utf-8")
        before = _snapshot(out)
        code, _, err = run_volcal(monkeypatch, capsys, *args)
        assert code == 2 and "holds 1 file volcal did not write there (notes.txt)" in " ".join(
            err.split()), (cmd, err)
        assert _snapshot(out) == before
        code, _, err = run_volcal(monkeypatch, capsys, *args, "--replace")
        assert code == 0, err
        (b,) = _backups(out)
        assert (b / "notes.txt").read_text("utf-8") == "spindle warm-up 20 min"
        assert not (out / "notes.txt").exists()


def test_calibration_refuses_and_replaces_the_same(model, tmp_path):
    from volcal import Calibration

    session, mfile = model
    cal = Calibration.open(session)
    cal.load_model(mfile)
    out = tmp_path / "c"
    files = cal.compensate(out, format="csv")
    (out / "scan.pdf").write_bytes(SCAN)
    with pytest.raises(VolcalInputError) as e:
        cal.compensate(out, format="csv")
    assert "holds 1 file volcal did not write there (scan.pdf)" in str(e.value)
    assert "give replace=True to move it" in str(e.value)
    assert (out / "scan.pdf").read_bytes() == SCAN
    assert cal.compensate(out, format="csv", replace=True) == files
    (b,) = _backups(out)
    assert (b / "scan.pdf").read_bytes() == SCAN


def test_the_library_function(tmp_path):
    d = tmp_path / "d"
    (d / "sub").mkdir(parents=True)
    (d / "volcal-programs.toml").write_text('programs = [{file = "A.ngc"}]\n', "utf-8")
    (d / "A.ngc").write_text("G0\n", "utf-8")
    (d / "sub" / "B.txt").write_text("b", "utf-8")
    (d / "backup" / "old").mkdir(parents=True)
    (d / "backup" / "old" / "x").write_text("x", "utf-8")
    written = manifest_files("volcal-programs.toml", "programs", "file")
    assert sorted(written(d)) == ["A.ngc", "volcal-programs.toml"]
    assert foreign_files(d, written(d)) == ["sub/B.txt"]  # backup/ is volcal's
    with pytest.raises(VolcalInputError, match=r"holds 1 file .*\(sub/B.txt\)"):
        claim_folder(d, "program", written)
    rel = claim_folder(d, "program", written, replace=True)
    assert (d / rel / "sub" / "B.txt").read_text("utf-8") == "b"
    assert foreign_files(d, written(d)) == []
    assert claim_folder(d, "program", written) is None
    # a folder of no volcal kind: the old refusal; with replace every file moved aside,
    # but a session folder is never taken over
    other = tmp_path / "other"
    other.mkdir()
    (other / "thesis.txt").write_text("precious", "utf-8")
    with pytest.raises(VolcalInputError, match="is not a volcal report folder"):
        check_output_folder(other, "report", lambda p: False, written=lambda p: [])
    check_output_folder(other, "report", lambda p: False, written=lambda p: [], replace=True)
    (b,) = _backups(other)
    assert (b / "thesis.txt").read_text("utf-8") == "precious"
    (other / "session.toml").write_text("", "utf-8")
    with pytest.raises(VolcalInputError, match="is not a volcal report folder"):
        check_output_folder(other, "report", lambda p: False, written=lambda p: [],
                            replace=True)


def test_atomic_dir_carries_the_backup_into_the_new_folder(tmp_path):
    from volcal.io.atomic import atomic_dir

    d = tmp_path / "d"
    (d / "backup" / "t").mkdir(parents=True)
    (d / "backup" / "t" / "scan.pdf").write_bytes(SCAN)
    (d / "old.txt").write_text("old", "utf-8")
    with atomic_dir(d) as tmp:
        (tmp / "new.txt").write_text("new", "utf-8")
    assert _snapshot(d) == {"backup/t/scan.pdf": SCAN, "new.txt": b"new"}
    assert np.all([not p.name.startswith(".") for p in tmp_path.iterdir()])
