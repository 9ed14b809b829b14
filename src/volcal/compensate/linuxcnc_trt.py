"""LinuxCNC's table-rotary-tilting kinematics: the location errors as HAL pins.

LinuxCNC's ``xyzac-trt-kins`` (C table on an A cradle) and ``xyzbc-trt-kins`` (C on B)
compute the workpiece coordinates of the tool from the joints with (source:
``src/emc/kinematics/trtfuncs.c``, ``xyzacKinematicsForward``)

``world = R_z(-c) [R_x(-a) (J - p_A) + p_A - r] + r``,
``r = (x-rot-point, y-rot-point, z-rot-point)``, ``p_A = r + (0, y-offset, z-offset +
tool-offset)``

(for ``xyzbc``: ``R_y(-b)`` about ``p_B = r + (x-offset, 0, z-offset + tool-offset)``): the
C line is vertical through ``(x-rot-point, y-rot-point)``, the A line parallel to X through
``y = y-rot-point + y-offset``, ``z = z-rot-point + z-offset`` (the B line parallel to Y
through ``x = x-rot-point + x-offset``, ``z = z-rot-point + z-offset``). Its rotary angles
turn the other way than volcal's (``docs/fiveaxis.md``: volcal's ``+theta`` turns the tool
relative to the workpiece by ``+theta``; LinuxCNC's ``R_z(-c)`` turns it by ``-c``, the
direction the LinuxCNC documentation calls opposite to the conventional one): volcal's
angle is minus the joint's. ``tests/compensate/test_linuxcnc_trt.py`` lets the installed
module decide both (called in-process through a stub of the HAL functions it imports).

So the pins hold the **positions** of the two lines: ``x-rot-point = p_C,x + EX0C``,
``y-rot-point = p_C,y + EY0C``, ``y-offset = (p_A,y + EY0A) - (p_C,y + EY0C)``, ``z-offset =
(p_A,z + EZ0A) - z-rot-point``, with ``z-rot-point`` kept as configured (only the sum of
``z-rot-point`` and ``z-offset`` enters). They cannot hold the lines' **orientations**
(``EA0C``, ``EB0C``, ``EB0A``, ``EC0A``: the kinematics has no tilt) nor the **zeros**
(``EC0C`` is a rotation of the workpiece zero, ``EA0A`` a joint's home offset,
``[JOINT_n] HOME_OFFSET`` in the INI file): :func:`trt_export` says so and predicts the
scatter those leave on the measured poses.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["TRT_KINS", "TrtExport", "trt_export", "trt_hal"]

TRT_KINS = {("C", "A"): "xyzac-trt-kins", ("C", "B"): "xyzbc-trt-kins"}
"""Rotary letters (workpiece side first) -> LinuxCNC's kinematics module."""
SOURCE = ("LinuxCNC src/emc/kinematics/trtfuncs.c (xyzacKinematicsForward, "
          "xyzbcKinematicsForward); docs: man 9 kins, 'xyzac-trt-kins'")


@dataclass
class TrtExport:
    """The pins of a trt kinematics and what they cannot hold.

    Attributes
    ----------
    kins : str
        ``'xyzac-trt-kins'`` or ``'xyzbc-trt-kins'``.
    pins : dict of str to float
        Pin name (without the module prefix) -> value [mm].
    not_held : dict of str to float
        The identified errors the kinematics cannot hold [um or urad].
    residual_um : ndarray
        Predicted dispersion of the sphere centre the control computes at each measured pose
        with these pins (distance from their mean) [um]; for an r_test test's poses the
        dispersion of the sphere's displacement in the nest
        (:mod:`volcal.compensate.rtest_residual`).
    scatter_before_um : ndarray
        The same with the configured pins [um] (r_test: the measured displacements).
    notes : list of str
        Plain words for the HAL file and the user.
    """

    kins: str
    pins: dict[str, float]
    not_held: dict[str, float] = field(default_factory=dict)
    residual_um: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    scatter_before_um: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    notes: list[str] = field(default_factory=list)


def _lines(machine: Any) -> tuple[str, NDArray[np.float64], NDArray[np.float64], str]:
    chain = machine.chain_obj
    key = tuple(chain.rotary)
    if key not in TRT_KINS or not all(chain.on_workpiece_side(r) for r in key):
        raise VolcalInputError(f"chain {chain.code}: LinuxCNC's trt kinematics hold a C table "
                               "on an A or B cradle (chain CA... or CB... with both before F)")
    second = key[1]
    c_ax, t_ax = machine.rotary["C"], machine.rotary[second]
    c_pt = c_ax.pivot_mm + c_ax.position_um() * 1e-3
    t_pt = t_ax.pivot_mm + t_ax.position_um() * 1e-3
    return TRT_KINS[key], c_pt, t_pt, second


def trt_pins(machine: Any, z_rot_point_mm: float | None = None) -> tuple[str, dict[str, float]]:
    """The pins that put LinuxCNC's lines where a machine's are.

    Parameters
    ----------
    machine : FiveAxisMachine
        The machine (nominal pivots and location errors).
    z_rot_point_mm : float, optional
        ``z-rot-point`` to keep (default the C pivot's z).

    Returns
    -------
    kins : str
    pins : dict of str to float
        [mm].
    """
    kins, c_pt, t_pt, second = _lines(machine)
    zr = float(c_pt[2] if z_rot_point_mm is None else z_rot_point_mm)
    pins = {"x-rot-point": float(c_pt[0]), "y-rot-point": float(c_pt[1]), "z-rot-point": zr}
    if second == "A":
        pins.update({"y-offset": float(t_pt[1] - c_pt[1]), "z-offset": float(t_pt[2] - zr)})
    else:
        pins.update({"x-offset": float(t_pt[0] - c_pt[0]), "z-offset": float(t_pt[2] - zr)})
    return kins, pins


def trt_export(identified: Any, blocks: Any, sphere_mm: Any,
               configured: Any | None = None, z_rot_point_mm: float | None = None,
               control: Any | None = None) -> TrtExport:
    """The pins of an identified machine and the residual they leave.

    Parameters
    ----------
    identified : FiveAxisMachine
        The identified machine (``LocationResult.machine``).
    blocks : sequence of SphereReadings
        The measured poses (their angles and tool offsets).
    sphere_mm : dict of str to array_like
        Estimated sphere centres by sphere id [mm].
    configured : FiveAxisMachine, optional
        The machine as configured (default the identified one's nominal pivots).
    z_rot_point_mm : float, optional
        ``z-rot-point`` to keep.
    control : FiveAxisMachine, optional
        The machine the control is given: lines without tilt, best fitted to the readings
        (:func:`volcal.identify.location.identify_location` with ``hold`` = the
        orientations and zeros); default the identified machine's positions alone.

    Returns
    -------
    TrtExport
    """
    from volcal.measure.spheres import probe_centres
    from volcal.model.fiveaxis import exact_pose5

    chain = identified.chain_obj
    held_names = []
    for r in chain.rotary:
        held_names += list(identified.rotary[r].location_names[:2])
    loc = {n: v for r in chain.rotary for n, v in identified.rotary[r].location.items()}
    held = control if control is not None else identified.with_location(
        [loc[n] if n in held_names else 0.0 for r in chain.rotary
         for n in identified.rotary[r].location_names])
    kins, pins = trt_pins(held, z_rot_point_mm)
    nominal = configured if configured is not None else identified.with_location(
        np.zeros(5 * len(chain.rotary)))
    not_held = {n: v for n, v in loc.items() if n not in held_names and abs(v) > 0}

    def scatter(control: Any, before: bool = False) -> NDArray[np.float64]:
        from volcal.compensate.rtest_residual import (
            machine_command,
            measured_dispersion,
            rtest_dispersion,
        )

        out = []
        for b in blocks:
            if b.kind == "rtest":  # the sphere's displacement in the nest
                out.append(measured_dispersion(b) if before else rtest_dispersion(
                    identified, machine_command(control, b.tool_offset_mm), b,
                    sphere_mm[b.sphere]))
                continue
            c = probe_centres(identified, b.angles, np.asarray(sphere_mm[b.sphere], dtype=float),
                              b.tool_offset_mm)
            p, _ = exact_pose5(control, c, b.angles, b.tool_offset_mm)
            out.append(np.linalg.norm(p - p.mean(axis=0), axis=1) * 1e3)
        return np.concatenate(out)

    exp = TrtExport(kins, pins, not_held, scatter(held), scatter(nominal, before=True))
    exp.notes = [
        f"{kins}: the positions of the C and {'A' if 'y-offset' in pins else 'B'} lines "
        f"(source: {SOURCE})",
        "only the sum z-rot-point + z-offset enters the kinematics; z-rot-point is kept",
        "LinuxCNC's rotary joints turn opposite to volcal's angles (volcal's angle = minus "
        "the joint's); the pins are positions and do not depend on it",
    ]
    if not_held:
        exp.notes.append("not held by the kinematics (no tilt, no zero of the angles): "
                         + ", ".join(f"{n} = {v:.1f}" for n, v in not_held.items())
                         + f"; they leave a scatter of {exp.residual_um.max():.2f} um (largest)"
                         " of the sphere centre (R-test: of its displacement in the nest) on "
                         "the measured poses")
    return exp


def trt_hal(exp: TrtExport) -> str:
    """The HAL file: one ``setp`` per pin, the notes as comments.

    Parameters
    ----------
    exp : TrtExport
        The export.

    Returns
    -------
    str
        ``setp xyzac-trt-kins.x-rot-point 400.001220`` ... (mm, 6 decimals); load it after
        the kinematics (``HALFILE`` in the INI's ``[HAL]`` section, after the file that
        ``loadrt``s the kinematics).
    """
    lines = ["# volcal: rotary axes' location errors for LinuxCNC's " + exp.kins,
             "# activate: add this file as a HALFILE after the one that loads the kinematics",
             "# (loadrt " + exp.kins + "); values in mm",
             "# limits: float pins without bounds in the module; the values are the axis"
             " lines' positions in machine coordinates, valid with tool-offset as the control"
             " sets it (the tool length) and the rotary joints homed where the probing had them"]
    lines += [f"# {n}" for n in exp.notes]
    if exp.residual_um.size:
        lines.append("# predicted dispersion of the sphere centre: before "
                     f"{exp.scatter_before_um.max():.3f} um, after "
                     f"{exp.residual_um.max():.3f} um (largest over the measured poses)")
    lines += [f"setp {exp.kins}.{k} {v:.6f}" for k, v in exp.pins.items()]
    return "\n".join(lines) + "\n"
