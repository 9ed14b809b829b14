"""Laser sources: the line parser, TCP, a serial port (a pseudo-terminal), a pipe, a file."""

from __future__ import annotations

import math
import os
import socket
import threading
import time

import pytest

from timing import scaled_timeout
from volcal.capture.samples import to_base_unit
from volcal.capture.sources import Clock, SourceContext, SourceError, make_laser, parse_spec
from volcal.capture.stream import LineParser
from volcal.errors import VolcalInputError


@pytest.mark.parametrize("line,value,unit", [
    ("  216.0253 mm", 216.0253, "mm"),
    ("X: -0.00123 mm  T=20.1C", -0.00123, "mm"),
    ("+1.2345E+02 um", 123.45, "um"),
    ("12.5 arcsec", 12.5, "arcsec"),
    ("0.5", 0.5, "mm"),               # no unit in the line: the default
    ("-3.2um", -3.2, "um"),
    (".75 nm", 0.75, "nm"),
])
def test_default_pattern(line, value, unit):
    s = LineParser({}, "stream:-").parse(line, 1.5)
    assert s is not None and s.value == pytest.approx(value) and s.unit == unit
    assert s.time_s == 1.5


def test_regex_with_time_scale_and_bad_lines():
    p = LineParser({"pattern": r"t=(?P<time>[\d.]+)\s+pos=(?P<value>[-\d.]+)",
                    "unit": "um", "scale": "-1", "bad": "BEAM"}, "x")
    s = p.parse("t=12.25 pos=3.5", 0.0)
    assert (s.value, s.unit, s.device_time_s) == (-3.5, "um", 12.25)
    bad = p.parse("t=13 BEAM LOST", 0.0)
    assert bad.status == "bad" and math.isnan(bad.value)
    assert p.parse("hello", 0.0) is None and p.unparsed == 1
    assert to_base_unit(s.value, s.unit) == (-3.5, "um")
    assert to_base_unit(1.0, "arcsec")[0] == pytest.approx(4.8481368, rel=1e-7)


def test_csv_format():
    p = LineParser({"format": "csv", "sep": ";", "column": "3", "unit_column": "4",
                    "time_column": "1"}, "x")
    s = p.parse("0.52;X;216.02531;mm", 0.0)
    assert (s.value, s.unit, s.device_time_s) == (216.02531, "mm", 0.52)
    assert p.parse("0.52;X;;mm", 0.0) is None


@pytest.mark.parametrize("opts,msg", [
    ({"format": "xml"}, "format='xml'"), ({"unit": "furlong"}, "unit='furlong'"),
    ({"pattern": "(("}, "not a regular expression"),
    ({"pattern": r"\d+"}, "no group (?P<value>"), ({"format": "csv", "column": "0"}, "column"),
])
def test_parser_options_are_checked(opts, msg):
    with pytest.raises(VolcalInputError, match=msg.replace("(", r"\(").replace("?", r"\?")):
        LineParser(opts, "stream:-")


def _ctx() -> SourceContext:
    return SourceContext(Clock())


def _collect(src, n: int):
    out, deadline = [], time.monotonic() + scaled_timeout(20)
    while len(out) < n:
        s = src.poll()
        if s is None:
            assert time.monotonic() < deadline
            time.sleep(0.005)
        else:
            out.append(s)
    return out


def test_tcp_stream_and_its_end():
    srv = socket.create_server(("127.0.0.1", 0))
    port = srv.getsockname()[1]

    def serve():
        c, _ = srv.accept()
        c.sendall(b"1.000 mm\r\n2.5")
        time.sleep(0.05)
        c.sendall(b"00 mm\r\n3.000 mm\n")  # a line split across two packets
        time.sleep(0.05)
        c.close()

    threading.Thread(target=serve, daemon=True).start()
    src = make_laser(f"stream:tcp://127.0.0.1:{port};unit=um", _ctx())
    src.open()
    try:
        got = _collect(src, 3)
        assert [(s.value, s.unit) for s in got] == [(1.0, "mm"), (2.5, "mm"), (3.0, "mm")]
        deadline = time.monotonic() + scaled_timeout(10)
        with pytest.raises(SourceError, match="the stream ended"):
            while time.monotonic() < deadline:
                assert src.poll() is None
                time.sleep(0.01)
    finally:
        src.close()
        srv.close()


def test_serial_port_through_a_pseudo_terminal():
    master, slave = os.openpty()
    name = os.ttyname(slave)
    src = make_laser(f"stream:{name};baud=115200;unit=um", _ctx())
    src.open()
    try:
        os.write(master, b"10.5\r\n-2.25 um\r\n")
        got = _collect(src, 2)
        assert [(s.value, s.unit) for s in got] == [(10.5, "um"), (-2.25, "um")]
    finally:
        src.close()
        os.close(master)
        os.close(slave)


def test_named_pipe(tmp_path):
    fifo = tmp_path / "laser.fifo"
    os.mkfifo(fifo)
    out = {}

    def writer():
        with open(fifo, "wb") as f:  # blocks until the source opens it
            f.write(b"0.001 mm\n0.002 mm\n")
        out["done"] = True

    threading.Thread(target=writer, daemon=True).start()
    src = make_laser(f"stream:{fifo}", _ctx())
    src.open()
    try:
        assert [s.value for s in _collect(src, 2)] == [0.001, 0.002]
    finally:
        src.close()


def test_file_appended_by_a_vendor_program(tmp_path):
    f = tmp_path / "export.txt"
    f.write_text("old 1.0 mm\nold 2.0 mm\n")
    src = make_laser(f"file:{f};pattern=pos (?P<value>[-\\d.]+)", _ctx())
    src.open()
    assert src.poll() is None  # the lines already there are old readings
    with f.open("a") as h:
        h.write("pos 5.5\npos 6.")  # the second line is being written
    assert src.poll().value == 5.5 and src.poll() is None
    with f.open("a") as h:
        h.write("25\n")
    assert src.poll().value == 6.25
    f.write_text("pos 7\n")  # a new file in its place
    assert src.poll().value == 7.0


def test_source_syntax():
    assert parse_spec("opcua:opc.tcp://10.0.0.5:4840", "control").argument == \
        "opc.tcp://10.0.0.5:4840"
    assert parse_spec(" Stream:- ", "laser").name == "stream"
    with pytest.raises(VolcalInputError, match="unknown laser source 'laser9'"):
        make_laser("laser9", _ctx())
    with pytest.raises(VolcalInputError, match="give an address"):
        make_laser("stream:", _ctx())
    with pytest.raises(SourceError, match="cannot open"):
        make_laser("stream:/nonexistent/tty", _ctx()).open()
