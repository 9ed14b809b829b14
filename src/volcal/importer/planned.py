"""Readings of a laser export -> a planned linear, diagonal or step-diagonal measurement.

The plan fixes the poses; the export brings one reading per planned pose, in the planned
order. The file's targets are checked against the plan: a target is the distance of the
pose from the first pose along the beam, ``(p_i - p_0) . b`` [mm] (for a linear test the
travel along the axis, for a diagonal the distance along it); a constant offset (targets
counted from another datum, e.g. machine coordinates of a linear test) is removed and
reported. Step diagonals may also come as one row per step with one column per single-axis
move (``deviation=dX|dY|dZ``, the moves in the plan's ``axis_order``); the first row is the
start (its first cell holds the reference reading, normally 0; the other cells empty or
equal) and may be left out (then the start reading is 0).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.importer.laser_csv import (
    ImportResult,
    LaserTable,
    check_id,
    check_plausible,
    header_meta,
    import_record,
    read_laser_csv,
    write_measurement,
)
from volcal.session.format import Measurement, Session, read_session
from volcal.session.kinds import kind_of

TARGET_TOL_MM = 0.01
"""Largest difference between a file's target and the planned one [mm] (the tolerance of
the session's geometry checks; exports round targets to 3-4 decimals)."""

__all__ = ["TARGET_TOL_MM", "import_planned", "planned_targets"]


def planned_targets(m: Measurement) -> NDArray[np.float64]:
    """Distance of each planned pose from the first along the beam [mm].

    Parameters
    ----------
    m : Measurement
        A planned measurement.

    Returns
    -------
    ndarray, shape (n,)
        ``(p_i - p_0) . b`` with ``b`` the unit beam direction.
    """
    b = m.beam_direction / np.linalg.norm(m.beam_direction)
    return (m.positions - m.positions[0]) @ b


def _find(s: Session, mid: str, folder: Path) -> Measurement:
    every = [*s.measurements, *s.unmeasured]
    for m in every:
        if m.id == mid:
            if m.kind == "multilateration":
                raise VolcalInputError(f"measurement {mid!r} is a multilateration; import "
                                       "tracker readings as its length_mm column",
                                       folder / "session.toml")
            return m
    ids = ", ".join(m.id for m in every)
    raise VolcalInputError(f"--measurement {mid!r}: no such measurement in the session "
                           f"(ids: {ids})"[:400], folder / "session.toml")


def _flatten_steps(t: LaserTable, m: Measurement, path: Path, notes: list[str]) -> LaserTable:
    """Per-step rows -> one reading per planned pose (start + k moves per step)."""
    k_plan = int(np.sum(np.ptp(m.positions, axis=0) > 1e-9))
    if t.steps != k_plan:
        raise VolcalInputError(f"--map names {t.steps} move column(s) but each step of "
                               f"{m.id!r} moves {k_plan} axes (in the order "
                               f"{m.meta.get('axis_order', 'of the plan')})")
    n_steps = (m.n - 1) // k_plan
    rows = t.rows.size // t.steps
    vals = (t.deviation_um if t.reading_mm is None else t.reading_mm).reshape(rows, t.steps)
    tgt = t.target_mm.reshape(rows, t.steps)
    src = np.array(t.sources, dtype=object).reshape(rows, t.steps)
    line = t.rows.reshape(rows, t.steps)
    if rows == n_steps + 1:
        first = vals[0]
        other = first[1:][~np.isnan(first[1:])]
        if np.isnan(first[0]) or np.any(np.abs(other - first[0]) > 1e-9):
            raise VolcalInputError("the start row holds the reference reading in its first "
                                   "move column (the others empty or equal)", path,
                                   int(line[0, 0]), str(src[0, 0]))
        v0, t0, r0, s0 = first[0], tgt[0, -1], line[0, 0], src[0, 0]
        vals, tgt, src, line = vals[1:], tgt[1:], src[1:], line[1:]
    elif rows == n_steps:
        v0, t0, r0, s0 = 0.0, np.nan, line[0, 0], src[0, 0]
        notes.append("no start row: the reading at the start is taken as 0")
    else:
        raise VolcalInputError(f"{rows} rows in the per-step table, but {m.id!r} is planned "
                               f"with {n_steps} steps: expected {n_steps + 1} rows (the start "
                               f"and one per step) or {n_steps}", path)
    flat = np.concatenate([[v0], vals.ravel()])
    reading = None if t.reading_mm is None else flat
    dev = flat if reading is None else np.full(flat.size, np.nan)
    return LaserTable(np.concatenate([[t0], tgt.ravel()]), dev, {}, t.notes,
                      np.concatenate([[r0], line.ravel()]).astype(np.int64),
                      [str(s0), *map(str, src.ravel())], reading, t.steps)


def _check_targets(t: LaserTable, m: Measurement, planned: NDArray[np.float64], path: Path,
                   t_col: str, notes: list[str]) -> float:
    """Compare the file's targets with the plan; return the offset removed [mm]."""
    known = np.flatnonzero(np.isfinite(t.target_mm))
    if known.size == 0:
        return 0.0
    offset = float(t.target_mm[known[0]] - planned[known[0]])
    diff = t.target_mm[known] - offset - planned[known]
    bad = np.flatnonzero(np.abs(diff) > TARGET_TOL_MM)
    if bad.size:
        i = int(known[bad[0]])
        raise VolcalInputError(
            f"target {t.target_mm[i]:g} mm does not match the plan of {m.id!r}: reading {i + 1} "
            f"is planned at {planned[i] + offset:.6g} mm along the beam (tolerance "
            f"{TARGET_TOL_MM:g} mm); is this the right file, --measurement and --units?",
            path, int(t.rows[i]), t_col)
    if abs(offset) > 1e-9:
        notes.append(f"targets counted from {offset:g} mm: offset removed")
    return offset


def _header_of(path: Path, column: str) -> str:
    """The header of ``column`` as written in the export (its unit included)."""
    import re

    from volcal.importer.laser_csv import _decode

    want = column.strip().casefold()
    for line in _decode(path).splitlines()[:200]:
        for field in re.split(r"[,;\t]", line):
            f = field.strip().strip('"')
            name = re.sub(r"\s*[\(\[][^\)\]]*[\)\]]\s*$", "", f).strip().casefold()
            if name == want:
                return f
    return column


def _columns(t: LaserTable, m: Measurement, path: Path) -> dict[str, NDArray[Any]]:
    """The plan's optional columns, with what the file gives; run/direction must agree."""
    cols = dict(m.columns)
    for name, v in t.columns.items():
        if name in t.inferred and name not in cols:
            continue
        if name in ("run", "direction") and name in cols and name not in t.inferred:
            planned = np.asarray(cols[name]).astype(str)
            bad = np.flatnonzero(planned != np.asarray(v).astype(str))
            if bad.size:
                i = int(bad[0])
                raise t.error(f"{name} {v[i]} of reading {i + 1} differs from the plan of "
                              f"{m.id!r} ({planned[i]}): readings must come in the planned "
                              "order", i, path)
        if name in t.inferred and name in cols:
            continue  # the plan knows better than an inference
        cols[name] = v
    return cols


def import_planned(path: str | Path, mapping: dict[str, str], session: str | Path, mid: str,
                   units: str = "auto", deviation_units: str = "auto",
                   replace: bool = False, sign: float = 1.0,
                   slope_removed: bool = False) -> ImportResult:
    """Fill a planned measurement of a session with the readings of a laser export.

    Parameters
    ----------
    path : str or Path
        The export.
    mapping : dict of str to str
        Column mapping (:func:`~volcal.importer.laser_csv.parse_mapping`): long, wide or
        per-step layout.
    session : str or Path
        Existing session folder.
    mid : str
        Id of the planned measurement (``diag-ppp``, ``step-npp``, ``linear-x1``...).
    units, deviation_units : str
        See :func:`~volcal.importer.laser_csv.read_laser_csv`.
    replace : bool
        Replace readings the measurement already has (they are kept in ``backup/``).
    sign : float
        +1, or -1 for a direct optic that reports the workpiece side relative to the tool
        side (:mod:`volcal.importer.optics`).
    slope_removed : bool
        A straightness export whose slope the instrument took out (recorded in the
        session; refused for a line of a reference group).

    Returns
    -------
    ImportResult

    Raises
    ------
    VolcalInputError
        No such measurement; a row count or target that does not match the plan, a
        run/direction out of the planned order, an absurd value: naming file, row and
        column.
    """
    path, folder = Path(path), Path(session)
    check_id(mid, "--measurement")
    if not (folder / "session.toml").is_file():
        raise VolcalInputError("--measurement needs an existing session (volcal plan writes "
                               "one)", folder)
    m = _find(read_session(folder, require_deviation=False), mid, folder)
    if m.kind == "rotary":  # angles against target angles (volcal.importer.rotary)
        from volcal.importer.rotary import import_rotary_planned

        return import_rotary_planned(path, mapping, folder, mid, units, deviation_units,
                                     replace, sign)
    if m.deviation is not None and not replace:
        raise VolcalInputError(f"measurement {mid!r} has readings; give --replace to replace "
                               "them (the old ones are kept in backup/)", folder / "session.toml")
    angle = None
    if kind_of(m.kind).value_unit == "urad":  # readings in an angle unit: to urad below
        from volcal.importer.optics import angle_unit

        t = read_laser_csv(path, mapping, units, "um")
        head = mapping.get("deviation", "")
        angle = angle_unit(deviation_units, _header_of(path, head))
    else:
        t = read_laser_csv(path, mapping, units, deviation_units)
    if sign != 1.0 and m.kind not in ("straightness", "angular"):
        raise VolcalInputError("--sign is for direct optics (straightness, angular)")
    if slope_removed and m.kind != "straightness":
        raise VolcalInputError("--slope-removed is for straightness measurements")
    if slope_removed and m.meta.get("reference"):
        raise VolcalInputError(f"{mid!r} belongs to the reference group "
                               f"{m.meta['reference']!r}: slope-removed data cannot (the group "
                               "relates the slopes)", folder / "session.toml")
    notes = list(t.notes)
    if t.steps:
        header, header_notes = t.header, t.header_notes
        t = _flatten_steps(t, m, path, notes)
        t.header, t.header_notes = header, header_notes
    if t.deviation_um.size != m.n:
        extra = t.deviation_um.size > m.n
        raise VolcalInputError(f"{t.deviation_um.size} readings in the file, but {mid!r} is "
                               f"planned with {m.n}: one reading per planned pose, in the "
                               "planned order", path, int(t.rows[m.n]) if extra else None)
    planned = planned_targets(m)
    offset = _check_targets(t, m, planned, path, mapping["target"], notes)
    if t.reading_mm is not None:  # deviation = reading - commanded (the plan's) target
        t.deviation_um = (t.reading_mm - offset - planned) * 1000.0
    empty = np.flatnonzero(np.isnan(t.deviation_um))
    if empty.size:
        raise t.error("empty field: expected a number", int(empty[0]), path)
    if angle is not None:
        from volcal.importer.optics import ANGLE_TO_URAD

        t.deviation_um = t.deviation_um * ANGLE_TO_URAD[angle]
        notes[:] = [n for n in notes if not n.startswith("deviation column")]
        notes.append(f"angle column {head!r}: {angle} -> urad")
    if sign != 1.0:
        t.deviation_um = -t.deviation_um + 0.0  # no -0
        notes.append("sign reversed (--sign -): the export reads the workpiece side relative "
                     "to the tool side")
    check_plausible(t, path)
    dev = t.deviation_um
    cols = _columns(t, m, path)
    unused = [c for c in t.inferred if c not in m.columns]
    notes[:] = [n for n in notes if not (unused and "inferred from" in n)]
    meta = header_meta(t, {**m.meta, "import": import_record(path, mapping, notes, t)})
    if slope_removed:
        meta["slope_removed"] = True
    new = Measurement(m.id, m.kind, m.target, m.positions, dev, m.beam_direction,
                      m.tool_offset, m.file, cols, meta)
    hnotes = list(t.header_notes)
    write_measurement(folder, new, True, notes, t.calibration, hnotes)
    return ImportResult(new, folder, False, notes, [f.describe() for f in t.header], hnotes)
