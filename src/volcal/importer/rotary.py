"""Rotary exports (a rotary calibrator's or an index table's test) -> a ``rotary`` measurement.

The laser software exports a rotary test as a table: the target angle [deg], the run, the
direction and the error, or the actual angle; one reading per line (``--map
target=Target,run=Run,direction=Dir,deviation=Error``) or one column per run (a wide
table, ``deviation=Run*``), as for linear tests (:mod:`volcal.importer.laser_csv`, whose
table reader, delimiter and decimal-comma handling, run and direction inference are used
here). Targets are degrees (``--units deg`` or ``auto``); the error is an angle in urad,
arcsec, deg, mrad (``--deviation-units``, or the header's ``Error (arcsec)``); a
``reading=`` column is the actual angle [deg] and the deviation is reading - target.
The deviation is actual - commanded angle, positive counter-clockwise looking from the
positive end of the axis (ISO 841, ``docs/conventions.md``); an export of the opposite
sign (commanded - actual, or clockwise positive) is read with ``--sign -``.

Either the readings of a planned rotary measurement (``--measurement rotary-c``: the
targets must match the plan's, in its order) or a new rotary measurement (``--axis c
--id ...``; its range is the targets' span, a full circle when they span 360 deg).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.importer.laser_csv import (
    ImportResult,
    check_id,
    header_meta,
    import_record,
    layout_of,
    read_laser_csv,
    write_measurement,
)
from volcal.importer.optics import ANGLE_TO_URAD, angle_unit
from volcal.session.format import Measurement, Session, read_session, write_session

__all__ = ["TARGET_TOL_DEG", "import_rotary_new", "import_rotary_planned", "read_rotary_export"]

TARGET_TOL_DEG = 0.0015
"""Largest difference between an export's target and the plan's [deg] (the programs write
0.001 deg)."""

_DEG = re.compile(r"[\(\[]\s*(deg|degree|degrees|°)\s*[\)\]]\s*$|[_\s](deg)\s*$", re.I)
_BRACKET = re.compile(r"[\(\[]\s*([^\)\]]+?)\s*[\)\]]\s*$")


def _header_of(path: Path, column: str) -> str:
    """The header of ``column`` as written in the export (its unit included)."""
    from volcal.importer.laser_csv import _decode

    want = column.strip().casefold()
    for line in _decode(path).splitlines()[:200]:
        for cell in re.split(r"[,;\t]", line):
            f = cell.strip().strip('"')
            name = re.sub(r"\s*[\(\[][^\)\]]*[\)\]]\s*$", "", f).strip().casefold()
            if name == want:
                return f
    return column


def read_rotary_export(path: str | Path, mapping: dict[str, str], units: str = "auto",
                       deviation_units: str = "auto", sign: float = 1.0
                       ) -> tuple[Any, NDArray[np.float64], NDArray[np.float64], list[str]]:
    """Read a rotary export: targets [deg], deviations [urad], notes.

    Parameters
    ----------
    path : str or Path
        The export.
    mapping : dict of str to str
        Column mapping, long or wide (:func:`volcal.importer.laser_csv.parse_mapping`).
    units : str
        Unit of the target (and reading) columns: ``deg`` or ``auto``.
    deviation_units : str
        Unit of the error columns: ``urad``, ``arcsec``, ``deg``, ``mrad`` or ``auto``
        (the header's).
    sign : float
        -1 for an export of the opposite sign.

    Returns
    -------
    table : LaserTable
        The export as read (columns ``run``, ``direction``...).
    target_deg : ndarray
    deviation_urad : ndarray
    notes : list of str

    Raises
    ------
    VolcalInputError
        Naming the file, row and column.
    """
    path = Path(path)
    if units not in ("auto", "deg"):
        raise VolcalInputError(f"--units {units!r}: the targets of a rotary test are angles "
                               "in deg (or auto)", path, None, "units")
    if layout_of(mapping) == "steps":
        raise VolcalInputError("--map: a per-step table (A|B|C) is a step diagonal, not a "
                               "rotary test", path)
    thead = _header_of(path, mapping["target"])
    m = _BRACKET.search(thead)
    if m and not _DEG.search(thead):
        raise VolcalInputError(f"the target column {thead!r} names the unit {m.group(1)!r}: a "
                               "rotary test's targets are degrees", path, None, mapping["target"])
    t = read_laser_csv(path, mapping, "mm", "mm")  # raw numbers: the units are angles here
    notes = [n for n in t.notes if not n.startswith(("target column", "deviation column",
                                                     "reading column"))]
    notes.append(f"target column {thead!r}: deg")
    target = np.asarray(t.target_mm, dtype=float)
    if "reading" in mapping:
        rhead = _header_of(path, mapping["reading"])
        rm = _BRACKET.search(rhead)
        if rm and not _DEG.search(rhead):
            raise VolcalInputError(f"the reading column {rhead!r} names the unit "
                                   f"{rm.group(1)!r}: an actual angle is read in deg", path,
                                   None, mapping["reading"])
        assert t.reading_mm is not None
        dev = (np.asarray(t.reading_mm, dtype=float) - target) * ANGLE_TO_URAD["deg"]
        notes.append(f"reading column {rhead!r}: actual angle [deg]; deviation = reading - "
                     "target -> urad")
    else:
        col = mapping["deviation"]
        head = _header_of(path, col) if layout_of(mapping) == "long" else t.sources[0]
        u = angle_unit(deviation_units, head)
        dev = np.asarray(t.deviation_um, dtype=float) / 1000.0 * ANGLE_TO_URAD[u]
        notes.append(f"deviation column {head!r}: {u} -> urad")
    if sign != 1.0:
        dev = -dev + 0.0
        notes.append("sign reversed (--sign -): the export's deviation is commanded - actual "
                     "or clockwise positive")
    bad = np.flatnonzero(~np.isfinite(dev) | (np.abs(dev) > 1e5))
    if bad.size:
        i = int(bad[0])
        raise t.error("deviation missing or beyond 0.1 rad: not a rotary reading (units?)", i,
                      path)
    return t, target, dev, notes


def import_rotary_planned(path: str | Path, mapping: dict[str, str], session: str | Path,
                          mid: str, units: str = "auto", deviation_units: str = "auto",
                          replace: bool = False, sign: float = 1.0) -> ImportResult:
    """Fill a planned rotary measurement with the readings of an export.

    Parameters
    ----------
    path : str or Path
        The export.
    mapping : dict of str to str
        Column mapping.
    session : str or Path
        The session folder.
    mid : str
        Id of the planned rotary measurement.
    units, deviation_units : str
        See :func:`read_rotary_export`.
    replace : bool
        Replace readings it already has (kept in ``backup/``).
    sign : float
        -1 for an export of the opposite sign.

    Returns
    -------
    ImportResult
    """
    path, folder = Path(path), Path(session)
    check_id(mid, "--measurement")
    s = read_session(folder, require_deviation=False)
    m = next((x for x in s.measurements if x.id == mid), None)
    if m is None or m.kind != "rotary":
        raise VolcalInputError(f"no rotary measurement {mid!r} in the session", folder)
    if m.deviation is not None and not replace:
        raise VolcalInputError(f"measurement {mid!r} has readings; give --replace to replace "
                               "them (the old ones are kept in backup/)", folder / "session.toml")
    t, target, dev, notes = read_rotary_export(path, mapping, units, deviation_units, sign)
    if dev.size != m.n:
        raise VolcalInputError(f"{dev.size} readings in the file, but {mid!r} is planned with "
                               f"{m.n}: one reading per planned target, in the planned order",
                               path, int(t.rows[m.n]) if dev.size > m.n else None)
    planned = np.asarray(m.columns["target_deg"], dtype=float)
    off = np.abs(target - planned)
    bad = np.flatnonzero(np.minimum(off, np.abs(off - 360.0)) > TARGET_TOL_DEG)
    if bad.size:
        i = int(bad[0])
        raise VolcalInputError(f"target {target[i]:g} deg does not match the plan of {mid!r}: "
                               f"reading {i + 1} is planned at {planned[i]:g} deg", path,
                               int(t.rows[i]), mapping["target"])
    cols = dict(m.columns)
    for name in ("run", "direction"):
        if name in t.columns and name not in t.inferred:
            got = np.asarray(t.columns[name]).astype(str)
            want = np.asarray(cols[name]).astype(str)
            diff = np.flatnonzero(got != want)
            if diff.size:
                i = int(diff[0])
                raise t.error(f"{name} {got[i]} of reading {i + 1} differs from the plan of "
                              f"{mid!r} ({want[i]}): readings must come in the planned order",
                              i, path)
    if "time_s" in t.columns:
        cols["time_s"] = t.columns["time_s"]
    meta = header_meta(t, {**m.meta, "import": import_record(path, mapping, notes, t)})
    new = Measurement(m.id, m.kind, m.target, m.positions, dev, m.beam_direction,
                      m.tool_offset, m.file, cols, meta)
    hnotes = list(t.header_notes)
    write_measurement(folder, new, True, notes, t.calibration, hnotes)
    return ImportResult(new, folder, False, notes, [f.describe() for f in t.header], hnotes)


def import_rotary_new(path: str | Path, mapping: dict[str, str], axis: str,
                      session: str | Path, mid: str, units: str = "auto",
                      deviation_units: str = "auto", target: str = "rotary_calibrator",
                      travel: Any = None, chain: str = "XYFZ", name: str = "machine",
                      replace: bool = False, sign: float = 1.0) -> ImportResult:
    """A new rotary measurement of axis ``axis`` from an export.

    Parameters
    ----------
    path : str or Path
        The export.
    mapping : dict of str to str
        Column mapping.
    axis : str
        ``'a'``, ``'b'`` or ``'c'``.
    session : str or Path
        Session folder (created with ``travel`` when missing).
    mid : str
        Measurement id.
    units, deviation_units : str
        See :func:`read_rotary_export`.
    target : str
        ``'rotary_calibrator'`` or ``'index_table'``.
    travel : array_like, shape (3, 2), optional
        Travel of a new session [mm].
    chain, name : str
        Chain and machine name of a new session.
    replace : bool
        Replace a measurement with this id.
    sign : float
        -1 for an export of the opposite sign.

    Returns
    -------
    ImportResult
    """
    from volcal.session.rotary import check_rotary_keys, read_rotary_axes

    check_id(mid)
    ax = axis.lower()
    t, tgt, dev, notes = read_rotary_export(path, mapping, units, deviation_units, sign)
    lo, hi = float(np.min(tgt)), float(np.max(tgt))
    modulo = hi - lo >= 360.0 - 1e-9
    rng = [0.0, 360.0] if modulo and lo >= 0 and hi <= 360 else [lo, hi]
    meta: dict[str, Any] = {"axis": ax, "range_deg": rng, "modulo": modulo,
                            "mounting": "on_axis",
                            "notes": f"imported from {Path(path).name}",
                            "import": import_record(path, mapping, notes, t)}
    folder = Path(session)
    exists = (folder / "session.toml").is_file()
    axes = read_rotary_axes(read_session(folder, require_deviation=False).meta,
                            folder / "session.toml") if exists else []
    known = next((a for a in axes if a.name == ax), None)
    if known is not None:
        meta["range_deg"], meta["modulo"] = list(known.range_deg), known.modulo
    check_rotary_keys(meta, path, "import", axes)
    cols: dict[str, NDArray[Any]] = {"target_deg": tgt}
    cols.update({k: v for k, v in t.columns.items() if k in ("run", "direction", "time_s")})
    m = Measurement(mid, "rotary", target, np.zeros((tgt.size, 3)), dev,
                    np.eye(3)["abc".index(ax)], np.zeros(3), f"{mid}.csv", cols,
                    header_meta(t, meta))
    said = [f.describe() for f in t.header]
    if not exists:
        if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
            raise VolcalInputError("not a session folder (no session.toml) and not empty",
                                   folder)
        if travel is None:
            raise VolcalInputError("a new session needs --travel xmin:xmax,ymin:ymax,"
                                   "zmin:zmax", folder)
        s = Session(name, chain, np.asarray(travel, dtype=float).reshape(3, 2), [m],
                    {"rotary_axes": [{"name": ax, "range_deg": meta["range_deg"],
                                      "modulo": meta["modulo"]}]},
                    calibration=dict(t.calibration))
        write_session(s, folder)
        return ImportResult(m, folder, True, notes, said, list(t.header_notes))
    hnotes = list(t.header_notes)
    write_measurement(folder, m, replace, notes, t.calibration, hnotes)
    return ImportResult(m, folder, False, notes, said, hnotes)
