"""The report's "Previous calibration" section (volcal report S --history DB)."""

from __future__ import annotations

import subprocess
import sys

import history_fixtures as _fx
import pytest

from volcal.errors import VolcalInputError

# pytest fixtures shared by the history tests (see history_fixtures.py)
history_two = _fx.history_two


def test_previous_section_flags_the_x_scale(history_two):
    """B (X scale +10 um/m) against stored A: EXX changed, about 8 um at x = 800 mm.

    The history is read from the store; B's model is not stored.
    """
    from volcal.history.previous import previous_section
    from volcal.identify.modelfile import load_model
    from volcal.report.document import Report
    from volcal.report.html import render_html
    from volcal.report.pipeline import collect_inputs
    from volcal.session.format import read_session

    b = history_two["b"]
    s = read_session(b)
    inp = collect_inputs(s, load_model(b / "model.json"))
    sec = previous_section(inp, history_two["db"])
    assert sec.id == "previous"
    assert history_two["id"] in sec.paragraphs[0] and "2026-01-10" in sec.paragraphs[0]
    # the only function flagged is EXX; its largest difference is the scale change at
    # the end of the travel (10 um/m * 800 mm = 8 um, within the identification's U)
    flagged = sec.tables[0]
    assert [r[0] for r in flagged.rows] == ["EXX"]
    d, U = float(flagged.rows[0][1]), float(flagged.rows[0][2])
    assert abs(d - 8.0) < max(U, 1.0) and flagged.rows[0][4] == "800"
    assert sec.warnings and sec.warnings[0].startswith(f"changed since {history_two['id']}")
    # results: B's evaluation minus A's stored value, per axis (ISO 230-2 A, E, M, R, B)
    from volcal.history.api import History
    from volcal.standards.session import evaluate_session

    res = {r[0]: r for r in sec.tables[1].rows}
    assert {"X.A", "Y.E", "Z.R", "V.E_VXYZ"} <= set(res)
    assert not any(n.endswith(("_up", "_down", "length_mm")) for n in res)
    ev = evaluate_session(s, inp.result)
    first_x = next(m for m, ax in ev.axis.items() if ax.upper() == "X")
    with History(history_two["db"]) as h:
        a_xa = h.show(history_two["id"]).results["X.A"]["value"]
    assert float(res["X.A"][1]) == pytest.approx(ev.iso230_2[first_x].A - a_xa, abs=0.006)
    # rendered by the report's HTML renderer (the section alone: the figures of the whole
    # report would take seconds)
    html = render_html(Report("t", [sec]))
    assert 'id="previous"' in html and "Previous calibration" in html
    assert "<td>EXX</td>" in html.replace(" ", "")


def test_history_is_loaded_only_with_the_option(history_two, tmp_path):
    """The report command imports volcal.history only when --history is given."""
    code = ("import sys\nfrom volcal.report import pipeline, sections\n"
            "import volcal.cli.report\n"
            "assert not [m for m in sys.modules if m.startswith(('volcal.history', "
            "'sqlalchemy'))], sorted(m for m in sys.modules if 'history' in m)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_missing_history_file_is_a_user_error(history_two, tmp_path):
    from volcal.history.previous import previous_section
    from volcal.report.sections import ReportInputs
    from volcal.session.format import read_session

    inp = ReportInputs(read_session(history_two["b"]))
    with pytest.raises(VolcalInputError, match="no such history file"):
        previous_section(inp, str(tmp_path / "none.sqlite"))


def test_no_earlier_calibration(history_two):
    """A stored only: its own report finds no earlier calibration (its record is itself)."""
    from volcal.history.previous import previous_section
    from volcal.report.sections import ReportInputs
    from volcal.session.format import read_session

    inp = ReportInputs(read_session(history_two["a"]))
    sec = previous_section(inp, history_two["db"])
    assert "no earlier calibration" in sec.paragraphs[0] and not sec.tables


def test_cli_missing_history_refused_before_work(history_two, tmp_path):
    b = history_two["b"]
    r = subprocess.run([sys.executable, "-c", "from volcal.cli import main; main()", "report",
                        str(b), "--model", str(b / "model.json"), "-o", str(tmp_path / "r"),
                        "--history", str(tmp_path / "none.sqlite")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "no such history file" in r.stderr
    assert not (tmp_path / "r").exists()


def test_previous_section_of_an_as_left(history_two, tmp_path):
    """B stored as the as-left of A: the section says that its changes are the tables' as
    much as the machine's (session 19); B stored as a plain calibration: it does not."""
    import shutil

    from volcal.history.api import History
    from volcal.history.previous import previous_section
    from volcal.identify.modelfile import load_model
    from volcal.report.pipeline import collect_inputs
    from volcal.session.format import read_session

    b = history_two["b"]
    inp = collect_inputs(read_session(b), load_model(b / "model.json"))
    texts = {}
    for kind in ("as-left", "plain"):
        db = tmp_path / f"{kind}.sqlite"
        shutil.copy(history_two["db"], db)  # A stored; B added here as kind
        with History(str(db)) as h:
            h.add(b, b / "model.json",
                  as_left_of=history_two["id"] if kind == "as-left" else None)
        texts[kind] = " ".join(previous_section(inp, str(db)).paragraphs)
    said = (f"This calibration is stored as the as-left of {history_two['id']} (measured "
            "with the compensation tables active)")
    assert said in texts["as-left"] and said not in texts["plain"]
    assert f"record {history_two['id']}, measured 2026-01-10" in texts["plain"]


def test_trend_of_an_axis_result_names_its_line(history_two):
    """``X.A`` is the first X line's: with three X lines, trend says so and names the
    others' parameters (session 19: a user trending X.A did not learn it)."""
    from volcal.history.api import History
    from volcal.history.trend import axis_lines_note, trend

    with History(history_two["db"]) as h:
        rows = trend(h, "VMC-1", "X.A")
        rid = rows[-1]["id"]
        res = h.store.current(rid).results
        assert res["X.A"]["value"] == res["linear-x1.A"]["value"]
        assert axis_lines_note(h, rows, "X.A") == (
            f"X.A is the first X line's (linear-x1); {rid} has 3 X lines: --parameter "
            "linear-x2.A, linear-x3.A for the others")
        assert axis_lines_note(h, trend(h, "VMC-1", "linear-x2.A"), "linear-x2.A") is None
        assert axis_lines_note(h, trend(h, "VMC-1", "V.E_VXYZ"), "V.E_VXYZ") is None
