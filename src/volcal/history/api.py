"""``volcal.History``: the calibration history from Python.

>>> h = History("sqlite:///plant.sqlite")          # doctest: +SKIP
>>> cid = h.add("S1", "S1/model.json")              # doctest: +SKIP
>>> h.compare(cid0, cid).query("changed == True")   # doctest: +SKIP
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from volcal.history.store import NewRecord, Record, Store


class History:
    """A calibration history (SQLite file or PostgreSQL server).

    Parameters
    ----------
    db : str, optional
        URL or SQLite file; default ``VOLCAL_DB``, else the documented default path
        (:func:`volcal.history.url.default_path`).
    """

    def __init__(self, db: str | None = None) -> None:
        self.store = Store(db)

    def close(self) -> None:
        """Release the connections."""
        self.store.close()

    def __enter__(self) -> History:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ----------------------------------------------------------------- add
    def add(self, session: str | Path, model: str | Path, as_left_of: str | None = None,
            supersedes: str | None = None, machine: str | None = None,
            force: bool = False) -> Record:
        """Store a calibration: its session, model, results and equipment.

        Parameters
        ----------
        session : str or Path
            Session folder with readings.
        model : str or Path
            The model file identified from it.
        as_left_of : str, optional
            Id of the as-found calibration (this one measured after loading tables).
        supersedes : str, optional
            Id of a calibration this one corrects.
        machine : str, optional
            Machine record id or name when the identity is ambiguous.
        force : bool
            Accept a model of other readings.

        Returns
        -------
        Record
            The calibration record (its ``id``).
        """
        from volcal.history.record import calibration_record

        rec, session_obj = calibration_record(session, model, as_left_of, supersedes, force)
        return self.store.append(rec, check=self._machine_of(session_obj.identity, machine))

    def add_etalon(self, path: str | Path, session: str | Path, date: str | None = None,
                   machine: str | None = None) -> Record:
        """Store another system's result: an Etalon exchange file (no covariance).

        Parameters
        ----------
        path : str or Path
            The exchange file (:mod:`volcal.history.etalon`).
        session : str or Path
            A session folder naming the machine (``[machine]``; readings not needed) and,
            unless ``date`` is given, the date of measurement (``[calibration] date``).
        date : str, optional
            Date of measurement (ISO 8601).
        machine : str, optional
            Machine record id or name when ambiguous.

        Returns
        -------
        Record
            A calibration record whose functions have no uncertainty: ``compare`` leaves
            them undecided (``changed`` null).
        """
        from volcal.errors import VolcalInputError
        from volcal.history.etalon import read_etalon
        from volcal.session.format import read_session
        from volcal.session.identity import parse_date

        path = Path(path)
        data = read_etalon(path)
        s = read_session(session, require_deviation=False)
        when = date or s.calibration.get("date")
        if when is None:
            raise VolcalInputError("no date of measurement: give --date or [calibration] date "
                                   "in the session", Path(session) / "session.toml", None,
                                   "calibration.date")
        when = parse_date(when)
        ident = s.identity
        payload = {"machine": ident.to_dict(), "calibration": dict(s.calibration, date=when),
                   "source": "etalon exchange file", "file": path.name,
                   "not_mapped": sorted(data.other), "k": 2.0}
        results = [(n, v, None, "urad") for n, v in sorted(data.squareness.items())]
        rec = NewRecord("calibration", payload, date=when, results=results,
                        files=[("etalon", path.name, path.read_bytes())])
        return self.store.append(rec, check=self._machine_of(ident, machine))

    def _machine_of(self, ident: Any, machine: str | None) -> Any:
        """The check :meth:`Store.append` runs under the writers' lock.

        It returns the id of the machine record the identity matches, or a new machine
        record to append first (two writers of a new machine never make two records). Only
        machine records are read.

        Parameters
        ----------
        ident : MachineIdentity
            The session's machine.
        machine : str, optional
            Machine record id or name chosen by the user.
        """
        from volcal.history.machines import machine_payload, match

        store = self.store

        def check(conn: Any) -> Any:
            found = match(store.records("machine", conn=conn), ident, machine)
            return found.id if found is not None else NewRecord("machine",
                                                                machine_payload(ident))

        return check

    # ----------------------------------------------------------------- read
    def list(self) -> list[Record]:
        """Every record in order (``superseded_by`` set)."""
        return self.store.records()

    def calibrations(self, machine: str | None = None, current: bool = True) -> list[Record]:
        """Calibration records, oldest first.

        Parameters
        ----------
        machine : str, optional
            Machine record id or name.
        current : bool
            Leave out superseded records.
        """
        recs = self.store.records()
        mid = None if machine is None else self.machine_id(machine, recs)
        return [r for r in recs if r.kind == "calibration"
                and (mid is None or r.machine_id == mid)
                and (not current or r.superseded_by is None)]

    def machine_id(self, machine: str, records: list[Record] | None = None) -> str:
        """Machine record id of a machine given by id or name.

        Parameters
        ----------
        machine : str
            Machine record id or name.
        records : list of Record, optional
            The store's records, when already read.

        Raises
        ------
        VolcalInputError
            No machine, or several of that name.
        """
        from volcal.errors import VolcalInputError
        from volcal.history.machines import current_machines

        ms = current_machines(records if records is not None else self.store.records())
        hit = [r for r in ms if r.id == machine] or [r for r in ms if r.machine_name == machine]
        if len(hit) != 1:
            names = ", ".join(f"{r.id} {r.machine_name}" for r in ms) or "none"
            what = "several machines are" if hit else "no machine is"
            raise VolcalInputError(f"{what} called {machine!r} in the history "
                                   f"(machines: {names})")
        return hit[0].id

    def show(self, rid: str) -> Record:
        """The newest version of a record (a correction replaces what it supersedes).

        Parameters
        ----------
        rid : str
            Record id.
        """
        return self.store.current(rid)

    def verify(self) -> tuple[bool, str | None, str, int, str]:
        """Check the chain (see :meth:`Store.verify`)."""
        return self.store.verify()

    # ------------------------------------------------------------- analysis
    def compare(self, id1: str, id2: str, level: float = 0.05) -> Any:
        """The change test between two calibrations, as a DataFrame.

        See :func:`volcal.history.compare.compare` for the columns.

        Parameters
        ----------
        id1, id2 : str
            Earlier and later calibration record.
        level : float
            Family-wise false-alarm level of the function tests.
        """
        import pandas as pd

        from volcal.history.compare import compare

        return pd.DataFrame([e.to_dict() for e in compare(self.store, id1, id2, level)])

    def trend(self, machine: str, parameter: str) -> Any:
        """One parameter over the calibrations of a machine, as a DataFrame.

        Columns ``id, date, value, U, unit``.

        Parameters
        ----------
        machine : str
            Machine record id or name.
        parameter : str
            Result name or a function at a position (:mod:`volcal.history.trend`).
        """
        import pandas as pd

        from volcal.history.trend import trend

        return pd.DataFrame(trend(self, machine, parameter))

    def results(self) -> Any:
        """Every stored result: DataFrame ``machine, date, id, parameter, value, U, unit``."""
        import pandas as pd

        rows = []
        for r in self.calibrations():
            for name, v in r.results.items():
                rows.append({"machine": r.machine_name, "date": r.date, "id": r.id,
                             "parameter": name, **v})
        return pd.DataFrame(rows, columns=["machine", "date", "id", "parameter", "value",
                                           "U", "unit"])
