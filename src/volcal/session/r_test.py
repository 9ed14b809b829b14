"""R-test readings in a session: the entry's keys and its CSV file.

An ``r_test`` measurement holds, at each pose of a path of the rotary axes (the linear
axes following so that the configured kinematics keep the nominal sphere centre at the
nest), the displacement of a precision sphere on the table relative to the nest of three
displacement sensors on the spindle (Weikert 2004; ISO 10791-6:2014, annex; Ibaraki et
al. 2010). ``docs/formats.md`` ("R-test measurements") documents it:

* keys: those of a ``probe_sphere`` test (``chain``, ``pivot_mm``, ``sphere_mm``,
  ``sphere``, ``noise_um``, ``control_angle_sign``; :func:`check_probe_keys`), with
  ``tool_offset_mm`` the nest's centre (where the sensors read zero displacement) in the
  tool frame, and ``sensor_directions`` (optional): three unit vectors, one per sensor, in
  the nest's frame, along which a displacement of the sphere increases that sensor's
  reading; ``control_kinematics`` (``"joints"``, default, or ``"tcp"``) says how the part
  program makes the linear axes follow;
* CSV: ``<axis>_deg`` for each rotary axis; ``x_mm, y_mm, z_mm`` the commanded linear
  positions (optional: default the configured kinematics' solution); the readings either
  ``dx_um, dy_um, dz_um`` (the sphere's displacement relative to the nest along the machine
  axes X, Y, Z) or ``s1_um, s2_um, s3_um`` (the three sensors' readings, converted by
  volcal through ``sensor_directions``); ``time_s`` and ``status`` (``ok``/``missed``)
  optional.

**Machine frame.** The nest is fixed to the spindle: its frame turns with a rotary head.
``dx, dy, dz`` are along the machine's X, Y, Z, i.e. the nest's axes turned by the head's
commanded rotation (:func:`head_rotation`; the identity on a machine whose rotary axes
are all on the table). The estimator reads the nest-frame components
``R_head^T (dx, dy, dz)``.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.io.table import Column, TableSpec, read_table
from volcal.session.probe_sphere import CENTRE_COLUMNS, check_probe_keys

__all__ = ["DISPLACEMENT_COLUMNS", "SENSOR_COLUMNS", "check_rtest_keys", "head_rotation",
           "read_rtest_csv", "rtest_angles", "rtest_csv", "rtest_keys", "rtest_machine",
           "sensor_matrix"]

DISPLACEMENT_COLUMNS: tuple[str, str, str] = ("dx_um", "dy_um", "dz_um")
"""The sphere's displacement relative to the nest, machine axes [um]."""
SENSOR_COLUMNS: tuple[str, str, str] = ("s1_um", "s2_um", "s3_um")
"""The three sensors' readings [um]."""
MISSED = "missed"
READING_ABS_MAX_UM = 1.0e5
"""Largest plausible reading [um] (a sensor's range is a few mm at most)."""
POSITION_ABS_MAX_MM = 1.0e5
SENSOR_CONDITION_MAX = 1.0e3
"""Largest condition number of the sensors' direction matrix (three independent directions)."""


def sensor_matrix(v: Any, file: Any, key: str) -> NDArray[np.float64]:
    """The sensors' directions, checked: rows are unit vectors, three independent ones.

    Parameters
    ----------
    v : object
        ``sensor_directions`` as read: three ``[x, y, z]``.
    file : str or Path
        ``session.toml``, for errors.
    key : str
        The key, for errors.

    Returns
    -------
    ndarray, shape (3, 3)
        One unit direction per row (normalised).

    Raises
    ------
    VolcalInputError
        Naming the key.
    """
    ok = (isinstance(v, list) and len(v) == 3
          and all(isinstance(r, list) and len(r) == 3 for r in v)
          and all(not isinstance(x, bool) and isinstance(x, int | float) and math.isfinite(x)
                  for r in v for x in r))
    if not ok:
        raise VolcalInputError("expected three directions [[x, y, z], [x, y, z], [x, y, z]], "
                               "one per sensor, in the nest's frame", file, None, key)
    N = np.array(v, dtype=float)
    n = np.linalg.norm(N, axis=1)
    if np.any(n < 1e-9):
        i = int(np.argmin(n))
        raise VolcalInputError(f"sensor {i + 1}'s direction is zero", file, None, key)
    N = N / n[:, None]
    if np.linalg.cond(N) > SENSOR_CONDITION_MAX:
        raise VolcalInputError("the three sensor directions lie (nearly) in one plane: they "
                               "cannot give the sphere's 3-D displacement", file, None, key)
    return N


def check_rtest_keys(entry: dict[str, Any], file: Any, where: str, mid: str) -> dict[str, Any]:
    """Check an r_test entry's own keys; the checked values.

    Parameters
    ----------
    entry : dict
        The ``[[measurements]]`` entry (or a measurement's ``meta``).
    file : str or Path
        ``session.toml``, for errors.
    where : str
        The entry's key (``measurements[3]``).
    mid : str
        The measurement's id (the default sphere id).

    Returns
    -------
    dict
        The keys of :func:`volcal.session.probe_sphere.check_probe_keys`, with
        ``sensor_directions`` (ndarray (3, 3) or None) and ``control_kinematics``.

    Raises
    ------
    VolcalInputError
        Naming the key.
    """
    k = check_probe_keys(entry, file, where, mid)
    sd = entry.get("sensor_directions")
    k["sensor_directions"] = (None if sd is None
                              else sensor_matrix(sd, file, f"{where}.sensor_directions"))
    ck = entry.get("control_kinematics", "joints")
    if ck not in ("joints", "tcp"):
        raise VolcalInputError(f"control_kinematics {ck!r}: expected joints or tcp", file, None,
                               f"{where}.control_kinematics")
    k["control_kinematics"] = ck
    return k


def head_rotation(chain: Any, angles: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """Commanded rotation of the nest (the spindle) relative to the machine's axes.

    Parameters
    ----------
    chain : MachineChain
        The chain.
    angles : dict of str to ndarray
        Commanded angle of each rotary axis [deg].

    Returns
    -------
    ndarray, shape (m, 3, 3)
        The product, in chain order, of the nominal rotations of the rotary axes on the
        tool side of the frame (each by its commanded angle about its axis,
        ``docs/fiveaxis.md``); the identity where every rotary axis is on the table.
    """
    from volcal.model.kinematics import rotation_matrices

    m = len(next(iter(angles.values())))
    R = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
    for r in chain.rotary:
        if chain.on_workpiece_side(r):
            continue
        e = np.zeros((m, 3))
        e[:, "ABC".index(r)] = np.deg2rad(np.asarray(angles[r], dtype=float))
        R = R @ rotation_matrices(e)
    return R


def _spec(letters: list[str]) -> TableSpec:
    cols = tuple(Column(f"{r}_deg", abs_max=3600.0) for r in letters) + tuple(
        Column(c, required=False, abs_max=POSITION_ABS_MAX_MM) for c in CENTRE_COLUMNS) + tuple(
        Column(c, required=False, empty=True, abs_max=READING_ABS_MAX_UM, markers=(MISSED,))
        for c in DISPLACEMENT_COLUMNS + SENSOR_COLUMNS) + (
        Column("time_s", required=False),
        Column("status", kind="choice", required=False, empty=True, choices=("ok", MISSED)),
    )
    return TableSpec(columns=cols, min_rows=1, what="r_test measurement file",
                     delimiters=",;\t", decimal_comma=True)


def read_rtest_csv(path: str | Path, chain: Any, sensors: NDArray[np.float64] | None,
                   toml: Any = None, where: str = "measurements") -> dict[str, Any]:
    """Read an r_test CSV.

    Parameters
    ----------
    path : str or Path
        The file.
    chain : MachineChain
        The chain: one ``<axis>_deg`` column per rotary axis.
    sensors : ndarray, shape (3, 3), or None
        The sensors' directions (``sensor_directions``), needed for ``s1_um...``.
    toml : str or Path, optional
        ``session.toml``, named when the sensors' directions are missing.
    where : str
        The entry's key, for that error.

    Returns
    -------
    dict
        ``angles`` (letter -> ndarray [deg]), ``q`` (ndarray (n, 3) [mm] or None when the
        file has no positions), ``d`` (ndarray (n, 3): dx, dy, dz [um], machine axes, NaN
        rows at missed poses; None for a planned skeleton), ``sensors`` (ndarray (n, 3) of
        s1..s3 [um] when the file holds them, else None), ``rows`` (CSV rows, header = 1),
        ``missed`` (bool per row), ``extra`` (``time_s`` when present).

    Raises
    ------
    VolcalInputError
        Naming file, row and column.
    """
    letters = [r.lower() for r in chain.rotary]
    t = read_table(path, _spec(letters))
    angles = {r.upper(): np.asarray(t[f"{r}_deg"], dtype=float) for r in letters}
    n = len(t)
    pos = [t.has(c) for c in CENTRE_COLUMNS]
    if any(pos) and not all(pos):
        missing = CENTRE_COLUMNS[pos.index(False)]
        raise t.error(f"the commanded position needs x_mm, y_mm and z_mm; {missing} is missing",
                      None, missing)
    q = (np.column_stack([np.asarray(t[c], dtype=float) for c in CENTRE_COLUMNS])
         if all(pos) else None)
    disp = [t.has(c) for c in DISPLACEMENT_COLUMNS]
    sens = [t.has(c) for c in SENSOR_COLUMNS]
    if any(disp) and any(sens):
        raise t.error("give either the displacement dx_um, dy_um, dz_um or the sensor readings "
                      "s1_um, s2_um, s3_um, not both", None, SENSOR_COLUMNS[sens.index(True)])
    if any(sens):
        cols = SENSOR_COLUMNS
        if not all(sens):
            missing = SENSOR_COLUMNS[sens.index(False)]
            raise t.error(f"the sensor readings need s1_um, s2_um and s3_um; {missing} is "
                          "missing", None, missing)
    else:
        cols = DISPLACEMENT_COLUMNS
        if not all(disp):
            missing = DISPLACEMENT_COLUMNS[disp.index(False)] if any(disp) else "dx_um"
            raise t.error(f"the readings need dx_um, dy_um and dz_um (the sphere's displacement "
                          f"relative to the nest) or s1_um, s2_um, s3_um; {missing} is missing",
                          None, missing)
    extra = {"time_s": t["time_s"]} if t.has("time_s") else {}
    v = np.column_stack([np.asarray(t[c], dtype=float) for c in cols])
    missed = np.zeros(n, dtype=bool)
    for c in cols:
        missed |= t.marked[c]
    if t.has("status"):
        missed |= t["status"] == MISSED
    empty = np.isnan(v) & ~missed[:, None]
    out: dict[str, Any] = {"angles": angles, "q": q, "rows": t.rows, "missed": missed,
                           "extra": extra, "sensors": None, "d": None}
    if empty.all():
        return out
    if empty.any():
        i, j = np.argwhere(empty)[0]
        raise t.error("empty reading: write the value, or 'missed' for a pose not read", int(i),
                      cols[j])
    v[missed] = np.nan
    if cols == SENSOR_COLUMNS:
        if sensors is None:
            raise VolcalInputError("the CSV holds the sensor readings s1_um, s2_um, s3_um: "
                                   "give the sensors' directions, sensor_directions = "
                                   "[[x, y, z], [x, y, z], [x, y, z]] (docs/formats.md)", toml,
                                   None, f"{where}.sensor_directions")
        out["sensors"] = v
        out["d"] = sensor_displacement(v, sensors)
    else:
        out["d"] = v
    return out


def sensor_displacement(s: NDArray[np.float64], sensors: NDArray[np.float64]
                        ) -> NDArray[np.float64]:
    """The sphere's displacement from three sensor readings: ``d = N^{-1} s``.

    A sensor with unit direction ``n`` (nest frame) reads ``n . d`` for a displacement
    ``d`` of the sphere (exact for flat-ended sensors on a sphere, first order otherwise).

    Parameters
    ----------
    s : ndarray, shape (m, 3)
        Sensor readings [um].
    sensors : ndarray, shape (3, 3)
        Unit directions, one per row.

    Returns
    -------
    ndarray, shape (m, 3)
        Displacement along the nest's axes [um].
    """
    return np.linalg.solve(sensors, np.asarray(s, dtype=float).T).T


def rtest_csv(angles: dict[str, NDArray[np.float64]], q: NDArray[np.float64],
              d: NDArray[np.float64] | None, columns: dict[str, NDArray[Any]] | None = None,
              sensors: NDArray[np.float64] | None = None) -> str:
    """The CSV text of an r_test measurement.

    Parameters
    ----------
    angles : dict of str to ndarray
        Commanded angle per rotary letter [deg].
    q : ndarray, shape (n, 3)
        Commanded linear positions [mm].
    d : ndarray, shape (n, 3), or None
        Displacements dx, dy, dz [um]; None: a planned skeleton (empty columns).
    columns : dict, optional
        ``time_s`` is written when present.
    sensors : ndarray, shape (n, 3), optional
        The sensors' own readings: written as ``s1_um, s2_um, s3_um`` instead of ``d``.

    Returns
    -------
    str
    """
    letters = list(angles)
    n = len(angles[letters[0]])
    extra = [c for c in ("time_s",) if columns and c in columns]
    vals, cols = (d, DISPLACEMENT_COLUMNS) if sensors is None else (sensors, SENSOR_COLUMNS)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([f"{r.lower()}_deg" for r in letters] + list(CENTRE_COLUMNS) + list(cols) + extra)
    for i in range(n):
        row = [f"{angles[r][i]:.6f}" for r in letters] + [f"{v:.6f}" for v in q[i]]
        row += ["", "", ""] if vals is None else [f"{v:.4f}" for v in vals[i]]
        row += [f"{columns[c][i]:.3f}" for c in extra] if columns else []
        w.writerow(row)
    return buf.getvalue()


def rtest_keys(m: Any) -> dict[str, Any]:
    """The checked keys of an r_test measurement (:func:`check_rtest_keys` on its meta).

    Parameters
    ----------
    m : Measurement
        The measurement.
    """
    return check_rtest_keys(m.meta, None, m.id, m.id)


def rtest_angles(m: Any) -> dict[str, NDArray[np.float64]]:
    """Commanded angle of each rotary axis per pose [deg].

    Parameters
    ----------
    m : Measurement
        The measurement.
    """
    k = rtest_keys(m)
    return {r: np.asarray(m.columns[f"{r.lower()}_deg"], dtype=float) for r in k["chain"].rotary}


def rtest_machine(m: Any, linear: Any = None, location: dict[str, float] | None = None):
    """The 5-axis machine of an r_test: its chain and configured pivots.

    Parameters
    ----------
    m : Measurement
        The measurement.
    linear : MachineErrors, optional
        The linear axes' errors; None: perfect.
    location : dict of str to float, optional
        Location errors [um, urad]; None: zero.

    Returns
    -------
    FiveAxisMachine
    """
    from volcal.session.probe_sphere import five_axis_machine

    return five_axis_machine(m, linear, location)
