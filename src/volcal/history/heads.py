"""The heads a writer has checked, kept on the writer's machine (``add``'s incremental check).

``volcal history add`` refuses a broken chain. Re-hashing every record before every add
grows with the store (about 5 s per 1000 calibrations); instead each writer keeps, outside
the store, the head (sequence number and hash) of the chain it last checked whole or
appended to: the next add checks the links of the whole chain (sequence numbers and
hashes: one query of three columns) and re-hashes only the records after that head, when
nobody wrote to the store since (:func:`store_state`: an SQLite file's size and time of
modification; PostgreSQL's row counts and newest writing transaction per table) and the
record at that position still carries that hash. A store never checked from this machine,
or written since by anyone else (another writer, another program), is checked whole: an
alteration anywhere is refused as before.

``volcal history verify`` re-hashes every record and file every time.

The file: ``$VOLCAL_HISTORY_HEADS``, else ``$XDG_CACHE_HOME/volcal/history-heads.json``
(``~/.cache/...``); JSON ``{store: [seq, hash, state]}`` of the 256 stores used last, written
atomically; a file that cannot be read or written is ignored (the whole chain is checked).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

KEEP = 256
"""Stores whose head is kept (the most recently used)."""


def heads_file() -> Path:
    """Path of the file of kept heads."""
    env = os.environ.get("VOLCAL_HISTORY_HEADS")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "volcal" / "history-heads.json"


def _read() -> dict[str, list]:
    try:
        doc = json.loads(heads_file().read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}


def kept_head(store: str, state: str | None = None) -> tuple[int, str] | None:
    """The head this machine last checked of ``store`` (None: none kept).

    Parameters
    ----------
    store : str
        The store's key (:func:`store_key`).
    state : str, optional
        The store's state now (:func:`store_state`): the head is given only when the
        store was not written since it was kept (else None: check the whole chain).
    """
    v = _read().get(store)
    if (isinstance(v, list) and len(v) == 3 and isinstance(v[0], int)
            and not isinstance(v[0], bool) and v[0] > 0 and isinstance(v[1], str)
            and v[2] == state):
        return v[0], v[1]
    return None


def keep_head(store: str, seq: int, digest: str, state: str | None) -> None:
    """Keep ``(seq, digest)`` as the checked head of ``store`` (best effort).

    Parameters
    ----------
    store : str
        The store's key.
    seq : int
        Sequence number of the head.
    digest : str
        Its hash.
    state : str or None
        The store's state after the check or the append (:func:`store_state`); None keeps
        nothing.
    """
    from volcal.io.atomic import write_text

    if state is None:
        return
    doc = _read()
    doc.pop(store, None)
    doc[store] = [int(seq), str(digest), state]
    while len(doc) > KEEP:
        doc.pop(next(iter(doc)))
    try:
        heads_file().parent.mkdir(parents=True, exist_ok=True)
        write_text(heads_file(), json.dumps(doc))
    except OSError:
        pass


def store_state(url: str, conn=None) -> str | None:
    """What changes whenever anyone writes to the store (None: unknown).

    SQLite: the file's size and modification time [ns]. PostgreSQL: per table the number
    of rows and the newest writing transaction (``max(xmin)``): an ``UPDATE``, ``INSERT``
    or ``DELETE`` by anyone changes it.

    Parameters
    ----------
    url : str
        The store's URL.
    conn : Connection, optional
        An open connection (PostgreSQL).
    """
    if url.startswith("sqlite") and ":///" in url:
        path = Path(url.split(":///", 1)[1])
        try:
            st = path.stat()
        except OSError:
            return None
        return f"sqlite {st.st_size} {st.st_mtime_ns}"
    if url.startswith("postgresql") and conn is not None:
        from sqlalchemy import text

        parts = []
        for tbl in ("records", "files", "results", "equipment"):
            n, x = conn.execute(text(f"SELECT count(*), max(xmin::text::bigint) FROM {tbl}")
                                ).one()
            parts.append(f"{tbl} {n} {x}")
        return "postgresql " + "; ".join(parts)
    return None


def store_key(url: str) -> str:
    """The key of a store: its SQLAlchemy URL, an SQLite file by its absolute path.

    Parameters
    ----------
    url : str
        The store's URL (:func:`volcal.history.url.resolve_url`).
    """
    if url.startswith("sqlite") and ":///" in url:
        path = url.split(":///", 1)[1]
        if path and path != ":memory:":
            return "sqlite:///" + str(Path(path).resolve())
    return url
