"""Probe-on-sphere readings in a session: the entry's keys and its CSV file.

A ``probe_sphere`` measurement holds the centre of a calibration sphere, fixed on the
workpiece side, as the control reports it in its machine coordinates (HEIDENHAIN cycle
451, Siemens CYCLE996, LinuxCNC ``G38.2`` probing and a fit of the logged points) at a set
of rotary poses. ``docs/formats.md`` ("Probe-on-sphere tests") documents it:

* keys: ``chain`` (the 5-axis chain code, ``'CAFXYZ'``), ``pivot_mm`` (the nominal pivot
  of each rotary axis as the control is configured, ``{c = [x, y, z], a = [x, y, z]}``),
  ``sphere_mm`` (the nominal sphere centre, workpiece coordinates at the zero pose),
  ``sphere`` (an id shared by the tests of one sphere placement; default the test's id),
  ``sphere_diameter_mm`` (optional), ``noise_um`` (the probe's repeatability per
  coordinate, default 1), ``control_angle_sign`` (1, default, or -1 where the control's
  rotary angles turn opposite to volcal's, as LinuxCNC's trt kinematics do: its part
  program and probe log carry the control's angles); the common ``tool_offset_mm`` is the
  probe tip centre in the tool frame;
* CSV: ``<axis>_deg`` for each rotary axis of the chain (``c_deg``, ``a_deg``) and
  ``x_mm, y_mm, z_mm``, the reported centre (empty in a planned skeleton; ``missed`` for a
  pose the cycle did not probe).
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
from volcal.model.chain import parse_machine_chain

__all__ = ["CENTRE_COLUMNS", "check_probe_keys", "dispersion_um", "five_axis_machine",
           "probe_csv", "read_probe_csv"]

CENTRE_COLUMNS: tuple[str, str, str] = ("x_mm", "y_mm", "z_mm")
"""The reported sphere centre, machine coordinates [mm]."""
MISSED = "missed"
POSITION_ABS_MAX_MM = 1.0e5
PIVOT_ABS_MAX_MM = 1.0e5
NOISE_MAX_UM = 1000.0


def _vec3(v: Any, file: Any, key: str) -> NDArray[np.float64]:
    if (not isinstance(v, list) or len(v) != 3
            or any(isinstance(x, bool) or not isinstance(x, int | float) for x in v)
            or not all(math.isfinite(x) and abs(x) <= PIVOT_ABS_MAX_MM for x in v)):
        raise VolcalInputError("expected [x, y, z] in mm (finite numbers)", file, None, key)
    return np.array(v, dtype=float)


def _positive(v: Any, file: Any, key: str, hi: float) -> float:
    if (isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v)
            or not 0.0 < v <= hi):
        raise VolcalInputError(f"expected a number above 0 and at most {hi:g}, got {v!r}",
                               file, None, key)
    return float(v)


def check_probe_keys(entry: dict[str, Any], file: Any, where: str, mid: str) -> dict[str, Any]:
    """Check a probe_sphere entry's own keys; the checked values.

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
        ``chain`` (MachineChain), ``pivot_mm`` (letter -> ndarray), ``sphere`` (str),
        ``sphere_mm`` (ndarray), ``noise_um`` (float), ``sphere_diameter_mm`` (float or
        None), ``control_angle_sign`` (1 or -1: the control's angle is volcal's times it).

    Raises
    ------
    VolcalInputError
        Naming the key.
    """
    if "chain" not in entry:
        raise VolcalInputError("missing chain: the 5-axis chain code read from workpiece to "
                               "tool, e.g. \"CAFXYZ\" (docs/fiveaxis.md)", file, None,
                               f"{where}.chain")
    try:
        chain = parse_machine_chain(entry["chain"])
    except VolcalInputError as e:
        raise VolcalInputError(str(e), file, None, f"{where}.chain") from None
    if not chain.rotary:
        raise VolcalInputError(f"chain {chain.code!r} has no rotary axis: a probe_sphere test "
                               "reads the location of rotary axes", file, None, f"{where}.chain")
    piv = entry.get("pivot_mm")
    if not isinstance(piv, dict):
        raise VolcalInputError("missing pivot_mm: the nominal pivot of each rotary axis, e.g. "
                               "pivot_mm = { c = [0, 0, 0], a = [0, 0, -120] }", file, None,
                               f"{where}.pivot_mm")
    letters = [r.lower() for r in chain.rotary]
    unknown = sorted(set(piv) - set(letters))
    if unknown:
        raise VolcalInputError(f"pivot of {unknown[0]!r}, not a rotary axis of the chain "
                               f"{chain.code} ({', '.join(letters)})", file, None,
                               f"{where}.pivot_mm.{unknown[0]}")
    pivots = {}
    for r in letters:
        if r not in piv:
            raise VolcalInputError(f"missing the pivot of axis {r}", file, None,
                                   f"{where}.pivot_mm.{r}")
        pivots[r.upper()] = _vec3(piv[r], file, f"{where}.pivot_mm.{r}")
    if "sphere_mm" not in entry:
        raise VolcalInputError("missing sphere_mm: the nominal sphere centre [x, y, z] in mm",
                               file, None, f"{where}.sphere_mm")
    sphere_mm = _vec3(entry["sphere_mm"], file, f"{where}.sphere_mm")
    sphere = entry.get("sphere", mid)
    if not isinstance(sphere, str) or not sphere.strip() or ":" in sphere:
        raise VolcalInputError(f"sphere must be a name (text without ':'), got {sphere!r}",
                               file, None, f"{where}.sphere")
    noise = _positive(entry.get("noise_um", 1.0), file, f"{where}.noise_um", NOISE_MAX_UM)
    dia = entry.get("sphere_diameter_mm")
    if dia is not None:
        dia = _positive(dia, file, f"{where}.sphere_diameter_mm", 1000.0)
    if entry.get("tip_diameter_mm") is not None:
        _positive(entry["tip_diameter_mm"], file, f"{where}.tip_diameter_mm", 100.0)
    sign = entry.get("control_angle_sign", 1)
    if isinstance(sign, bool) or sign not in (1, -1):
        raise VolcalInputError(f"control_angle_sign must be 1 or -1, got {sign!r}", file, None,
                               f"{where}.control_angle_sign")
    return {"chain": chain, "pivot_mm": pivots, "sphere": sphere, "sphere_mm": sphere_mm,
            "noise_um": noise, "sphere_diameter_mm": dia, "control_angle_sign": int(sign)}


def _spec(letters: list[str]) -> TableSpec:
    cols = tuple(Column(f"{r}_deg", abs_max=3600.0) for r in letters) + tuple(
        Column(c, required=False, empty=True, abs_max=POSITION_ABS_MAX_MM, markers=(MISSED,))
        for c in CENTRE_COLUMNS) + (
        Column("time_s", required=False),
        Column("status", kind="choice", required=False, empty=True, choices=("ok", MISSED)),
    )
    return TableSpec(columns=cols, min_rows=1, what="probe_sphere measurement file",
                     delimiters=",;\t", decimal_comma=True)


def read_probe_csv(path: str | Path, chain) -> tuple[dict[str, NDArray[np.float64]],
                                                     NDArray[np.float64] | None,
                                                     NDArray[np.int64], NDArray[np.bool_],
                                                     dict[str, NDArray[Any]]]:
    """Read a probe_sphere CSV.

    Parameters
    ----------
    path : str or Path
        The file.
    chain : MachineChain
        The chain: one ``<axis>_deg`` column per rotary axis.

    Returns
    -------
    angles : dict of str to ndarray
        Commanded angle per rotary letter (upper case) [deg].
    centres : ndarray, shape (n, 3), or None
        Reported centres [mm] (NaN rows at missed poses); None for a planned skeleton.
    rows : ndarray of int
        CSV rows (header = 1).
    missed : ndarray of bool
        Poses the cycle did not probe.
    extra : dict of str to ndarray
        ``time_s`` when present.

    Raises
    ------
    VolcalInputError
        Naming file, row and column.
    """
    letters = [r.lower() for r in chain.rotary]
    t = read_table(path, _spec(letters))
    angles = {r.upper(): np.asarray(t[f"{r}_deg"], dtype=float) for r in letters}
    present = [t.has(c) for c in CENTRE_COLUMNS]
    if any(present) and not all(present):
        missing = CENTRE_COLUMNS[present.index(False)]
        raise t.error(f"the centre needs x_mm, y_mm and z_mm; {missing} is missing", None,
                      missing)
    extra = {"time_s": t["time_s"]} if t.has("time_s") else {}
    n = len(t)
    if not all(present):
        return angles, None, t.rows, np.zeros(n, dtype=bool), extra
    c = np.column_stack([np.asarray(t[k], dtype=float) for k in CENTRE_COLUMNS])
    missed = np.zeros(n, dtype=bool)
    for k in CENTRE_COLUMNS:
        missed |= t.marked[k]
    if t.has("status"):
        missed |= t["status"] == MISSED
    empty = np.isnan(c) & ~missed[:, None]
    if empty.any() and not empty.all():
        i, j = np.argwhere(empty)[0]
        raise t.error("empty centre coordinate: write the reported value, or 'missed' for a "
                      "pose the cycle did not probe", int(i), CENTRE_COLUMNS[j])
    if empty.all():
        return angles, None, t.rows, missed, extra
    c[missed] = np.nan
    return angles, c, t.rows, missed, extra


def probe_csv(angles: dict[str, NDArray[np.float64]], centres: NDArray[np.float64] | None,
              columns: dict[str, NDArray[Any]] | None = None) -> str:
    """The CSV text of a probe_sphere measurement.

    Parameters
    ----------
    angles : dict of str to ndarray
        Commanded angle per rotary letter [deg].
    centres : ndarray, shape (n, 3), or None
        Reported centres [mm]; None: a planned skeleton (empty columns).
    columns : dict, optional
        ``time_s`` is written when present.

    Returns
    -------
    str
    """
    letters = list(angles)
    n = len(angles[letters[0]])
    extra = [c for c in ("time_s",) if columns and c in columns]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([f"{r.lower()}_deg" for r in letters] + list(CENTRE_COLUMNS) + extra)
    for i in range(n):
        row = [f"{angles[r][i]:.6f}" for r in letters]
        if centres is None:
            row += ["", "", ""]
        else:
            row += [f"{v:.6f}" for v in centres[i]]
        row += [f"{columns[c][i]:.3f}" for c in extra] if columns else []
        w.writerow(row)
    return buf.getvalue()


def _keys(m: Any) -> dict[str, Any]:
    return check_probe_keys(m.meta, None, m.id, m.id)


def five_axis_machine(m: Any, linear: Any = None, location: dict[str, float] | None = None):
    """The 5-axis machine of a probe_sphere measurement: its chain and nominal pivots.

    Parameters
    ----------
    m : Measurement
        The measurement.
    linear : MachineErrors, optional
        The linear axes' errors (same linear order as the chain); None: perfect.
    location : dict of str to float, optional
        Location errors [um, urad]; None: zero.

    Returns
    -------
    FiveAxisMachine
    """
    from volcal.model.fiveaxis import FiveAxisMachine
    from volcal.model.rotary import RotaryAxis

    k = _keys(m)
    chain = k["chain"]
    loc = location or {}
    rot = {}
    for r in chain.rotary:
        names = RotaryAxis(r).location_names
        full = r == "C"
        rot[r] = RotaryAxis(r, k["pivot_mm"][r], {n: loc[n] for n in names if n in loc},
                            full_circle=full)
    if linear is not None and linear.chain_obj.order != chain.linear.order:
        linear = None
    return FiveAxisMachine(chain, rot, linear)


def _angles(m: Any) -> dict[str, NDArray[np.float64]]:
    k = _keys(m)
    return {r: np.asarray(m.columns[f"{r.lower()}_deg"], dtype=float) for r in k["chain"].rotary}


def dispersion_um(m: Any, positions: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance of each pose's sphere centre (nominal kinematics) from their mean [um].

    Parameters
    ----------
    m : Measurement
        The measurement (chain, pivots, angles, tool offset).
    positions : ndarray, shape (n, 3)
        Reported centres [mm].
    """
    from volcal.model.fiveaxis import exact_pose5

    p, _ = exact_pose5(five_axis_machine(m), positions, _angles(m), m.tool_offset)
    return np.linalg.norm(p - p.mean(axis=0), axis=1) * 1e3
