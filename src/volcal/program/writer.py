"""Write one measuring program per measurement of a session into a folder, atomically."""

from __future__ import annotations

from pathlib import Path

from volcal.errors import VolcalInputError
from volcal.io.atomic import atomic_dir
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.program.dialects import DIALECTS, EXTENSIONS, program_name, render
from volcal.program.steps import ProgramOptions, build_steps
from volcal.session.format import Session
from volcal.session.kinds import kind_of

_TRAVEL_TOL_MM = 1e-3
"""Tolerance of the travel check of a kind's own program [mm]."""
_ANGLE_TOL_DEG = 1e-6
"""Tolerance of the check of the poses' angles against a limited axis' range [deg]."""
INDEX_FILE = "volcal-programs.toml"
"""Index written into every program folder (program file -> measurement id)."""


def write_programs(session: Session, dialect: str, folder: str | Path,
                   options: ProgramOptions | None = None, first_number: int = 1000
                   ) -> tuple[Path, list[str]]:
    """Write the measuring programs of a session.

    Parameters
    ----------
    session : Session
        Planned (or measured) session.
    dialect : str
        ``'fanuc'``, ``'linuxcnc'``, ``'siemens'`` or ``'heidenhain'``.
    folder : str or Path
        Output folder. It is built aside and moved into place; an existing folder is
        replaced only if it is empty or a previous program folder (holds
        ``volcal-programs.toml``).
    options : ProgramOptions, optional
        Dwell, feed, overrun, decimals.
    first_number : int
        Fanuc program number of the first measurement (``O`` word).

    Returns
    -------
    folder : Path
    warnings : list of str

    Raises
    ------
    VolcalInputError
        Unknown dialect, bad options, poses outside the travel or beyond a limited rotary
        axis' range, unsafe output folder.
    """
    dialect = dialect.lower()
    if dialect not in DIALECTS:
        raise VolcalInputError(f"unknown dialect {dialect!r}: expected one of "
                               f"{', '.join(DIALECTS)}")
    options = options or ProgramOptions()
    options.check()
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir() or (any(folder.iterdir())
                                                    and not (folder / INDEX_FILE).is_file())):
        raise VolcalInputError("output exists and is not a volcal program folder; "
                               "choose a new or empty folder", folder)
    if not 1 <= first_number <= 9999 - len(session.measurements):
        raise VolcalInputError(f"program numbers {first_number}.. do not fit O1..O9999")
    from volcal.session.rotary import read_rotary_axes

    limited = {a.name: a.range_deg for a in read_rotary_axes(session.meta) if not a.modulo}
    files: dict[str, str] = {}
    index: list[dict[str, object]] = []
    warnings: list[str] = []
    for i, m in enumerate(session.measurements):
        name = program_name(m.id, dialect)
        fname = name + EXTENSIONS[dialect]
        base, n = name, 2
        while fname.upper() in (f.upper() for f in files):
            name = f"{base}_{n}"
            fname = name + EXTENSIONS[dialect]
            n += 1
        _check_travel(m, kind_of(m.kind).program_positions(m, dialect), session.travel)
        _check_angles(m, limited)
        own = kind_of(m.kind).program_text(m, dialect, name, first_number + i, options)
        if own is not None:  # a kind with its own program (rotary: incremental turns)
            files[fname], more = own
            warnings += more
        else:
            built = build_steps(m, session.travel, options)
            warnings += built.warnings
            files[fname] = render(built.steps, dialect, name, first_number + i,
                                  options.decimals, options.safe_z_mm)
        extra = kind_of(m.kind).program_files(m, dialect, name)
        files.update(extra)
        index.append({"file": fname, "measurement": m.id, "kind": m.kind, "readings": m.n,
                      **({"needs": sorted(extra)} if extra else {})})
    doc = {"format": "volcal-programs/1", "dialect": dialect, "session": session.name,
           "dwell_s": options.dwell_s, "feed_mm_min": options.feed,
           "overrun_mm": options.overrun_mm, "safe_z_machine_mm": options.safe_z_mm,
           "overrun_deg": options.overrun_deg, "programs": index}
    with atomic_dir(folder) as tmp:
        for fname, text in files.items():
            (tmp / fname).write_text(text, encoding="ascii", newline="\n")
        (tmp / INDEX_FILE).write_text(toml_dumps(doc), encoding="utf-8")
    return folder, warnings


def _check_travel(m, positions, travel) -> None:
    """Refuse a kind's own program that commands a position outside the travel.

    Parameters
    ----------
    m : Measurement
        The measurement.
    positions : list of (str, array_like) or None
        :meth:`volcal.session.kinds.Kind.program_positions`.
    travel : array_like, shape (3, 2)
        The session's travel [mm].

    Raises
    ------
    VolcalInputError
        Naming the measurement, the first position outside (its label), the axis and the
        travel.
    """
    import numpy as np

    t = np.asarray(travel, dtype=float).reshape(3, 2)
    for label, p in positions or []:
        q = np.asarray(p, dtype=float).reshape(3)
        bad = np.flatnonzero((q < t[:, 0] - _TRAVEL_TOL_MM) | (q > t[:, 1] + _TRAVEL_TOL_MM))
        if bad.size:
            k = int(bad[0])
            v = float(q[k])
            ax = "XYZ"[k]
            raise VolcalInputError(
                f"{m.kind} test {m.id!r}: {label}: {ax} = {v:.3f} mm lies outside the "
                f"session's travel {ax} {t[k, 0]:g}..{t[k, 1]:g} mm; the program would "
                "command it. Edit the test's pivot_mm, sphere_mm or poses to the machine's, "
                "or the session's travel_mm", m.file, None, f"{ax.lower()}_mm")


def _check_angles(m, limited: dict[str, tuple[float, float]]) -> None:
    """Refuse a program that turns a limited rotary axis beyond its range.

    The angles of a test's poses (its ``<axis>_deg`` columns: a probe-on-sphere test, an
    R-test), as the control turns to them (times the test's ``control_angle_sign``),
    against ``[[machine.rotary_axes]]``: an axis with ``modulo = false`` stops at the ends
    of its ``range_deg`` (the control's limits), so a pose beyond them would stop
    the program there, or turn the table into something its range keeps it from. The moves
    between two poses stay between their angles. Modulo axes turn freely.

    Parameters
    ----------
    m : Measurement
        The measurement.
    limited : dict of str to (float, float)
        The session's limited axes (``modulo = false``): letter -> ``range_deg`` [deg].

    Raises
    ------
    VolcalInputError
        Naming the measurement's file, the first row beyond the range (1-based, the header
        being row 1) and its column.
    """
    import numpy as np

    sign = float(m.meta.get("control_angle_sign", 1))  # the control's angles: volcal's x it
    for col, values in m.columns.items():
        letter = col[:-4] if col.endswith("_deg") else ""
        if letter not in limited:
            continue
        lo, hi = limited[letter]
        v = sign * np.asarray(values, dtype=float)
        bad = np.flatnonzero((v < lo - _ANGLE_TOL_DEG) | (v > hi + _ANGLE_TOL_DEG))
        if bad.size:
            i = int(bad[0])
            whose = " (the control's angle: control_angle_sign = -1)" if sign < 0 else ""
            raise VolcalInputError(
                f"{m.kind} test {m.id!r}: pose {i + 1}: {letter.upper()} = {v[i]:g} deg{whose} "
                f"lies beyond the range {lo:g}..{hi:g} deg of axis {letter.upper()} "
                "([[machine.rotary_axes]] of session.toml, modulo = false); the program would "
                f"command it ({bad.size} of {v.size} poses beyond). Plan the test with the "
                "machine's --rotary-axes (volcal plan keeps its poses within them), edit its "
                "poses, or correct the axis' range_deg", m.file, i + 2, col)
