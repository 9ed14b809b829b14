"""Laser readings a vendor program appends to a file: ``--laser file:PATH[;KEY=V...]``.

The file is followed as ``tail -f`` does: the lines already in it when the capture starts
are old readings and are skipped (``from=start`` reads them too); each line appended
afterwards is parsed by :class:`volcal.capture.stream.LineParser` (the same keys:
``format``, ``pattern``, ``unit``, ``column``...). A file that shrinks (the vendor program
started a new one) is read again from its start. A line is used once it ends with a line
break, so a line being written is never read half.
"""

from __future__ import annotations

import collections
import os
from pathlib import Path

from volcal.capture.samples import LaserSample
from volcal.capture.sources import (
    SourceContext,
    SourceError,
    SourceSpec,
    options,
    register_laser,
)
from volcal.capture.stream import PARSER_KEYS, LineParser, split_address
from volcal.errors import VolcalInputError

__all__ = ["FileTailLaser"]


class FileTailLaser:
    """The ``file:`` laser source (see the module's docstring)."""

    def __init__(self, spec: SourceSpec, ctx: SourceContext) -> None:
        address, rest = split_address(spec.argument)
        if not address:
            raise VolcalInputError(f"source {spec.text!r}: give the file: file:PATH")
        opts = options(rest, spec.text, (*PARSER_KEYS, "from"))
        self.parser = LineParser(opts, spec.text)
        frm = opts.get("from", "end").lower()
        if frm not in ("end", "start"):
            raise VolcalInputError(f"source {spec.text!r}: from={frm!r}: expected end or start")
        self.from_start = frm == "start"
        self.path, self.where, self.ctx = Path(address), spec.text, ctx
        if self.path.is_dir():
            raise VolcalInputError(f"source {spec.text!r}: {address} is a folder: give the "
                                   "file the vendor program appends its readings to")
        if not self.path.parent.is_dir():
            raise VolcalInputError(f"source {spec.text!r}: the folder {str(self.path.parent)!r}"
                                   " does not exist: give the file the vendor program appends "
                                   "its readings to (it may be created once the capture runs)")
        self._pos = 0
        self._buf = b""
        self._ready: collections.deque[LaserSample] = collections.deque()

    def open(self) -> None:
        """Note where the file ends now (or wait for it to be created)."""
        try:
            self._pos = 0 if self.from_start else self.path.stat().st_size
        except FileNotFoundError:
            self._pos = 0  # the vendor program creates it when it starts
        except OSError as e:
            raise SourceError(f"laser {self.where!r}: {e.strerror}") from None

    def close(self) -> None:
        """Nothing held open between polls."""

    def _read_more(self) -> None:
        try:
            size = os.stat(self.path).st_size
        except FileNotFoundError:
            return
        if size < self._pos:  # a new file in its place
            self._pos, self._buf = 0, b""
        if size == self._pos:
            return
        try:
            with self.path.open("rb") as f:
                f.seek(self._pos)
                data = f.read(size - self._pos)
        except OSError as e:
            raise SourceError(f"laser {self.where!r}: {e.strerror}") from None
        self._pos += len(data)
        self._buf += data
        *lines, self._buf = self._buf.replace(b"\r\n", b"\n").split(b"\n")
        now = self.ctx.clock.now()
        for raw in lines:
            s = self.parser.parse(raw.decode("utf-8", "replace"), now)
            if s is not None:
                self._ready.append(s)

    def poll(self) -> LaserSample | None:
        """The next reading appended, or None."""
        if not self._ready:
            self._read_more()
        return self._ready.popleft() if self._ready else None


register_laser("file", FileTailLaser, "lines a vendor program appends to a file")
