"""Each test of a session is evaluated once (issue 25, item 2: "Evaluate once").

A spy on :func:`volcal.standards.iso230_2.evaluate` (and on
:func:`volcal.standards.iso230_6.evaluate_diagonal`) counts the evaluations of one
``Calibration.report(...)`` / ``volcal report`` with a tolerance, a budget and a
certificate: exactly one per linear test (and per diagonal) of each session, as-found and
as-left. The "after" of a verdict with compensation tables, and the line check of
``volcal compensate --session``, evaluate other readings (the readings with the tables'
correction taken off): they are counted apart.

The reports are written with blank figures and stub PDFs (tests/report_stubs.py): drawing
evaluates nothing (the figures and the certificate are built from the evaluation before
they are drawn), and the drawing is checked by the rendering tests of tests/report. The
model's U is drawn once per model content (tests/model_u_once.py): its draws evaluate no
test either, and the tests here give the same model file again and again.
"""

import shutil
from collections import Counter
from pathlib import Path

import pytest
import report_fixtures as _fx

from volcal_cli_helpers import run_volcal

# pytest fixtures shared by the report tests (see report_fixtures.py)
identified = _fx.identified
small_session = _fx.small_session

TOLERANCE = "X=1000,Y=1000,Z=1000,V=1000"

pytestmark = pytest.mark.usefixtures("blank_figures", "stub_pdfs", "model_u_once")


class Spy:
    """Counts the ISO 230-2 evaluations by file, the ISO 230-6 ones by measurement id."""

    # a measurement knows its file name, not its folder: the diagonals are counted by id

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        from volcal.standards import iso230_2, iso230_6, verdict

        self.linear: Counter = Counter()
        self.diagonal: Counter = Counter()
        self.after: Counter = Counter()
        real, real_d, real_after = (iso230_2.evaluate, iso230_6.evaluate_diagonal,
                                    verdict._after)

        def evaluate(*a, **k):
            self.linear[Path(str(k.get("file"))).resolve()] += 1
            return real(*a, **k)

        def evaluate_diagonal(meas, *a, **k):
            self.diagonal[meas.id] += 1
            return real_d(meas, *a, **k)

        def after(m, *a, **k):
            self.after[m.id] += 1
            return real_after(m, *a, **k)

        monkeypatch.setattr(iso230_2, "evaluate", evaluate)
        monkeypatch.setattr(iso230_6, "evaluate_diagonal", evaluate_diagonal)
        monkeypatch.setattr(verdict, "_after", after)


def _model_file(r, folder: Path, budget_file: Path | None = None) -> Path:
    """MODEL.json of the result; with a budget, identified with it (as ``volcal identify
    --budget``: the certificate refuses a model without the budget's systematic part)."""
    if budget_file is not None:
        from volcal.report.certificate_inputs import certificate_model
        from volcal.uncertainty.budget import read_budget

        r = certificate_model(r, read_budget(budget_file), budget_file)
    model = folder / "model.json"
    r.to_json(model)
    return model


def _files(session, kind: str) -> Counter:
    """Each measured test of a kind, once (the expected count): by file or by id."""
    return Counter((Path(session.path) / m.file).resolve() if kind == "linear" else m.id
                   for m in session.measurements if m.kind == kind and m.deviation is not None)


@pytest.fixture
def budget_file(tmp_path) -> Path:
    from volcal.uncertainty.budget import template_text

    p = tmp_path / "budget.toml"
    p.write_text(template_text(), encoding="utf-8")
    return p


@pytest.fixture
def as_left(identified, tmp_path) -> Path:
    """A copy of the session (same machine) as the as-left measurement: other files."""
    s, _ = identified
    return Path(shutil.copytree(s.path, tmp_path / "as-left"))


def test_calibration_report_evaluates_each_test_once(identified, budget_file, as_left,
                                                     tmp_path, monkeypatch):
    from volcal import Calibration
    from volcal.session.format import read_session

    s, r = identified
    cal = Calibration.open(s.path)
    cal.result = r
    left = read_session(as_left)
    spy = Spy(monkeypatch)
    cal.report(tmp_path / "rep", tolerance_um=TOLERANCE, certificate=True,
               budget=budget_file, as_left=as_left, decision_rule="guarded")
    lin = _files(s, "linear") + _files(left, "linear")
    assert len(lin) == 2 * len(_files(s, "linear")) >= 18  # 9 lines in each session
    assert spy.linear == lin  # one ISO 230-2 evaluation per linear test and session
    assert spy.diagonal == _files(s, "diagonal") + _files(left, "diagonal")
    assert not spy.after  # no compensation tables: no "after" readings
    assert cal.certificate is not None
    doc = cal.certificate.json.read_text(encoding="utf-8")
    assert '"as_left"' in doc and '"U_um"' in doc


def test_volcal_report_evaluates_each_test_once(identified, budget_file, tmp_path,
                                                monkeypatch, capsys):
    s, r = identified
    model = _model_file(r, tmp_path, budget_file)
    spy = Spy(monkeypatch)
    code, out, err = run_volcal(monkeypatch, capsys, "report", str(s.path), "--model",
                                str(model), "-o", str(tmp_path / "rep"), "--certificate",
                                "--budget", str(budget_file), "--tolerance-um", TOLERANCE)
    assert code == 0, err
    assert (tmp_path / "rep" / "certificate.json").is_file()
    assert spy.linear == _files(s, "linear")
    assert spy.diagonal == _files(s, "diagonal")
    assert not spy.after


def test_the_after_compensation_readings_are_evaluated_apart(identified, budget_file,
                                                             tmp_path, monkeypatch, capsys):
    """With --compensation the verdict's "after" evaluates the readings with the tables'
    correction taken off: one more ISO 230-2 evaluation per linear test of a toleranced
    axis, counted apart; the session's readings are still evaluated once."""
    from volcal.compensate.formats import CompensationOptions, write_compensation

    s, r = identified
    model = _model_file(r, tmp_path, budget_file)
    write_compensation(r.errors, "heidenhain", tmp_path / "comp",
                       CompensationOptions("error", 25.0), "model.json")
    spy = Spy(monkeypatch)
    code, out, err = run_volcal(monkeypatch, capsys, "report", str(s.path), "--model",
                                str(model), "-o", str(tmp_path / "rep"), "--certificate",
                                "--budget", str(budget_file), "--tolerance-um", "X=1000,Z=1000",
                                "--compensation", str(tmp_path / "comp"))
    assert code == 0, err
    xz = Counter({f: 1 for f in _files(s, "linear")
                  if f.stem.startswith(("linear-x", "linear-z"))})
    assert len(xz) == 6
    # the after-compensation readings of the toleranced axes, once each
    assert spy.after == Counter({f.stem: 1 for f in xz})
    assert spy.linear == _files(s, "linear") + xz  # the session's readings: once each


def test_compensate_session_checks_before_and_after_apart(identified, tmp_path, monkeypatch,
                                                          capsys):
    """``volcal compensate --session`` is another step: its line check evaluates each
    linear test's readings before and after the tables just written (two evaluations,
    of two sets of readings), and the reversal of one line per axis for the reverse
    tables (:func:`volcal.compensate.bidirectional.directional_from_session`)."""
    s, r = identified
    model = _model_file(r, tmp_path)
    spy = Spy(monkeypatch)
    code, out, err = run_volcal(monkeypatch, capsys, "compensate", str(model), "--format",
                                "linuxcnc", "-o", str(tmp_path / "comp"), "--session",
                                str(s.path))
    assert code == 0, err
    lin = _files(s, "linear")
    by_name = Counter()
    for f, n in spy.linear.items():  # the reversal reads the file without its folder
        by_name[f.stem] += n
    # before + after per line, and the line per axis the reverse table comes from
    assert sum(by_name.values()) == 2 * len(lin) + 3
    assert by_name == Counter({f.stem: 2 for f in lin}) + Counter(
        {f"linear-{a}1": 1 for a in "xyz"})


def test_volcal_evaluate_session_evaluates_each_test_once(identified, budget_file, tmp_path,
                                                          monkeypatch, capsys):
    """``volcal evaluate session --budget --tolerance-um --decision-rule guarded``: the
    table, the U and the verdict come from one evaluation per test."""
    import json

    s, r = identified
    model = _model_file(r, tmp_path, budget_file)
    spy = Spy(monkeypatch)
    code, out, err = run_volcal(monkeypatch, capsys, "evaluate", "session", str(s.path),
                                "--json", "--model", str(model), "--budget", str(budget_file),
                                "--tolerance-um", TOLERANCE, "--decision-rule", "guarded")
    assert code == 0, err
    assert spy.linear == _files(s, "linear")
    assert spy.diagonal == _files(s, "diagonal")
    doc = json.loads(out)
    assert len(doc["verdict"]) == 4 and all(v["U_before_um"] for v in doc["verdict"])
