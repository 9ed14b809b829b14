"""The history under load (issue 26, deliver 7): ``list`` streamed a chunk at a time,
the commands of one machine on one connection, the change test never "unchanged" where
the design cannot tell.

The figures at 10 ... 10,000 calibrations are benchmarks/bench_history.py's
(benchmarks/README.md, "History under load"); these tests check the mechanisms on a small
store, on SQLite and PostgreSQL.
"""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from history_fixtures import history_two  # noqa: F401  (a fixture)

from volcal_cli_helpers import volcal_process

DATES = ("2026-01-10", "2025-03-02", "2026-05-20", "2024-11-30")
"""Dates of measurement of the copies, in the order stored (back-filled older ones)."""


def _fill(url: str, source: str, rid: str) -> list[str]:
    """A machine and four calibrations copied from record ``rid`` of ``source``, each
    with its own date and content digest; returns their ids in the order stored."""
    from volcal.history.api import History
    from volcal.history.store import NewRecord

    with History(source, create=False) as src:
        rec = src.store.record(rid)
        mach = src.store.record(rec.machine_id)
        files = [(f["role"], f["name"], src.store.file(rid, f["role"], f["name"], rec))
                 for f in rec.files]
    results = [(n, v["value"], v["U"], v["unit"]) for n, v in rec.results.items()]
    with History(url, create=True) as h:
        mid = h.store.append_many([NewRecord("machine", mach.payload)])[0]
        cals = []
        for k, day in enumerate(DATES):
            payload = copy.deepcopy(rec.payload)
            payload["calibration"] = dict(payload.get("calibration") or {}, date=day)
            payload["content_sha256"] = f"{k:064d}"
            cals.append(NewRecord("calibration", payload, machine_id=mid, date=day,
                                  files=files, results=results, equipment=rec.equipment))
        return h.store.append_many(cals)


@pytest.fixture
def four(store_url, history_two):  # noqa: F811
    return store_url, _fill(store_url, history_two["db"], history_two["id"])


def test_list_streamed_by_date(four):
    """``list`` reads a chunk of records at a time (memory bounded at 10^4) and gives
    what the whole read gave: by date of measurement, each record checked."""
    from volcal.history.api import History, by_date

    url, ids = four
    with History(url, create=False) as h:
        whole = by_date(h.calibrations(current=False))
        assert [r.id for r in whole] == [ids[3], ids[1], ids[0], ids[2]]
        one = list(h.store.iter_records("calibration", by_date=True, chunk=1))
        assert [r.id for r in one] == [r.id for r in whole]
        assert [r.hash for r in one] == [r.hash for r in whole]
        assert all(r.damage is None for r in one)
        assert one[0].results == whole[0].results and len(one[0].results) > 100
        slim = list(h.stream())          # what the CLI shows: no results kept
        assert [r.id for r in slim] == [r.id for r in whole]
        assert all(r.results == {} and r.damage is None for r in slim)
        every = [r.id for r in h.stream(all_records=True)]
        assert every == [r.id for r in h.list()] and len(every) == 5
    r = volcal_process("history", "list", "--json", "--db", url)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert [d["id"] for d in doc] == [ids[3], ids[1], ids[0], ids[2]]
    # streamed item by item, the text is json.dumps(whole list, indent=1)'s
    assert r.stdout == json.dumps(doc, indent=1) + "\n"


def test_list_json_of_empty_store(tmp_path):
    from volcal.history.store import Store

    db = tmp_path / "h.sqlite"

    Store(str(db), create=True).close()
    r = volcal_process("history", "list", "--json", "--db", db)
    assert (r.returncode, r.stdout) == (0, "[]\n"), r.stderr


def test_one_machine_commands_on_one_connection(four):
    """``trend EXX@100`` read 4 records and 8 stored files on 13 connections (30 ms each
    on a PostgreSQL server: 1-2 s of a trend at 10^4 calibrations); one now."""
    from sqlalchemy import event

    from volcal.history.api import History
    from volcal.history.compare import compare
    from volcal.history.fleet import fleet_html
    from volcal.history.trend import trend

    url, ids = four
    with History(url, create=False) as h:
        machine = h.store.record(ids[0]).machine_name
        opened = []
        event.listen(h.store.engine, "connect", lambda *a: opened.append(1))
        rows = trend(h, machine, "EXX@100")
        assert len(opened) == 1 and len(rows) == 4
        assert [r["id"] for r in rows] == [ids[3], ids[1], ids[0], ids[2]]
        assert len({r["value"] for r in rows}) == 1 and rows[0]["U"] > 0  # one model
        opened.clear()
        entries = compare(h.store, ids[0], ids[2])
        assert len(opened) == 1
        assert not any(e.changed for e in entries)   # the same model and results
        opened.clear()
        assert machine in fleet_html(h, machine=machine)
        assert len(opened) == 1


def test_split_statistic_by_hand():
    """The difference in the combinations the data do not determine is measured too:
    large there, the verdict is undecided (the design cannot tell), never unchanged."""
    from volcal.history.compare import _split_statistic

    C = np.diag([4.0, 1.0])           # posterior variances
    Cn = np.diag([4.0, 0.1])          # the readings' part: 100 % and 10 %
    r, stat, r_rest, rest = _split_statistic(np.array([3.0, 40.0]), C, Cn)
    assert (r, r_rest) == (1, 1)
    assert stat == pytest.approx(9.0 / 4.0) and rest == pytest.approx(1600.0)
    assert _split_statistic(np.array([3.0, 4.0]), C, None) == pytest.approx(
        (2, 9.0 / 4.0 + 16.0, 0, 0.0))
