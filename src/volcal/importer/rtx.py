"""Renishaw dynamic capture (``.rtx``): the samples of one quantity, cut at the dwells.

A dynamic capture of the XL-80 software records one quantity (a linear displacement, a
straightness or an angle) at a fixed sample rate while the part program runs. The file
is a text header and a block of samples (``docs/formats.md``, "Dynamic capture"; the
layout as the open readers TanmayPani/rtx2csv and travdt/RTX2CSV-Converter read it)::

    HEADER::\\r\\n
    Filename: ...\\r\\n          one "Key: value" line each (a line ending in "::" is a
    Owner: ...\\r\\n             section title): Filename, Owner, Version no, File Type,
    ...                         Velocity, Sample rate, Sample no, Trigger point, Trigger
    Actual sample rate: 50000   interval, Actual sample rate, Flags, Machine, Serial No,
    ...                         Date, By, Axis, Location
    Data:\\r\\n
    <Sample no> little-endian IEEE-754 float64 samples (mm for lengths, mrad for angles)
    [\\r\\n]EOF::\\r\\n

The reading at each planned pose is the mean of the samples of the dwell at it: the
stretches where the signal is still (:func:`find_dwells`), one per planned pose, in the
planned order. Nothing else of the capture (motion, settling, overrun) is used.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["DATA_MARK", "HEADER_MARK", "SPLIT_T", "Dwell", "RtxCapture", "dwell_readings",
           "find_dwells", "read_rtx"]

HEADER_MARK = b"HEADER::\r\n"
"""First bytes of every ``.rtx`` file."""

DATA_MARK = b"Data:\r\n"
"""End of the header: the samples follow."""

_EOF = re.compile(rb"^(\r\n)?EOF::(\r\n)?\s*$")
_MAX_HEADER = 1 << 16


@dataclass
class RtxCapture:
    """A dynamic capture as read.

    Attributes
    ----------
    header : dict of str to str
        The header's ``Key: value`` lines as written (``'Sample rate'``, ``'Date'``...).
    rate_hz : float
        Samples per second [Hz] (``Actual sample rate``, else ``Sample rate``).
    samples : ndarray
        The samples in the capture's unit (mm or mrad).
    notes : list of str
        What the reader found (a trailer missing, ...).
    """

    header: dict[str, str]
    rate_hz: float
    samples: NDArray[np.float64]
    notes: list[str] = field(default_factory=list)


def _header(raw: bytes, path: Path) -> dict[str, str]:
    out: dict[str, str] = {}
    for line in raw.split(b"\r\n"):
        text = line.decode("utf-8", errors="replace").strip()
        if not text or text.endswith("::"):
            continue  # empty, or a section title
        key, sep, value = text.partition(":")
        if not sep:
            raise VolcalInputError(f"header line {text[:60]!r} is not 'Key: value'", path)
        out.setdefault(key.strip(), value.strip())
    return out


def _number(header: dict[str, str], key: str, path: Path) -> float | None:
    if not header.get(key):
        return None
    try:
        v = float(header[key].replace(",", "."))
    except ValueError:
        raise VolcalInputError(f"header {key!r}: {header[key]!r} is not a number", path,
                               column=key) from None
    return v


def read_rtx(path: str | Path) -> RtxCapture:
    """Read a Renishaw dynamic-capture file.

    Parameters
    ----------
    path : str or Path
        The ``.rtx`` file.

    Returns
    -------
    RtxCapture

    Raises
    ------
    VolcalInputError
        Not an ``.rtx`` file (no ``HEADER::``, no ``Data:``), no sample rate, fewer
        samples than the header declares, or bytes after the samples that are not the
        ``EOF::`` trailer.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise VolcalInputError("file not found", path) from None
    except OSError as exc:
        raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
    if not raw.startswith(HEADER_MARK):
        raise VolcalInputError("not a Renishaw dynamic capture: an .rtx file starts with "
                               "'HEADER::'", path)
    end = raw.find(DATA_MARK, len(HEADER_MARK), _MAX_HEADER)
    if end < 0:
        raise VolcalInputError("no 'Data:' line after the header: not a complete .rtx file",
                               path)
    header = _header(raw[len(HEADER_MARK):end], path)
    rate = _number(header, "Actual sample rate", path) or _number(header, "Sample rate", path)
    if rate is None or not np.isfinite(rate) or rate <= 0:
        raise VolcalInputError("no sample rate in the header ('Actual sample rate' or "
                               "'Sample rate' > 0): the samples have no time", path,
                               column="Sample rate")
    body = raw[end + len(DATA_MARK):]
    notes: list[str] = []
    declared = _number(header, "Sample no", path)
    if declared is not None:
        n = int(declared)
        if declared != n or n < 0:
            raise VolcalInputError(f"header 'Sample no' {header['Sample no']!r}: expected a "
                                   "whole number", path, column="Sample no")
        if 8 * n > len(body):
            raise VolcalInputError(f"the header declares {n} samples but the file holds "
                                   f"{len(body) // 8}: an incomplete capture", path,
                                   column="Sample no")
        tail = body[8 * n:]
    else:
        m = re.search(rb"(\r\n)?EOF::(\r\n)?\s*$", body)
        data = body if m is None else body[:m.start()]
        n = len(data) // 8
        tail = body[8 * n:]
        notes.append(f"no 'Sample no' in the header: {n} samples up to the end")
    if tail and not _EOF.match(tail):
        raise VolcalInputError(f"{len(tail)} bytes after the {n} samples are not the "
                               "'EOF::' trailer: is 'Sample no' right?", path, column="Sample no")
    if not tail:
        notes.append("no 'EOF::' trailer")
    samples = np.frombuffer(body[:8 * n], dtype="<f8").astype(np.float64)
    return RtxCapture(header, float(rate), samples, notes)


@dataclass
class Dwell:
    """One dwell found in a capture.

    Attributes
    ----------
    start, stop : int
        The samples averaged, ``samples[start:stop]``.
    mean : float
        Their mean, in the capture's unit.
    std : float
        Their standard deviation, in the capture's unit.
    time_s : float
        Time of the middle of the dwell since the first sample [s].
    """

    start: int
    stop: int
    mean: float
    std: float
    time_s: float


def _noise(x: NDArray[np.float64]) -> float:
    """Robust noise of the samples from their second differences.

    Motion at a constant velocity has none: ``1.4826 median|d2| / sqrt(6)``.
    """
    if x.size < 3:
        return 0.0
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    return float(1.4826 * np.median(np.abs(d2)) / np.sqrt(6.0))


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(),
                    strict=True))


SPLIT_T = 8.0
"""Least step between two parts of a still stretch, in standard errors of their mean
difference, that splits it into two dwells (:func:`find_dwells` with ``n``)."""


def _split(x: NDArray[np.float64], a: int, b: int, m: int, sigma: float) -> tuple[float, int]:
    """Best split of ``x[a:b]`` into two parts of ``m`` samples or more: (t, index)."""
    if b - a < 2 * m + 1:
        return 0.0, a
    c = np.concatenate([[0.0], np.cumsum(x[a:b])])
    k = np.arange(m, b - a - m + 1)
    left = c[k] / k
    right = (c[-1] - c[k]) / (b - a - k)
    t = np.abs(left - right) / (sigma * np.sqrt(1.0 / k + 1.0 / (b - a - k)))
    i = int(np.argmax(t))
    return float(t[i]), a + int(k[i])


def find_dwells(samples: NDArray[np.float64], rate_hz: float, dwell_s: float,
                n: int | None = None, trim: float = 0.1) -> list[Dwell]:
    """The dwells of a capture: stretches where the signal is still.

    A window of a quarter of the dwell slides over the samples; the signal is still at
    the window's centre when the straight line fitted to the window changes by less than
    5 standard errors across it and the scatter about the line is below twice the noise
    (the noise from the second differences, which motion at a constant velocity does
    not have). Still stretches at least a quarter of ``dwell_s`` long are dwells; their
    first and last ``trim`` share is left out (settling), the rest averaged.

    Parameters
    ----------
    samples : ndarray
        The capture [any unit].
    rate_hz : float
        Sample rate [Hz].
    dwell_s : float
        The part program's dwell at each target [s] (``volcal program --dwell-s``).
    n : int, optional
        The dwells expected: while fewer are found, the still stretch with the largest
        step between its two parts (at least :data:`SPLIT_T` standard errors) is split
        there, a window's width on each side of the step left out (a move too small for the
        window: two targets whose readings differ by about the noise).
    trim : float
        Share of each still stretch left out at both ends.

    Returns
    -------
    list of Dwell
        In time order.
    """
    x = np.asarray(samples, dtype=float)
    d = int(round(dwell_s * rate_hz))
    w = max(5, d // 4)
    if x.size < w or not np.all(np.isfinite(x)):
        finite = np.isfinite(x)
        if x.size >= w and not finite.all():
            raise VolcalInputError(f"sample {int(np.flatnonzero(~finite)[0]) + 1} is not a "
                                   "number (beam lost?)")
        return []
    x0 = x - np.median(x)
    sigma = max(_noise(x0), 1e-10 * float(np.max(np.abs(x))), 1e-300)
    j = np.arange(w, dtype=float) - (w - 1) / 2.0
    slope = -np.convolve(x0, j, mode="valid") / float(j @ j)  # least-squares slope per window
    drift = np.abs(slope) * (w - 1)
    # scatter about the line from the second differences (no cancellation against a
    # large reading, as a running variance of a linear capture at 800 mm would have)
    d2 = np.concatenate([[0.0], x0[2:] - 2.0 * x0[1:-1] + x0[:-2], [0.0]])
    c = np.concatenate([[0.0], np.cumsum(d2 * d2)])
    scatter = np.sqrt((c[w:] - c[:-w]) / (6.0 * w))
    still = (drift < 5.0 * sigma * np.sqrt(12.0 / w)) & (scatter < 2.0 * sigma)
    mask = np.zeros(x.size, dtype=bool)
    mask[(w - 1) // 2:(w - 1) // 2 + still.size] = still
    runs = [(a, b) for a, b in _runs(mask) if b - a >= max(3, d // 4)]
    while n is not None and len(runs) < n:  # dwells joined by a move the window missed
        best = max(((_split(x0, a, b, max(3, d // 4), sigma), k)
                    for k, (a, b) in enumerate(runs)), default=((0.0, 0), 0))
        (t, at), k = best
        if t < SPLIT_T:
            break
        a, b = runs[k]
        runs[k:k + 1] = [(a, at - w), (at + w, b)]
    out = []
    for a, b in runs:
        cut = int(trim * (b - a))
        a2, b2 = a + cut, b - cut
        seg = x[a2:b2]
        out.append(Dwell(a2, b2, float(seg.mean()), float(seg.std()),
                         (a2 + b2 - 1) / 2.0 / rate_hz))
    return out


def dwell_readings(capture: RtxCapture, n: int, dwell_s: float, path: str | Path
                   ) -> list[Dwell]:
    """The ``n`` dwells of a capture, one per planned pose.

    Parameters
    ----------
    capture : RtxCapture
        As read.
    n : int
        Planned poses.
    dwell_s : float
        The part program's dwell [s].
    path : str or Path
        The file (for messages).

    Returns
    -------
    list of Dwell

    Raises
    ------
    VolcalInputError
        Another number of dwells than planned poses (their times are named).
    """
    try:
        dwells = find_dwells(capture.samples, capture.rate_hz, dwell_s, n)
    except VolcalInputError as exc:
        raise VolcalInputError(exc.message, path) from None
    if len(dwells) != n:
        times = ", ".join(f"{d.time_s:.1f}" for d in dwells[:12])
        more = " ..." if len(dwells) > 12 else ""
        raise VolcalInputError(
            f"{len(dwells)} dwells found in the capture ({capture.samples.size} samples at "
            f"{capture.rate_hz:g} Hz; still at {times}{more} s), but the measurement is "
            f"planned with {n} poses: one dwell per planned pose, in the planned order. Is "
            f"--dwell-s ({dwell_s:g} s) the part program's dwell, and does the capture hold "
            "exactly this measurement (no idle time at another position)?", path)
    return dwells
