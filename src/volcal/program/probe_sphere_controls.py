"""HEIDENHAIN and Siemens probe_sphere programs: probe the sphere, print every trip point.

Both programs do what volcal's LinuxCNC program does (:mod:`volcal.program.probe_sphere`)
with the control's own probing function, for a control whose X Y Z are the linear axes'
positions (``control_kinematics = "joints"``, no tool centre point transformation): for
each planned pose they retract Z in machine coordinates, turn the rotary axes with the
linear axes still, move over the sphere centre the **configured** kinematics predict and
probe one point from above (``Z-``) and three or four around the sphere at 30 deg above its
equator along ``X+``, ``X-``, ``Y+``, ``Y-`` (those clear of the stem, which points along
the table's -Z turned with the table), each from ``clearance`` (10 mm) outside the expected
contact to at most ``overtravel`` (10 mm) past it, retracting the way it came. Every trip
point is written to a text file with the pose's angles; ``volcal import FILE --session S
--measurement ID`` fits the centres (:mod:`volcal.importer.probe_control_log`).

**HEIDENHAIN TNC 640 (Klartext).** Probing: touch probe cycle 0 "REFERENCE PLANE"
(``TCH PROBE 0.0 REF. PLANE Q10 Z-`` / ``TCH PROBE 0.1 X.. Y.. Z..``: from the pre-position
in ``0.1`` the probe moves in the given axis direction at the probing feed of the touch
probe table, at most the table's measuring path ``DIST``; without contact the control
stops the program with an error message; after the contact it returns to the
pre-position): TNC 640 User's Manual Touch Probe Cycles, "Special cycles", "REFERENCE
PLANE (Cycle 0)". The trip point: the preassigned Q parameters ``Q115``, ``Q116``,
``Q117`` hold "the coordinates of the spindle position at the moment of contact during
programmed measurement with the 3-D touch probe", referred to the active datum, with "the
length of the stylus and the radius of the ball tip not compensated" (TNC 640 User's
Manual, HEIDENHAIN Conversational Programming, 34059x-05, 1/2015, 9.11 "Preassigned Q
parameters", p. 356; DIN/ISO manual p. 341). Output: ``FN 16: F-PRINT`` with a format file
(``<program>.A``, written beside the program) that prints one line per call, ``VOLCAL_TNC
X Y Z R1 R2`` (``%10.4LF``; ``R1``, ``R2`` the pose's angles held in ``Q1``, ``Q2``); the
control appends the lines of every call of the program to the one output file (same
manual, 9.8 "Additional functions", "FN 16: F-PRINT: formatted output of text and Q
parameter values"). Start block: ``FUNCTION RESET TCPM`` and ``PLANE RESET STAY`` (no
tool centre point, no tilted working plane), Z retracted with ``M91`` (machine
coordinates) before every rotary move; positioning at the program feed
(``ProgramOptions.feed``), never ``FMAX``.

**Siemens SINUMERIK 840D sl.** Probing: ``MEAS=1 G1 X.. Y.. Z.. F..`` ("measurement with
deletion of distance-to-go", trigger event 1 = rising edge of probe 1), the result in
``$AA_MM[X]``, ``$AA_MM[Y]``, ``$AA_MM[Z]`` ("acquired measured value in the machine
coordinate system") and the probe's status ``$AC_MEA[1]`` (1: the probe switched):
SINUMERIK 840D sl Programming Manual Job Planning (6FC5398-2BP10-1BA0, 03/2006), 5.7
"Measurements with touch trigger probe (MEAS, MEAW)". After each ``MEAS`` block ``STOPRE``,
then ``IF $AC_MEA[1]==0 GOTOF NO_CONTACT`` (``SETAL(65000)``, ``M0``: the program stops
with a cycle alarm) and ``WRITE(ERR,"<file>","VOLCAL_840D "<<$AA_MM[X]<<...)`` (same
manual, "File functions", ``WRITE``: appends one line to a file of the NC's file system,
``ERR`` the result, checked: ``SETAL(65001)`` on an error). Start block: ``G71 G90 G94 G17
G40 G500 D0 TRAFOOF`` (no settable frame, no tool offset, no 5-axis transformation), Z
retracted with ``SUPA`` before every rotary move, positioning with ``G1`` at the program
feed.

**What the programs need** (stated in their headers): the touch probe in the spindle,
calibrated (its effective ball diameter is the test's ``tip_diameter_mm``), with tool
length and radius 0 for these positioning blocks (volcal carries the tip offset
``tool_offset_mm``: the programs' and the logged coordinates are the spindle's); the
sphere where the test says (``sphere_mm`` within a few mm, ``sphere_diameter_mm``); the
machine datum as the program's zero (HEIDENHAIN: the preset of the machine datum;
Siemens: no basic frame), so that the safe machine Z (``--safe-z-mm``, refused below
:func:`safe_height`: the sphere's highest point, plus tip and clearance, at the poses and
while the rotary axes turn between them) is a height in the program's frame; HEIDENHAIN:
``DIST`` of the touch probe table at least ``clearance + overtravel`` (20 mm); nothing
within ``clearance`` of the probing paths.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import ParameterError, VolcalInputError
from volcal.program.dialects import _ascii, _num

__all__ = ["ProbeMove", "check_safe_z", "heidenhain_format_file", "probe_moves",
           "probe_program_heidenhain", "probe_program_siemens", "safe_height",
           "HEIDENHAIN_TAG", "SIEMENS_TAG", "SIEMENS_FILE"]

HEIDENHAIN_TAG = "VOLCAL_TNC"
"""First word of every line the HEIDENHAIN program prints (``FN 16``)."""
SIEMENS_TAG = "VOLCAL_840D"
"""First word of every line the Siemens program writes (``WRITE``)."""
SIEMENS_FILE = "VOLCAL_PROBE"
"""Name of the file the Siemens program writes to (``WRITE``; the NC adds its type)."""
CLEARANCE_MM = 10.0
"""Free travel before the expected contact of the HEIDENHAIN and Siemens programs [mm]."""
OVERTRAVEL_MM = 10.0
"""How far past the expected contact their probing moves may go [mm]: with the clearance,
sphere centres off the predicted ones by up to about 5 mm are probed (pivots off by 2 mm,
as in the study, put them up to 4.5 mm off)."""
ALARM_NO_CONTACT = 65000
"""Siemens cycle alarm raised (``SETAL``) when a probing move ends without contact."""
ALARM_WRITE = 65001
"""Siemens cycle alarm raised when ``WRITE`` reports an error."""

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ProbeMove:
    """One probing move.

    Attributes
    ----------
    pose : int
        Pose (0-based).
    start : ndarray, shape (3,)
        Pre-position, ``clearance`` outside the expected contact [mm].
    end : ndarray, shape (3,)
        ``overtravel`` inside the expected contact [mm].
    axis : str
        Probing axis ``'X'``, ``'Y'`` or ``'Z'``.
    sign : int
        Probing direction along it (+1 or -1).
    """

    pose: int
    start: Array
    end: Array
    axis: str
    sign: int


def probe_moves(m: Any, *, clearance: float, overtravel: float, elevation_deg: float,
                sphere_d: float, tip_d: float) -> tuple[dict[str, Array], Array,
                                                         list[ProbeMove], list[str]]:
    """The axis-parallel probing moves of every pose around the predicted centres.

    Parameters
    ----------
    m : Measurement
        The planned probe_sphere test.
    clearance, overtravel : float
        Free travel before and after the expected contact [mm].
    elevation_deg : float
        Elevation of the side points above the sphere's equator [deg].
    sphere_d, tip_d : float
        Sphere and probe ball diameters [mm].

    Returns
    -------
    angles : dict of str to ndarray
        volcal's angles per rotary letter [deg].
    centres : ndarray, shape (n, 3)
        Centres the configured kinematics predict [mm].
    moves : list of ProbeMove
        Pose by pose: the top point, then the sides.
    warnings : list of str
    """
    from volcal.measure.spheres import probe_centres
    from volcal.model.fiveaxis import exact_pose5
    from volcal.session.probe_sphere import _angles, _keys, five_axis_machine

    k = _keys(m)
    nominal = five_axis_machine(m)
    ang = _angles(m)
    centres = probe_centres(nominal, ang, k["sphere_mm"], m.tool_offset)
    _, R = exact_pose5(nominal, centres, ang, m.tool_offset)
    r = 0.5 * (sphere_d + tip_d)
    el = np.deg2rad(elevation_deg)
    moves: list[ProbeMove] = []
    warnings: list[str] = []
    for i in range(m.n):
        c = centres[i]
        stem = R[i].T @ np.array([0.0, 0.0, -1.0])  # the table's -Z in machine axes
        moves.append(ProbeMove(i, c + np.array([0.0, 0.0, r + clearance]),
                               c + np.array([0.0, 0.0, r - overtravel]), "Z", -1))
        n_side = 0
        for ax, u in (("X", (1.0, 0.0)), ("Y", (0.0, 1.0)), ("X", (-1.0, 0.0)),
                      ("Y", (0.0, -1.0))):
            uu = np.array([u[0], u[1], 0.0])
            if not (uu @ stem < 0.3 * np.linalg.norm(stem[:2]) or np.linalg.norm(stem[:2]) < 0.3):
                continue
            h = np.array([0.0, 0.0, r * np.sin(el)])
            start = c + h + (r * np.cos(el) + clearance) * uu
            end = c + h + (r * np.cos(el) - overtravel) * uu
            moves.append(ProbeMove(i, start, end, ax, -int(round(u[0] + u[1]))))
            n_side += 1
        if n_side < 3:
            warnings.append(f"{m.id}: pose {i + 1}: only {n_side} side points clear of the stem")
    return ang, centres, moves, warnings


SWEEP_SAMPLES = 24
"""Samples of each rotary move between two poses for :func:`safe_height`."""


def safe_height(m: Any, angles: dict[str, Array], above_mm: float) -> float:
    """The lowest safe Z: the predicted sphere centre's highest Z plus ``above_mm``.

    Over every pose and every rotary move between consecutive poses (the angles moving
    linearly, :data:`SWEEP_SAMPLES` samples each), the centre the configured kinematics
    predict; the linear axes stand still while the rotary axes turn.

    Parameters
    ----------
    m : Measurement
        The planned test.
    angles : dict of str to ndarray
        volcal's angles per rotary letter [deg].
    above_mm : float
        Height to keep above the centre [mm] (sphere radius + tip radius + clearance).

    Returns
    -------
    float
        [mm].
    """
    from volcal.measure.spheres import probe_centres
    from volcal.session.probe_sphere import _keys, five_axis_machine

    t = np.linspace(0.0, 1.0, SWEEP_SAMPLES + 1)
    swept = {a: np.concatenate([v[:1]] + [v[i] + t[1:] * (v[i + 1] - v[i])
                                          for i in range(len(v) - 1)]) for a, v in angles.items()}
    c = probe_centres(five_axis_machine(m), swept, _keys(m)["sphere_mm"], m.tool_offset)
    return float(c[:, 2].max() + above_mm)


def check_safe_z(m: Any, angles: dict[str, Array], safe_z_mm: float, above_mm: float
                 ) -> None:
    """Refuse a retract height that does not clear the sphere (:func:`safe_height`).

    Parameters
    ----------
    m : Measurement
        The planned test.
    angles : dict of str to ndarray
        volcal's angles per rotary letter [deg].
    safe_z_mm : float
        The program's retract height, machine Z [mm] (``--safe-z-mm``).
    above_mm : float
        Height to keep above the centre [mm] (sphere radius + tip radius + clearance).

    Raises
    ------
    VolcalInputError
        ``safe_z_mm`` below the highest point of the sphere at the poses and while the
        rotary axes turn between them, naming the height needed.
    """
    need = safe_height(m, angles, above_mm)
    if safe_z_mm < need:
        raise ParameterError(f"{{safe_z_mm=}}{safe_z_mm:g}: below {need:.3f} mm, the "
                               "highest point of the sphere (plus tip and clearance) at the "
                               "poses and while the rotary axes turn between them; this program "
                               "retracts there before every rotary move (machine coordinates = "
                               "the program's: the machine datum is its zero)")


def _setup(m: Any, options: Any, feed: float, clearance: float, overtravel: float,
           elevation_deg: float, sphere_d: float, tip_d: float
           ) -> tuple[dict[str, Any], list[str], list[ProbeMove], list[str], list[str]]:
    from volcal.session.probe_control import control_kinematics
    from volcal.session.probe_sphere import _keys

    if control_kinematics(m) == "tcp":
        raise VolcalInputError(f"{m.id}: control_kinematics = \"tcp\": volcal writes tool centre "
                               "point probing programs for LinuxCNC only; for this control "
                               "probe with the kinematics off (\"joints\")", "session.toml",
                               None, f"measurements.{m.id}.control_kinematics")
    k = _keys(m)
    ang, centres, moves, warnings = probe_moves(
        m, clearance=clearance, overtravel=overtravel, elevation_deg=elevation_deg,
        sphere_d=sphere_d, tip_d=tip_d)
    check_safe_z(m, ang, options.safe_z_mm, 0.5 * (sphere_d + tip_d) + clearance)
    sign = k["control_angle_sign"]
    letters = list(ang)
    ctrl = {a: sign * ang[a] for a in letters}
    head = [f"volcal probe_sphere program: test {m.id}, chain {k['chain'].code}, {m.n} poses",
            f"needs: the touch probe in the spindle, calibrated; its effective ball diameter "
            f"{tip_d:g} mm (tip_diameter_mm), sphere diameter {sphere_d:g} mm "
            "(sphere_diameter_mm) at the test's sphere_mm within a few mm",
            "needs: tool length and radius 0 for these blocks (volcal carries the tip offset "
            f"{', '.join(f'{v:g}' for v in m.tool_offset)} mm): coordinates are the spindle's",
            "needs: the machine datum as the program zero; nothing within "
            f"{clearance:g} mm of the probing paths; machine Z {options.safe_z_mm:g} "
            "clear of the sphere at every pose",
            f"every probing move starts {clearance:g} mm outside the expected contact and "
            f"may travel {clearance + overtravel:g} mm; feed {feed:g} mm/min probing, "
            f"{options.feed:g} mm/min positioning",
            "rotary angles: the control's" + (" (minus volcal's: control_angle_sign = -1)"
                                              if sign < 0 else ", volcal's"),
            f"the output: one line per trip point, TAG X Y Z {' '.join(letters)} "
            "(spindle position [mm], the pose's angles [deg])"]
    del centres
    return {"ctrl": ctrl, "letters": letters, "n": m.n}, head, moves, warnings, letters


def heidenhain_format_file(letters: list[str]) -> str:
    """The ``FN 16`` format file (``.A``): one line ``VOLCAL_TNC X Y Z R1 R2`` per call.

    Parameters
    ----------
    letters : list of str
        The chain's rotary letters (``Q1`` holds the first's angle, ``Q2`` the second's).
    """
    qs = ",".join(["Q115", "Q116", "Q117"] + [f"Q{j + 1}" for j in range(len(letters))])
    fmt = " ".join(["%10.4LF"] * (3 + len(letters)))
    return f'"{HEIDENHAIN_TAG} {fmt}",{qs};\n'


def probe_program_heidenhain(m: Any, name: str, options: Any, *, feed: float,
                             clearance: float, overtravel: float, elevation_deg: float,
                             sphere_d: float, tip_d: float
                             ) -> tuple[str, list[str], dict[str, str]]:
    """The HEIDENHAIN TNC 640 Klartext program of a probe_sphere test and its format file.

    Parameters
    ----------
    m : Measurement
        The planned test.
    name : str
        Program name.
    options : volcal.program.steps.ProgramOptions
        ``decimals``, ``safe_z_mm`` (machine Z, ``M91``), ``feed`` (positioning [mm/min]).
    feed, clearance, overtravel, elevation_deg, sphere_d, tip_d : float
        Probe feed [mm/min] (the touch probe table's ``F`` governs cycle 0; stated), approach
        and overtravel [mm], side points' elevation [deg], diameters [mm].

    Returns
    -------
    text : str
    warnings : list of str
    files : dict of str to str
        The format file ``<name>.A``.
    """
    st, head, moves, warnings, letters = _setup(m, options, feed, clearance, overtravel,
                                                elevation_deg, sphere_d, tip_d)
    d = options.decimals
    fpos = f"F{options.feed:g}"
    afile = f"{name}.A"
    out_file = f"{_ascii(m.id).upper()}.TXT"

    def n(v: float) -> str:
        return _num(v, d, signed=True)

    body = [f"BEGIN PGM {name} MM"]
    body += ["; " + _ascii(h) for h in head]
    body += [f"; HEIDENHAIN: touch probe cycle 0 REFERENCE PLANE, Q115-Q117; FN 16 prints with "
             f"{afile} (beside this program) to {out_file}",
             f"; set DIST of the touch probe table >= {clearance + overtravel:g} mm and its F "
             f"to the probing feed {feed:g} mm/min; a probe without contact stops the program",
             "FUNCTION RESET TCPM", "PLANE RESET STAY",
             f"L Z{n(options.safe_z_mm)} R0 {fpos} M91"]
    for i in range(m.n):
        pose = [mv for mv in moves if mv.pose == i]
        top = pose[0].start[2]
        body.append(f"; pose {i + 1} of {m.n}")
        body.append(f"L Z{n(options.safe_z_mm)} R0 {fpos} M91")
        for j, a in enumerate(letters):
            body.append(f"FN 0: Q{j + 1} = {n(st['ctrl'][a][i])}")
        body.append("L " + " ".join(f"{a}{n(st['ctrl'][a][i])}" for a in letters) + f" R0 {fpos}")
        for mv in pose:
            s = mv.start
            body.append(f"L X{n(s[0])} Y{n(s[1])} R0 {fpos}")
            body.append(f"L Z{n(s[2])} R0 {fpos}")
            body.append(f"TCH PROBE 0.0 REF. PLANE Q10 {mv.axis}{'+' if mv.sign > 0 else '-'}")
            body.append(f"TCH PROBE 0.1 X{n(s[0])} Y{n(s[1])} Z{n(s[2])}")
            body.append(f"FN 16: F-PRINT {afile} / {out_file}")
            body.append(f"L Z{n(top)} R0 {fpos}")
    body.append(f"L Z{n(options.safe_z_mm)} R0 {fpos} M91")
    body.append(f"END PGM {name} MM")
    text = "\n".join(f"{i} {line}" for i, line in enumerate(body)) + "\n"
    return text, warnings, {afile: heidenhain_format_file(letters)}


def probe_program_siemens(m: Any, name: str, options: Any, *, feed: float, clearance: float,
                          overtravel: float, elevation_deg: float, sphere_d: float,
                          tip_d: float) -> tuple[str, list[str]]:
    """The SINUMERIK 840D sl program of a probe_sphere test (``MEAS=1``, ``WRITE``).

    Parameters
    ----------
    m : Measurement
        The planned test.
    name : str
        Program name.
    options : volcal.program.steps.ProgramOptions
        ``decimals``, ``safe_z_mm`` (machine Z, ``SUPA``), ``feed`` (positioning [mm/min]).
    feed, clearance, overtravel, elevation_deg, sphere_d, tip_d : float
        Probe feed [mm/min], approach and overtravel [mm], side points' elevation [deg],
        diameters [mm].

    Returns
    -------
    (text, warnings)
    """
    st, head, moves, warnings, letters = _setup(m, options, feed, clearance, overtravel,
                                                elevation_deg, sphere_d, tip_d)
    d = options.decimals

    def n(v: float) -> str:
        return _num(v, d)

    out = [f"; volcal program {name}"] + ["; " + _ascii(h) for h in head]
    out += [f'; Siemens: MEAS=1 probing, $AA_MM (machine coordinates), WRITE to file '
            f'"{SIEMENS_FILE}"; no contact: alarm {ALARM_NO_CONTACT}, write error: alarm '
            f"{ALARM_WRITE}",
            "DEF INT ERR",
            "G71 G90 G94 G17 G40 G500 D0 TRAFOOF",
            f"G1 SUPA Z{n(options.safe_z_mm)} F{options.feed:g}"]
    for i in range(m.n):
        pose = [mv for mv in moves if mv.pose == i]
        top = pose[0].start[2]
        angles = " ".join(f"{st['ctrl'][a][i]:.4f}" for a in letters)
        out.append(f"; pose {i + 1} of {m.n}")
        out.append(f"G1 SUPA Z{n(options.safe_z_mm)} F{options.feed:g}")
        out.append("G1 " + " ".join(f"{a}{n(st['ctrl'][a][i])}" for a in letters)
                   + f" F{options.feed:g}")
        for mv in pose:
            s, e = mv.start, mv.end
            out.append(f"G1 X{n(s[0])} Y{n(s[1])} F{options.feed:g}")
            out.append(f"G1 Z{n(s[2])}")
            out.append(f"MEAS=1 G1 X{n(e[0])} Y{n(e[1])} Z{n(e[2])} F{feed:g}")
            out.append("STOPRE")
            out.append("IF $AC_MEA[1]==0 GOTOF NO_CONTACT")
            out.append(f'WRITE(ERR,"{SIEMENS_FILE}","{SIEMENS_TAG} "<<$AA_MM[X]<<" "'
                       f'<<$AA_MM[Y]<<" "<<$AA_MM[Z]<<" {angles}")')
            out.append("IF ERR<>0 GOTOF WRITE_FAILED")
            out.append(f"G1 X{n(s[0])} Y{n(s[1])} Z{n(s[2])} F{options.feed:g}")
            out.append(f"G1 Z{n(top)}")
    out += [f"G1 SUPA Z{n(options.safe_z_mm)} F{options.feed:g}", "M30",
            "NO_CONTACT:", f"SETAL({ALARM_NO_CONTACT})", "M0", "M30",
            "WRITE_FAILED:", f"SETAL({ALARM_WRITE})", "M0", "M30"]
    return "\n".join(out) + "\n", warnings
