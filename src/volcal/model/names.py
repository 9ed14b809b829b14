"""ISO 230-1 names of the 21 rigid-body errors and their mapping to the seeds' symbols.

Component errors of a linear axis ``K`` (ISO 230-1:2012, 3.4):

========  =====================  ========  =========  ======
ISO name  meaning                Wang      Soons      unit
========  =====================  ========  =========  ======
EXX       positioning of X       Dx(x)     e_x(x)     um
EYX       straightness of X in Y Dy(x)     e_y(x)     um
EZX       straightness of X in Z Dz(x)     e_z(x)     um
EAX       roll of X              Ax(x)     eps_x(x)   urad
EBX       pitch of X             Ay(x)     eps_y(x)   urad
ECX       yaw of X               Az(x)     eps_z(x)   urad
EC0Y      squareness Y to X      -Oxy/Y    S_xy       urad
EB0Z      squareness Z to X      Ozx/Z     -S_xz      urad
EA0Z      squareness Z to Y      -Oyz/Z    S_yz       urad
========  =====================  ========  =========  ======

(and likewise for Y and Z). Wang's squareness symbols are lengths: the deviation at the
end of the travel ``Y`` or ``Z`` (his eq. 1 adds ``y/Y * Oxy`` to the X error); the
signs follow from his eq. 1 and are checked in ``tests/measure/test_wang_diagonal.py``.
See ``docs/conventions.md`` for the signs.
"""

from __future__ import annotations

AXES: tuple[str, str, str] = ("X", "Y", "Z")
"""Machine axes in their fixed order; index 0, 1, 2."""

COMPONENTS: tuple[str, ...] = ("EX", "EY", "EZ", "EA", "EB", "EC")
"""Component prefixes: 3 translations [um] then 3 rotations [urad]."""

SQUARENESS_NAMES: tuple[str, str, str] = ("EC0Y", "EB0Z", "EA0Z")
"""Squareness errors [urad]: Y to X about Z, Z to X about Y, Z to Y about X."""


def component_name(axis: int | str, component: int) -> str:
    """ISO 230-1 name of a component error.

    Parameters
    ----------
    axis : int or str
        Moving axis, 0/1/2 or 'X'/'Y'/'Z'.
    component : int
        0..5 for EX, EY, EZ, EA, EB, EC.

    Returns
    -------
    str
        For example ``component_name('X', 4) == 'EBX'``.
    """
    a = AXES[axis] if isinstance(axis, int) else axis.upper()
    return COMPONENTS[component] + a


COMPONENT_NAMES: tuple[str, ...] = tuple(
    component_name(a, c) for a in range(3) for c in range(6)
)
"""The 18 component errors, axis-major: EXX, EYX, EZX, EAX, EBX, ECX, EXY, ..., ECZ."""

WANG_SYMBOLS: dict[str, str] = {
    "EXX": "Dx(x)", "EYX": "Dy(x)", "EZX": "Dz(x)", "EAX": "Ax(x)", "EBX": "Ay(x)", "ECX": "Az(x)",
    "EXY": "Dx(y)", "EYY": "Dy(y)", "EZY": "Dz(y)", "EAY": "Ax(y)", "EBY": "Ay(y)", "ECY": "Az(y)",
    "EXZ": "Dx(z)", "EYZ": "Dy(z)", "EZZ": "Dz(z)", "EAZ": "Ax(z)", "EBZ": "Ay(z)", "ECZ": "Az(z)",
    "EC0Y": "-Oxy/Y", "EB0Z": "Ozx/Z", "EA0Z": "-Oyz/Z",
}
"""ISO 230-1 name -> symbol of Wang & Liotto (seed 000); squareness from his eq. (1)."""

SOONS_SYMBOLS: dict[str, str] = {
    "EXX": "e_x(x)", "EYX": "e_y(x)", "EZX": "e_z(x)",
    "EAX": "eps_x(x)", "EBX": "eps_y(x)", "ECX": "eps_z(x)",
    "EXY": "e_x(y)", "EYY": "e_y(y)", "EZY": "e_z(y)",
    "EAY": "eps_x(y)", "EBY": "eps_y(y)", "ECY": "eps_z(y)",
    "EXZ": "e_x(z)", "EYZ": "e_y(z)", "EZZ": "e_z(z)",
    "EAZ": "eps_x(z)", "EBZ": "eps_y(z)", "ECZ": "eps_z(z)",
    "EC0Y": "S_xy", "EB0Z": "-S_xz", "EA0Z": "S_yz",
}
"""ISO 230-1 name -> symbol of Soons (seed 004, eq. 1)."""
