"""Probed points of a control's probe log, fitted to sphere centres per rotary pose.

LinuxCNC writes every successful ``G38.n`` probe to the file opened by ``(PROBEOPEN
file)`` until ``(PROBECLOSE)``: one line per probe with the nine coordinates ``X Y Z A B C
U V W`` of the trip point, separated by spaces (LinuxCNC G-code reference, "Probe
logging", and ``src/emc/rs274ngc/interp_o_word.cc``/``emccanon.cc``, ``"%f %f %f %f %f %f
%f %f %f"``). volcal groups the consecutive lines of one rotary pose (the same A, B, C),
fits a sphere to each group and writes the centres as the readings of a planned
``probe_sphere`` measurement (``volcal import LOG --session S --measurement ID``).

The fit (:func:`fit_sphere`): the algebraic least-squares sphere (linear in the centre and
``r^2 - |c|^2``), refined by Gauss-Newton on the geometric distances ``|p - c| - r``; with
the radius given (sphere radius plus the probe tip's effective radius) only the centre is
fitted, which four or five points around the sphere's upper half determine well.
Reference: Forbes, A.B., "Least-squares best-fit geometric elements", NPL report DITC
140/89 (1989), section 3.2.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["fit_sphere", "import_probe_log", "pose_centres", "read_linuxcnc_probe_log"]

Array = NDArray[np.float64]
ANGLE_TOL_DEG = 1e-3
"""Lines whose A, B, C differ by less than this belong to one pose [deg]."""


def read_linuxcnc_probe_log(path: str | Path) -> tuple[Array, NDArray[np.int64]]:
    """The probed points of a LinuxCNC probe log.

    Parameters
    ----------
    path : str or Path
        The file ``(PROBEOPEN file)`` wrote.

    Returns
    -------
    points : ndarray, shape (n, 9)
        X Y Z [mm], A B C [deg], U V W of each probe.
    rows : ndarray of int
        Line of each point in the file (1-based).

    Raises
    ------
    VolcalInputError
        A line without nine numbers, naming the file and line.
    """
    p = Path(path)
    try:
        text = p.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise VolcalInputError(f"cannot read the probe log: {e}", p) from None
    pts, rows = [], []
    for i, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        f = line.split()
        try:
            v = [float(x) for x in f]
        except ValueError:
            v = []
        if len(v) != 9 or not all(math.isfinite(x) for x in v):
            raise VolcalInputError("expected nine numbers X Y Z A B C U V W (LinuxCNC's probe "
                                   f"log), got {line.strip()[:80]!r}", p, i)
        pts.append(v)
        rows.append(i)
    if not pts:
        raise VolcalInputError("the probe log holds no probed point", p)
    return np.array(pts), np.array(rows, dtype=np.int64)


def fit_sphere(points: Array, radius_mm: float | None = None, iterations: int = 20
               ) -> tuple[Array, float, float]:
    """Least-squares sphere through points.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        Points [mm]; at least 4 (3 with ``radius_mm``).
    radius_mm : float, optional
        The radius, if known [mm]; None: fitted.
    iterations : int
        Gauss-Newton iterations at most.

    Returns
    -------
    centre : ndarray, shape (3,)
        [mm].
    radius : float
        [mm].
    rms_um : float
        RMS of the geometric residuals [um].
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    need = 3 if radius_mm is not None else 4
    if p.shape[0] < need:
        raise ValueError(f"a sphere needs at least {need} points, got {p.shape[0]}")
    m = p.mean(axis=0)
    q = p - m
    A = np.column_stack([2 * q, np.ones(len(q))])
    sol, *_ = np.linalg.lstsq(A, (q**2).sum(axis=1), rcond=None)
    c = sol[:3]
    r = float(np.sqrt(max(sol[3] + c @ c, 1e-12))) if radius_mm is None else float(radius_mm)
    for _ in range(iterations):
        d = q - c
        dist = np.linalg.norm(d, axis=1)
        res = dist - r
        J = -d / dist[:, None]
        if radius_mm is None:
            J = np.column_stack([J, -np.ones(len(q))])
        step, *_ = np.linalg.lstsq(J, -res, rcond=None)
        c = c + step[:3]
        if radius_mm is None:
            r += float(step[3])
        if np.abs(step).max() < 1e-12:
            break
    res = np.linalg.norm(q - c, axis=1) - r
    return c + m, r, float(np.sqrt(np.mean(res**2)) * 1e3)


def pose_centres(points: Array, letters: tuple[str, ...], radius_mm: float | None = None,
                 rows: NDArray[np.int64] | None = None, path: str | Path | None = None
                 ) -> tuple[dict[str, Array], Array, Array]:
    """Sphere centres of the consecutive groups of points at one rotary pose.

    Parameters
    ----------
    points : ndarray, shape (n, 9)
        A probe log (:func:`read_linuxcnc_probe_log`).
    letters : tuple of str
        The chain's rotary letters (``('C', 'A')``).
    radius_mm : float, optional
        Sphere radius plus the probe tip's effective radius [mm]; None: fitted per pose.
    rows, path
        For messages: the lines of the points and the file.

    Returns
    -------
    angles : dict of str to ndarray
        Angle of each pose per letter [deg].
    centres : ndarray, shape (k, 3)
        Fitted centres [mm].
    rms_um : ndarray, shape (k,)
        RMS residual of each fit [um].
    """
    col = {"A": 3, "B": 4, "C": 5}
    rot = points[:, [col[r] for r in letters]]
    starts = [0] + [i for i in range(1, len(points))
                    if np.abs(rot[i] - rot[i - 1]).max() > ANGLE_TOL_DEG]
    bounds = starts + [len(points)]
    angles: dict[str, list[float]] = {r: [] for r in letters}
    centres: list[Array] = []
    rms: list[float] = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        try:
            c, _, e = fit_sphere(points[a:b, :3], radius_mm)
        except ValueError as exc:
            line = None if rows is None else int(rows[a])
            pose = ", ".join(f"{r}={rot[a, k]:g}" for k, r in enumerate(letters))
            raise VolcalInputError(f"pose {len(centres) + 1} ({pose}): {exc}", path,
                                   line) from None
        centres.append(c)
        rms.append(e)
        for k, r in enumerate(letters):
            angles[r].append(float(rot[a, k]))
    return ({r: np.array(v) for r, v in angles.items()}, np.array(centres), np.array(rms))


def import_probe_log(path: str | Path, session: str | Path, mid: str, replace: bool = False,
                     radius_mm: float | None = None):
    """Fill a planned probe_sphere measurement from a control's probe log.

    LinuxCNC's ``PROBEOPEN`` log, or the file volcal's HEIDENHAIN (``FN 16``) or Siemens
    (``WRITE``) program printed (:mod:`volcal.importer.probe_control_log`), told apart by
    its first word.

    Parameters
    ----------
    path : str or Path
        The probe log.
    session : str or Path
        The session folder.
    mid : str
        The planned measurement's id.
    replace : bool
        Replace readings already there (kept in ``backup/``).
    radius_mm : float, optional
        Sphere plus tip radius [mm]; default the measurement's ``sphere_diameter_mm`` / 2
        plus nothing if given, else fitted.

    Returns
    -------
    volcal.importer.laser_csv.ImportResult
    """
    from volcal.importer.laser_csv import ImportResult, write_measurement
    from volcal.session.format import Measurement, read_session
    from volcal.session.probe_sphere import dispersion_um

    folder = Path(session)
    s = read_session(folder, require_deviation=False)
    ms = [m for m in s.measurements + s.unmeasured if m.id == mid]
    if not ms:
        raise VolcalInputError(f"no measurement {mid!r} in the session", folder / "session.toml")
    m = ms[0]
    if m.kind != "probe_sphere":
        raise VolcalInputError(f"measurement {mid!r} is a {m.kind} test, not probe_sphere",
                               folder / "session.toml")
    if m.deviation is not None and not replace:
        raise VolcalInputError(f"measurement {mid!r} has readings; give --replace to replace "
                               "them (the old ones are kept in backup/)", folder / "session.toml")
    from volcal.model.chain import parse_machine_chain
    from volcal.session.probe_sphere import _keys

    letters = parse_machine_chain(m.meta["chain"]).rotary
    sign = _keys(m)["control_angle_sign"]  # the log holds the control's angles
    from volcal.importer.probe_control_log import control_log_layout, read_control_probe_log

    if control_log_layout(path) is not None:  # volcal's HEIDENHAIN or Siemens program
        pts, rows, layout = read_control_probe_log(path, tuple(letters))
    else:
        pts, rows = read_linuxcnc_probe_log(path)
        layout = "linuxcnc-probe-log"
    angles, centres, rms = pose_centres(pts, letters, radius_mm, rows, path)
    angles = {r: sign * a for r, a in angles.items()}
    from volcal.session.probe_control import control_kinematics

    if control_kinematics(m) == "tcp":  # the log holds table coordinates: to machine ones
        from volcal.measure.spheres import probe_centres
        from volcal.session.probe_sphere import five_axis_machine

        centres = probe_centres(five_axis_machine(m), angles, centres, m.tool_offset)
    planned = {r: np.asarray(m.columns[f"{r.lower()}_deg"], dtype=float) for r in letters}
    k = len(centres)
    if k != m.n:
        raise VolcalInputError(f"the log holds {k} poses, {mid!r} plans {m.n}: is this the log "
                               "of its program?", path)
    for r in letters:
        diff = np.abs(((angles[r] - planned[r]) + 180.0) % 360.0 - 180.0)
        bad = np.flatnonzero(diff > 1e-3)
        if bad.size:
            i = int(bad[0])
            raise VolcalInputError(f"pose {i + 1}: {r} = {angles[r][i]:g} deg in the log, "
                                   f"{planned[r][i]:g} deg planned", path)
    notes = [f"{len(pts)} probed points, {k} poses; sphere fits RMS "
             f"{np.median(rms):.2f} um (median), {rms.max():.2f} um (largest)"]
    meta = {**m.meta, "import": {"source": Path(path).name, "layout": layout,
                                 "points": int(len(pts))}}
    cols = dict(m.columns)
    new = Measurement(m.id, m.kind, m.target, np.round(centres, 6), None, m.beam_direction,
                      m.tool_offset, m.file, cols, meta)
    new.deviation = dispersion_um(new, new.positions)
    write_measurement(folder, new, True, notes)
    return ImportResult(new, folder, False, notes)
