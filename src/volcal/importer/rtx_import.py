"""A Renishaw dynamic capture (``.rtx``) -> the readings of a planned measurement.

The capture's dwells (:func:`volcal.importer.rtx.find_dwells`), one per planned pose in the
planned order, give one reading each: the mean of the dwell's samples. Readings are
counted from the first dwell (the session's readings are changes since the first row).

* linear, diagonal, step diagonal: the samples are the laser's displacement (mm by
  default, ``--units``); the deviation is the displacement minus the planned travel along
  the beam, which it must match within :data:`TARGET_TOL_MM` (a wrong file or order);
* straightness: the samples are the straightness displacement (mm, ``--deviation-units``);
* angular: the samples are the angle (mrad, ``--deviation-units``), converted to urad.

``--sign -`` and ``--slope-removed`` as for CSV exports of direct optics.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from volcal.errors import VolcalInputError
from volcal.importer.laser_csv import ImportResult, check_id, write_measurement
from volcal.session.format import Measurement

__all__ = ["DEFAULT_DWELL_S", "TARGET_TOL_MM", "import_rtx"]

DEFAULT_DWELL_S = 4.0
"""The part programs' default dwell at each target [s] (``volcal program --dwell-s``)."""

TARGET_TOL_MM = 1.0
"""Largest difference between a dwell's displacement and the planned travel [mm]: far
above any machine's deviation, far below a target spacing (a wrong file or pose order)."""


def _length_unit(option: str) -> str:
    from volcal.importer.units import TO_MM, unit_name

    if option in (None, "auto"):
        return "mm"
    u = unit_name(option)
    if u not in TO_MM:
        raise VolcalInputError(f"unit {option!r}: expected one of {', '.join(TO_MM)}")
    return u


def import_rtx(path: str | Path, session: str | Path, mid: str, units: str = "auto",
               deviation_units: str = "auto", replace: bool = False, sign: float = 1.0,
               slope_removed: bool = False, dwell_s: float = DEFAULT_DWELL_S) -> ImportResult:
    """Fill a planned measurement with the dwell means of a dynamic capture.

    Parameters
    ----------
    path : str or Path
        The ``.rtx`` file.
    session : str or Path
        Existing session folder.
    mid : str
        Id of the planned measurement.
    units : str
        Unit of a displacement capture (linear, diagonal, step diagonal): ``auto`` (mm,
        the capture's unit), ``mm``, ``um``, ``in``...
    deviation_units : str
        Unit of a straightness capture (``auto``: mm) or an angle capture (``auto``: mrad;
        ``urad``, ``arcsec``, ``mm/m``...).
    replace : bool
        Replace readings the measurement already has (kept in ``backup/``).
    sign : float
        +1, or -1 for an optic that reads the workpiece side relative to the tool side.
    slope_removed : bool
        The straightness had its slope taken out (recorded; refused in a reference group).
    dwell_s : float
        The part program's dwell at each target [s].

    Returns
    -------
    ImportResult

    Raises
    ------
    VolcalInputError
        No such measurement, readings there without ``replace``, another number of dwells
        than planned poses, a displacement that does not follow the plan, an absurd value.
    """
    from volcal.importer.optics import ANGLE_TO_URAD, angle_unit
    from volcal.importer.planned import _find, planned_targets
    from volcal.importer.rtx import dwell_readings, read_rtx
    from volcal.importer.units import TO_MM
    from volcal.session.format import DEVIATION_ABS_MAX_UM, read_session

    path, folder = Path(path), Path(session)
    check_id(mid, "--measurement")
    if not (folder / "session.toml").is_file():
        raise VolcalInputError("--measurement needs an existing session (volcal plan writes "
                               "one)", folder)
    if not np.isfinite(dwell_s) or dwell_s <= 0:
        raise VolcalInputError(f"--dwell-s {dwell_s}: expected the part program's dwell > 0 s")
    m = _find(read_session(folder, require_deviation=False), mid, folder)
    if m.deviation is not None and not replace:
        raise VolcalInputError(f"measurement {mid!r} has readings; give --replace to replace "
                               "them (the old ones are kept in backup/)", folder / "session.toml")
    direct = m.kind in ("straightness", "angular")
    if sign != 1.0 and not direct:
        raise VolcalInputError("--sign is for direct optics (straightness, angular)")
    if slope_removed and m.kind != "straightness":
        raise VolcalInputError("--slope-removed is for straightness measurements")
    if slope_removed and m.meta.get("reference"):
        raise VolcalInputError(f"{mid!r} belongs to the reference group "
                               f"{m.meta['reference']!r}: slope-removed data cannot (the group "
                               "relates the slopes)", folder / "session.toml")
    cap = read_rtx(path)
    dwells = dwell_readings(cap, m.n, dwell_s, path)
    v = np.array([d.mean for d in dwells])
    v = v - v[0]
    notes = list(cap.notes)
    notes.append(f"dynamic capture: {cap.samples.size} samples at {cap.rate_hz:g} Hz, {m.n} "
                 f"dwells (--dwell-s {dwell_s:g}), readings = dwell means counted from the "
                 "first")
    if m.kind == "angular":
        u = angle_unit(deviation_units, "(mrad)")
        dev = v * ANGLE_TO_URAD[u]
        notes.append(f"angle samples: {u} -> urad")
    elif m.kind == "straightness":
        u = _length_unit(deviation_units)
        dev = v * TO_MM[u] * 1000.0
        notes.append(f"straightness samples: {u} -> um")
    else:
        u = _length_unit(units)
        planned = planned_targets(m)
        moved = v * TO_MM[u]
        diff = moved - (planned - planned[0])
        bad = np.flatnonzero(np.abs(diff) > TARGET_TOL_MM)
        if bad.size:
            i = int(bad[0])
            raise VolcalInputError(
                f"dwell {i + 1} (at {dwells[i].time_s:.1f} s) reads {moved[i]:.6g} mm from the "
                f"first, but {mid!r} is planned {planned[i] - planned[0]:.6g} mm along the beam "
                f"there (tolerance {TARGET_TOL_MM:g} mm): is this the right file, "
                "--measurement and --units (or the laser's direction setting)?", path)
        dev = diff * 1000.0
        notes.append(f"displacement samples: {u}; deviation = displacement - planned travel")
    if sign != 1.0:
        dev = -dev + 0.0
        notes.append("sign reversed (--sign -): the capture reads the workpiece side relative "
                     "to the tool side")
    big = np.flatnonzero(np.abs(dev) > DEVIATION_ABS_MAX_UM)
    if big.size:
        i = int(big[0])
        raise VolcalInputError(f"reading {dev[i]:.6g} of dwell {i + 1} (at {dwells[i].time_s:.1f}"
                               f" s) is absurd (> {DEVIATION_ABS_MAX_UM:g}): wrong units?", path)
    cols = dict(m.columns)
    cols["time_s"] = np.array([d.time_s for d in dwells])
    record = {"source": path.name, "layout": "rtx", "units": "; ".join(notes),
              "sample_rate_hz": cap.rate_hz, "dwell_s": float(dwell_s)}
    for key, name in (("Date", "date_text"), ("By", "operator"), ("Serial No", "serial_no")):
        if cap.header.get(key):
            record[name] = cap.header[key]
    meta = {**m.meta, "import": record}
    if slope_removed:
        meta["slope_removed"] = True
    new = Measurement(m.id, m.kind, m.target, m.positions, dev, m.beam_direction,
                      m.tool_offset, m.file, cols, meta)
    write_measurement(folder, new, True, notes)
    header = [f"{k}: {cap.header[k]}" for k in ("Owner", "Version no", "Date", "By", "Axis")
              if cap.header.get(k)]
    return ImportResult(new, folder, False, notes, header, [])
