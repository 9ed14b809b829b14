"""Soft checks of a session's readings: each measurement consistent with the others.

Readings that are possible but unlikely give a warning naming the measurement (printed
by the commands, recorded in the identification's notes); absurd values are refused by
the reader itself (``docs/formats.md``, "Plausibility"). The checks:

* **scale** (um entered as nm, or mm entered as um): a measurement's robust spread per
  metre of travel (the 5th to 95th percentile range of its deviations divided by its
  length; measurements whose poses run along a line, ``Kind.along_beam``) is compared
  with the median of the session's measurements of the same kind (all measurements when
  fewer than 3 share its kind); more than :data:`SCALE_RATIO`
  times the median (the median floored at :data:`SCALE_FLOOR_UM_PER_M`) is flagged as
  too large, less than the median over :data:`SCALE_RATIO` (the median at least
  :data:`SCALE_FLOOR_UM_PER_M`) as too small;
* **floors and ceiling** that need no other test (:func:`reading_warnings`), on a line,
  diagonal or step diagonal longer than :data:`FLOOR_MIN_LENGTH_MM`: a 2 s repeatability
  (the largest over the targets and directions of a linear test with runs) below
  :data:`REPEATABILITY_FLOOR_UM` (no interferometer in air reads that; exactly repeated
  readings, and a session whose ``[provenance]`` declares a simulation with
  ``noise_um`` below the floor, are exempt); a range of the deviations below
  :data:`RANGE_FLOOR_UM_PER_M` or above :data:`RANGE_CEILING_UM_PER_M` per metre of
  length;
* **sign** of a whole linear test: with at least 3 linear tests of one axis on the same
  targets, a test whose mean deviation per target ``c`` is much closer to minus each of
  the others than to it (``|c + o| < SIGN_RATIO |c - o|``), while the others agree with
  each other (``|o1 - o2| < SIGN_RATIO |o1 + o2|``), is flagged;
* **order** (a reversed CSV): poses moving against the beam direction of
  ``session.toml``; in a linear test, ``+`` rows whose positions descend; a first
  reading far from 0 in a laser displacement (its readings count from the first row, so
  reversed deviations start with the last reading; not a rotary test's or an optic's,
  whose first reading is an error like any other).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from volcal.session.kinds import kind_of

if TYPE_CHECKING:
    from volcal.session.format import Measurement, Session

__all__ = ["FIRST_READING_UM", "FLOOR_MIN_LENGTH_MM", "RANGE_CEILING_UM_PER_M",
           "RANGE_FLOOR_UM_PER_M", "REPEATABILITY_FLOOR_UM", "SCALE_FLOOR_UM_PER_M",
           "SCALE_RATIO", "SIGN_RATIO", "plausibility_warnings", "positioning_warnings",
           "reading_warnings"]

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
FLOOR_MIN_LENGTH_MM = 100.0
"""The floors and the ceiling speak on tests longer than this [mm]."""
REPEATABILITY_FLOOR_UM = 0.02
"""A 2 s repeatability below this (20 nm) on a line longer than 100 mm is not an
interferometer in air (air turbulence alone gives more) [um]."""
RANGE_FLOOR_UM_PER_M = 0.1
"""A range of the deviations below this per metre of length is below what any machine
shows (its positioning error and the air's refractive index over that length) [um/m]."""
RANGE_CEILING_UM_PER_M = 1000.0
"""A range above this (1 mm per metre) is no calibrated machine axis: readings in nm, or
mm x 1000? [um/m]."""
EXACT_UM = 1e-9
"""Readings repeating to within this are exact repeats (a noise-free simulation) [um]."""


def _length_mm(m: Measurement) -> float:
    return float(np.max(np.linalg.norm(m.positions - m.positions[0], axis=1)))


def _readings(m: Measurement) -> NDArray[np.float64]:
    """The deviations of ``m`` [um]: plausibility_warnings checks only measurements with them."""
    assert m.deviation is not None
    return m.deviation


def _spread_um_per_m(m: Measurement) -> float:
    lo, hi = np.percentile(_readings(m), [5, 95])
    return float(hi - lo) / max(_length_mm(m), 1.0) * 1000.0


def _scale(ms: list[Measurement]) -> list[str]:
    out = []
    # a spread per metre of the poses' extent is a common scale only for readings along a
    # line of poses (Kind.along_beam): not a rotary test's (its poses do not move), an
    # R-test's (the nest's displacements while the axes circle) or a tracker grid's
    ms = [m for m in ms if _length_mm(m) > 0 and kind_of(m.kind).along_beam]
    dens = {m.id: _spread_um_per_m(m) for m in ms}
    for m in ms:
        ang = _in_urad(m)  # angles, never compared with displacements
        group = [o for o in ms if o.kind == m.kind and o is not m]
        kind = f"{m.kind.replace('_', ' ')} tests"
        if len(group) < 2:
            group = [o for o in ms if o is not m and _in_urad(o) == ang]
            kind = "tests"
        if len(group) < 2:
            continue
        med = max(float(np.median([dens[o.id] for o in group])), SCALE_FLOOR_UM_PER_M)
        ratio = dens[m.id] / med
        raw = float(np.median([dens[o.id] for o in group]))
        u = "urad/m" if ang else "um/m"
        if ratio > SCALE_RATIO:
            hint = ("mrad (or mm/m) entered as urad" if ang else "mm entered as um")
            out.append(f"{m.id}: deviations ~{ratio:.0f}x larger than the session's other "
                       f"{kind} ({dens[m.id]:.3g} {u} against a "
                       f"median of {med:.3g} {u}): {hint} in {m.file}?")
        elif raw >= SCALE_FLOOR_UM_PER_M and dens[m.id] * SCALE_RATIO < raw:
            small = raw / max(dens[m.id], 1e-12)
            hint = ("readings 1000x too small (mrad typed into angle_urad)" if ang else
                    "readings 1000x too small (mm typed into deviation_um)")
            out.append(f"{m.id}: deviations ~{small:.0f}x smaller than the session's other "
                       f"{kind} ({dens[m.id]:.3g} {u} against a median of "
                       f"{raw:.3g} {u}): {hint} in {m.file}?")
    return out


def _repeatability_2s(targets: NDArray[np.float64], deviation: NDArray[np.float64],
                      run: NDArray | None, direction: NDArray | None) -> float | None:
    """Largest 2 s over the (target, direction) groups read by two runs or more [um]."""
    if run is None or direction is None:
        return None
    key = np.round(np.asarray(targets, dtype=float), 3) + 0.0  # -0.0 is 0.0's target
    side = np.unique(np.asarray(direction).astype(str), return_inverse=True)[1].ravel()
    order = np.lexsort((key, side))  # stable: each group's readings in the file's order
    k, d = key[order], side[order]
    dev = np.asarray(deviation)[order]
    starts = np.flatnonzero(np.r_[True, (np.diff(k) != 0) | (np.diff(d) != 0), True])
    worst = None
    for a, b in zip(starts[:-1], starts[1:], strict=True):
        if b - a >= 2:
            s2 = 2.0 * float(np.std(dev[a:b], ddof=1))
            worst = s2 if worst is None else max(worst, s2)
    return worst


def reading_warnings(label: str, file: str, length_mm: float, deviation: NDArray[np.float64],
                     targets: NDArray[np.float64] | None = None, run: NDArray | None = None,
                     direction: NDArray | None = None) -> list[str]:
    """Floors and ceiling of one test's readings, needing no other test.

    Parameters
    ----------
    label : str
        Measurement id (or file name) starting each message.
    file : str
        File of the readings, named in the messages.
    length_mm : float
        Length of the test [mm].
    deviation : ndarray, shape (n,)
        Deviations [um].
    targets : ndarray, shape (n,), optional
        Target of each reading along the line [mm] (for the repeatability).
    run, direction : ndarray, optional
        Run and direction of each reading (for the repeatability).

    Returns
    -------
    list of str
        At most one warning, the first that fires of: repeatability floor, range floor,
        range ceiling (empty below :data:`FLOOR_MIN_LENGTH_MM`).
    """
    dev = np.asarray(deviation, dtype=float)
    dev = dev[np.isfinite(dev)]
    if length_mm <= FLOOR_MIN_LENGTH_MM or dev.size < 2:
        return []
    out = []
    per_m = float(np.ptp(dev)) / length_mm * 1000.0
    if targets is not None:
        r2 = _repeatability_2s(np.asarray(targets)[np.isfinite(deviation)], dev,
                               None if run is None else np.asarray(run)[np.isfinite(deviation)],
                               None if direction is None
                               else np.asarray(direction)[np.isfinite(deviation)])
        if r2 is not None and EXACT_UM < r2 < REPEATABILITY_FLOOR_UM:
            out.append(f"{label}: 2s repeatability {r2 * 1000:.3g} nm on a {length_mm:.0f} mm "
                       f"line, below the {REPEATABILITY_FLOOR_UM * 1000:g} nm no "
                       f"interferometer in air reads: readings 1000x too small (mm typed "
                       f"into deviation_um) in {file}?")
    if out:
        return out
    if per_m < RANGE_FLOOR_UM_PER_M:
        out.append(f"{label}: the deviations span {np.ptp(dev):.3g} um over {length_mm:.0f} mm "
                   f"({per_m:.3g} um/m), below the {RANGE_FLOOR_UM_PER_M:g} um/m any machine "
                   f"shows: readings 1000x too small (mm typed into deviation_um) in {file}?")
    elif per_m > RANGE_CEILING_UM_PER_M:
        out.append(f"{label}: the deviations span {np.ptp(dev):.4g} um over {length_mm:.0f} "
                   f"mm ({per_m:.4g} um/m), above the {RANGE_CEILING_UM_PER_M:g} um/m of any "
                   f"calibrated machine axis: readings 1000x too large (nm read as um) in "
                   f"{file}?")
    return out


def noise_free_simulation(provenance: dict) -> bool:
    """Whether ``[provenance]`` declares a simulation with less noise than the floor.

    Such readings are exact by design: the repeatability floor does not apply.

    Parameters
    ----------
    provenance : dict
        The session's ``[provenance]`` table (``readings``, ``noise_um`` [um]).

    Returns
    -------
    bool
    """
    if provenance.get("readings") != "simulated":
        return False
    try:
        return float(provenance.get("noise_um", 1.0)) < REPEATABILITY_FLOOR_UM
    except (TypeError, ValueError):
        return False


def _in_urad(m: Measurement) -> bool:
    """Readings in urad (an angle), by the measurement's kind (:mod:`volcal.kinds`)."""
    return kind_of(m.kind).value_unit == "urad"


def _floors(m: Measurement, exact: bool = False) -> list[str]:
    kind = kind_of(m.kind)
    if kind.systematic != "length":  # laser lengths along a beam only
        return []
    targets = m.positions[:, m.axis] if kind.bidirectional and not exact else None
    return reading_warnings(m.id, m.file, _length_mm(m), _readings(m), targets, m.run,
                            m.direction)


class PositioningReadings(Protocol):
    """What :func:`positioning_warnings` reads of a positioning file's readings.

    :class:`volcal.standards.positioning_data.PositioningData` is one (the standards sit
    above the session: this module does not import it).
    """

    file: str
    targets_mm: NDArray[np.float64]
    deviation_um: NDArray[np.float64]
    run: NDArray[np.int64]
    direction: NDArray[np.str_]


def positioning_warnings(data: PositioningReadings) -> list[str]:
    """Floors and ceiling of one positioning file (``volcal evaluate iso230-2 FILE``).

    Parameters
    ----------
    data : PositioningData
        Readings of :func:`volcal.standards.positioning_data.read_positioning_csv`.

    Returns
    -------
    list of str
        Warnings starting with the file's name.
    """
    from pathlib import Path

    t = np.asarray(data.targets_mm, dtype=np.float64)
    name = Path(data.file).name
    return reading_warnings(name, name, float(np.ptp(t)) if t.size else 0.0,
                            data.deviation_um, t, data.run, data.direction)


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
    if kind_of(m.kind).along_beam and d[far] @ m.beam_direction < -1e-9:
        out.append(f"{m.id}: the poses move against the beam direction of session.toml: "
                   f"rows of {m.file} in reverse order?")
    elif kind_of(m.kind).bidirectional and m.direction is not None and m.axis is not None:
        k = m.axis
        run = m.run if m.run is not None else np.zeros(m.n, dtype=int)
        same = (run[1:] == run[:-1]) & (m.direction[1:] == m.direction[:-1])
        step = np.diff(m.positions[:, k])
        up = np.sum(step[same & (m.direction[1:] == "+")])
        down = np.sum(step[same & (m.direction[1:] == "-")])
        if up < 0 or down > 0:
            out.append(f"{m.id}: positions descend in the '+' rows (or ascend in the '-' "
                       f"rows) of {m.file}: rows in reverse order?")
    if not kind_of(m.kind).displacement:
        return out  # readings that do not count from the first row (rotary, optics)
    dev = _readings(m)
    dev0 = float(dev[0])
    if abs(dev0) > max(FIRST_READING_UM, 0.2 * float(np.ptp(dev))):
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
          and np.all(np.isfinite(m.deviation)) and m.n >= 2
          and m.kind != "probe_sphere"]  # sphere centres, not laser readings (its dispersion)
    out = _scale(ms) + _sign(ms)
    scaled = {w.split(":", 1)[0] for w in out}  # one warning per cause: floors say the same
    exact = noise_free_simulation(getattr(session, "provenance", {}) or {})
    for m in ms:
        out += _order(m) + ([] if m.id in scaled else _floors(m, exact))
    return out
