"""The history store: append-only records in one hash chain, SQLite or PostgreSQL.

Nothing is updated or deleted: a correction is a new record that supersedes an older
one. Every insert takes the writers' lock (:func:`volcal.history.engine.lock`), reads
the head of the chain, and appends in one transaction: an interrupted or failed ``add``
leaves nothing behind.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import json
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from volcal.errors import VolcalInputError
from volcal.history.chain import GENESIS, canonical, content_key, record_hash

KIND_PREFIX = {"machine": "M", "calibration": "C", "interval": "I"}


@dataclass
class Record:
    """One record of the history, as read back.

    Attributes
    ----------
    seq : int
        Position in the chain (1-based).
    id : str
        Record id (``M000001`` machine, ``C000002`` calibration, ``I...`` interval).
    kind : str
        ``machine``, ``calibration`` or ``interval``.
    machine_id : str or None
        The machine record a calibration or interval belongs to.
    date : str or None
        Date of measurement (ISO 8601) of a calibration.
    created : str
        UTC time the record was appended.
    supersedes : str or None
        Id of the record this one corrects.
    as_left_of : str or None
        The as-found calibration this as-left one pairs with.
    payload : dict
        The record's content (identity, calibration keys, evaluation, model summary).
    prev_hash, hash : str
        The chain.
    report_id : str or None
        The certificate's report id, where one was stored.
    results : dict of str to dict
        ``name -> {value, U, unit}``.
    files : list of dict
        ``role, name, sha256`` (content through :meth:`Store.file`).
    equipment : list of dict
        The calibration's equipment.
    superseded_by : str or None
        Set by :meth:`Store.records`: the newest record that supersedes this one.
    already_stored : bool
        Set by :meth:`Store.append`: the calibration was stored before (same readings and
        model, ``content_sha256``) and this is that record; nothing was appended.
    signature, key_id : str or None
        Ed25519 signature of the hash (hex) and the id of the key that made it
        (:mod:`volcal.history.signing`); None for an unsigned record.
    """

    seq: int
    id: str
    kind: str
    machine_id: str | None
    date: str | None
    created: str
    supersedes: str | None
    as_left_of: str | None
    payload: dict[str, Any]
    prev_hash: str
    hash: str
    report_id: str | None = None
    results: dict[str, dict[str, Any]] = field(default_factory=dict)
    files: list[dict[str, Any]] = field(default_factory=list)
    equipment: list[dict[str, Any]] = field(default_factory=list)
    superseded_by: str | None = None
    already_stored: bool = False
    signature: str | None = None
    key_id: str | None = None
    damage: str | None = None
    """Set when the record does not match its own hash (:mod:`volcal.history.integrity`)."""

    @property
    def machine_name(self) -> str:
        """Name of the machine (from the payload's identity)."""
        ident = self.payload.get("machine") or {}
        return str(ident.get("name", ""))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (``list --json`` and ``show --json``)."""
        return {"id": self.id, "kind": self.kind, "machine": self.machine_name,
                "machine_id": self.machine_id, "date": self.date, "created": self.created,
                "supersedes": self.supersedes, "superseded_by": self.superseded_by,
                "as_left_of": self.as_left_of, "report_id": self.report_id,
                "hash": self.hash, "signature": self.signature, "key_id": self.key_id,
                "payload": self.payload,
                "results": self.results, "files": self.files, "equipment": self.equipment}


@dataclass
class NewRecord:
    """What :meth:`Store.append` writes: a record and its children."""

    kind: str
    payload: dict[str, Any]
    machine_id: str | None = None
    date: str | None = None
    supersedes: str | None = None
    as_left_of: str | None = None
    report_id: str | None = None
    files: list[tuple[str, str, bytes]] = field(default_factory=list)  # role, name, content
    results: list[tuple[str, float | None, float | None, str]] = field(default_factory=list)
    equipment: list[dict[str, Any]] = field(default_factory=list)


def _text(v: Any) -> Any:
    """A value read back as volcal wrote it: bytes (another program's) as text."""
    if isinstance(v, bytes | bytearray | memoryview):
        return bytes(v).decode("utf-8", "replace")
    return v


def _chunks(seqs: list[Any], size: int = 20_000) -> list[list[Any]]:
    """``seqs`` in pieces small enough for one ``IN (...)`` of SQLite and PostgreSQL."""
    return [seqs[k:k + size] for k in range(0, len(seqs), size)]


def _number(v: Any) -> Any:
    """A result's value or U as stored (None for a value of another type than a number)."""
    return v if isinstance(v, int | float) and not isinstance(v, bool) else None


class Store:
    """A calibration history in a SQL database.

    Parameters
    ----------
    url : str, optional
        ``--db`` value (URL or SQLite file); default :func:`volcal.history.url.resolve_url`.
    create : bool
        Make a new store when there is none (an SQLite file and its folder, the schema of
        an empty database); ``False`` refuses a path or database without a history.
    private_key : str or Path, optional
        Private key file that signs every appended record's hash
        (:mod:`volcal.history.signing`); default the file named by ``VOLCAL_HISTORY_KEY``,
        read at the first append. Without a key, appending to a store whose last record is
        signed is refused.
    """

    def __init__(self, url: str | None = None, create: bool = True,
                 private_key=None) -> None:
        from volcal.history.engine import open_engine
        from volcal.history.heads import store_key
        from volcal.history.integrity import guard
        from volcal.history.url import describe, resolve_url

        self._private_key = private_key
        self._signer: Any = False  # not resolved yet
        if private_key is not None:  # a wrong key file: refused before the store is opened
            _ = self.signer
        self.url = resolve_url(url)
        self.where = describe(self.url)
        #: this store's entry in the kept heads (:mod:`volcal.history.heads`)
        self.key = store_key(describe(self.url) if not self.url.startswith("sqlite")
                             else self.url)
        self._head: tuple[int, str] | None = None  # the last appended, under the lock
        #: record id -> what is wrong with it, of every damaged record read so far
        self.damaged: dict[str, str] = {}
        self._reader: Any = None  # the connection of :meth:`reading`, inside its block
        with guard(self.where):
            self.engine = open_engine(self.url, create=create)
        #: True when opening made a new, empty store
        self.created = bool(getattr(self.engine, "volcal_created", False))

    @property
    def signer(self) -> Any:
        """The :class:`~volcal.history.signing.Signer` of appended records, or None."""
        if self._signer is False:
            from volcal.history.signing import signer_from

            self._signer = signer_from(self._private_key)
        return self._signer

    def close(self) -> None:
        """Release the database connections."""
        self.engine.dispose()

    # ---------------------------------------------------------------- writing
    def append(self, rec: NewRecord, check=None) -> Record:
        """Append one record to the chain, atomically and serialised with other writers.

        With a signer (:attr:`signer`) every record appended is signed; without one, a
        store whose last record is signed is refused.

        Parameters
        ----------
        rec : NewRecord
            The record.
        check : callable, optional
            ``check(conn)`` run under the lock before the insert (e.g. machine matching);
            may return a :class:`NewRecord` to append first (a new machine), whose id
            becomes ``rec.machine_id``, or a machine id (str) to set.

        Returns
        -------
        Record
            As stored; a calibration whose readings and model are stored already (same
            ``content_sha256``, not a correction) is not appended again: the stored
            record is returned with ``already_stored`` set.
        """
        from volcal.history.engine import lock, writer
        from volcal.history.integrity import guard

        _ = self.signer  # the key file read before the lock is taken
        self._head = None
        with guard(self.where), writer(self.engine) as conn, conn.begin():
            lock(conn)
            self._refuse_broken(conn)
            same = self._stored_before(conn, rec)
            if same is None:
                rid = self._append_locked(conn, rec, check)
        self._keep_head()
        if same is not None:
            found = self._same_content(same, rec.payload["content_sha256"])
            if rec.as_left_of is not None and rec.as_left_of != found.as_left_of:
                raise VolcalInputError(
                    f"this session and model are stored already as {found.id}, "
                    f"{'as-left of ' + found.as_left_of if found.as_left_of else 'not as-left'}"
                    f": --supersedes {found.id} --as-left-of {rec.as_left_of} corrects it")
            found.already_stored = True
            return found
        return self.record(rid)

    def append_many(self, recs: list[NewRecord]) -> list[str]:
        """Append records in one transaction: one lock, one check of the chain.

        A bulk import (the benchmarks build stores of 10^4 calibrations with it): each
        record is appended as :meth:`append` appends it, without a ``check``, so a
        calibration names its machine record (``machine_id``) itself; a calibration whose
        content is stored already is not appended again (its id is returned). Nothing is
        appended when any record is refused.

        Parameters
        ----------
        recs : list of NewRecord
            The records, in order.

        Returns
        -------
        list of str
            The id of each record (the stored one for a content stored already).
        """
        from volcal.history.engine import lock, writer
        from volcal.history.integrity import guard

        _ = self.signer
        self._head = None
        ids: list[str] = []
        with guard(self.where), writer(self.engine) as conn, conn.begin():
            lock(conn)
            self._refuse_broken(conn)
            for rec in recs:
                same = self._stored_before(conn, rec)
                ids.append(same if same is not None else self._append_locked(conn, rec, None))
        self._keep_head()
        return ids

    def _keep_head(self) -> None:
        """Keep the head this writer checked and appended to (after the commit)."""
        from volcal.history.heads import keep_head, store_state

        if self._head is not None:
            with self.engine.connect() as conn:
                keep_head(self.key, *self._head, store_state(self.url, conn))
            self._head = None

    def _append_locked(self, conn, rec: NewRecord, check) -> str:
        """The insert of :meth:`append`, under the writers' lock; returns the new id."""
        from sqlalchemy import select

        from volcal.history import schema as t

        self._refuse_unsigned(conn)
        extra = check(conn) if check is not None else None
        if isinstance(extra, NewRecord):
            rec.machine_id = self._insert(conn, extra)
        elif isinstance(extra, str):
            rec.machine_id = extra
        for ref in (rec.supersedes, rec.as_left_of, rec.machine_id):
            if ref is not None and conn.execute(
                    select(t.records.c.seq).where(t.records.c.id == ref)).first() is None:
                raise self.no_record(ref, conn)
        return self._insert(conn, rec)

    def _same_content(self, rid: str, digest: str) -> Record:
        """The newest of ``rid`` and its corrections that holds the same content.

        ``rid`` itself (``superseded_by`` set) when it was corrected by other content.
        """
        links = self._corrections()
        chain, seen = [rid], {rid}
        while chain[-1] in links and links[chain[-1]] not in seen:  # rid's corrections
            chain.append(links[chain[-1]])
            seen.add(chain[-1])
        for r in reversed(chain[1:]):  # the newest correction of the same content
            rec = self.record(r)
            if rec.payload.get("content_sha256") == digest:
                return rec
        return self.record(rid)

    @staticmethod
    def _stored_before(conn, rec: NewRecord) -> str | None:
        """Id of the newest calibration stored with the same content (under the lock).

        A correction (``supersedes``) is always appended. The content digest is the
        indexed column ``records.content_sha256`` (revision 0004, unique where the store
        never held duplicates).
        """
        from sqlalchemy import select

        from volcal.history import schema as t

        digest = content_key(rec.kind, rec.supersedes, rec.payload)
        if digest is None:
            return None
        row = conn.execute(select(t.records.c.id).where(t.records.c.content_sha256 == digest)
                           .order_by(t.records.c.seq.desc()).limit(1)).first()
        return None if row is None else str(row.id)

    def _refuse_unsigned(self, conn) -> None:
        """Without a signer, refuse to append after a signed record (under the lock)."""
        from sqlalchemy import select

        from volcal.history import schema as t
        from volcal.history.signing import KEY_ENV

        if self.signer is not None:
            return
        head = conn.execute(select(t.records.c.id, t.records.c.key_id, t.records.c.signature)
                            .order_by(t.records.c.seq.desc()).limit(1)).first()
        if head is not None and head.signature:
            raise VolcalInputError(f"the records of the history {self.where} are signed "
                                   f"(the last, {head.id}, by key {head.key_id}): give "
                                   f"--private-key FILE or set {KEY_ENV} to sign this one")

    def _refuse_broken(self, conn) -> None:
        """Refuse to append to a broken chain (under the lock; stored digests trusted).

        Incremental when nobody wrote to the store since this machine last checked or
        appended: the records after that head are re-hashed, the links of all
        (:mod:`volcal.history.heads`); otherwise the whole chain.
        """
        from volcal.history.heads import kept_head, store_state
        from volcal.history.integrity import check_chain

        trusted = kept_head(self.key, store_state(self.url, conn))
        chk = check_chain(conn, contents=False, trusted=trusted)
        if not chk.ok:
            raise VolcalInputError(f"the history is broken at {chk.first}: {chk.why}; "
                                   "nothing was added (volcal history verify tells the rest)",
                                   self.where)

    def _insert(self, conn, rec: NewRecord) -> str:
        """Insert one record and its children at the head of the chain (under the lock)."""
        from sqlalchemy import insert, select

        from volcal.history import schema as t

        head = conn.execute(select(t.records.c.seq, t.records.c.hash)
                            .order_by(t.records.c.seq.desc()).limit(1)).first()
        seq = 1 if head is None else int(head.seq) + 1
        prev = GENESIS if head is None else head.hash
        rid = f"{KIND_PREFIX[rec.kind]}{seq:06d}"
        row = {"seq": seq, "id": rid, "kind": rec.kind,
               "machine_id": rec.machine_id, "date": rec.date,
               "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
               "supersedes": rec.supersedes, "as_left_of": rec.as_left_of,
               "report_id": rec.report_id, "payload": canonical(rec.payload),
               "prev_hash": prev, "content_sha256": content_key(rec.kind, rec.supersedes,
                                                                 rec.payload)}
        files = [{"record_seq": seq, "role": r, "name": n,
                  "sha256": hashlib.sha256(c).hexdigest(), "content": c}
                 for r, n, c in rec.files]
        results = [{"record_seq": seq, "name": n, "value": v, "U": u, "unit": unit}
                   for n, v, u, unit in rec.results]
        equipment = [{"record_seq": seq, "position": i,
                      **{k: e.get(k) for k in ("role", "make", "model", "serial",
                                                "certificate", "calibrated", "due")}}
                     for i, e in enumerate(rec.equipment)]
        row["hash"] = record_hash(prev, row, files, results, equipment)
        self._head = (seq, str(row["hash"]))
        if self.signer is not None:  # outside the hash it signs
            row["signature"], row["key_id"] = self.signer.sign(row["hash"]), self.signer.key_id
        conn.execute(insert(t.records).values(**row))
        if files:
            conn.execute(insert(t.files), files)
        if results:
            conn.execute(insert(t.results), results)
        if equipment:
            conn.execute(insert(t.equipment), equipment)
        return rid

    # ---------------------------------------------------------------- reading
    @contextlib.contextmanager
    def reading(self) -> Iterator[None]:
        """Every read inside the block on one connection (one snapshot of the store).

        The engine keeps no pool (:func:`volcal.history.engine.open_engine`), so each read
        outside such a block opens a connection: 30 ms each on a PostgreSQL server, and a
        ``trend EXX@100`` reads 10 records and 20 stored files. Nested blocks share the
        outer one.
        """
        from volcal.history.integrity import guard

        if self._reader is not None:
            yield
            return
        with guard(self.where), self.engine.connect() as conn:
            self._reader = conn
            try:
                yield
            finally:
                self._reader = None

    def no_record(self, rid: str, conn=None) -> VolcalInputError:
        """The error for a record id the history does not hold, with the id meant if clear.

        Ids are a kind's letter and six digits (``C000002``); a number alone (``2``,
        ``000002``) or a lower-case id names the record of that number, which the message
        proposes.

        Parameters
        ----------
        rid : str
            The id as given.
        conn : Connection, optional
            The connection of the transaction asking (the writers' lock), else a reader.

        Returns
        -------
        VolcalInputError
        """
        from volcal.history import schema as t

        letters = "".join(KIND_PREFIX.values())
        digits = rid.strip().lstrip(letters + letters.lower())
        hint = ""
        if digits.isdigit() and int(digits) > 0:
            near = self._rows(t.records.c.seq == int(digits), conn)
            if near:
                hint = f"; did you mean {near[0].id} ({near[0].kind})?"
        if not hint:
            hint = ("; ids are a letter and six digits, e.g. C000002 (volcal history list "
                    "--all shows them)")
        return VolcalInputError(f"no record {rid!r} in the history {self.where}{hint}")

    def _rows(self, where=None, conn=None) -> list[Record]:
        from volcal.history.integrity import guard

        conn = self._reader if conn is None else conn
        with guard(self.where):
            if conn is None:
                with self.engine.connect() as c:
                    return self._read(where, c)
            return self._read(where, conn)

    def _read(self, where, conn, results: bool = True) -> list[Record]:
        """The records ``where`` selects, with their children, each checked against its hash.

        ``results=False`` reads the results only for the check (``Record.results`` left
        empty: ``list`` shows none; a third less work per record).
        """
        from sqlalchemy import select

        from volcal.history import schema as t

        q = select(t.records).order_by(t.records.c.seq)
        if where is not None:
            q = q.where(where)
        rows = conn.execute(q).mappings().all()
        seqs = [r["seq"] for r in rows]
        res: dict[int, dict] = {s: {} for s in seqs}
        fil: dict[int, list] = {s: [] for s in seqs}
        eqp: dict[int, list] = {s: [] for s in seqs}
        raw: dict[int, tuple[list, list, list]] = {s: ([], [], []) for s in seqs}
        # the children as tuples (the rows of thousands of records: no mappings)
        for chunk in _chunks(seqs):
            c = t.results.c
            for seq, name, value, u, unit in conn.execute(select(
                    c.record_seq, c.name, c.value, c.U, c.unit).where(
                    c.record_seq.in_(chunk))).all():
                if results:
                    res[seq][name if type(name) is str else _text(name)] = {
                        "value": _number(value), "U": _number(u),
                        "unit": unit if type(unit) is str else _text(unit)}
                raw[seq][1].append((name, value, u, unit))
            f = t.files.c
            for seq, role, name, sha in conn.execute(select(
                    f.record_seq, f.role, f.name, f.sha256).where(f.record_seq.in_(chunk))).all():
                fil[seq].append({"role": _text(role), "name": _text(name),
                                 "sha256": _text(sha)})
                raw[seq][0].append((role, name, sha))
            for r in conn.execute(select(t.equipment).where(
                    t.equipment.c.record_seq.in_(chunk)).order_by(
                    t.equipment.c.position)).mappings():
                eqp[r["record_seq"]].append({k: _text(v) for k, v in r.items()
                                             if k not in ("record_seq", "position")
                                             and v is not None})
                raw[r["record_seq"]][2].append(dict(r))
        return [self._record(dict(r), res[r["seq"]], fil[r["seq"]], eqp[r["seq"]],
                             raw[r["seq"]]) for r in rows]

    def _record(self, r: dict, res: dict, fil: list, eqp: list, raw: tuple) -> Record:
        """A :class:`Record` from its rows, checked against its own hash."""
        from volcal.history.integrity import record_damage

        try:
            payload = json.loads(r["payload"])
        except (ValueError, TypeError):  # not JSON, not text
            payload = {"unreadable": True}
        if not isinstance(payload, dict):
            payload = {"unreadable": True}
        c = {k: _text(v) for k, v in r.items()}  # a damaged store: bytes where text was
        rec = Record(r["seq"], str(c["id"]), str(c["kind"]), c["machine_id"], c["date"],
                     c["created"], c["supersedes"], c["as_left_of"], payload, c["prev_hash"],
                     c["hash"], c["report_id"], res, fil, eqp, signature=c.get("signature"),
                     key_id=c.get("key_id"))
        rec.damage = record_damage(r, *raw)
        if rec.damage is not None:
            self.damaged[rec.id] = rec.damage
        return rec

    def records(self, kind: str | None = None, conn=None,
                machine_id: str | None = None) -> list[Record]:
        """Records in chain order, ``superseded_by`` set.

        Only the records asked for are read and checked against their hashes (indexes on
        ``kind`` and ``machine_id``: the records of one machine are read without reading
        the store).

        Parameters
        ----------
        kind : str, optional
            Only records of this kind.
        conn : Connection, optional
            Read inside this transaction (a writer's, under its lock).
        machine_id : str, optional
            Only the records that belong to this machine record (calibrations, intervals).
        """
        from sqlalchemy import and_

        from volcal.history import schema as t

        conds = []
        if machine_id is not None:  # by its own index alone (the kind: below), so that
            # the database never scans every calibration through the index of kinds
            conds.append(t.records.c.machine_id == machine_id)
        elif kind is not None:
            conds.append(t.records.c.kind == kind)
        allr = self._rows(and_(*conds) if conds else None, conn)
        if machine_id is not None and kind is not None:
            allr = [r for r in allr if r.kind == kind]
        self._mark_superseded(allr, conn)
        return allr

    def iter_records(self, kind: str | None = None, by_date: bool = False,
                     results: bool = True, chunk: int = 500) -> Iterator[Record]:
        """Every record (of ``kind``), streamed: read and checked ``chunk`` records at a time.

        The memory held is that of one chunk whatever the size of the store (``list``
        of 10^4 calibrations: 1.2 GB read at once before), and the first records are out
        before the last are read. Each record is checked against its own hash as
        :meth:`records` checks it; ``superseded_by`` is set.

        Parameters
        ----------
        kind : str, optional
            Only records of this kind.
        by_date : bool
            By date of measurement, then in the order stored
            (:func:`volcal.history.api.by_date`); default the chain's order.
        results : bool
            Fill ``Record.results`` (``False``: read only for the check).
        chunk : int
            Records read per query.
        """
        from sqlalchemy import select

        from volcal.history import schema as t
        from volcal.history.integrity import guard

        c = t.records.c
        q = select(c.seq, c.date).order_by(c.seq)
        if kind is not None:
            q = q.where(c.kind == kind)
        with guard(self.where), self.engine.connect() as conn:
            keys = [(int(seq), str(_text(day) or "")) for seq, day in conn.execute(q).all()]
            if by_date:
                keys.sort(key=lambda k: (k[1], k[0]))
            links = self._corrections(conn)
            for k in range(0, len(keys), chunk):
                part = [seq for seq, _ in keys[k:k + chunk]]
                got = {r.seq: r for r in self._read(c.seq.in_(part), conn, results)}
                recs = [got[seq] for seq in part if seq in got]
                self._mark_superseded(recs, links=links)
                yield from recs

    def machines_named(self, machine: str, conn=None) -> list[Record]:
        """The machine records whose id or name is ``machine`` (``superseded_by`` set).

        The name is found in the canonical payload (``"name":"VMC-1"``) by the database,
        so that naming one machine does not read every machine record.

        Parameters
        ----------
        machine : str
            Machine record id or name.
        conn : Connection, optional
            Read inside this transaction.
        """
        from sqlalchemy import and_, or_

        from volcal.history import schema as t

        c = t.records.c
        key = canonical({"name": machine})[1:-1]
        recs = self._rows(and_(c.kind == "machine", or_(
            c.id == machine, c.payload.contains(key, autoescape=True))), conn)
        self._mark_superseded(recs, conn)
        return [r for r in recs if r.id == machine or r.machine_name == machine]

    def _corrections(self, conn=None) -> dict[str, str]:
        """Record id -> id of the newest record that supersedes it, directly.

        One query of two columns over the indexed ``supersedes``; the chain order decides.
        """
        from sqlalchemy import select

        from volcal.history import schema as t
        from volcal.history.integrity import guard

        q = select(t.records.c.id, t.records.c.supersedes).where(
            t.records.c.supersedes.is_not(None)).order_by(t.records.c.seq)
        conn = self._reader if conn is None else conn
        with guard(self.where):
            if conn is None:
                with self.engine.connect() as c:
                    rows = c.execute(q).all()
            else:
                rows = conn.execute(q).all()
        return {str(_text(old)): str(_text(new)) for new, old in rows}

    def _mark_superseded(self, recs: list[Record], conn=None,
                         links: dict[str, str] | None = None) -> None:
        """Set ``superseded_by``: the newest record of the chain of corrections.

        ``links``: :meth:`_corrections`, when already read.
        """
        links = self._corrections(conn) if links is None else links
        for r in recs:
            nxt, seen = links.get(r.id), {r.id}
            while nxt is not None and nxt in links and links[nxt] not in seen:
                seen.add(nxt)
                nxt = links[nxt]
            r.superseded_by = nxt

    def record(self, rid: str) -> Record:
        """One record by id (as stored, superseded or not; ``superseded_by`` set).

        Parameters
        ----------
        rid : str
            Record id.

        Raises
        ------
        VolcalInputError
            No such record.
        """
        from volcal.history import schema as t

        rows = self._rows(t.records.c.id == rid)
        if not rows:
            raise self.no_record(rid)
        self._mark_superseded(rows)
        return rows[0]

    def current(self, rid: str) -> Record:
        """The newest record superseding ``rid`` (``rid`` itself when none does).

        Parameters
        ----------
        rid : str
            Record id.
        """
        r = self.record(rid)
        return self.record(r.superseded_by) if r.superseded_by else r

    def file(self, rid: str, role: str, name: str | None = None,
             record: Record | None = None) -> bytes:
        """The stored content of a record's file (the first of ``role`` if no name).

        Parameters
        ----------
        rid : str
            Record id.
        role : str
            File role (``session``, ``model``, ``model-part``, ``etalon``).
        name : str, optional
            File name.
        record : Record, optional
            The record ``rid``, when already read.
        """
        from sqlalchemy import LargeBinary, cast, select

        from volcal.history import schema as t
        from volcal.history.integrity import guard

        rec = record if record is not None and record.id == rid else self.record(rid)
        q = select(cast(t.files.c.content, LargeBinary), t.files.c.name,
                   t.files.c.sha256).where(t.files.c.record_seq == rec.seq,
                                           t.files.c.role == role)
        if name is not None:
            q = q.where(t.files.c.name == name)
        with guard(self.where):
            if self._reader is not None:
                row = self._reader.execute(q.order_by(t.files.c.name)).first()
            else:
                with self.engine.connect() as conn:
                    row = conn.execute(q.order_by(t.files.c.name)).first()
        if row is None:
            raise VolcalInputError(f"record {rid} has no {role} file")
        data = row[0].encode() if isinstance(row[0], str) else bytes(row[0] or b"")
        if hashlib.sha256(data).hexdigest() != row[2]:
            self.damaged[rec.id] = (f"stored file {row[1]} does not match its sha256 "
                                    "(altered in the store)")
            raise VolcalInputError(f"stored file {row[1]} of record {rec.id} does not match "
                                   "its sha256 (altered in the store): not used (volcal "
                                   "history verify)", self.where)
        return data

    # ---------------------------------------------------------------- verify
    def verify(self, contents: bool = True) -> tuple[bool, str | None, str, int, str]:
        """Recompute the chain (:func:`volcal.history.integrity.check_chain`).

        Parameters
        ----------
        contents : bool
            Also hash every stored file's content.

        Returns
        -------
        ok : bool
            Every record's hash and link and every file's digest agree, and no row
            points to a record that does not exist.
        first_broken : str or None
            The first record that does not (``C000003 (record 3)``, ``record 7``).
        head : str
            Hash of the last good record (:data:`GENESIS` when empty).
        n : int
            Records checked.
        why : str
            What is wrong with the first broken record.
        """
        return self.check(contents).as_tuple()

    def check(self, contents: bool = True):
        """The full outcome of the chain check (:class:`~volcal.history.integrity.ChainCheck`).

        Parameters
        ----------
        contents : bool
            Also hash every stored file's content.
        """
        from volcal.history.heads import keep_head, store_state
        from volcal.history.integrity import check_chain, guard

        with guard(self.where), self.engine.connect() as conn:
            chk = check_chain(conn, contents)
            if chk.ok and contents and chk.n:  # every record checked: the head kept
                keep_head(self.key, chk.n, chk.head, store_state(self.url, conn))
        return chk
