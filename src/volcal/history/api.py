"""``volcal.History``: the calibration history from Python.

>>> h = History("sqlite:///plant.sqlite")          # doctest: +SKIP
>>> cid = h.add("S1", "S1/model.json")              # doctest: +SKIP
>>> h.compare(cid0, cid).query("changed == True")   # doctest: +SKIP
"""

from __future__ import annotations

import builtins
from collections.abc import Iterator
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
    create : bool
        Make a new store when there is none (``False``: refuse a path or database without
        a history, as every ``volcal history`` command but ``add --create`` does).
    private_key : str or Path, optional
        Private key file: every record appended is signed (``docs/history.md``, "Signed
        records"); default the file named by ``VOLCAL_HISTORY_KEY``, else unsigned.
    """

    def __init__(self, db: str | None = None, create: bool = True,
                 private_key: str | Path | None = None) -> None:
        self.store = Store(db, create=create, private_key=private_key)

    def close(self) -> None:
        """Release the connections."""
        self.store.close()

    def __enter__(self) -> History:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        from volcal.history.integrity import damaged_error, database_errors

        self.close()
        # a database error met anywhere inside the block (a damaged page read by a
        # reader of its own, e.g. the export): the user's message, naming the store
        if exc is not None and isinstance(exc, database_errors()):
            raise damaged_error(exc, self.store.where) from None

    # ----------------------------------------------------------------- add
    def add(self, session: str | Path, model: str | Path | None = None,
            as_left_of: str | None = None,
            supersedes: str | None = None, machine: str | None = None,
            force: bool = False, certificate: str | Path | None = None,
            budget: str | Path | None = None) -> Record:
        """Store a calibration: its session, model, results and equipment.

        Parameters
        ----------
        session : str or Path
            Session folder with readings.
        model : str or Path, optional
            The model file identified from it. None: no linear model (rotary tests only,
            or only those of interest): the session's evaluation is stored without the
            model's results, with a note in the record.
        as_left_of : str, optional
            Id of the as-found calibration (this one measured after loading tables).
        supersedes : str, optional
            Id of a calibration this one corrects.
        machine : str, optional
            Machine record id or name when the identity is ambiguous.
        force : bool
            Accept a model of other readings.
        certificate : str or Path, optional
            The folder ``volcal report --certificate`` wrote for this calibration (or its
            ``certificate.json``): the certificate's number is stored (``report_id``);
            without it, ``[calibration] report_id`` of the session where given.
        budget : str or Path, optional
            Uncertainty budget (TOML, ``volcal budget``): the session is evaluated with it
            and the U of every ISO 230-2 parameter, diagonal and direct-optics result is
            stored with its value. Without it those have no U (NaN in the DataFrames);
            the volumetric indices and squareness errors have the model's U either way.

        Returns
        -------
        Record
            The calibration record (its ``id``). When the same readings and model are
            stored already (a retried add), that record, with ``already_stored`` set.

        Raises
        ------
        VolcalInputError
            ``as_left_of`` is not a calibration of the same machine measured on or before
            this session's date.
        """
        from volcal.history.record import calibration_record

        rec, session_obj = calibration_record(session, model, as_left_of, supersedes, force,
                                              certificate, budget)
        return self.store.append(rec, check=self._machine_of(session_obj.identity, machine,
                                                             rec))

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
        results: builtins.list[tuple[str, float | None, float | None, str]] = [
            (n, v, None, "urad") for n, v in sorted(data.squareness.items())]
        rec = NewRecord("calibration", payload, date=when, results=results,
                        files=[("etalon", path.name, path.read_bytes())])
        return self.store.append(rec, check=self._machine_of(ident, machine))

    def _machine_of(self, ident: Any, machine: str | None, rec: NewRecord | None = None
                    ) -> Any:
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
        rec : NewRecord, optional
            The calibration: its ``as_left_of`` is checked against the machine and date.
        """
        from volcal.history.machines import machine_payload, match

        store = self.store

        def check(conn: Any) -> Any:
            found = match(store.records("machine", conn=conn), ident, machine)
            if rec is not None and rec.as_left_of is not None:
                _check_as_left(store, conn, rec, found, ident)
            return found.id if found is not None else NewRecord("machine",
                                                                machine_payload(ident))

        return check

    # ----------------------------------------------------------------- read
    def list(self) -> list[Record]:
        """Every record in order (``superseded_by`` set)."""
        return self.store.records()

    def stream(self, all_records: bool = False, results: bool = False
               ) -> Iterator[Record]:
        """What ``volcal history list`` shows, read a chunk at a time (memory bounded).

        Parameters
        ----------
        all_records : bool
            Every record in the order stored; default the calibrations by date of
            measurement (:func:`by_date`).
        results : bool
            Fill ``Record.results`` (``list`` shows none).
        """
        if all_records:
            return self.store.iter_records(results=results)
        return self.store.iter_records("calibration", by_date=True, results=results)

    # `list` below is the method above, hence builtins.list
    def calibrations(self, machine: str | None = None,
                     current: bool = True) -> builtins.list[Record]:
        """Calibration records, oldest first: by date of measurement (then as stored).

        Parameters
        ----------
        machine : str, optional
            Machine record id or name.
        current : bool
            Leave out superseded records.
        """
        mid = None if machine is None else self.machine_id(machine)
        recs = self.store.records("calibration", machine_id=mid)  # one machine's: indexed
        return by_date([r for r in recs if not current or r.superseded_by is None])

    def machine_id(self, machine: str, records: builtins.list[Record] | None = None) -> str:
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

        ms = current_machines(records if records is not None
                              else self.store.machines_named(machine))
        hit = [r for r in ms if r.id == machine] or [r for r in ms if r.machine_name == machine]
        if len(hit) != 1 and records is None:  # the message lists every machine
            ms = current_machines(self.store.records("machine"))
            hit = [r for r in ms if r.id == machine] or [r for r in ms
                                                         if r.machine_name == machine]
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

    def verify_signatures(self, public_keys: builtins.list[str | Path]) -> Any:
        """Check every record's signature against public key files.

        Parameters
        ----------
        public_keys : list of str or Path
            PEM files of the accepted public keys (``volcal history key new``).

        Returns
        -------
        SignatureCheck
            See :func:`volcal.history.signing.check_signatures`.
        """
        from volcal.history.signing import load_public_key, verify_store

        return verify_store(self.store, [load_public_key(p) for p in public_keys])

    # ------------------------------------------------------------- analysis
    def compare(self, id1: str, id2: str, level: float = 0.05) -> Any:
        """The change test between two calibrations, as a DataFrame.

        See :func:`volcal.history.compare.compare` for the columns; ``attrs["notes"]``
        says what the two are to each other (:func:`volcal.history.compare.pair_notes`:
        an as-found/as-left pair, or given latest first).

        Parameters
        ----------
        id1, id2 : str
            Earlier and later calibration record.
        level : float
            Family-wise false-alarm level of the function tests.
        """
        import pandas as pd

        from volcal.history.compare import compare, pair_notes

        df = pd.DataFrame([e.to_dict() for e in compare(self.store, id1, id2, level)],
                          columns=["name", "difference", "U", "changed", "unit", "test",
                                   "statistic", "threshold", "dof", "position_mm", "reason",
                                   "verdict"])
        for col in ("difference", "U", "statistic", "threshold", "dof", "position_mm"):
            df[col] = pd.to_numeric(df[col], errors="coerce").astype(float)
        df["changed"] = df["changed"].astype("boolean")
        df.attrs["notes"] = pair_notes(self.store, id1, id2)  # an as-found/as-left pair
        return df

    def trend(self, machine: str, parameter: str) -> Any:
        """One parameter over the calibrations of a machine, as a DataFrame.

        Columns ``id, date`` (datetime64), ``value, U`` (float, NaN where none), ``unit``.

        Parameters
        ----------
        machine : str
            Machine record id or name.
        parameter : str
            Result name or a function at a position (:mod:`volcal.history.trend`).
        """
        import pandas as pd

        from volcal.history.trend import trend

        return _typed(pd.DataFrame(trend(self, machine, parameter),
                                   columns=["id", "date", "value", "U", "unit"]))

    def results(self) -> Any:
        """Every stored result: DataFrame ``machine, date, id, parameter, value, U, unit``.

        ``date`` is datetime64, ``value`` and ``U`` float (NaN where none).
        """
        import pandas as pd

        rows = []
        for r in self.calibrations():
            for name, v in r.results.items():
                rows.append({"machine": r.machine_name, "date": r.date, "id": r.id,
                             "parameter": name, **v})
        return _typed(pd.DataFrame(rows, columns=["machine", "date", "id", "parameter",
                                                  "value", "U", "unit"]))


def _typed(df: Any) -> Any:
    """``date`` as datetime64, ``value`` and ``U`` as float (NaN where none)."""
    import pandas as pd

    df["date"] = pd.to_datetime(df["date"].map(lambda d: None if d is None else str(d)[:10]),
                                format="%Y-%m-%d", errors="coerce")
    for col in ("value", "U"):
        df[col] = pd.to_numeric(df[col], errors="coerce").astype(float)
    return df


def by_date(records: list[Record]) -> list[Record]:
    """Records by date of measurement, oldest first (then in the order stored).

    "Last" and "previous" mean the newest measurement, never the newest insertion: a
    back-filled older calibration does not become the last one.

    Parameters
    ----------
    records : list of Record
        Calibration records.
    """
    return sorted(records, key=lambda r: (str(r.date or ""), r.seq))


def _check_as_left(store: Store, conn: Any, rec: NewRecord, machine: Record | None,
                   ident: Any) -> None:
    """Refuse an as-left-of that is no calibration of this machine measured before.

    Run under the writers' lock; the as-found record must be a calibration of the same
    machine measured on or before ``rec.date``.
    """
    from volcal.errors import VolcalInputError
    from volcal.history import schema as t

    rid = rec.as_left_of
    found = store._rows(t.records.c.id == rid, conn)  # noqa: SLF001 - the store's reader
    if not found:
        raise store.no_record(str(rid), conn)
    ref = found[0]
    if ref.kind != "calibration":
        raise VolcalInputError(f"--as-left-of {rid}: {rid} is a {ref.kind} record, not a "
                               "calibration")
    name = ident.name if machine is None else f"{machine.machine_name} ({machine.id})"
    if machine is None or ref.machine_id != machine.id:
        raise VolcalInputError(
            f"--as-left-of {rid}: {rid} is a calibration of {ref.machine_name} "
            f"({ref.machine_id}) measured {ref.date}; this session is of {name}"
            f"{'' if machine is not None else ' (not in the history yet)'}, measured "
            f"{rec.date}: an as-left calibration pairs with an as-found one of the same "
            "machine")
    if str(ref.date or "")[:10] > str(rec.date or "")[:10]:
        raise VolcalInputError(
            f"--as-left-of {rid}: {rid} of {name} was measured {ref.date}, after this "
            f"session ({rec.date}): the as-found calibration is measured before (or on the "
            "same date as) its as-left one")

