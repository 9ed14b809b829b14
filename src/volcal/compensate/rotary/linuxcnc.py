"""LinuxCNC ``COMP_FILE`` of a rotary joint (angular positioning error).

LinuxCNC loads a joint's compensation file the same way for a rotary joint as for a
linear one (``usrmotLoadComp``, ``src/emc/motion/usrmotintf.cc``; at most 256 entries,
strictly increasing, ``src/emc/motion/command.c``): ``nominal forward_trim reverse_trim``
per line, in the **joint's units, degrees** for an angular joint (``[TRAJ] ANGULAR_UNITS
= degree``). ``COMP_FILE_TYPE = 1`` (default): the trims are added to the commanded joint
position, so they hold the correction ``-error``; type 0 holds the actual angles
``nominal + error``. The forward trim applies while the joint moves in the positive
direction, the reverse one while it moves in the negative direction (``compute_screw_comp``
in ``src/emc/motion/control.c``).

The table is a function of the joint position, which LinuxCNC does not reduce modulo 360
(a full-circle axis counts turns in its joint position; ``WRAPPED_ROTARY`` wraps the axis
coordinate, not the joint). volcal therefore writes the periodic profile of a full-circle
axis over several turns, ``[-360 n, 360 (n + 1)]`` deg (``turns`` = n, default 1: -360 to
720 deg), one entry per target angle per turn; beyond the first and last entry LinuxCNC
holds the end value (``EMCMOT_SET_JOINT_COMP``: sentinel entries at -/+ DBL_MAX), which on
a periodic table is the value at 0 deg. A limited axis gets its targets once.

References
----------
LinuxCNC documentation, "INI Configuration" ``[JOINT_<num>]`` ``COMP_FILE``,
``COMP_FILE_TYPE``; "Lead screw compensation" (Integrator's manual); LinuxCNC source
``usrmotintf.cc`` (loader), ``command.c`` (256 entries), ``control.c`` (application by
direction).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.compensate.rotary.profile import DEG_PER_URAD, RotaryProfile
from volcal.compensate.tables import sign_factor
from volcal.errors import ParameterError, VolcalInputError

__all__ = ["MAX_ENTRIES", "linuxcnc_rotary_files", "linuxcnc_rotary_nodes",
           "read_linuxcnc_rotary"]

MAX_ENTRIES = 256
"""``EMCMOT_COMP_SIZE``: entries per joint."""
DECIMALS = 9
"""Values in degrees with 9 decimals (1e-9 deg = 0.017 nrad)."""


def linuxcnc_rotary_nodes(p: RotaryProfile, turns: int = 1) -> NDArray[np.float64]:
    """Nominal joint positions of the table [deg]: the targets, repeated over the turns.

    Parameters
    ----------
    p : RotaryProfile
        The axis' error.
    turns : int
        Full-circle axis: turns either side of 0..360 deg.

    Returns
    -------
    ndarray
    """
    if not p.modulo:
        return np.asarray(p.targets_deg, dtype=float)
    if turns < 0:
        raise ParameterError(f"{{rotary_turns=}}{turns}: expected 0 or more")
    base = np.asarray(p.targets_deg, dtype=float)
    nodes = np.concatenate([base + 360.0 * k for k in range(-turns, turns + 2)])
    return nodes[nodes <= 360.0 * (turns + 1) + 1e-9]


def linuxcnc_rotary_files(p: RotaryProfile, name: str, comp_type: int = 1, turns: int = 1,
                          joint: str = "JOINT_n", sign: str = "correction"
                          ) -> tuple[dict[str, str], list[str]]:
    """The comp file of one rotary axis and the README lines for it.

    Parameters
    ----------
    p : RotaryProfile
        The axis' error.
    name : str
        File name (``C.comp``).
    comp_type : int
        ``COMP_FILE_TYPE``: 1 (trims, default) or 0 (actual angles).
    turns : int
        Full-circle axis: turns written either side of 0..360 deg.
    joint : str
        Section name printed in the README.
    sign : str
        ``'correction'`` (LinuxCNC adds the trims: default) or ``'error'`` (for inspection:
        loading it doubles the error).

    Returns
    -------
    files : dict of str to str
    notes : list of str

    Raises
    ------
    VolcalInputError
        More than 256 entries.
    """
    if comp_type not in (0, 1):
        raise ParameterError(f"{{linuxcnc_type=}}{comp_type}: expected 0 or 1")
    nom = linuxcnc_rotary_nodes(p, turns)
    if nom.size > MAX_ENTRIES:
        raise VolcalInputError(
            f"LinuxCNC {name}: {nom.size} entries exceed the limit of {MAX_ENTRIES} per joint "
            f"({p.targets_deg.size} targets x {2 * turns + 2} turns); write fewer turns")
    s = -sign_factor(sign)  # correction: trim = -error [deg]
    fwd = -s * p.error_urad(nom, "+") * DEG_PER_URAD
    rev = -s * p.error_urad(nom, "-") * DEG_PER_URAD
    if comp_type == 0:  # actual angle = nominal + error = nominal - trim
        fwd, rev = nom - fwd, nom - rev
    lines = [f"{n:.6f} {f:.{DECIMALS}f} {r:.{DECIMALS}f}" for n, f, r in zip(nom, fwd, rev,
                                                                                strict=True)]
    ax = p.axis.upper()
    notes = [
        "", f"Rotary axis {ax} (test {p.id}): {name}",
        f"[{joint}]   (the joint of axis {ax}, TYPE = ANGULAR)", f"COMP_FILE = {name}",
        f"COMP_FILE_TYPE = {comp_type}",
        *([] if sign == "correction" else
          ["Sign: error (trim = +error): loading this DOUBLES the error; for inspection only."]),
        "Columns: nominal [deg], " + ("forward trim [deg], reverse trim [deg]; the trim "
                                       "(-error) is added to the commanded joint angle."
                                       if comp_type == 1 else
                                       "actual angle moving forward [deg], moving in reverse "
                                       "[deg]; LinuxCNC adds nominal - actual."),
        (f"Full circle: the periodic table is written over joint angles {nom[0]:g} to "
         f"{nom[-1]:g} deg ({2 * turns + 2} turns); LinuxCNC does not reduce the joint "
         "angle modulo 360 and holds the end values beyond the table: keep the joint "
         "inside this span (MIN_LIMIT/MAX_LIMIT) or write more turns."
         if p.modulo else f"Limited axis: entries at the targets {nom[0]:g} to {nom[-1]:g} "
         "deg; beyond them LinuxCNC holds the end values."),
        ("Forward and reverse trims from the test's two approach directions."
         if p.bidirectional else "One approach direction measured: forward = reverse."),
        "Do not set BACKLASH on this joint together with the table.",
        "LinuxCNC 2.9.0~pre1 (Debian 12) was seen not to apply a step of the trim larger "
        "than MAX_ACCELERATION/4 x servo period^2 of the joint (the reversal at a change of "
        "direction): after a reversal compare joint.N.backlash-filt with "
        "joint.N.backlash-corr (halcmd getp); volcal's docs/controllers.md (LinuxCNC).",
    ]
    return {name: "\n".join(lines) + "\n"}, notes


def read_linuxcnc_rotary(path: str | Path, comp_type: int = 1
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                    NDArray[np.float64]]:
    """Load a rotary comp file as LinuxCNC does: (nominal [deg], fwd, rev trims [deg]).

    Parameters
    ----------
    path : str or Path
        The comp file.
    comp_type : int
        ``COMP_FILE_TYPE``.

    Returns
    -------
    nominal, forward, reverse : ndarray
    """
    from volcal.compensate.linuxcnc import load_linuxcnc_comp

    return load_linuxcnc_comp(path, comp_type)
