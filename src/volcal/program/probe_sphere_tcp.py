"""LinuxCNC probe_sphere program for a tool centre point control (``control_kinematics = "tcp"``).

With LinuxCNC's ``xyzac-trt-kins``/``xyzbc-trt-kins`` the program's X Y Z are the rotary
table's coordinates (the kinematics turns them into joint positions with its configured
pins: ``man 9 kins``, "xyzac-trt-kins", and ``src/emc/kinematics/trtfuncs.c``). The sphere
sits at one point of the table, so every pose probes the same program points: one from
above and four around the sphere at 30 deg above its equator (the stem points along the
table's -Z, away from all of them), each from ``clearance`` outside the expected contact to
``overtravel`` inside it with ``G38.2`` (stop on contact, error without one: LinuxCNC
G-code reference, "G38.x Straight Probe"), retracting the way it came. Between poses the
tool goes up to ``safe_z_mm`` in table coordinates (above the sphere), then the rotary
axes turn: the control keeps the tool point fixed on the table while they turn, so it
stays clear of the sphere. ``(PROBEOPEN file)`` ... ``(PROBECLOSE)`` log every trip point
in table coordinates; ``volcal import`` fits each pose's centre and turns it back into
machine coordinates through the configured kinematics (:mod:`volcal.session.probe_control`).

**Safe as written**: every probing move travels ``clearance`` (5 mm) before the expected
contact and ends ``overtravel`` (5 mm) inside, so a missing sphere stops the program with
LinuxCNC's error; ``safe_z_mm`` below the top approach point is refused.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from volcal.errors import ParameterError
from volcal.program.dialects import _ascii, _paren_comment

__all__ = ["probe_program_tcp"]


def _f(v: float, d: int) -> str:
    s = f"{v:.{d}f}"
    return s[1:] if s == "-0." + "0" * d else s


def probe_program_tcp(m: Any, name: str, options: Any, *, feed: float, clearance: float,
                      overtravel: float, elevation_deg: float, sphere_d: float,
                      tip_d: float) -> tuple[str, list[str]]:
    """The LinuxCNC program of a probe_sphere test on a tool centre point control.

    Parameters
    ----------
    m : Measurement
        The planned test (chain, sphere, poses, ``control_angle_sign``).
    name : str
        Program name.
    options : volcal.program.steps.ProgramOptions
        ``decimals``; ``safe_z_mm``: Z of the retract between poses, table coordinates [mm].
    feed, clearance, overtravel, elevation_deg, sphere_d, tip_d : float
        Probe feed [mm/min], approach and overtravel [mm], side points' elevation [deg],
        sphere and tip diameters [mm] (those of :mod:`volcal.program.probe_sphere`).

    Returns
    -------
    (text, warnings)
    """
    from volcal.session.probe_sphere import _angles, _keys

    k = _keys(m)
    ang = _angles(m)
    sign = k["control_angle_sign"]
    c = np.asarray(k["sphere_mm"], dtype=float)
    d = options.decimals
    r = 0.5 * (sphere_d + tip_d)
    top = c[2] + r + clearance
    safe = float(options.safe_z_mm)
    if safe < top:
        raise ParameterError(f"{{safe_z_mm=}}{safe:g}: below the top approach point "
                               f"{top:g} mm of the sphere (table coordinates of a tool centre "
                               "point control): the retract must clear the sphere")
    letters = list(ang)
    out = [_paren_comment(h) for h in (
        f"volcal probe_sphere program {name}: test {m.id}, chain {k['chain'].code}, {m.n} poses",
        f"sphere diameter {sphere_d:g} mm, probe tip diameter {tip_d:g} mm",
        "coordinates: the table's (tool centre point kinematics, e.g. LinuxCNC "
        "xyzac-trt-kins); G54 = no work offset, no tool length offset",
        "rotary angles: the control's" + (" (minus volcal's: control_angle_sign = -1)"
                                          if sign < 0 else ", volcal's"),
        f"G38.2 stops on contact and raises an error without one; every probing move "
        f"travels {clearance:g} mm before the expected contact")]
    out += ["G21 G90 G17 G40 G49 G94 G54", f"(PROBEOPEN {_ascii(m.id)}.txt)"]
    el = np.deg2rad(elevation_deg)
    moves = [f"G0 X{_f(c[0], d)} Y{_f(c[1], d)}", f"G0 Z{_f(top, d)}",
             f"G38.2 Z{_f(c[2] + r - overtravel, d)} F{feed:g}", f"G0 Z{_f(top, d)}"]
    for t in np.deg2rad([0.0, 90.0, 180.0, 270.0]):
        u = np.array([np.cos(t), np.sin(t)])
        h = c[2] + r * np.sin(el)
        start = c[:2] + (r * np.cos(el) + clearance) * u
        end = c[:2] + (r * np.cos(el) - overtravel) * u
        moves += [f"G0 X{_f(start[0], d)} Y{_f(start[1], d)}", f"G0 Z{_f(h, d)}",
                  f"G38.2 X{_f(end[0], d)} Y{_f(end[1], d)} F{feed:g}",
                  f"G0 X{_f(start[0], d)} Y{_f(start[1], d)}", f"G0 Z{_f(top, d)}"]
    for i in range(m.n):
        out.append(_paren_comment(f"pose {i + 1} of {m.n}"))
        out.append(f"G0 Z{_f(safe, d)}")
        out.append("G0 " + " ".join(f"{a}{_f(sign * ang[a][i], d)}" for a in letters))
        out += moves
    out += ["(PROBECLOSE)", f"G0 Z{_f(safe, d)}", "M2"]
    return "\n".join(out) + "\n", []
