"""The heads a writer has checked, kept on the writer's machine (``add``'s incremental check).

``volcal history add`` refuses a broken chain. Re-hashing every record before every add
grows with the store (about 5 s per 1000 calibrations); instead each writer keeps, outside
the store, the head (sequence number and hash) of the chain it last checked whole or
appended to: the next add checks the links of the whole chain (sequence numbers and
hashes: one query of three columns) and re-hashes only the records after that head, when
the record at that position still carries that hash. A store never checked from this
machine, or whose record at the kept position changed, is checked whole.

What this gives up: a record *before* the kept head whose content was altered without
touching its hash column is not seen by ``add`` (its links are intact); ``volcal history
verify`` re-hashes every record and file every time, and every reader checks the records it
shows against their hashes.

The file: ``$VOLCAL_HISTORY_HEADS``, else ``$XDG_CACHE_HOME/volcal/history-heads.json``
(``~/.cache/...``); JSON ``{store: [seq, hash]}`` of the 256 stores used last, written
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


def kept_head(store: str) -> tuple[int, str] | None:
    """The head this machine last checked of ``store`` (None: none kept).

    Parameters
    ----------
    store : str
        The store's key (:func:`store_key`).
    """
    v = _read().get(store)
    if (isinstance(v, list) and len(v) == 2 and isinstance(v[0], int)
            and not isinstance(v[0], bool) and v[0] > 0 and isinstance(v[1], str)):
        return v[0], v[1]
    return None


def keep_head(store: str, seq: int, digest: str) -> None:
    """Keep ``(seq, digest)`` as the checked head of ``store`` (best effort).

    Parameters
    ----------
    store : str
        The store's key.
    seq : int
        Sequence number of the head.
    digest : str
        Its hash.
    """
    from volcal.io.atomic import write_text

    doc = _read()
    doc.pop(store, None)
    doc[store] = [int(seq), str(digest)]
    while len(doc) > KEEP:
        doc.pop(next(iter(doc)))
    try:
        heads_file().parent.mkdir(parents=True, exist_ok=True)
        write_text(heads_file(), json.dumps(doc))
    except OSError:
        pass


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
