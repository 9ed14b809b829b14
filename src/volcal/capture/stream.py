"""Laser readings from a line stream: a TCP socket, a serial port or a pipe.

``--laser stream:ADDRESS[;KEY=VALUE...]``. The address is ``tcp://HOST:PORT`` (the laser
software or a serial-to-network adapter sends one line per reading), a device path
(``/dev/ttyUSB0``: a serial port, configured here as raw 8N1 at ``baud``), a named pipe or
file path, or ``-`` (standard input: ``vendor-tool | volcal capture ... --laser
stream:-``). Each line is parsed by :class:`LineParser`; its keys:

==============  ==============  ==========================================================
key             default         meaning
==============  ==============  ==========================================================
``format``      ``regex``       ``regex`` (a pattern with named groups) or ``csv``
``pattern``     the first       the regular expression (Python syntax) with the group
                number, then    ``value`` and, optionally, ``unit`` and ``time``; the
                an optional     first match in the line is used
                unit
``sep``         ``,``           ``csv``: the separator (``tab`` for a tab)
``column``      1               ``csv``: the column of the value (1 = first)
``unit_column`` -               ``csv``: the column of the unit
``time_column`` -               ``csv``: the column of the laser's own time [s]
``unit``        ``mm``          the unit of a value whose line names none (``um``,
                                ``mm``, ``nm``, ``in``, ``urad``, ``arcsec``...)
``scale``       1               factor applied to every value (``-1`` when the laser
                                counts the other way)
``bad``         -               a regular expression: a matching line is a reading the
                                laser marks as bad (``BEAM|ERR``), never used
``channels``    1               values per reading: 3 for an R-test's nest
                                (``dx,dy,dz`` or the three sensors): ``csv``: the
                                columns ``column`` and the next ones; ``regex``: the
                                first ``channels`` matches of ``pattern`` in the line
                                (the default pattern: its first numbers)
``baud``        9600            serial port speed
==============  ==============  ==========================================================

A line that does not parse is counted and left out (the capture's journal says how
many). Every reading is stamped with the capture's clock when it arrives; the laser's own
time, when the line carries one, is journaled beside it. The ``file:`` source
(:mod:`volcal.capture.filetail`) uses the same parser.
"""

from __future__ import annotations

import contextlib
import os
import queue
import re
import socket
import stat
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from volcal.capture.samples import ANGULAR_UNITS, LINEAR_UNITS, LaserSample
from volcal.capture.sources import (
    SourceContext,
    SourceError,
    SourceSpec,
    options,
    register_laser,
)
from volcal.errors import VolcalInputError

__all__ = ["DEFAULT_PATTERN", "LineParser", "StreamLaser", "split_address"]

_UNITS = "|".join(sorted((re.escape(u) for u in {*LINEAR_UNITS, *ANGULAR_UNITS}),
                         key=len, reverse=True))
DEFAULT_PATTERN = (r"(?P<value>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*"
                   rf"(?P<unit>{_UNITS})?(?![A-Za-z])")
"""The first number of the line, and the unit written after it if any."""

PARSER_KEYS = ("format", "pattern", "sep", "column", "unit_column", "time_column", "unit",
               "scale", "bad", "channels")


class LineParser:
    """Parse one line of a laser's output into a value, a unit and a time.

    Parameters
    ----------
    opts : dict of str to str
        The keys of the module's table (``format``, ``pattern``...).
    where : str
        The source as written, for the messages.
    """

    def __init__(self, opts: dict[str, str], where: str) -> None:
        self.where = where
        self.format = opts.get("format", "regex").lower()
        if self.format not in ("regex", "csv"):
            raise VolcalInputError(f"source {where!r}: format={self.format!r}: expected regex "
                                   "or csv")
        self.unit = opts.get("unit", "mm")
        if self.unit not in LINEAR_UNITS and self.unit not in ANGULAR_UNITS:
            raise VolcalInputError(f"source {where!r}: unit={self.unit!r}: expected one of "
                                   f"{', '.join(sorted({*LINEAR_UNITS, *ANGULAR_UNITS}))}")
        try:
            self.scale = float(opts.get("scale", "1"))
        except ValueError:
            raise VolcalInputError(f"source {where!r}: scale={opts['scale']!r} is not a "
                                   "number") from None
        self.pattern = self._regex(opts.get("pattern", DEFAULT_PATTERN), "pattern")
        if "value" not in self.pattern.groupindex:
            raise VolcalInputError(f"source {where!r}: pattern has no group (?P<value>...)")
        self.bad = self._regex(opts["bad"], "bad") if "bad" in opts else None
        sep = opts.get("sep", ",")
        self.sep = "\t" if sep.lower() == "tab" else sep
        self.column = self._col(opts, "column", 1)
        self.unit_column = self._col(opts, "unit_column", None)
        self.time_column = self._col(opts, "time_column", None)
        self.channels = self._col(opts, "channels", 1) or 1
        self.unparsed = 0

    def _regex(self, text: str, key: str) -> re.Pattern[str]:
        try:
            return re.compile(text)
        except re.error as e:
            raise VolcalInputError(f"source {self.where!r}: {key}={text!r} is not a regular "
                                   f"expression ({e})") from None

    def _col(self, opts: dict[str, str], key: str, default: int | None) -> int | None:
        if key not in opts:
            return default
        try:
            c = int(opts[key])
        except ValueError:
            c = 0
        if c < 1:
            raise VolcalInputError(f"source {self.where!r}: {key}={opts[key]!r}: expected a "
                                   f"{'count' if key == 'channels' else 'column number'} >= 1")
        return c

    def parse(self, line: str, time_s: float) -> LaserSample | None:
        """The sample of one line, or None when it holds no reading.

        Parameters
        ----------
        line : str
            One line of the stream, without its end.
        time_s : float
            Arrival time on the capture's clock [s].

        Returns
        -------
        LaserSample or None
        """
        text = line.strip()
        if not text:
            return None
        if self.bad is not None and self.bad.search(text):
            return LaserSample(time_s, float("nan"), self.unit, status="bad")
        if self.channels > 1:
            return self._several(text, time_s)
        value, unit, dev_t = (self._csv(text) if self.format == "csv" else self._re(text))
        if value is None:
            self.unparsed += 1
            return None
        return LaserSample(time_s, value * self.scale, unit or self.unit, device_time_s=dev_t)

    def _several(self, text: str, time_s: float) -> LaserSample | None:
        """A reading of ``channels`` values (an R-test's nest), or None (counted unparsed)."""
        got: list[tuple[float | None, str | None, float | None]] = []
        if self.format == "csv":
            for k in range(self.channels):
                c = self.column + k if self.column is not None else None
                got.append(self._csv(text, c))
        else:
            for m in list(self.pattern.finditer(text))[:self.channels]:
                got.append(self._match(m))
        if len(got) < self.channels or any(v is None for v, _, _ in got):
            self.unparsed += 1
            return None
        vals = tuple(float(v) * self.scale for v, _, _ in got if v is not None)
        unit = next((u for _, u, _ in got if u), None) or self.unit
        return LaserSample(time_s, vals[0], unit, device_time_s=got[0][2], channels=vals)

    def _re(self, text: str) -> tuple[float | None, str | None, float | None]:
        m = self.pattern.search(text)
        if m is None:
            return None, None, None
        return self._match(m)

    @staticmethod
    def _match(m: re.Match[str]) -> tuple[float | None, str | None, float | None]:
        g = m.groupdict()
        try:
            v = float(g["value"].replace(",", ".")) if g.get("value") else None
            t = float(g["time"]) if g.get("time") else None
        except ValueError:
            return None, None, None
        return v, g.get("unit") or None, t

    def _csv(self, text: str, column: int | None = None
             ) -> tuple[float | None, str | None, float | None]:
        cells = [c.strip() for c in text.split(self.sep)]

        def cell(k: int | None) -> str | None:
            return cells[k - 1] if k is not None and k <= len(cells) else None

        try:
            v = float(cell(column or self.column) or "x")
        except ValueError:
            return None, None, None
        t = cell(self.time_column)
        try:
            tt = float(t) if t else None
        except ValueError:
            tt = None
        return v, cell(self.unit_column) or None, tt


def split_address(argument: str) -> tuple[str, str]:
    """``ADDRESS;KEY=V;...`` -> (address, options text).

    Parameters
    ----------
    argument : str
        The text after ``stream:`` or ``file:``.

    Returns
    -------
    tuple of str
    """
    address, _, rest = argument.partition(";")
    return address.strip(), rest


class _SocketReader:
    """``read1``/``close`` on a socket (a socket file object fails after a timeout)."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock

    def read1(self, n: int) -> bytes:
        return self.sock.recv(n)

    def close(self) -> None:
        self.sock.close()


def _configure_tty(fd: int, baud: int, where: str) -> None:
    """Raw 8N1 at ``baud`` (POSIX termios)."""
    import termios
    import tty

    speed = getattr(termios, f"B{baud}", None)
    if speed is None:
        raise VolcalInputError(f"source {where!r}: baud={baud} is not a standard speed")
    tty.setraw(fd)
    attrs = termios.tcgetattr(fd)
    attrs[4] = attrs[5] = speed
    attrs[2] = (attrs[2] & ~(termios.PARENB | termios.CSTOPB | termios.CSIZE)) | termios.CS8 \
        | termios.CLOCAL | termios.CREAD
    termios.tcsetattr(fd, termios.TCSANOW, attrs)


class StreamLaser:
    """The ``stream:`` laser source: a reader thread fills a queue the capture polls."""

    def __init__(self, spec: SourceSpec, ctx: SourceContext) -> None:
        address, rest = split_address(spec.argument)
        if not address:
            raise VolcalInputError(f"source {spec.text!r}: give an address: "
                                   "stream:tcp://HOST:PORT, stream:/dev/ttyUSB0 or stream:-")
        opts = options(rest, spec.text, (*PARSER_KEYS, "baud"))
        self.parser = LineParser(opts, spec.text)
        self.baud = int(opts.get("baud", "9600")) if opts.get("baud", "9600").isdigit() else 0
        if self.baud <= 0:
            raise VolcalInputError(f"source {spec.text!r}: baud={opts.get('baud')!r}: expected "
                                   "a positive whole number")
        self.address, self.where, self.ctx = address, spec.text, ctx
        self._q: queue.Queue[LaserSample] = queue.Queue()
        self._thread: threading.Thread | None = None
        self._error: str | None = None
        self._stop = threading.Event()
        self._closers: list[Any] = []

    def _open_stream(self) -> IO[bytes]:
        a = self.address
        if a == "-":
            return sys.stdin.buffer
        if a.startswith("tcp://"):
            host, _, port = a[6:].rpartition(":")
            try:
                sock = socket.create_connection((host.strip("[]"), int(port)), timeout=5.0)
            except (OSError, ValueError) as e:
                raise SourceError(f"laser {self.where!r}: cannot connect ({e})") from None
            sock.settimeout(0.5)  # the reader looks at its stop flag twice a second
            self._closers.append(sock)
            return _SocketReader(sock)  # type: ignore[return-value]  # read1 and close only
        path = Path(a)
        try:
            mode = path.stat().st_mode
            fd = os.open(path, os.O_RDONLY | os.O_NOCTTY)
        except OSError as e:
            raise SourceError(f"laser {self.where!r}: cannot open {a} ({e.strerror})") from None
        if stat.S_ISCHR(mode) and os.isatty(fd):
            _configure_tty(fd, self.baud, self.where)
        return os.fdopen(fd, "rb", buffering=0)

    def open(self) -> None:
        """Connect and start reading."""
        f = self._open_stream()
        self._closers.append(f)
        self._thread = threading.Thread(target=self._read, args=(f,), daemon=True,
                                        name="volcal-laser-stream")
        self._thread.start()

    def _lines(self, f: IO[bytes]) -> Iterator[bytes]:
        buf = b""
        while not self._stop.is_set():
            try:
                chunk = f.read1(4096) if hasattr(f, "read1") else f.read(4096)
            except TimeoutError:
                continue
            except OSError as e:
                if self._stop.is_set():
                    return
                self._error = f"read failed ({e})"
                return
            if not chunk:
                self._error = "the stream ended"
                return
            buf += chunk
            *lines, buf = re.split(rb"\r\n|\r|\n", buf)
            yield from lines

    def _read(self, f: IO[bytes]) -> None:
        for raw in self._lines(f):
            s = self.parser.parse(raw.decode("utf-8", "replace"), self.ctx.clock.now())
            if s is not None:
                self._q.put(s)

    def poll(self) -> LaserSample | None:
        """The next reading received, or None."""
        try:
            return self._q.get_nowait()
        except queue.Empty:
            pass
        if self._error is not None and self._thread is not None and not self._thread.is_alive():
            raise SourceError(f"laser {self.where!r}: {self._error}")
        return None

    def close(self) -> None:
        """Stop reading and close the connection."""
        self._stop.set()
        for c in self._closers:
            if c is not sys.stdin.buffer:
                with contextlib.suppress(OSError):
                    c.close()
        self._closers.clear()


register_laser("stream", StreamLaser, "lines from tcp://HOST:PORT, a serial port or - (stdin)")
