import json
import re
import subprocess
import sys
from pathlib import Path

import report_fixtures as _fx

from report_stubs import use_blank_figures
from timing import scaled_timeout
from volcal_cli_helpers import volcal_process

# pytest fixtures shared by the report tests (see report_fixtures.py)
identified = _fx.identified
small_session = _fx.small_session

VOLCAL = [sys.executable, "-c", "from volcal.cli import main; main()"]
def _run(*args, cwd=None):
    """``volcal *args`` as a process (the demo end to end, the refusals' exit codes)."""
    p = subprocess.run([*VOLCAL, *args], capture_output=True, text=True, cwd=cwd,
                       timeout=scaled_timeout(600))
    # rich wraps long lines at the terminal width; compare words, not line breaks
    p.stdout, p.stderr = " ".join(p.stdout.split()), " ".join(p.stderr.split())
    return p


def _in_process(*args):
    """``volcal *args`` in-process unless VOLCAL_TEST_SUBPROCESS=1 (volcal_cli_helpers:
    a process costs seconds of imports), white space squeezed as by :func:`_run`."""
    p = volcal_process(*args, timeout=scaled_timeout(600))
    p.stdout, p.stderr = " ".join(p.stdout.split()), " ".join(p.stderr.split())
    return p


def test_report_with_a_model_file(identified, tmp_path, monkeypatch):
    s, r = identified
    model = tmp_path / "model.json"
    r.to_json(model)
    out = tmp_path / "rep"
    from volcal.compensate.formats import CompensationOptions, write_compensation

    write_compensation(r.errors, "heidenhain", tmp_path / "comp",
                       CompensationOptions("error", 25.0), "model.json")
    # in-process (volcal_process): the command's files and words, not its process; the
    # report's figures blank (tests/report_stubs.py: drawn for real in the demo below and
    # in the shared rendering of the report tests)
    use_blank_figures(monkeypatch)
    p = _in_process("report", str(s.path), "--model", str(model), "-o", str(out),
                    "--compensation", str(tmp_path / "comp"), "--tolerance-um",
                    "X=1000,Y=0.001,V=1000")
    assert p.returncode == 0, p.stderr
    html = (out / "report.html").read_text(encoding="utf-8")
    assert html.count("<img ") >= 5
    # the compensation section names what the Heidenhain tables carry, and the verdict
    assert "per-axis pitch only: EXX, EYY, EZZ" in html and "Tolerance verdict" in html
    assert "out of tolerance: Y: ISO 230-2 A" in html
    assert (out / "report.pdf").read_bytes()[:5] == b"%PDF-"
    assert not [f for f in tmp_path.iterdir() if f.name.startswith(".")]  # no leftovers


def test_report_of_a_missing_session_is_a_user_error(tmp_path):
    p = _run("report", str(tmp_path / "nope"), "-o", str(tmp_path / "r"))
    assert p.returncode == 2
    assert "no session.toml" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "r").exists()


def test_report_with_a_broken_model_is_a_user_error(small_session, tmp_path):
    bad = tmp_path / "model.json"
    bad.write_text("{not json", encoding="utf-8")
    p = _run("report", str(small_session), "--model", str(bad), "-o", str(tmp_path / "r"))
    assert p.returncode == 2 and "invalid JSON" in p.stderr and "Traceback" not in p.stderr


def test_demo_writes_a_report_with_at_least_five_figures(tmp_path):
    out = tmp_path / "demo-output"
    p = _run("demo", "-o", str(out))
    assert p.returncode == 0, p.stderr
    html_path = out / "report" / "report.html"
    assert str(html_path.resolve()) in p.stdout
    html = html_path.read_text(encoding="utf-8")
    figs = re.findall(r'<img src="data:image/png;base64,', html)
    assert len(figs) >= 5
    assert len(list((out / "report" / "figures").glob("*.png"))) == len(figs)
    assert (out / "report" / "report.pdf").stat().st_size > 10000
    assert (out / "model.json").is_file() and (out / "session" / "truth" / "machine.csv").is_file()
    assert "Positioning (ISO 230-2)" in html and "Volumetric error" in html
    assert "Compensation" in html and (out / "compensation" / "volcal-compensation.toml").is_file()
    # the tables the demo wrote are summarised (Calibration.report(compensation=...))
    assert "Compensation tables for the &#39;grid&#39; format were written" in html
    assert Path(out / "session" / "session.toml").is_file()
    # the as-left rehearsal: the plan simulated with the demo's grid active, paired with
    # the as-found on the certificate
    assert "grid = true" in (out / "as-left" / "truth" / "compensation.toml").read_text()
    cert = json.loads((out / "report" / "certificate.json").read_text(encoding="utf-8"))
    found, left = cert["results"]["as_found"], cert["results"]["as_left"]
    assert left["simulated"] and len(left["positioning"]) == 9
    assert cert["tables"]["controller_format"] == "grid"
    assert left["elv"]["ELv"] < 0.2 * found["elv"]["ELv"]  # seed 7: 22.8 -> 0.9 um
    assert "certificate: as found and as left" in p.stdout
