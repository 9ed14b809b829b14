"""The OPC UA control source: ``--control opcua:opc.tcp://host:4840[;KEY=V...]``.

The control's axes are found by type (``CncAxisType`` of OPC 40502, the CNC information
model), their positions read from ``PosDirect/ActPos`` (or ``PosIndirect/ActPos``) through
a subscription (:mod:`volcal.capture.opcua_link`). A subscription notifies only on change,
so while the machine dwells the server is silent: :meth:`OpcUaControl.poll` reports the last
value of each axis at every poll, stamped with the time of the poll, and the trigger rule
sees a control at rest, exactly as a polled LinuxCNC status would show it; nothing depends
on how many notifications arrived. A lost connection is a sample with status
``'lost: <reason>'`` and no position (never the last position: a lost control must not look
like a dwell); the link connects again by itself and the samples resume.

A rotary axis (``IsRotational`` true, or its position in degrees or radians) is reported
in degrees under its browse name (``C``), as the server gives it (0..360 or counting on:
the capture follows either). When the capture opens the source, each measurement's axes
are checked against the server's: a rotary test of an axis the server does not report,
or reports as linear, is refused, naming ``--control`` and the axes found
(:class:`ControlAxesError`).

Options after the URL, separated by ``;``:

=================  =======  ===============================================================
key                default  meaning
=================  =======  ===============================================================
``position``       direct   ``direct`` (``PosDirect``: the scale) or ``indirect``
                            (``PosIndirect``: the motor encoder)
``publishing_ms``  50       publishing and sampling interval of the subscription [ms]
``timeout_s``      4        timeout of one request, and of the first connection [s]
``watch_s``        0.5      interval of the liveness check (a read of the server state) [s]
``policy``         -        a signed channel: ``Basic256Sha256``, ``Aes128_Sha256_RsaOaep``
                            or ``Aes256_Sha256_RsaPss`` (default: message security None)
``mode``           SignAnd  ``Sign`` or ``SignAndEncrypt``
                   Encrypt
``cert``, ``key``  -        volcal's application certificate (DER or PEM) and its private
                            key (PEM), required with ``policy``
``server_cert``    -        the server's certificate (DER or PEM); without it the endpoints
                            are asked over an unsecured channel first
``axes``           -        volcal's axis letter and the server's axis name, ``LETTER:NAME``
                            separated by ``/`` (``X:X1/Y:Y1/Z:Z1/C:C1``): a control whose
                            axes are not named by their letters; an axis not listed is
                            read under its own name
``program``        on       ``on``: the channel's ``ActProgramStatus`` says whether the
                            program runs (:data:`PROGRAM_RUNNING`); ``off``: not read (a
                            server that does not keep it up to date)
``channel``        -        the browse name of the channel that runs the measurement's
                            program (a control of several channels; default: the only one)
=================  =======  ===============================================================

Where the server has one ``CncChannelType`` object, its ``ActProgramStatus`` (OPC 40502,
7.2.5) gives the samples' ``program_running``: Running true; Stopped, Interrupted (an
``M0``, a feed hold) and Canceled false, so that no reading is taken while the program
stands at an operator stop (an R-test's first pose, where the sensors are zeroed);
Waiting unknown. Without a channel, or with several and none named by ``channel=``, it
stays unknown (None), as before; a ``channel=`` the server lacks is refused at the
connection, naming the channels it has.

Requires the ``capture`` extra (PyPI ``asyncua``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from volcal.capture.samples import ControlSample
from volcal.capture.sources import (
    SourceContext,
    SourceError,
    SourceSpec,
    options,
    register_control,
)
from volcal.errors import ParameterError, VolcalInputError
from volcal.extras import require_extra

if TYPE_CHECKING:
    from volcal.capture.opcua_link import AxisNode, Security
    from volcal.capture.plan import PlannedMeasurement

__all__ = ["ControlAxesError", "OpcUaControl", "STATUS_LOST", "check_axes", "make"]

STATUS_LOST = "lost"
"""First word of the status of a sample taken while the connection is down."""

OPTION_KEYS = ("position", "publishing_ms", "timeout_s", "watch_s", "policy", "mode", "cert",
               "key", "server_cert", "axes", "program", "channel")

PROGRAM_RUNNING = {0: False, 1: True, 2: None, 3: False, 4: False}
"""``ActProgramStatus`` (``CncChannelProgramStatus``, OPC 40502 7.2.5: Stopped 0, Running
1, Waiting 2, Interrupted 3, Canceled 4) -> the samples' ``program_running`` (a value not
listed: None)."""

AXIS_LETTERS = "XYZABC"
"""The axis letters of volcal's plans (ISO 841), the left side of ``axes=``."""


class ControlAxesError(SourceError, ParameterError):
    """The control does not report an axis a measurement reads, or of the other kind.

    A rotary test's axis reported as linear, or a linear axis as rotary. The message names
    the ``control`` parameter (``--control`` on the command line).
    """


MIN_INTERVAL_S = 0.005
"""A poll within this time [s] of the last sample returns None: the capture's loop drains
each source until None, and a held value is one sample per poll, not an endless stream."""


class OpcUaControl:
    """A CNC control read over OPC UA (OPC 40502 ``CncAxisType``).

    Parameters
    ----------
    url : str
        ``opc.tcp://host:port[/path]``.
    context : SourceContext
        The capture's clock stamps the samples.
    position : {'direct', 'indirect'}
        ``PosDirect`` or ``PosIndirect``.
    publishing_ms : float
        Publishing interval of the subscription [ms].
    timeout_s : float
        Timeout of one request and of the first connection [s].
    watch_s : float
        Interval of the liveness check [s].
    security : Security, optional
        A signed channel (:class:`volcal.capture.opcua_link.Security`).
    source : str, optional
        The source as the user gave it (``opcua:URL;KEY=V``), for messages (default:
        ``opcua:URL``).
    names : dict of str to str, optional
        The server's axis name -> volcal's letter (``axes=``): the axis is reported under
        the letter, and a server axis named as one of these letters is left out.
    program : bool
        Report the channel's program status (``program=on``, default) or not (``off``).
    channel : str, optional
        The channel whose status is read (``channel=``; default the only one).
    """

    def __init__(self, url: str, context: SourceContext, *, position: str = "direct",
                 publishing_ms: float = 50.0, timeout_s: float = 4.0,
                 watch_s: float = 0.5, security: Security | None = None,
                 source: str | None = None, names: dict[str, str] | None = None,
                 program: bool = True, channel: str | None = None) -> None:
        from volcal.capture.opcua_link import OpcUaLink

        self.names = dict(names or {})
        self.program = program
        self.url = url
        self.source = source or f"opcua:{url}"
        self.context = context
        self.timeout_s = timeout_s
        self.link = OpcUaLink(url, position=position, publishing_ms=publishing_ms,
                              timeout_s=timeout_s, watch_s=watch_s, security=security,
                              channel=channel if program else None, program=program)
        self._last_t: float | None = None

    def open(self) -> None:
        """Connect, find the axes and subscribe.

        Raises
        ------
        SourceError
            No answer within ``timeout_s`` (plus the browse), or the server has no CNC axes.
        """
        from volcal.capture.opcua_link import OpcUaError

        try:
            self.link.start(wait_s=self.timeout_s * 2.0 + 2.0)
        except OpcUaError as e:
            raise SourceError(f"control source opcua:{self.url}: {e}") from None
        snap = self.link.snapshot()
        if not snap.connected:
            self.link.close()
            raise SourceError(f"control source opcua:{self.url}: cannot connect "
                              f"({snap.reason or 'no answer'})")
        try:
            check_axes(self._renamed(snap.axes), self.context.measurements, self.source)
        except ControlAxesError:
            self.link.close()
            raise

    def _renamed(self, axes: list[AxisNode]) -> list[AxisNode]:
        """The server's axes under volcal's letters (``axes=``).

        A mapped name the server does not have is refused, naming the axes it has.
        """
        from dataclasses import replace

        have = {a.name for a in axes}
        lost = [f"{letter}:{name}" for name, letter in self.names.items() if name not in have]
        if lost:
            raise ControlAxesError(
                f"{{control=}}{self.source}: axes={'/'.join(lost)}: the server reports no "
                f"CncAxisType object of that name; the server's axes: "
                f"{', '.join(f'{a.name} ({a.kind})' for a in axes) or 'none'} "
                "(docs/capture_opcua.md)")
        return [replace(a, name=self.names.get(a.name, a.name)) for a in axes
                if a.name not in self._shadowed]

    @property
    def _shadowed(self) -> set[str]:
        """Server axes named as a letter ``axes=`` gives to another axis: left out."""
        return set(self.names.values()) - set(self.names)

    def poll(self) -> ControlSample | None:
        """The last position of every axis, at the time of this poll.

        Returns
        -------
        ControlSample or None
            ``status`` ``'ok'`` with the positions [mm; a rotary axis' in deg] while
            connected; ``'lost: ...'`` with no position while the connection is down;
            None when the last sample is less than :data:`MIN_INTERVAL_S` old (the loop
            asks again at once).
        """
        now = self.context.clock.now()
        if self._last_t is not None and now - self._last_t < MIN_INTERVAL_S:
            return None
        self._last_t = now
        snap = self.link.snapshot()
        if not snap.connected:
            return ControlSample(time_s=now, positions={},
                                 status=f"{STATUS_LOST}: {snap.reason or snap.status}")
        running = (PROGRAM_RUNNING.get(snap.program_status)
                   if self.program and snap.program_status is not None else None)
        if not self.names:
            return ControlSample(time_s=now, positions=snap.positions,
                                 program_running=running)
        return ControlSample(time_s=now, positions={
            self.names.get(n, n): v for n, v in snap.positions.items()
            if n not in self._shadowed}, program_running=running)

    def close(self) -> None:
        """Disconnect (may be called twice)."""
        self.link.close()

    @property
    def axes(self) -> list[str]:
        """The names of the axes found (after :meth:`open`).

        volcal's letters for the axes ``axes=`` renames.
        """
        return [a.name for a in self._renamed(self.link.snapshot().axes)]


def check_axes(axes: list[AxisNode], measurements: list[PlannedMeasurement],
               source: str) -> None:
    """Refuse a control that lacks an axis of the measurements, or has it of the other kind.

    Parameters
    ----------
    axes : list of AxisNode
        The server's axes (name, rotary or linear).
    measurements : list of PlannedMeasurement
        The measurements to capture; each reads the axes of its frame (X, Y, Z [mm], or
        one rotary axis [deg]).
    source : str
        The control source as given (``opcua:opc.tcp://...``), for the message.

    Raises
    ------
    ControlAxesError
        Naming the measurement, the axis, the axes found and ``--control``.
    """
    found = {a.name: a for a in axes}
    listed = ", ".join(f"{a.name} ({a.kind})" for a in axes) or "none"
    for pm in measurements:
        frame = pm.frame
        units = frame.units or (frame.unit,) * len(frame.axes)  # an R-test: mm and deg
        for name, unit in zip(frame.axes, units, strict=True):
            rotary = unit == "deg"
            want = "rotary [deg]" if rotary else "linear [mm]"
            verb = "turns" if rotary else "moves"
            got = found.get(name)
            if got is None:
                why = "the server reports no such CncAxisType object"
            elif got.rotary != rotary:
                why = (f"the server's axis {name} is {got.kind} (IsRotational, "
                       f"EngineeringUnits {got.unit or 'none'})")
            else:
                continue
            raise ControlAxesError(
                f"{{control=}}{source}: measurement {pm.id} {verb} axis {name} "
                f"({want}), but {why}; the server's axes: {listed}. Give a control that "
                f"reports {name}, or name the server's axis: axes={name}:NAME "
                "(docs/capture_opcua.md)")


def make(spec: SourceSpec, context: SourceContext) -> OpcUaControl:
    """The factory registered as ``opcua``: parse ``URL[;KEY=V...]``.

    Parameters
    ----------
    spec : SourceSpec
        ``argument`` is the URL and its options.
    context : SourceContext
        The capture's context.

    Returns
    -------
    OpcUaControl
        Not connected yet.
    """
    require_extra("capture", f"control source {spec.text!r}", ("asyncua",))
    url, _, rest = spec.argument.partition(";")
    url = url.strip()
    if not url.startswith("opc.tcp://") or len(url) <= len("opc.tcp://"):
        raise VolcalInputError(f"control source {spec.text!r}: expected "
                               "opcua:opc.tcp://HOST:PORT (docs/capture_opcua.md)")
    opts = options(rest, spec.text, OPTION_KEYS)
    kw: dict[str, float] = {}
    for key in ("publishing_ms", "timeout_s", "watch_s"):
        if key in opts:
            try:
                kw[key] = float(opts[key])
            except ValueError:
                raise VolcalInputError(f"control source {spec.text!r}: {key}={opts[key]!r}: "
                                       "expected a number") from None
            if not kw[key] > 0:
                raise VolcalInputError(f"control source {spec.text!r}: {key}={opts[key]}: "
                                       "expected a positive number")
    position = opts.get("position", "direct").lower()
    if position not in ("direct", "indirect"):
        raise VolcalInputError(f"control source {spec.text!r}: position={position!r}: "
                               "expected direct or indirect")
    security = None
    if any(k in opts for k in ("policy", "cert", "key", "server_cert")):
        security = _security(opts, spec.text)
    elif "mode" in opts:
        raise VolcalInputError(f"control source {spec.text!r}: mode= needs policy=, cert= "
                               "and key= (docs/capture_opcua.md)")
    program = opts.get("program", "on").lower()
    if program not in ("on", "off"):
        raise VolcalInputError(f"control source {spec.text!r}: program={program!r}: "
                               "expected on or off")
    channel = opts.get("channel")
    if channel is not None and (not channel.strip() or program == "off"):
        raise VolcalInputError(f"control source {spec.text!r}: channel={channel!r}: "
                               + ("expected the channel's browse name" if not channel.strip()
                                  else "names the channel whose status program=off ignores"))
    return OpcUaControl(url, context, position=position, security=security,
                        source=spec.text, names=_axis_names(opts.get("axes"), spec.text),
                        program=program == "on",
                        channel=None if channel is None else channel.strip(), **kw)


def _axis_names(text: str | None, where: str) -> dict[str, str]:
    """``axes=X:X1/C:C1`` as server name -> letter, each letter and name once."""
    if text is None:
        return {}
    out: dict[str, str] = {}
    for part in text.split("/"):
        letter, colon, name = (v.strip() for v in part.partition(":"))
        letter = letter.upper()
        if not colon or len(letter) != 1 or letter not in AXIS_LETTERS or not name:
            raise VolcalInputError(f"control source {where!r}: axes={text!r}: {part!r} is not "
                                   f"LETTER:NAME with LETTER one of {', '.join(AXIS_LETTERS)} "
                                   "(axes=X:X1/Y:Y1/Z:Z1/C:C1)")
        if letter in out.values() or name in out:
            raise VolcalInputError(f"control source {where!r}: axes={text!r}: "
                                   f"{letter if letter in out.values() else name} given twice")
        out[name] = letter
    return out


def _security(opts: dict[str, str], where: str) -> Security:
    """The signed channel of the options ``policy``, ``mode``, ``cert``, ``key``."""
    from pathlib import Path

    from volcal.capture.opcua_link import MODES, POLICIES, Security

    missing = [k for k in ("policy", "cert", "key") if not opts.get(k)]
    if missing:
        raise VolcalInputError(f"control source {where!r}: a signed channel needs "
                               f"{', '.join(k + '=' for k in missing)} (docs/capture_opcua.md)")
    if opts["policy"] not in POLICIES:
        raise VolcalInputError(f"control source {where!r}: policy={opts['policy']!r}: "
                               f"expected one of {', '.join(POLICIES)}")
    mode = opts.get("mode", "SignAndEncrypt")
    if mode not in MODES:
        raise VolcalInputError(f"control source {where!r}: mode={mode!r}: expected "
                               f"{' or '.join(MODES)}")
    for k in ("cert", "key", "server_cert"):
        if k in opts and not Path(opts[k]).is_file():
            raise VolcalInputError(f"control source {where!r}: {k}={opts[k]}: no such file")
    return Security(opts["policy"], mode, opts["cert"], opts["key"], opts.get("server_cert"))


register_control("opcua", make, "an OPC UA server with the OPC 40502 CNC model "
                 "(opcua:opc.tcp://HOST:4840)")
