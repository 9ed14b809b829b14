"""Direct optics in a session: straightness and angular measurements, reference groups.

Two measurement kinds of the open session format (``docs/formats.md``, "Direct optics"):

* ``straightness`` (target ``straightness_optics``): the displacement since the first row,
  along ``+error_direction``, of the tool side relative to the workpiece side at the
  sensing optic, plus the tilt of the reference optic's straight line (a set-up nuisance);
  keys ``axis``, ``error_direction``, optional ``reference``, ``tool_offset_mm`` or
  ``sensor_position_mm``, ``slope_removed``; CSV column ``deviation_um`` [um].
* ``angular`` (targets ``angular_optics``, ``level``, ``roll_optics``): the rotation of the
  tool frame relative to the workpiece frame since the first row, component about
  ``+rotation`` (``a``, ``b``, ``c``: about X, Y, Z) [urad]; CSV column ``angle_urad``.

Measurements sharing a ``reference`` were read against one reference optic that was not
moved in between: straight on (parallel lines) or turned through an optical square
(perpendicular lines). A ``[references.NAME]`` table may give the square's calibrated
deviation from 90 degrees (``square_deviation_urad``, ``u_square_urad``).

This module validates the keys (:func:`read_optic_keys`), the reference groups
(:func:`check_references`) and records each grouped measurement's role in working state
(:func:`annotate_references`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = [
    "ANGULAR_COLUMN",
    "DEFAULT_U_SQUARE_URAD",
    "OPTIC_KINDS",
    "OPTIC_TARGETS",
    "REFERENCE_META",
    "annotate_references",
    "axis_index",
    "check_references",
    "read_optic_keys",
    "read_references",
    "vertical_axis",
]

OPTIC_KINDS: tuple[str, ...] = ("straightness", "angular")
"""Measurement kinds of the direct optics."""
OPTIC_TARGETS: dict[str, tuple[str, ...]] = {
    "straightness": ("straightness_optics",),
    "angular": ("angular_optics", "level", "roll_optics"),
}
"""Valid targets of each optic kind (and only of it)."""
ANGULAR_COLUMN = "angle_urad"
"""Reading column of an angular CSV [urad]."""
DEFAULT_U_SQUARE_URAD = 2.5
"""Standard uncertainty of an optical square without a ``[references.NAME]`` table
[urad]: a typical certificate states +-1 arcsec (4.8 urad) at k = 2."""
REFERENCE_META = "_reference"
"""Working-state key of ``Measurement.meta`` (never written): the measurement's role in
its reference group, see :func:`annotate_references`."""

_AXES = "xyz"
_ROTATIONS = "abc"


def axis_index(value: Any, letters: str = _AXES) -> int | None:
    """Index 0..2 of an axis (``x``, ``y``, ``z``) or rotation (``a``, ``b``, ``c``) letter.

    Parameters
    ----------
    value : object
        The letter as read, in either case.
    letters : str
        ``'xyz'`` or ``'abc'``.

    Returns
    -------
    int or None
        None when ``value`` is not one of the letters.
    """
    if isinstance(value, str) and len(value) == 1 and value.lower() in letters:
        return letters.index(value.lower())
    return None


def vertical_axis(machine_meta: dict[str, Any], file: str | Path | None = None) -> int:
    """The machine's vertical axis from ``[machine] vertical_axis`` (default ``"z"``).

    Parameters
    ----------
    machine_meta : dict
        The other ``[machine]`` keys.
    file : str or Path, optional
        ``session.toml``, for the error.

    Returns
    -------
    int
        0, 1 or 2.

    Raises
    ------
    VolcalInputError
        Not one of x, y, z.
    """
    v = machine_meta.get("vertical_axis", "z")
    k = axis_index(v)
    if k is None:
        raise VolcalInputError(f"vertical_axis must be \"x\", \"y\" or \"z\", got {v!r}", file,
                               None, "machine.vertical_axis")
    return k


def _letter(e: dict[str, Any], key: str, letters: str, where: str, file: Path) -> int:
    if key not in e:
        raise VolcalInputError(f"missing {key} = one of {', '.join(letters)} (either case)",
                               file, None, f"{where}.{key}")
    k = axis_index(e[key], letters)
    if k is None:
        raise VolcalInputError(f"{key} must be one of {', '.join(letters)} (either case), got "
                               f"{e[key]!r}", file, None, f"{where}.{key}")
    return k


def read_optic_keys(kind: str, target: str, e: dict[str, Any], positions: NDArray[np.float64],
                    rows: NDArray[np.int64], where: str, toml_path: Path, csv_path: Path,
                    vertical: int) -> dict[str, Any]:
    """Check the keys of a straightness or angular entry against its poses.

    Parameters
    ----------
    kind : str
        ``'straightness'`` or ``'angular'``.
    target : str
        The entry's target.
    e : dict
        The ``[[measurements]]`` entry.
    positions : ndarray, shape (n, 3)
        Commanded poses [mm].
    rows : ndarray of int
        CSV row of each pose (header = row 1).
    where : str
        ``'measurements[i]'``, for the TOML key in messages.
    toml_path, csv_path : Path
        Files, for messages.
    vertical : int
        The machine's vertical axis (:func:`vertical_axis`).

    Returns
    -------
    dict
        Normalised metadata: ``axis``, ``error_direction`` or ``rotation`` lower case,
        ``sensor_position_mm`` as floats, the other keys as read.

    Raises
    ------
    VolcalInputError
        A target of another kind, a missing or unknown letter, an ``axis`` along which the
        poses do not move, poses off the line, ``error_direction`` equal to ``axis``, a
        ``level`` about the vertical axis, an ``angular_optics`` reading about the moving
        axis, ``tool_offset_mm`` and ``sensor_position_mm`` both, keys of the other kind.
    """
    valid = OPTIC_TARGETS[kind]
    if target not in valid:
        raise VolcalInputError(f"a {kind} measurement needs target = one of "
                               f"{', '.join(valid)}, got {target!r}", toml_path, None,
                               f"{where}.target")
    meta = {k: v for k, v in e.items()
            if k not in ("id", "kind", "target", "file", "tool_offset_mm", "beam_direction")}
    k = _letter(e, "axis", _AXES, where, toml_path)
    meta["axis"] = _AXES[k]
    d = positions - positions[0]
    moving = int(np.argmax(np.ptp(positions, axis=0)))
    if np.ptp(positions, axis=0)[moving] <= 0:
        raise VolcalInputError("all readings at one position: the axis does not move",
                               csv_path, int(rows[-1]), "x_mm")
    if moving != k:
        raise VolcalInputError(f"axis = {e['axis']!r} but the positions in {csv_path.name} move "
                               f"along {'XYZ'[moving]}: axis must be the moving one",
                               toml_path, None, f"{where}.axis")
    from volcal.session.checks import GEOMETRY_TOLERANCE_MM

    off = np.abs(np.delete(d, k, axis=1)) > GEOMETRY_TOLERANCE_MM
    if off.any():
        i = int(np.flatnonzero(off.any(axis=1))[0])
        c = [j for j in range(3) if j != k][int(np.argmax(off[i]))]
        raise VolcalInputError(f"pose not on the line of this {kind} measurement along "
                               f"{'XYZ'[k]} from row {int(rows[0])}: {_AXES[c]} = "
                               f"{positions[i, c]:g} mm, expected {positions[0, c]:g} mm",
                               csv_path, int(rows[i]), f"{_AXES[c]}_mm")
    if kind == "straightness":
        for bad in ("rotation",):
            if bad in e:
                raise VolcalInputError(f"{bad} belongs to kind 'angular', not 'straightness'",
                                       toml_path, None, f"{where}.{bad}")
        j = _letter(e, "error_direction", _AXES, where, toml_path)
        if j == k:
            raise VolcalInputError(f"error_direction = {e['error_direction']!r} equals axis "
                                   f"{e['axis']!r}: a straightness is read across the motion "
                                   f"(one of {', '.join(c for c in _AXES if c != _AXES[k])})",
                                   toml_path, None, f"{where}.error_direction")
        meta["error_direction"] = _AXES[j]
        if "sensor_position_mm" in e:
            if "tool_offset_mm" in e and any(v != 0 for v in e["tool_offset_mm"]):
                raise VolcalInputError("give tool_offset_mm (sensor on the tool side) or "
                                       "sensor_position_mm (sensor on the workpiece side), "
                                       "not both", toml_path, None,
                                       f"{where}.sensor_position_mm")
            sp_ = e["sensor_position_mm"]
            if (not isinstance(sp_, list) or len(sp_) != 3
                    or any(isinstance(v, bool) or not isinstance(v, int | float)
                           or not math.isfinite(v) for v in sp_)):
                raise VolcalInputError("expected a list of 3 finite numbers [mm]", toml_path,
                                       None, f"{where}.sensor_position_mm")
            meta["sensor_position_mm"] = [float(v) for v in sp_]
        sr = e.get("slope_removed", False)
        if not isinstance(sr, bool):
            raise VolcalInputError(f"slope_removed must be true or false, got {sr!r}",
                                   toml_path, None, f"{where}.slope_removed")
        ref = e.get("reference")
        if ref is not None:
            if not isinstance(ref, str) or not ref:
                raise VolcalInputError(f"reference must be a non-empty name, got {ref!r}",
                                       toml_path, None, f"{where}.reference")
            if sr:
                raise VolcalInputError(
                    f"slope_removed data cannot belong to the reference group {ref!r}: the "
                    "group relates the lines' slopes, which were taken out", toml_path, None,
                    f"{where}.slope_removed")
    else:
        for bad in ("error_direction", "reference", "sensor_position_mm", "slope_removed"):
            if bad in e:
                raise VolcalInputError(f"{bad} belongs to kind 'straightness', not 'angular'",
                                       toml_path, None, f"{where}.{bad}")
        r = _letter(e, "rotation", _ROTATIONS, where, toml_path)
        meta["rotation"] = _ROTATIONS[r]
        if target == "level" and r == vertical:
            raise VolcalInputError(
                f"a level cannot see a rotation about the vertical axis "
                f"({'XYZ'[vertical]}, [machine] vertical_axis): rotation = {e['rotation']!r}; "
                "read it with angular_optics, roll_optics or two straightness lines",
                toml_path, None, f"{where}.rotation")
        if target == "angular_optics" and r == k:
            raise VolcalInputError(
                f"an angular interferometer cannot see the rotation about its beam "
                f"(rotation = {e['rotation']!r} about the moving axis {'XYZ'[k]}): use "
                "target = \"level\" or \"roll_optics\"", toml_path, None, f"{where}.rotation")
    return meta


def read_references(doc: dict[str, Any], toml_path: Path) -> dict[str, dict[str, float]]:
    """The ``[references.NAME]`` tables: an optical square's certificate.

    Parameters
    ----------
    doc : dict
        The parsed ``session.toml``.
    toml_path : Path
        For messages.

    Returns
    -------
    dict of str to dict
        Name -> ``{'square_deviation_urad': ..., 'u_square_urad': ...}`` (as given).

    Raises
    ------
    VolcalInputError
        Not tables, unknown keys, values not finite (``u_square_urad`` not positive).
    """
    refs = doc.get("references", {})
    if not isinstance(refs, dict):
        raise VolcalInputError("[references] must hold [references.NAME] tables", toml_path,
                               None, "references")
    out: dict[str, dict[str, float]] = {}
    for name, t in refs.items():
        key = f"references.{name}"
        if not isinstance(t, dict):
            raise VolcalInputError("expected a table with square_deviation_urad, u_square_urad",
                                   toml_path, None, key)
        unknown = sorted(set(t) - {"square_deviation_urad", "u_square_urad", "notes"})
        if unknown:
            raise VolcalInputError(f"unknown key {unknown[0]!r}: expected square_deviation_urad, "
                                   "u_square_urad, notes", toml_path, None,
                                   f"{key}.{unknown[0]}")
        entry: dict[str, Any] = {}
        for k2 in ("square_deviation_urad", "u_square_urad"):
            if k2 in t:
                v = t[k2]
                if (isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v)
                        or (k2 == "u_square_urad" and v <= 0)):
                    raise VolcalInputError(f"{k2} must be a finite number"
                                           + (" > 0" if k2 == "u_square_urad" else "")
                                           + f" [urad], got {v!r}", toml_path, None,
                                           f"{key}.{k2}")
                entry[k2] = float(v)
        if "notes" in t:
            entry["notes"] = t["notes"]
        out[str(name)] = entry
    return out


def _groups(measurements) -> dict[str, list]:
    groups: dict[str, list] = {}
    for m in measurements:
        if m.kind == "straightness" and m.meta.get("reference"):
            groups.setdefault(str(m.meta["reference"]), []).append(m)
    return groups


def check_references(measurements, references: dict[str, dict[str, Any]],
                     toml_path: str | Path | None = None,
                     keys: dict[str, str] | None = None) -> None:
    """Refuse reference groups that one optic cannot have read.

    The first line of a group (in session order) is read straight on; every other line is
    parallel to it (same axis: straight on) or perpendicular (turned through the optical
    square). One square turns the reference in one plane, so the perpendicular lines of a
    group share one axis; a group with lines along all three axes, or a ``slope_removed``
    line, is refused.

    Parameters
    ----------
    measurements : list of Measurement
        The session's measurements (any kinds).
    references : dict
        The ``[references.NAME]`` tables (:func:`read_references`).
    toml_path : str or Path, optional
        ``session.toml``, for messages.
    keys : dict of str to str, optional
        Measurement id -> its TOML table (``'measurements[3]'``), for messages.

    Raises
    ------
    VolcalInputError
        Naming the measurement's ``reference`` key.
    """
    keys = keys or {}
    for name, ms in _groups(measurements).items():
        k1 = "xyz".index(ms[0].meta["axis"])
        perp: set[int] = set()
        for m in ms:
            if m.meta.get("slope_removed"):
                raise VolcalInputError(
                    f"measurement {m.id!r}: slope_removed data cannot belong to the reference "
                    f"group {name!r}", toml_path, None,
                    f"{keys.get(m.id, m.id)}.slope_removed")
            k = "xyz".index(m.meta["axis"])
            if k != k1:
                perp.add(k)
            if len(perp) > 1:
                raise VolcalInputError(
                    f"measurement {m.id!r}: reference group {name!r} holds lines along "
                    f"{', '.join('XYZ'[j] for j in sorted({k1, *perp}))}: with one optical "
                    f"square its lines can be only parallel or perpendicular to the first "
                    f"({ms[0].id!r}, along {'XYZ'[k1]}) in one plane", toml_path, None,
                    f"{keys.get(m.id, m.id)}.reference")


def annotate_references(measurements, references: dict[str, dict[str, Any]] | None = None
                        ) -> None:
    """Record in each grouped straightness measurement its role (working state).

    Sets ``meta['_reference']`` (:data:`REFERENCE_META`) to ``{'name', 'first_axis',
    'square', 'square_deviation_urad', 'u_square_urad'}``: ``square`` is True for a line
    perpendicular to the group's first line (read through the optical square).

    Parameters
    ----------
    measurements : list of Measurement
        The session's measurements, in session order.
    references : dict, optional
        The ``[references.NAME]`` tables.
    """
    refs = references or {}
    for name, ms in _groups(measurements).items():
        k1 = "xyz".index(ms[0].meta["axis"])
        cert = refs.get(name, {})
        for m in ms:
            m.meta[REFERENCE_META] = {
                "name": name, "first_axis": k1,
                "square": "xyz".index(m.meta["axis"]) != k1,
                "square_deviation_urad": float(cert.get("square_deviation_urad", 0.0)),
                "u_square_urad": float(cert.get("u_square_urad", DEFAULT_U_SQUARE_URAD)),
            }
    for m in measurements:
        if m.kind == "straightness" and not m.meta.get("reference"):
            m.meta.pop(REFERENCE_META, None)
