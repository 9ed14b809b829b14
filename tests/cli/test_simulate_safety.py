"""`volcal simulate` never destroys measured readings."""


import numpy as np

from volcal.session.format import read_session, write_session
from volcal_cli_helpers import volcal_process


def _cli(*args):
    """``volcal *args`` in-process (VOLCAL_TEST_SUBPROCESS=1: in a process of its own)."""
    return volcal_process(*args)


def test_simulate_refuses_measured_readings_and_keeps_a_backup_on_overwrite(tmp_path):
    s_dir = tmp_path / "S"
    assert _cli("plan", "-o", str(s_dir), "--tests", "linear", "--steps", "4").returncode == 0
    assert _cli("simulate", str(s_dir), "--seed", "1").returncode == 0
    # simulated readings may be simulated again
    assert _cli("simulate", str(s_dir), "--seed", "2").returncode == 0
    # a copied session whose readings were measured (no provenance, no truth/)
    s = read_session(s_dir)
    for m in s.measurements:
        m.meta.pop("readings_source", None)
        m.deviation = np.arange(m.n, dtype=float) * 0.25
    write_session(s, tmp_path / "M")
    before = {p.name: p.read_text() for p in (tmp_path / "M").glob("*.csv")}
    r = _cli("simulate", str(tmp_path / "M"))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "did not write" in r.stderr and "--overwrite" in r.stderr
    assert {p.name: p.read_text() for p in (tmp_path / "M").glob("*.csv")} == before
    r = _cli("simulate", str(tmp_path / "M"), "--overwrite")
    assert r.returncode == 0, r.stderr
    backups = list((tmp_path / "M" / "backup").iterdir())
    assert len(backups) == 1
    assert {p.name: p.read_text() for p in backups[0].glob("*.csv")} == before
    assert (backups[0] / "session.toml").is_file()
    after = {p.name: p.read_text() for p in (tmp_path / "M").glob("*.csv")}
    assert after != before
