"""The capture journal: an append-only record of every sample and decision, beside the session.

One file per measurement, ``SESSION/capture/<id>.jsonl``, JSON lines, each an object with a
``type``:

==============  ===================================================================
``type``        fields
==============  ===================================================================
``start``       ``measurement``, ``control``, ``laser``, ``params`` (the trigger
                rule's), ``program`` (dwell, feed, overrun), ``readings`` (planned
                count), ``utc`` (wall time of the start); one per capture run
``control``     a control sample (``t`` [s], ``pos`` {axis: mm or deg}, ``moving``,
                ``running``, ``status``, ``line``)
``laser``       a laser sample (``t`` [s], ``v``, ``unit``, ``status``)
``accepted``    ``reading`` (0-based data row), ``t``, ``value`` [um or urad],
                ``unit``, ``sigma``, ``n``, ``pos`` [mm], ``window`` [s]
``missed``      ``reading``, ``t``, ``reason``
``replayed``    ``reading``, ``t``: a dwell of a reading already recorded, not used
``note``        ``t``, ``text``
``end``         ``t``, ``reason`` (``complete``, ``stopped``, ``disconnected: ...``)
==============  ===================================================================

Times ``t`` are seconds of the run's clock (each ``start`` begins a new clock). Lines are
appended and flushed at once; the file is synced to disk (``fsync``) before an accepted
or missed point reaches the session's CSV and at least every ``sync_s`` seconds, so a
point in the CSV is always in the journal. A line cut short by a kill is dropped when the
journal is opened again. Nothing is ever rewritten: a resumed capture appends.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError
from volcal.io.folders import JOURNAL_FOLDER  # one definition (volcal.io)

__all__ = ["JOURNAL_FOLDER", "Journal", "Recorded", "journal_path", "read_journal"]


def journal_path(session_folder: str | Path, measurement_id: str) -> Path:
    """``SESSION/capture/<id>.jsonl``.

    Parameters
    ----------
    session_folder : str or Path
        The session folder.
    measurement_id : str
        The measurement's id.

    Returns
    -------
    Path
    """
    return Path(session_folder) / JOURNAL_FOLDER / f"{measurement_id}.jsonl"


@dataclass
class Recorded:
    """What a journal says was decided, per reading (0-based data row).

    Attributes
    ----------
    accepted : dict of int to dict
        The ``accepted`` records (the first for a reading; a later one is never used).
    missed : dict of int to dict
        The ``missed`` records.
    runs : int
        Number of ``start`` records (capture runs).
    starts : list of dict
        The ``start`` records.
    """

    accepted: dict[int, dict[str, Any]] = field(default_factory=dict)
    missed: dict[int, dict[str, Any]] = field(default_factory=dict)
    runs: int = 0
    starts: list[dict[str, Any]] = field(default_factory=list)

    @property
    def done(self) -> set[int]:
        """Readings decided (accepted or missed)."""
        return set(self.accepted) | set(self.missed)


def _lines(path: Path) -> Iterator[tuple[int, int, dict[str, Any] | None]]:
    """(byte offset after the line, line number, object or None when cut short)."""
    data = path.read_bytes()
    pos, no = 0, 0
    while pos < len(data):
        end = data.find(b"\n", pos)
        no += 1
        if end < 0:  # the last line has no end: cut short by a kill
            yield len(data), no, None
            return
        raw = data[pos:end]
        pos = end + 1
        try:
            obj = json.loads(raw)
        except (json.JSONDecodeError, UnicodeDecodeError):
            yield pos, no, None
            continue
        yield pos, no, obj if isinstance(obj, dict) else None


def read_journal(path: str | Path) -> Recorded:
    """Read what a journal recorded (a missing journal records nothing).

    Parameters
    ----------
    path : str or Path
        The journal.

    Returns
    -------
    Recorded

    Raises
    ------
    VolcalInputError
        A damaged line other than the last (naming the file and line).
    """
    path = Path(path)
    rec = Recorded()
    if not path.is_file():
        return rec
    items = list(_lines(path))
    for k, (_, no, obj) in enumerate(items):
        if obj is None:
            if k == len(items) - 1:
                break  # the last line, cut short: dropped on the next append
            raise VolcalInputError("damaged journal line (not a JSON object): the journal "
                                   "is append-only, do not edit it", path, no)
        typ = obj.get("type")
        if typ == "start":
            rec.runs += 1
            rec.starts.append(obj)
        elif typ in ("accepted", "missed"):
            r = obj.get("reading")
            if not isinstance(r, int) or r < 0:
                raise VolcalInputError(f"{typ} record without a reading number", path, no)
            if r in rec.accepted or r in rec.missed:
                continue  # never happens with volcal; the first record stands
            if typ == "accepted":
                v = obj.get("value")
                if not isinstance(v, int | float) or not math.isfinite(v):
                    raise VolcalInputError("accepted record without a finite value", path, no)
                rec.accepted[r] = obj
            else:
                rec.missed[r] = obj
    return rec


class Journal:
    """Append JSON lines to a journal, flushed at once and synced to disk.

    Parameters
    ----------
    path : str or Path
        The journal file (created with its folder).
    sync_s : float
        Longest time between two ``fsync`` [s] for the sample lines.
    """

    def __init__(self, path: str | Path, sync_s: float = 1.0) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        good = 0
        if self.path.is_file():
            for end, _, obj in _lines(self.path):
                if obj is not None:
                    good = end
            if good != self.path.stat().st_size:
                with self.path.open("r+b") as f:  # drop a last line cut short by a kill
                    f.truncate(good)
        self._f = self.path.open("ab")
        self.sync_s = sync_s
        self._synced = time.monotonic()

    def write(self, typ: str, obj: dict[str, Any], sync: bool = False) -> None:
        """Append one record ``{"type": typ, **obj}``.

        Parameters
        ----------
        typ : str
            The record's type.
        obj : dict
            Its fields.
        sync : bool
            ``fsync`` now (accepted and missed points, start and end).
        """
        line = json.dumps({"type": typ, **obj}, separators=(",", ":"), allow_nan=False)
        self._f.write(line.encode("utf-8") + b"\n")
        self._f.flush()
        if sync or time.monotonic() - self._synced >= self.sync_s:
            self.sync()

    def sync(self) -> None:
        """Force the journal to disk."""
        self._f.flush()
        os.fsync(self._f.fileno())
        self._synced = time.monotonic()

    def close(self) -> None:
        """Sync and close (twice is harmless)."""
        if not self._f.closed:
            self.sync()
            self._f.close()
