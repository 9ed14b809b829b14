"""The ``typed`` laser source: readings the technician types on the capture's page.

The technician reads the laser's display while the machine dwells at a target and types
the value on the page (``volcal capture ... --laser typed --serve``). The position and the
time of the reading come from the control: the source holds the typed value and reports it
at every poll, stamped with the time of the poll, for as long as the control stands where it
stood when the value was typed (within ``hold_mm``); when the control moves on, the value is
dropped, so a reading typed at one target is never taken at the next. The trigger rule then
sees a laser signal that stands still while the control does, and accepts the point after
its stable time, once per dwell, like any other laser.

A program captured with typed readings needs dwells long enough to read and type, plus the
rule's stable time: ``volcal program --dwell-s 20`` (docs/capture_page.md).

The page hands its :class:`TypedQueue` to the source through
``SourceContext.extras['typed']``.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass

import numpy as np

from volcal.capture.samples import ANGULAR_UNITS, LINEAR_UNITS, ControlSample, LaserSample
from volcal.capture.sources import (
    SourceContext,
    SourceError,
    SourceSpec,
    options,
    register_laser,
)
from volcal.errors import VolcalInputError

__all__ = ["TypedLaser", "TypedQueue", "TypedReading", "EXTRAS_KEY", "make"]

EXTRAS_KEY = "typed"
"""Key of ``SourceContext.extras`` under which the page puts its :class:`TypedQueue`."""

HOLD_MM = 0.01
"""Default distance the control may move before a typed value is dropped [mm]."""

MIN_INTERVAL_S = 0.005
"""A poll within this time [s] of the last sample returns None (the loop drains a source
until None: a held value is one sample per poll)."""


@dataclass(frozen=True)
class TypedReading:
    """One value typed on the page.

    Attributes
    ----------
    id : int
        Its number in the order typed (from 1).
    value : float
        The reading as typed, in ``unit``.
    unit : str
        ``'um'``, ``'mm'``, ``'urad'``, ``'arcsec'``... (:mod:`volcal.capture.samples`).
    note : str
        Free text typed with it (journal only).
    """

    id: int
    value: float
    unit: str
    note: str = ""


class TypedQueue:
    """The readings typed on the page and not yet taken by the source (thread-safe)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._items: deque[TypedReading] = deque()
        self._count = 0
        self.connected = False
        """True once a ``typed`` source reads this queue."""

    def put(self, value: float, unit: str = "um", note: str = "") -> TypedReading:
        """Queue a typed reading.

        Parameters
        ----------
        value : float
            The reading [``unit``].
        unit : str
            Its unit.
        note : str
            Free text.

        Returns
        -------
        TypedReading

        Raises
        ------
        VolcalInputError
            A value that is not a finite number, or an unknown unit.
        """
        if not (isinstance(value, int | float) and math.isfinite(value)):
            raise VolcalInputError(f"typed reading {value!r}: expected a finite number")
        u = str(unit).strip()
        if u not in LINEAR_UNITS and u not in ANGULAR_UNITS:
            raise VolcalInputError(f"typed reading unit {unit!r}: expected one of "
                                   f"{', '.join(sorted(set(LINEAR_UNITS) | set(ANGULAR_UNITS)))}")
        with self._lock:
            self._count += 1
            r = TypedReading(self._count, float(value), u, str(note)[:200])
            self._items.append(r)
            return r

    def take(self) -> TypedReading | None:
        """The oldest reading not taken yet, or None."""
        with self._lock:
            return self._items.popleft() if self._items else None


class TypedLaser:
    """A laser source fed by the technician's typing (see the module's docstring).

    Parameters
    ----------
    queue : TypedQueue
        Where the page puts the typed readings.
    context : SourceContext
        The capture's clock and its latest control sample.
    hold_mm : float
        The control may move this far from where it stood when the value was typed before
        the value is dropped [mm].
    """

    def __init__(self, queue: TypedQueue, context: SourceContext,
                 hold_mm: float = HOLD_MM) -> None:
        self.queue = queue
        self.context = context
        self.hold_mm = float(hold_mm)
        self.held: TypedReading | None = None
        self._at: np.ndarray | None = None
        self._last_t: float | None = None

    def open(self) -> None:
        """Mark the queue as read (the page then shows the entry form)."""
        self.queue.connected = True

    def _position(self) -> np.ndarray | None:
        s: ControlSample | None = self.context.latest_control()
        if s is None or s.status != "ok" or not s.positions:
            return None
        return np.array([float(v) for _, v in sorted(s.positions.items())])

    def poll(self) -> LaserSample | None:
        """The value typed last, at the time of this poll, while the control stays put.

        Returns
        -------
        LaserSample or None
            None before a value is typed, while the control is unknown, and once it has
            moved more than ``hold_mm`` from where the value was typed.
        """
        new = self.queue.take()
        while new is not None:  # the newest typed value wins
            self.held, self._at = new, self._position()
            new = self.queue.take()
        if self.held is None:
            return None
        here = self._position()
        if here is None:
            return None
        if self._at is None or self._at.shape != here.shape:
            self._at = here
        elif float(np.max(np.abs(here - self._at))) > self.hold_mm:
            self.held, self._at = None, None
            return None
        return self._sample()

    def _sample(self) -> LaserSample | None:
        assert self.held is not None
        now = self.context.clock.now()
        if self._last_t is not None and now - self._last_t < MIN_INTERVAL_S:
            return None
        self._last_t = now
        return LaserSample(time_s=now, value=self.held.value,
                           unit=self.held.unit, extra={"typed": self.held.id,
                                                       **({"note": self.held.note}
                                                          if self.held.note else {})})

    def close(self) -> None:
        """Nothing to release."""
        self.queue.connected = False


def make(spec: SourceSpec, context: SourceContext) -> TypedLaser:
    """The factory registered as ``typed`` (``typed`` or ``typed:hold_mm=0.02``).

    Parameters
    ----------
    spec : SourceSpec
        The source as written; its argument may set ``hold_mm`` [mm].
    context : SourceContext
        The capture's context: ``extras['typed']`` is the page's queue.

    Returns
    -------
    TypedLaser

    Raises
    ------
    SourceError
        No page to type on (``--serve`` not given).
    """
    opts = options(spec.argument, spec.text, ("hold_mm",))
    hold = HOLD_MM
    if "hold_mm" in opts:
        try:
            hold = float(opts["hold_mm"])
        except ValueError:
            hold = math.nan
        if not (math.isfinite(hold) and hold > 0):
            raise VolcalInputError(f"laser source {spec.text!r}: hold_mm={opts['hold_mm']!r}: "
                                   "expected a positive number [mm]")
    queue = context.extras.get(EXTRAS_KEY)
    if not isinstance(queue, TypedQueue):
        raise SourceError("laser source 'typed': the readings are typed on the capture's "
                          "page: add --serve (docs/capture_page.md)")
    return TypedLaser(queue, context, hold)


register_laser("typed", make, "readings typed by the technician on the page (needs --serve)")
