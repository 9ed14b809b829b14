"""Part program of a probe_sphere test: LinuxCNC ``G38.2`` probing with a probe log.

For each planned pose the program retracts Z in machine coordinates (``G53``), turns the
rotary axes with the linear axes still, moves over the sphere centre the **configured**
kinematics predict (:func:`volcal.measure.spheres.probe_centres` on the nominal machine),
and probes one point from above and three or four around the sphere at 30 deg above its
equator, each from outside the sphere with a clearance of free travel before the expected
contact, towards the sphere, with ``G38.2`` (stop on
contact, error without one: LinuxCNC G-code reference, "G38.x Straight Probe"), retracting
the way it came. The side points avoid the sphere's stem, which points along the table's
-Z turned with the table. ``(PROBEOPEN file)`` ... ``(PROBECLOSE)`` log every trip point
(``X Y Z A B C U V W``); ``volcal import LOG --session S --measurement ID`` fits the
centres (:mod:`volcal.importer.probe_log`).

**Safe as written.** Every probing move travels ``clearance`` before the expected contact (5
mm, more than the largest pivot error a configuration should carry; raise it for a
machine whose pivots are not known to a few mm) and every probing move ends
``overtravel`` (5 mm) inside the expected surface, so a missing sphere stops the program
with LinuxCNC's error instead of driving on. Z goes up first, then the rotary axes turn,
then X and Y. The probe feed is 100 mm/min (the test's ``probe_feed_mm_min`` replaces
it); the header states the sphere and tip diameters the program assumes
(``sphere_diameter_mm``, ``tip_diameter_mm`` of the test). A tool centre point control
(``control_kinematics = "tcp"``, LinuxCNC's trt kinematics) gets the program of
:mod:`volcal.program.probe_sphere_tcp`.

HEIDENHAIN (cycle 0 and ``FN 16``) and Siemens (``MEAS=1`` and ``WRITE``) get the same
probing with the control's own functions (:mod:`volcal.program.probe_sphere_controls`);
for another dialect (Fanuc) volcal writes a listing of the poses and nominal centres to
enter into the control's own cycle, and reads the centres it reports as the test's CSV
(``docs/formats.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from volcal.program.dialects import _ascii, _paren_comment

__all__ = ["PROBE_FEED_MM_MIN", "probe_program", "probe_program_files",
           "probe_program_positions"]

PROBE_FEED_MM_MIN = 100.0
"""Probing feed [mm/min] (the test's ``probe_feed_mm_min`` replaces it)."""
MAX_PROBE_FEED_MM_MIN = 1000.0
"""Largest probing feed a test may ask [mm/min]."""
CLEARANCE_MM = 5.0
"""Distance outside the sphere each approach starts from [mm]."""
OVERTRAVEL_MM = 5.0
"""How far inside the expected surface a probing move ends [mm]."""
SIDE_ELEVATION_DEG = 30.0
"""Elevation of the side points above the sphere's equator [deg]."""
DEFAULT_SPHERE_DIAMETER_MM = 25.0
DEFAULT_TIP_DIAMETER_MM = 3.0


def _fmt(v: float, d: int) -> str:
    s = f"{v:.{d}f}"
    return "0." + "0" * d if s in ("-0." + "0" * d,) else s


def probe_program(m: Any, dialect: str, name: str, number: int, options: Any
                  ) -> tuple[str, list[str]]:
    """The part program of a probe_sphere measurement.

    Parameters
    ----------
    m : Measurement
        The planned test (chain, pivots, sphere, poses).
    dialect : str
        ``'linuxcnc'``, ``'heidenhain'``, ``'siemens'`` write the probing program; another
        dialect a listing of the poses for the control's own cycle.
    name : str
        Program name.
    number : int
        Program number (unused).
    options : volcal.program.steps.ProgramOptions
        ``decimals``, ``safe_z_mm`` (machine Z to retract to [mm]).

    Returns
    -------
    (text, warnings)
    """
    from volcal.measure.spheres import probe_centres
    from volcal.model.fiveaxis import exact_pose5
    from volcal.session.probe_sphere import _angles, _keys, five_axis_machine

    k = _keys(m)
    nominal = five_axis_machine(m)
    ang = _angles(m)
    centres = probe_centres(nominal, ang, k["sphere_mm"], m.tool_offset)
    _, R, = exact_pose5(nominal, centres, ang, m.tool_offset)
    d = options.decimals
    letters = list(ang)
    sign = k["control_angle_sign"]  # the control's angles: volcal's times this
    sphere_d = float(m.meta.get("sphere_diameter_mm", DEFAULT_SPHERE_DIAMETER_MM))
    tip_d = float(m.meta.get("tip_diameter_mm", DEFAULT_TIP_DIAMETER_MM))
    r = 0.5 * (sphere_d + tip_d)  # tip centre at contact, from the sphere centre
    feed = float(m.meta.get("probe_feed_mm_min", PROBE_FEED_MM_MIN))
    if not (np.isfinite(feed) and 0.0 < feed <= MAX_PROBE_FEED_MM_MIN):
        from volcal.errors import VolcalInputError

        raise VolcalInputError(f"probe_feed_mm_min {feed:g}: expected 0 < feed <= "
                               f"{MAX_PROBE_FEED_MM_MIN:g} mm/min", None, None,
                               f"measurements.{m.id}.probe_feed_mm_min")
    head = [f"volcal probe_sphere program {name}: test {m.id}, chain {k['chain'].code}, "
            f"{m.n} poses",
            f"sphere diameter {sphere_d:g} mm, probe tip diameter {tip_d:g} mm, tip offset "
            f"{', '.join(f'{v:g}' for v in m.tool_offset)} mm",
            "coordinates: G54 = machine zero (no work offset), no tool length offset; the "
            "centres are those the configured kinematics predict",
            "rotary angles: the control's" + (" (minus volcal's: control_angle_sign = -1)"
                                              if sign < 0 else ", volcal's")]
    warnings: list[str] = []
    from volcal.session.probe_control import control_kinematics

    if dialect == "linuxcnc" and control_kinematics(m) == "tcp":
        from volcal.program.probe_sphere_tcp import probe_program_tcp

        return probe_program_tcp(m, name, options, feed=feed, clearance=CLEARANCE_MM,
                                 overtravel=OVERTRAVEL_MM, elevation_deg=SIDE_ELEVATION_DEG,
                                 sphere_d=sphere_d, tip_d=tip_d)
    if dialect in ("heidenhain", "siemens"):
        from volcal.program import probe_sphere_controls as pc

        kw = dict(feed=feed, clearance=pc.CLEARANCE_MM, overtravel=pc.OVERTRAVEL_MM,
                  elevation_deg=SIDE_ELEVATION_DEG, sphere_d=sphere_d, tip_d=tip_d)
        if dialect == "siemens":
            return pc.probe_program_siemens(m, name, options, **kw)
        text, more, _ = pc.probe_program_heidenhain(m, name, options, **kw)
        return text, more
    if dialect != "linuxcnc":
        lines = [_paren_comment(h) for h in head] + [
            _paren_comment(f"{dialect}: run the control's own kinematics cycle at these "
                           "poses and enter the centres it reports into the test's CSV")]
        for i in range(m.n):
            pose = " ".join(f"{a}={sign * ang[a][i]:.3f}" for a in letters)
            c = " ".join(f"{ax}={_fmt(v, d)}" for ax, v in zip("XYZ", centres[i], strict=True))
            lines.append(_paren_comment(f"pose {i + 1}: {pose} nominal centre {c}"))
        warnings.append(f"{m.id}: the {dialect} program lists the poses for the control's own "
                        "probing cycle; volcal writes probing moves for LinuxCNC, HEIDENHAIN "
                        "and Siemens")
        return "\n".join(lines) + "\n", warnings
    clear, over = CLEARANCE_MM, OVERTRAVEL_MM
    safe = options.safe_z_mm
    from volcal.program.probe_sphere_controls import check_safe_z

    # the rotary axes turn, and X Y move, at this height: it must clear the sphere
    check_safe_z(m, ang, safe, r + clear)
    out = [_paren_comment(h) for h in head] + [
        _paren_comment("G38.2 stops on contact and raises an error without one; every "
                       f"probing move travels {clear:g} mm before the expected contact"),
        "G21 G90 G17 G40 G49 G94 G54",
        f"(PROBEOPEN {_ascii(m.id)}.txt)",
    ]
    el = np.deg2rad(SIDE_ELEVATION_DEG)
    for i in range(m.n):
        c = centres[i]
        stem = R[i].T @ np.array([0.0, 0.0, -1.0])  # the table's -Z in machine axes
        sides = []
        for t in np.deg2rad(np.arange(0.0, 360.0, 45.0)):
            u = np.array([np.cos(t), np.sin(t), 0.0])
            if u @ stem < 0.3 * np.linalg.norm(stem[:2]) or np.linalg.norm(stem[:2]) < 0.3:
                sides.append(u)
        sides = sides[::2] if len(sides) > 4 else sides
        if len(sides) < 3:
            warnings.append(f"{m.id}: pose {i + 1}: only {len(sides)} side points clear of the "
                            "stem")
        top = c[2] + r + clear
        out.append(_paren_comment(f"pose {i + 1} of {m.n}"))
        out.append(f"G53 G0 Z{_fmt(safe, d)}")
        out.append("G0 " + " ".join(f"{a}{_fmt(sign * ang[a][i], d)}" for a in letters))
        out.append(f"G0 X{_fmt(c[0], d)} Y{_fmt(c[1], d)}")
        out.append(f"G0 Z{_fmt(top, d)}")
        out.append(f"G38.2 Z{_fmt(c[2] + r - over, d)} F{feed:g}")
        out.append(f"G0 Z{_fmt(top, d)}")
        for u in sides:
            h = c[2] + r * np.sin(el)
            rad = r * np.cos(el)
            start = c[:2] + (rad + clear) * u[:2]
            end = c[:2] + (rad - over) * u[:2]
            out.append(f"G0 X{_fmt(start[0], d)} Y{_fmt(start[1], d)}")
            out.append(f"G0 Z{_fmt(h, d)}")
            out.append(f"G38.2 X{_fmt(end[0], d)} Y{_fmt(end[1], d)} F{feed:g}")
            out.append(f"G0 X{_fmt(start[0], d)} Y{_fmt(start[1], d)}")
            out.append(f"G0 Z{_fmt(top, d)}")
    out += ["(PROBECLOSE)", f"G53 G0 Z{_fmt(safe, d)}", "M2"]
    return "\n".join(out) + "\n", warnings


def probe_program_files(m: Any, dialect: str, name: str) -> dict[str, str]:
    """Files a probe_sphere program needs beside it: HEIDENHAIN's ``FN 16`` format file.

    Parameters
    ----------
    m : Measurement
        The planned test.
    dialect : str
        The dialect.
    name : str
        The program's name.

    Returns
    -------
    dict of str to str
        File name to text (empty for the other dialects).
    """
    if dialect != "heidenhain":
        return {}
    from volcal.program.probe_sphere_controls import heidenhain_format_file
    from volcal.session.probe_sphere import _angles

    return {f"{name}.A": heidenhain_format_file(list(_angles(m)))}


def probe_program_positions(m: Any, dialect: str) -> list[tuple[str, np.ndarray]]:
    """The machine positions a probe_sphere program goes to, labelled.

    Each pose's sphere centre as the configured kinematics predict it, then (for the
    dialects volcal writes probing moves for) the start and end of every probing move
    around it, with the dialect's clearance and overtravel (the LinuxCNC program's side
    points between the axes lie inside these). ``volcal program`` refuses the test when
    one lies outside the session's travel.

    Parameters
    ----------
    m : Measurement
        The planned test.
    dialect : str
        The dialect.

    Returns
    -------
    list of (str, ndarray)
        ``'pose 3'``, ``'pose 3, probing along Z'`` ... and the position X, Y, Z [mm].
    """
    from volcal.program import probe_sphere_controls as pc

    sphere_d = float(m.meta.get("sphere_diameter_mm", DEFAULT_SPHERE_DIAMETER_MM))
    tip_d = float(m.meta.get("tip_diameter_mm", DEFAULT_TIP_DIAMETER_MM))
    clear, over = ((pc.CLEARANCE_MM, pc.OVERTRAVEL_MM) if dialect in ("heidenhain", "siemens")
                   else (CLEARANCE_MM, OVERTRAVEL_MM))
    _, centres, moves, _ = pc.probe_moves(m, clearance=clear, overtravel=over,
                                          elevation_deg=SIDE_ELEVATION_DEG, sphere_d=sphere_d,
                                          tip_d=tip_d)
    out = [(f"pose {i + 1}", centres[i]) for i in range(m.n)]
    if dialect in ("linuxcnc", "heidenhain", "siemens"):
        for mv in moves:
            what = f"pose {mv.pose + 1}, probing along {'-' if mv.sign < 0 else '+'}{mv.axis}"
            out += [(f"{what} (start)", mv.start), (f"{what} (end)", mv.end)]
    return out

