"""The hash chain of a history store: each record carries the hash of its predecessor.

The hash of a record is the sha256 of its predecessor's hash and the canonical JSON
(sorted keys, no spaces) of the record's fields and of its children (files by their
sha256, results, equipment). Changing, inserting or deleting a row anywhere breaks the
chain at that record; deleting the *latest* record shows only against a head hash kept
elsewhere, which ``volcal history verify`` prints for that purpose.
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any

GENESIS = "0" * 64
_RECORD_FIELDS = ("seq", "id", "kind", "machine_id", "date", "created", "supersedes",
                  "as_left_of", "report_id", "payload")


def _num(v: Any) -> Any:
    if isinstance(v, float):  # -0.0 is 0.0: SQLite reads a stored -0.0 back as 0.0
        return None if not math.isfinite(v) else float(f"{v:.12g}") + 0.0
    return v


def canonical(obj: Any) -> str:
    """Canonical JSON: sorted keys, no spaces, floats to 12 significant digits.

    Parameters
    ----------
    obj : Any
        JSON-ready object.
    """
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      default=str)


def content_key(kind: Any, supersedes: Any, payload: Any) -> str | None:
    """The ``records.content_sha256`` of a record (revision 0004).

    Its payload's content digest when it is a calibration that corrects nothing, else None.

    Parameters
    ----------
    kind : str
        The record's kind.
    supersedes : str or None
        The record it corrects.
    payload : dict
        Its payload.
    """
    if kind != "calibration" or supersedes is not None or not isinstance(payload, dict):
        return None
    d = payload.get("content_sha256")
    return d if isinstance(d, str) and d else None


def record_hash(prev_hash: str, record: dict[str, Any], files: list[dict[str, Any]],
                results: list[dict[str, Any]], equipment: list[dict[str, Any]]) -> str:
    """The hash of one record.

    Parameters
    ----------
    prev_hash : str
        Hash of the predecessor (:data:`GENESIS` for the first record).
    record : dict
        The row of ``records`` (the keys of ``_RECORD_FIELDS``).
    files, results, equipment : list of dict
        The record's children: ``role, name, sha256``; ``name, value, U, unit``; the
        equipment columns.

    Returns
    -------
    str
        64 hex digits.
    """
    return hash_rows(prev_hash, record,
                     [(f["role"], f["name"], f["sha256"]) for f in files],
                     [(r["name"], r["value"], r["U"], r["unit"]) for r in results], equipment)


def hash_rows(prev_hash: str, record: dict[str, Any], files: list[tuple[Any, ...]],
              results: list[tuple[Any, ...]], equipment: list[dict[str, Any]]) -> str:
    """:func:`record_hash` of children given as tuples (the readers' fast path).

    Parameters
    ----------
    prev_hash : str
        Hash of the predecessor.
    record : dict
        The row of ``records``.
    files : list of tuple
        ``(role, name, sha256)`` of each file.
    results : list of tuple
        ``(name, value, U, unit)`` of each result.
    equipment : list of dict
        The equipment rows.

    Returns
    -------
    str
        64 hex digits, the same as :func:`record_hash`.
    """
    body = {
        "record": {k: record.get(k) for k in _RECORD_FIELDS},
        "files": sorted([f[0], f[1], f[2]] for f in files),
        "results": sorted([r[0], _num(r[1]), _num(r[2]), r[3]] for r in results),
        "equipment": sorted(([int(e["position"])] + [e.get(k) for k in
                             ("role", "make", "model", "serial", "certificate",
                              "calibrated", "due")]) for e in equipment),
    }
    return hashlib.sha256((prev_hash + "\n" + canonical(body)).encode()).hexdigest()
