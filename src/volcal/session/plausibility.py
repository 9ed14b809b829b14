"""Soft checks of a session's readings: each measurement consistent with the others.

Readings that are possible but unlikely give a warning naming the measurement (printed
by the commands, recorded in the identification's notes); absurd values are refused by
the reader itself (``docs/formats.md``, "Plausibility"). The checks:

* **scale** (mm entered as um): a measurement's robust spread per metre of travel (the
  5th to 95th percentile range of its deviations divided by its length) is compared
  with the median of the session's measurements of the same kind (all measurements
  when fewer than 3 share its kind); more than :data:`SCALE_RATIO` times the median
  (the median floored at :data:`SCALE_FLOOR_UM_PER_M`) is flagged;
* **sign** of a whole linear test: with at least 3 linear tests of one axis on the same
  targets, a test whose mean deviation per target ``c`` is much closer to minus each of
  the others than to it (``|c + o| < SIGN_RATIO |c - o|``), while the others agree with
  each other (``|o1 - o2| < SIGN_RATIO |o1 + o2|``), is flagged;
* **order** (a reversed CSV): poses moving against the beam direction of
  ``session.toml``; in a linear test, ``+`` rows whose positions descend; a first
  reading far from 0 (readings count from the first row, so reversed deviations start
  with the last reading).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from volcal.session.format import Measurement, Session

__all__ = ["FIRST_READING_UM", "SCALE_FLOOR_UM_PER_M", "SCALE_RATIO", "SIGN_RATIO",
           "plausibility_warnings"]

SCALE_RATIO = 30.0
"""A spread this many times the session's median is flagged [-]."""
SCALE_FLOOR_UM_PER_M = 2.0
"""Floor of the median spread (noise of a good laser over 1 m) [um/m]."""
SIGN_RATIO = 0.15
"""Flag a sign when ``|c + ref| < SIGN_RATIO |c - ref|`` (per-target means) [-]."""
SIGN_MIN_UM = 2.0
"""Smallest RMS of the per-target means for the sign check to speak [um]."""
FIRST_READING_UM = 1.0
"""A first reading beyond this and beyond 20 % of the test's range is flagged [um]."""


def _length_mm(m: Measurement) -> float:
    return float(np.max(np.linalg.norm(m.positions - m.positions[0], axis=1)))


def _spread_um_per_m(m: Measurement) -> float:
    lo, hi = np.percentile(m.deviation, [5, 95])
    return float(hi - lo) / max(_length_mm(m), 1.0) * 1000.0


def _scale(ms: list[Measurement]) -> list[str]:
    out = []
    dens = {m.id: _spread_um_per_m(m) for m in ms}
    for m in ms:
        group = [o for o in ms if o.kind == m.kind and o is not m]
        if len(group) < 2:
            group = [o for o in ms if o is not m]
        if len(group) < 2:
            continue
        med = max(float(np.median([dens[o.id] for o in group])), SCALE_FLOOR_UM_PER_M)
        ratio = dens[m.id] / med
        if ratio > SCALE_RATIO:
            out.append(f"{m.id}: deviations ~{ratio:.0f}x larger than the session's other "
                       f"{m.kind.replace('_', ' ')} tests ({dens[m.id]:.3g} um/m against a "
                       f"median of {med:.3g} um/m): mm entered as um in {m.file}?")
    return out


def _per_target(m: Measurement) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    t = np.round(m.positions[:, m.axis], 3)
    u, inv = np.unique(t, return_inverse=True)
    return u, np.bincount(inv, weights=m.deviation) / np.bincount(inv)


def _sign(ms: list[Measurement]) -> list[str]:
    out = []
    for k in range(3):
        lines = [m for m in ms if m.kind == "linear" and m.axis == k]
        if len(lines) < 3:
            continue
        curves = {m.id: _per_target(m) for m in lines}
        for m in lines:
            t, c = curves[m.id]
            others = [curves[o.id] for o in lines if o is not m
                      and curves[o.id][0].shape == t.shape and np.allclose(curves[o.id][0], t)]
            if len(others) < 2:
                continue
            cs = [o[1] for o in others]
            if min(np.sqrt(np.mean(v**2)) for v in [c, *cs]) < SIGN_MIN_UM:
                continue
            flipped = all(np.linalg.norm(c + o) < SIGN_RATIO * np.linalg.norm(c - o) for o in cs)
            agree = all(np.linalg.norm(a - b) < SIGN_RATIO * np.linalg.norm(a + b)
                        for i, a in enumerate(cs) for b in cs[i + 1:])
            if flipped and agree:
                ids = ", ".join(o.id for o in lines if o is not m)
                out.append(f"{m.id}: readings of the opposite sign to the other {'XYZ'[k]} "
                           f"lines ({ids}): a whole test with the wrong sign in {m.file}?")
    return out


def _order(m: Measurement) -> list[str]:
    out = []
    d = m.positions - m.positions[0]
    far = int(np.argmax(np.linalg.norm(d, axis=1)))
    if d[far] @ m.beam_direction < -1e-9:
        out.append(f"{m.id}: the poses move against the beam direction of session.toml: "
                   f"rows of {m.file} in reverse order?")
    elif m.kind == "linear" and m.direction is not None:
        k = m.axis
        run = m.run if m.run is not None else np.zeros(m.n, dtype=int)
        same = (run[1:] == run[:-1]) & (m.direction[1:] == m.direction[:-1])
        step = np.diff(m.positions[:, k])
        up = np.sum(step[same & (m.direction[1:] == "+")])
        down = np.sum(step[same & (m.direction[1:] == "-")])
        if up < 0 or down > 0:
            out.append(f"{m.id}: positions descend in the '+' rows (or ascend in the '-' "
                       f"rows) of {m.file}: rows in reverse order?")
    dev0 = float(m.deviation[0])
    if abs(dev0) > max(FIRST_READING_UM, 0.2 * float(np.ptp(m.deviation))):
        out.append(f"{m.id}: the first reading is {dev0:.3g} um, not ~0 (readings count from "
                   f"the first row): deviations of {m.file} in reverse order?")
    return out


def plausibility_warnings(session: Session) -> list[str]:
    """Warnings about readings inconsistent with the rest of the session.

    Parameters
    ----------
    session : Session
        A session read with its readings (measurements without readings are ignored).

    Returns
    -------
    list of str
        One message per finding, starting with the measurement id.
    """
    ms = [m for m in session.measurements if m.deviation is not None
          and np.all(np.isfinite(m.deviation)) and m.n >= 2]
    out = _scale(ms) + _sign(ms)
    for m in ms:
        out += _order(m)
    return out
