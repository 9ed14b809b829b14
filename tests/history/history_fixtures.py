"""Calibrations shared by the QIF and report tests of the history (a uniquely named
module, imported by the test modules; tests/conftest.py is imported by name elsewhere)."""

from __future__ import annotations

from pathlib import Path

import pytest

TRAVEL = [[0, 800], [0, 600], [0, 500]]

_SHARED: dict = {}


def _calibrate(folder: Path, machine, seed: int, date: str) -> Path:
    from volcal.flow import Calibration

    c = Calibration.plan(TRAVEL, steps=10)
    c.simulate(machine=machine, seed=seed)
    c.save(folder)
    toml = folder / "session.toml"
    toml.write_text(toml.read_text().replace(
        "[machine]\n", '[machine]\nmake = "Hermle"\nserial = "42-1187"\n', 1)
        + f"\n[calibration]\ndate = {date}\n")
    c.identify().to_json(folder / "model.json")
    return folder


def _make(tmp: Path) -> dict:
    from volcal.history.api import History
    from volcal.measure.virtual import random_machine

    base = random_machine(TRAVEL, "XYFZ", seed=7)
    scaled = base.copy()
    scaled.values[0][:, 0] += 0.010 * scaled.nodes[0]          # X scale +10 um/m
    a = _calibrate(tmp / "a", base, 1, "2026-01-10")
    b = _calibrate(tmp / "b", scaled, 3, "2026-08-10")
    db = str(tmp / "h.sqlite")
    with History(db) as h:
        rid = h.add(a, a / "model.json").id
    return {"db": db, "id": rid, "a": a, "b": b, "tmp": tmp}


@pytest.fixture(scope="session")
def history_two(tmp_path_factory) -> dict:
    """Calibration A stored (SQLite; record ``id``), B of the same machine not stored.

    B is measured 7 months later on a machine whose X scale grew by 10 um/m (EXX +8 um
    at x = 800 mm); both sessions carry serial 42-1187 and a ``[calibration] date``.
    """
    if "two" not in _SHARED:
        _SHARED["two"] = _make(tmp_path_factory.mktemp("hist2"))
    return _SHARED["two"]
