"""A damaged or foreign store: clear messages, never a traceback, never a write.

Three checks, from the cheapest:

* :func:`record_damage`: one record against its own hash (its row, its children's rows,
  its files' stored digests). Every read (:meth:`Store.records`) runs it, so that the
  readers (``show``, ``trend``, ``compare``, ``fleet``, ``export``) can warn about the
  records they use.
* :func:`check_chain` with ``contents=False``: the whole chain (order, links, hashes)
  and rows that point to no record, by the stored file digests. ``add`` runs it under
  the writers' lock and refuses a broken store (it grows linearly with the store; the
  files themselves are not read).
* :func:`check_chain` with ``contents=True`` (``volcal history verify``): the same and
  every stored file's content against its digest.

Database errors met on the way (a corrupted page, a foreign file, a column of the wrong
type) become a :class:`~volcal.errors.VolcalInputError` naming the store (:func:`guard`).
"""

from __future__ import annotations

import contextlib
import hashlib
import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from volcal.errors import VolcalInputError
from volcal.history.chain import GENESIS, hash_rows, record_hash

CHILDREN = ("files", "results", "equipment")


def db_error_message(exc: BaseException) -> str:
    """The first line of a database error, without SQLAlchemy's boilerplate.

    Parameters
    ----------
    exc : BaseException
        A SQLAlchemy or sqlite3 error.
    """
    orig = getattr(exc, "orig", None)
    text = str(orig if orig is not None else exc).strip() or type(exc).__name__
    return text.splitlines()[0][:200]


def database_errors() -> tuple[type[BaseException], ...]:
    """The exception types of a damaged or unreadable database.

    A ``UnicodeDecodeError`` too: volcal writes UTF-8, so text that does not decode (a
    table name in a damaged schema page) is damage.
    """
    from sqlalchemy.exc import SQLAlchemyError

    return (SQLAlchemyError, sqlite3.Error, UnicodeDecodeError)


def damaged_error(exc: BaseException, where: str) -> VolcalInputError:
    """The user's message for a database error met in the store ``where``.

    Parameters
    ----------
    exc : BaseException
        The database error.
    where : str
        The store (URL without password).
    """
    return VolcalInputError("the history database cannot be read or written "
                            f"({db_error_message(exc)}): damaged, or not a volcal history; "
                            "nothing was written", where)


@contextlib.contextmanager
def guard(where: str) -> Iterator[None]:
    """Turn a database error inside the block into :func:`damaged_error`.

    Parameters
    ----------
    where : str
        The store, named in the message.
    """
    try:
        yield
    except VolcalInputError:
        raise
    except database_errors() as exc:
        raise damaged_error(exc, where) from None


def record_damage(row: dict[str, Any], files: list[dict[str, Any]],
                  results: list[dict[str, Any]], equipment: list[dict[str, Any]]) -> str | None:
    """What is wrong with one record against its own hash (None: nothing).

    Parameters
    ----------
    row : dict
        The row of ``records``.
    files, results, equipment : list of dict
        Its children's rows (files: ``role, name, sha256``); files and results may be
        tuples ``(role, name, sha256)`` and ``(name, value, U, unit)``.
    """
    try:
        if files and isinstance(files[0], tuple) or results and isinstance(results[0], tuple):
            ok = hash_rows(row["prev_hash"], row, files, results, equipment) == row["hash"]
        else:
            ok = record_hash(row["prev_hash"], row, files, results, equipment) == row["hash"]
    except (TypeError, ValueError, KeyError, IndexError):
        return "its content cannot be read (a column holds a value of the wrong type)"
    if not ok:
        return "its content does not match its hash"
    return digest_column_damage(row)


def digest_column_damage(row: dict[str, Any]) -> str | None:
    """What is wrong with ``records.content_sha256`` (revision 0004, outside the hash).

    None when it agrees with the record's payload, or the store has no such column.

    Parameters
    ----------
    row : dict
        The row of ``records``.
    """
    import json

    from volcal.history.chain import content_key

    if "content_sha256" not in row:
        return None
    try:
        payload = json.loads(row["payload"])
    except (TypeError, ValueError):
        payload = None
    if row["content_sha256"] != content_key(row.get("kind"), row.get("supersedes"), payload):
        return ("its content digest column (records.content_sha256) does not match its "
                "payload (altered in the store)")
    return None


@dataclass
class ChainCheck:
    """The outcome of :func:`check_chain`.

    Attributes
    ----------
    ok : bool
        Nothing wrong.
    first : str or None
        The first broken record, e.g. ``C000003 (record 3)`` or ``record 7``.
    head : str
        Hash of the last good record (:data:`GENESIS` when none).
    n : int
        Records checked.
    why : str
        What is wrong with the first broken record.
    hashes : dict of str to int
        Hash -> sequence number of every record found intact, in order.
    duplicates : list of list of str
        Ids of calibrations that hold the same readings and model, one list per content
        (a store written before revision 0004 refused them; not a break of the chain).
    """

    ok: bool
    first: str | None
    head: str
    n: int
    why: str
    hashes: dict[str, int]
    duplicates: list[list[str]] = field(default_factory=list)

    def as_tuple(self) -> tuple[bool, str | None, str, int, str]:
        """``(ok, first, head, n, why)`` as :meth:`Store.verify` returns it."""
        return self.ok, self.first, self.head, self.n, self.why


def _orphans(conn, after: int = 0) -> list[tuple[Any, str, list[str]]]:
    """Rows of the children tables whose record does not exist: (seq, table, names).

    ``after``: only rows of a sequence number above it (or none, or of another type):
    the add's incremental check, where the links show the records up to it all exist.
    """
    from sqlalchemy import select

    from volcal.history import schema as t

    known = select(t.records.c.seq)
    out: dict[tuple[Any, str], list[str]] = {}
    for name in CHILDREN:
        tbl = getattr(t, name)
        key = tbl.c.position if name == "equipment" else tbl.c.name
        cond = tbl.c.record_seq.not_in(known) | tbl.c.record_seq.is_(None)
        if after:
            cond = cond & (tbl.c.record_seq.is_(None) | (tbl.c.record_seq > after))
        for seq, k in conn.execute(select(tbl.c.record_seq, key).where(cond)):
            out.setdefault((seq, name), []).append(str(k))
    return sorted(((s, n, ks) for (s, n), ks in out.items()),
                  key=lambda x: (-1 if not isinstance(x[0], int) else x[0], x[1]))


def _children(conn, seq: int | None = None, after: int = 0) -> tuple[dict, dict, dict]:
    """The children of records by sequence number.

    Files ``(role, name, sha256)`` and results ``(name, value, U, unit)`` as tuples,
    equipment rows as dicts: of record ``seq``, else of every record after ``after``.
    """
    from sqlalchemy import select

    from volcal.history import schema as t

    out: tuple[dict, dict, dict] = ({}, {}, {})
    f, r = t.files.c, t.results.c
    cols = {"files": [f.record_seq, f.role, f.name, f.sha256],
            "results": [r.record_seq, r.name, r.value, r.U, r.unit],
            "equipment": list(t.equipment.c)}
    for k, name in enumerate(CHILDREN):
        q = select(*cols[name])
        col = getattr(t, name).c.record_seq
        if seq is not None:
            q = q.where(col == seq)
        elif after:
            q = q.where(col > after)
        if name == "equipment":
            for e in conn.execute(q).mappings():
                out[k].setdefault(e["record_seq"], []).append(dict(e))
        else:
            for row in conn.execute(q).all():
                out[k].setdefault(row[0], []).append(tuple(row[1:]))
    return out


def altered_file(conn, seq: int) -> str | None:
    """The first stored file of record ``seq`` whose content does not match its digest.

    The content is read as bytes whatever was written into the column (``CAST AS BLOB``:
    text written into it by another program is hashed, not decoded).

    Parameters
    ----------
    conn : Connection
        Open connection.
    seq : int
        Record sequence number.
    """
    from sqlalchemy import LargeBinary, cast, select

    from volcal.history import schema as t

    q = select(t.files.c.name, t.files.c.sha256, cast(t.files.c.content, LargeBinary)).where(
        t.files.c.record_seq == seq).order_by(t.files.c.role, t.files.c.name)
    for name, digest, content in conn.execute(q):
        data = content.encode() if isinstance(content, str) else bytes(content or b"")
        if hashlib.sha256(data).hexdigest() != digest:
            return str(name)
    return None


def duplicates(conn) -> list[list[str]]:
    """Calibrations stored more than once with the same content (revision 0004's column).

    Parameters
    ----------
    conn : Connection
        Open connection.

    Returns
    -------
    list of list of str
        Record ids of each content held by several records, in chain order.
    """
    from sqlalchemy import func, select

    from volcal.history import schema as t

    c = t.records.c
    twice = select(c.content_sha256).where(c.content_sha256.is_not(None)).group_by(
        c.content_sha256).having(func.count() > 1)
    out: dict[str, list[str]] = {}
    for digest, rid in conn.execute(select(c.content_sha256, c.id).where(
            c.content_sha256.in_(twice)).order_by(c.seq)):
        out.setdefault(str(digest), []).append(str(rid))
    return sorted(out.values())


def _label(row: dict[str, Any]) -> str:
    return f"{row['id']} (record {row['seq']})"


def check_chain(conn, contents: bool = True, trusted: tuple[int, str] | None = None
                ) -> ChainCheck:
    """Walk the chain: order, links, hashes, files, rows that point to no record.

    Parameters
    ----------
    conn : Connection
        Open connection (inside the writer's transaction for ``add``).
    contents : bool
        Also hash every stored file's content (``verify``); ``False`` trusts the stored
        digests (``add``'s check before it appends).
    trusted : (int, str), optional
        A head checked before (``add``'s, :mod:`volcal.history.heads`): when the record at
        that position still carries that hash, the records up to it are checked by their
        links only (sequence numbers and hashes) and only those after it are re-hashed.
        Otherwise the whole chain is checked.

    Returns
    -------
    ChainCheck
        The first problem in chain order: a record deleted, reordered, altered (its row,
        its children, a file), or rows planted for a record that does not exist.
    """
    from sqlalchemy import select

    from volcal.history import schema as t

    c = t.records.c
    after = 0
    if trusted is not None and not contents:
        row = conn.execute(select(c.hash).where(c.seq == trusted[0])).first()
        after = trusted[0] if row is not None and row[0] == trusted[1] else 0
    light = [] if not after else [
        {"seq": s, "id": i, "prev_hash": p, "hash": h} for s, i, p, h in conn.execute(
            select(c.seq, c.id, c.prev_hash, c.hash).where(c.seq <= after)
            .order_by(c.seq)).all()]
    rows = light + [dict(r) for r in conn.execute(
        select(t.records).where(c.seq > after).order_by(c.seq)).mappings()]
    orphans = _orphans(conn, after)
    last = rows[-1]["seq"] if rows else 0
    bad = None
    if orphans:
        seq, tbl, keys = orphans[0]
        planted = isinstance(seq, int) and seq > last
        what = "planted for" if planted else "pointing to"
        bad = (seq if isinstance(seq, int) else 0,
               f"record {seq}",
               f"{tbl} rows ({', '.join(keys[:5])}) {what} record {seq}, which does not "
               f"exist{' (not written by volcal)' if planted else ''}")
    # every child row read in one pass (verify too: it reads at least what add reads, so
    # a damaged page that add's check meets is never missed by verify; found by the fuzz
    # test, a page of garbage that only the table scan reached)
    files, results, equipment = _children(conn, after=after)
    prev = GENESIS
    hashes: dict[str, int] = {}
    for i, r in enumerate(rows, start=1):
        if bad is not None and bad[0] <= i:
            break
        why = None
        if r["seq"] != i:
            why = f"record {i} is missing (deleted)"
        elif r["prev_hash"] != prev:
            why = "its link to the previous record is broken (reordered, or a record " \
                  "before it rewritten)"
        elif i <= after:  # before the trusted head: its link only
            why = None
        elif contents and (name := altered_file(conn, r["seq"])) is not None:
            why = f"file {name} was altered"
        else:
            why = record_damage(r, files.get(r["seq"], []), results.get(r["seq"], []),
                                equipment.get(r["seq"], []))
        if why is not None:
            return ChainCheck(False, _label(r), prev, i, why, hashes)
        prev = r["hash"]
        hashes[prev] = i
    if bad is not None:
        return ChainCheck(False, bad[1], prev, len(hashes), bad[2], hashes)
    return ChainCheck(True, None, prev, len(rows), "", hashes,
                      duplicates(conn) if contents else [])
