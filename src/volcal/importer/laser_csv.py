"""Generic laser CSV export -> linear measurement of a session.

Every laser software can export a linear test as a table: target position, run,
direction and either the error (deviation) or the absolute laser reading. A column
mapping names the columns (``--map target=Pos,run=Run,direction=Dir,deviation=Err``);
the units come from the ``--units`` option or from the headers (``Pos (mm)``,
``Err [µm]``) and are reported. The deviation of a reading column is
``reading - target`` (ISO 230-2:2014, 2.10: deviation of position = actual - target).

Files are decoded as UTF-8 (with or without BOM) or Windows-1252; the delimiter is
``,``, ``;`` or tab (sniffed); with ``;`` or tab a decimal comma is accepted. Lines
before the header (vendor preamble) are skipped: the header is the first line holding
all mapped columns.

The session is never left half-written: a new session is built aside and moved into
place; a measurement added to an existing session is written as its CSV file first and
then ``session.toml`` is replaced atomically.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.importer.header import (
    CALIBRATION_FIELDS,
    ENVIRONMENT_FIELDS,
    HEADER_KEYS,
    HeaderField,
    read_header,
)
from volcal.importer.units import TO_MM, unit_from_header, unit_name, unsupported_unit
from volcal.importer.wide import DIRECTION_WORDS, run_columns, to_long
from volcal.io.atomic import write_together
from volcal.io.table import Column, Table, TableSpec, parse_table
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.model.names import AXES
from volcal.session.format import (
    MIN_ROWS,
    OPTIONAL_COLUMNS,
    TARGETS,
    Measurement,
    Session,
    read_session,
    write_session,
)

KEYS: tuple[str, ...] = ("target", "deviation", "reading", "run", "direction", "time",
                         *[c for c in OPTIONAL_COLUMNS if c not in ("run", "direction",
                                                                     "time_s", "status")],
                         *CALIBRATION_FIELDS)
"""Mapping keys: what a column holds; ``date``, ``operator`` and the environment keys may
name a field of the header block above the table instead (:mod:`volcal.importer.header`)."""

_DIRECTIONS = {**DIRECTION_WORDS, "1": "+", "-1": "-", "+1": "+"}
MAX_BYTES = 50_000_000
_RUN = re.compile(r"^\+?\d{1,9}([.,]0*)?$")
PATTERN_CHARS = "*?["
"""A mapped column name holding one of these is a pattern: a wide table."""
STEP_SEPARATOR = "|"
"""Separates the columns of a per-step step-diagonal table: ``deviation=dX|dY|dZ``."""


def layout_of(mapping: dict[str, str]) -> str:
    """Layout a mapping describes: ``'long'``, ``'wide'`` (pattern) or ``'steps'``.

    Parameters
    ----------
    mapping : dict of str to str
        From :func:`parse_mapping`.

    Returns
    -------
    str
    """
    value = mapping.get("deviation") or mapping.get("reading") or ""
    if STEP_SEPARATOR in value:
        return "steps"
    if any(ch in value for ch in PATTERN_CHARS):
        return "wide"
    return "long"


def parse_mapping(text: str) -> dict[str, str]:
    """Parse ``'target=Pos,run=Run,deviation=Err'`` into {key: column header}.

    Parameters
    ----------
    text : str
        The ``--map`` option: comma-separated ``key=column header`` pairs; keys are
        case-insensitive and taken from :data:`KEYS`. A ``deviation`` or ``reading``
        column holding ``*``, ``?`` or ``[`` is a pattern naming the run columns of a
        wide table (``deviation=Run*``); ``deviation=A|B|C`` names the columns of a
        per-step step-diagonal table (the readings after each single-axis move).

    Returns
    -------
    dict of str to str
        Lower-case key to the column header of the laser file.

    Raises
    ------
    VolcalInputError
        Unknown keys, missing target, both or neither of deviation and reading, a
        key that does not fit the layout (``run=`` with a wide table...).
    """
    out: dict[str, str] = {}
    for part in (p for p in text.split(",") if p.strip()):
        key, sep, col = part.partition("=")
        key = key.strip().lower()
        if not sep or not col.strip():
            raise VolcalInputError(f"--map: {part!r} is not key=column")
        if key not in KEYS:
            raise VolcalInputError(f"--map: unknown key {key!r}; expected {', '.join(KEYS)}")
        if key in out:
            raise VolcalInputError(f"--map: key {key!r} given twice")
        out[key] = col.strip()
    if "target" not in out:
        raise VolcalInputError("--map needs target=<column of the target positions>")
    if ("deviation" in out) == ("reading" in out):
        raise VolcalInputError("--map needs exactly one of deviation=<column> or "
                               "reading=<column>")
    layout = layout_of(out)
    extra = [k for k in out if k not in ("target", "deviation", "reading", *HEADER_KEYS)]
    if layout != "long" and extra:
        what = ("a wide table (the pattern names one column per run; run and direction "
                "come from the column names)" if layout == "wide" else
                "a per-step step-diagonal table")
        raise VolcalInputError(f"--map: {extra[0]}= does not fit {what}")
    return out


@dataclass
class LaserTable:
    """Readings from a laser export, one per element, in capture order.

    Attributes
    ----------
    target_mm : ndarray
        Target position of each reading [mm] (as in the file, converted); NaN where the
        layout gives none (intermediate moves of a per-step table).
    deviation_um : ndarray
        Deviation of each reading [um].
    columns : dict
        Optional session columns (``run``, ``direction``, ``time_s``, environment).
    notes : list of str
        What was detected (units, delimiter, skipped lines, inferred runs).
    rows : ndarray of int
        Physical line of each reading in the file (for messages).
    sources : list of str
        Column of each reading's value (for messages).
    reading_mm : ndarray or None
        The absolute reading of each element [mm] when mapped with ``reading=``.
    steps : int
        Per-step tables: readings per row (moves per step); 0 otherwise.
    inferred : tuple of str
        Columns not in the file but inferred (``'run'``, ``'direction'``).
    """

    target_mm: NDArray[np.float64]
    deviation_um: NDArray[np.float64]
    columns: dict[str, NDArray[Any]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    rows: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    sources: list[str] = field(default_factory=list)
    reading_mm: NDArray[np.float64] | None = None
    steps: int = 0
    inferred: tuple[str, ...] = ()
    header: list[HeaderField] = field(default_factory=list)
    header_notes: list[str] = field(default_factory=list)

    @property
    def environment(self) -> dict[str, float]:
        """The environment read from the header block (``air_temperature_c``...)."""
        return {f.key: float(f.value) for f in self.header
                if f.key in (*ENVIRONMENT_FIELDS, "expansion_ppm_per_k")}

    @property
    def calibration(self) -> dict[str, str]:
        """``date`` and ``operator`` read from the header block."""
        return {f.key: str(f.value) for f in self.header if f.key in CALIBRATION_FIELDS}

    def error(self, message: str, i: int, path: str | Path) -> VolcalInputError:
        """An error located at reading ``i`` (its file row and column).

        Parameters
        ----------
        message : str
            What is wrong.
        i : int
            0-based reading.
        path : str or Path
            The file.

        Returns
        -------
        VolcalInputError
        """
        return VolcalInputError(message, path, int(self.rows[i]), self.sources[i])


def _decode(path: Path) -> str:
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise VolcalInputError("file not found", path) from None
    except (IsADirectoryError, PermissionError, OSError) as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    if len(raw) > MAX_BYTES:
        raise VolcalInputError("file larger than 50 MB: not a laser export", path)
    if b"\x00" in raw:
        raise VolcalInputError("binary file: export CSV from the laser software (vendor "
                               "binary formats such as Renishaw .rtl are not documented)", path)
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("cp1252", errors="replace")


def _unit(option: str | None, header: str, fallback: str | None, what: str, notes: list[str],
          path: Path, col: str, row: int = 1) -> str:
    found = unit_from_header(header)
    if option not in (None, "auto"):
        u = unit_name(option, f"--{what}-units" if what != "target" else "--units")
        if found is not None and found != u:
            raise VolcalInputError(f"header says {found} but --units says {u}", path, row, col)
        notes.append(f"{what} column '{header}': {u} (given)")
        return u
    if found is not None:
        notes.append(f"{what} column '{header}': {found} (detected from the header)")
        return found
    other = unsupported_unit(header)
    if other is not None:
        raise VolcalInputError(f"the header names the unit {other!r}, which volcal does not "
                               f"read; convert to one of {', '.join(TO_MM)}", path, row, col)
    if fallback is None:
        raise VolcalInputError(f"no unit in the header; give the unit of the {what} column",
                               path, row, col)
    notes.append(f"{what} column '{header}': {fallback} (assumed; no unit in the header)")
    return fallback


def _parse_run(text: str) -> int:
    if not _RUN.match(text):
        raise ValueError(f"run must be a whole number >= 0, got {text!r}")
    return int(text.split(".")[0].split(",")[0])


def _parse_direction(text: str) -> str:
    v = _DIRECTIONS.get(text.casefold())
    if v is None:
        raise ValueError(f"unknown direction {text!r}: expected +/-, up/down, forward/backward")
    return v


def laser_spec(mapping: dict[str, str]) -> TableSpec:
    """The :class:`~volcal.io.table.TableSpec` of a laser export with this mapping.

    Parameters
    ----------
    mapping : dict of str to str
        From :func:`parse_mapping`.

    Returns
    -------
    TableSpec
        Sniffed delimiter (``,``, ``;``, tab), decimal comma with ``;`` or tab, a
        preamble of up to 200 lines, header names matched without case or unit.
    """
    cols: list[Column] = [Column(mapping["target"])]
    vkey = "deviation" if "deviation" in mapping else "reading"
    layout = layout_of(mapping)
    if layout == "wide":
        cols.append(Column("runs", pattern=mapping[vkey]))
    elif layout == "steps":
        cols += [Column(c.strip(), empty=True) for c in mapping[vkey].split(STEP_SEPARATOR)]
    else:
        cols.append(Column(mapping[vkey]))
    for key, col in mapping.items():
        if key == "run":
            cols.append(Column(col, kind="int", parse=_parse_run))
        elif key == "direction":
            cols.append(Column(col, kind="str", parse=_parse_direction))
        elif key in ENVIRONMENT_FIELDS:
            if layout == "long":  # a column, else a field of the header block
                cols.append(Column(col, required=False))
        elif key not in ("target", "deviation", "reading", *CALIBRATION_FIELDS):
            cols.append(Column(col))
    return TableSpec(tuple(cols), min_rows=0, delimiters=",;\t", sniff=True,
                     decimal_comma=True, header_within=200, loose_names=True,
                     extra_fields=True, what="laser export")


def read_laser_csv(path: str | Path, mapping: dict[str, str], units: str = "auto",
                   deviation_units: str = "auto") -> LaserTable:
    """Read the mapped columns of a laser CSV export.

    Parameters
    ----------
    path : str or Path
        The export.
    mapping : dict of str to str
        From :func:`parse_mapping`; its layout (:func:`layout_of`) decides how the
        table is read: one reading per row (long), one column per run (wide), or one
        row per step with a column per move (steps).
    units : str
        Unit of the target and reading columns: ``mm``, ``um``, ``in`` or ``auto``
        (header, else mm).
    deviation_units : str
        Unit of the deviation columns: ``um``, ``nm``, ``mm``, ``in``, ``uin`` or ``auto``
        (header, else um for metric targets; required for inch targets).

    Returns
    -------
    LaserTable

    Raises
    ------
    VolcalInputError
        Naming the file, row (1-based line of the file) and column.
    """
    path = Path(path)
    t = parse_table(_decode(path), laser_spec(mapping), path)
    notes = [f"header on line {t.header_row}, delimiter {t.delimiter!r}"]
    if len(t) < MIN_ROWS:
        last = int(t.rows[-1]) if len(t) else t.header_row
        raise VolcalInputError(f"need at least {MIN_ROWS} data lines, found {len(t)}", path,
                               last + 1)
    tu = _unit(units, t.written[mapping["target"]], "mm", "target", notes, path,
               mapping["target"], t.header_row)
    target = t[mapping["target"]] * TO_MM[tu]
    layout = layout_of(mapping)
    if layout == "steps":
        out = _read_steps(t, mapping, target, tu, units, deviation_units, notes, path)
    elif layout == "wide":
        out = _read_wide(t, mapping, target, tu, units, deviation_units, notes, path)
    else:
        out = _read_long(t, mapping, target, tu, units, deviation_units, notes, path)
    if layout != "steps":
        _check_duplicates(out, path, mapping["target"])
    _read_header_block(t, mapping, out, path)
    return out


def _read_header_block(t: Table, mapping: dict[str, str], out: LaserTable, path: Path) -> None:
    """Date, operator and environment from the lines above the table (or say none)."""
    columns = tuple(k for k in ENVIRONMENT_FIELDS if k in mapping and t.has(mapping[k]))
    named = {k: v for k, v in mapping.items() if k in HEADER_KEYS and k not in columns}
    out.header, out.header_notes = read_header(t.preamble, named, path, skip=columns,
                                               columns=tuple(t.header),
                                               header_row=t.header_row)
    if t.preamble and not out.header and not out.header_notes:
        first, last = t.preamble[0][0], t.preamble[-1][0]
        out.header_notes.append(
            f"line{'s' if last > first else ''} {first}{f'-{last}' if last > first else ''} "
            "above the table: no date, operator or environment recognised (name them with "
            "--map date=<label>,operator=<label>,air_temperature_c=<label>,...)")


def _value_unit(t: Table, key: str, col: str, tu: str, units: str, deviation_units: str,
                notes: list[str], path: Path) -> str:
    head = t.written[col]
    if key == "deviation":
        return _unit(deviation_units, head, "um" if tu in ("mm", "um") else None, "deviation",
                     notes, path, col, t.header_row)
    return _unit(units if unit_from_header(head) is None else "auto", head, tu, "reading",
                 notes, path, col, t.header_row)


def _values(key: str, v: NDArray[np.float64], unit: str, target: NDArray[np.float64]
            ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Deviation [um] and (reading columns) the reading [mm] of raw values in ``unit``."""
    x = v * TO_MM[unit]
    if key == "reading":
        return (x - target) * 1000.0, x
    return x * 1000.0, None


def _read_long(t: Table, mapping: dict[str, str], target: NDArray[np.float64], tu: str,
               units: str, deviation_units: str, notes: list[str], path: Path) -> LaserTable:
    key = "deviation" if "deviation" in mapping else "reading"
    col = mapping[key]
    du = _value_unit(t, key, col, tu, units, deviation_units, notes, path)
    dev, reading = _values(key, t[col].astype(float), du, target)
    cols: dict[str, NDArray[Any]] = {}
    for k, c in mapping.items():
        if k in ("target", "deviation", "reading") or (k in HEADER_KEYS and not t.has(c)):
            continue  # header keys without a column: fields of the header block
        name = "time_s" if k == "time" else k
        cols[name] = (np.array(t[c], dtype=int) if k == "run" else
                      np.array(t[c], dtype=str) if k == "direction" else t[c].astype(float))
    inferred = []
    if "direction" not in cols:
        cols["direction"] = _infer_directions(target)
        notes.append("approach directions inferred from the order of the targets")
        inferred.append("direction")
        if "run" not in cols:
            cols["run"] = _infer_runs(cols["direction"])
            notes.append(f"{int(cols['run'].max())} run(s) inferred from the direction changes "
                         "(a run is one + pass and one - pass)")
            inferred.append("run")
    return LaserTable(target, dev, cols, notes, t.rows.copy(), [col] * len(t), reading,
                      inferred=tuple(inferred))


def _read_wide(t: Table, mapping: dict[str, str], target: NDArray[np.float64], tu: str,
               units: str, deviation_units: str, notes: list[str], path: Path) -> LaserTable:
    key = "deviation" if "deviation" in mapping else "reading"
    rcols = run_columns(t.groups["runs"], mapping[key], path, t.header_row)
    long = to_long(target, rcols, _infer_directions(target))
    n = long.index.size
    dev, reading = np.empty(n), np.empty(n)
    at = 0
    for c in rcols:
        u = _value_unit(t, key, c.header, tu, units, deviation_units, notes, path)
        k = len(t)
        sel = long.index[at:at + k]
        d, r = _values(key, t[c.header].astype(float)[sel], u, target[sel])
        dev[at:at + k] = d
        reading[at:at + k] = np.nan if r is None else r
        at += k
    has_dir = rcols[0].direction is not None
    notes.append(f"wide table: {len(rcols)} run column(s) ({', '.join(c.header for c in rcols)})"
                 + ("" if has_dir else "; directions inferred from the order of the targets")
                 + f" -> {n} readings")
    cols = {"run": long.run, "direction": long.direction}
    return LaserTable(target[long.index], dev, cols, notes, t.rows[long.index], long.column,
                      reading if key == "reading" else None,
                      inferred=() if has_dir else ("direction",))


def _read_steps(t: Table, mapping: dict[str, str], target: NDArray[np.float64], tu: str,
                units: str, deviation_units: str, notes: list[str], path: Path) -> LaserTable:
    key = "deviation" if "deviation" in mapping else "reading"
    names = [c.strip() for c in mapping[key].split(STEP_SEPARATOR)]
    per = np.empty((len(t), len(names)))
    for j, c in enumerate(names):
        u = _value_unit(t, key, c, tu, units, deviation_units, notes, path)
        per[:, j] = t[c].astype(float) * TO_MM[u]
    tgt = np.full((len(t), len(names)), np.nan)
    tgt[:, -1] = target
    notes.append(f"per-step table: {len(t)} rows x {len(names)} moves")
    # readings become deviations against the plan's targets (volcal.importer.planned)
    dev = per.ravel() * 1000.0 if key == "deviation" else np.full(per.size, np.nan)
    return LaserTable(tgt.ravel(), dev, {}, notes, np.repeat(t.rows, len(names)),
                      names * len(t), per.ravel() if key == "reading" else None, len(names))


def _check_duplicates(table: LaserTable, path: Path, t_col: str) -> None:
    """ISO 230-2: each target once per run and direction."""
    run, dirn = table.columns.get("run"), table.columns.get("direction")
    if run is None or dirn is None:
        return
    seen: dict[tuple[float, int, str], int] = {}
    for j, key in enumerate(zip(table.target_mm.round(6), run, dirn, strict=True)):  # as written
        if key in seen:
            raise VolcalInputError(
                f"target {key[0]:g} mm appears twice in run {key[1]} direction {key[2]} "
                f"(also on line {seen[key]}): a duplicated line?", path, int(table.rows[j]),
                t_col)
        seen[key] = int(table.rows[j])


def _infer_directions(q: NDArray[np.float64]) -> NDArray[np.str_]:
    """Approach direction of each reading from the capture order.

    A reading takes the sign of the move that reached it; a target read twice in a row
    (the turn-around of a run, after the overrun) takes the sign of the move that leaves
    it, so the two readings of the end target fall in opposite directions.
    """
    d = np.diff(q)
    out, last = [], "+"
    for i in range(q.size):
        s = d[i - 1] if i > 0 else (d[0] if d.size else 0.0)
        if abs(s) <= 1e-12 and i < d.size:
            s = d[i]
        if abs(s) > 1e-12:
            last = "+" if s > 0 else "-"
        out.append(last)
    return np.array(out)


def _infer_runs(direction: NDArray[np.str_]) -> NDArray[np.int_]:
    """Run number (1-based) of each reading: a new run starts where ``-`` turns to ``+``."""
    run, out = 1, []
    for i, dr in enumerate(direction):
        if i > 0 and dr == "+" and direction[i - 1] == "-":
            run += 1
        out.append(run)
    return np.array(out, dtype=int)


@dataclass
class ImportResult:
    """What ``import_csv`` did: the measurement, the session folder, notes for the user.

    ``header`` holds one line per field read from the export's header block (date,
    operator, environment: where it went), ``header_notes`` what was not read there.
    """

    measurement: Measurement
    session: Path
    created: bool
    notes: list[str]
    header: list[str] = field(default_factory=list)
    header_notes: list[str] = field(default_factory=list)


def header_meta(table: LaserTable, meta: dict[str, Any]) -> dict[str, Any]:
    """``meta`` with the header block's environment merged into its ``environment`` table.

    Parameters
    ----------
    table : LaserTable
        As read (its ``header`` fields).
    meta : dict
        The measurement's metadata (a planned measurement's, or a new one's).

    Returns
    -------
    dict
        A copy; ``environment`` gains ``air_temperature_c``, ``air_pressure_pa``,
        ``humidity_pct``, ``material_temperature_c``, ``expansion_ppm_per_k`` as read
        (the header's values replace earlier ones of the same key); ``referred_to_20c``
        when the header states the material compensation (on: true, off: false).
    """
    out = dict(meta)
    env = table.environment
    if env:
        out["environment"] = {**dict(out.get("environment") or {}), **env}
    for f in table.header:
        if f.key == "referred_to_20c":  # the export says whether its software referred them
            out["referred_to_20c"] = bool(f.value)
    return out


def check_plausible(table: LaserTable, path: str | Path) -> None:
    """Refuse a deviation no session reader would accept (|d| > 10 mm), naming its cell.

    Parameters
    ----------
    table : LaserTable
        The readings.
    path : str or Path
        The export (for the message).

    Raises
    ------
    VolcalInputError
        Naming the file, row and column of the first absurd value.
    """
    from volcal.session.format import DEVIATION_ABS_MAX_UM

    big = np.flatnonzero(np.abs(np.nan_to_num(table.deviation_um)) > DEVIATION_ABS_MAX_UM)
    if big.size:  # never write a session file its reader refuses (docs/formats.md)
        i = int(big[0])
        raise table.error(f"deviation {table.deviation_um[i]:.6g} um of reading {i + 1} is absurd "
                          f"(> {DEVIATION_ABS_MAX_UM:g} um): wrong units (mm in a um column?), "
                          "or a column that is not the laser's reading?", i, path)


def _check_options(axis: str, mid: str, target: str) -> str:
    ax = axis.strip().upper()
    if ax not in AXES or len(ax) != 1:
        raise VolcalInputError(f"--axis {axis!r}: expected X, Y or Z")
    check_id(mid)
    if target not in TARGETS:
        raise VolcalInputError(f"--optics {target!r}: expected one of {', '.join(TARGETS)}")
    return ax


def check_id(mid: str, option: str = "--id") -> None:
    """Refuse a measurement id that is not a safe file name.

    Parameters
    ----------
    mid : str
        Measurement id.
    option : str
        Option it came from (for the message).

    Raises
    ------
    VolcalInputError
        Not letters, digits, ``-`` and ``_`` starting with a letter or digit.
    """
    if not mid or not all(c.isalnum() or c in "-_" for c in mid) or not mid[0].isalnum():
        raise VolcalInputError(f"{option} {mid!r}: use letters, digits, '-' and '_'")


def import_csv(path: str | Path, mapping: dict[str, str], axis: str, line_mm, session: str | Path,
               mid: str, units: str = "auto", deviation_units: str = "auto",
               target: str = "retroreflector", tool_offset=(0.0, 0.0, 0.0),
               travel=None, chain: str = "XYFZ", name: str = "machine",
               replace: bool = False) -> ImportResult:
    """Add a linear measurement read from a laser CSV export to a session.

    Parameters
    ----------
    path : str or Path
        The export.
    mapping : dict
        Column mapping (:func:`parse_mapping`); long or wide layout.
    axis : str
        Measured axis ``'X'``, ``'Y'`` or ``'Z'``.
    line_mm : array_like, shape (3,)
        Machine position of the measuring line [mm]; its coordinate along ``axis`` is
        added to the targets (0 when the targets are machine coordinates).
    session : str or Path
        Session folder; created if it does not exist (then ``travel`` is required).
    mid : str
        Measurement id (letters, digits, ``-``, ``_``).
    units, deviation_units : str
        See :func:`read_laser_csv`.
    target : str
        Optics on the tool: ``'retroreflector'`` or ``'flat_mirror'``.
    tool_offset : array_like, shape (3,)
        Target point relative to the tool reference point [mm].
    travel : array_like, shape (3, 2), optional
        Travel limits for a new session [mm].
    chain, name : str
        Chain code and machine name of a new session.
    replace : bool
        Replace a measurement with the same id.

    Returns
    -------
    ImportResult
    """
    ax = _check_options(axis, mid, target)
    if layout_of(mapping) == "steps":
        raise VolcalInputError("--map: a per-step table (deviation=A|B|C) is a step diagonal: "
                               "import it into its planned measurement with --measurement ID")
    line = np.asarray(line_mm, dtype=float).reshape(3)
    k = AXES.index(ax)
    table = read_laser_csv(path, mapping, units, deviation_units)
    check_plausible(table, path)
    pos = np.tile(line, (table.target_mm.size, 1))
    pos[:, k] = line[k] + table.target_mm
    beam = np.zeros(3)
    beam[k] = 1.0
    meta: dict[str, Any] = {"axis": ax, "line_mm": [float(v) for v in line],
                            "notes": f"imported from {Path(path).name}",
                            "import": import_record(path, mapping, table.notes, table)}
    m = Measurement(mid, "linear", target, pos, table.deviation_um, beam,
                    np.asarray(tool_offset, dtype=float), f"{mid}.csv", table.columns,
                    header_meta(table, meta))
    folder = Path(session)
    notes = list(table.notes)
    said = [f.describe() for f in table.header]
    if not (folder / "session.toml").is_file():
        _new_session(folder, m, travel, chain, name, notes, Path(path), table.calibration)
        return ImportResult(m, folder, True, notes, said, list(table.header_notes))
    s = read_session(folder, require_deviation=False)
    _check_travel(m, s.travel, notes, Path(path))
    hnotes = list(table.header_notes)
    write_measurement(folder, m, replace, notes, table.calibration, hnotes)
    return ImportResult(m, folder, False, notes, said, hnotes)


def import_record(path: str | Path, mapping: dict[str, str], notes: list[str],
                  table: LaserTable | None = None) -> dict[str, Any]:
    """The ``import`` table written into the measurement's entry of ``session.toml``.

    Parameters
    ----------
    path : str or Path
        The export.
    mapping : dict of str to str
        Column mapping.
    notes : list of str
        What was detected (units, layout, inferences).
    table : LaserTable, optional
        The export as read: its header block's date and operator are recorded as
        ``date`` and ``operator`` (the measurement's own, whatever ``[calibration]``
        says).

    Returns
    -------
    dict
    """
    out: dict[str, Any] = {"source": Path(path).name, "mapping": mapping,
                           "units": "; ".join(notes)}
    if table is not None:
        out.update(table.calibration)
    return out


def _new_session(folder: Path, m: Measurement, travel, chain: str, name: str,
                 notes: list[str], source: Path, calibration: dict[str, str] | None = None
                 ) -> None:
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise VolcalInputError("not a session folder (no session.toml) and not empty", folder)
    if travel is None:
        raise VolcalInputError("a new session needs --travel xmin:xmax,ymin:ymax,zmin:zmax",
                               folder)
    travel = np.asarray(travel, dtype=float).reshape(3, 2)
    if not np.all(np.isfinite(travel)) or np.any(travel[:, 1] <= travel[:, 0]):
        raise VolcalInputError("--travel: every axis needs finite min < max [mm]")
    s = Session(name, chain, travel, [m], calibration=dict(calibration or {}))
    _check_travel(m, s.travel, notes, source)
    write_session(s, folder)


def write_measurement(folder: Path, m: Measurement, replace: bool, notes: list[str],
                      calibration: dict[str, str] | None = None,
                      header_notes: list[str] | None = None) -> None:
    """Add or replace one measurement of a session: its CSV first, then ``session.toml``.

    Readings that are replaced are first copied into ``backup/<time>/``. The date and
    operator of an export's header block fill ``[calibration]`` keys the session does
    not have yet; a different value already there is kept (and said).

    Parameters
    ----------
    folder : Path
        Session folder (with ``session.toml``).
    m : Measurement
        The measurement to write.
    replace : bool
        Replace a measurement with the same id (else that is an error).
    notes : list of str
        Where the backup made is reported.
    calibration : dict of str to str, optional
        ``date`` (ISO 8601) and ``operator`` read from the export's header block.
    header_notes : list of str, optional
        Where a header value that was not taken over is reported (default ``notes``).

    Raises
    ------
    VolcalInputError
        The id exists without ``replace``; the file belongs to another measurement or
        is some other file of the folder (nothing is overwritten).
    """
    toml_path = folder / "session.toml"
    doc = tomllib.loads(toml_path.read_text(encoding="utf-8"))
    entries = doc.get("measurements", [])
    same = [i for i, e in enumerate(entries) if e.get("id") == m.id]
    if same and not replace:
        raise VolcalInputError(f"measurement {m.id!r} exists; choose another --id or --replace",
                               toml_path)
    others = {e.get("file") for i, e in enumerate(entries) if i not in same}
    if m.file in others:
        raise VolcalInputError(f"file {m.file!r} belongs to another measurement", toml_path)
    old_files = {e.get("file") for i, e in enumerate(entries) if i in same}
    if (folder / m.file).exists() and m.file not in old_files:
        raise VolcalInputError(f"{m.file!r} exists in the session and is not a measurement's "
                               "file: choose another --id (nothing is overwritten)", toml_path)
    old = [f for f in old_files if isinstance(f, str) and (folder / f).is_file()]
    if same and _has_readings(folder, old, m.kind):  # never discard readings: keep them
        from volcal.session.provenance import backup_files

        kept = backup_files(folder, old)
        notes.append(f"the replaced readings of {m.id} are kept in {kept}/")
    entry = m.to_toml()
    if same:
        entries[same[0]] = entry
    else:
        entries.append(entry)
    doc["measurements"] = entries
    _merge_calibration(doc, calibration or {}, notes if header_notes is None else header_notes)
    write_together([(folder / m.file, m.to_csv()), (toml_path, toml_dumps(doc))])


def _merge_calibration(doc: dict[str, Any], found: dict[str, str], notes: list[str]) -> None:
    """Fill ``[calibration]`` keys the document lacks; say where the header differs."""
    from volcal.session.identity import as_date, parse_date

    if not found:
        return
    cal = doc.get("calibration")
    if not isinstance(cal, dict):
        cal = {}
    for k, v in found.items():
        if k not in cal:
            cal[k] = v
            continue
        old = str(parse_date(cal[k])) if k == "date" else str(cal[k])
        same = as_date(old) == as_date(v) if k == "date" else old == v
        if not same:
            notes.append(f"calibration.{k}: the session says {old!r}, this export's header "
                         f"{v!r}; the session's is kept (the export's is recorded in the "
                         "measurement's import table)")
    doc["calibration"] = cal
    order = ["format", "machine", "calibration"]  # the documented order of the tables
    rest = {k: doc[k] for k in doc if k not in order}
    head = {k: doc[k] for k in order if k in doc}
    doc.clear()
    doc.update({**head, **rest})


def _has_readings(folder: Path, files: list[str], kind: str) -> bool:
    """Whether any of ``files`` holds a reading in its kind's value column.

    A file not laid out as the kind's, or that cannot be read, counts as holding readings
    (it is kept). A planned rotary test's file was read by the linear reader, refused, and
    so backed up as "the replaced readings" it never held (session 20).
    """
    import csv

    from volcal.session.kinds import kind_of

    column = kind_of(kind).value_column
    for f in files:
        try:
            with open(folder / f, newline="", encoding="utf-8") as fh:
                rows = list(csv.DictReader(fh))
        except (OSError, UnicodeDecodeError, csv.Error):
            return True
        if not rows or column not in rows[0]:
            return True
        if any((r.get(column) or "").strip() for r in rows):
            return True
    return False


def _check_travel(m: Measurement, travel: NDArray[np.float64], notes: list[str],
                  source: Path | None = None) -> None:
    from volcal.session.checks import travel_margin

    margin = travel_margin(travel)
    out = np.flatnonzero(np.any((m.positions < travel[:, 0] - margin)
                                | (m.positions > travel[:, 1] + margin), axis=1))
    if out.size:  # the session reader would refuse it (docs/formats.md, Plausibility)
        raise VolcalInputError(f"position {m.positions[out[0]].tolist()} mm of reading "
                               f"{out[0] + 1} is outside the session's travel by more than the "
                               f"margin {margin.tolist()} mm: check --line-mm and --units",
                               source or m.meta.get("import", {}).get("source"))
    lo, hi = travel[:, 0] - 1e-9, travel[:, 1] + 1e-9
    bad = np.flatnonzero(np.any((m.positions < lo) | (m.positions > hi), axis=1))
    if bad.size:
        notes.append(f"warning: {bad.size} positions lie outside the session's travel "
                     f"(first: {m.positions[bad[0]].tolist()} mm); check --line-mm and --units")
