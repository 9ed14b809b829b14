"""docs/python.md: its code blocks run as written (in a temporary folder)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from timing import scaled_timeout
from volcal_cli_helpers import SUBPROCESS

DOC = Path(__file__).resolve().parents[1] / "docs" / "python.md"


def _blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)


def _run_script(script: str, cwd: Path, monkeypatch) -> subprocess.CompletedProcess[str]:
    """Run the walkthrough in ``cwd``: in this process (a fresh namespace, its output
    captured, its report's figures blank and its report.pdf and certificate.pdf stubs:
    tests/report_stubs.py, they are drawn by tests/report; the model's U drawn once per
    model content: tests/model_u_once.py, the walkthrough asks for the U of the same
    model more than once) unless VOLCAL_TEST_SUBPROCESS=1, then in a Python process of its
    own."""
    if SUBPROCESS:
        return subprocess.run([sys.executable, "-c", script], cwd=cwd, capture_output=True,
                              text=True, timeout=scaled_timeout(900))
    import contextlib
    import io
    import traceback

    from report_stubs import use_blank_figures, use_stub_pdfs

    use_blank_figures(monkeypatch)
    use_stub_pdfs(monkeypatch)
    monkeypatch.chdir(cwd)
    out, err, code = io.StringIO(), io.StringIO(), 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            exec(compile(script, "docs/python.md", "exec"), {"__name__": "__main__"})
        except BaseException:  # what the user would see
            err.write(traceback.format_exc())
            code = 1
    return subprocess.CompletedProcess(["python"], code, out.getvalue(), err.getvalue())


def test_walkthrough_runs_and_writes_every_output(tmp_path, monkeypatch, model_u_once):
    blocks = _blocks()
    assert len(blocks) == 5  # flow, measured session, advise/program/import, budget, tables
    assert len([ln for ln in blocks[0].splitlines() if ln.strip()]) <= 13
    script = "\n".join(blocks) + "\n"
    r = _run_script(script, tmp_path, monkeypatch)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    assert "model of VMC-400 (chain XYFZ, travel 0..400 x 0..300 x 0..200 mm)" in r.stdout
    assert re.search(r"ELv = \d+\.\d\d um \(measured\)", r.stdout)
    for f in ("session/session.toml", "session/truth/machine.csv", "model.json",
              "compensation/volcal-compensation.toml", "compensation/FANUC_PITCH.TXT",
              "report/report.html", "report/report.pdf", "imported/session.toml",
              "report/certificate.json", "report/certificate.pdf", "budget.toml"):
        assert (tmp_path / f).is_file(), f
    import tomllib

    man = tomllib.loads((tmp_path / "compensation/volcal-compensation.toml").read_text())
    assert man["sign"] == "correction"  # Fanuc's own sign, never a silent "error"
    html = (tmp_path / "report/report.html").read_text(encoding="utf-8")
    assert "Compensation tables for the &#39;fanuc&#39; format were written" in html
    assert "Tolerance verdict" in html  # tolerance_um=15 reached the report
    # 4 body diagonals and 3 lines per axis, one program each
    assert len(list((tmp_path / "programs").glob("*.ngc"))) == 4 + 9
    assert "[0.  1.2 1.9 0.4]" in r.stdout  # the imported readings [um]
    assert "mm (detected from the header)" in r.stdout
    assert re.search(r"function\s+axis\s+position_mm\s+value\s+u\s+unit", r.stdout)
    assert re.search(r"\d\s+EXX\s+X\s+0\.0\s+0\.0+\s+0\.0+\s+um", r.stdout)
    assert re.search(r"id\s+axis\s+A_um\s+R_um\s+B_um", r.stdout)
    assert "'target_mm':" in r.stdout and "'mean_up_um':" in r.stdout
    # the budget block: U of A, and a guarded verdict per axis with its U
    u_a = float(re.search(r"U\(A\) linear-x1 = (\d+\.\d\d) um", r.stdout).group(1))
    assert 0 < u_a < 10
    guarded = re.findall(r"([XYZ]): ISO 230-2 A \(.*?\) (pass|conditional|fail) U = "
                         r"(\d+\.\d\d) um", r.stdout)
    assert [g[0] for g in guarded] == ["X", "Y", "Z"] and all(float(g[2]) > 0
                                                              for g in guarded)
    import json

    cert = json.loads((tmp_path / "report/certificate.json").read_text(encoding="utf-8"))
    assert cert["format"] == "volcal-certificate/1" and cert["item"]["name"] == "VMC-400"


def test_import_volcal_is_light():
    code = ("import sys, volcal; assert 'matplotlib' not in sys.modules; "
            "assert 'volcal.identify' not in sys.modules; "
            "from volcal import Calibration, evaluate_session; "
            "assert 'matplotlib' not in sys.modules; print('ok')")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=scaled_timeout(60))
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr
