"""The capture loop: poll both sources, feed the trigger rule, journal, write the CSV.

One :func:`capture_measurement` per planned measurement, in the plan's order, on sources
opened once for the whole capture. Every sample is journaled as it arrives; an accepted
or missed point is synced to the journal, then the measurement's CSV is rewritten
atomically from the journal (so a point in the CSV is always in the journal, and a point
in the journal reaches the CSV on the next start at the latest).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from volcal.capture.journal import Journal, Recorded, journal_path, read_journal
from volcal.capture.plan import PlannedMeasurement
from volcal.capture.samples import CaptureEvent, ControlSample, LaserSample
from volcal.capture.sessionfile import reading_of, stale_temporaries, write_csv
from volcal.capture.sources import Clock, ControlSource, LaserSource, SourceError
from volcal.capture.trigger import (
    Accepted,
    Missed,
    Note,
    Replayed,
    TriggerEvent,
    TriggerParams,
    TriggerRule,
)
from volcal.errors import VolcalInputError

__all__ = ["LoopOptions", "Outcome", "capture_measurement"]

Observer = Callable[[CaptureEvent], None]


@dataclass(frozen=True)
class LoopOptions:
    """How the loop polls.

    Attributes
    ----------
    poll_s : float
        Pause between two polls of the sources [s].
    stale_s : float
        A source silent this long is announced as stopped (``'stale'`` event) [s].
    timeout_s : float or None
        A control silent this long, or no new reading decided for this long, ends the
        capture (resume later) [s]; None waits for ever.
    """

    poll_s: float = 0.02
    stale_s: float = 2.0
    timeout_s: float | None = None


@dataclass
class Outcome:
    """What the capture of one measurement recorded.

    Attributes
    ----------
    measurement : str
    accepted : int
        Readings accepted (this run and before).
    missed : list of int
        CSV rows (header = row 1) recorded ``missed``.
    replayed : int
        Dwells of readings recorded before, passed over.
    planned : int
    complete : bool
        Every planned dwell recorded.
    reason : str
        Why the loop ended (``complete``, ``program ended``, ``timeout``, ``disconnected:
        ...``).
    notes : list of str
    """

    measurement: str
    accepted: int
    missed: list[int]
    replayed: int
    planned: int
    complete: bool
    reason: str
    notes: list[str] = field(default_factory=list)


def _times(rec: Recorded) -> dict[int, float]:
    out = {}
    for i, r in (*rec.accepted.items(), *rec.missed.items()):
        if isinstance(r.get("time_s"), int | float):
            out[i] = float(r["time_s"])
    return out


def _base_seconds(rec: Recorded, simulated: bool) -> float:
    """Measurement time at the start of this run [s]: wall time since the first start."""
    if simulated or not rec.starts:
        return 0.0
    try:
        first = datetime.fromisoformat(str(rec.starts[0]["utc"]))
    except (KeyError, ValueError):
        return 0.0
    return max(0.0, (datetime.now(UTC) - first).total_seconds())


def capture_measurement(pm: PlannedMeasurement, folder: Path, control: ControlSource,
                        laser: LaserSource, clock: Clock, params: TriggerParams, *,
                        sources: tuple[str, str] = ("", ""), loop: LoopOptions | None = None,
                        observer: Observer | None = None,
                        latest: Callable[[ControlSample], None] | None = None) -> Outcome:
    """Capture one measurement into its CSV in ``folder``, resuming its journal.

    Parameters
    ----------
    pm : PlannedMeasurement
        The measurement and its programmed dwells.
    folder : Path
        The session folder (the CSV and ``capture/<id>.jsonl``).
    control, laser : ControlSource, LaserSource
        Open sources.
    clock : Clock
        The capture's clock (the sources stamp with it).
    params : TriggerParams
    sources : tuple of str
        The control and laser ``SOURCE`` texts (journal only).
    loop : LoopOptions, optional
    observer : callable, optional
        Called with every :class:`CaptureEvent`.
    latest : callable, optional
        Called with every control sample (the context's latest control).

    Returns
    -------
    Outcome
    """
    loop = loop or LoopOptions()
    m = pm.measurement
    csv_path = folder / m.file
    for tmp in stale_temporaries(csv_path):
        tmp.unlink()
    jpath = journal_path(folder, m.id)
    rec = read_journal(jpath)
    reading = reading_of(m)
    times = _times(rec)
    write_csv(csv_path, m, rec, times)  # refuses readings not from this journal first
    base = _base_seconds(rec, clock.simulated)
    journal = Journal(jpath)
    emit = observer or (lambda e: None)
    notes: list[str] = []
    rule = TriggerRule(pm.dwells, params, pm.waypoints, reading.unit, rec.done, m.id, pm.start,
                       pm.frame, reading.channels)
    t_start = clock.now()
    journal.write("start", {
        "measurement": m.id, "control": sources[0], "laser": sources[1],
        "params": {k: getattr(params, k) for k in params.__dataclass_fields__},
        "program": {"dwell_s": pm.options.dwell_s, "feed": pm.options.feed,
                    "overrun_mm": pm.options.overrun_mm,
                    **({"overrun_deg": pm.options.overrun_deg} if pm.frame.rotary else {})},
        "axes": list(pm.frame.axes), "axes_unit": pm.frame.unit,
        "readings": len(pm.dwells), "done": sorted(rec.done),
        "utc": datetime.now(UTC).isoformat(timespec="milliseconds"), "t": t_start},
        sync=True)
    emit(CaptureEvent("start", m.id, t_start, {
        "readings": len(pm.dwells), "targets": [d.target.tolist() for d in pm.dwells],
        "axes": list(pm.frame.axes), "axes_unit": pm.frame.unit,
        "directions": [d.direction for d in pm.dwells], "runs": [d.run for d in pm.dwells],
        "done": sorted(rec.done), "column": reading.column, "unit": reading.unit,
        "values": reading.values(rec), "missed": sorted(rec.missed),
        "columns": list(reading.columns),
        "rows": ({i: list(v) for i, v in reading.rows(rec).items()}
                 if reading.channels > 1 else {})}))
    replayed = 0
    last = {"control": t_start, "laser": t_start}
    stale = {"control": False, "laser": False}
    last_decision = t_start
    reason = "complete"

    def handle(ev: TriggerEvent) -> None:
        nonlocal replayed, last_decision
        t = ev.time_s
        if isinstance(ev, Accepted | Missed):
            last_decision = t
            ts = base + (t - t_start)
            typ = "accepted" if isinstance(ev, Accepted) else "missed"
            journal.write(typ, {**ev.to_json(), "time_s": ts}, sync=True)
            target = rec.accepted if isinstance(ev, Accepted) else rec.missed
            target[ev.reading] = {**ev.to_json(), "time_s": ts}
            times[ev.reading] = ts
            write_csv(csv_path, m, rec, times)
            data = ev.to_json()
            if isinstance(ev, Accepted):
                data = {**data, "raw": ev.value, "value": reading.values(rec)[ev.reading]}
                if ev.values:
                    data["values"] = list(reading.rows(rec)[ev.reading])
            emit(CaptureEvent(typ, m.id, t, data))
        elif isinstance(ev, Replayed):
            replayed += 1
            last_decision = t
            journal.write("replayed", ev.to_json())
            emit(CaptureEvent("replayed", m.id, t, ev.to_json()))
        elif isinstance(ev, Note):
            notes.append(ev.text)
            journal.write("note", ev.to_json())
            emit(CaptureEvent("note", m.id, t, {"text": ev.text}))

    try:
        while not rule.complete:
            now = clock.now()
            batch: list[tuple[float, int, ControlSample | LaserSample]] = []
            ended = False
            while (c := control.poll()) is not None:
                batch.append((c.time_s, 0, c))
            while (la := laser.poll()) is not None:
                batch.append((la.time_s, 1, la))
            batch.sort(key=lambda x: (x[0], x[1]))
            for _, k, s in batch:
                name = "control" if k == 0 else "laser"
                journal.write(name, s.to_json())
                last[name] = s.time_s
                if stale[name]:
                    stale[name] = False
                    emit(CaptureEvent("fresh", m.id, s.time_s, {"source": name}))
                emit(CaptureEvent(name, m.id, s.time_s, s.to_json()))
                if isinstance(s, ControlSample):
                    if latest is not None:
                        latest(s)
                    ended = ended or s.status == "ended"
                    events = rule.feed_control(s)
                else:
                    events = rule.feed_laser(s)
                for ev in events:
                    handle(ev)
                if rule.complete:
                    break
            if rule.complete:
                break
            for name in ("control", "laser"):
                if not stale[name] and now - last[name] > loop.stale_s:
                    stale[name] = True
                    emit(CaptureEvent("stale", m.id, now, {"source": name,
                                                           "silent_s": now - last[name]}))
                    journal.write("note", {"t": now, "text": f"{name} silent since "
                                                             f"{last[name]:.3f} s"})
            if ended:
                reason = "program ended before every dwell was recorded"
                break
            if loop.timeout_s is not None and (now - last["control"] > loop.timeout_s
                                               or now - last_decision > loop.timeout_s):
                reason = f"timeout: nothing decided for {loop.timeout_s:g} s"
                break
            clock.sleep(loop.poll_s)
    except SourceError as e:
        reason = f"disconnected: {e}"
    except VolcalInputError as e:  # a mismatch with the plan: refused, said in the journal
        reason = f"refused: {e}"
        raise
    except KeyboardInterrupt:
        reason = "interrupted"
        raise
    finally:
        complete = rule.complete
        journal.write("end", {"t": clock.now(), "reason": reason if complete or
                              reason != "complete" else "stopped"}, sync=True)
        journal.close()
    emit(CaptureEvent("end", m.id, clock.now(), {"reason": reason, "complete": complete}))
    return Outcome(m.id, len(rec.accepted), sorted(i + 2 for i in rec.missed), replayed,
                   len(pm.dwells), complete, reason, notes)


def journal_summary(folder: Path, m: Any) -> Recorded:
    """The journal records of measurement ``m`` in ``folder`` (for a status line).

    Parameters
    ----------
    folder : Path
        The session folder.
    m : Measurement
        The measurement.

    Returns
    -------
    Recorded
    """
    return read_journal(journal_path(folder, m.id))
