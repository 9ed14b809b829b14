"""Compensation tables of rotary axes from the session's rotary tests (issue 27).

One module per controller, each in the control's own unit (degrees) and sign, with its
manual's source, limits and activation in its docstring and in the notes written beside
the tables: :mod:`.linuxcnc` (``COMP_FILE`` of the rotary joint, bidirectional),
:mod:`.heidenhain` (``.COM`` with ``BACKLASH``), :mod:`.siemens` (LEC on a modulo axis,
the reversal as direction-dependent CEC tables), :mod:`.fanuc` (rotation-axis pitch error
compensation, 3620-3625), :mod:`.isg` (the ISG / Beckhoff leadscrew error compensation
list ``kw.ssfk.*`` of the rotary axis, bilateral, modulo). The input is
:class:`~.profile.RotaryProfile`: the mean deviation per target and direction of an
ISO 230-2 rotary test, periodic on a full-circle axis.

:func:`rotary_tables` writes them for a format; :func:`rotary_removed_urad` reads the
written files back and applies them as the control does (the error they remove at a
commanded angle), for the A before/after of ``volcal compensate --session``
(:mod:`.check`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.compensate.rotary.profile import DEG_PER_URAD, RotaryProfile, rotary_profiles
from volcal.compensate.tables import sign_factor
from volcal.errors import VolcalInputError

__all__ = ["ROTARY_FORMATS", "ROTARY_SOURCES", "RotaryOptions", "RotaryProfile", "rotary_profiles",
           "rotary_removed_urad", "rotary_tables"]

ROTARY_FORMATS: dict[str, str] = {
    "linuxcnc": "correction", "heidenhain": "error", "siemens": "error", "fanuc": "correction",
    "isg": "error"}
"""Formats with rotary tables -> the control's own sign."""
NOTES_FILE = "ROTARY_NOTES.TXT"

ROTARY_SOURCES: dict[str, str] = {
    "linuxcnc": ("LinuxCNC documentation, INI Configuration [JOINT_<num>] COMP_FILE, "
                 "COMP_FILE_TYPE, and the Integrator's manual, Lead screw compensation; "
                 "LinuxCNC source usrmotintf.cc (loader), command.c (256 entries), control.c "
                 "(applied by direction)."),
    "heidenhain": ("HEIDENHAIN MANUALplus 620 Technical Manual (01/2012), 6.10.3 Nonlinear "
                   "axis error compensation, pp. 713-716 (BACKLASH p. 716); iTNC 530 HSCI "
                   "Technical Manual, KinematicsComp, Rotary axes - Recommendation for COM "
                   "file (positioning error EAA), p. 680."),
    "siemens": ("SINUMERIK 840D sl Function Manual Extended Functions (6FC5397-1BP40-3BA1, "
                "03/2013), K3 4.4 Interpolatory compensation ($AA_ENC_COMP, "
                "$AA_ENC_COMP_IS_MODULO, $AN_CEC_DIRECTION, $AN_CEC_IS_MODULO); Function "
                "Manual Axes and Spindles, R2 (MD30330, MD30340)."),
    "fanuc": ("FANUC Series 0i-PB Parameter Manual B-63980EN/01, parameters 3620-3625, "
              "Example 2) For the rotation axis, p. 100; FANUC 16i/18i technical report "
              "A-77810E (3625 for a rotation axis); FANUC 30i/31i/32i-MODEL A Parameter Manual "
              "B-63950EN/02 (parameter I/O format); the sign rule from the GSK983Ma connection "
              "and operation manual, Appendix 8 (docs/controllers.md)."),
    "isg": ("Beckhoff TF5200 TwinCAT 3 CNC, Axis compensation: Leadscrew error compensation "
            "(kw.ssfk.*), P-COMP-00017 ... P-COMP-00025, P-COMP-00059; Axis parameters "
            "P-AXIS-00175, P-AXIS-00243 (infosys.beckhoff.com)."),
}
"""The manuals (and pages) each format's rotary tables follow, as the notes file states
them (each module's References in full)."""


@dataclass(frozen=True)
class RotaryOptions:
    """Options of the rotary tables.

    Parameters
    ----------
    sign : str, optional
        Override of the control's sign (None: its own, :data:`ROTARY_FORMATS`).
    spacing_deg : float
        Siemens and Fanuc: distance between the equidistant points [deg] (divides 360).
    linuxcnc_type : int
        LinuxCNC ``COMP_FILE_TYPE``.
    turns : int
        LinuxCNC, full-circle axis: turns written either side of 0..360 deg.
    fanuc_series : str
        ``'30i'`` or ``'16i'``.
    fanuc_unit_deg : float
        Fanuc detection unit of the rotary axis [deg].
    magnification, max_increment : int
        Fanuc 3623 and the largest value per point.
    fanuc_reference_number : int
        Fanuc 3620 of the (first) rotary axis; the next one follows its table.
    """

    sign: str | None = None
    spacing_deg: float = 5.0
    linuxcnc_type: int = 1
    turns: int = 1
    fanuc_series: str = "30i"
    fanuc_unit_deg: float = 0.001
    magnification: int = 1
    max_increment: int = 7
    fanuc_reference_number: int = 900


def _names(profiles: Sequence[RotaryProfile]) -> list[str]:
    """File stem of each profile: the axis letter, with the test id when an axis repeats."""
    axes = [p.axis.upper() for p in profiles]
    return [a if axes.count(a) == 1 else f"{a}_{p.id}" for a, p in zip(axes, profiles,
                                                                          strict=True)]


def _fanuc_first_point(profiles: Sequence[RotaryProfile], o: RotaryOptions
                       ) -> tuple[int, list[str]]:
    """Parameter 3620 of the first Fanuc rotary table, and a note when it is not the default.

    The full-circle axes' tables follow each other from ``o.fanuc_reference_number``
    (900) in the table all axes share (:data:`~volcal.compensate.rotary.fanuc.
    TABLE_POINTS`); where they would run past its end (two axes at 5 deg: 146 points from
    900), they start lower, so that the last ends at its last point. Whether the linear
    axes' tables (from point 0) reach them is checked when both are written.
    """
    from volcal.compensate.rotary.fanuc import TABLE_POINTS, table_points

    ref = o.fanuc_reference_number
    need = sum(table_points(o.spacing_deg) for p in profiles if p.modulo)
    if ref + need <= TABLE_POINTS or need > TABLE_POINTS:
        return ref, []
    first = TABLE_POINTS - need
    return first, [f"Fanuc: the rotary tables take points {first}..{TABLE_POINTS - 1} of the "
                   f"shared table of {TABLE_POINTS} (from point {ref} they would not fit)"]


def rotary_tables(profiles: Sequence[RotaryProfile], fmt: str, o: RotaryOptions
                  ) -> tuple[dict[str, str], list[dict[str, Any]], list[str]]:
    """The rotary tables of ``fmt``.

    Parameters
    ----------
    profiles : sequence of RotaryProfile
        One per rotary test (the session's order).
    fmt : str
        The format (``linuxcnc``, ``heidenhain``, ``siemens``, ``fanuc``, ``isg``; others
        get none, with the reason in ``skipped``).
    o : RotaryOptions
        Sign override, spacing, the controllers' options.

    Returns
    -------
    files : dict of str to str
        File name -> content (with ``ROTARY_NOTES.TXT``).
    entries : list of dict
        Per rotary test, for the manifest: ``id``, ``axis``, ``files``, ``sign``,
        ``modulo`` and the format's keys needed to read the tables back.
    skipped : list of str
        Why a test got no table (format without rotary tables, limited axis on Fanuc).
    """
    from volcal.compensate.rotary import fanuc, heidenhain, isg, linuxcnc, siemens

    if not profiles:
        return {}, [], []
    if fmt not in ROTARY_FORMATS:
        return {}, [], [f"{p.id}: the {fmt} format has no rotary tables (LinuxCNC, "
                        "HEIDENHAIN, Siemens, Fanuc and ISG have)" for p in profiles]
    sign = o.sign if o.sign is not None else ROTARY_FORMATS[fmt]
    sign_factor(sign)
    files: dict[str, str] = {}
    entries: list[dict[str, Any]] = []
    skipped: list[str] = []
    notes = [f"volcal: rotary axis compensation ({fmt}), angles and values in degrees",
             "Input: the mean deviation per target and approach direction of each rotary "
             "ISO 230-2 test (deviation = actual - commanded angle, ISO 841 positive "
             "counter-clockwise); the table removes it. Full-circle axes: periodic, 0 deg "
             "and 360 deg one position.",
             f"Source: {ROTARY_SOURCES[fmt]}"]
    names = _names(profiles)
    if fmt == "siemens":
        f, n = siemens.siemens_rotary_files(list(profiles), o.spacing_deg, sign)
        files.update(f)
        notes += n
        for i, p in enumerate(profiles):
            entries.append({"id": p.id, "axis": p.axis, "sign": sign, "modulo": p.modulo,
                            "files": sorted(f), "siemens_axis": f"AX{4 + i}"})
    else:
        cma: dict[str, str] = {}
        ref = o.fanuc_reference_number
        if fmt == "fanuc":
            ref, moved = _fanuc_first_point(profiles, o)
            notes += moved
        for i, (p, stem) in enumerate(zip(profiles, names, strict=True)):
            e: dict[str, Any] = {"id": p.id, "axis": p.axis, "sign": sign, "modulo": p.modulo}
            if fmt == "linuxcnc":
                name = f"{stem}.comp"
                f, n = linuxcnc.linuxcnc_rotary_files(p, name, o.linuxcnc_type, o.turns,
                                                      sign=sign)
                e["linuxcnc_type"] = o.linuxcnc_type
            elif fmt == "heidenhain":
                name = f"{stem}.COM"
                f, n = heidenhain.heidenhain_rotary_files(p, name, sign)
                cma[stem] = name
            elif fmt == "isg":
                f, n = isg.isg_rotary_files(p, f"rotary_isg_{stem}.lis", sign, 4 + i)
            else:
                if not p.modulo:
                    skipped.append(f"{p.id}: Fanuc's rotation-axis pitch compensation is for "
                                   "full-circle axes; this axis is limited")
                    continue
                f, n = fanuc.fanuc_rotary_files(
                    p, o.spacing_deg, sign, o.fanuc_unit_deg, o.magnification,
                    o.max_increment, ref, 4 + i, series=o.fanuc_series, stem=stem)
                e.update(fanuc_unit_deg=o.fanuc_unit_deg, fanuc_stem=stem)
                ref += fanuc.table_points(o.spacing_deg)
            files.update(f)
            notes += n
            e["files"] = sorted(f)
            entries.append(e)
        if cma:
            files[heidenhain.ROTARY_CMA_FILE] = heidenhain.heidenhain_rotary_cma(cma)
    files[NOTES_FILE] = "\n".join(notes) + "\n"
    return files, entries, skipped


def rotary_removed_urad(folder: str | Path, fmt: str, entry: dict[str, Any],
                        angle_deg: ArrayLike, direction: ArrayLike) -> NDArray[np.float64]:
    """The error the written rotary table removes at commanded angles [urad].

    Reads the table back from its file(s) and applies it as the control does: linear
    interpolation between points (Fanuc: the value of the last point passed), the table of
    the approach direction where the control has two, periodic on a full-circle axis
    (LinuxCNC: over the joint angles written).

    Parameters
    ----------
    folder : str or Path
        The compensation folder.
    fmt : str
        The format.
    entry : dict
        The test's entry of the manifest (:func:`rotary_tables`).
    angle_deg : array_like
        Commanded angles [deg].
    direction : array_like of str
        ``'+'`` / ``'-'`` per angle.

    Returns
    -------
    ndarray
        The error removed [urad] (the error left is the error minus this).
    """
    from volcal.compensate.rotary import fanuc, heidenhain, isg, linuxcnc, siemens

    folder = Path(folder)
    a = np.asarray(angle_deg, dtype=float)
    d = np.asarray(direction).astype(str)
    modulo = bool(entry.get("modulo", True))
    s = sign_factor(str(entry["sign"]))
    files = list(entry["files"])

    def periodic(x: NDArray[np.float64], pos: NDArray[np.float64], v: NDArray[np.float64]
                 ) -> NDArray[np.float64]:
        if modulo:
            x = np.mod(x - pos[0], 360.0) + pos[0]
        return np.interp(x, pos, v)

    if fmt == "linuxcnc":
        nom, fwd, rev = linuxcnc.read_linuxcnc_rotary(folder / files[0],
                                                      int(entry.get("linuxcnc_type", 1)))
        trim = np.where(d == "-", np.interp(a, nom, rev), np.interp(a, nom, fwd))
        return s * trim / DEG_PER_URAD  # correction: trim = -error
    if fmt == "heidenhain":
        com = folder / [f for f in files if f.upper().endswith(".COM")][0]
        pos, fv = heidenhain.read_heidenhain_rotary(com)
        _, rv = heidenhain.read_heidenhain_rotary(com, "BACKLASH")
        val = np.where(d == "-", periodic(a, pos, rv), periodic(a, pos, fv))
        return s * val / DEG_PER_URAD
    if fmt == "siemens":
        t = siemens.read_siemens_rotary(folder, str(entry["siemens_axis"]))
        pos, v, _ = t["lec"]
        val = periodic(a, pos, v)
        if "+" in t and "-" in t:
            val = val + np.where(d == "-", periodic(a, *t["-"][:2]), periodic(a, *t["+"][:2]))
        return s * val / DEG_PER_URAD
    if fmt == "isg":  # the SSFK list: a table per direction, linear between points
        pos, up, down, _ = isg.read_isg_rotary(folder / files[0])
        val = np.where(d == "-", periodic(a, pos, down), periodic(a, pos, up))
        return s * val / DEG_PER_URAD
    if fmt == "fanuc":
        pos, cum = fanuc.read_fanuc_rotary(folder, str(entry["fanuc_stem"]),
                                           float(entry.get("fanuc_unit_deg", 0.001)))
        x = np.mod(a, 360.0)
        i = np.clip(np.searchsorted(pos, x + 1e-9, side="right") - 1, 0, pos.size - 1)
        return s * cum[i] / DEG_PER_URAD
    raise VolcalInputError(f"no rotary tables in the {fmt} format", folder)
