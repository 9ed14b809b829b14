"""The technician's page without a browser: its state, its HTTP server, the typed source and
``volcal capture --serve``."""

from __future__ import annotations

import json
import math
import urllib.error
import urllib.request

import numpy as np
import pytest

from volcal.capture.samples import CaptureEvent, ControlSample
from volcal.capture.sources import Clock, SourceContext, SourceError, make_laser
from volcal.capture.typed import TypedLaser, TypedQueue
from volcal.errors import VolcalInputError
from volcal_cli_helpers import run_volcal

aiohttp = pytest.importorskip("aiohttp", reason="the capture extra (aiohttp) is not installed")

from volcal.capture.page.server import Page, PageServer  # noqa: E402
from volcal.capture.page.state import LiveState  # noqa: E402

TARGETS = [[5.0, 0.0, 0.0], [105.0, 0.0, 0.0], [205.0, 0.0, 0.0]]


class Wall:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def _start(state, mid="linear-x1", **data):
    state(CaptureEvent("start", mid, 0.0, {
        "readings": 3, "targets": TARGETS, "directions": ["+"] * 3, "runs": [1] * 3,
        "done": [], "column": "deviation_um", "unit": "um", "values": {}, "missed": [],
        **data}))


def _ctrl(state, t, x, status="ok"):
    pos = {} if status != "ok" else {"X": x, "Y": 0.0, "Z": 0.0}
    state(CaptureEvent("control", "linear-x1", t, ControlSample(t, pos, status=status)
                       .to_json()))


def test_state_rows_values_and_the_reading_expected():
    wall = Wall()
    st = LiveState("VMC", wall=wall)
    st.set_sources("sim", "sim")
    _start(st)
    snap = st.snapshot()
    m = snap["measurements"][0]
    assert [d["status"] for d in m["dwells"]] == ["pending"] * 3
    # position along the line from the first target [mm]
    assert [d["along"] for d in m["dwells"]] == [0.0, 100.0, 200.0]
    assert snap["expected"] == 0
    st(CaptureEvent("accepted", "linear-x1", 3.0, {
        "reading": 0, "value": 0.0, "raw": 5000.12, "sigma": 0.01, "n": 40,
        "pos": [5.0, 0.0, 0.0], "window": [2.0, 3.0]}))
    st(CaptureEvent("missed", "linear-x1", 9.0, {"reading": 1, "reason": "no laser"}))
    snap = st.snapshot()
    d = snap["measurements"][0]["dwells"]
    assert d[0]["status"] == "accepted" and d[0]["value"] == 0.0 and d[0]["raw"] == 5000.12
    assert d[1]["status"] == "missed" and d[1]["reason"] == "no laser"
    assert snap["expected"] == 2
    assert snap["counts"] == {"planned": 3, "accepted": 1, "missed": 1}


def test_state_resumed_readings_are_shown_as_recorded():
    st = LiveState("VMC", wall=Wall())
    _start(st, done=[0, 1], values={0: 0.0, 1: 1.25}, missed=[1])
    d = st.snapshot()["measurements"][0]["dwells"]
    assert [x["status"] for x in d] == ["accepted", "missed", "pending"]
    assert d[0]["value"] == 0.0 and d[1]["value"] is None


def test_banner_when_a_source_stops_sending():
    wall = Wall()
    st = LiveState("VMC", stale_s=2.0, wall=wall)
    st.set_sources("opcua:opc.tcp://cnc:4840", "sim")
    _start(st)
    _ctrl(st, 0.0, 5.0)
    st(CaptureEvent("laser", "linear-x1", 0.0, {"t": 0.0, "v": 1.0, "unit": "um"}))
    assert st.snapshot()["banners"] == []
    wall.t += 1.9
    _ctrl(st, 1.9, 5.0)
    assert st.snapshot()["banners"] == []
    wall.t += 0.2  # the laser: 2.1 s without a sample
    snap = st.snapshot()
    assert snap["laser"]["stale"] and not snap["control"]["stale"]
    assert snap["banners"] == ["The laser source sim stopped sending 2 s ago (no sample)"]
    # a lost connection is announced at once, with its reason
    st(CaptureEvent("laser", "linear-x1", 2.1, {"t": 2.1, "v": 1.0, "unit": "um"}))
    _ctrl(st, 2.1, 0.0, status="lost: ConnectionError: closed")
    snap = st.snapshot()
    assert snap["control"]["stale"] and snap["control"]["positions"] == {}
    assert snap["banners"] == ["The control source opcua:opc.tcp://cnc:4840 stopped sending "
                               "0 s ago (lost: ConnectionError: closed)"]
    _ctrl(st, 2.2, 5.0)
    assert st.snapshot()["banners"] == []
    # the loop's own 'stale' event sets the banner too, 'fresh' clears it
    st(CaptureEvent("stale", "linear-x1", 2.3, {"source": "control", "silent_s": 2.0}))
    assert st.snapshot()["control"]["stale"]
    st(CaptureEvent("fresh", "linear-x1", 2.4, {"source": "control"}))
    assert not st.snapshot()["control"]["stale"]


def test_a_typed_laser_is_silent_without_a_banner_and_the_end_is_shown():
    wall = Wall()
    st = LiveState("VMC", typed=TypedQueue(), wall=wall)
    st.set_sources("sim", "typed")
    _start(st)
    _ctrl(st, 0.0, 5.0)
    wall.t += 30.0
    _ctrl(st, 30.0, 5.0)
    snap = st.snapshot()
    assert snap["laser"]["typed"] and snap["banners"] == []
    st.finish("capture stopped", error="disconnected: bridge died")
    assert st.snapshot()["banners"] == ["The capture stopped: disconnected: bridge died"]


def test_stability_indicator_from_the_recent_samples():
    wall = Wall()
    st = LiveState("VMC", wall=wall, window_mm=0.01)
    _start(st)
    for k in range(10):  # moving towards the first target
        wall.t += 0.05
        _ctrl(st, k * 0.05, 4.0 + 0.1 * k)
    assert st.snapshot()["stability"]["state"] == "moving"
    wall.t += 1.5
    for k in range(10):  # at rest on it, within the window
        wall.t += 0.05
        _ctrl(st, 2 + k * 0.05, 5.0 + 0.001 * (k % 2))
    s = st.snapshot()["stability"]
    assert s["state"] == "at target"
    assert s["distance_mm"] <= 0.001 and s["control_spread_mm"] == 0.001


def _typed_source(hold_mm=0.01):
    where = {"c": None}
    q = TypedQueue()
    clock = Clock()
    ctx = SourceContext(clock=clock, latest_control=lambda: where["c"], extras={"typed": q})
    src = make_laser("typed" if hold_mm == 0.01 else f"typed:hold_mm={hold_mm}", ctx)
    assert isinstance(src, TypedLaser)
    return q, src, where, clock


def _sleep_poll(src):
    import time

    time.sleep(0.01)
    return src.poll()


def test_typed_source_holds_the_value_while_the_control_stays():
    q, src, where, _ = _typed_source()
    src.open()
    assert q.connected
    where["c"] = ControlSample(0.0, {"X": 105.0, "Y": 0.0, "Z": 0.0})
    assert _sleep_poll(src) is None  # nothing typed yet
    q.put(12.5, "um")
    s = _sleep_poll(src)
    assert s.value == 12.5 and s.unit == "um" and s.extra["typed"] == 1
    assert src.poll() is None  # the loop drains until None: one sample per poll
    where["c"] = ControlSample(1.0, {"X": 105.008, "Y": 0.0, "Z": 0.0})  # servo jitter
    assert _sleep_poll(src).value == 12.5
    where["c"] = ControlSample(2.0, {"X": 105.02, "Y": 0.0, "Z": 0.0})  # moves on
    assert _sleep_poll(src) is None
    where["c"] = ControlSample(3.0, {"X": 105.0, "Y": 0.0, "Z": 0.0})
    assert _sleep_poll(src) is None  # dropped: never taken at the next target
    q.put(1.0, "mm")
    q.put(2.0, "mm")  # the newest typed value wins
    assert _sleep_poll(src).value == 2.0


@pytest.mark.parametrize("value, unit, match", [
    (math.nan, "um", "finite number"), (math.inf, "um", "finite number"),
    (1.0, "furlong", "unit 'furlong'"),
])
def test_typed_queue_refuses_bad_input(value, unit, match):
    with pytest.raises(VolcalInputError, match=match):
        TypedQueue().put(value, unit)


def test_typed_source_needs_the_page():
    ctx = SourceContext(clock=Clock())
    with pytest.raises(SourceError, match="--serve"):
        make_laser("typed", ctx)
    with pytest.raises(VolcalInputError, match="hold_mm"):
        make_laser("typed:hold_mm=-1", SourceContext(clock=Clock(), extras={
            "typed": TypedQueue()}))


def _get(url):
    with urllib.request.urlopen(url, timeout=10) as r:
        return r.status, dict(r.headers), r.read()


def _post(url, body, ctype="application/json"):
    req = urllib.request.Request(url, data=body.encode(), method="POST",
                                 headers={"Content-Type": ctype})
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


@pytest.fixture
def page():
    p = Page("VMC", "sim", "typed", port=0)
    try:
        yield p
    finally:
        p.close()


def test_server_binds_loopback_and_serves_local_assets_only(page):
    assert page.url.startswith("http://127.0.0.1:")
    status, headers, body = _get(page.url)
    assert status == 200 and "default-src 'self'" in headers["Content-Security-Policy"]
    html = body.decode()
    for name in ("page.js", "page.css"):
        assert f"/static/{name}" in html
        s, _, asset = _get(page.url + "static/" + name)
        assert s == 200 and b"http://" not in asset and b"https://" not in asset
    assert "http://" not in html and "https://" not in html
    with pytest.raises(urllib.error.HTTPError) as e:
        _get(page.url + "static/server.py")
    assert e.value.code == 404
    status, _, body = _get(page.url + "api/state")
    snap = json.loads(body)
    assert snap["title"] == "VMC" and snap["laser"]["typed"] is True


def test_typed_reading_posted_reaches_the_queue(page):
    url = page.url + "api/typed"
    assert _post(url, "value=1", "application/x-www-form-urlencoded")[0] == 415
    code, body = _post(url, json.dumps({"value": "abc"}))
    assert code == 400 and "abc" in body["error"]
    code, body = _post(url, json.dumps({"value": 1.0, "unit": "parsec"}))
    assert code == 400 and "parsec" in body["error"]
    code, body = _post(url, json.dumps({"value": "12,75", "unit": "um"}))
    assert code == 200 and body["value"] == 12.75 and body["state"] == "queued"
    r = page.extras["typed"].take()
    assert (r.value, r.unit) == (12.75, "um")
    # an angle typed for a length measurement would stop the capture: refused here
    _start(page.observer)
    code, body = _post(url, json.dumps({"value": 3.0, "unit": "arcsec"}))
    assert code == 400 and "reads lengths" in body["error"]
    assert page.extras["typed"].take() is None
    assert page.observer.snapshot()["typed_log"][0]["value"] == 12.75


def test_no_typed_laser_refuses_typed_readings():
    p = Page("VMC", "sim", "sim", port=0)
    try:
        code, body = _post(p.url + "api/typed", json.dumps({"value": 1.0}))
        assert code == 400 and "--laser typed" in body["error"]
        assert p.extras == {}
    finally:
        p.close()


def test_events_stream_pushes_the_state(page):
    with urllib.request.urlopen(page.url + "events", timeout=10) as r:
        assert r.headers["Content-Type"] == "text/event-stream"
        line = r.readline().decode()
    assert line.startswith("data: ")
    snap = json.loads(line[len("data: "):])
    assert snap["title"] == "VMC" and "measurements" in snap


def test_port_in_use_is_a_clear_error(page):
    port = int(page.url.rsplit(":", 1)[1].strip("/"))
    with pytest.raises(VolcalInputError, match=f"cannot serve the capture page on "
                                               f"127.0.0.1:{port}"):
        PageServer(LiveState(), "127.0.0.1", port).start()


def test_cli_serve_prints_the_page_and_captures(tmp_path, monkeypatch, capsys):
    from volcal.plan.planner import plan_session
    from volcal.session.format import write_session

    s = plan_session(np.array([[0, 100], [0, 100], [0, 100]], float), "XYFZ", 2,
                     ("linear:x",), 1, name="CLI")
    write_session(s, tmp_path / "s")
    mid = s.measurements[0].id
    code, out, err = run_volcal(monkeypatch, capsys, "capture", str(tmp_path / "s"),
                                "--control", "sim", "--laser", "sim", "--measurement", mid,
                                "--serve", "--port", "0")
    assert code == 0, out + err
    assert "page: http://127.0.0.1:" in out and "captured" in out


def test_cli_typed_readings_need_the_page(tmp_path, monkeypatch, capsys):
    from volcal.plan.planner import plan_session
    from volcal.session.format import write_session

    s = plan_session(np.array([[0, 100], [0, 100], [0, 100]], float), "XYFZ", 2,
                     ("linear:x",), 1, name="CLI")
    write_session(s, tmp_path / "s")
    code, out, err = run_volcal(monkeypatch, capsys, "capture", str(tmp_path / "s"),
                                "--control", "sim", "--laser", "typed")
    assert code == 2
    assert "laser source 'typed'" in err and "add --serve" in err
    assert "Traceback" not in err
