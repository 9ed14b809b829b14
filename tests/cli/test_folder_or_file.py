"""A session named by its ``session.toml``, and a folder given where a file is expected
(session 19, found as a user).

``volcal simulate S/session.toml`` read the session (the reader accepts its
``session.toml``) and then wrote the session "folder" ``S/session.toml``: the atomic
folder writer moved the file ``session.toml`` aside to ``S/.session.toml.old.*`` and put
a folder in its place, so ``S`` was no session any more (the whole session nested in
``S/session.toml/``) and the output said "truth in S/session.toml/truth/". A folder given
as a model or a positioning file read "model file not found" or "cannot read the file as
UTF-8 text (IsADirectoryError)".
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from volcal import Calibration
from volcal.cli import app
from volcal.errors import VolcalInputError
from volcal.io.atomic import atomic_dir

runner = CliRunner()


def refused(args: list[str]) -> str:
    """The message a command refuses with (``volcal.cli.main`` prints it as ``error:``)."""
    r = runner.invoke(app, args)
    assert isinstance(r.exception, VolcalInputError), (r.exit_code, r.output)
    return " ".join(str(r.exception).split())


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    d = tmp_path_factory.mktemp("toml")
    Calibration.plan([[0, 800], [0, 600], [0, 500]], steps=4, runs=1,
                     name="TOML").save(d / "S")
    return d


def test_simulate_a_session_named_by_its_toml(planned):
    s = planned / "S"
    r = runner.invoke(app, ["simulate", str(s / "session.toml"), "--seed", "3"])
    assert r.exit_code == 0, r.output
    assert (s / "session.toml").is_file()  # not replaced by a folder
    assert [p.name for p in s.iterdir() if p.name.startswith(".")] == []
    assert (s / "truth" / "machine.csv").is_file()
    assert f"truth in {s}/truth/" in " ".join(r.output.split())
    sess = Calibration.open(s).session
    assert len(sess.measurements) > 0 and not sess.unmeasured


def test_a_folder_never_replaces_a_file(tmp_path):
    f = tmp_path / "notes.txt"
    f.write_text("mine", encoding="utf-8")
    with pytest.raises(VolcalInputError, match="a file, not a folder") as exc:
        with atomic_dir(f) as tmp:
            (tmp / "x").write_text("new", encoding="utf-8")
    assert str(f) in str(exc.value)
    assert f.read_text(encoding="utf-8") == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_simulate_where_nothing_is_planned(tmp_path):
    text = refused(["simulate", str(tmp_path / "LEFT"), "--seed", "1"])
    assert "no planned session here" in text and "plan it first" in text
    assert not (tmp_path / "LEFT").exists()


def test_a_folder_given_as_a_file(planned):
    s = planned / "S"
    text = refused(["evaluate", "iso230-2", str(s)])
    assert f"{s}: a folder, not a positioning file" in text
    assert "a session folder: name one of its measurement files" in text
    # which ones (its linear tests, the first three), and what evaluates them all
    assert (f"files: {s / 'linear-x1.csv'}, {s / 'linear-x2.csv'}, {s / 'linear-x3.csv'} ...; "
            f"volcal evaluate session {s} evaluates every test") in text, text
    text = refused(["evaluate", "vdi3441", str(s)])  # the same layouts, the same answer
    assert (f"files: {s / 'linear-x1.csv'}, {s / 'linear-x2.csv'}, {s / 'linear-x3.csv'} ...; "
            f"volcal evaluate session {s} evaluates every test") in text, text
    text = refused(["evaluate", "volumetric", str(s)])
    assert f"{s}: a session folder, not a model: identify it first" in text, text
    # compensate takes a session too, as --session (its rotary tests' tables)
    text = refused(["compensate", str(s), "--format", "linuxcnc", "-o", str(planned / "C")])
    assert (f"{s / 'session.toml'}: a session folder, not a model: give a session as "
            f"--session {s} (its rotary tests' tables") in text, text
    assert f"(volcal identify {s} -o model.json)" in text
    assert "a folder, not a model file" in refused(["evaluate", "volumetric", str(planned)])
    assert not (planned / "C").exists()


def test_a_table_separated_by_semicolons(tmp_path):
    from volcal.io.table import Column, TableSpec, read_table

    f = tmp_path / "points.csv"
    f.write_text("x_mm;y_mm;z_mm\n0;0;0\n", encoding="utf-8")
    spec = TableSpec(columns=(Column("x_mm"), Column("y_mm"), Column("z_mm")), what="points")
    with pytest.raises(VolcalInputError, match="separated by semicolons or tabs") as exc:
        read_table(f, spec)
    assert "row 1, column 'x_mm'" in str(exc.value)


def test_a_planned_session_of_other_kinds_names_their_readings_columns(tmp_path):
    """A planned session of R-test and probe-on-sphere tests: ``evaluate iso230-2`` on its
    folder says it has no test ISO 230-2 evaluates, and the session reader names the
    columns the readings go in (an R-test's dx_um, a probed centre's x_mm), not
    deviation_um; a rotary test's is deviation_urad, of its one measurement."""
    s = tmp_path / "S"
    r = runner.invoke(app, ["plan", "--tests", "r_test,probe_sphere", "-o", str(s)])
    assert r.exit_code == 0, r.output
    text = refused(["evaluate", "iso230-2", str(s)])
    assert (f"{s}: a folder, not a positioning file (a session folder without linear or "
            f"rotary tests, which ISO 230-2 evaluates; volcal evaluate session {s} evaluates "
            "its tests)") in text, text
    text = refused(["evaluate", "session", str(s)])
    assert ("no readings yet: the dx_um, x_mm columns of all 2 measurements are empty "
            "(measure them,") in text, text
    r = runner.invoke(app, ["plan", "--tests", "rotary:c", "-o", str(tmp_path / "R")])
    assert r.exit_code == 0, r.output
    text = refused(["evaluate", "session", str(tmp_path / "R")])
    assert ("column 'deviation_urad': no readings yet: the deviation_urad column of its one "
            "measurement is empty (measure it,") in text, text
    text = refused(["evaluate", "iso230-2", str(tmp_path / "R")])
    assert f"files: {tmp_path / 'R' / 'rotary-c.csv'}; volcal evaluate session" in text, text
    text = refused(["evaluate", "vdi3441", str(tmp_path / "R")])  # linear axes only
    assert ("(a session folder without linear tests, which VDI/DGQ 3441 evaluates; volcal "
            f"evaluate session {tmp_path / 'R'} evaluates its tests)") in text, text
