"""The OPC UA control source against an independent server (node-opcua, OPC 40502 nodeset).

The server (tests/opcua/cnc_server.mjs) is not volcal's: node-opcua loads the official
``Opc.Ua.CNC.NodeSet.xml`` and instantiates ``CncAxisType`` axes; the test writes their
positions. The source must find the axes by type, read ``PosDirect/ActPos``, report the last
value at every poll during a dwell (a subscription is silent then), and report a dropped
connection as a status, never as a position.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from timing import scaled_timeout

from .opcua_server import cnc_server  # noqa: F401 - the module's fixture

pytest.importorskip("asyncua", reason="the capture extra (asyncua) is not installed")

from volcal.capture.plan import plan_measurement, program_options  # noqa: E402
from volcal.capture.runner import LoopOptions, capture_measurement  # noqa: E402
from volcal.capture.samples import LaserSample  # noqa: E402
from volcal.capture.sources import Clock, SourceContext, make_control  # noqa: E402
from volcal.capture.trigger import TriggerParams  # noqa: E402
from volcal.plan.planner import plan_session  # noqa: E402
from volcal.session.format import read_session, write_session  # noqa: E402


def _poll_until(src, pred, nominal_s=10.0):
    deadline = time.monotonic() + scaled_timeout(nominal_s)
    s = src.poll()
    while not pred(s):
        if time.monotonic() > deadline:
            raise AssertionError(f"no such sample in time; last: {s}")
        time.sleep(0.02)
        s = src.poll()
    return s


@pytest.fixture
def control(cnc_server):  # noqa: F811
    ctx = SourceContext(clock=Clock())
    src = make_control(f"opcua:{cnc_server.url};publishing_ms=20", ctx)
    src.open()
    yield src
    src.close()


def test_axes_found_by_type_and_positions_read(cnc_server, control):  # noqa: F811
    assert sorted(control.axes) == ["X", "Y", "Z"]
    cnc_server.set(X=123.4567, Y=-20.125, Z=250.0)
    s = _poll_until(control, lambda s: s.status == "ok" and s.positions.get("X") == 123.4567)
    # doubles travel exactly through OPC UA
    assert dict(s.positions) == {"X": 123.4567, "Y": -20.125, "Z": 250.0}


def test_a_dwell_is_reported_at_every_poll_with_the_poll_time(cnc_server, control):  # noqa: F811
    cnc_server.set(X=10.0, Y=20.0, Z=30.0)
    _poll_until(control, lambda s: s.positions.get("X") == 10.0)
    before = control.link.snapshot().notifications
    samples = []
    t_end = time.monotonic() + 0.6
    while time.monotonic() < t_end:
        time.sleep(0.02)
        samples.append(control.poll())
    # the server sent nothing during the dwell (change-only subscription) ...
    assert control.link.snapshot().notifications == before
    # ... yet every poll reports the last position, stamped with the time of that poll
    assert len(samples) >= 10
    assert all(dict(s.positions) == {"X": 10.0, "Y": 20.0, "Z": 30.0} for s in samples)
    times = np.array([s.time_s for s in samples])
    assert np.all(np.diff(times) > 0)


class _Laser:
    """A laser on X: the displacement [um] plus an error of 2 um per 100 mm, plus 0.02 um of
    noise, at every poll."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.rng = np.random.default_rng(3)
        self.last = None

    def open(self):
        pass

    def close(self):
        pass

    def poll(self):
        c = self.ctx.latest_control()
        now = self.ctx.clock.now()
        if c is None or c.status != "ok" or (self.last is not None and now - self.last < 0.005):
            return None  # one sample per poll of the loop
        self.last = now
        x = c.positions["X"]
        v = 1000.0 * x + 0.02 * x + self.rng.normal(0.0, 0.02)
        return LaserSample(time_s=now, value=v, unit="um")


def _drive(server, pm, stop, speed_mm_s=800.0, tick_s=0.025):
    """Play the program's steps on the server: moves interpolated, dwells silent."""
    here = None
    for st in pm.steps:
        if stop.is_set():
            return
        if st.kind == "start" and st.position is not None:
            here = np.array(st.position, float)
            server.set(X=here[0], Y=here[1], Z=here[2])
            time.sleep(0.3)
        elif st.kind == "move" and st.position is not None:
            to = np.array(st.position, float)
            # at least 8 updates a move: a short reversal (overrun) lasts long enough for
            # the subscription (50 ms publishing) to see it, as on a machine
            n = max(8, int(np.ceil(np.linalg.norm(to - here) / (speed_mm_s * tick_s))))
            for k in range(1, n + 1):
                p = here + (to - here) * k / n
                server.set(X=float(p[0]), Y=float(p[1]), Z=float(p[2]))
                time.sleep(tick_s)
            here = to
        elif st.kind == "dwell":
            time.sleep(float(st.seconds))  # silence: the server writes nothing


@pytest.mark.parametrize("steps, dwell_s, stable_s", [
    (1, 1.0, 0.5),  # 4 dwells: make test
    pytest.param(4, 2.0, 1.0, marks=pytest.mark.slow),  # 10 dwells, the default stable time
])
def test_capture_over_opcua_one_row_per_dwell(cnc_server, tmp_path, steps, dwell_s,  # noqa: F811
                                              stable_s):
    s = plan_session(np.array([[0, 400], [0, 300], [0, 250]], float), "XYFZ", steps,
                     ("linear:x",), 1, name="OPCUA")
    folder = tmp_path / "session"
    write_session(s, folder)
    m = s.measurements[0]
    opts = program_options(dwell_s=dwell_s)
    pm = plan_measurement(m, s.travel, opts)
    params = TriggerParams(stable_s=stable_s, max_gap_s=min(0.5, stable_s / 2))
    clock = Clock()
    latest = {}
    ctx = SourceContext(clock=clock, latest_control=lambda: latest.get("c"))
    control = make_control(f"opcua:{cnc_server.url};publishing_ms=20", ctx)
    laser = _Laser(ctx)
    control.open()
    counts = {"accepted": 0, "missed": 0}
    events = []

    def observe(ev):
        events.append(ev.kind)
        if ev.kind in counts:
            counts[ev.kind] += 1

    stop = threading.Event()
    cnc_server.set(X=pm.steps[0].position[0] if pm.steps[0].position else 0.0)
    driver = threading.Thread(target=_drive, args=(cnc_server, pm, stop), daemon=True)
    try:
        driver.start()
        out = capture_measurement(pm, folder, control, laser, clock, params,
                                  loop=LoopOptions(poll_s=0.02,
                                                   timeout_s=scaled_timeout(20.0)),
                                  observer=observe,
                                  latest=lambda c: latest.__setitem__("c", c))
    finally:
        stop.set()
        driver.join(timeout=scaled_timeout(30.0))
        control.close()
    assert out.complete, out.reason
    n = len(pm.dwells)
    assert counts == {"accepted": n, "missed": 0}
    got = read_session(folder).measurements[0]
    assert got.deviation is not None and len(got.deviation) == n
    # the deviation (reading minus commanded displacement from the first row) is the
    # laser's error of 0.02 um per mm of X at the positions the control reported
    expect = 0.02 * (m.positions[:, 0] - m.positions[0, 0])
    assert np.max(np.abs(got.deviation - expect)) < 0.05


def test_a_dropped_connection_is_a_status_not_a_position(cnc_server):  # noqa: F811
    ctx = SourceContext(clock=Clock())
    src = make_control(f"opcua:{cnc_server.url};watch_s=0.2;timeout_s=2", ctx)
    src.open()
    try:
        cnc_server.set(X=1.0, Y=2.0, Z=3.0)
        _poll_until(src, lambda s: s.positions.get("X") == 1.0)
        cnc_server.stop()
        s = _poll_until(src, lambda s: s.status != "ok")
        assert s.status.startswith("lost")
        assert dict(s.positions) == {}
        # the page shows it as a banner naming the source and the reason
        from volcal.capture.page.state import LiveState
        from volcal.capture.samples import CaptureEvent

        page = LiveState("OPCUA")
        page.set_sources(f"opcua:{cnc_server.url}", "sim")
        page(CaptureEvent("start", "m", 0.0, {"targets": [[1.0, 2.0, 3.0]]}))
        page(CaptureEvent("control", "m", s.time_s, s.to_json()))
        (banner,) = [b for b in page.snapshot()["banners"] if "control" in b]
        assert banner.startswith(f"The control source opcua:{cnc_server.url} stopped sending")
        assert "(lost: " in banner
    finally:
        src.close()


@pytest.mark.slow
def test_the_source_connects_again_when_the_server_returns():
    from .opcua_server import CncServer, skip_reason

    if skip_reason():
        pytest.skip(skip_reason())
    first = CncServer()
    ctx = SourceContext(clock=Clock())
    src = make_control(f"opcua:{first.url};watch_s=0.2;timeout_s=2", ctx)
    second = None
    try:
        src.open()
        first.set(X=1.0)
        _poll_until(src, lambda s: s.positions.get("X") == 1.0)
        first.stop()
        _poll_until(src, lambda s: s.status.startswith("lost"))
        second = CncServer(port=first.port)  # the control restarted: new session, new nodes
        second.set(X=7.25, Y=1.0, Z=2.0)
        s = _poll_until(src, lambda s: s.status == "ok" and s.positions.get("X") == 7.25, 60.0)
        assert dict(s.positions) == {"X": 7.25, "Y": 1.0, "Z": 2.0}
    finally:
        src.close()
        first.stop()
        if second is not None:
            second.stop()


@pytest.mark.slow
def test_a_signed_and_encrypted_channel(tmp_path):
    import asyncio
    import socket

    from asyncua.crypto.cert_gen import setup_self_signed_certificate
    from cryptography.x509.oid import ExtendedKeyUsageOID

    from volcal.capture.sources import SourceError

    from .opcua_server import CncServer, skip_reason

    if skip_reason():
        pytest.skip(skip_reason())
    cert, key = tmp_path / "volcal.der", tmp_path / "volcal.pem"
    asyncio.run(setup_self_signed_certificate(
        key, cert, "urn:volcal:capture:test", socket.gethostname(),
        [ExtendedKeyUsageOID.CLIENT_AUTH], {"commonName": "volcal capture test"}))
    (tmp_path / "pki").mkdir()
    server = CncServer(pki=tmp_path / "pki")
    try:
        server.set(X=3.5, Y=4.5, Z=5.5)
        # the server offers no channel without security: refused, with the reason
        plain = make_control(f"opcua:{server.url};timeout_s=2", SourceContext(clock=Clock()))
        with pytest.raises(SourceError, match="cannot connect"):
            plain.open()
        # the server's own certificate, as its administrator exports it (node-opcua keeps
        # it in its PKI folder): this server offers no unsecured channel to ask for it
        server_cert = tmp_path / "pki" / "own" / "certs" / "certificate.pem"
        src = make_control(f"opcua:{server.url};policy=Basic256Sha256;mode=SignAndEncrypt;"
                           f"cert={cert};key={key};server_cert={server_cert}",
                           SourceContext(clock=Clock()))
        src.open()
        try:
            s = _poll_until(src, lambda s: s.positions.get("X") == 3.5)
            assert dict(s.positions) == {"X": 3.5, "Y": 4.5, "Z": 5.5}
        finally:
            src.close()
    finally:
        server.stop()


def test_signed_channel_options_are_checked(tmp_path):
    from volcal.errors import VolcalInputError

    ctx = SourceContext(clock=Clock())
    with pytest.raises(VolcalInputError, match="needs cert=, key="):
        make_control("opcua:opc.tcp://h:1;policy=Basic256Sha256", ctx)
    (tmp_path / "c.der").write_bytes(b"x")
    with pytest.raises(VolcalInputError, match="key=.*no such file"):
        make_control(f"opcua:opc.tcp://h:1;policy=Basic256Sha256;cert={tmp_path / 'c.der'};"
                     f"key={tmp_path / 'nope.pem'}", ctx)
    with pytest.raises(VolcalInputError, match="policy='Basic128Rsa15'"):
        make_control("opcua:opc.tcp://h:1;policy=Basic128Rsa15;cert=a;key=b", ctx)
    with pytest.raises(VolcalInputError, match="mode= needs"):
        make_control("opcua:opc.tcp://h:1;mode=Sign", ctx)


def test_an_address_without_a_server_is_refused_at_open():
    from volcal.capture.sources import SourceError

    from .opcua_server import free_port

    ctx = SourceContext(clock=Clock())
    src = make_control(f"opcua:opc.tcp://127.0.0.1:{free_port()}/;timeout_s=1", ctx)
    with pytest.raises(SourceError, match="cannot connect"):
        src.open()


@pytest.mark.parametrize("text, match", [
    ("opcua:http://host:4840", "expected opcua:opc.tcp://HOST:PORT"),
    ("opcua:opc.tcp://h:1;position=motor", "position='motor'"),
    ("opcua:opc.tcp://h:1;publishing_ms=-5", "publishing_ms=-5"),
    ("opcua:opc.tcp://h:1;speed=3", "KEY one of"),
])
def test_bad_source_text_is_refused(text, match):
    from volcal.errors import VolcalInputError

    with pytest.raises(VolcalInputError, match=match):
        make_control(text, SourceContext(clock=Clock()))
