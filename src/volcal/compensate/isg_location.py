"""ISG / Beckhoff TwinCAT CNC: the rotary axes' location errors for the volumetric compensation.

The volumetric compensation of the ISG kernel (Beckhoff TF5280) reads the ISO 230 errors
of every axis of its kinematic chain from parameter files; in the **ISG CSV format** a
block is a header line of names and the rows below it, ``//`` starts a comment line and
``#`` a new block ("ISG CSV format": "Position errors are typically (but not necessarily)
constant. Therefore, one data row is usually sufficient here", with the example header
``Y0A Z0A X0B ...``). The supported names ("List of parameters supported") are the
position errors ``X0C, Y0C, Z0C, A0C, B0C, C0C`` (likewise for A and B), the component
errors ``EXC ... ECC`` and the ISG parameters ``PXC, PYC, PZC`` ("centre of rotation of C
axis"; ``PXA ...``, ``PXB ...``); values in **mm** for offsets and **rad** for angles,
arguments of rotary axes in **degrees** ("Units of measure"). The file holds the errors
(list parameter ``negate 0``).

volcal writes (:func:`isg_location_csv`):

* a block ``PXC PYC PZC PXA PYA PZA`` (the chain's rotary axes): the configured pivots, the
  reference points the position errors are measured from (``docs/fiveaxis.md``) [mm];
* a block of the location errors the readings determined, ISG spelling (``X0C`` for
  ``EX0C``) [mm, rad]: the redundant ones (held at zero by the identification) are
  written as 0 and named in a comment;
* a block ``C EXC EYC EZC EAC EBC ECC`` per rotary axis whose component errors the
  identified machine carries (not a probe-on-sphere result: none is written then).

Activation (comments in the file): list the file in the volumetric compensation's
configuration list (``file[j]`` / ``file_format[j] ISG_CSV``, P-VOLC-00012/13), the rotary
axes' logical numbers (``c``, ``a``: P-VOLC-00006 ...), ``chain`` (P-VOLC-00007: volcal's
chain without ``F``, read from the workpiece to the tool as the universal kinematics' axis
sequence, TF5240 example 3: ``CAXYZ``; "the row chain XYZCA defines the kinematic chain for
a conventional CA machine", volcal's ``FXYZCA``) and ``workpiece_axes`` (the letters
before ``F``); then ``#VOLCOMP [ID0 UPDATE]`` ("Updating the Volumetric Compensation").

Sign: the values are volcal's (``docs/fiveaxis.md``): an angle turns the tool relative to
the workpiece in the sense of the commanded angle (for a table axis that is ISO 841's
``C``, not the table's own motion ``C'``). The pages of the ISG documentation at hand give
the names and units but not the sign reference of a workpiece-side axis' errors (the
universal kinematics reverses the direction vector of a workpiece-side axis, TF5240
"Example of an AC machine with cardanic table"): check one value on the machine before
relying on the signs (e.g. the sphere centre the control reports after activation, as
``volcal locate`` predicts it).

References
----------
Beckhoff TF5280 TwinCAT 3 CNC Volumetric Compensation: "ISG CSV format" (296429067),
"List of parameters supported" (296423819), "Units of measure" (296426379), "Updating
the Volumetric Compensation" (1218769547); TF5200 parameters P-VOLC-00007 "Type of
kinematic chain" (106009099486136715); TF5240 Universal Kinematics "Example of an AC
machine with cardanic table" (278732555).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["IsgLocationExport", "isg_location_csv", "isg_location_export", "read_isg_location"]

Array = NDArray[np.float64]
SOURCE = ("Beckhoff TF5280 Volumetric Compensation: 'ISG CSV format', 'List of parameters "
          "supported', 'Units of measure'; P-VOLC-00007 'Type of kinematic chain'")
MM_PER_UM = 1e-3
RAD_PER_URAD = 1e-6


@dataclass
class IsgLocationExport:
    """The ISG parameters of an identified machine and the residual they leave.

    Attributes
    ----------
    chain : str
        ISG ``chain`` (volcal's code without ``F``).
    workpiece_axes : int
        Number of axes on the workpiece side.
    centres : dict of str to float
        ``PXC`` ... : the configured pivots [mm].
    errors : dict of str to float
        ISG name (``X0C``) -> value [mm or rad].
    redundant : list of str
        ISG names of the errors the readings do not determine (written as 0).
    components : dict of str to ndarray
        Per rotary letter, the rows ``angle [deg], EX.. [mm], EA.. [rad]`` (empty: none).
    residual_um : ndarray
        Dispersion of the sphere centre the compensated control computes at each measured
        pose (distance from their mean) [um].
    scatter_before_um : ndarray
        The same without the compensation (the configured pivots) [um].
    notes : list of str
        Plain words for the file and the user.
    """

    chain: str
    workpiece_axes: int
    centres: dict[str, float]
    errors: dict[str, float]
    redundant: list[str] = field(default_factory=list)
    components: dict[str, Array] = field(default_factory=dict)
    residual_um: Array = field(default_factory=lambda: np.zeros(0))
    scatter_before_um: Array = field(default_factory=lambda: np.zeros(0))
    notes: list[str] = field(default_factory=list)


def _isg(name: str) -> str:
    from volcal.model.names import ISG_SYMBOLS

    return ISG_SYMBOLS[name]


def _to_isg(name: str, value: float) -> float:
    return value * (MM_PER_UM if name[1] in "XYZ" else RAD_PER_URAD)


def _scatter(identified: Any, control: Any, blocks: Any, sphere_mm: Any,
             before: bool = False) -> Array:
    """Centre dispersion the control computes at the measured poses [um].

    An r_test block's: the dispersion of the sphere's displacement in the nest, measured
    (``before``) or predicted (:mod:`volcal.compensate.rtest_residual`).
    """
    from volcal.compensate.rtest_residual import (
        machine_command,
        measured_dispersion,
        rtest_dispersion,
    )
    from volcal.measure.spheres import probe_centres
    from volcal.model.fiveaxis import exact_pose5

    out = []
    for b in blocks:
        if b.kind == "rtest":
            out.append(measured_dispersion(b) if before else rtest_dispersion(
                identified, machine_command(control, b.tool_offset_mm), b,
                sphere_mm[b.sphere]))
            continue
        q = probe_centres(identified, b.angles, np.asarray(sphere_mm[b.sphere], dtype=float),
                          b.tool_offset_mm)
        p, _ = exact_pose5(control, q, b.angles, b.tool_offset_mm)
        out.append(np.linalg.norm(p - p.mean(axis=0), axis=1) * 1e3)
    return np.concatenate(out) if out else np.zeros(0)


def isg_location_export(identified: Any, blocks: Any, sphere_mm: Any, configured: Any,
                        redundant: list[str] | tuple[str, ...] = ()) -> IsgLocationExport:
    """The ISG location parameters of an identified machine, read back as the control would.

    Parameters
    ----------
    identified : FiveAxisMachine
        The identified machine (``LocationResult.machine``).
    blocks : sequence of SphereReadings
        The measured poses.
    sphere_mm : dict of str to array_like
        Estimated sphere centres by sphere id [mm].
    configured : FiveAxisMachine
        The machine as configured (zero location errors): the scatter before.
    redundant : sequence of str
        ISO names of the errors held at zero by the identification.

    Returns
    -------
    IsgLocationExport
        ``residual_um`` is computed from the machine the written text describes
        (:func:`isg_location_csv` read back by :func:`read_isg_location`).
    """
    chain = identified.chain_obj
    code = chain.code
    centres: dict[str, float] = {}
    errors: dict[str, float] = {}
    comps: dict[str, Array] = {}
    for r in chain.rotary:
        ax = identified.rotary[r]
        for k, c in enumerate("XYZ"):
            centres[f"P{c}{r}"] = float(ax.pivot_mm[k])
        for n, v in ax.location.items():
            errors[_isg(n)] = _to_isg(n, float(v)) + 0.0
        if np.any(ax.values != 0.0):
            t = np.asarray(ax.nodes_deg, dtype=float)
            if ax.full_circle:
                t = np.unique(np.r_[t, 360.0])
            v = ax.component(t % 360.0 if ax.full_circle else t)
            comps[r] = np.column_stack([t, v[:, :3] * MM_PER_UM, v[:, 3:] * RAD_PER_URAD])
    exp = IsgLocationExport(code.replace("F", ""), code.index("F"), centres, errors,
                            [_isg(n) for n in redundant], comps)
    held = read_isg_location(isg_location_csv(exp), configured, "<written text>")
    exp.residual_um = _scatter(identified, held, blocks, sphere_mm)
    exp.scatter_before_um = _scatter(identified, configured, blocks, sphere_mm, before=True)
    exp.notes = [
        f"ISG/Beckhoff volumetric compensation (TF5280), ISG CSV; source: {SOURCE}",
        "units: mm (positions), rad (angles), deg (arguments); the errors (negate 0)",
        "sign: volcal's (docs/fiveaxis.md): angles in the sense of the commanded angle, the "
        "tool relative to the workpiece; the ISG pages at hand do not give the sign reference "
        "of a workpiece-side axis: check one value on the machine",
        f"chain {exp.chain} (volcal {code}), workpiece_axes {exp.workpiece_axes}; the "
        "position errors are measured from the centres of rotation P..",
    ]
    if exp.redundant:
        exp.notes.append("not determined by the readings (written as 0): "
                         + ", ".join(exp.redundant) + " (volcal locate's report)")
    exp.notes.append("not held by this file: the axial position of an axis line (Z0C, X0A, "
                     "Y0B: not a property of a line), the component errors over the angle"
                     + ("" if comps else " (none identified; the angular positioning ECC of a "
                        "rotary test: volcal compensate --format isg --session)")
                     + ", the tool's zero position and orientation (P0X.., N0X..: the "
                     "machine's configuration)")
    return exp


def isg_location_csv(exp: IsgLocationExport) -> str:
    """The ISG CSV text of the export.

    Parameters
    ----------
    exp : IsgLocationExport
        The export.

    Returns
    -------
    str
        ``//`` comments, the block of the centres, ``#``, the block of the location errors,
        then one block per rotary axis with component errors.
    """
    letters = [r for r in exp.chain if r in "ABC"]
    lines = ["// volcal: rotary axes' location errors for the ISG volumetric compensation "
             "(Beckhoff TF5280), ISG CSV format",
             "// activate: in the compensation list (vol_comp[i].file_name): file[j] this file, "
             "file_format[j] ISG_CSV, the axes' logical numbers ("
             + ", ".join(r.lower() for r in letters) + f"), chain {exp.chain}, "
             f"workpiece_axes {exp.workpiece_axes}; then #VOLCOMP [ID0 UPDATE]",
             "// limits: measured with the volumetric compensation off; valid for the probing's "
             "homing and rotary zero; |position errors| beyond a few mm are not plausible"]
    lines += [f"// {n}" for n in exp.notes]
    if exp.residual_um.size:
        lines.append("// predicted dispersion of the sphere centre on the measured poses: "
                     f"before {exp.scatter_before_um.max():.3f} um, after "
                     f"{exp.residual_um.max():.3f} um (largest)")
    lines.append(" ".join(f"{k:<16}" for k in exp.centres).rstrip())
    lines.append(" ".join(f"{v:<16.6f}" for v in exp.centres.values()).rstrip())
    lines.append("#")
    lines.append(" ".join(f"{k:<16}" for k in exp.errors).rstrip())
    lines.append(" ".join(f"{v:<16.9e}" for v in exp.errors.values()).rstrip())
    for r, rows in exp.components.items():
        lines.append("#")
        lines.append(f"// component errors of {r} over {r} [deg]: E{r}.. [mm], tilts and "
                     "angular positioning [rad]")
        names = [r] + [f"E{c}{r}" for c in "XYZABC"]
        lines.append(" ".join(f"{k:<16}" for k in names).rstrip())
        lines += [" ".join(f"{x:<16.9e}" if j else f"{x:<16.6f}" for j, x in enumerate(row))
                  .rstrip() for row in rows]
    return "\n".join(lines) + "\n"


def read_isg_location(text_or_path: str | Path, configured: Any, name: str | None = None
                      ) -> Any:
    """The machine an ISG CSV file of location errors describes (the control's view).

    Parameters
    ----------
    text_or_path : str or Path
        The file (a Path) or its text.
    configured : FiveAxisMachine
        The configured machine (its chain, pivots and linear errors).
    name : str, optional
        File name for messages.

    Returns
    -------
    FiveAxisMachine
        ``configured`` with the file's location errors (and component errors).

    Raises
    ------
    VolcalInputError
        Centres other than the configured pivots, a missing error, another chain.
    """
    from volcal.compensate.volumetric import parse_isg_csv
    from volcal.model.names import ISG_SYMBOLS
    from volcal.model.rotary import RotaryAxis

    if isinstance(text_or_path, Path):
        name = name or str(text_or_path)
        text = text_or_path.read_text(encoding="utf-8")
    else:
        text = text_or_path
    where = name or "ISG CSV"
    found: dict[str, float] = {}
    comps: dict[str, dict[str, Array]] = {}
    for b in parse_isg_csv(text, where):
        head = list(b)
        if head[0] in ("A", "B", "C") and all(h.startswith("E") for h in head[1:]):
            comps[head[0]] = b
            continue
        for h in head:
            found[h] = float(b[h][0])
    chain = configured.chain_obj
    rot = {}
    for r in chain.rotary:
        ax = configured.rotary[r]
        for k, c in enumerate("XYZ"):
            key = f"P{c}{r}"
            if key in found and abs(found[key] - ax.pivot_mm[k]) > 1e-6:
                raise VolcalInputError(f"{key} = {found[key]:g} mm: the configured pivot is "
                                       f"{ax.pivot_mm[k]:g} mm", where, None, key)
        loc = {}
        for n in ax.location_names:
            isg = ISG_SYMBOLS[n]
            if isg not in found:
                raise VolcalInputError(f"no position error {isg}", where, None, isg)
            loc[n] = found[isg] / (MM_PER_UM if n[1] in "XYZ" else RAD_PER_URAD)
        nodes, values = ax.nodes_deg, ax.values
        if r in comps:
            b = comps[r]
            t = np.asarray(b[r], dtype=float)
            vals = np.column_stack([b[f"E{c}{r}"] / (MM_PER_UM if c in "XYZ" else RAD_PER_URAD)
                                    for c in "XYZABC"])
            keep = t < 360.0 if ax.full_circle else np.ones(t.size, dtype=bool)
            nodes, values = t[keep], vals[keep]
        rot[r] = RotaryAxis(r, ax.pivot_mm, loc, nodes, values, ax.full_circle)
    from volcal.model.fiveaxis import FiveAxisMachine

    return FiveAxisMachine(chain, rot, configured.linear, configured.name)
