"""What the technician's page shows, kept up to date by the capture (thread-safe).

The capture's loop (:mod:`volcal.capture.runner`) tells a :class:`LiveState` what happens:
the plan, the measurement it starts, every control and laser sample, every event of the
trigger rule (accepted, missed, replayed, note), the end. The page's server
(:mod:`volcal.capture.page.server`) reads :meth:`LiveState.snapshot` and sends it to the
browsers. Nothing here decides anything about a reading: the stability indicator is a
display of the signals' recent spread, the acceptance is the trigger rule's.

A source *stops sending* when no sample of it arrived for ``stale_s`` seconds of wall time,
or when its last sample carries a status other than ``ok`` (``lost: ...`` from a dropped
OPC UA connection); the page then shows a banner naming the source, how long it has been
silent and the reason. A ``typed`` laser is silent by nature between two typed values and
gets no such banner.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["LiveState", "STALE_S"]

STALE_S = 2.0
"""A source that sent nothing for this long is shown as stopped [s]."""

RECENT_S = 1.0
"""The stability indicator looks at the samples of the last this many seconds [s]."""

MAX_NOTES = 30
"""The page lists this many of the latest notes."""


def _num(x: Any, nd: int = 6) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return round(v, nd) if math.isfinite(v) else None


class _Source:
    """Receipt times and status of one source."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.last_wall: float | None = None
        self.last_ok_wall: float | None = None
        self.status = "ok"
        self.recent: deque[tuple[float, Any]] = deque(maxlen=400)

    def seen(self, wall: float, status: str, value: Any) -> None:
        self.last_wall = wall
        self.status = status
        if status == "ok":
            self.last_ok_wall = wall
            self.recent.append((wall, value))


class LiveState:
    """The live state of a capture for the page.

    Parameters
    ----------
    title : str
        Shown as the page's heading (the session's name).
    stale_s : float
        A source silent this long [s] of wall time gets a banner.
    typed : TypedQueue, optional
        The queue of the ``typed`` laser source, when the page takes typed readings.
    window_mm : float
        The trigger rule's target window [mm]: the indicator's "at target".
    wall : callable
        The wall clock (``time.monotonic``; a test passes its own).
    """

    def __init__(self, title: str = "", *, stale_s: float = STALE_S, typed: Any = None,
                 window_mm: float = 0.010,
                 wall: Callable[[], float] = time.monotonic) -> None:
        self._lock = threading.RLock()
        self.title = title
        self.stale_s = float(stale_s)
        self.typed = typed
        self._wall = wall
        self._t0 = wall()
        self.version = 0
        self.points_version = 0
        self.control_src = _Source("")
        self.laser_src = _Source("")
        self.laser_is_typed = typed is not None
        self.control: dict[str, Any] | None = None
        self.laser: dict[str, Any] | None = None
        self.flagged = {"control": False, "laser": False}
        self.measurements: list[dict[str, Any]] = []
        self._by_id: dict[str, dict[str, Any]] = {}
        self.current: str | None = None
        self.window_mm = float(window_mm)
        self.notes: deque[dict[str, Any]] = deque(maxlen=MAX_NOTES)
        self.typed_log: list[dict[str, Any]] = []
        self.finished: str | None = None
        self.error: str | None = None
        self.started = False

    # ------------------------------------------------------------------ feeding
    def _bump(self, points: bool = False) -> None:
        self.version += 1
        if points:
            self.points_version += 1

    def set_sources(self, control: str, laser: str) -> None:
        """Name the sources as on the command line.

        Parameters
        ----------
        control, laser : str
            The ``SOURCE`` texts (a ``typed`` laser gets no silence banner).
        """
        with self._lock:
            self.control_src.text = control
            self.laser_src.text = laser
            self.laser_is_typed = self.laser_is_typed or laser.split(":")[0] == "typed"
            self._bump()

    def __call__(self, ev: Any) -> None:
        """Take one event of the capture (:class:`volcal.capture.samples.CaptureEvent`).

        This is the observer the capture's loop calls: ``start`` (a measurement begins,
        with its planned targets), ``control`` and ``laser`` (a sample), ``accepted``,
        ``missed``, ``replayed``, ``note``, ``stale`` / ``fresh`` (a source stopped or
        resumed sending) and ``end``.
        """
        kind = ev.kind
        data = dict(ev.data or {})
        with self._lock:
            if kind == "start":
                self._start(str(ev.measurement), data)
            elif kind == "control":
                pos = {str(k): float(v) for k, v in (data.get("pos") or {}).items()}
                status = str(data.get("status", "ok"))
                self.control_src.seen(self._wall(), status, pos)
                self.control = {"t": data.get("t"), "pos": pos, "status": status}
            elif kind == "laser":
                status = str(data.get("status", "ok"))
                value = _num(data.get("v"))
                self.laser_src.seen(self._wall(), status, value)
                self.laser = {"t": data.get("t"), "v": value, "unit": data.get("unit"),
                              "status": status,
                              "ch": [_num(v) for v in data["ch"]] if data.get("ch") else None}
                typed = (data.get("extra") or {}).get("typed")
                if typed is not None:
                    for e in self.typed_log:
                        if e["id"] == typed and e["state"] == "queued":
                            e["state"] = "taken"
            elif kind in ("accepted", "missed", "replayed"):
                self._decided(str(ev.measurement), kind, ev.time_s, data)
            elif kind == "note":
                self.notes.append({"t": _num(ev.time_s, 3), "text": str(data.get("text", ""))})
            elif kind in ("stale", "fresh"):
                src = data.get("source")
                if src in ("control", "laser"):
                    self.flagged[src] = kind == "stale"
            elif kind == "end":
                reason = str(data.get("reason", ""))
                if data.get("complete"):
                    self.notes.append({"t": _num(ev.time_s, 3),
                                       "text": f"{ev.measurement}: complete"})
                else:
                    self.notes.append({"t": _num(ev.time_s, 3),
                                       "text": f"{ev.measurement}: stopped ({reason})"})
            else:
                return
            self._bump(points=kind in ("start", "accepted", "missed", "replayed"))

    def _start(self, mid: str, data: dict[str, Any]) -> None:
        dim = len(data.get("axes") or "XYZ")  # a rotary test's targets are angles [deg]
        targets = np.array(data.get("targets") or [], float).reshape(-1, dim)
        if data.get("axes_unit") == "mm+deg":  # an R-test: poses, no line to follow
            along = np.arange(1.0, len(targets) + 1.0)
        elif len(targets) >= 2:
            first = targets[0]
            far = targets[int(np.argmax(np.linalg.norm(targets - first, axis=1)))]
            u = far - first
            n = float(np.linalg.norm(u))
            along = (targets - first) @ (u / n) if n > 0 else np.zeros(len(targets))
        else:
            along = np.zeros(len(targets))
        k = len(targets)
        runs = list(data.get("runs") or [None] * k)
        dirs = list(data.get("directions") or [None] * k)
        # readings recorded before (a resumed capture): reading -> value, and for a reading
        # of several channels (an R-test's sensors) reading -> the channels' values
        values = {int(i): v for i, v in (data.get("values") or {}).items()}
        rows = {int(i): v for i, v in (data.get("rows") or {}).items()}
        done = {int(i) for i in data.get("done") or []}
        missed = {int(i) for i in data.get("missed") or []}
        dwells = []
        for i in range(k):
            status = "missed" if i in missed else ("accepted" if i in done else "pending")
            dwells.append({"reading": i, "target": [_num(v, 4) for v in targets[i]],
                           "along": _num(along[i], 4), "run": runs[i], "direction": dirs[i],
                           "status": status,
                           "value": _num(values.get(i)) if status == "accepted" else None,
                           "values": ([_num(v) for v in rows[i]]
                                      if status == "accepted" and i in rows else None),
                           "raw": None, "position": None, "t": None,
                           "reason": "recorded before" if i in done else None})
        m = {"id": mid, "column": str(data.get("column", "")),
             "columns": [str(c) for c in data.get("columns") or [data.get("column", "")]],
             "unit": str(data.get("unit", "um")), "dwells": dwells,
             "axes": [str(a) for a in data.get("axes") or "XYZ"],
             "axes_unit": str(data.get("axes_unit", "mm"))}
        if mid in self._by_id:
            self.measurements[self.measurements.index(self._by_id[mid])] = m
        else:
            self.measurements.append(m)
        self._by_id[mid] = m
        self.current = mid
        self.started = True
        self.finished = None

    def _decided(self, mid: str, kind: str, t: float, data: dict[str, Any]) -> None:
        m = self._by_id.get(mid)
        if m is None or "reading" not in data:
            return
        i = int(data["reading"])
        if not 0 <= i < len(m["dwells"]):
            return
        d = m["dwells"][i]
        if kind == "accepted":
            d.update(status="accepted", value=_num(data.get("value")),
                     values=([_num(v) for v in data["values"]] if data.get("values")
                             else None),
                     raw=_num(data.get("raw")), t=_num(t, 3), reason=None,
                     position=[_num(v, 5) for v in data.get("pos") or []])
        elif kind == "missed":
            d.update(status="missed", t=_num(t, 3), reason=str(data.get("reason", "")))
        else:
            d.update(reason="replayed: recorded before, not written again")

    @property
    def expected(self) -> int | None:
        """The first reading of the current measurement not recorded yet."""
        m = self._by_id.get(self.current or "")
        if m is None:
            return None
        return next((d["reading"] for d in m["dwells"] if d["status"] == "pending"), None)

    def note(self, text: str) -> None:
        """A message for the technician.

        Parameters
        ----------
        text : str
            The message.
        """
        with self._lock:
            self.notes.append({"t": None, "text": str(text)})
            self._bump()

    def finish(self, message: str = "capture finished", error: str | None = None) -> None:
        """The capture ended.

        Parameters
        ----------
        message : str
            What the page says of the end.
        error : str, optional
            Why it stopped on an error (shown as a banner).
        """
        with self._lock:
            self.finished = message
            self.error = error
            self._bump()

    def typed_put(self, value: float, unit: str, note: str = "") -> dict[str, Any]:
        """Queue a reading typed on the page for the ``typed`` source.

        Parameters
        ----------
        value : float
            The reading [``unit``].
        unit : str
            Its unit (``'um'``, ``'mm'``, ``'urad'``...).
        note : str
            Free text.

        Returns
        -------
        dict
            The log entry (``id``, ``value``, ``unit``, ``state`` = ``'queued'``).

        Raises
        ------
        VolcalInputError
            No typed source, or a bad value or unit (from the queue).
        """
        from volcal.capture.samples import ANGULAR_UNITS, LINEAR_UNITS
        from volcal.errors import VolcalInputError

        if self.typed is None:
            raise VolcalInputError("this capture reads no typed laser (--laser typed)")
        with self._lock:
            m = self._by_id.get(self.current or "")
        u = str(unit).strip()
        if m is not None and (m["unit"] == "um" and u in ANGULAR_UNITS
                              or m["unit"] == "urad" and u in LINEAR_UNITS):
            reads = "lengths (um, mm...)" if m["unit"] == "um" else "angles (urad, arcsec...)"
            raise VolcalInputError(f"typed reading in {u}: measurement {m['id']} reads {reads}")
        r = self.typed.put(value, unit, note)
        with self._lock:
            entry = {"id": r.id, "value": r.value, "unit": r.unit, "state": "queued",
                     "measurement": self.current, "expected": self.expected}
            self.typed_log.append(entry)
            self._bump()
            return dict(entry)

    def _dwell(self, measurement_id: str, reading: int) -> dict[str, Any] | None:
        m = self._by_id.get(str(measurement_id))
        if m is None:
            return None
        return next((d for d in m["dwells"] if d["reading"] == reading), None)

    # ------------------------------------------------------------------ reading
    def _source_view(self, src: _Source, now: float, typed: bool,
                     flagged: bool = False) -> dict[str, Any]:
        silent = None if src.last_ok_wall is None else now - src.last_ok_wall
        if src.last_ok_wall is None:
            silent = now - self._t0
        lost = src.status != "ok"
        stale = (not typed and self.started and self.finished is None
                 and (lost or flagged or (silent is not None and silent > self.stale_s)))
        return {"source": src.text, "status": src.status, "silent_s": _num(silent, 1),
                "stale": bool(stale)}

    def _stability(self, now: float) -> dict[str, Any]:
        """The indicator: recent spread of each signal and where the control stands."""
        out: dict[str, Any] = {"state": "waiting", "control_spread_mm": None,
                               "laser_spread": None, "distance_mm": None}
        ctrl = [v for t, v in self.control_src.recent if t >= now - RECENT_S and v]
        if ctrl:
            keys = sorted(ctrl[-1])
            arr = np.array([[c.get(k, np.nan) for k in keys] for c in ctrl], float)
            spread = float(np.nanmax(np.nanmax(arr, axis=0) - np.nanmin(arr, axis=0)))
            out["control_spread_mm"] = _num(spread, 5)
            out["state"] = "moving" if spread > self.window_mm else "at rest"
            m = self._by_id.get(self.current or "")
            axes = list(m.get("axes", "XYZ")) if m is not None else list("XYZ")
            if m is not None and self.expected is not None and set(axes) <= set(keys):
                d = next((d for d in m["dwells"] if d["reading"] == self.expected), None)
                if d is not None:
                    here = np.array([ctrl[-1][k] for k in axes])
                    off = here - np.array(d["target"], float)
                    if m.get("axes_unit") == "deg":  # a rotary axis: [deg], modulo 360
                        off = (off + 180.0) % 360.0 - 180.0
                    elif m.get("axes_unit") == "mm+deg":  # an R-test: X Y Z, the angles
                        off[3:] = (off[3:] + 180.0) % 360.0 - 180.0
                    dist = float(np.max(np.abs(off)))
                    out["distance_mm"] = _num(dist, 4)
                    if out["state"] == "at rest" and dist <= self.window_mm:
                        out["state"] = "at target"
        las = [v for t, v in self.laser_src.recent if t >= now - RECENT_S and v is not None]
        if len(las) >= 2:
            out["laser_spread"] = _num(max(las) - min(las), 4)
        return out

    def snapshot(self, with_points: bool = True) -> dict[str, Any]:
        """The state as JSON-ready data.

        Parameters
        ----------
        with_points : bool
            Include the planned measurements and their points (large); without them the
            snapshot carries only ``points_version`` for the page to ask again.

        Returns
        -------
        dict
        """
        with self._lock:
            now = self._wall()
            c, la = self.control, self.laser
            control = self._source_view(self.control_src, now, typed=False,
                                        flagged=self.flagged["control"])
            control["positions"] = ({k: _num(v, 4) for k, v in c["pos"].items()}
                                    if c is not None and c["pos"] else {})
            control["t"] = _num(c["t"], 3) if c is not None else None
            laser = self._source_view(self.laser_src, now, typed=self.laser_is_typed,
                                      flagged=self.flagged["laser"])
            laser.update(value=la["v"] if la is not None else None,
                         channels=la["ch"] if la is not None else None,
                         unit=la["unit"] if la is not None else None,
                         t=_num(la["t"], 3) if la is not None else None,
                         typed=self.laser_is_typed)
            banners = []
            for what, v in (("control", control), ("laser", laser)):
                if v["stale"]:
                    why = v["status"] if v["status"] != "ok" else "no sample"
                    banners.append(f"The {what} source {v['source']} stopped sending "
                                   f"{v['silent_s']:.0f} s ago ({why})".replace(" ()", ""))
            if self.error:
                banners.append(f"The capture stopped: {self.error}")
            counts = {"planned": 0, "accepted": 0, "missed": 0}
            for m in self.measurements:
                for d in m["dwells"]:
                    counts["planned"] += 1
                    if d["status"] in counts:
                        counts[d["status"]] += 1
            out: dict[str, Any] = {
                "title": self.title, "version": self.version,
                "points_version": self.points_version, "current": self.current,
                "expected": self.expected,
                "control": control, "laser": laser, "banners": banners,
                "stability": self._stability(now), "counts": counts,
                "notes": list(self.notes), "typed_log": [dict(e) for e in self.typed_log],
                "finished": self.finished, "error": self.error,
            }
            if with_points:
                out["measurements"] = [
                    {**m, "dwells": [dict(d) for d in m["dwells"]]} for m in self.measurements]
            return out
