"""The OPC UA connection to a CNC control (OPC 40502 CNC information model).

A background thread runs an asyncio loop with an :mod:`asyncua` client. It browses the
server's ``Objects`` folder for objects whose type is ``CncAxisType`` (or a subtype) of the
namespace ``http://opcfoundation.org/UA/CNC``, subscribes to each axis' ``PosDirect/ActPos``
(or ``PosIndirect/ActPos``), keeps the last value of each and watches the connection by
reading the server's state every ``watch_s`` seconds. Where the server has exactly one
object of type ``CncChannelType``, the channel's ``ActProgramStatus`` is subscribed to as
well (whether its program runs, or stands interrupted at an ``M0`` or a feed hold).

A linear axis' position is kept in mm, a rotary axis' in degrees, under the axis' browse
name (``X``, ``C``). An axis is rotary when its ``IsRotational`` is true or its position's
``EngineeringUnits`` is an angle (UNECE ``DD`` degree, ``C81`` radian: converted to
degrees); the angle is passed on as the server reports it, wrapped (0..360) or counting on
(:func:`axis_scale`).

A subscription notifies only on change: while the machine dwells at a target, the server
sends nothing. :meth:`OpcUaLink.snapshot` therefore answers from the values kept, never from a
count of notifications; the caller stamps them with the time of its poll. When the
connection is lost, the snapshot says so (``connected`` false, the reason and the time) and
holds no position, so a lost control never looks like a dwell; the thread connects again
every ``retry_s`` seconds, browses again and subscribes again.

References
----------
OPC Foundation, OPC 40502 "OPC UA for Computerized Numerical Control (CNC) Systems" 1.00
(2017): section 6.6.2 ``CncChannelType`` (``ActProgramStatus``, mandatory), 7.2.5
``CncChannelProgramStatus`` (Stopped 0, Running 1, Waiting 2, Interrupted 3, Canceled 4),
6.8.2 ``CncAxisType`` (``IsRotational``: true for a rotational axis),
7.3.2 ``CncPositionVariableType`` (``ActPos``, ``CmdPos``, ``RemDist``, its
``EngineeringUnits``). The nodeset file is ``Opc.Ua.CNC.NodeSet.xml``. UN/CEFACT
Recommendation 20, the codes of ``EUInformation.UnitId`` (OPC 10000-8, 5.6.3).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError

CNC_NAMESPACES = ("http://opcfoundation.org/UA/CNC", "http://opcfoundation.org/UA/CNC/")
"""The namespace URI of OPC 40502 (the nodeset spells it without the final slash)."""

CNC_AXIS_TYPE_ID = 1004
"""Numeric node id of ``CncAxisType`` in the CNC namespace (``Opc.Ua.CNC.NodeSet.xml``)."""

CNC_CHANNEL_TYPE_ID = 1002
"""Numeric node id of ``CncChannelType`` (its ``ActProgramStatus``: OPC 40502, 6.6.2)."""

POLICIES = ("Basic256Sha256", "Aes128_Sha256_RsaOaep", "Aes256_Sha256_RsaPss")
"""Security policies of a signed channel (OPC UA's current ones; the deprecated Basic128Rsa15
and Basic256 are left out)."""

MODES = ("Sign", "SignAndEncrypt")
"""Message security modes of a signed channel."""


@dataclass(frozen=True)
class Security:
    """A signed (and encrypted) channel: the policy, the mode and volcal's certificate.

    Attributes
    ----------
    policy : str
        One of :data:`POLICIES`.
    mode : str
        ``'Sign'`` or ``'SignAndEncrypt'``.
    cert : str
        volcal's application certificate (DER or PEM); its URI (subject alternative name)
        becomes the client's application URI, as servers check.
    key : str
        Its private key (PEM).
    server_cert : str, optional
        The server's certificate (DER or PEM). Without it the client asks the server for
        its endpoints over an unsecured channel first, which a server offering only
        secured channels refuses.
    """

    policy: str
    mode: str
    cert: str
    key: str
    server_cert: str | None = None


POSITION_NODES = {"direct": "PosDirect", "indirect": "PosIndirect"}
"""Which position of ``CncAxisType`` to read: the direct measuring system (a scale on the
axis) or the indirect one (the motor encoder)."""

MAX_BROWSE_NODES = 20000
"""Browsing stops after this many objects (a large server is not browsed without end)."""

MAX_BROWSE_DEPTH = 8
"""Browsing goes at most this many references deep below ``Objects``."""


class OpcUaError(VolcalInputError):
    """The OPC UA server cannot be used as a control source (no CNC axes, bad URL...)."""


@dataclass(frozen=True)
class AxisNode:
    """One CNC axis found on the server.

    Attributes
    ----------
    name : str
        Its browse name (``X``).
    node_id : str
        The axis object's node id.
    value_id : str
        The node id of the ``ActPos`` variable subscribed to.
    factor : float
        Millimetres (a rotary axis: degrees) per unit of the server's value, from the
        position's ``EngineeringUnits`` (1 when it has none: the model's mm, or deg).
    rotary : bool
        A rotary axis (``IsRotational`` true, or its position in an angle): its position
        is in degrees.
    unit : str
        What the server says of the unit, for messages (``'DD'``, ``'mm'``; empty when
        the position has no ``EngineeringUnits``).
    """

    name: str
    node_id: str
    value_id: str
    factor: float = 1.0
    rotary: bool = False
    unit: str = ""

    @property
    def kind(self) -> str:
        """``'rotary [deg]'`` or ``'linear [mm]'``, for messages."""
        return "rotary [deg]" if self.rotary else "linear [mm]"


@dataclass
class Snapshot:
    """What the link knows at one instant.

    Attributes
    ----------
    connected : bool
        The connection is up and subscribed.
    positions : dict of str to float
        Last ``ActPos`` per axis name [mm; a rotary axis' in deg] (empty while not
        connected).
    changed_at : float
        ``time.time()`` when a position last changed [s] (0 before the first value).
    notifications : int
        Count of data-change notifications received (for diagnostics only).
    status : str
        ``'connecting'``, ``'connected'`` or ``'lost'``.
    reason : str
        Why the link is not connected (empty when connected).
    since : float
        ``time.time()`` of the last change of ``status`` [s].
    axes : list of AxisNode
        The axes subscribed to.
    program_status : int or None
        The channel's last ``ActProgramStatus`` (``CncChannelProgramStatus``, OPC 40502
        7.2.5: :data:`volcal.capture.opcua.PROGRAM_RUNNING`); None when the server has no
        single channel or has not sent it.
    """

    connected: bool = False
    positions: dict[str, float] = field(default_factory=dict)
    changed_at: float = 0.0
    notifications: int = 0
    status: str = "connecting"
    reason: str = ""
    since: float = 0.0
    axes: list[AxisNode] = field(default_factory=list)
    program_status: int | None = None


class _Handler:
    """asyncua subscription handler: stores each notified value under the link's lock."""

    def __init__(self, link: OpcUaLink, axes: list[AxisNode],
                 status_id: str | None = None) -> None:
        self.link = link
        self.axes = {a.value_id: a for a in axes}  # node id string -> axis
        self.status_id = status_id

    def datachange_notification(self, node: Any, val: Any, data: Any) -> None:
        key = node.nodeid.to_string()
        if key == self.status_id:
            self.link._store_status(val)
            return
        axis = self.axes.get(key)
        if axis is None or val is None:
            return
        self.link._store(axis.name, float(val) * axis.factor)

    def status_change_notification(self, status: Any) -> None:
        self.link._lost(f"subscription status {status}")


class OpcUaLink:
    """A connection to an OPC UA CNC server kept by a background thread.

    Parameters
    ----------
    url : str
        ``opc.tcp://host:port[/path]``.
    position : {'direct', 'indirect'}
        ``PosDirect`` (the scale) or ``PosIndirect`` (the motor encoder).
    publishing_ms : float
        Publishing interval of the subscription [ms]; also its sampling interval.
    timeout_s : float
        Timeout of one request [s].
    watch_s : float
        Interval of the liveness check (a read of the server state) [s].
    retry_s : float
        Delay before connecting again after a loss [s].
    security : Security, optional
        A signed channel (default: message security None).
    channel : str, optional
        Browse name of the ``CncChannelType`` object whose ``ActProgramStatus`` is read
        (a control of several channels); default: the server's only channel, if it has
        exactly one.
    program : bool
        Read the channel's ``ActProgramStatus`` at all (False: the channels are not looked
        for; a status that cannot be read is left unknown either way, never a lost
        connection).
    """

    def __init__(self, url: str, *, position: str = "direct", publishing_ms: float = 50.0,
                 timeout_s: float = 4.0, watch_s: float = 0.5, retry_s: float = 1.0,
                 security: Security | None = None, channel: str | None = None,
                 program: bool = True) -> None:
        if not url.startswith("opc.tcp://"):
            raise OpcUaError(f"OPC UA source {url!r}: expected opc.tcp://host:port")
        if position not in POSITION_NODES:
            raise OpcUaError(f"OPC UA source {url!r}: position {position!r}: expected "
                             f"{' or '.join(POSITION_NODES)}")
        self.url = url
        self.position = position
        self.publishing_ms = float(publishing_ms)
        self.timeout_s = float(timeout_s)
        self.watch_s = float(watch_s)
        self.retry_s = float(retry_s)
        self.security = security
        self.channel = channel
        self.program = program
        self._lock = threading.Lock()
        self._snap = Snapshot(since=time.time())
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._stop: asyncio.Event | None = None
        self._first = threading.Event()
        self._fatal: Exception | None = None

    # -- the caller's side ------------------------------------------------------------
    def start(self, wait_s: float = 10.0) -> None:
        """Start the thread; wait until connected or ``wait_s`` passed.

        Parameters
        ----------
        wait_s : float
            Longest wait for the first connection [s] (the thread goes on trying after).

        Raises
        ------
        OpcUaError
            The server answered but exposes no usable CNC axis (a configuration error,
            not a lost connection).
        """
        if self._thread is not None:
            return
        log = logging.getLogger("asyncua")
        if log.level == logging.NOTSET:  # its warnings (revised intervals) and the errors of
            log.setLevel(logging.CRITICAL)  # a refused channel would reach the terminal: the
            # snapshot's status says why; a level set by the caller wins
        self._thread = threading.Thread(target=self._run, name="volcal-opcua", daemon=True)
        self._thread.start()
        self._first.wait(wait_s)
        if self._fatal is not None:
            self.close()
            raise OpcUaError(str(self._fatal)) from self._fatal

    def snapshot(self) -> Snapshot:
        """A copy of what the link knows now (thread-safe)."""
        with self._lock:
            s = self._snap
            return Snapshot(connected=s.connected,
                            positions=dict(s.positions) if s.connected else {},
                            changed_at=s.changed_at, notifications=s.notifications,
                            status=s.status, reason=s.reason, since=s.since,
                            axes=list(s.axes),
                            program_status=s.program_status if s.connected else None)

    def close(self) -> None:
        """Stop the thread and disconnect."""
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and loop.is_running():
            loop.call_soon_threadsafe(stop.set)
        if self._thread is not None:
            self._thread.join(timeout=self.timeout_s + 2.0)
        self._thread = None

    # -- called from the loop thread -------------------------------------------------
    def _store(self, name: str, value: float) -> None:
        with self._lock:
            s = self._snap
            if s.positions.get(name) != value:
                s.changed_at = time.time()
            s.positions[name] = value
            s.notifications += 1

    def _store_status(self, value: Any) -> None:
        with self._lock:
            try:
                self._snap.program_status = None if value is None else int(value)
            except (TypeError, ValueError):
                self._snap.program_status = None

    def _set_status(self, status: str, reason: str = "") -> None:
        with self._lock:
            s = self._snap
            if s.status != status:
                s.since = time.time()
            s.status = status
            s.reason = reason
            s.connected = status == "connected"
            if not s.connected:
                s.positions = {}
                s.program_status = None

    def _lost(self, reason: str) -> None:
        self._set_status("lost", reason)

    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._supervise())
        finally:
            loop.close()
            self._first.set()

    async def _supervise(self) -> None:
        self._stop = asyncio.Event()
        while not self._stop.is_set():
            try:
                await self._session()
            except OpcUaError as exc:  # the server is there but has no CNC axes
                self._fatal = exc
                self._lost(str(exc))
                self._first.set()
                return
            except Exception as exc:  # any loss: report, retry
                self._lost(_describe(exc))
            self._first.set()
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(self._stop.wait(), self.retry_s)

    async def _session(self) -> None:
        from asyncua import Client

        assert self._stop is not None
        client = Client(self.url, timeout=self.timeout_s)
        try:
            if self.security is not None:
                await _secure(client, self.security)
            await client.connect()
            axes, status_id = await find_cnc(client, self.position, self.channel,
                                             self.program)
            nodes = [client.get_node(a.value_id) for a in axes]
            values = await client.read_values(nodes)
            status = None
            if status_id is not None:
                try:  # a status the server cannot give leaves it unknown, the axes read on
                    status = await client.get_node(status_id).read_value()
                    nodes.append(client.get_node(status_id))
                except Exception:
                    status_id = None
            handler = _Handler(self, axes, status_id)
            sub = await client.create_subscription(self.publishing_ms, handler)
            from asyncua import ua

            await sub.subscribe_data_change(nodes,
                                            sampling_interval=ua.Double(self.publishing_ms))
            with self._lock:
                self._snap.axes = axes
            self._set_status("connected")
            for a, v in zip(axes, values, strict=True):
                self._store(a.name, float(v) * a.factor)
            if status_id is not None:
                self._store_status(status)
            self._first.set()
            state = client.nodes.server_state
            while not self._stop.is_set():
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(self._stop.wait(), self.watch_s)
                if self._stop.is_set():
                    break
                await asyncio.wait_for(state.read_value(), self.timeout_s)
                if self._snap.status != "connected":  # the subscription said it died
                    raise ConnectionError(self._snap.reason or "subscription lost")
        finally:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(client.disconnect(), self.timeout_s)
        self._set_status("lost", "closed")


async def _secure(client: Any, sec: Security) -> None:
    """Set a signed channel on ``client`` (before it connects)."""
    from asyncua import ua
    from asyncua.crypto import security_policies as sp
    from cryptography import x509

    policy = {"Basic256Sha256": sp.SecurityPolicyBasic256Sha256,
              "Aes128_Sha256_RsaOaep": sp.SecurityPolicyAes128Sha256RsaOaep,
              "Aes256_Sha256_RsaPss": sp.SecurityPolicyAes256Sha256RsaPss}[sec.policy]
    raw = Path(sec.cert).read_bytes()
    cert = (x509.load_pem_x509_certificate(raw) if raw.lstrip().startswith(b"-----")
            else x509.load_der_x509_certificate(raw))
    try:
        san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName)
        uris = san.value.get_values_for_type(x509.UniformResourceIdentifier)
    except x509.ExtensionNotFound:
        uris = []
    if uris:
        client.application_uri = uris[0]
    await client.set_security(policy, sec.cert, sec.key, server_certificate=sec.server_cert,
                              mode=getattr(ua.MessageSecurityMode, sec.mode))


def _describe(exc: Exception) -> str:
    text = str(exc) or type(exc).__name__
    return f"{type(exc).__name__}: {text}" if text != type(exc).__name__ else text


async def find_cnc(client: Any, position: str = "direct", channel: str | None = None,
                   program: bool = True) -> tuple[list[AxisNode], str | None]:
    """Browse ``Objects`` for the CNC axes (their ``ActPos``) and the channel's status.

    Parameters
    ----------
    client : asyncua.Client
        A connected client.
    position : {'direct', 'indirect'}
        ``PosDirect`` or ``PosIndirect``.
    channel : str, optional
        Browse name of the channel to read; default the only one.
    program : bool
        Look for the channel's status at all (False: ``status`` is None).

    Returns
    -------
    axes : list of AxisNode
        In browse order.
    status : str or None
        The node id of ``ActProgramStatus`` of the channel named ``channel``, or of the
        one object of type ``CncChannelType``; None when there is none or several and
        none is named (which runs the program is not known).

    Raises
    ------
    OpcUaError
        No CNC namespace, no object of type ``CncAxisType``, an axis without the position
        variable, two axes of one name, or no channel named ``channel`` (naming those
        there are).
    """
    from asyncua import ua

    uris = await client.get_namespace_array()
    idx = next((i for i, u in enumerate(uris) if u in CNC_NAMESPACES), None)
    if idx is None:
        raise OpcUaError(f"{client.server_url.geturl()}: the server has no OPC 40502 CNC "
                         f"namespace ({CNC_NAMESPACES[0]}); namespaces: {', '.join(uris)}")
    types = await _subtypes(client, ua.NodeId(ua.Int32(CNC_AXIS_TYPE_ID), ua.Int16(idx)))
    channel_types = (await _subtypes(client, ua.NodeId(ua.Int32(CNC_CHANNEL_TYPE_ID),
                                                       ua.Int16(idx))) if program else set())
    found: list[tuple[str, str]] = []
    channels: list[tuple[str, str]] = []
    seen = {client.nodes.objects.nodeid.to_string(), client.nodes.server.nodeid.to_string()}
    level = [client.nodes.objects]
    for _ in range(MAX_BROWSE_DEPTH):
        nxt = []
        for node in level:
            refs = await node.get_children_descriptions(
                refs=ua.ObjectIds.HierarchicalReferences, nodeclassmask=ua.NodeClass.Object)
            for r in refs:
                key = r.NodeId.to_string()
                if key in seen:
                    continue
                seen.add(key)
                if r.TypeDefinition.to_string() in types:
                    found.append((r.BrowseName.Name, key))
                else:
                    if r.TypeDefinition.to_string() in channel_types:
                        channels.append((r.BrowseName.Name, key))
                    nxt.append(client.get_node(r.NodeId))
                if len(seen) > MAX_BROWSE_NODES:
                    break
        level = nxt
        if not level or len(seen) > MAX_BROWSE_NODES:
            break
    url = client.server_url.geturl()
    if not found:
        raise OpcUaError(f"{url}: no object of type CncAxisType below Objects "
                         f"(OPC 40502 namespace {uris[idx]})")
    names = [n for n, _ in found]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise OpcUaError(f"{url}: several CNC axes named {', '.join(dup)}: "
                         + "; ".join(f"{n} {k}" for n, k in found if n in dup))
    axes = []
    var = POSITION_NODES[position]
    for name, key in found:
        try:
            node = await client.get_node(key).get_child([f"{idx}:{var}", f"{idx}:ActPos"])
        except Exception as exc:  # BadNoMatch and the like
            raise OpcUaError(f"{url}: axis {name} ({key}) has no {var}/ActPos: "
                             f"{_describe(exc)}") from exc
        unit_id, text = await _units(client, key, idx, var)
        rotational = await _is_rotational(client, key, idx)
        factor, rotary = axis_scale(unit_id, text, rotational, f"{url}: axis {name} {var}")
        axes.append(AxisNode(name=name, node_id=key, value_id=node.nodeid.to_string(),
                             factor=factor, rotary=rotary,
                             unit=unece_code(unit_id) if unit_id else ""))
    if not program:
        return axes, None
    if channel is not None:
        chosen = [k for n, k in channels if n == channel]
        if len(chosen) != 1:
            raise OpcUaError(f"{url}: channel={channel}: "
                             + ("no CncChannelType object of that name" if not chosen else
                                f"{len(chosen)} CncChannelType objects of that name")
                             + "; the server's channels: "
                             + (", ".join(n for n, _ in channels) or "none"))
    else:
        chosen = [k for _, k in channels] if len(channels) == 1 else []
    status = None
    if chosen:
        try:
            status = (await client.get_node(chosen[0]).get_child(
                [f"{idx}:ActProgramStatus"])).nodeid.to_string()
        except Exception as exc:  # not exposed: unknown, unless the user named it
            if channel is not None:
                raise OpcUaError(f"{url}: channel={channel} has no ActProgramStatus: "
                                 f"{_describe(exc)}") from exc
            status = None
    return axes, status


async def _subtypes(client: Any, base: Any) -> set[str]:
    """Node ids of ``base`` and of its subtypes (object types), as strings."""
    from asyncua import ua

    types = {base.to_string()}
    todo = [base]
    while todo:
        children = await client.get_node(todo.pop()).get_children(
            refs=ua.ObjectIds.HasSubtype, nodeclassmask=ua.NodeClass.ObjectType)
        for c in children:
            if c.nodeid.to_string() not in types:
                types.add(c.nodeid.to_string())
                todo.append(c.nodeid)
    return types


def unece_code(unit_id: int) -> str:
    """The UN/CEFACT common code of an ``EUInformation.UnitId`` (``17476`` -> ``'DD'``).

    Parameters
    ----------
    unit_id : int
        The code's characters, one byte each (OPC 10000-8, 5.6.3).

    Returns
    -------
    str
        The code, or the number when it is not one.
    """
    raw = int(unit_id).to_bytes(4, "big", signed=int(unit_id) < 0).lstrip(b"\0")
    return raw.decode("ascii") if raw and raw.isalnum() else str(unit_id)


LENGTH_UNITS = {"MMT": 1.0, "INH": 25.4, "MTR": 1000.0}
"""UNECE common code -> factor to mm: millimetre, inch, metre."""

ANGLE_UNITS = {"DD": 1.0, "C81": 180.0 / math.pi}
"""UNECE common code -> factor to degrees: degree (unit of angle), radian."""


def axis_scale(unit_id: int | None, text: str, rotational: bool | None,
               where: str) -> tuple[float, bool]:
    """The factor of an axis' position to mm or deg, and whether the axis is rotary.

    The unit decides when it is an angle (a rotary axis whose ``IsRotational`` was left
    at the type's default false is still read in degrees); a length on an axis whose
    ``IsRotational`` is true is a contradiction, refused. Without ``EngineeringUnits``
    the position is in the model's unit: mm, or deg on a rotational axis.

    Parameters
    ----------
    unit_id : int or None
        ``EUInformation.UnitId`` of the position (None or 0: no unit given).
    text : str
        Its ``DisplayName``, for messages.
    rotational : bool or None
        The axis' ``IsRotational`` (None: the server does not expose it).
    where : str
        The server and axis, for messages.

    Returns
    -------
    factor : float
        mm (rotary: deg) per unit of the server's value.
    rotary : bool

    Raises
    ------
    OpcUaError
        A unit that is neither a length nor an angle volcal knows, or a length on a
        rotational axis.
    """
    if not unit_id:
        return 1.0, bool(rotational)
    code = unece_code(unit_id)
    if code in ANGLE_UNITS:
        return ANGLE_UNITS[code], True
    if code in LENGTH_UNITS:
        if rotational:
            raise OpcUaError(f"{where} is in {text or code} but the axis' IsRotational is "
                             "true: a rotary axis' position must be an angle (UNECE DD, "
                             "C81)")
        return LENGTH_UNITS[code], False
    raise OpcUaError(f"{where} is in {text or code}: expected mm, m, inch (UNECE MMT, MTR, "
                     "INH), or deg or rad on a rotary axis (DD, C81)")


async def _units(client: Any, key: str, idx: int, var: str) -> tuple[int | None, str]:
    """``UnitId`` and display name of the position's ``EngineeringUnits`` (None: none)."""
    pos = client.get_node(key)
    for browse in (f"{idx}:{var}/{idx}:EngineeringUnits", f"{idx}:{var}/0:EngineeringUnits"):
        try:
            node = await pos.get_child(browse.split("/"))
            eu = await node.read_value()
            break
        except Exception:  # absent or empty: the model's unit
            continue
    else:
        return None, ""
    text = getattr(getattr(eu, "DisplayName", None), "Text", "") or ""
    return getattr(eu, "UnitId", None) or None, text


async def _is_rotational(client: Any, key: str, idx: int) -> bool | None:
    """The axis' ``IsRotational`` (mandatory in ``CncAxisType``; None: not exposed)."""
    try:
        node = await client.get_node(key).get_child([f"{idx}:IsRotational"])
        value = await node.read_value()
    except Exception:  # absent: the unit alone decides
        return None
    return None if value is None else bool(value)
