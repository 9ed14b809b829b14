"""Step ``capture``: readings taken while the part programs run, one row per dwell."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from volcal import defaults as D
from volcal.errors import ParameterError, VolcalInputError

if TYPE_CHECKING:
    from volcal.capture.plan import PlannedMeasurement
    from volcal.capture.runner import Outcome
    from volcal.capture.samples import CaptureEvent
    from volcal.session.format import Session

__all__ = ["Captured", "capture", "read_planned"]

PLANNED_SUFFIX = ".planned.csv"
"""``capture/<id>.planned.csv``: the measurement's file as planned, kept at the first start."""


def _capturable(s: Session, chosen: list[str], named: bool, passed_over: list[str],
                folder: Path) -> list[str]:
    """The chosen measurements ``volcal capture`` takes (:attr:`Kind.captured_by` empty).

    A measurement of another kind named by the user is refused; among every measurement of
    the session (none named) it is passed over with a note in ``passed_over``. Refused
    too when none is left.
    """
    from volcal.session.kinds import kind_of

    keep = []
    for mid in chosen:
        m = s.get(mid)
        how = kind_of(m.kind).captured_by
        if not how:
            keep.append(mid)
            continue
        said = (f"{mid} ({m.kind}) is not captured by volcal capture, which takes one reading "
                f"per dwell at a position of the linear axes, an angle of a rotary axis or a "
                f"pose of an R-test: "
                f"{how}")
        if named:
            raise ParameterError(f"{{measurement=}}{said}", folder / "session.toml")
        passed_over.append(f"{said}; passed over")
    if not keep:
        raise VolcalInputError("nothing to capture: " + "; ".join(passed_over),
                               folder / "session.toml")
    return keep


@dataclass(frozen=True)
class Captured:
    """What :func:`capture` recorded.

    Attributes
    ----------
    folder : Path
        The session folder written (``output``, else the session).
    outcomes : tuple of Outcome
        One per measurement captured in this run (:class:`volcal.capture.runner.Outcome`).
    skipped : tuple of str
        Measurements already complete in their journals, not captured again.
    complete : bool
        Every asked measurement is complete.
    notes : tuple of str
        What the user should know (missed rows, where to resume).
    unreadable : tuple of str
        Measurements captured to the end whose file the session reader refuses: their
        first reading (the reference of the others) or every reading missed. Capture
        them again (``again=True``).
    """

    folder: Path
    outcomes: tuple[Outcome, ...]
    skipped: tuple[str, ...]
    complete: bool
    notes: tuple[str, ...]
    unreadable: tuple[str, ...] = ()


def read_planned(folder: str | Path) -> Session:
    """The session as planned, also while its measurements are being captured.

    A measurement under capture has rows not filled yet, which the session reader refuses;
    its planned file, kept at the first start in ``capture/<id>.planned.csv``, is read in
    its place.

    Parameters
    ----------
    folder : str or Path
        The session folder.

    Returns
    -------
    Session
        Read with ``require_deviation=False``; ``path`` is ``folder``.
    """
    from volcal.capture.journal import JOURNAL_FOLDER
    from volcal.io.paths import session_entries
    from volcal.session.format import read_session

    folder = Path(folder)
    planned = folder / JOURNAL_FOLDER
    if not planned.is_dir() or not any(planned.glob("*" + PLANNED_SUFFIX)):
        return read_session(folder, require_deviation=False)
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / "s"
        shutil.copytree(folder, copy, ignore=shutil.ignore_patterns(
            JOURNAL_FOLDER, "backup", "truth", ".*.tmp"))
        for e in session_entries(copy) or []:
            rel = str(e["file"])
            src = planned / (Path(rel).stem + PLANNED_SUFFIX)
            if src.is_file():
                shutil.copyfile(src, copy / rel)
        s = read_session(copy, require_deviation=False)
    s.path = folder
    return s


def _target_folder(session: Any, output: str | Path | None) -> Path:
    """The folder captured into: the session, or ``output`` (made from it, or resumed)."""
    from volcal.session.format import write_session

    if not isinstance(session, str | Path) and session.path is None:
        raise ParameterError("{session=} has no folder: capture writes into a session "
                             "folder (save the session first)")
    src = Path(session.path) if not isinstance(session, str | Path) else Path(session)
    if output is None:
        return src
    out = Path(output)
    if (out / "session.toml").is_file():
        a, b = read_planned(src), read_planned(out)
        if [m.id for m in a.measurements] != [m.id for m in b.measurements]:
            raise ParameterError(f"{{output=}}{out} holds another session (measurements "
                                 f"{', '.join(m.id for m in b.measurements)}), not a "
                                 "capture of this one", out / "session.toml")
        return out
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ParameterError(f"{{output=}}{out} exists and is not a session: give a new "
                             "folder, or the folder of a capture to resume")
    planned = read_planned(src)
    for m in planned.measurements:
        if m.deviation is not None:
            raise ParameterError(f"{{output=}}: {m.id} of {src} holds readings: capture into "
                                 "a copy of the planned session only", src / m.file)
    write_session(planned, out)
    return out


def _start_again(folder: Path, measurements: list[Any]) -> str:
    """Put captured measurements back as planned, their earlier capture kept in a backup.

    Each measurement's file and journal are copied into one new ``backup/<UTC time>/`` of
    the session (each copy written atomically), then its journal is removed and its
    planned file (``capture/<id>.planned.csv``) written back in its place. Every
    measurement is checked before anything is written. Killed in between, the same call
    starts again: a file holding readings no journal holds is what ``again`` is for.

    Parameters
    ----------
    folder : Path
        The session folder captured into.
    measurements : list of Measurement
        The measurements (as planned).

    Returns
    -------
    str
        The backup folder, relative to ``folder``.
    """
    from volcal.capture.journal import JOURNAL_FOLDER, journal_path
    from volcal.io.atomic import write_text
    from volcal.session.provenance import backup_files

    def kept(m: Any) -> Path:
        return folder / JOURNAL_FOLDER / (Path(m.file).stem + PLANNED_SUFFIX)

    for m in measurements:
        if not kept(m).is_file():
            raise ParameterError(f"{{again=True}}: {m.id} was never captured here (no "
                                 f"{JOURNAL_FOLDER}/{kept(m).name}): its readings, if any, "
                                 "came from elsewhere; capture into a new folder with "
                                 "{output}", folder / m.file)
    files = [f for m in measurements
             for f in (m.file, journal_path(folder, m.id).relative_to(folder).as_posix())]
    rel = backup_files(folder, [f for f in files if (folder / f).is_file()])
    for m in measurements:
        journal_path(folder, m.id).unlink(missing_ok=True)
        write_text(folder / m.file, kept(m).read_text(encoding="utf-8"))
    return rel.relative_to(folder).as_posix()


def _unreadable_notes(outcomes: list[Outcome], files: dict[str, Path]
                      ) -> tuple[list[str], list[str]]:
    """The measurements captured to the end that the session reader refuses, and why."""
    ids, notes = [], []
    for out in outcomes:
        if not out.complete:
            continue
        if out.accepted == 0:
            why = (f"{out.measurement}: no reading accepted (every one of the {out.planned} "
                   "missed: did the laser send readings? the journal's laser samples say); "
                   f"the session reads {files[out.measurement]} as not measured")
        elif 2 in out.missed:
            why = (f"{out.measurement}: the first reading (row 2), the reference of the "
                   f"others, was missed; the session reader refuses {files[out.measurement]}")
        else:
            continue
        ids.append(out.measurement)
        notes.append(f"{why}: capture it again (the same command with --measurement "
                     f"{out.measurement} --again)")
    return ids, notes


def capture(session: Session | str | Path, *, control: str, laser: str,
            measurement: Sequence[str] | None = None, output: str | Path | None = None,
            programs: str | Path | None = None, dwell_s: float | None = None,
            feed: float | None = None, overrun_mm: float | None = None,
            window_mm: float = D.CAPTURE_WINDOW_MM, window_deg: float = D.CAPTURE_WINDOW_DEG,
            stable_s: float = D.CAPTURE_STABLE_S,
            k_sigma: float = D.CAPTURE_K_SIGMA, laser_noise: float = D.CAPTURE_LASER_NOISE,
            control_noise_mm: float = D.CAPTURE_CONTROL_NOISE_MM,
            max_gap_s: float = D.CAPTURE_MAX_GAP_S, poll_s: float = D.CAPTURE_POLL_S,
            timeout_s: float | None = None, speed: float | None = None,
            observer: Callable[[CaptureEvent], None] | None = None,
            extras: dict[str, Any] | None = None, again: bool = False) -> Captured:
    """Capture the planned measurements of a session while their part programs run.

    Each measurement is captured in the plan's order (or the order of ``measurement``):
    the trigger rule (:mod:`volcal.capture.trigger`, ``docs/capture.md``) accepts one
    point per programmed dwell, or records it ``missed``; every sample and decision is
    journaled in ``SESSION/capture/<id>.jsonl`` and the measurement's CSV is rewritten
    atomically after each point. Run again after a kill or a disconnection, the same call
    resumes each measurement where its journal stopped; a complete measurement is skipped.

    Parameters
    ----------
    session : Session, str or Path
        The planned session (its folder).
    control : str
        Control ``SOURCE``: ``'sim'``, ``'linuxcnc'``, ``'opcua:opc.tcp://host:4840'``...
        (:mod:`volcal.capture.sources`).
    laser : str
        Laser ``SOURCE``: ``'sim'``, ``'stream:tcp://host:port'``, ``'stream:/dev/ttyUSB0'``,
        ``'stream:-'``, ``'file:PATH'``, ``'typed'``; a rotary test's readings are angles
        (``'stream:/dev/ttyUSB0;unit=arcsec'``: the unit of a line that names none).
    measurement : sequence of str, optional
        Ids of the measurements to capture, in this order (default: every one).
    output : str or Path, optional
        Capture into this folder (a copy of the planned session is made there; an
        existing capture there is resumed) instead of the session's own folder.
    programs : str or Path, optional
        The program folder (``volcal program -o``): its dwell, feed and overrun.
    dwell_s, feed, overrun_mm : float, optional
        The program's dwell [s], feed [mm/min] and overrun [mm] when not read from
        ``programs`` (default: volcal program's defaults).
    window_mm : float
        Target window [mm].
    window_deg : float
        Target window of a rotary test's axis [deg].
    stable_s : float
        Time both signals must be stable [s] (at most 3/4 of the dwell).
    k_sigma : float
        Stability threshold in standard errors.
    laser_noise : float
        Floor of the laser noise [um or urad].
    control_noise_mm : float
        Floor of the control position noise [mm].
    max_gap_s : float
        Longest polling gap inside a stable window [s].
    poll_s : float
        Pause between two polls [s].
    timeout_s : float, optional
        Stop (to resume later) when the control is silent, or nothing is decided, this
        long [s]; None waits for ever (a simulated control ends with its program).
    speed : float, optional
        With a simulated control: simulated seconds per wall second (None: as fast as
        possible).
    observer : callable, optional
        Called with every :class:`volcal.capture.samples.CaptureEvent` (the page).
    extras : dict, optional
        Objects handed to the sources (:attr:`volcal.capture.sources.SourceContext.extras`).
    again : bool
        Capture the measurements named in ``measurement`` again from their first reading
        (one whose first reading was missed, a set-up found wrong): each one's earlier
        file and journal are kept in ``backup/<UTC time>/`` of the session, then it is
        captured as planned. Only measurements captured before (their planned file kept
        in ``capture/``); ``measurement`` required.

    Returns
    -------
    Captured
    """
    from volcal.capture.plan import plan_measurement, program_options
    from volcal.capture.runner import LoopOptions, capture_measurement
    from volcal.capture.sources import (
        Clock,
        SourceContext,
        VirtualClock,
        is_simulated_control,
        make_control,
        make_laser,
    )
    from volcal.capture.trigger import TriggerParams

    params = TriggerParams(window_mm=window_mm, window_deg=window_deg, stable_s=stable_s,
                           k_sigma=k_sigma,
                           laser_noise=laser_noise, control_noise_mm=control_noise_mm,
                           max_gap_s=max_gap_s)
    _check_options(params, poll_s, timeout_s, speed, again, measurement)
    opts = program_options(programs, dwell_s=dwell_s, feed=feed, overrun_mm=overrun_mm)
    params.check(opts.dwell_s)
    simulated = is_simulated_control(control)
    if isinstance(session, str | Path) and not (Path(session) / "session.toml").is_file():
        raise VolcalInputError("not a session folder (no session.toml)", session)

    passed_over: list[str] = []

    def planned(folder: Path) -> tuple[Session, list[PlannedMeasurement]]:
        s = read_planned(folder)
        chosen = _capturable(s, _chosen(s, measurement, folder), bool(measurement),
                             passed_over, folder)
        return s, [plan_measurement(s.get(mid), s.travel, opts, programs) for mid in chosen]

    def check_sources(s0: Session, plans0: list[PlannedMeasurement]) -> None:
        ctx0 = SourceContext(VirtualClock(speed) if simulated else Clock(), s0, plans0,
                             lambda: None, lambda: None, dict(extras or {}))
        make_control(control, ctx0)
        make_laser(laser, ctx0)

    # nothing is written before the sources, the measurements and their files are known good
    resume = output is not None and (Path(output) / "session.toml").is_file()
    if again and output is not None and not resume:
        raise ParameterError(f"{{again=True}}: {{output=}}{output} holds no capture to take "
                             "again: capture into it without {again=True}")
    if not resume:
        check_sources(*planned(Path(session) if isinstance(session, str | Path)
                               else Path(session.path or ".")))
    folder = _target_folder(session, output)
    s, plans = planned(folder)
    if resume:
        check_sources(s, plans)
    notes: list[str] = list(dict.fromkeys(passed_over))
    if again:
        rel = _start_again(folder, [pm.measurement for pm in plans])
        notes += [f"{pm.id}: captured again from its first reading; the earlier capture is "
                  f"kept in {rel}/" for pm in plans]
    _prepare_files(folder, plans)
    todo, skipped = _split_done(folder, plans)
    outcomes: list[Outcome] = []
    if todo:
        clock = VirtualClock(speed) if simulated else Clock()
        state: dict[str, Any] = {"latest": None, "current": None}
        ctx = SourceContext(clock, s, plans, lambda: state["latest"],
                            lambda: state["current"], dict(extras or {}))

        def one(pm: PlannedMeasurement, ctrl: Any, las: Any) -> Outcome:
            state["current"] = pm.id
            return capture_measurement(
                pm, folder, ctrl, las, clock, params, sources=(control, laser),
                loop=LoopOptions(poll_s=poll_s, timeout_s=timeout_s), observer=observer,
                latest=lambda c: state.__setitem__("latest", c))

        outcomes = _run(todo, make_control(control, ctx), make_laser(laser, ctx), one)
        notes += [n for out in outcomes for n in out.notes]
    unreadable, said = _unreadable_notes(
        outcomes, {pm.id: folder / pm.measurement.file for pm in plans})
    done = len(outcomes) == len(todo) and all(o.complete for o in outcomes)
    return Captured(folder, tuple(outcomes), tuple(pm.id for pm in skipped), done,
                    tuple(notes + _outcome_notes(outcomes) + said), tuple(unreadable))


def _run(todo: list[PlannedMeasurement], ctrl: Any, las: Any,
         one: Callable[[PlannedMeasurement, Any, Any], Outcome]) -> list[Outcome]:
    """Open both sources, capture each measurement in turn until one stops, close both."""
    outcomes: list[Outcome] = []
    ctrl.open()
    try:
        las.open()
        try:
            for pm in todo:
                outcomes.append(one(pm, ctrl, las))
                if not outcomes[-1].complete:
                    break
        finally:
            las.close()
    finally:
        ctrl.close()
    return outcomes


def _check_options(params: Any, poll_s: float, timeout_s: float | None, speed: float | None,
                   again: bool, measurement: Sequence[str] | None) -> None:
    """Refuse option values the capture cannot use, before anything is read or written."""
    params.check()
    if not (isinstance(poll_s, int | float) and 0 < poll_s <= params.max_gap_s):
        raise ParameterError(f"{{poll_s=}}{poll_s!r}: expected 0 < poll <= {{max_gap_s=}}"
                             f"{params.max_gap_s:g} s")
    if timeout_s is not None and not timeout_s > 0:
        raise ParameterError(f"{{timeout_s=}}{timeout_s!r}: expected a positive time [s]")
    if speed is not None and not speed > 0:
        raise ParameterError(f"{{speed=}}{speed!r}: expected a positive factor")
    if again and not measurement:
        raise ParameterError("{again=True} needs {measurement}: name the measurements to "
                             "capture again (their earlier capture is kept in backup/)")


def _chosen(s: Session, measurement: Sequence[str] | None, folder: Path) -> list[str]:
    """The ids ``measurement`` names (every measurement of ``s`` when None), checked."""
    ids = [m.id for m in s.measurements]
    chosen = list(measurement) if measurement else ids
    for mid in chosen:
        if mid not in ids:
            raise ParameterError(f"{{measurement=}}{mid!r} is not in the session (its "
                                 f"measurements: {', '.join(ids)})", folder / "session.toml")
    if len(set(chosen)) != len(chosen):
        raise ParameterError(f"{{measurement=}}: an id is given twice ({', '.join(chosen)})")
    return chosen


def _prepare_files(folder: Path, plans: list[PlannedMeasurement]) -> None:
    """Refuse a file holding a reading its journal does not hold; keep each planned file.

    A measured reading is never overwritten: every file is checked before the first is
    written. Each measurement's file as planned is kept at its first start, in
    ``capture/<id>.planned.csv``.
    """
    from volcal.capture.journal import JOURNAL_FOLDER, journal_path, read_journal
    from volcal.capture.sessionfile import render_csv
    from volcal.io.atomic import write_text

    for pm in plans:
        render_csv(folder / pm.measurement.file, pm.measurement,
                   read_journal(journal_path(folder, pm.id)), {})
    (folder / JOURNAL_FOLDER).mkdir(exist_ok=True)
    for pm in plans:
        keep = folder / JOURNAL_FOLDER / (Path(pm.measurement.file).stem + PLANNED_SUFFIX)
        if not keep.is_file():
            write_text(keep, (folder / pm.measurement.file).read_text(encoding="utf-8"))


def _split_done(folder: Path, plans: list[PlannedMeasurement]
                ) -> tuple[list[PlannedMeasurement], list[PlannedMeasurement]]:
    """The measurements still to capture, and those their journals hold complete."""
    from volcal.capture.journal import journal_path, read_journal

    todo: list[PlannedMeasurement] = []
    skipped: list[PlannedMeasurement] = []
    for pm in plans:
        rec = read_journal(journal_path(folder, pm.id))
        (skipped if rec.done >= {d.reading for d in pm.dwells} else todo).append(pm)
    return todo, skipped


def _outcome_notes(outcomes: list[Outcome]) -> list[str]:
    """The missed rows of each measurement captured, and where a stopped one resumes."""
    notes = []
    for out in outcomes:
        if out.missed:
            notes.append(f"{out.measurement}: missed at row(s) {', '.join(map(str, out.missed))}"
                         " (docs/capture.md: what to do when a point is missed)")
        if not out.complete:
            notes.append(f"{out.measurement}: {out.reason}; {out.accepted} of {out.planned} "
                         "readings recorded. Run the same command again to resume")
    return notes
