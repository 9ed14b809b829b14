"""The measurement's CSV, rewritten atomically from the journal as points are accepted.

The CSV keeps every cell of the planned file (positions, ``run``, ``direction``) and
fills the reading column and ``time_s`` from the journal's ``accepted`` and ``missed``
records: a reading, ``missed``, or empty for a dwell not reached yet. A file being
captured has empty cells below its last recorded row, so the other commands refuse it
(``missing deviation``) until the capture is complete; the complete file is read back
with the session's reader before the capture reports success.

The reading column of the displacement tests (linear, diagonal, step diagonal: the
kinds whose beam is in ``session.toml``) is the deviation ``(L_i - L_ref) - 1000 (p_i -
p_ref) . b`` [um] (docs/formats.md): laser reading minus commanded displacement along
the nominal beam ``b``, from the reference row ``ref`` (the first row; the first
accepted row when the first was missed). A rotary test's reading (the angular
interferometer on the rotary calibrator: the axis' angular positioning error, actual -
commanded angle [urad]) counts from the first row as its kind's file does (the
calibrator is zeroed there; :attr:`volcal.session.kinds.Kind.from_first_row`):
``R_i - R_ref``. A direct optic's reading (straightness [um], angle [urad]) is written as
the optic gave it. An R-test's reading is the nest's three sensors [um], written into its
three reading columns (``dx_um, dy_um, dz_um``, or ``s1_um, s2_um, s3_um`` when the planned
file has them) as the sensors give them: they are zeroed at the program's operator stop
at the first pose (docs/fiveaxis.md), so they count from there already. With
``sensor_directions`` the three values are the sensors' own readings ``s``: written into
``dx_um...`` as the displacement ``N^-1 s`` (:func:`volcal.session.r_test.
sensor_displacement`).

A cell holding a reading that the journal does not hold (measured or typed by someone
else) is never overwritten: the capture refuses, naming the file, row and column.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

import numpy as np

from volcal.capture.journal import Recorded
from volcal.errors import VolcalInputError
from volcal.io.atomic import write_text
from volcal.session.format import MISSED
from volcal.session.kinds import kind_of

__all__ = ["Reading", "reading_of", "render_csv", "stale_temporaries"]


class Reading:
    """How a measurement's readings are written (see the module's docstring).

    Parameters
    ----------
    m : Measurement
        The planned measurement.
    """

    def __init__(self, m: Any) -> None:
        k = kind_of(m.kind)
        self.column = str(k.value_column)
        self.columns: tuple[str, ...] = (self.column,)
        if m.kind == "r_test":  # the nest's three sensors
            cols = (("s1_um", "s2_um", "s3_um") if "s1_um" in m.columns
                    else ("dx_um", "dy_um", "dz_um"))
            self.column, self.columns = cols[0], cols
        self.sensors = None  # the directions of a nest that sends its sensors' readings
        if m.kind == "r_test":
            from volcal.session.r_test import rtest_keys

            self.sensors = rtest_keys(m)["sensor_directions"]
        if k.captured_by:  # the capture step passes these over (Kind.captured_by)
            raise VolcalInputError(f"measurement {m.id!r} ({m.kind}) is not captured by "
                                   f"volcal capture: {k.captured_by}")
        self.displacement = k.displacement
        self.from_first = k.displacement or k.from_first_row
        self.unit = "urad" if self.column.endswith("_urad") else "um"
        self.positions = np.asarray(m.positions, float)
        b = np.asarray(m.beam_direction, float)
        self.beam = b / np.linalg.norm(b)

    @property
    def channels(self) -> int:
        """Values of each reading (3 for an R-test's sensors)."""
        return len(self.columns)

    def rows(self, rec: Recorded) -> dict[int, tuple[float, ...]]:
        """Each accepted reading's value in every reading column [um or urad].

        Parameters
        ----------
        rec : Recorded
            The journal's records.

        Returns
        -------
        dict of int to tuple of float
            Reading (0-based data row) -> one value per column of :attr:`columns`.
        """
        if self.channels == 1:
            return {i: (v,) for i, v in self.values(rec).items()}
        return {i: tuple(float(x) for x in r.get("values", [r["value"]]))
                for i, r in rec.accepted.items()}

    def values(self, rec: Recorded) -> dict[int, float]:
        """Value of each accepted reading in the file's column [um or urad].

        Parameters
        ----------
        rec : Recorded
            The journal's records.

        Returns
        -------
        dict of int to float
            Reading (0-based data row) -> value.
        """
        raw = {i: float(r["value"]) for i, r in rec.accepted.items()}
        if not self.from_first or not raw:
            return raw
        ref = 0 if 0 in raw else min(raw)
        p0, l0 = self.positions[ref], raw[ref]
        if not self.displacement:
            return {i: v - l0 for i, v in raw.items()}
        return {i: (v - l0) - 1000.0 * float((self.positions[i] - p0) @ self.beam)
                for i, v in raw.items()}


def reading_of(m: Any) -> Reading:
    """The :class:`Reading` of measurement ``m``.

    Parameters
    ----------
    m : Measurement
        The planned measurement.

    Returns
    -------
    Reading
    """
    return Reading(m)


def render_csv(path: Path, m: Any, rec: Recorded, time_offsets: dict[int, float]
               ) -> tuple[str, int]:
    """The CSV text of ``m`` with the recorded readings, from the file as it stands.

    Parameters
    ----------
    path : Path
        The measurement's CSV (planned, or partly captured by this journal).
    m : Measurement
        The planned measurement.
    rec : Recorded
        The journal's records.
    time_offsets : dict of int to float
        ``time_s`` [s] of each recorded reading (measurement time).

    Returns
    -------
    text : str
        The new file.
    n : int
        Rows with a reading or ``missed``.

    Raises
    ------
    VolcalInputError
        The file holds a reading the journal does not (never overwritten), or its rows
        are not the planned ones.
    """
    r = reading_of(m)
    text = path.read_text(encoding="utf-8")
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise VolcalInputError("empty measurement file", path)
    head = rows[0]
    names = r.columns
    sensors = ("s1_um", "s2_um", "s3_um")
    if r.channels == 3 and names[0] not in head and all(c in head for c in sensors):
        names = sensors  # a planned file of the sensors' own readings (sensor_directions)
    for c in names:
        if c not in head:
            raise VolcalInputError(f"no column {c!r}", path, 1)
    values = r.rows(rec)
    if names[0] == "dx_um" and r.sensors is not None:  # the sensors' readings: d = N^-1 s
        from volcal.session.r_test import sensor_displacement

        values = {i: tuple(float(x) for x in sensor_displacement(np.array([v]), r.sensors)[0])
                  for i, v in values.items()}
    body = [row for row in rows[1:] if any(c.strip() for c in row)]
    if len(body) != m.n_planned:
        raise VolcalInputError(f"{len(body)} rows, the plan has {m.n_planned}: the file "
                               "changed since it was planned", path)
    if "time_s" not in head:
        head = [*head, "time_s"]
        body = [[*row, ""] for row in body]
    cols, tcol = [head.index(c) for c in names], head.index("time_s")
    n = 0
    for i, row in enumerate(body):
        row += [""] * (len(head) - len(row))
        t = f"{time_offsets.get(i, 0.0):.3f}"
        if i in values:
            new = [f"{v:.6f}" for v in values[i]]
        elif i in rec.missed:
            new = [MISSED] * len(cols)
        else:
            new, t = [""] * len(cols), row[tcol]
        for col, name, cell in zip(cols, names, new, strict=True):
            old = row[col].strip()
            if old and old != cell:
                raise VolcalInputError(
                    f"holds the reading {old!r}, which the capture journal does not hold"
                    f"{'' if not cell else f' (it holds {cell})'}: a measured reading is "
                    "never overwritten; capture into a new session (-o), or capture it "
                    "again here (--measurement ID --again: the file is kept in backup/)",
                    path, i + 2, name)
            row[col] = cell
        row[tcol] = t
        n += bool(new[0])
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(head)
    w.writerows(body)
    return buf.getvalue(), n


def write_csv(path: Path, m: Any, rec: Recorded, time_offsets: dict[int, float]) -> int:
    """Rewrite the measurement's CSV atomically (:func:`render_csv`).

    Parameters
    ----------
    path : Path
        The measurement's CSV.
    m : Measurement
        The planned measurement.
    rec : Recorded
        The journal's records.
    time_offsets : dict of int to float
        ``time_s`` of each recorded reading [s].

    Returns
    -------
    int
        Rows with a reading or ``missed``.
    """
    text, n = render_csv(path, m, rec, time_offsets)
    if text != path.read_text(encoding="utf-8"):
        write_text(path, text)
    return n


def stale_temporaries(path: Path) -> list[Path]:
    """Temporary files an atomic write of ``path`` left when killed (removed on resume).

    Parameters
    ----------
    path : Path
        The measurement's CSV.

    Returns
    -------
    list of Path
    """
    return sorted(path.parent.glob(f".{path.name}.*.tmp"))
