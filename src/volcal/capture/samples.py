"""The samples a capture reads: control positions and laser readings.

Both carry the time at which the capture received them, in seconds of the capture's
clock (:class:`volcal.capture.sources.Clock`), so that the trigger rule compares the two
signals on one time base; a source's own timestamp, when it gives one, is kept beside it
(``device_time_s``) for the journal.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from volcal.errors import VolcalInputError

__all__ = ["ANGULAR_UNITS", "LINEAR_UNITS", "CaptureEvent", "ControlSample", "LaserSample",
           "to_base_unit"]

LINEAR_UNITS: dict[str, float] = {"um": 1.0, "µm": 1.0, "mm": 1e3, "nm": 1e-3, "m": 1e6,
                                  "in": 25400.0, "inch": 25400.0, "uin": 0.0254}
"""Factor of each linear unit to micrometres."""
ANGULAR_UNITS: dict[str, float] = {"urad": 1.0, "µrad": 1.0, "mrad": 1e3, "rad": 1e6,
                                   "arcsec": math.pi / 648000.0 * 1e6,
                                   "deg": math.pi / 180.0 * 1e6}
"""Factor of each angular unit to microradians."""

STATUS_OK = "ok"
"""Status of a sample read normally."""


@dataclass(frozen=True)
class ControlSample:
    """One reading of the control's status.

    Attributes
    ----------
    time_s : float
        Time at which the capture received it [s], on the capture's clock.
    positions : mapping of str to float
        Actual position of each axis by its letter (``'X'``, ``'Y'``, ``'Z'`` [mm];
        ``'A'``, ``'B'``, ``'C'`` [deg]), in the coordinates of the plan (the program's
        work offset, G54 = the plan's origin).
    in_motion : bool or None
        The control says the axes move (LinuxCNC: ``current_vel`` > 0 or not ``inpos``);
        None where the source does not know.
    program_running : bool or None
        A part program is being executed and not paused (LinuxCNC: ``interp_state`` not
        idle and not paused; an ``M0`` stop reads False); None where unknown.
    status : str
        ``'ok'``, or a short word of the source (``'stale'``, ``'ended'``: the program of a
        simulated control has ended, ``'error: ...'``).
    line : int or None
        Program line being executed, where known (journal only).
    device_time_s : float or None
        The source's own timestamp [s], where it gives one (journal only).
    """

    time_s: float
    positions: Mapping[str, float]
    in_motion: bool | None = None
    program_running: bool | None = None
    status: str = STATUS_OK
    line: int | None = None
    device_time_s: float | None = None

    def to_json(self) -> dict[str, Any]:
        """The sample as a JSON object (journal line)."""
        d: dict[str, Any] = {"t": self.time_s, "pos": dict(self.positions)}
        for key, v in (("moving", self.in_motion), ("running", self.program_running),
                       ("line", self.line), ("device_t", self.device_time_s)):
            if v is not None:
                d[key] = v
        if self.status != STATUS_OK:
            d["status"] = self.status
        return d


@dataclass(frozen=True)
class LaserSample:
    """One reading of the laser (or of a direct optic).

    Attributes
    ----------
    time_s : float
        Time at which the capture received it [s], on the capture's clock.
    value : float
        The reading in ``unit``: the displacement of the target along the beam since the
        laser was zeroed (linear, diagonal and step-diagonal tests), or the optic's own
        reading (straightness [um], angle [urad]).
    unit : str
        ``'um'`` (also ``'mm'``, ``'nm'``, ``'in'``...) or ``'urad'`` (also ``'arcsec'``,
        ``'mrad'``...); :func:`to_base_unit` converts.
    status : str
        ``'ok'`` or a short word of the source (``'beam'``: the laser reports a broken
        beam; such a sample is never used).
    device_time_s : float or None
        The laser's own timestamp [s], where it gives one (journal only).
    extra : mapping
        Further fields a parser found (air temperature...), journal only.
    channels : tuple of float
        A reading of several channels (an R-test nest's three sensors, in ``unit``): every
        channel's value, ``value`` the first; empty for a laser of one channel.
    """

    time_s: float
    value: float
    unit: str = "um"
    status: str = STATUS_OK
    device_time_s: float | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)
    channels: tuple[float, ...] = ()

    @property
    def values(self) -> tuple[float, ...]:
        """Every channel's value (one for a laser) [``unit``]."""
        return self.channels or (self.value,)

    def to_json(self) -> dict[str, Any]:
        """The sample as a JSON object (journal line)."""
        d: dict[str, Any] = {"t": self.time_s, "v": self.value, "unit": self.unit}
        if self.status != STATUS_OK:
            d["status"] = self.status
        if self.device_time_s is not None:
            d["device_t"] = self.device_time_s
        if self.extra:
            d["extra"] = dict(self.extra)
        if self.channels:
            d["ch"] = list(self.channels)
        return d


def to_base_unit(value: float, unit: str) -> tuple[float, str]:
    """A reading in volcal's unit: micrometres or microradians.

    Parameters
    ----------
    value : float
        The reading in ``unit``.
    unit : str
        A key of :data:`LINEAR_UNITS` or :data:`ANGULAR_UNITS` (case-insensitive).

    Returns
    -------
    value : float
        The reading [um] or [urad].
    base : str
        ``'um'`` or ``'urad'``.

    Raises
    ------
    VolcalInputError
        An unknown unit (the message lists the known ones).
    """
    u = unit.strip()
    key = u if u in LINEAR_UNITS or u in ANGULAR_UNITS else u.lower()
    if key in LINEAR_UNITS:
        return value * LINEAR_UNITS[key], "um"
    if key in ANGULAR_UNITS:
        return value * ANGULAR_UNITS[key], "urad"
    raise VolcalInputError(f"unknown laser unit {unit!r}: expected one of "
                           f"{', '.join(sorted(set(LINEAR_UNITS) | set(ANGULAR_UNITS)))}")


@dataclass(frozen=True)
class CaptureEvent:
    """What a running capture tells an observer (the technician's page, the command line).

    Attributes
    ----------
    kind : str
        ``'start'`` (a measurement's capture begins: ``data`` has ``readings``, the planned
        ``targets`` [[x, y, z] mm], or [[angle] deg] of a rotary test, ``axes`` (their
        letters), ``axes_unit`` (``'mm'`` or ``'deg'``), ``directions``, ``runs``, ``done``
        (readings already recorded), ``column``, ``unit``), ``'control'`` / ``'laser'`` (a
        sample: ``data`` is its JSON form), ``'accepted'`` (``reading``, ``value`` of the
        CSV column, ``raw`` laser value, ``sigma``, ``pos``...), ``'missed'`` (``reading``,
        ``reason``), ``'replayed'``, ``'note'`` (``text``), ``'stale'`` (``source``:
        ``'control'`` or ``'laser'``, ``silent_s``: a source stopped sending), ``'fresh'``
        (it sends again), ``'end'`` (``reason``, ``complete``).
    measurement : str or None
        The measurement's id.
    time_s : float
        The capture clock [s].
    data : mapping
        As listed for ``kind``.
    """

    kind: str
    measurement: str | None
    time_s: float
    data: Mapping[str, Any] = field(default_factory=dict)
