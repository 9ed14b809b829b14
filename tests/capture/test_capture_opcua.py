"""The OPC UA control source against an independent server (node-opcua, OPC 40502 nodeset).

The server (tests/opcua/cnc_server.mjs) is not volcal's: node-opcua loads the official
``Opc.Ua.CNC.NodeSet.xml`` and instantiates ``CncAxisType`` axes; the test writes their
positions. The source must find the axes by type, read ``PosDirect/ActPos``, report the last
value at every poll during a dwell (a subscription is silent then), and report a dropped
connection as a status, never as a position.
"""

from __future__ import annotations

import math
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
from volcal.capture.sources import (  # noqa: E402
    Clock,
    SourceContext,
    make_control,
    register_laser,
)
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


def ok(s) -> bool:
    """A sample taken while connected (a poll may return None: too soon after the last)."""
    return s is not None and s.status == "ok"


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


def test_a_server_without_a_channel_reports_no_program_status(control):
    s = _poll_until(control, ok)
    assert s.program_running is None and control.link.snapshot().program_status is None


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
    for i, st in enumerate(pm.steps):
        if stop.is_set():
            return
        if st.kind == "start" and st.position is not None:
            here = np.array(st.position, float)
            server.set(X=here[0], Y=here[1], Z=here[2])
            time.sleep(0.3)
        elif st.kind == "move" and st.position is not None:
            to = np.array(st.position, float)
            # at least 16 updates a move (0.4 s): a short reversal (the 5 mm overrun at
            # the end of a run) lasts long enough for the subscription (20-50 ms
            # publishing) to see it on a loaded box, as on a machine. With 8 (0.2 s) the
            # slow variant failed once in three runs beside a make test: the overrun
            # unseen, the rule took the machine for standing at reading 5's target
            # through reading 6's dwell (the same position) and refused the next stop.
            n = max(16, int(np.ceil(np.linalg.norm(to - here) / (speed_mm_s * tick_s))))
            for k in range(1, n + 1):
                p = here + (to - here) * k / n
                server.set(X=float(p[0]), Y=float(p[1]), Z=float(p[2]))
                time.sleep(tick_s)
            here = to
            nxt = pm.steps[i + 1] if i + 1 < len(pm.steps) else None
            if nxt is not None and nxt.kind == "move":
                # a move on to another (the reversal at the overrun): the machine stops
                # there (decelerates to rest) for 0.2 s, as a part program's two G1s do;
                # still no reading (no dwell), and the stop makes the reversal plain to
                # the rule even when the box is loaded (session 25: the unseen overrun)
                time.sleep(0.2)
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


# -- a rotary axis (the server's A, B, C added for these tests, removed after) -----------

ROT = "rotary-c"
HOME_DEG = 90.0  # where C stands before the program
DWELL_S, STABLE_S = 1.0, 0.5
ARCSEC_URAD = math.pi / 648000.0 * 1e6
NOISE_ARCSEC = 0.003
# a reading is the difference of two means of >= 20 samples of 0.003 arcsec (0.0145 urad):
# sigma <= 0.0145 * sqrt(2 / 20) = 0.0046 urad
TOL_URAD = 0.03


@pytest.fixture
def rotary_server(cnc_server):  # noqa: F811
    """The server with three rotary axes as a 5-axis CNC exposes them (OPC 40502): A
    rotational without EngineeringUnits, B in radians (UNECE C81), C in degrees (DD)."""
    cnc_server.add("A:rot", "B:rad", "C:deg")
    try:
        yield cnc_server
    finally:
        cnc_server.remove("A", "B", "C")


def calibrator_arcsec(angle_deg: float, side: float) -> float:
    """The scripted calibrator's reading at the axis' true angle, reached turning ``side``
    [arcsec]: distinct at 0 and 360 deg and on each side, so that a reading taken at
    another dwell would show."""
    return 1.5 + 0.004 * angle_deg + (0.6 if side < 0 else 0.0)


def test_rotary_axes_are_found_and_read_in_degrees(rotary_server):
    server = rotary_server
    ctx = SourceContext(clock=Clock())
    src = make_control(f"opcua:{server.url};publishing_ms=20", ctx)
    src.open()
    try:
        axes = {a.name: a for a in src.link.snapshot().axes}
        assert {n: (a.rotary, a.unit) for n, a in axes.items()} == {
            "X": (False, ""), "Y": (False, ""), "Z": (False, ""),
            "A": (True, ""), "B": (True, "C81"), "C": (True, "DD")}
        server.set(X=12.5, A=-30.25, B=math.pi / 4, C=359.875)
        s = _poll_until(src, lambda s: s.status == "ok" and s.positions.get("C") == 359.875)
        assert s.positions["C"] == 359.875  # degrees as the server gives them, not wrapped
        assert s.positions["A"] == -30.25  # rotational without units: the model's degrees
        assert s.positions["B"] == pytest.approx(45.0, abs=1e-12)  # radians to degrees
        assert s.positions["X"] == 12.5
    finally:
        src.close()
        server.set(X=0.0, A=0.0, B=0.0, C=0.0)


def test_a_table_named_c1_is_read_as_c_with_the_axes_key(cnc_server):  # noqa: F811
    """A control naming its rotary table C1 (a machine axis name): ``axes=C:C1`` reads it
    as volcal's C, in degrees, beside the linear axes under their own names."""
    cnc_server.add("C1:deg")
    ctx = SourceContext(clock=Clock())
    src = make_control(f"opcua:{cnc_server.url};publishing_ms=20;axes=C:C1", ctx)
    try:
        src.open()
        assert src.axes == ["X", "Y", "Z", "C"]
        cnc_server.set(X=4.5, C1=123.25)
        s = _poll_until(src, lambda s: s.status == "ok" and s.positions.get("C") == 123.25)
        assert s.positions == {"X": 4.5, "Y": 0.0, "Z": 0.0, "C": 123.25}
    finally:
        src.close()
        cnc_server.set(X=0.0)
        cnc_server.remove("C1")


class _Machine:
    """The C axis as the test turns it: its true angle, the side of the last turn, the
    dwell it stands in (None while moving), and when the capture opened its laser."""

    def __init__(self) -> None:
        self.angle = HOME_DEG
        self.side = 1.0
        self.dwell: int | None = None
        self.go = threading.Event()
        self.stop = threading.Event()


class _Calibrator:
    """The scripted calibrator: one reading [arcsec] per poll of the capture's loop, of
    the axis' true angle and side, with 0.003 arcsec of noise; it logs the dwell each
    sample was taken in."""

    def __init__(self, ctx, machine: _Machine):
        self.ctx = ctx
        self.machine = machine
        self.rng = np.random.default_rng(7)
        self.last: float | None = None
        self.log: list[tuple[float, int | None]] = []

    def open(self):
        self.machine.go.set()  # the control is connected (opened first): the program starts

    def close(self):
        pass

    def poll(self) -> LaserSample | None:
        now = self.ctx.clock.now()
        if self.last is not None and now - self.last < 0.005:
            return None
        self.last = now
        m = self.machine
        self.log.append((now, m.dwell))
        v = calibrator_arcsec(m.angle, m.side) + self.rng.normal(0.0, NOISE_ARCSEC)
        return LaserSample(time_s=now, value=float(v), unit="arcsec")


def _turn(server, m: _Machine, to: float, speed_deg_s: float = 720.0,
          tick_s: float = 0.025) -> None:
    """Turn C from its angle to ``to`` [deg], written wrapped into 0..360; at least 8
    updates a turn, so that the 2 deg overrun is seen (50 ms publishing), as on a machine."""
    here = m.angle
    n = max(8, math.ceil(abs(to - here) / (speed_deg_s * tick_s)))
    if to != here:
        m.side = 1.0 if to > here else -1.0
    for k in range(1, n + 1):
        if k > 1:
            time.sleep(tick_s)
        m.angle = here + (to - here) * k / n
        server.set(C=m.angle % 360.0)
    # returns at the update that reaches ``to``: a dwell starts there


def _play_rotary(server, pm, m: _Machine) -> None:
    """Play the rotary program on the server: the start (to the first target and on by
    the overrun), the operator stop, then the turns and the silent dwells."""
    mv = pm.rotary
    if not m.go.wait(scaled_timeout(30.0)):
        return
    time.sleep(0.2)
    _turn(server, m, mv.start_deg)
    turned = True
    for i, (kind, value, row) in enumerate(mv.items):
        if m.stop.is_set():
            return
        if i == mv.stop:
            time.sleep(0.3)  # the operator stop, at the first reading's approach point
        if kind == "turn":
            if turned:
                time.sleep(0.025)  # a reversal (the overrun) holds one update, as a move's
            _turn(server, m, m.angle + float(value))
            turned = True
        elif kind == "dwell":
            m.dwell = row
            time.sleep(float(value))  # silence: the server writes nothing
            m.dwell = None
            turned = False


def test_rotary_capture_over_opcua_one_reading_per_dwell(rotary_server, tmp_path):
    import json

    from volcal.capture.journal import journal_path
    from volcal.capture.plan import plan_measurement, program_options
    from volcal.session.format import read_session
    from volcal.steps.capture import capture
    from volcal.steps.plan import plan

    server = rotary_server
    s = tmp_path / "S"
    plan(((0.0, 400.0), (0.0, 300.0), (0.0, 250.0)), steps=2, tests="rotary:c", runs=1,
         output=s)
    planned = read_session(s, require_deviation=False)
    m = planned.get(ROT)
    pm = plan_measurement(m, planned.travel, program_options(dwell_s=DWELL_S))
    targets, sides = m.columns["target_deg"], m.columns["direction"]
    assert list(targets) == [0.0, 158.545, 360.0, 360.0, 158.545, 0.0]  # 0 and 360: one pose
    machine, calibrators = _Machine(), []

    def calibrator(spec, ctx):
        calibrators.append(_Calibrator(ctx, machine))
        return calibrators[-1]

    register_laser("calibrator-opcua-test", calibrator, "a scripted angular calibrator")
    server.set(X=0.0, Y=0.0, Z=0.0, C=HOME_DEG)
    driver = threading.Thread(target=_play_rotary, args=(server, pm, machine), daemon=True)
    driver.start()
    out = tmp_path / "C"
    try:
        r = capture(s, control=f"opcua:{server.url};publishing_ms=20",
                    laser="calibrator-opcua-test", measurement=[ROT], output=out,
                    dwell_s=DWELL_S, stable_s=STABLE_S, max_gap_s=0.25, poll_s=0.02,
                    timeout_s=scaled_timeout(10.0))
    finally:
        machine.stop.set()
        driver.join(timeout=scaled_timeout(30.0))
    n = len(pm.dwells)
    assert r.complete, r.outcomes
    assert [(o.measurement, o.accepted, o.missed) for o in r.outcomes] == [(ROT, n, [])]
    # the CSV: the planned rows, the known readings in urad from the first row
    rows = (out / f"{ROT}.csv").read_text().splitlines()
    assert rows[0] == "target_deg,run,direction,deviation_urad,time_s"
    assert [x.split(",")[:3] for x in rows[1:]] == \
        [x.split(",")[:3] for x in (s / f"{ROT}.csv").read_text().splitlines()[1:]]
    side = np.where(sides == "+", 1.0, -1.0)
    known = np.array([calibrator_arcsec(t, d) for t, d in zip(targets, side, strict=True)])
    want = (known - known[0]) * ARCSEC_URAD
    got = read_session(out).get(ROT).deviation
    assert got[0] == 0.0
    assert np.max(np.abs(got - want)) < TOL_URAD, got - want
    assert np.min(np.abs(np.diff(want))) > 2.0  # each neighbour's reading differs: a
    # reading taken at the wrong dwell (360 for 0, the other side) would fail
    # one reading per dwell, inside it: the calibrator's samples of each accepted window
    # were all taken while the machine stood in that reading's dwell
    recs = [json.loads(x) for x in journal_path(out, ROT).read_text().splitlines()]
    acc = [x for x in recs if x["type"] == "accepted"]
    assert sorted(a["reading"] for a in acc) == list(range(n))
    log = calibrators[-1].log
    for a in acc:
        t0, t1 = a["window"]
        inside = {d for t, d in log if t0 <= t <= t1}
        assert inside == {a["reading"]}, (a["reading"], inside)
        assert a["pos"][0] == pytest.approx(targets[a["reading"]], abs=0.005)
    _check_sides(recs, acc, targets, side)


def _check_sides(recs, acc, targets, side) -> None:
    """The server's C as reported: wrapped into 0..360 (-2 deg read 358, 362 read 2);
    unwrapped, the last 0.5 deg turned before each accepted window is on the reading's
    side."""
    ctrl = [(x["t"], x["pos"]["C"]) for x in recs if x["type"] == "control" and x["pos"]]
    t = np.array([c[0] for c in ctrl])
    c = np.array([c[1] for c in ctrl])
    assert np.all((c >= 0.0) & (c < 360.0)) and c.max() > 357.9  # the overrun below 0
    u = np.unwrap(c, period=360.0)
    # the overruns to -2 and 362 deg: the stop holds -2; the turn at 362 lasts one update
    # of the server (25 ms), which 50 ms of sampling may miss by a step or two (0.25 deg)
    assert u[0] == pytest.approx(HOME_DEG) and -2.0 - 1e-9 <= u.min() < -1.9 \
        and 361.0 < u.max() <= 362.0 + 1e-9
    for a in acc:
        i = a["reading"]
        before = u[t < a["window"][0]]
        far = before[np.abs(before - targets[i]) > 0.5][-1]
        assert side[i] * (targets[i] - far) > 0, (i, targets[i], far)


def test_a_rotary_test_from_a_server_without_the_axis_is_refused_naming_the_option(
        cnc_server, tmp_path, monkeypatch, capsys):  # noqa: F811
    """The server exposes X, Y, Z only: exit 2 once connected, naming --control, the
    rotary test's axis and the axes found; no traceback, no reading recorded."""
    from volcal.steps.plan import plan
    from volcal_cli_helpers import run_volcal

    s = tmp_path / "S"
    plan(((0.0, 400.0), (0.0, 300.0), (0.0, 250.0)), steps=2, tests="rotary:c", runs=1,
         output=s)
    code, _, err = run_volcal(monkeypatch, capsys, "capture", str(s), "--control",
                              f"opcua:{cnc_server.url};timeout_s=2", "--laser", "sim",
                              "--measurement", "rotary-c", "-o", str(tmp_path / "O"),
                              "--dwell-s", "2")
    assert code == 2, err
    assert f"--control opcua:{cnc_server.url};timeout_s=2: measurement rotary-c turns axis " \
           "C (rotary [deg]), but the server reports no such CncAxisType object; the " \
           "server's axes: X (linear [mm]), Y (linear [mm]), Z (linear [mm]). Give a " \
           "control that reports C" in err, err
    assert "Traceback" not in err
    assert not (tmp_path / "O" / "capture" / "rotary-c.jsonl").exists()  # nothing captured


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


@pytest.fixture(scope="module")
def five_axis_server():
    """A server of a 5-axis CNC with one channel: X, Y, Z in mm, C, A in degrees, the
    channel's ActProgramStatus written by the tests (started once for the module's)."""
    from .opcua_server import CncServer, skip_reason

    why = skip_reason()
    if why:
        pytest.skip(why)
    server = CncServer(axes=("X:mm", "Y:mm", "Z:mm", "C:deg", "A:deg"), channel=True)
    try:
        yield server
    finally:
        server.stop()


def test_the_channels_program_status_says_whether_the_program_runs(five_axis_server):
    """A server with one CncChannelType object: its ActProgramStatus (OPC 40502, 7.2.5)
    gives each sample's program_running: Stopped false, Running true, Interrupted (an M0,
    a feed hold) false, so that the trigger takes no reading at an operator stop (an
    R-test's first pose); ``program=off`` leaves it unknown; the module's server, without
    a channel, reports none (the samples' program_running None, as before)."""
    server = five_axis_server
    server.program(0)
    srcs = []
    try:
        on = make_control(f"opcua:{server.url};publishing_ms=20", SourceContext(clock=Clock()))
        off = make_control(f"opcua:{server.url};publishing_ms=20;program=off",
                           SourceContext(clock=Clock()))
        for src in (on, off):
            src.open()
            srcs.append(src)
        assert _poll_until(on, ok).program_running is False
        for status, want in ((1, True), (3, False), (1, True), (0, False), (2, None)):
            server.program(status)
            _poll_until(on, lambda s, w=want: ok(s) and s.program_running is w)
            assert _poll_until(off, ok).program_running is None
        assert on.link.snapshot().program_status == 2
        assert off.link.snapshot().program_status is None  # not even looked for
    finally:
        for src in srcs:
            src.close()


def test_a_status_the_server_cannot_give_leaves_it_unknown():
    """A channel whose ActProgramStatus the server lists without read access
    (BadNotReadable): the axes are read as without a channel, the status unknown; the
    connection is not lost over it."""
    from .opcua_server import CncServer, skip_reason

    why = skip_reason()
    if why:
        pytest.skip(why)
    server = CncServer(channel=True, unreadable=True)
    src = make_control(f"opcua:{server.url};publishing_ms=20", SourceContext(clock=Clock()))
    try:
        src.open()
        server.set(X=12.5, Y=1.0, Z=2.0)
        s = _poll_until(src, lambda s: s is not None and s.positions.get("X") == 12.5)
        assert s.status == "ok" and s.program_running is None
        assert src.link.snapshot().program_status is None
    finally:
        src.close()
        server.stop()


def test_a_control_of_two_channels_reads_the_one_named():
    """Two CncChannelType objects: which runs the program is not known, so the status is
    left unknown; ``channel=Channel2`` reads that one (Channel1's status changes nothing);
    a channel the server lacks is refused at the connection, naming the two it has."""
    from volcal.capture.sources import SourceError

    from .opcua_server import CncServer, skip_reason

    why = skip_reason()
    if why:
        pytest.skip(why)
    server = CncServer(channels=("Channel1", "Channel2"))
    srcs = []
    try:
        both = make_control(f"opcua:{server.url};publishing_ms=20",
                            SourceContext(clock=Clock()))
        named = make_control(f"opcua:{server.url};publishing_ms=20;channel=Channel2",
                             SourceContext(clock=Clock()))
        for src in (both, named):
            src.open()
            srcs.append(src)
        assert _poll_until(named, ok).program_running is False  # Stopped at the start
        server.program(1, "Channel2")
        _poll_until(named, lambda s: ok(s) and s.program_running is True)
        server.program(3, "Channel1")  # the other channel interrupted: not ours
        server.program(3, "Channel2")
        _poll_until(named, lambda s: ok(s) and s.program_running is False)
        server.program(1, "Channel2")
        _poll_until(named, lambda s: ok(s) and s.program_running is True)
        assert named.link.snapshot().program_status == 1
        assert _poll_until(both, ok).program_running is None
        assert both.link.snapshot().program_status is None
        wrong = make_control(f"opcua:{server.url};timeout_s=2;channel=Channel3",
                             SourceContext(clock=Clock()))
        with pytest.raises(SourceError, match="channel=Channel3: no CncChannelType object of "
                                              "that name; the server's channels: Channel1, "
                                              "Channel2"):
            wrong.open()
        wrong.close()
    finally:
        for src in srcs:
            src.close()
        server.stop()


# -- an R-test over OPC UA: five axes and the channel's program status --------------------

RT_POSES = [(0, 0), (30, 0), (0, -15)]
"""(c, a) [deg] of the default ``r_test:ca`` plan kept (a C turn and an A tilt)."""
NEST_OFF_UM = (7.0, -5.0, 3.0)
"""What the nest reads during the operator stop at pose 1, before its sensors are zeroed."""


def _nest_um(i: int) -> np.ndarray:
    """The scripted nest's three readings at pose ``i`` (zero at pose 1: zeroed there) [um]."""
    return np.array([12.5 * i, -8.0 * i, 3.5 * i * i])


class _Cell:
    """Where the played R-test stands: its pose's dwell (None elsewhere), the stop."""

    def __init__(self) -> None:
        self.dwell: int | None = None
        self.stopped = False
        self.go = threading.Event()
        self.stop = threading.Event()


class _Nest:
    """The nest's three sensors: their scripted values in a dwell, the unzeroed ones during
    the operator stop, a value changing with time between (the nest follows the sphere),
    0.02 um of noise."""

    def __init__(self, ctx, cell: _Cell):
        self.ctx, self.cell = ctx, cell
        self.rng = np.random.default_rng(11)
        self.last: float | None = None

    def open(self):
        pass

    def close(self):
        pass

    def poll(self):
        now = self.ctx.clock.now()
        if self.last is not None and now - self.last < 0.005:
            return None
        self.last = now
        c = self.cell
        v = (np.array(NEST_OFF_UM) if c.stopped else
             _nest_um(c.dwell) if c.dwell is not None else np.full(3, 50.0 * np.sin(now)))
        v = v + self.rng.normal(0.0, 0.02, 3)
        return LaserSample(time_s=now, value=float(v[0]), unit="um",
                           channels=tuple(float(x) for x in v))


def _play_rtest(server, pm, cell: _Cell, axes: tuple[str, ...], tick_s: float = 0.025):
    """Play the R-test's path (pm.path: moves in the control's axes, the stop, the dwells)
    on the server, its channel's ActProgramStatus as a control sets it: Running, Interrupted
    at the operator stop, Stopped at the end."""
    if not cell.go.wait(scaled_timeout(30.0)):
        return
    time.sleep(0.3)  # the capture's loop polls the standing machine first
    here = None
    server.program(1)
    for kind, p, i in pm.path:
        if cell.stop.is_set():
            return
        if kind == "move":
            to = np.asarray(p, float) if here is None else np.where(np.isnan(p), here, p)
            if here is None or np.isnan(here).any():
                here = np.where(np.isnan(to), 0.0, to)
                to = here
            for k in range(1, 5):  # 0.1 s a move: the path's points are 1 deg apart
                q = here + (to - here) * k / 4
                server.set(**{a: float(v) for a, v in zip(axes, q, strict=True)})
                time.sleep(tick_s)
            here = to
        elif kind == "stop":
            server.program(3)  # M0: the operator puts the sphere in the nest, zeroes it
            cell.stopped = True
            time.sleep(1.2)
            cell.stopped = False
            server.program(1)  # cycle start
        elif kind == "dwell":
            cell.dwell = int(i)
            time.sleep(float(pm.options.dwell_s))
            cell.dwell = None
    server.program(0)


@pytest.mark.parametrize("status", ["on", pytest.param("off", marks=pytest.mark.slow)])
def test_rtest_over_opcua_takes_pose_1_after_the_operator_stop(five_axis_server, tmp_path,
                                                              status):
    """An R-test played on the OPC UA server (X, Y, Z in mm, C, A in degrees, one channel):
    the nest reads 7, -5, 3 um during the operator stop at pose 1 (not zeroed yet) and its
    scripted values in each dwell. With the channel's status (the default) the capture
    takes pose 1 in the dwell after the cycle start; with ``program=off`` (a position-only
    control, where the stop and the dwell look alike) the last stable window before the
    machine leaves pose 1 (session 25 took the stop's 7, -5, 3 um there): every row its
    dwell's values."""
    from .rtest_plan import plan_rtest

    server = five_axis_server
    server.program(0)
    folder = plan_rtest(tmp_path / "S", ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0)),
                        RT_POSES)
    s = read_session(folder, require_deviation=False)
    m = s.get("r_test")
    pm = plan_measurement(m, s.travel, program_options(dwell_s=1.5, safe_z_mm=480.0))
    axes = pm.frame.axes
    assert axes == ("X", "Y", "Z", "C", "A")  # as the server names them
    cell = _Cell()
    clock = Clock()
    latest: dict = {}
    ctx = SourceContext(clock=clock, latest_control=lambda: latest.get("c"))
    control = make_control(f"opcua:{server.url};publishing_ms=20;program={status}", ctx)
    nest = _Nest(ctx, cell)
    driver = threading.Thread(target=_play_rtest, args=(server, pm, cell, axes), daemon=True)
    try:
        control.open()
        cell.go.set()
        driver.start()
        out = capture_measurement(pm, folder, control, nest, clock,
                                  TriggerParams(stable_s=0.5, max_gap_s=0.25),
                                  loop=LoopOptions(poll_s=0.02, timeout_s=scaled_timeout(30.0)),
                                  latest=lambda c: latest.__setitem__("c", c))
    finally:
        cell.stop.set()
        driver.join(timeout=scaled_timeout(30.0))
        control.close()
    assert out.complete, out.reason
    got = read_session(folder).get("r_test")
    d = np.column_stack([got.columns[c] for c in ("dx_um", "dy_um", "dz_um")])
    want = np.array([_nest_um(i) for i in range(len(RT_POSES))])
    np.testing.assert_allclose(d, want, atol=0.05)
