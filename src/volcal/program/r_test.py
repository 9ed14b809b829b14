"""Part program of an r_test: the rotary paths with the linear axes following (LinuxCNC).

The R-test nest (three displacement sensors in the spindle) must stay around the sphere
while the rotary axes turn, so the linear axes follow. Two ways, the test's
``control_kinematics`` says which:

* ``"joints"`` (default; LinuxCNC with ``trivkins``, X Y Z the linear axes' positions):
  volcal computes the linear positions with the **configured** kinematics (the test's
  ``pivot_mm``: :func:`volcal.measure.spheres.probe_centres`, the nest centre on the
  nominal sphere) at every pose and at intermediate angles at most ``MAX_STEP_DEG`` apart,
  and writes ``G1`` moves of all five axes between them: the chord between two steps
  leaves the nest at most ``r (1 - cos(step / 2))`` off the sphere (19 um at 500 mm from
  the axes and 1 deg);
* ``"tcp"`` (a tool centre point control, LinuxCNC's ``xyzac-trt-kins``/``xyzbc-trt-kins``:
  X Y Z are the table's coordinates, ``man 9 kins``): X Y Z stay at the sphere's table
  coordinates and only the rotary axes are programmed; the control makes the linear axes
  follow with its configured pins.

**Safe as written.** Z goes up to ``safe_z_mm`` first (machine coordinates, ``G53``; in
table coordinates for ``"tcp"``; refused below the approach point), then the rotary axes
turn to the first pose, then X Y, then Z down to ``CLEARANCE_MM`` (the test's
``approach_mm``) above the sphere along the tool axis, where the nest must be clear of
the sphere, and the nest is lowered onto the sphere at the slow ``APPROACH_FEED_MM_MIN``;
``M0`` stops for the operator to check the sphere sits in the nest and to zero the sensors
(they read relative to the first pose). Each measuring pose dwells ``dwell_s`` (the
sensors are read at standstill). At the end the path returns, following, to the first
pose and the nest is lifted off along the tool axis before Z goes up. Rotary angles are
the control's (``control_angle_sign``: volcal's times it).

Only LinuxCNC is written; for another dialect volcal lists the poses with the nominal
linear positions (a HEIDENHAIN or Siemens control with TCPM/TRAORI runs the path with its
own tool centre point function: program the sphere's table coordinates and the angles).

References: ISO 10791-6:2014, annex (R-test); Ibaraki, S., Oyama, C., Otsubo, H.,
"Construction of an error map of rotary axes on a five-axis machining center by static
R-test", Int. J. Machine Tools and Manufacture 51 (2011) 190-200; LinuxCNC G-code
reference (G1, G4, G53, M0).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from volcal.errors import ParameterError, VolcalInputError
from volcal.program.dialects import _paren_comment

__all__ = ["APPROACH_FEED_MM_MIN", "CLEARANCE_MM", "MAX_STEP_DEG", "rtest_path_points",
           "rtest_program_path",
           "rtest_program", "rtest_program_positions"]

CLEARANCE_MM = 30.0
"""Distance along the tool axis above the sphere from which the nest is lowered [mm] (the
test's ``approach_mm`` replaces it): the sensors must be clear of the sphere there."""
APPROACH_FEED_MM_MIN = 200.0
"""Feed of lowering the nest onto the sphere and lifting it off [mm/min]."""
MAX_STEP_DEG = 1.0
"""Largest angle between two interpolated points of a following move [deg]."""
FOLLOW_FEED_MAX_MM_MIN = 1000.0
"""Largest feed of a following move [mm/min]."""
POSE_DECIMALS = 6
"""Decimals of the moves that end at a pose (at least: ``decimals`` if larger) [mm, deg]:
the session file's, so that the machine dwells at the position its row states (the
program's 3 decimals put the nest up to 0.5 um off it, which the sensors read as a
location error)."""


def _f(v: float, d: int) -> str:
    s = f"{v:.{d}f}"
    return s[1:] if s == "-0." + "0" * d else s


def rtest_path_points(angles: dict[str, np.ndarray], max_step_deg: float = MAX_STEP_DEG
                      ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The poses with interpolated angles between consecutive ones.

    Parameters
    ----------
    angles : dict of str to ndarray
        Angle per rotary axis per pose [deg].
    max_step_deg : float
        Largest angle step of any axis between two points [deg].

    Returns
    -------
    points : dict of str to ndarray
        Angles of every point of the path [deg].
    is_pose : ndarray of int
        Index of the pose a point is (-1 for an intermediate point).
    """
    letters = list(angles)
    A = np.column_stack([np.asarray(angles[a], dtype=float) for a in letters])
    pts = [A[0]]
    pose = [0]
    for i in range(1, A.shape[0]):
        span = np.abs(A[i] - A[i - 1]).max()
        n = max(1, int(np.ceil(span / max_step_deg - 1e-9)))
        for k in range(1, n + 1):
            pts.append(A[i - 1] + (A[i] - A[i - 1]) * k / n)
            pose.append(i if k == n else -1)
    P = np.array(pts)
    return {a: P[:, j] for j, a in enumerate(letters)}, np.array(pose)


def rtest_program(m: Any, dialect: str, name: str, number: int, options: Any
                  ) -> tuple[str, list[str]]:
    """The part program of an r_test measurement.

    Parameters
    ----------
    m : Measurement
        The planned test (chain, pivots, sphere, poses, commanded positions).
    dialect : str
        ``'linuxcnc'`` writes the path; any other dialect a listing of the poses.
    name : str
        Program name.
    number : int
        Program number (unused).
    options : volcal.program.steps.ProgramOptions
        ``decimals``, ``safe_z_mm``, ``dwell_s``, ``feed`` (capped at
        ``FOLLOW_FEED_MAX_MM_MIN`` for the following moves).

    Returns
    -------
    (text, warnings)
    """
    from volcal.model.fiveaxis import exact_pose5
    from volcal.session.r_test import rtest_angles, rtest_keys
    from volcal.session.r_test import rtest_machine as _machine

    k = rtest_keys(m)
    nominal = _machine(m)
    ang = rtest_angles(m)
    letters = list(ang)
    sign = k["control_angle_sign"]
    d = options.decimals
    s = np.asarray(k["sphere_mm"], dtype=float)
    t = np.asarray(m.tool_offset, dtype=float)
    feed = min(float(options.feed), FOLLOW_FEED_MAX_MM_MIN)
    tcp = k["control_kinematics"] == "tcp"
    clear = m.meta.get("approach_mm", CLEARANCE_MM)
    if isinstance(clear, bool) or not isinstance(clear, int | float) or not 0 < clear <= 500:
        raise VolcalInputError(f"approach_mm {clear!r}: expected a number above 0 and at most "
                               "500 [mm]", None, None, f"measurements.{m.id}.approach_mm")
    clear = float(clear)
    head = [f"volcal r_test program {name}: test {m.id}, chain {k['chain'].code}, {m.n} poses",
            f"nominal sphere centre {', '.join(f'{v:g}' for v in s)} mm (table coordinates at "
            f"the zero pose); nest centre {', '.join(f'{v:g}' for v in t)} mm from the tool "
            "reference point",
            "the linear axes follow: " + ("the control's tool centre point kinematics "
                                          "(X Y Z are table coordinates)" if tcp else
                                          "positions computed by volcal with the configured "
                                          "pivots (pivot_mm)"),
            "rotary angles: the control's" + (" (minus volcal's: control_angle_sign = -1)"
                                              if sign < 0 else ", volcal's"),
            "coordinates: G54 = machine zero (no work offset), no tool length offset"
            + ("" if not tcp else " beyond the nest's in the kinematics")]
    warnings: list[str] = []
    pts, is_pose = rtest_path_points(ang)
    if dialect != "linuxcnc":
        lines = [_paren_comment(h) for h in head] + [
            _paren_comment(f"{dialect}: run the path with the control's tool centre point "
                           "function (TCPM, TRAORI) at the sphere's table coordinates, "
                           "reading the sensors at each pose")]
        for i in range(m.n):
            pose = " ".join(f"{a}={_f(sign * ang[a][i], 3)}" for a in letters)
            q = " ".join(f"{ax}={_f(v, d)}" for ax, v in zip("XYZ", m.positions[i], strict=True))
            lines.append(_paren_comment(f"pose {i + 1}: {pose} linear axes {q}"))
        warnings.append(f"{m.id}: the {dialect} program lists the poses; volcal writes the "
                        "R-test path for LinuxCNC only")
        return "\n".join(lines) + "\n", warnings
    _, R0 = exact_pose5(nominal, m.positions[:1], {a: ang[a][:1] for a in letters}, t)
    axis0 = R0[0][:, 2]
    safe = float(options.safe_z_mm)
    blocks, above = _blocks(m, options)
    if tcp:
        if not np.allclose(axis0, [0.0, 0.0, 1.0], atol=1e-9):
            raise VolcalInputError("control_kinematics = \"tcp\": the first pose must hold the "
                                   "tool along the table's Z (the approach and retract go "
                                   "along it)", None, None, f"measurements.{m.id}.file")
        if safe < above[2]:
            raise ParameterError(f"{{safe_z_mm=}}{safe:g}: below the approach point "
                                   f"{above[2]:g} mm above the sphere (table coordinates)")
    elif safe < above[2]:
        raise ParameterError(f"{{safe_z_mm=}}{safe:g}: below the approach point "
                               f"{above[2]:g} mm (machine coordinates, {clear:g} mm above "
                               "the sphere's working position): the nest would hit the "
                               "sphere")
    out = [_paren_comment(h) for h in head] + ["G21 G90 G17 G40 G49 G94 G54"]
    words = ["X", "Y", "Z", *letters]

    def said(v: np.ndarray, order: range | list[int] = range(3 + len(letters)),
             dd: int = d) -> str:
        return " ".join(f"{words[j]}{_f(v[j], dd)}" for j in order if not np.isnan(v[j]))

    # a following move: the rotary axes, then (unless the control follows) X, Y, Z
    follow_order = [*range(3, 3 + len(letters)), *([] if tcp else range(3))]

    for i, b in enumerate(blocks):
        ends_at_pose = i + 1 < len(blocks) and blocks[i + 1].kind in ("stop", "dwell")
        if ends_at_pose and b.how in ("slow", "follow"):
            order = follow_order if b.how == "follow" else range(3 + len(letters))
            feed_word = feed if b.how == "follow" else APPROACH_FEED_MM_MIN
            out.append(f"G1 {said(b.target, order, max(d, POSE_DECIMALS))} F{feed_word:g}")
            continue
        if b.how == "safe":
            out.append(f"G0 Z{_f(safe, d)}" if tcp else f"G53 G0 Z{_f(safe, d)}")
        elif b.how == "rapid":
            out.append(f"G0 {said(b.target)}")
        elif b.how == "slow":
            out.append(f"G1 {said(b.target)} F{APPROACH_FEED_MM_MIN:g}")
        elif b.how == "follow":
            out.append(f"G1 {said(b.target, follow_order)} F{feed:g}")
        elif b.kind == "stop":
            out.append("M0 (the sphere in the nest: zero the sensors, start recording, cycle "
                       "start)")
        elif b.kind == "dwell" and b.pose is not None:
            out += [_paren_comment(f"pose {b.pose + 1} of {m.n}"),
                    f"G4 P{options.dwell_s:g}"]
        elif b.kind == "note":
            out.append(_paren_comment(b.how))
    return "\n".join(out + ["M2"]) + "\n", warnings


def rtest_program_positions(m: Any) -> list[tuple[str, np.ndarray]]:
    """The machine positions the LinuxCNC path of an r_test commands, labelled.

    The nest's approach point above the first pose, every pose and every intermediate
    point of the following moves (the configured kinematics' positions: with
    ``control_kinematics = "tcp"`` the control's joints go there too). ``volcal program``
    refuses the test when one lies outside the session's travel.

    Parameters
    ----------
    m : Measurement
        The planned test.

    Returns
    -------
    list of (str, ndarray)
        ``'approach point above pose 1'``, ``'pose 3'``, ``'between pose 3 and 4'`` ... and
        the position X, Y, Z [mm].
    """
    from volcal.measure.spheres import probe_centres
    from volcal.model.fiveaxis import exact_pose5
    from volcal.session.r_test import rtest_angles, rtest_keys
    from volcal.session.r_test import rtest_machine as _machine

    k = rtest_keys(m)
    nominal = _machine(m)
    ang = rtest_angles(m)
    letters = list(ang)
    s = np.asarray(k["sphere_mm"], dtype=float)
    t = np.asarray(m.tool_offset, dtype=float)
    pos = np.asarray(m.positions, dtype=float)
    clear = m.meta.get("approach_mm", CLEARANCE_MM)
    clear = float(clear) if isinstance(clear, int | float) and not isinstance(clear, bool) \
        else CLEARANCE_MM
    first = {a: ang[a][:1] for a in letters}
    _, R0 = exact_pose5(nominal, pos[:1], first, t)
    out = [("approach point above pose 1",
            probe_centres(nominal, first, s + clear * R0[0][:, 2], t)[0])]
    out += [(f"pose {i + 1}", pos[i]) for i in range(m.n)]
    back = {a: np.concatenate([ang[a], ang[a][:1]]) for a in letters}
    pts, is_pose = rtest_path_points(back)
    mid = np.flatnonzero(is_pose < 0)
    if mid.size:
        q = probe_centres(nominal, {a: pts[a][mid] for a in letters}, s, t)
        # the last pose point before each point (the path's poses: 0 .. n, n = back at 0)
        prev = np.maximum.accumulate(np.where(is_pose >= 0, np.arange(is_pose.size), 0))
        for n, j in enumerate(mid):
            a = int(is_pose[prev[j]])
            out.append((f"between pose {a + 1} and {(a + 1) % m.n + 1}", q[n]))
    return out



class _Block(NamedTuple):
    """One block of an R-test's LinuxCNC path (:func:`_blocks`)."""

    kind: str  # 'move', 'stop', 'dwell', 'note'
    target: np.ndarray  # X, Y, Z [mm], the rotary axes [deg, the control's]; NaN: not commanded
    pose: int | None  # a dwell's pose (0-based CSV row)
    how: str  # a move: 'safe', 'rapid', 'slow' (onto and off the sphere), 'follow'; a note's text


def rtest_program_path(m: Any, options: Any) -> list[tuple[str, np.ndarray, int | None]]:
    """The LinuxCNC path of :func:`rtest_program`, block by block, in the control's axes.

    The capture's plan and its simulated control follow it (they never parse the
    G-code): the blocks :func:`rtest_program` writes (:func:`_blocks`), the same poses,
    the same intermediate points of the following moves (:func:`rtest_path_points`), the
    same approach and retract.

    Parameters
    ----------
    m : Measurement
        The planned test.
    options : volcal.program.steps.ProgramOptions
        ``safe_z_mm`` and ``dwell_s``.

    Returns
    -------
    list of (str, ndarray, int or None)
        ``('move', p, None)``: a move to ``p`` = X, Y, Z [mm] then the rotary axes in the
        chain's order [deg, the control's angles: ``control_angle_sign`` times volcal's];
        NaN for an axis the block does not command (the first, ``G53 G0 Z``: Z only);
        ``('stop', p, None)``: the operator stop ``M0`` (the sensors zeroed at pose 1);
        ``('dwell', p, i)``: the ``G4`` dwell at pose ``i`` (0-based CSV row).
    """
    return [(b.kind, b.target, b.pose) for b in _blocks(m, options)[0] if b.kind != "note"]


def _blocks(m: Any, options: Any) -> tuple[list[_Block], np.ndarray]:
    """The blocks of an R-test's LinuxCNC path, and the approach point above the sphere.

    Z up to ``safe_z_mm``, the rotary axes to the first pose, X Y then Z above the sphere
    (the approach point, ``approach_mm`` along the tool axis), the nest lowered onto the
    sphere, the operator stop and the first dwell; the following moves through every
    intermediate point with a dwell at each pose; back to the first pose, following; the
    nest lifted off to the approach point and Z up. With ``control_kinematics = "tcp"``
    the linear targets are the sphere's table coordinates (the control follows).

    Parameters
    ----------
    m : Measurement
        The planned test.
    options : volcal.program.steps.ProgramOptions
        ``safe_z_mm``.

    Returns
    -------
    blocks : list of _Block
    above : ndarray, shape (3,)
        The approach point [mm] (machine coordinates; table coordinates for ``"tcp"``).
    """
    from volcal.measure.spheres import probe_centres
    from volcal.model.fiveaxis import exact_pose5
    from volcal.session.r_test import rtest_angles, rtest_keys
    from volcal.session.r_test import rtest_machine as _machine

    k = rtest_keys(m)
    nominal = _machine(m)
    ang = rtest_angles(m)
    letters = list(ang)
    sign = float(k["control_angle_sign"])
    s = np.asarray(k["sphere_mm"], dtype=float)
    t = np.asarray(m.tool_offset, dtype=float)
    pos = np.asarray(m.positions, dtype=float)
    tcp = k["control_kinematics"] == "tcp"
    clear = m.meta.get("approach_mm", CLEARANCE_MM)
    clear = float(clear) if isinstance(clear, int | float) and not isinstance(clear, bool) \
        else CLEARANCE_MM
    nan = np.full(3, np.nan)
    first = {a: ang[a][:1] for a in letters}
    _, R0 = exact_pose5(nominal, pos[:1], first, t)
    axis0 = R0[0][:, 2]
    above = s + clear * axis0 if tcp else probe_centres(nominal, first, s + clear * axis0, t)[0]

    def at(q: np.ndarray, src: dict[str, np.ndarray], i: int) -> np.ndarray:
        return np.concatenate([q, [sign * float(src[a][i]) for a in letters]])

    def linear(q: np.ndarray) -> np.ndarray:
        return np.concatenate([q, np.full(len(letters), np.nan)])

    z = np.array([np.nan, np.nan, float(options.safe_z_mm)])
    out = [_Block("move", linear(z), None, "safe"), _Block("move", at(nan, ang, 0), None, "rapid"),
           _Block("move", linear(np.array([above[0], above[1], np.nan])), None, "rapid"),
           _Block("move", linear(np.array([np.nan, np.nan, above[2]])), None, "rapid"),
           _Block("move", linear(s if tcp else pos[0]), None, "slow"),
           _Block("stop", at(s if tcp else pos[0], ang, 0), None, ""),
           _Block("dwell", at(s if tcp else pos[0], ang, 0), 0, "")]
    for src, stops, back in ((ang, True, False),
                             ({a: np.array([ang[a][-1], ang[a][0]]) for a in letters}, False,
                              True)):
        if back:
            out.append(_Block("note", nan, None, "back to the first pose, following"))
        pts, is_pose = rtest_path_points(src)
        mid = np.flatnonzero(is_pose < 0)
        q_mid = (probe_centres(nominal, {a: pts[a][mid] for a in letters}, s, t)
                 if mid.size and not tcp else np.zeros((mid.size, 3)))
        qi = {int(j): (s if tcp else q_mid[n]) for n, j in enumerate(mid)}
        for j in range(1, is_pose.size):
            p = int(is_pose[j])
            q = qi[j] if p < 0 else (s if tcp else pos[0] if back else pos[p])
            out.append(_Block("move", at(q, pts, j), None, "follow"))
            if p >= 0 and stops:
                out.append(_Block("dwell", at(q, pts, j), p, ""))
    out += [_Block("move", linear(above), None, "slow"), _Block("move", linear(z), None, "safe")]
    return out, above
