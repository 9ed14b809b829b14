"""Identity and circumstances of a calibration: the machine, the calibration, the equipment.

One definition, used by every feature that needs to know *which* machine and *which*
calibration a file belongs to (report, certificate, history, compensation manifest).
The keys live in ``session.toml`` (``docs/formats.md``, "Identity and circumstances"):

* ``[machine]``: ``name``, ``chain``, ``travel_mm`` (required, read by
  :mod:`volcal.session.format`) and the identity keys :data:`MACHINE_KEYS`
  (``make``, ``model``, ``serial``, ``control``, ``location``);
* ``[calibration]``: :data:`CALIBRATION_KEYS` (``date`` of measurement, ``operator``,
  ``customer``, ``laboratory``);
* ``[[equipment]]``: one table per instrument, :data:`EQUIPMENT_KEYS` (``role``,
  ``make``, ``model``, ``serial``, ``certificate``, ``calibrated``, ``due``).

Two identities are the *same machine* when both carry a serial number and the serials
(and makes, where both are given) are equal; otherwise when name, chain and travel are
equal (:func:`same_machine`).
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError

#: Identity keys of ``[machine]`` besides name, chain and travel (all strings).
MACHINE_KEYS: tuple[str, ...] = ("make", "model", "serial", "control", "location")
#: Keys of ``[calibration]``: ``date`` is a date (TOML date, date-time or ISO 8601
#: string), the others strings.
CALIBRATION_KEYS: tuple[str, ...] = ("date", "operator", "customer", "laboratory")
#: Keys of each ``[[equipment]]`` entry: ``calibrated`` and ``due`` are dates.
EQUIPMENT_KEYS: tuple[str, ...] = ("role", "make", "model", "serial", "certificate",
                                   "calibrated", "due")
_DATE_KEYS = ("date", "calibrated", "due")


def parse_date(value: Any, file: str | Path | None = None, key: str | None = None) -> str:
    """An ISO 8601 date or date-time, validated, as text.

    Parameters
    ----------
    value : date, datetime or str
        A TOML date/date-time or an ISO 8601 string (``2026-11-23``,
        ``2026-11-23T09:30:00Z``).
    file, key : optional
        Where the value came from, for the error message.

    Returns
    -------
    str
        ``YYYY-MM-DD`` for a date, the ISO 8601 form for a date-time.

    Raises
    ------
    VolcalInputError
        Not a date.
    """
    if isinstance(value, _dt.datetime):
        return value.isoformat()
    if isinstance(value, _dt.date):
        return value.isoformat()
    if isinstance(value, str):
        text = value.strip()
        try:
            if len(text) == 10:
                return _dt.date.fromisoformat(text).isoformat()
            return _dt.datetime.fromisoformat(text.replace("Z", "+00:00")).isoformat()
        except ValueError:
            pass
    raise VolcalInputError(f"expected a date (YYYY-MM-DD or ISO 8601 date-time), got {value!r}",
                           file, None, key)


def as_date(text: str) -> _dt.date:
    """The calendar date of an ISO 8601 date or date-time string (see :func:`parse_date`).

    Parameters
    ----------
    text : str
        ISO 8601 date or date-time.
    """
    return _dt.date.fromisoformat(text[:10])


def _strings(table: dict[str, Any], keys: tuple[str, ...], file: Path | None, prefix: str
             ) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k in keys:
        if k not in table:
            continue
        v = table[k]
        if k in _DATE_KEYS:
            out[k] = parse_date(v, file, f"{prefix}{k}")
        elif isinstance(v, str | int) and not isinstance(v, bool):
            out[k] = str(v)  # a serial number typed without quotes is still a serial
        else:
            raise VolcalInputError(f"expected text, got {v!r}", file, None, f"{prefix}{k}")
    return out


def read_machine_identity(machine: dict[str, Any], file: Path | None = None) -> dict[str, str]:
    """Validate the identity keys of a ``[machine]`` table.

    Parameters
    ----------
    machine : dict
        The ``[machine]`` table (other keys are ignored here).
    file : Path, optional
        ``session.toml``, for messages.

    Returns
    -------
    dict of str to str
        The identity keys present (:data:`MACHINE_KEYS`), as text.
    """
    return _strings(machine, MACHINE_KEYS, file, "machine.")


def read_calibration(doc: dict[str, Any], file: Path | None = None) -> dict[str, Any]:
    """Validate the ``[calibration]`` table of a session document.

    Parameters
    ----------
    doc : dict
        The parsed ``session.toml``.
    file : Path, optional
        ``session.toml``, for messages.

    Returns
    -------
    dict
        :data:`CALIBRATION_KEYS` present (``date`` as ISO 8601 text); other keys of the
        table are kept as they were read.

    Raises
    ------
    VolcalInputError
        Not a table, a date that is no date, a name that is no text.
    """
    cal = doc.get("calibration", {})
    if not isinstance(cal, dict):
        raise VolcalInputError("[calibration] must be a table", file, None, "calibration")
    out = {k: v for k, v in cal.items() if k not in CALIBRATION_KEYS}
    out.update(_strings(cal, CALIBRATION_KEYS, file, "calibration."))
    return out


def read_equipment(doc: dict[str, Any], file: Path | None = None) -> list[dict[str, Any]]:
    """Validate the ``[[equipment]]`` entries of a session document.

    Parameters
    ----------
    doc : dict
        The parsed ``session.toml``.
    file : Path, optional
        ``session.toml``, for messages.

    Returns
    -------
    list of dict
        One dict per entry with the :data:`EQUIPMENT_KEYS` present (dates as ISO 8601
        text) and any other keys as read.

    Raises
    ------
    VolcalInputError
        Not an array of tables, an entry without ``role``, bad dates, ``due`` before
        ``calibrated``.
    """
    eq = doc.get("equipment", [])
    if not isinstance(eq, list) or not all(isinstance(e, dict) for e in eq):
        raise VolcalInputError("[[equipment]] must be an array of tables", file, None,
                               "equipment")
    out = []
    for i, e in enumerate(eq):
        where = f"equipment[{i + 1}]."
        item = {k: v for k, v in e.items() if k not in EQUIPMENT_KEYS}
        item.update(_strings(e, EQUIPMENT_KEYS, file, where))
        if "role" not in item:
            raise VolcalInputError("every equipment entry needs a role (e.g. \"laser\", "
                                   "\"air sensor\", \"material sensor\")", file, None,
                                   f"{where}role")
        if "calibrated" in item and "due" in item and \
                as_date(item["due"]) < as_date(item["calibrated"]):
            raise VolcalInputError(f"due {item['due']} is before calibrated "
                                   f"{item['calibrated']}", file, None, f"{where}due")
        out.append(item)
    return out


def expired_equipment(equipment: list[dict[str, Any]], on: str | None) -> list[dict[str, Any]]:
    """Equipment whose calibration was due before the date of measurement.

    Parameters
    ----------
    equipment : list of dict
        ``Session.equipment``.
    on : str, optional
        Date of measurement (ISO 8601); today when not given.

    Returns
    -------
    list of dict
        The entries with ``due`` earlier than ``on``.
    """
    day = as_date(on) if on else _dt.date.today()
    return [e for e in equipment if "due" in e and as_date(e["due"]) < day]


@dataclass(frozen=True)
class MachineIdentity:
    """Who a machine is: what ``[machine]`` says of it.

    Attributes
    ----------
    name : str
        Machine name.
    chain : str
        Kinematic chain code.
    travel_mm : tuple of tuple of float
        ``((xmin, xmax), (ymin, ymax), (zmin, zmax))`` [mm].
    make, model, serial, control, location : str or None
        The identity keys of :data:`MACHINE_KEYS`.
    """

    name: str
    chain: str
    travel_mm: tuple[tuple[float, float], ...]
    make: str | None = None
    model: str | None = None
    serial: str | None = None
    control: str | None = None
    location: str | None = None

    @classmethod
    def of(cls, session: Any) -> MachineIdentity:
        """The identity of a :class:`~volcal.session.format.Session`.

        Parameters
        ----------
        session : Session
            A session.
        """
        keys = read_machine_identity(session.meta)
        travel = tuple((float(a), float(b)) for a, b in session.travel)
        return cls(session.name, session.chain, travel, **keys)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MachineIdentity:
        """Inverse of :meth:`to_dict` (e.g. from a compensation manifest).

        Parameters
        ----------
        d : dict
            As written by :meth:`to_dict`.

        Raises
        ------
        VolcalInputError
            ``name``, ``chain`` or ``travel_mm`` missing or malformed.
        """
        try:
            travel = tuple((float(a), float(b)) for a, b in d["travel_mm"])
            if len(travel) != 3:
                raise ValueError
            return cls(str(d["name"]), str(d["chain"]), travel,
                       **{k: (None if d.get(k) is None else str(d[k])) for k in MACHINE_KEYS})
        except (KeyError, TypeError, ValueError):
            raise VolcalInputError(f"not a machine identity: {d!r}"[:300]) from None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: name, chain, travel_mm and the identity keys that are set."""
        d: dict[str, Any] = {"name": self.name, "chain": self.chain,
                             "travel_mm": [list(t) for t in self.travel_mm]}
        for k in MACHINE_KEYS:
            if getattr(self, k) is not None:
                d[k] = getattr(self, k)
        return d

    def label(self) -> str:
        """One line for messages: ``name (make model, serial S)``."""
        extra = " ".join(v for v in (self.make, self.model) if v)
        if self.serial:
            extra = f"{extra}, serial {self.serial}" if extra else f"serial {self.serial}"
        return f"{self.name} ({extra})" if extra else self.name

    def digest(self) -> str:
        """sha256 of the canonical JSON of :meth:`to_dict` (16 hex digits)."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def same_machine(a: MachineIdentity, b: MachineIdentity) -> tuple[bool, str]:
    """Whether two identities name the same machine, and why.

    Parameters
    ----------
    a, b : MachineIdentity

    Returns
    -------
    same : bool
        By serial number when both have one (and the makes agree where both are
        given); otherwise by name, chain and travel.
    reason : str
        Plain words naming what differs (empty when the same).
    """
    if a.serial and b.serial:
        if a.serial != b.serial:
            return False, f"serial {a.serial!r} is not {b.serial!r}"
        if a.make and b.make and a.make.casefold() != b.make.casefold():
            return False, f"make {a.make!r} is not {b.make!r}"
        return True, ""
    diffs = []
    if a.name != b.name:
        diffs.append(f"name {a.name!r} is not {b.name!r}")
    if a.chain != b.chain:
        diffs.append(f"chain {a.chain} is not {b.chain}")
    if any(abs(x - y) > 1e-6 for ta, tb in zip(a.travel_mm, b.travel_mm, strict=True)
           for x, y in zip(ta, tb, strict=True)):
        diffs.append(f"travel {list(map(list, a.travel_mm))} mm is not "
                     f"{list(map(list, b.travel_mm))} mm")
    return not diffs, "; ".join(diffs)
