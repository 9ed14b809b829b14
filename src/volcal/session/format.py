"""Read and write sessions: a folder with ``session.toml`` and one CSV per measurement.

The format (``volcal-session/1``) is documented in ``docs/formats.md``. Readers validate
everything and raise :class:`~volcal.errors.VolcalInputError` naming the file, row and
column; writers build the whole folder aside and move it into place.
"""

from __future__ import annotations

import csv
import io
import math
import shutil
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.io.atomic import atomic_dir, write_text
from volcal.io.table import Column, TableSpec, read_table
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.model.chain import parse_chain
from volcal.session.identity import (
    MachineIdentity,
    read_calibration,
    read_equipment,
    read_machine_identity,
)
from volcal.session.kinds import ReadContext, kind_names, kind_of, kinds, target_names
from volcal.session.missed import FIRST_ROW_MISSED, MISSED, reading_cells

SESSION_FORMAT = "volcal-session/1"
KINDS: tuple[str, ...] = ("linear", "diagonal", "step_diagonal", "multilateration",
                          "straightness", "angular", "rotary", "probe_sphere")
"""The built-in measurement kinds (``kind`` in ``session.toml``), in their documented order.
Every kind, built-in or added, is an entry of the registry :mod:`volcal.kinds`
(:func:`volcal.kinds.kind_names`); this tuple is kept for the readers of the names."""
TARGETS: tuple[str, ...] = ("flat_mirror", "retroreflector", "retroreflector_mirror", "cat_eye",
                            "straightness_optics", "angular_optics", "level", "roll_optics",
                            "rotary_calibrator", "index_table", "touch_probe")
"""The built-in targets (``target`` in ``session.toml``); each kind of the registry
:mod:`volcal.kinds` lists its own (:func:`volcal.kinds.target_names`)."""
MULTILATERATION_COLUMN = "length_mm"
"""Reading column of a multilateration CSV: change of the station-to-reflector distance."""
REQUIRED_COLUMNS: tuple[str, ...] = ("x_mm", "y_mm", "z_mm", "deviation_um")
OPTIONAL_COLUMNS: dict[str, str] = {
    "run": "int",
    "direction": "dir",
    "time_s": "float",
    "air_temperature_c": "float",
    "air_pressure_pa": "float",
    "humidity_pct": "float",
    "material_temperature_c": "float",
    "status": "text",
}
MIN_ROWS = 2
MISSED_META = "_missed"
"""Key of ``Measurement.meta`` listing the missed captures skipped by the reader: one dict
per row with ``row`` (in the CSV, header = row 1), ``position_mm`` [x, y, z] and, when the
file has them, ``run`` and ``direction``. Working state (never written back)."""

__all__ = [
    "KINDS",
    "SESSION_FORMAT",
    "TARGETS",
    "Measurement",
    "Session",
    "read_measurement_csv",
    "session_toml",
    "read_session",
    "write_session",
]


@dataclass
class Measurement:
    """One laser measurement: its set-up and its readings.

    Attributes
    ----------
    id : str
        Unique name within the session.
    kind : str
        A registered measurement kind (:mod:`volcal.kinds`: ``'linear'``,
        ``'diagonal'``, ``'step_diagonal'``, ``'multilateration'``, ``'straightness'``,
        ``'angular'``, or one added with :func:`volcal.kinds.register_kind`).
    target : str
        A target of a registered kind (``'flat_mirror'``, ``'retroreflector'``...).
    positions : ndarray, shape (n, 3)
        Commanded position of each reading [mm].
    deviation : ndarray, shape (n,), or None
        Laser reading minus commanded displacement along the nominal beam, counted from
        the first row [um]; None in a planned (unmeasured) skeleton.
    beam_direction : ndarray, shape (3,)
        Nominal beam direction, unit vector in machine axes.
    tool_offset : ndarray, shape (3,)
        Target point relative to the tool reference point [mm].
    file : str
        CSV file name, relative to the session folder.
    columns : dict of str to ndarray
        Optional columns (``run``, ``direction``, ``time_s``, environment columns).
    meta : dict
        Optional metadata: ``axis``, ``axis_order``, ``diagonal``, ``plane``, ``notes``,
        the direct optics' ``error_direction``, ``rotation``, ``reference``,
        ``sensor_position_mm``, ``slope_removed`` (:mod:`volcal.session.optics`),
        ``environment`` (table), ``readings`` (``'deviation'`` or ``'raw'``)...; keys
        starting with ``_`` are working state never written, e.g. ``_missed`` (the missed
        captures the reader skipped, :data:`MISSED_META`).
    rows : ndarray of int, shape (n,), optional
        Row of each reading in its CSV file (header = row 1), for messages; missed
        captures leave gaps.

    Raises
    ------
    VolcalInputError
        Unknown ``kind`` or ``target`` (the message lists the valid ones), positions not
        of shape (n, 3) or not finite, a zero or non-finite beam direction, a tool
        offset not of shape (3,), deviations of another length than the positions.
    """

    id: str
    kind: str
    target: str
    positions: NDArray[np.float64]
    deviation: NDArray[np.float64] | None
    beam_direction: NDArray[np.float64]
    tool_offset: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    file: str = ""
    columns: dict[str, NDArray[Any]] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)
    rows: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        """Validate every field (a Measurement built in Python is checked as one read)."""
        if not isinstance(self.id, str) or not self.id:
            raise VolcalInputError(f"measurement id must be a non-empty string, got {self.id!r}")
        where = f"measurement {self.id!r}"
        check_choice(self.kind, kind_names(), "kind", where)
        check_choice(self.target, target_names(), "target", where)
        if not self.file:
            self.file = f"{self.id}.csv"
        self.positions = _array(self.positions, (-1, 3), f"{where}: positions [mm]")
        if self.positions.shape[0] < 1:
            raise VolcalInputError(f"{where}: positions [mm] must have at least one row")
        self.beam_direction = _array(self.beam_direction, (3,), f"{where}: beam_direction")
        if np.linalg.norm(self.beam_direction) < 1e-12:
            raise VolcalInputError(f"{where}: beam_direction must not be the zero vector")
        self.tool_offset = _array(self.tool_offset, (3,), f"{where}: tool_offset [mm]")
        if self.deviation is not None:
            d = np.asarray(self.deviation, dtype=float)
            if d.shape != (self.positions.shape[0],):
                raise VolcalInputError(f"{where}: deviation [um] has shape {d.shape}, expected "
                                       f"({self.positions.shape[0]},) like the positions")
            if np.any(np.isinf(d)):
                raise VolcalInputError(f"{where}: deviation [um] must be finite (NaN marks a "
                                       "missed capture)")
            self.deviation = d

    @property
    def n(self) -> int:
        """Number of readings."""
        return self.positions.shape[0]

    @property
    def missed(self) -> list[dict[str, Any]]:
        """Missed captures skipped by the reader (row, position_mm, run, direction)."""
        return list(self.meta.get(MISSED_META, []))

    @property
    def n_planned(self) -> int:
        """Planned readings: the readings plus the missed captures."""
        return self.n + len(self.missed)

    @property
    def run(self) -> NDArray[np.int64] | None:
        """Run number of each reading, if recorded."""
        return self.columns.get("run")

    @property
    def direction(self) -> NDArray[np.str_] | None:
        """Approach direction ``'+'``/``'-'`` of each reading, if recorded."""
        return self.columns.get("direction")

    @property
    def axis(self) -> int | None:
        """Measured axis index of a linear test or direct optic (metadata or positions).

        The measurement's kind decides (:meth:`volcal.kinds.Kind.axis`); None for a kind
        that reads no single axis (diagonals, multilateration).
        """
        return kind_of(self.kind).axis(self)

    def to_toml(self) -> dict[str, Any]:
        """The measurement's entry in ``session.toml``."""
        d: dict[str, Any] = {
            "id": self.id,
            "kind": self.kind,
            "target": self.target,
            "beam_direction": [float(v) for v in self.beam_direction],
            "tool_offset_mm": [float(v) for v in self.tool_offset],
            "file": self.file,
        }
        if not kind_of(self.kind).beam_in_session:
            del d["beam_direction"]  # not part of these set-ups (see docs/formats.md)
        for k, v in self.meta.items():
            if not k.startswith("_"):  # "_" keys: working state, never written
                d[k] = v
        return d

    def to_csv(self) -> str:
        """The measurement's CSV text (header ``x_mm,y_mm,z_mm,deviation_um`` + optional)."""
        own = kind_of(self.kind).csv_text(self)  # a kind with its own columns (rotary)
        if own is not None:
            return own
        extra = [c for c in OPTIONAL_COLUMNS if c in self.columns]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        header = list(REQUIRED_COLUMNS)
        header[3], values, fmt = kind_of(self.kind).csv_values(self)  # the kind's column
        cells = None if values is None else reading_cells(values, fmt)
        w.writerow([*header, *extra])
        for i in range(self.n):
            row = [_fmt(v) for v in self.positions[i]]
            row.append("" if cells is None else cells[i])
            for c in extra:
                v = self.columns[c][i]
                row.append(str(v) if OPTIONAL_COLUMNS[c] in ("int", "dir", "text")
                           else _fmt(v))
            w.writerow(row)
        return buf.getvalue()


def check_choice(value: Any, valid: tuple[str, ...], what: str, where: str = "",
                 file: str | Path | None = None, key: str | None = None) -> str:
    """Check that ``value`` is one of ``valid``; the message lists the valid values.

    Parameters
    ----------
    value : object
        The value read or given.
    valid : tuple of str
        The valid values (e.g. :data:`KINDS`, :data:`TARGETS`).
    what : str
        Name of the field (``'kind'``).
    where : str
        Context for the message (``"measurement 'x1'"``).
    file : str or Path, optional
        File of the value, for the error.
    key : str, optional
        TOML key or column of the value, for the error.

    Returns
    -------
    str
        ``value``.

    Raises
    ------
    VolcalInputError
        ``value`` is not one of ``valid``.
    """
    if not isinstance(value, str) or value not in valid:
        pre = f"{where}: " if where else ""
        raise VolcalInputError(f"{pre}unknown {what} {value!r}: expected one of "
                               f"{', '.join(valid)}", file, None, key)
    return value


def _array(value: Any, shape: tuple[int, ...], what: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise VolcalInputError(f"{what}: expected numbers, got {value!r}"[:200]) from None
    want = tuple(a.shape[0] if k == -1 and a.ndim else k for k in shape)
    if a.shape != want:
        shown = "(n, 3)" if shape == (-1, 3) else str(shape)
        raise VolcalInputError(f"{what}: expected shape {shown}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise VolcalInputError(f"{what}: values must be finite")
    return a


def _fmt(v: float) -> str:
    return f"{float(v):.6f}".rstrip("0").rstrip(".") if math.isfinite(v) else "nan"


@dataclass
class Session:
    """A calibration session: the machine and its measurements.

    Attributes
    ----------
    name : str
        Machine name.
    chain : str
        Kinematic chain code (``'XYFZ'``...).
    travel : ndarray, shape (3, 2)
        Travel limits of X, Y, Z [mm].
    measurements : list of Measurement
    meta : dict
        Other ``[machine]`` keys kept as they were read.
    path : Path, optional
        Folder the session was read from.
    unmeasured : list of Measurement
        Planned measurements without readings yet, set aside by :func:`read_session`
        (``measurements`` then holds the measured subset).
    notes : list of str
        What the reader did that the user should know (measurements without readings,
        missed captures skipped); commands print them.
    warnings : list of str
        Implausible readings (:mod:`volcal.session.plausibility`), each naming the
        measurement; commands print them and the identification records them.
    provenance : dict
        The ``[provenance]`` table: who wrote the readings (``readings = "simulated"``,
        seed, date, digest of the readings; ``docs/formats.md``).
    calibration : dict
        The ``[calibration]`` table (date of measurement, operator, customer,
        laboratory; :mod:`volcal.session.identity`).
    equipment : list of dict
        The ``[[equipment]]`` entries (role, make, model, serial, certificate,
        calibrated, due).
    references : dict of str to dict
        The ``[references.NAME]`` tables of the direct optics (an optical square's
        ``square_deviation_urad``, ``u_square_urad``; :mod:`volcal.session.optics`).

    Raises
    ------
    VolcalInputError
        Unknown chain, travel not (3, 2) finite with max > min, an entry that is not a
        Measurement, two measurements with one id.
    """

    name: str
    chain: str
    travel: NDArray[np.float64]
    measurements: list[Measurement] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None
    unmeasured: list[Measurement] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    provenance: dict[str, Any] = field(default_factory=dict)
    calibration: dict[str, Any] = field(default_factory=dict)
    equipment: list[dict[str, Any]] = field(default_factory=list)
    references: dict[str, dict[str, Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Validate chain, travel and measurements."""
        self.chain = parse_chain(self.chain).code
        self.travel = _array(self.travel, (3, 2), "travel [mm]")
        if np.any(self.travel[:, 1] <= self.travel[:, 0]):
            raise VolcalInputError("travel [mm]: every axis needs max > min")
        seen: set[str] = set()
        for m in [*self.measurements, *self.unmeasured]:
            if not isinstance(m, Measurement):
                raise VolcalInputError(f"a session holds Measurement objects, got {m!r}"[:200])
            if m.id in seen:
                raise VolcalInputError(f"duplicate measurement id {m.id!r}")
            seen.add(m.id)

    @property
    def identity(self) -> MachineIdentity:
        """The machine's identity (:class:`volcal.session.identity.MachineIdentity`)."""
        return MachineIdentity.of(self)

    @property
    def unmeasured_ids(self) -> list[str]:
        """Ids of the planned measurements without readings (set aside by the reader)."""
        return [m.id for m in self.unmeasured]

    def get(self, mid: str) -> Measurement:
        """Measurement by id.

        Parameters
        ----------
        mid : str
            Measurement id, as in ``session.toml``.

        Returns
        -------
        Measurement

        Raises
        ------
        KeyError
            No measurement has this id.
        """
        for m in self.measurements:
            if m.id == mid:
                return m
        raise KeyError(mid)

    def to_toml(self) -> dict[str, Any]:
        """The content of ``session.toml``."""
        machine: dict[str, Any] = {"name": self.name, "chain": self.chain}
        machine.update(self.meta)
        machine["travel_mm"] = {a: [float(v) for v in self.travel[i]] for i, a in enumerate("xyz")}
        every = [*self.measurements, *self.unmeasured]  # set-aside ones kept, at the end
        doc: dict[str, Any] = {"format": SESSION_FORMAT, "machine": machine}
        if self.calibration:
            doc["calibration"] = dict(self.calibration)
        if self.equipment:
            doc["equipment"] = [dict(e) for e in self.equipment]
        if self.provenance:
            doc["provenance"] = dict(self.provenance)
        if self.references:
            doc["references"] = {k: dict(v) for k, v in self.references.items()}
        doc["measurements"] = [m.to_toml() for m in every]
        return doc


def write_session(session: Session, folder: str | Path, extra_files: dict[str, str] | None = None,
                  keep_existing: bool = False, backup: str | None = None) -> Path:
    """Write a session folder atomically (built aside, then moved into place).

    Parameters
    ----------
    session : Session
        The session.
    folder : str or Path
        Target folder; replaced if it exists.
    extra_files : dict of str to str, optional
        Further text files to write, relative path -> content (e.g. the simulation truth).
    keep_existing : bool
        Copy every other file of an existing ``folder`` (results of later commands, the
        user's notes) into the new folder; files written here replace their old versions.
    backup : str, optional
        With ``keep_existing``: first copy the existing ``session.toml``, measurement
        CSVs and ``truth/`` into this sub-folder (relative, e.g. ``backup/<time>``),
        in the same atomic replacement.

    Returns
    -------
    Path
        The folder.
    """
    folder = Path(folder)
    names = [m.file for m in session.measurements]
    if len(set(names)) != len(names):
        raise VolcalInputError("two measurements share one file name")
    with atomic_dir(folder) as tmp:
        if keep_existing and folder.is_dir():
            shutil.copytree(folder, tmp, symlinks=True, dirs_exist_ok=True)
            if backup is not None:
                from volcal.session.provenance import backup_session_files

                backup_session_files(tmp, names, backup)
                if (tmp / "truth").is_dir():
                    shutil.rmtree(tmp / "truth")  # the new truth, if any, comes below
        (tmp / "session.toml").write_text(toml_dumps(session.to_toml()), encoding="utf-8")
        for m in session.measurements:
            (tmp / m.file).parent.mkdir(parents=True, exist_ok=True)
            (tmp / m.file).write_text(m.to_csv(), encoding="utf-8")
        for rel, text in (extra_files or {}).items():
            (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp / rel).write_text(text, encoding="utf-8")
    session.path = folder
    return folder


def update_measurement_files(session: Session) -> None:
    """Rewrite the CSV files and ``session.toml`` of a session read from disk, file by file.

    Each file is replaced atomically.

    Parameters
    ----------
    session : Session
        A session with ``path`` set.
    """
    assert session.path is not None
    for m in session.measurements:
        write_text(session.path / m.file, m.to_csv())
    write_text(session.path / "session.toml", toml_dumps(session.to_toml()))


# ----------------------------------------------------------------------------- readers

def _err(msg: str, file: Path, row: int | None = None, col: str | None = None):
    return VolcalInputError(msg, file, row, col)


def _vec3(value: Any, file: Path, key: str, nonzero: bool = False) -> NDArray[np.float64]:
    if not isinstance(value, list) or len(value) != 3:
        raise _err("expected a list of 3 numbers", file, None, key)
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise _err(f"expected finite numbers, got {v!r}", file, None, key)
        out.append(float(v))
    a = np.array(out)
    if nonzero and np.linalg.norm(a) < 1e-12:
        raise _err("a direction must not be the zero vector", file, None, key)
    return a


DEVIATION_ABS_MAX_UM = 10_000.0
"""Largest plausible |deviation| [um] (10 mm): larger values are errors, not readings."""
POSITION_ABS_MAX_MM = 1.0e6
"""Largest plausible |position| [mm] (1 km): a guard against absurd values such as 1e308."""

def _check_environment_columns(t: Any) -> None:
    """Refuse a per-reading environment value outside its range, naming row and column.

    The ranges are those of the environment table
    (:data:`volcal.environment.limits.ENVIRONMENT_LIMITS`).
    """
    from volcal.environment.limits import ENVIRONMENT_LIMITS, range_message

    for name, lim in ENVIRONMENT_LIMITS.items():
        if not t.has(name):
            continue
        v = np.asarray(t[name], dtype=float)
        bad = np.flatnonzero(~((v >= lim.lo) & (v <= lim.hi)))
        if bad.size:
            raise t.error(range_message(float(v[bad[0]]), name, lim), int(bad[0]), name)


SPREADSHEET: dict[str, Any] = {"delimiters": ",;\t", "decimal_comma": True}
"""Options of the session CSV readers shared with the laser-export reader
(:func:`volcal.importer.laser_csv.laser_spec`): the header line decides the delimiter
(``,``, ``;`` or tab) and with ``;`` or tab a decimal comma is read (a CSV saved by a
European spreadsheet: ``0;0;0;1,25``)."""

MEASUREMENT_TABLE = TableSpec(
    columns=(
        Column("x_mm", abs_max=POSITION_ABS_MAX_MM), Column("y_mm", abs_max=POSITION_ABS_MAX_MM),
        Column("z_mm", abs_max=POSITION_ABS_MAX_MM),
        Column("deviation_um", empty=True, abs_max=DEVIATION_ABS_MAX_UM, markers=(MISSED,)),
        Column("run", kind="int", required=False, min=0),
        Column("direction", kind="choice", required=False, choices=("+", "-")),
        *(Column(c, required=False) for c, k in OPTIONAL_COLUMNS.items()
          if k == "float"),
        Column("status", kind="choice", required=False, empty=True, choices=("ok", MISSED)),
    ),
    min_rows=MIN_ROWS,
    min_rows_message="need at least {min} readings, found {n}",
    what="measurement file",
    **SPREADSHEET,
)
"""Columns of a measurement CSV (``docs/formats.md``)."""

ANGULAR_TABLE = TableSpec(
    columns=(
        Column("x_mm", abs_max=POSITION_ABS_MAX_MM), Column("y_mm", abs_max=POSITION_ABS_MAX_MM),
        Column("z_mm", abs_max=POSITION_ABS_MAX_MM),
        Column("angle_urad", empty=True, abs_max=DEVIATION_ABS_MAX_UM, markers=(MISSED,)),
        *MEASUREMENT_TABLE.columns[4:],
    ),
    min_rows=MIN_ROWS,
    min_rows_message="need at least {min} readings, found {n}",
    what="angular measurement file",
)
"""Columns of an angular CSV: ``angle_urad`` [urad] instead of ``deviation_um``."""

MULTILATERATION_TABLE = TableSpec(
    columns=(
        Column("x_mm"), Column("y_mm"), Column("z_mm"),
        Column(MULTILATERATION_COLUMN, empty=True, abs_max=1e5),
        Column("run", kind="int", required=False, min=0),
        Column("direction", kind="choice", required=False, choices=("+", "-")),
        *(Column(c, required=False) for c, k in OPTIONAL_COLUMNS.items()
          if k == "float"),
    ),
    min_rows=MIN_ROWS,
    min_rows_message="need at least {min} readings, found {n}",
    what="multilateration file",
    **SPREADSHEET,
)
"""Columns of a multilateration CSV: ``length_mm`` instead of ``deviation_um``."""

@dataclass
class _Rows:
    """A measurement CSV as read: every row, with the missed captures marked."""

    positions: NDArray[np.float64]
    deviation: NDArray[np.float64] | None  # NaN at missed captures; None: not measured
    columns: dict[str, NDArray[Any]]
    rows: NDArray[np.int64]
    missed: NDArray[np.bool_]


def _value_table(value_column: str) -> TableSpec:
    """Columns of a measurement CSV whose reading column is ``value_column``."""
    if value_column == "deviation_um":
        return MEASUREMENT_TABLE
    if value_column == "angle_urad":
        return ANGULAR_TABLE
    return TableSpec(columns=(*MEASUREMENT_TABLE.columns[:3],
                              Column(value_column, empty=True, abs_max=DEVIATION_ABS_MAX_UM,
                                     markers=(MISSED,)),
                              *MEASUREMENT_TABLE.columns[4:]),
                     min_rows=MIN_ROWS, min_rows_message="need at least {min} readings, found {n}",
                     what="measurement file", **SPREADSHEET)


def _read_rows(path: str | Path, value_column: str = "deviation_um") -> _Rows:
    spec = _value_table(value_column)
    t = read_table(path, spec)
    _check_environment_columns(t)
    pos = np.stack([t["x_mm"], t["y_mm"], t["z_mm"]], axis=1)
    dev = t[value_column]
    missed = t.marked[value_column].copy()
    if t.has("status"):
        missed |= t["status"] == MISSED
    empty = np.isnan(dev) & ~missed
    cols = {c: t[c] for c in OPTIONAL_COLUMNS if t.has(c)}
    if (empty | missed).all():
        return _Rows(pos, None, cols, t.rows, missed)
    if empty.any():
        raise t.error(f"missing deviation: write the reading, or '{MISSED}' for a missed "
                      "capture (docs/formats.md)", int(np.argmax(empty)), value_column)
    if missed[0]:
        raise t.error(FIRST_ROW_MISSED, 0, value_column)
    dev = np.where(missed, np.nan, dev)
    return _Rows(pos, dev, cols, t.rows, missed)


def _missed_note(file: str | Path, rows: NDArray[np.int64], missed: NDArray[np.bool_]) -> str:
    r = ", ".join(str(int(v)) for v in rows[missed])
    s = "s" if missed.sum() > 1 else ""
    return f"{file}: missed capture{s} skipped (row{s} {r})"


def _missed_records(r: _Rows) -> list[dict[str, Any]]:
    """The missed captures of a file: row, commanded position and run/direction if given."""
    out = []
    for i in np.flatnonzero(r.missed):
        rec: dict[str, Any] = {"row": int(r.rows[i]),
                               "position_mm": [float(v) for v in r.positions[i]]}
        if "run" in r.columns:
            rec["run"] = int(r.columns["run"][i])
        if "direction" in r.columns:
            rec["direction"] = str(r.columns["direction"][i])
        out.append(rec)
    return out


def _drop_missed(r: _Rows, file: str | Path, notes: list[str] | None) -> _Rows:
    if r.deviation is None or not r.missed.any():
        return r
    keep = ~r.missed
    if keep.sum() < MIN_ROWS:
        raise VolcalInputError(f"need at least {MIN_ROWS} readings, found {int(keep.sum())} "
                               "besides the missed captures", file, int(r.rows[-1]),
                               "deviation_um")
    if notes is not None:
        notes.append(_missed_note(file, r.rows, r.missed))
    cols = {k: v[keep] for k, v in r.columns.items() if k != "status"}
    return _Rows(r.positions[keep], r.deviation[keep], cols, r.rows[keep], r.missed[keep])


def read_measurement_csv(path: str | Path, require_deviation: bool = True,
                         notes: list[str] | None = None, value_column: str = "deviation_um"):
    """Read one measurement CSV.

    Rows marked as missed captures (``deviation_um`` = ``missed``, or ``status`` =
    ``missed``) are skipped, with a note.

    Parameters
    ----------
    path : str or Path
        CSV file with the header ``x_mm,y_mm,z_mm,deviation_um`` and optional columns.
    require_deviation : bool
        If False, an empty ``deviation_um`` column is accepted (a planned skeleton).
    value_column : str
        Name of the reading column: ``'deviation_um'`` [um], or ``'length_mm'`` [mm] for a
        multilateration measurement (returned as read, in its own unit).
    notes : list of str, optional
        Notes about the file (missed captures skipped) are appended here.

    Returns
    -------
    positions : ndarray, shape (n, 3)
        Commanded positions [mm].
    deviation : ndarray, shape (n,) or None
        Deviations [um]; None if the column is empty and not required.
    columns : dict
        Optional columns.

    Raises
    ------
    VolcalInputError
        Naming file, row (1-based, header = row 1) and column; ``no readings yet`` for an
        empty ``deviation_um`` column when ``require_deviation``.
    """
    if value_column == MULTILATERATION_COLUMN:
        t = read_table(path, MULTILATERATION_TABLE)
        _check_environment_columns(t)
        pos = np.stack([t["x_mm"], t["y_mm"], t["z_mm"]], axis=1)
        readings = t[value_column]
        missing = np.isnan(readings)
        dev: NDArray[np.float64] | None = readings
        if missing.all() and not require_deviation:
            dev = None
        elif missing.any():
            raise t.error("missing reading", int(np.argmax(missing)), value_column)
        out = {c: t[c] for c in OPTIONAL_COLUMNS if t.has(c)}
        return pos, dev, out
    r = _read_rows(path, value_column)
    if r.deviation is None:
        if require_deviation:
            raise VolcalInputError("no readings yet: the deviation_um column is empty "
                                   "(planned, not measured)", path, None, "deviation_um")
        return r.positions, None, r.columns
    r = _drop_missed(r, path, notes)
    return r.positions, r.deviation, r.columns


def read_session(folder: str | Path, require_deviation: bool = True) -> Session:
    """Read and validate a session folder.

    With ``require_deviation`` (what every command that uses readings asks), the
    measurements without readings yet are set aside in ``Session.unmeasured`` and named
    in one note, missed captures are skipped with a note, and the plausibility checks of
    :mod:`volcal.session.plausibility` add their warnings; a session without any reading
    is refused with ``no readings yet: ...``.

    Parameters
    ----------
    folder : str or Path
        Folder with ``session.toml`` (or the path of ``session.toml`` itself).
    require_deviation : bool
        If False (plan, program, simulate, advise), every measurement is kept, planned
        skeletons with empty deviations load, missed captures stay as NaN.

    Returns
    -------
    Session

    Raises
    ------
    VolcalInputError
        Naming the file, row and column (TOML key) of the first problem.
    """
    folder, toml_path, doc = _load_session_toml(Path(folder))
    name, chain, travel, meta, provenance = _read_machine(doc, toml_path)
    raw = doc.get("measurements", [])
    if not isinstance(raw, list) or not raw:
        raise _err("no [[measurements]] in the session", toml_path, None, "measurements")
    from volcal.session.optics import (
        annotate_references,
        check_references,
        read_references,
        vertical_axis,
    )

    vertical = vertical_axis(meta, toml_path)
    references = read_references(doc, toml_path)
    _check_files_once(raw, toml_path)
    seen: set[str] = set()
    meas: list[Measurement] = []
    unmeasured: list[Measurement] = []
    notes: list[str] = []
    for i, e in enumerate(raw):
        m = _read_entry(e, i, folder, toml_path, seen, require_deviation, travel, notes,
                        vertical, meta)
        from volcal.environment.apply import prepare_readings
        from volcal.session.kinds import kinds

        # the one referral to 20 C; errors name '<session.toml> [<id>]' and measurements[i]
        m = prepare_readings(m, f"{toml_path} [{m.id}]", f"measurements[{i}]", kinds())
        (unmeasured if require_deviation and m.deviation is None else meas).append(m)
    if require_deviation and not meas:
        from volcal.session.kinds import kind_of

        # each kind's readings column (an R-test's dx_um, a rotary test's deviation_urad)
        cols = sorted({kind_of(m.kind).value_column for m in unmeasured})
        n = len(unmeasured)
        raise _err(f"no readings yet: the {', '.join(cols)} column{'s' * (len(cols) > 1)} of "
                   f"{f'all {n} measurements' if n > 1 else 'its one measurement'} "
                   f"{'are' if len(cols) > 1 else 'is'} empty (measure "
                   f"{'them' if n > 1 else 'it'}, `volcal import` or `volcal simulate` first)",
                   toml_path, None, cols[0] if len(cols) == 1 else None)
    if unmeasured:
        notes.insert(0, f"no readings yet: {', '.join(m.id for m in unmeasured)} "
                     f"(working on the {len(meas)} measured)")
    check_references([*meas, *unmeasured], references, toml_path,
                     {e["id"]: f"measurements[{i}]" for i, e in enumerate(raw)
                      if isinstance(e, dict) and isinstance(e.get("id"), str)})
    annotate_references([*meas, *unmeasured], references)
    s = Session(name, chain, travel, meas, meta, folder, unmeasured, notes, [], provenance,
                read_calibration(doc, toml_path), read_equipment(doc, toml_path), references)
    if require_deviation:
        from volcal.session.plausibility import plausibility_warnings

        s.warnings = plausibility_warnings(s)
    return s


def _check_files_once(raw: list[Any], toml_path: Path) -> None:
    """Refuse two entries naming one file.

    Each measurement has its own file: two entries naming one file would read (and
    ``volcal simulate`` or ``volcal import`` would write) the same readings twice.
    """
    owner: dict[str, str] = {}
    for i, e in enumerate(raw):
        if not isinstance(e, dict) or not isinstance(e.get("file"), str) or not e["file"]:
            continue
        key = Path(e["file"]).as_posix()
        if key in owner:
            raise _err(f"measurement file {e['file']!r} is also the file of {owner[key]}: "
                       "each measurement has its own file", toml_path, None,
                       f"measurements[{i}].file")
        mid = e.get("id")
        owner[key] = f"measurement {mid!r}" if isinstance(mid, str) else f"measurements[{i}]"


def session_toml(folder: str | Path) -> tuple[Path, Path]:
    """The session folder and its ``session.toml``, as :func:`read_session` finds them.

    Parameters
    ----------
    folder : str or Path
        A session folder, or its ``session.toml``.

    Returns
    -------
    folder, toml_path : Path

    Raises
    ------
    VolcalInputError
        No such folder, another file, or a folder without ``session.toml``.
    """
    folder = Path(folder)
    if folder.is_file():
        if folder.name != "session.toml":
            raise _err("a file, not a session folder (a folder with session.toml)", folder)
        folder = folder.parent
    elif not folder.exists():
        raise _err("session folder not found (no session.toml here)", folder)
    toml_path = folder / "session.toml"
    if not toml_path.is_file():
        raise _err("no session.toml in this folder (is it a volcal session?)", folder)
    return folder, toml_path


def _load_session_toml(folder: Path) -> tuple[Path, Path, dict[str, Any]]:
    """The session folder, its ``session.toml`` and the parsed document (format checked)."""
    folder, toml_path = session_toml(folder)
    try:
        doc = tomllib.loads(toml_path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise _err(f"invalid TOML: {exc}", toml_path) from None
    except OSError as exc:
        raise _err(f"cannot read the file ({exc.__class__.__name__})", toml_path) from None
    fmt = doc.get("format")
    if fmt != SESSION_FORMAT:
        raise _err(f"expected format = \"{SESSION_FORMAT}\", got {fmt!r}", toml_path, None,
                   "format")
    return folder, toml_path, doc


def _read_machine(doc: dict[str, Any], toml_path: Path
                  ) -> tuple[str, str, NDArray[np.float64], dict[str, Any], dict[str, Any]]:
    """Name, chain, travel [mm], other ``[machine]`` keys and ``[provenance]``."""
    machine = doc.get("machine")
    if not isinstance(machine, dict):
        raise _err("missing [machine] table", toml_path, None, "machine")
    name = machine.get("name", "machine")
    if not isinstance(name, str):
        raise _err("machine name must be a string", toml_path, None, "machine.name")
    chain = machine.get("chain")
    try:
        parse_chain(chain)
    except VolcalInputError as exc:
        raise _err(exc.message, toml_path, None, "machine.chain") from None
    travel = _read_travel(machine.get("travel_mm"), toml_path)
    meta = {k: v for k, v in machine.items() if k not in ("name", "chain", "travel_mm")}
    meta.update(read_machine_identity(machine, toml_path))  # identity keys validated, as text
    from volcal.session.rotary import read_rotary_axes

    read_rotary_axes(machine, toml_path)  # [[machine.rotary_axes]] validated
    provenance = doc.get("provenance", {})
    if not isinstance(provenance, dict):
        raise _err("[provenance] must be a table", toml_path, None, "provenance")
    return name, str(chain), travel, meta, provenance  # parse_chain took text only


def _read_travel(tr: Any, toml_path: Path) -> NDArray[np.float64]:
    if not isinstance(tr, dict):
        raise _err("missing [machine.travel_mm] table with x, y, z = [min, max]", toml_path, None,
                   "machine.travel_mm")
    travel = np.empty((3, 2))
    unknown = sorted(set(tr) - {"x", "y", "z"})
    if unknown:
        raise _err(f"unknown axis {unknown[0]!r}: expected x, y, z", toml_path, None,
                   f"machine.travel_mm.{unknown[0]}")
    for i, a in enumerate("xyz"):
        v = tr.get(a)
        key = f"machine.travel_mm.{a}"
        if (not isinstance(v, list) or len(v) != 2
                or any(isinstance(x, bool) or not isinstance(x, int | float) for x in v)
                or not all(math.isfinite(x) for x in v)
                or not all(abs(x) <= POSITION_ABS_MAX_MM for x in v)):
            raise _err("expected [min, max] in mm", toml_path, None, key)
        if v[1] <= v[0]:
            raise _err("travel max must exceed min", toml_path, None, key)
        travel[i] = v
    return travel


def _entry_keys(e: Any, where: str, folder: Path, toml_path: Path, seen: set[str]
                ) -> tuple[str, str, str, str, Path]:
    """Id, kind, target, file and CSV path of a ``[[measurements]]`` entry, checked."""
    if not isinstance(e, dict):
        raise _err("each [[measurements]] entry must be a table", toml_path, None, where)
    _check_misspelled(e, where, toml_path)
    mid = e.get("id")
    if not isinstance(mid, str) or not mid:
        raise _err("missing or empty id", toml_path, None, f"{where}.id")
    if mid in seen:
        raise _err(f"duplicate measurement id {mid!r}", toml_path, None, f"{where}.id")
    seen.add(mid)
    kind = check_choice(e.get("kind"), kind_names(), "kind", "", toml_path, f"{where}.kind")
    k = kind_of(kind)
    target = check_choice(e.get("target", k.default_target or k.targets[0]), target_names(),
                          "target", "", toml_path, f"{where}.target")
    file = e.get("file")
    if not isinstance(file, str) or not file:
        raise _err("missing file name", toml_path, None, f"{where}.file")
    csv_path = folder / file
    if Path(file).is_absolute() or ".." in Path(file).parts:
        raise _err(f"measurement file {file!r} is outside the session folder: give a name "
                   "beside session.toml (or in a subfolder of it)", toml_path, None,
                   f"{where}.file")
    if not csv_path.is_file():
        raise _err(f"measurement file {file!r} not found beside session.toml", toml_path, None,
                   f"{where}.file")
    if target not in k.targets:  # the kind's own targets (registry: volcal.kinds)
        owner = next((o.name for o in kinds() if target in o.own_targets), None)
        pre = f"target {target!r} belongs to kind {owner!r}, not {kind!r}: " if owner else ""
        raise _err(f"{pre}a {kind} measurement needs target = one of {', '.join(k.targets)}",
                   toml_path, None, f"{where}.target")
    return mid, kind, target, file, csv_path


ENTRY_KEYS: tuple[str, ...] = ("id", "kind", "target", "file", "tool_offset_mm",
                               "beam_direction", "notes", "referred_to_20c", "environment",
                               "axis", "diagonal", "axis_order", "plane")
"""The ``[[measurements]]`` keys the session reader itself reads (a kind reads its own)."""


def _check_misspelled(e: dict[str, Any], where: str, toml_path: Path) -> None:
    """Refuse a misspelling of one of :data:`ENTRY_KEYS` that the entry lacks.

    ``tool_ofset_mm`` would otherwise be kept as a note and the offset taken as 0. Other
    keys of the user's own are kept.
    """
    import difflib

    for key in e:
        if key in ENTRY_KEYS:
            continue
        close = [k for k in difflib.get_close_matches(key, ENTRY_KEYS, 1, 0.85) if k not in e]
        if close:
            raise _err(f"unknown key {key!r}: did you mean {close[0]!r}?", toml_path, None,
                       f"{where}.{close[0]}")


def _beam(e: dict[str, Any], pos: NDArray[np.float64], where: str, toml_path: Path,
          csv_path: Path) -> NDArray[np.float64]:
    """Unit beam direction: as given, else from the first row to the farthest."""
    if "beam_direction" in e:
        n = _vec3(e["beam_direction"], toml_path, f"{where}.beam_direction", nonzero=True)
    else:
        d = pos - pos[0]
        far = int(np.argmax(np.linalg.norm(d, axis=1)))
        if np.linalg.norm(d[far]) < 1e-9:
            raise _err("all readings at one position: cannot infer the beam direction",
                       csv_path)
        n = d[far]
    return n / np.linalg.norm(n)


def _check_meta(kind: str, meta: dict[str, Any], pos: NDArray[np.float64], file: str,
                where: str, toml_path: Path) -> None:
    """The linear test's ``axis`` moves; ``environment`` is a table."""
    if kind == "linear" and "axis" in meta:
        a = meta["axis"]
        if not isinstance(a, str) or a.upper() not in ("X", "Y", "Z"):
            raise _err(f"axis must be \"X\", \"Y\" or \"Z\", got {a!r}", toml_path, None,
                       f"{where}.axis")
        moving = int(np.argmax(np.ptp(pos, axis=0)))
        if "XYZ".index(a.upper()) != moving:
            raise _err(f"axis = {a!r} but the positions in {file} move along "
                       f"{'XYZ'[moving]}", toml_path, None, f"{where}.axis")
    env = meta.get("environment")
    if env is not None and not isinstance(env, dict):
        raise _err("environment must be a table", toml_path, None, f"{where}.environment")
    _check_labels(kind, meta, where, toml_path)


def _check_labels(kind: str, meta: dict[str, Any], where: str, toml_path: Path) -> None:
    """The enumerated set-up keys of a diagonal or step diagonal, with the valid choices."""
    order = meta.get("axis_order")
    if order is not None and (not isinstance(order, str) or not order
                              or not set(order.lower()) <= set("xyz")
                              or len(set(order.lower())) != len(order)):
        raise _err(f"axis_order must be the moving axes in their order, each once (\"xyz\", "
                   f"\"yxz\", \"xy\"...), got {order!r}", toml_path, None,
                   f"{where}.axis_order")
    plane = meta.get("plane")
    if plane is not None and (not isinstance(plane, str) or plane.lower() not in PLANES):
        raise _err(f"unknown plane {plane!r}: expected one of {', '.join(PLANES)}", toml_path,
                   None, f"{where}.plane")
    code = meta.get("diagonal")
    if code is not None and kind in ("diagonal", "step_diagonal") and (
            not isinstance(code, str) or len(code) not in (2, 3)
            or not set(code.lower()) <= set("pn")):
        raise _err(f"unknown diagonal {code!r}: expected the sign of each axis' travel, p or "
                   "n (body: ppp, npp, pnp, ppn...; face: pp, np)", toml_path, None,
                   f"{where}.diagonal")


PLANES: tuple[str, ...] = ("xy", "yz", "xz")
"""Values of a face diagonal's ``plane`` key."""


def _read_entry(e: Any, i: int, folder: Path, toml_path: Path, seen: set[str],
                require_deviation: bool, travel: NDArray[np.float64],
                notes: list[str], vertical: int = 2,
                machine: dict[str, Any] | None = None) -> Measurement:
    """One ``[[measurements]]`` entry: common keys here, the rest by its kind's reader."""
    where = f"measurements[{i}]"
    mid, kind, target, file, csv_path = _entry_keys(e, where, folder, toml_path, seen)
    offset = _vec3(e.get("tool_offset_mm", [0, 0, 0]), toml_path, f"{where}.tool_offset_mm")
    ctx = ReadContext(where, mid, kind, target, file, csv_path, toml_path, offset,
                      require_deviation, travel, notes, vertical, dict(machine or {}))
    return kind_of(kind).read(e, ctx)


def read_laser_entry(e: dict[str, Any], ctx: ReadContext) -> Measurement:
    """A laser reading along a beam (linear, diagonal, step diagonal): ``deviation_um``.

    Parameters
    ----------
    e : dict
        The ``[[measurements]]`` entry.
    ctx : ReadContext
        Its checked keys and the session's context.

    Returns
    -------
    Measurement
    """
    from volcal.session.checks import check_geometry, check_repeats, check_travel

    where, toml_path, csv_path = ctx.where, ctx.toml_path, ctx.csv_path
    r = _read_rows(csv_path)
    n = _beam(e, r.positions, where, toml_path, csv_path)
    meta = {k: v for k, v in e.items()
            if k not in ("id", "kind", "target", "file", "tool_offset_mm", "beam_direction")}
    _check_meta(ctx.kind, meta, r.positions, ctx.file, where, toml_path)
    check_travel(r.positions, r.rows, ctx.travel, csv_path)
    check_geometry(ctx.kind, r.positions, r.rows, meta, csv_path,
                   n if "beam_direction" in e else None)
    check_repeats(r.positions, r.rows, r.columns, r.missed, csv_path)
    r = missed_dropped(r, meta, ctx)
    return Measurement(ctx.id, ctx.kind, ctx.target, r.positions, r.deviation, n,
                       ctx.tool_offset, ctx.file, r.columns, meta, r.rows)


def missed_dropped(r: _Rows, meta: dict[str, Any], ctx: ReadContext) -> _Rows:
    """The rows without their missed captures, recorded in ``meta`` (when readings count).

    Parameters
    ----------
    r : rows read by :func:`read_rows`
    meta : dict
        The measurement's metadata; gains :data:`MISSED_META`.
    ctx : ReadContext
        ``require_deviation`` and the notes.

    Returns
    -------
    rows
    """
    if ctx.require_deviation:
        if r.deviation is not None and r.missed.any():
            meta[MISSED_META] = _missed_records(r)
        r = _drop_missed(r, ctx.csv_path, ctx.notes)
    return r


def read_rows(path: str | Path, value_column: str = "deviation_um") -> _Rows:
    """Every row of a measurement CSV with the reading column ``value_column``.

    Parameters
    ----------
    path : str or Path
        The CSV file (``x_mm, y_mm, z_mm``, the reading column, the optional columns).
    value_column : str
        Reading column of the kind (``deviation_um``, ``angle_urad``...).

    Returns
    -------
    rows
        ``positions`` [mm], ``deviation`` (NaN at missed captures; None when the column
        is empty), ``columns``, ``rows`` (CSV row numbers), ``missed``.

    Raises
    ------
    VolcalInputError
        Naming the file, row and column.
    """
    return _read_rows(path, value_column)
