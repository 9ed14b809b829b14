"""Writers never leave a partial file: failures mid-write keep the old content."""

from __future__ import annotations

import os

import numpy as np
import pytest

from conftest import TRAVEL, machine
from volcal.io.atomic import atomic_dir, write_text
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.plan.planner import plan_session
from volcal.session import format as fmt
from volcal.session.errortable import read_error_table, write_error_table
from volcal.session.format import read_session, write_session


class Boom(RuntimeError):
    pass


def _session():
    s = plan_session(TRAVEL, "XYFZ", steps=3, runs=1, tests=("diagonal", "linear"))
    simulate_session(s, machine("XYFZ"), SimulationOptions(seed=2))
    return s


def _listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_write_text_failure_keeps_old_file(tmp_path, monkeypatch):
    p = tmp_path / "a.txt"
    write_text(p, "old content\n")

    def fail(fd):
        raise Boom("disk full")

    monkeypatch.setattr(os, "fsync", fail)
    with pytest.raises(Boom):
        write_text(p, "new content that never lands\n" * 1000)
    assert p.read_text() == "old content\n"
    assert _listing(tmp_path) == ["a.txt"]  # no temporary file left behind


def test_write_session_failure_mid_write_keeps_old_session(tmp_path, monkeypatch):
    s = _session()
    folder = tmp_path / "S"
    write_session(s, folder)
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    calls = {"n": 0}
    real = fmt.Measurement.to_csv

    def flaky(self):
        calls["n"] += 1
        if calls["n"] == 5:
            raise Boom("killed while writing the 5th file")
        return real(self)

    monkeypatch.setattr(fmt.Measurement, "to_csv", flaky)
    s.measurements[0].deviation = s.measurements[0].deviation + 1.0
    with pytest.raises(Boom):
        write_session(s, folder)
    after = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    assert after == before
    assert _listing(tmp_path) == ["S"] + [f"S/{x}" for x in _listing(folder)]
    read_session(folder)  # still a valid session


def test_write_session_failure_on_new_folder_leaves_nothing(tmp_path, monkeypatch):
    s = _session()
    monkeypatch.setattr(fmt.Measurement, "to_csv", lambda self: (_ for _ in ()).throw(Boom()))
    with pytest.raises(Boom):
        write_session(s, tmp_path / "new")
    assert list(tmp_path.iterdir()) == []


def test_atomic_dir_replaces_whole_folder(tmp_path):
    target = tmp_path / "d"
    with atomic_dir(target) as tmp:
        (tmp / "a").write_text("1")
    with atomic_dir(target) as tmp:
        (tmp / "b").write_text("2")
    assert _listing(target) == ["b"]


def test_error_table_roundtrip(tmp_path):
    m = machine("ZFXY", seed=3, n_nodes=11)
    m.reversal[:] = [1.0, 2.0, 3.0]
    p = write_error_table(m, tmp_path / "M.csv")
    back = read_error_table(p)
    assert str(back.chain) == "ZFXY"
    np.testing.assert_allclose(back.reversal, [1, 2, 3])
    for k in range(3):
        np.testing.assert_allclose(back.values[k], m.values[k], atol=1e-6)
    header = p.read_text().splitlines()[0]
    assert header == "axis,position_mm,EX_um,EY_um,EZ_um,EA_urad,EB_urad,EC_urad"


def test_rewrite_keeps_other_files_when_asked(tmp_path):
    s = _session()
    folder = tmp_path / "S"
    write_session(s, folder)
    (folder / "results").mkdir()
    (folder / "results" / "fit.bin").write_bytes(b"\x00\x01")
    (folder / "notes.txt").write_text("operator: A")
    s.measurements[0].deviation = s.measurements[0].deviation + 1.0
    write_session(s, folder, {"truth/setup.toml": "x = 1\n"}, keep_existing=True)
    assert (folder / "results" / "fit.bin").read_bytes() == b"\x00\x01"
    assert (folder / "notes.txt").read_text() == "operator: A"
    r = read_session(folder)
    np.testing.assert_allclose(r.measurements[0].deviation, s.measurements[0].deviation,
                               atol=1e-6)
    write_session(s, folder)  # default: the folder is exactly the session
    assert not (folder / "notes.txt").exists()
