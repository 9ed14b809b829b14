"""Where the samples come from: the source protocols and the source registry.

A capture reads two sources, named on the command line as ``--control SOURCE`` and
``--laser SOURCE``. ``SOURCE`` is a registered name, optionally followed by ``:`` and an
argument the source reads itself:

=====================================  ========  =============================================
``SOURCE``                             for       what it reads
=====================================  ========  =============================================
``sim`` / ``sim:KEY=V,...``            control   the planned program, timed (acceleration, dwells)
                                                 on a simulated clock (:mod:`.simulated`)
``linuxcnc`` / ``linuxcnc:INI-or-NML`` control   LinuxCNC's status channel through a bridge run
                                                 by the system Python (:mod:`.linuxcnc_source`)
``opcua:opc.tcp://host:4840``          control   an OPC UA server with the OPC 40502 CNC model
                                                 (added by :mod:`volcal.capture.opcua`)
``sim`` / ``sim:KEY=V,...``            laser     volcal's virtual machine at the control's actual
                                                 position (:mod:`.simulated`)
``stream:tcp://host:port``             laser     lines from a TCP socket (:mod:`.stream`)
``stream:/dev/ttyUSB0``                laser     lines from a serial port
``stream:-``                           laser     lines piped to standard input
``file:PATH``                          laser     lines a vendor program appends to PATH
                                                 (:mod:`.filetail`)
``typed``                              laser     readings typed on the technician's page
                                                 (added by :mod:`volcal.capture.typed`)
=====================================  ========  =============================================

The stream and file sources take the parser's options after the address, separated by
``;`` (``stream:tcp://10.0.0.5:5000;format=regex;pattern=...``, see :mod:`.stream`).

A new source registers a factory with :func:`register_control` or
:func:`register_laser`; the names of the modules that register themselves when first asked
for are listed in :data:`LAZY_MODULES` (``opcua``, ``typed``), so adding a source is
adding a module, not editing the capture's logic.
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from volcal.capture.samples import ControlSample, LaserSample
from volcal.errors import VolcalInputError

if TYPE_CHECKING:
    from volcal.capture.plan import PlannedMeasurement

__all__ = [
    "LAZY_MODULES",
    "Clock",
    "ControlSource",
    "LaserSource",
    "SourceContext",
    "SourceError",
    "SourceSpec",
    "VirtualClock",
    "make_control",
    "make_laser",
    "parse_spec",
    "register_control",
    "register_laser",
    "registered",
]


class SourceError(VolcalInputError):
    """A source cannot be opened or stopped answering (disconnected, bridge died)."""


@runtime_checkable
class ControlSource(Protocol):
    """A control the capture polls for the axes' actual positions.

    ``open()`` connects (raising :class:`SourceError` with a clear message when it cannot);
    ``poll()`` returns the next sample not returned yet, or None when none is waiting (it
    never blocks for long: a source that reads a device does so in a thread of its own);
    ``close()`` releases the connection and may be called twice.
    """

    def open(self) -> None:
        """Connect."""

    def poll(self) -> ControlSample | None:
        """The next sample, or None when none is waiting."""

    def close(self) -> None:
        """Disconnect."""


@runtime_checkable
class LaserSource(Protocol):
    """A laser (or direct optic) the capture polls for readings; as :class:`ControlSource`."""

    def open(self) -> None:
        """Connect."""

    def poll(self) -> LaserSample | None:
        """The next sample, or None when none is waiting."""

    def close(self) -> None:
        """Disconnect."""


class Clock:
    """The capture's clock: wall time, monotonic [s] since the clock was made."""

    simulated = False

    def __init__(self) -> None:
        self._t0 = time.monotonic()

    def now(self) -> float:
        """Seconds since the clock was made."""
        return time.monotonic() - self._t0

    def sleep(self, seconds: float) -> None:
        """Wait.

        Parameters
        ----------
        seconds : float
            How long [s].
        """
        if seconds > 0:
            time.sleep(seconds)


class VirtualClock(Clock):
    """A simulated clock: ``sleep`` advances the time at once (or at ``speed`` x real time).

    Parameters
    ----------
    speed : float or None
        None: as fast as the computer runs; a number: that many simulated seconds per
        wall-clock second (1.0 = real time, for watching a simulated capture on the page).
    """

    simulated = True

    def __init__(self, speed: float | None = None) -> None:
        super().__init__()
        self._us = 0  # whole microseconds: the same times whatever the run's history
        self.speed = speed

    def now(self) -> float:
        """The simulated time [s]."""
        return self._us / 1e6

    def sleep(self, seconds: float) -> None:
        """Advance the simulated time (rounded to 1 us).

        Parameters
        ----------
        seconds : float
            How long [s].
        """
        if seconds > 0:
            if self.speed is not None:
                time.sleep(seconds / self.speed)
            self._us += round(seconds * 1e6)


def _nothing() -> None:
    return None


@dataclass
class SourceContext:
    """What a source factory may use besides its own argument.

    Attributes
    ----------
    clock : Clock
        The capture's clock; a source stamps its samples with ``clock.now()``.
    session : Any
        The session (:class:`volcal.session.format.Session`) being captured.
    measurements : list of PlannedMeasurement
        The planned measurements, in the order they are captured (targets, moves, dwells).
    latest_control : callable
        Returns the latest control sample the capture received (or None): a simulated
        laser reads the virtual machine at the control's actual position.
    current : callable
        Returns the id of the measurement being captured (or None between measurements).
    extras : dict
        Free room for sources and faces that need to share an object (the technician's
        page hands its queue of typed readings to the ``typed`` source here).
    """

    clock: Clock
    session: Any = None
    measurements: list[PlannedMeasurement] = field(default_factory=list)
    latest_control: Callable[[], ControlSample | None] = field(
        default_factory=lambda: _nothing)
    current: Callable[[], str | None] = field(default_factory=lambda: _nothing)
    extras: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class SourceSpec:
    """A parsed ``SOURCE``: its registered ``name`` and the ``argument`` after ``:``."""

    name: str
    argument: str
    text: str


ControlFactory = Callable[[SourceSpec, SourceContext], ControlSource]
LaserFactory = Callable[[SourceSpec, SourceContext], LaserSource]


@dataclass(frozen=True)
class _Entry:
    factory: Callable[[SourceSpec, SourceContext], Any]
    help: str
    simulated: bool


_CONTROLS: dict[str, _Entry] = {}
_LASERS: dict[str, _Entry] = {}

#: (kind, name) -> module that registers the source when imported: the sources built in
#: and those other modules add (a module not installed leaves its name unavailable).
LAZY_MODULES: dict[tuple[str, str], str] = {
    ("control", "sim"): "volcal.capture.simulated",
    ("laser", "sim"): "volcal.capture.simulated",
    ("control", "linuxcnc"): "volcal.capture.linuxcnc_source",
    ("laser", "stream"): "volcal.capture.stream",
    ("laser", "file"): "volcal.capture.filetail",
    ("control", "opcua"): "volcal.capture.opcua",
    ("laser", "typed"): "volcal.capture.typed",
}


def register_control(name: str, factory: ControlFactory, help: str,
                     simulated: bool = False) -> None:
    """Register a control source under ``name``.

    Parameters
    ----------
    name : str
        The ``SOURCE`` word (``'linuxcnc'``).
    factory : callable
        ``factory(spec, context) -> ControlSource``; it checks its argument and raises
        :class:`~volcal.errors.VolcalInputError` naming it; it does not connect yet.
    help : str
        One line for ``volcal capture --help`` and the error listing the sources.
    simulated : bool
        The source runs on a simulated clock (the capture then uses a
        :class:`VirtualClock` instead of the wall clock).
    """
    _CONTROLS[name] = _Entry(factory, help, simulated)


def register_laser(name: str, factory: LaserFactory, help: str) -> None:
    """Register a laser source under ``name``.

    Parameters
    ----------
    name : str
        The ``SOURCE`` word (``'stream'``).
    factory : callable
        ``factory(spec, context) -> LaserSource``; as :func:`register_control`'s.
    help : str
        One line for the error listing the sources.
    """
    _LASERS[name] = _Entry(factory, help, False)


def parse_spec(text: str, what: str) -> SourceSpec:
    """Split ``name[:argument]``.

    Parameters
    ----------
    text : str
        The ``SOURCE`` text.
    what : str
        ``'control'`` or ``'laser'`` (for the message).

    Returns
    -------
    SourceSpec
    """
    t = str(text).strip()
    if not t:
        raise VolcalInputError(f"empty {what} source: expected one of {_names(what)}")
    name, _, arg = t.partition(":")
    return SourceSpec(name.strip().lower(), arg.strip(), t)


def _table(what: str) -> dict[str, _Entry]:
    return _CONTROLS if what == "control" else _LASERS


def _names(what: str) -> str:
    names = set(_table(what)) | {n for k, n in LAZY_MODULES if k == what}
    return ", ".join(sorted(names))


def _entry(spec: SourceSpec, what: str) -> _Entry:
    table = _table(what)
    if spec.name not in table and (what, spec.name) in LAZY_MODULES:
        try:
            importlib.import_module(LAZY_MODULES[(what, spec.name)])
        except ModuleNotFoundError as e:
            raise VolcalInputError(f"{what} source {spec.text!r}: not available in this "
                                   f"installation ({e.name} is missing)") from None
    if spec.name not in table:
        raise VolcalInputError(f"unknown {what} source {spec.text!r}: expected one of "
                               f"{_names(what)} (docs/capture.md)")
    return table[spec.name]


def is_simulated_control(text: str) -> bool:
    """Whether the control source ``text`` runs on a simulated clock.

    Parameters
    ----------
    text : str
        ``SOURCE`` as on the command line.

    Returns
    -------
    bool
    """
    return _entry(parse_spec(text, "control"), "control").simulated


def make_control(text: str, context: SourceContext) -> ControlSource:
    """The control source of ``text`` (not opened yet).

    Parameters
    ----------
    text : str
        ``SOURCE`` as on the command line (``'sim'``, ``'linuxcnc'``, ``'opcua:...'``).
    context : SourceContext

    Returns
    -------
    ControlSource
    """
    spec = parse_spec(text, "control")
    src: ControlSource = _entry(spec, "control").factory(spec, context)
    return src


def make_laser(text: str, context: SourceContext) -> LaserSource:
    """The laser source of ``text`` (not opened yet).

    Parameters
    ----------
    text : str
        ``SOURCE`` as on the command line (``'sim'``, ``'stream:-'``, ``'typed'``...).
    context : SourceContext

    Returns
    -------
    LaserSource
    """
    spec = parse_spec(text, "laser")
    src: LaserSource = _entry(spec, "laser").factory(spec, context)
    return src


def registered(what: str) -> dict[str, str]:
    """The sources registered so far and their help.

    Parameters
    ----------
    what : str
        ``'control'`` or ``'laser'``.

    Returns
    -------
    dict of str to str
    """
    return {k: v.help for k, v in sorted(_table(what).items())}


def options(argument: str, where: str, allowed: tuple[str, ...]) -> dict[str, str]:
    """Parse ``KEY=V,KEY=V`` (or ``;``-separated) options of a source argument.

    Parameters
    ----------
    argument : str
        The text after ``name:``.
    where : str
        The source as written (for the message).
    allowed : tuple of str
        The keys the source reads.

    Returns
    -------
    dict of str to str
    """
    out: dict[str, str] = {}
    if not argument:
        return out
    sep = ";" if ";" in argument else ","
    for part in argument.split(sep):
        if not part.strip():
            continue
        k, eq, v = part.partition("=")
        k = k.strip().lower()
        if not eq or k not in allowed:
            raise VolcalInputError(f"source {where!r}: {part.strip()!r} is not KEY=VALUE with "
                                   f"KEY one of {', '.join(allowed)}")
        out[k] = v.strip()
    return out
