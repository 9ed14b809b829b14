"""The rotary axes' location errors in the history: stored, trended, compared with U.

Calibration A: a linear test of X and a probe_sphere test of a trunnion (``CAXYFZ``) on a
virtual machine with hidden location errors (pivots off by up to 2 mm, tilts up to
200 urad). Calibration B: the same machine probed again (A's centres with fresh 1 um
probe noise): nothing changed. Calibration C: a machine whose location errors differ.
``history add`` stores each determined location error with the U ``volcal locate`` states
(the same numbers, to the bit), ``history trend EX0C`` lists them, and ``history compare``
tests each against the combined U: A-B unchanged, A-C changed. SQLite (A, B, C) and
PostgreSQL (A, C).
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from volcal_cli_helpers import run_volcal

pytest.importorskip("sqlalchemy")
TRAVEL = [[0, 400], [0, 300], [0, 200]]
_CACHE: dict = {}


def _calibration(folder, seed, date):
    from volcal.flow import Calibration
    from volcal.measure.virtual import random_machine

    c = Calibration.plan(TRAVEL, steps=4, runs=3, tests=["linear:x", "probe_sphere"])
    # the layout this test was written with (the plan's default before it kept the poses
    # inside the travel, volcal.plan.fiveaxis; no program is written here)
    m = c.session.measurements[-1]
    m.meta["pivot_mm"] = {"c": [200.0, 150.0, 0.0], "a": [200.0, 150.0, -120.0]}
    m.meta["sphere_mm"] = [350.0, 150.0, 40.0]
    c.simulate(machine=random_machine(TRAVEL, "XYFZ", seed=7), seed=seed, noise_um=0.1)
    c.save(folder)
    toml = folder / "session.toml"
    toml.write_text(toml.read_text() + f"\n[calibration]\ndate = {date}\n")
    c.identify().to_json(folder / "model.json")
    return folder


def _reprobed(a, folder, date):
    """A's session probed again: its centres with fresh 1 um noise (identified again)."""
    shutil.copytree(a, folder)
    csv = folder / "probe_sphere.csv"
    lines = csv.read_text().splitlines()
    head = lines[0].split(",")
    ix = [head.index(c) for c in ("x_mm", "y_mm", "z_mm")]
    rng = np.random.default_rng(11)
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        for i in ix:
            cells[i] = f"{float(cells[i]) + rng.normal(0.0, 1e-3):.6f}"
        out.append(",".join(cells))
    csv.write_text("\n".join(out) + "\n")
    toml = folder / "session.toml"
    toml.write_text(toml.read_text().replace("date = 2026-01-10", f"date = {date}"))
    from volcal.flow import Calibration

    Calibration.open(folder).identify().to_json(folder / "model.json")  # of these readings
    return folder


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    if not _CACHE:
        tmp = tmp_path_factory.mktemp("loc")
        a = _calibration(tmp / "a", 1, "2026-01-10")
        _CACHE.update(a=a, b=_reprobed(a, tmp / "b", "2026-04-10"),
                      c=_calibration(tmp / "c", 2, "2026-09-10"))
    return _CACHE


def test_location_errors_stored_trended_compared(store_url, sessions, monkeypatch, capsys):
    from volcal.history.api import History
    from volcal.steps.locate import locate

    # on PostgreSQL the changed pair only (the same stored rows; each add costs seconds)
    keys = "ac" if store_url.startswith("postgresql") else "abc"
    with History(store_url) as h:
        recs = {k: h.add(sessions[k], sessions[k] / "model.json") for k in keys}
    # stored: what `volcal locate` states with the model's linear errors, value and U
    for k, rec in recs.items():
        loc = locate(sessions[k], model=sessions[k] / "model.json")
        for row in loc.to_json()["location_errors"]:
            name = row["name"]
            if row["status"] != "identified":
                assert name not in rec.results  # redundant: not a result
                continue
            got = rec.results[name]
            assert got["unit"] == row["unit"]
            assert got["value"] == pytest.approx(row["value"], rel=1e-12, abs=1e-9)
            assert got["U"] == pytest.approx(row["U"], rel=1e-12)
        assert rec.results["CAXYFZ.scatter_after"]["value"] < 10.0 < \
            rec.results["CAXYFZ.scatter_before"]["value"]
        assert "X.A" in rec.results  # the linear results as before
    # trend of EX0C: the three calibrations in date order with their U
    code, out, err = run_volcal(monkeypatch, capsys, "history", "trend", "VMC-1",
                                "--parameter", "EX0C", "--json", "--db", store_url)
    assert code == 0, err
    rows = json.loads(out)
    assert [r["id"] for r in rows] == [recs[k].id for k in keys]
    for r, k in zip(rows, keys, strict=True):
        assert r["value"] == recs[k].results["EX0C"]["value"] and r["unit"] == "um"
        assert 0.0 < r["U"] < 2.0
    # compare: each location error against the combined U of the two calibrations
    for other, changed in (("b", False), ("c", True)):
        if other not in recs:
            continue
        code, out, err = run_volcal(monkeypatch, capsys, "history", "compare", recs["a"].id,
                                    recs[other].id, "--json", "--db", store_url)
        assert code == 0, err
        entries = {e["name"]: e for e in json.loads(out)}
        for name in ("EX0C", "EY0C", "EA0C", "EB0C", "EY0A", "EZ0A", "EB0A", "EC0A"):
            e, ra, rb = entries[name], recs["a"].results[name], recs[other].results[name]
            assert e["difference"] == pytest.approx(rb["value"] - ra["value"])
            assert e["U"] == pytest.approx(np.hypot(ra["U"], rb["U"]))
            if not changed:
                assert e["changed"] is False, name
        if changed:  # other hidden location errors: pivots mm apart, far beyond U
            assert entries["EX0C"]["changed"] and entries["EY0C"]["changed"]


@pytest.mark.parametrize("kind", ["probe_sphere", "r_test"])
def test_a_probe_sphere_session_alone_is_stored_without_a_model(kind, tmp_path, monkeypatch,
                                                                  capsys):
    """No linear test, no model (``history add`` without ``--model``): the location errors
    are stored as ``volcal locate`` states them with perfect linear axes, for the probed
    sphere centres and for the R-test's displacements alike."""
    from volcal.steps.locate import locate

    folder = tmp_path / "S"
    for args in (["plan", "--travel", "0:800,0:600,0:500", "--chain", "XYFZ", "--tests",
                  kind, "-o", str(folder)], ["simulate", str(folder), "--seed", "3"]):
        code, _, err = run_volcal(monkeypatch, capsys, *args)
        assert code == 0, err
    toml = folder / "session.toml"
    toml.write_text(toml.read_text() + "\n[calibration]\ndate = 2026-03-01\n")
    db = str(tmp_path / "h.sqlite")
    code, out, err = run_volcal(monkeypatch, capsys, "history", "add", str(folder), "--db", db,
                                "--create")
    assert code == 0, err
    assert "stored: the rotary axes' location errors" in " ".join(err.split())
    code, out, err = run_volcal(monkeypatch, capsys, "history", "trend", "VMC-1",
                                "--parameter", "EA0C", "--json", "--db", db)
    assert code == 0, err
    (row,) = json.loads(out)
    want = next(r for r in locate(folder).to_json()["location_errors"] if r["name"] == "EA0C")
    assert row["value"] == pytest.approx(want["value"], rel=1e-12)
    assert row["U"] == pytest.approx(want["U"], rel=1e-12) and row["unit"] == "urad"
