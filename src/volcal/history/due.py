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
    try:
        return int(days or DEFAULT_INTERVAL_DAYS)
    except (TypeError, ValueError):  # a damaged record (its reader warns of it)
        return DEFAULT_INTERVAL_DAYS


def measured_on(date: Any) -> _dt.date | None:
    """The date of measurement of a record, or ``None`` where it is not a date.

    Parameters
    ----------
    date : str or None
        The record's ``date`` (ISO 8601, a time may follow). A damaged record's column may
        hold anything; such a record is left out of the due dates, and the command that
        read it names it (``volcal.history.store.Store.damaged``).
    """
    try:
        return _dt.date.fromisoformat(str(date)[:10]) if date else None
    except ValueError:
        return None


def _kinds(history: Any, rec: Any) -> list[str]:
    """The kinds of test a calibration measured.

    Its payload's ``kinds``; a record stored before volcal kept them: from its stored
    ``session.toml``.
    """
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
    machines, others = machine_records(history, machine)
    return due_rows(history, today, machines, others)


def machine_records(history: Any, machine: str | None = None) -> tuple[list[Any], list[Any]]:
    """The current machine records and the other records of them (calibrations, intervals).

    Parameters
    ----------
    history : History
        The store.
    machine : str, optional
        Only this machine (record id or name): only its records are read (indexed).
    """
    from volcal.history.machines import current_machines

    store = history.store
    if machine is not None:
        mid = history.machine_id(machine)
        return [store.record(mid)], store.records(machine_id=mid)
    machines = current_machines(store.records("machine"))
    return machines, store.records("interval") + store.records("calibration")


def due_rows(history: Any, today: _dt.date | None, machines: list[Any], others: list[Any]
             ) -> list[dict[str, Any]]:
    """:func:`due` of records already read (:func:`machine_records`).

    Parameters
    ----------
    history : History
        The store (a stored session file is read for a record older than ``kinds``).
    today : date or None
        Reference date (default today).
    machines, others : list of Record
        :func:`machine_records`.
    """
    today = today or _dt.date.today()
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
                if measured_on(r.date) is None:
                    continue
                for k in _kinds(history, r):
                    if k not in last or r.date > last[k]:
                        last[k] = r.date
        if not last:
            rows.append({"machine": mach.machine_name, "machine_id": mach.id, "test": "-",
                         "last": None, "next": today.isoformat(), "interval_days": interval,
                         "overdue_days": 0})
        for k, d in last.items():
            nxt = _dt.date.fromisoformat(d[:10]) + _dt.timedelta(days=interval)  # checked
            rows.append({"machine": mach.machine_name, "machine_id": mach.id, "test": k,
                         "last": d[:10], "next": nxt.isoformat(), "interval_days": interval,
                         "overdue_days": max(0, (today - nxt).days)})
    rows.sort(key=lambda r: (r["next"], r["machine"], r["test"]))
    return rows
