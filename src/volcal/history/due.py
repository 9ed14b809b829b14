"""When each machine and test is due: last calibration plus the machine's interval.

The interval is kept per machine (``interval_days`` of its record, 365 by default;
``volcal history interval MACHINE DAYS`` appends a record that changes it). A test
kind (linear, diagonal, step_diagonal, multilateration) is due ``interval`` days after
the last calibration that measured it.
"""

from __future__ import annotations

import datetime as _dt
import json
from typing import Any


def machine_interval(records: list[Any], machine_id: str) -> int:
    """The machine's interval [days]: its newest interval record, else its own record.

    Parameters
    ----------
    records : list of Record
        Every record of the store.
    machine_id : str
        Machine record id.
    """
    from volcal.history.machines import DEFAULT_INTERVAL_DAYS

    days = None
    for r in records:
        if r.kind == "machine" and r.id == machine_id:
            days = r.payload.get("interval_days", days)
        if r.kind == "interval" and r.machine_id == machine_id:
            days = r.payload.get("interval_days", days)
    return int(days or DEFAULT_INTERVAL_DAYS)


def _kinds(history: Any, rec: Any) -> list[str]:
    """The kinds of test a calibration measured (its payload's ``kinds``; a record stored
    before volcal kept them: from its stored ``session.toml``)."""
    kinds = rec.payload.get("kinds")
    if isinstance(kinds, list) and kinds and all(isinstance(k, str) for k in kinds):
        return sorted(set(kinds))
    try:
        doc = __import__("tomllib").loads(history.store.file(rec.id, "session",
                                                             "session.toml").decode())
        return sorted({m.get("kind", "?") for m in doc.get("measurements", [])
                       if m.get("id") in set(rec.payload.get("measurements", []))})
    except (ValueError, KeyError, json.JSONDecodeError):
        return ["calibration"]
    except Exception:  # noqa: BLE001 - a session file that no longer parses: whole calibration
        return ["calibration"]


def due(history: Any, today: _dt.date | None = None, machine: str | None = None
        ) -> list[dict[str, Any]]:
    """Rows ``machine, machine_id, test, last, next, interval_days, overdue_days``.

    Sorted by the next date, so the most overdue come first.

    Parameters
    ----------
    history : History
        The store.
    today : date, optional
        Reference date (default today).
    machine : str, optional
        Only this machine (record id or name): only its records are read.
    """
    from volcal.history.machines import current_machines

    today = today or _dt.date.today()
    store = history.store
    machines = current_machines(store.records("machine"))
    if machine is not None:
        mid = history.machine_id(machine, machines)
        machines = [m for m in machines if m.id == mid]
        others = store.records(machine_id=mid)
    else:
        others = store.records("interval") + store.records("calibration")
    mine: dict[str | None, list[Any]] = {}
    for r in others:
        mine.setdefault(r.machine_id, []).append(r)
    rows = []
    for mach in machines:
        own = sorted(mine.get(mach.id, []), key=lambda r: r.seq)
        interval = machine_interval([mach, *own], mach.id)
        last: dict[str, str] = {}
        for r in own:
            if r.kind == "calibration" and r.superseded_by is None:
                for k in _kinds(history, r):
                    if r.date and (k not in last or r.date > last[k]):
                        last[k] = r.date
        if not last:
            rows.append({"machine": mach.machine_name, "machine_id": mach.id, "test": "-",
                         "last": None, "next": today.isoformat(), "interval_days": interval,
                         "overdue_days": 0})
        for k, d in last.items():
            nxt = _dt.date.fromisoformat(d[:10]) + _dt.timedelta(days=interval)
            rows.append({"machine": mach.machine_name, "machine_id": mach.id, "test": k,
                         "last": d[:10], "next": nxt.isoformat(), "interval_days": interval,
                         "overdue_days": max(0, (today - nxt).days)})
    rows.sort(key=lambda r: (r["next"], r["machine"], r["test"]))
    return rows
