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

import csv
import io
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.importer.units import TO_MM, unit_from_header, unit_name, unsupported_unit
from volcal.io.atomic import write_text
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.io.values import parse_finite
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
                                                                     "time_s")])
"""Mapping keys: what a column holds."""

_DIRECTIONS = {"+": "+", "-": "-", "up": "+", "down": "-", "fwd": "+", "bwd": "-",
               "forward": "+", "backward": "-", "forwards": "+", "backwards": "-",
               "pos": "+", "neg": "-", "positive": "+", "negative": "-", "1": "+", "-1": "-",
               "f": "+", "b": "-", "+1": "+", "increasing": "+", "decreasing": "-"}
MAX_BYTES = 50_000_000
_RUN = re.compile(r"^\+?\d{1,9}([.,]0*)?$")


def parse_mapping(text: str) -> dict[str, str]:
    """Parse ``'target=Pos,run=Run,deviation=Err'`` into {key: column header}.

    Parameters
    ----------
    text : str
        The ``--map`` option: comma-separated ``key=column header`` pairs; keys are
        case-insensitive and taken from :data:`KEYS`.

    Returns
    -------
    dict of str to str
        Lower-case key to the column header of the laser file.

    Raises
    ------
    VolcalInputError
        Unknown keys, missing target, both or neither of deviation and reading.
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
    return out


@dataclass
class LaserTable:
    """Columns read from a laser export.

    Attributes
    ----------
    target_mm : ndarray
        Target positions [mm] (as in the file, converted).
    deviation_um : ndarray
        Deviations [um].
    columns : dict
        Optional session columns (``run``, ``direction``, ``time_s``, environment).
    notes : list of str
        What was detected (units, delimiter, skipped lines).
    """

    target_mm: NDArray[np.float64]
    deviation_um: NDArray[np.float64]
    columns: dict[str, NDArray[Any]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


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


def _norm(h: str) -> str:
    h = h.strip().strip('"').strip()
    for open_, close in (("(", ")"), ("[", "]")):
        if h.endswith(close) and open_ in h:
            h = h[: h.rindex(open_)].strip()
    return h.casefold()


def _find(header: list[str], name: str) -> int | None:
    for f in (lambda s: s.strip(), lambda s: s.strip().casefold(), _norm):
        hits = [i for i, h in enumerate(header) if f(h) == f(name)]
        if len(hits) == 1:
            return hits[0]
        if len(hits) > 1:
            return None
    return None


def _number(text: str, decimal_comma: bool, path: Path, row: int, col: str) -> float:
    t = text.strip().replace("\u2212", "-")
    if decimal_comma:
        t = t.replace(",", ".")
    return parse_finite(t, path, row, col)


def _unit(option: str | None, header: str, fallback: str | None, what: str, notes: list[str],
          path: Path, col: str) -> str:
    found = unit_from_header(header)
    if option not in (None, "auto"):
        u = unit_name(option, f"--{what}-units" if what != "target" else "--units")
        if found is not None and found != u:
            raise VolcalInputError(f"header says {found} but --units says {u}", path, 1, col)
        notes.append(f"{what} column '{header}': {u} (given)")
        return u
    if found is not None:
        notes.append(f"{what} column '{header}': {found} (detected from the header)")
        return found
    other = unsupported_unit(header)
    if other is not None:
        raise VolcalInputError(f"the header names the unit {other!r}, which volcal does not "
                               f"read; convert to one of {', '.join(TO_MM)}", path, 1, col)
    if fallback is None:
        raise VolcalInputError(f"no unit in the header; give the unit of the {what} column",
                               path, 1, col)
    notes.append(f"{what} column '{header}': {fallback} (assumed; no unit in the header)")
    return fallback


def read_laser_csv(path: str | Path, mapping: dict[str, str], units: str = "auto",
                   deviation_units: str = "auto") -> LaserTable:
    """Read the mapped columns of a laser CSV export.

    Parameters
    ----------
    path : str or Path
        The export.
    mapping : dict of str to str
        From :func:`parse_mapping`.
    units : str
        Unit of the target and reading columns: ``mm``, ``um``, ``in`` or ``auto``
        (header, else mm).
    deviation_units : str
        Unit of the deviation column: ``um``, ``nm``, ``mm``, ``in``, ``uin`` or ``auto``
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
    text = _decode(path)
    lines = text.splitlines()
    sample = "\n".join(lines[:50])
    try:
        delim = csv.Sniffer().sniff(sample, delimiters=",;\t").delimiter
    except csv.Error:
        delim = ","
    try:
        rows = list(csv.reader(io.StringIO(text), delimiter=delim))
    except csv.Error as exc:
        raise VolcalInputError(f"malformed CSV: {exc}", path) from None
    head_i = None
    for i, r in enumerate(rows[:200]):
        if all(_find(r, c) is not None for c in mapping.values()):
            head_i = i
            break
    if head_i is None:
        first = next((r for r in rows if any(c.strip() for c in r)), [])
        missing = [c for c in mapping.values() if _find(first, c) is None]
        raise VolcalInputError(f"no header line with the mapped columns (missing "
                               f"{', '.join(repr(m) for m in missing)}; first line: "
                               f"{delim.join(first)[:120]!r})", path, 1,
                               missing[0] if missing else None)
    header = rows[head_i]
    idx = {k: _find(header, c) for k, c in mapping.items()}
    notes = [f"header on line {head_i + 1}, delimiter {delim!r}"]
    decimal_comma = delim != ","
    t_col, t_head = mapping["target"], header[idx["target"]]
    tu = _unit(units, t_head, "mm", "target", notes, path, t_col)
    dkey = "deviation" if "deviation" in mapping else "reading"
    d_head = header[idx[dkey]]
    if dkey == "deviation":
        du = _unit(deviation_units, d_head, "um" if tu in ("mm", "um") else None, "deviation",
                   notes, path, mapping[dkey])
    else:
        du = _unit(units if unit_from_header(d_head) is None else "auto", d_head, tu, "reading",
                   notes, path, mapping[dkey])
    data = [(i + 1, r) for i, r in enumerate(rows) if i > head_i and any(c.strip() for c in r)]
    if len(data) < MIN_ROWS:
        raise VolcalInputError(f"need at least {MIN_ROWS} data lines, found {len(data)}", path,
                               data[-1][0] + 1 if data else head_i + 2)
    n = len(data)
    target = np.empty(n)
    dev = np.empty(n)
    cols: dict[str, list[Any]] = {}
    for j, (line, r) in enumerate(data):
        if len(r) < len(header):
            raise VolcalInputError(f"expected {len(header)} fields, found {len(r)}", path, line)
        t = _number(r[idx["target"]], decimal_comma, path, line, t_col) * TO_MM[tu]
        d = _number(r[idx[dkey]], decimal_comma, path, line, mapping[dkey]) * TO_MM[du]
        target[j] = t
        dev[j] = (d - t if dkey == "reading" else d) * 1000.0
        for key in mapping:
            if key in ("target", "deviation", "reading"):
                continue
            cell = r[idx[key]].strip()
            name = "time_s" if key == "time" else key
            if key == "run":
                if not _RUN.match(cell):
                    raise VolcalInputError(f"run must be a whole number >= 0, got {cell!r}",
                                           path, line, mapping[key])
                v: Any = int(cell.split(".")[0].split(",")[0])
            elif key == "direction":
                v = _DIRECTIONS.get(cell.casefold())
                if v is None:
                    raise VolcalInputError(f"unknown direction {cell!r}: expected +/-, up/down, "
                                           "forward/backward", path, line, mapping[key])
            else:
                v = _number(cell, decimal_comma, path, line, mapping[key])
            cols.setdefault(name, []).append(v)
    out = {k: np.array(v, dtype=int if k == "run" else (str if k == "direction" else float))
           for k, v in cols.items()}
    if "direction" not in out:
        out["direction"] = _infer_directions(target)
        notes.append("approach directions inferred from the order of the targets")
        if "run" not in out:
            out["run"] = _infer_runs(out["direction"])
            notes.append(f"{int(out['run'].max())} run(s) inferred from the direction changes "
                         "(a run is one + pass and one - pass)")
    if "run" in out:  # ISO 230-2: each target once per run and direction
        seen: dict[tuple[float, int, str], int] = {}
        for j, key in enumerate(zip(target.round(9), out["run"], out["direction"], strict=True)):
            if key in seen:
                raise VolcalInputError(
                    f"target {key[0]:g} mm appears twice in run {key[1]} direction {key[2]} "
                    f"(also on line {seen[key]}): a duplicated line?", path, data[j][0], t_col)
            seen[key] = data[j][0]
    return LaserTable(target, dev, out, notes)


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
    """What ``import_csv`` did: the measurement, the session folder, notes for the user."""

    measurement: Measurement
    session: Path
    created: bool
    notes: list[str]


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
        Column mapping (:func:`parse_mapping`).
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
    ax = axis.strip().upper()
    if ax not in AXES or len(ax) != 1:
        raise VolcalInputError(f"--axis {axis!r}: expected X, Y or Z")
    if not mid or not all(c.isalnum() or c in "-_" for c in mid) or not mid[0].isalnum():
        raise VolcalInputError(f"--id {mid!r}: use letters, digits, '-' and '_'")
    if target not in TARGETS:
        raise VolcalInputError(f"--optics {target!r}: expected one of {', '.join(TARGETS)}")
    line = np.asarray(line_mm, dtype=float).reshape(3)
    k = AXES.index(ax)
    table = read_laser_csv(path, mapping, units, deviation_units)
    from volcal.session.format import DEVIATION_ABS_MAX_UM

    big = np.flatnonzero(np.abs(table.deviation_um) > DEVIATION_ABS_MAX_UM)
    if big.size:  # never write a session file its reader refuses (docs/formats.md)
        col = mapping.get("deviation") or mapping.get("reading")
        raise VolcalInputError(
            f"deviation {table.deviation_um[big[0]]:.6g} um of reading {big[0] + 1} is absurd "
            f"(> {DEVIATION_ABS_MAX_UM:g} um): wrong units, or a column that is not the "
            "laser's reading?", path, None, col)
    pos = np.tile(line, (table.target_mm.size, 1))
    pos[:, k] = line[k] + table.target_mm
    beam = np.zeros(3)
    beam[k] = 1.0
    meta: dict[str, Any] = {"axis": ax, "line_mm": [float(v) for v in line],
                            "notes": f"imported from {Path(path).name}",
                            "import": {"source": Path(path).name, "mapping": mapping,
                                       "units": "; ".join(table.notes)}}
    m = Measurement(mid, "linear", target, pos, table.deviation_um, beam,
                    np.asarray(tool_offset, dtype=float), f"{mid}.csv", table.columns, meta)
    folder = Path(session)
    notes = list(table.notes)
    if not (folder / "session.toml").is_file():
        if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
            raise VolcalInputError("not a session folder (no session.toml) and not empty", folder)
        if travel is None:
            raise VolcalInputError("a new session needs --travel xmin:xmax,ymin:ymax,zmin:zmax",
                                   folder)
        travel = np.asarray(travel, dtype=float).reshape(3, 2)
        if not np.all(np.isfinite(travel)) or np.any(travel[:, 1] <= travel[:, 0]):
            raise VolcalInputError("--travel: every axis needs finite min < max [mm]")
        s = Session(name, chain, travel, [m])
        _check_travel(m, s.travel, notes, Path(path))
        write_session(s, folder)
        return ImportResult(m, folder, True, notes)
    s = read_session(folder, require_deviation=False)
    _check_travel(m, s.travel, notes, Path(path))
    toml_path = folder / "session.toml"
    doc = tomllib.loads(toml_path.read_text(encoding="utf-8"))
    entries = doc.get("measurements", [])
    same = [i for i, e in enumerate(entries) if e.get("id") == mid]
    if same and not replace:
        raise VolcalInputError(f"measurement {mid!r} exists; choose another --id or --replace",
                               toml_path)
    others = {e.get("file") for i, e in enumerate(entries) if i not in same}
    if m.file in others:
        raise VolcalInputError(f"file {m.file!r} belongs to another measurement", toml_path)
    old_files = {e.get("file") for i, e in enumerate(entries) if i in same}
    if (folder / m.file).exists() and m.file not in old_files:
        raise VolcalInputError(f"{m.file!r} exists in the session and is not a measurement's "
                               "file: choose another --id (nothing is overwritten)", toml_path)
    old = [f for f in old_files if isinstance(f, str) and (folder / f).is_file()]
    had_readings = [m0.id for m0 in s.measurements if m0.id == mid and m0.deviation is not None]
    if had_readings:  # never discard readings: keep the replaced files
        from volcal.session.provenance import backup_files

        kept = backup_files(folder, old)
        notes.append(f"the replaced readings of {mid} are kept in {kept}/")
    entry = m.to_toml()
    if same:
        entries[same[0]] = entry
    else:
        entries.append(entry)
    doc["measurements"] = entries
    write_text(folder / m.file, m.to_csv())
    write_text(toml_path, toml_dumps(doc))
    return ImportResult(m, folder, False, notes)


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
