"""Plan rotary tests: ISO 230-2 targets over a rotary axis' range, bidirectional runs.

``volcal plan --tests rotary:c`` plans one test of the C axis: ``steps + 1`` targets over
the axis' range, the interior ones moved from the uniform grid by a reproducible amount of
at most a quarter of the interval (ISO 230-2:2014, 5.2, as for linear axes), so that they
are not all multiples of a round angle and the periodic errors of an encoder or a worm
gear are sampled at different phases. On a full-circle (modulo 360) axis the targets run
from 0 to 360 deg: 0 and 360 are the same physical position, read at both ends of each
pass, which closes the circle (``docs/methods.md``, "ISO 230-2 for rotary axes"). On a
limited axis they stay ``margin_deg`` inside both ends, so that the overrun before each
approach has room. Each run goes up through the targets, then back down (the ISO 230-2
standard test cycle), 5 runs by default.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import ParameterError, VolcalInputError
from volcal.plan.geometry import iso_targets
from volcal.session.format import Measurement
from volcal.session.rotary import ROTARY_AXES, RotaryAxis

__all__ = ["DEFAULT_MARGIN_DEG", "rotary_axis_spec", "rotary_targets", "rotary_tests"]

DEFAULT_MARGIN_DEG = 2.0
"""Room left at both ends of a limited rotary axis for the overrun [deg]; equal to the
default overrun of the rotary part programs."""


def rotary_axis_spec(text: str) -> list[RotaryAxis]:
    """Parse ``c:0:360:modulo,a:-120:30`` (name:min:max[:modulo|:limited]) into axes.

    Parameters
    ----------
    text : str
        Comma-separated axes; the range in degrees; ``modulo`` (the default for a range
        of exactly 360 deg) or ``limited``.

    Returns
    -------
    list of RotaryAxis

    Raises
    ------
    VolcalInputError
        A malformed entry, named.
    """
    out: list[RotaryAxis] = []
    for part in (p.strip() for p in text.split(",") if p.strip()):
        f = [x.strip().lower() for x in part.split(":")]
        if len(f) not in (3, 4) or f[0] not in ROTARY_AXES:
            raise VolcalInputError(f"rotary axis {part!r}: expected name:min:max[:modulo|"
                                   "limited] with name a, b or c (c:0:360:modulo)")
        try:
            lo, hi = float(f[1]), float(f[2])
        except ValueError:
            raise VolcalInputError(f"rotary axis {part!r}: min and max are numbers of "
                                   "degrees") from None
        if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo and abs(lo) <= 3600
                and abs(hi) <= 3600):
            raise VolcalInputError(f"rotary axis {part!r}: expected min < max [deg]")
        if len(f) == 4 and f[3] not in ("modulo", "limited"):
            raise VolcalInputError(f"rotary axis {part!r}: the last field is modulo or "
                                   "limited")
        modulo = (f[3] == "modulo") if len(f) == 4 else abs(hi - lo - 360.0) < 1e-9
        if modulo and hi - lo > 360.0 + 1e-9:
            raise VolcalInputError(f"rotary axis {part!r}: a full-circle (modulo) axis spans "
                                   "at most 360 deg")
        if any(a.name == f[0] for a in out):
            raise VolcalInputError(f"rotary axis {f[0]!r} given twice")
        out.append(RotaryAxis(f[0], (lo, hi), modulo))
    return out


def rotary_targets(axis: RotaryAxis, steps: int, margin_deg: float = DEFAULT_MARGIN_DEG,
                   targets_deg: Sequence[float] | None = None, seed: int = 0
                   ) -> NDArray[np.float64]:
    """Target angles of a rotary test [deg], ascending.

    Parameters
    ----------
    axis : RotaryAxis
        The axis.
    steps : int
        Intervals (``steps + 1`` targets).
    margin_deg : float
        Room left at both ends of a limited axis [deg].
    targets_deg : sequence of float, optional
        The targets given (``--targets``), checked against the range.
    seed : int
        Seed of the ISO 230-2 offsets.

    Returns
    -------
    ndarray
    """
    lo, hi = axis.range_deg
    if targets_deg is not None:
        t = np.sort(np.asarray(targets_deg, dtype=float))
        if t.size < 2 or not np.all(np.isfinite(t)):
            raise ParameterError("{targets}: at least two angles [deg] are needed")
        if np.any(np.diff(t) <= 0):
            raise ParameterError("{targets}: each angle once")
        if t[0] < lo or t[-1] > hi:
            raise ParameterError(f"{{targets}}: the angles must lie in the range of axis "
                                   f"{axis.name.upper()} [{lo:g}, {hi:g}] deg")
        return t
    if not axis.modulo:
        lo, hi = lo + margin_deg, hi - margin_deg
        if hi <= lo:
            raise VolcalInputError(f"rotary axis {axis.name.upper()}: range too short for an "
                                   f"overrun of {margin_deg:g} deg at both ends")
    return iso_targets(lo, hi, steps, seed)


def rotary_tests(c: Any, only: str | None = None) -> list[Measurement]:
    """The rotary tests of a plan (``volcal plan --tests rotary[:a|b|c]``).

    Parameters
    ----------
    c : volcal.plan.planner.PlanOptions
        The plan: ``runs``, ``steps`` and ``rotary`` (``axes``: list of RotaryAxis,
        ``targets_deg``: sequence or None, ``mounting``, ``eccentricity_mm``, ``target``).
    only : str or None
        One axis; None: every axis given, else C.

    Returns
    -------
    list of Measurement
    """
    opts = dict(getattr(c, "rotary", None) or {})
    given: list[RotaryAxis] = list(opts.get("axes") or [])
    names = [only] if only else ([a.name for a in given] or ["c"])
    out = []
    for name in names:
        axis = next((a for a in given if a.name == name), RotaryAxis(name))
        t = rotary_targets(axis, c.steps, opts.get("margin_deg", DEFAULT_MARGIN_DEG),
                           opts.get("targets_deg"), seed=ROTARY_AXES.index(name))
        seq, run, dirn = [], [], []
        for r in range(1, c.runs + 1):
            seq += list(t) + list(t[::-1])
            run += [r] * (2 * t.size)
            dirn += ["+"] * t.size + ["-"] * t.size
        meta: dict[str, Any] = {"axis": name, "range_deg": [float(v) for v in axis.range_deg],
                                "modulo": bool(axis.modulo),
                                "mounting": opts.get("mounting", "on_axis")}
        if meta["mounting"] == "off_axis":
            meta["eccentricity_mm"] = float(opts.get("eccentricity_mm", 0.0))
        meta["notes"] = (f"ISO 230-2 angular positioning of axis {name.upper()}: "
                         f"{t.size} targets, {c.runs} bidirectional runs")
        mid = f"rotary-{name}"
        n = len(seq)
        out.append(Measurement(
            mid, "rotary", opts.get("target", "rotary_calibrator"), np.zeros((n, 3)), None,
            np.eye(3)[ROTARY_AXES.index(name)], np.zeros(3), f"{mid}.csv",
            {"target_deg": np.asarray(seq, dtype=float), "run": np.asarray(run),
             "direction": np.asarray(dirn)}, meta))
    return out


def machine_rotary_axes(measurements: list[Measurement], given: list[RotaryAxis] | None = None
                        ) -> list[dict[str, Any]]:
    """``[[machine.rotary_axes]]`` of a plan: the axes given, then those of its tests.

    Parameters
    ----------
    measurements : list of Measurement
        The planned measurements.
    given : list of RotaryAxis, optional
        Axes given to the plan.

    Returns
    -------
    list of dict
    """
    axes = {a.name: a for a in given or []}
    for m in measurements:
        if m.kind == "rotary" and m.meta["axis"] not in axes:
            axes[m.meta["axis"]] = RotaryAxis(m.meta["axis"], tuple(m.meta["range_deg"]),
                                              bool(m.meta["modulo"]))
    return [axes[k].to_toml() for k in sorted(axes)]
