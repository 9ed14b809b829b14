"""The default layout of a trunnion's sphere tests: one for ``probe_sphere`` and ``r_test``.

Both kinds plan a C table on an A (or B) cradle with the same pivots (``pivot_mm``, the
control's rotation points) for the same chain and travel, so that the two planned together
in one session locate together (``volcal locate`` refuses tests of one chain with other
pivots). The layout: the C pivot at the centre of the X and Y travel, the tilting axis'
line :data:`PIVOT_DROP_MM` below it, the sphere :data:`SPHERE_OFFSET_MM` from the C pivot
(along X on an A cradle, along Y on a B cradle). The height of the pivots is chosen so
that the sphere centre stays inside the travel, :data:`TRAVEL_MARGIN_MM` from its ends,
at every angle the default plans visit (C over a full turn, the tilting axis from -90 to
+90 deg, and every angle between: the R-test's following moves); where the travel is too
short for it, the layout is shrunk about the C pivot until it fits (``docs/fiveaxis.md``,
"The default plans"). The machine's real pivots replace these in the session
(``pivot_mm``): they are a start, not the machine's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError

__all__ = ["PIVOT_DROP_MM", "SPHERE_OFFSET_MM", "TRAVEL_MARGIN_MM", "TrunnionLayout",
           "TrunnionRanges", "default_trunnion", "trunnion_ranges"]

PIVOT_DROP_MM = 120.0
"""The tilting axis' line this far below the C pivot [mm] (a trunnion's)."""
SPHERE_OFFSET_MM = (150.0, 0.0, 40.0)
"""The sphere this far from the C pivot [mm] (x and y swapped for a B cradle)."""
TRAVEL_MARGIN_MM = 35.0
"""Room kept between the sphere centre and the ends of the travel [mm]: the R-test nest's
approach (30 mm above the sphere) and the probe's (sphere and tip radius plus clearance,
about 20 mm) stay inside it."""
TILT_RANGE_DEG = (-90.0, 90.0)
"""The tilting axis' range the layout keeps inside the travel [deg] (the default plans'
where the machine's ``[[machine.rotary_axes]]`` do not limit it: :func:`trunnion_ranges`)."""
ENVELOPE_STEP_DEG = 2.0
"""Angle step of the poses the layout's envelope is computed on [deg]."""
MIN_SCALE = 0.2
"""Smallest shrink of the layout; a travel shorter than that needs is refused."""


@dataclass(frozen=True)
class TrunnionLayout:
    """The default pivots and sphere of a trunnion's sphere tests.

    Attributes
    ----------
    chain : str
        The 5-axis chain (``CA`` or ``CB`` + the linear chain).
    pivot_mm : dict of str to list of float
        ``pivot_mm`` of the session: lower-case rotary letter -> a point of its line [mm].
    sphere_mm : list of float
        The sphere centre at the zero pose [mm].
    scale : float
        The shrink applied to :data:`PIVOT_DROP_MM` and :data:`SPHERE_OFFSET_MM` (1: none).
    """

    chain: str
    pivot_mm: dict[str, list[float]]
    sphere_mm: list[float]
    scale: float


@dataclass(frozen=True)
class TrunnionRanges:
    """The angles a trunnion's sphere tests may command [deg].

    Attributes
    ----------
    c : (float, float)
        C's range; a full turn from its first value where :attr:`c_full`.
    c_full : bool
        C turns full circles (a modulo axis, or a range of 360 deg or more).
    tilt : (float, float)
        The tilting axis' (A or B) range.
    """

    c: tuple[float, float] = (0.0, 360.0)
    c_full: bool = True
    tilt: tuple[float, float] = TILT_RANGE_DEG

    def c_angles(self, step_deg: float) -> NDArray[np.float64]:
        """C's angles in steps of ``step_deg`` over its range [deg].

        A full turn without its end (0 and 360 deg are one pose), or a limited range with
        both ends.

        Parameters
        ----------
        step_deg : float
            Step between the angles [deg] (a limited range: about it, evenly spaced).

        Returns
        -------
        ndarray
        """
        lo, hi = self.c
        if self.c_full:
            return lo + np.arange(0.0, 360.0 - 1e-9, step_deg)
        return np.linspace(lo, hi, max(2, int(round((hi - lo) / step_deg)) + 1))

    def tilt_angles(self, step_deg: float) -> NDArray[np.float64]:
        """The tilting axis' angles over its range [deg].

        Evenly spaced, about ``step_deg`` apart, both ends included.

        Parameters
        ----------
        step_deg : float
            Step between the angles [deg].

        Returns
        -------
        ndarray
        """
        lo, hi = self.tilt
        return np.linspace(lo, hi, max(2, int(round((hi - lo) / step_deg)) + 1))


def trunnion_ranges(pair: str, axes: Any = None) -> TrunnionRanges:
    """The angles the sphere tests of a trunnion may command, from the machine's axes.

    A limited axis of ``[[machine.rotary_axes]]`` (``modulo = false``) bounds the plan's
    angles: the tilting axis' (the default plans' -90..+90 deg otherwise,
    :data:`TILT_RANGE_DEG`) and C's (a full turn from 0 otherwise). A modulo axis turns
    freely: C a full turn, the tilting axis the default range.

    Parameters
    ----------
    pair : str
        ``'ca'`` or ``'cb'``.
    axes : sequence of volcal.session.rotary.RotaryAxis, optional
        The machine's rotary axes (``name``, ``range_deg``, ``modulo``).

    Returns
    -------
    TrunnionRanges

    Raises
    ------
    VolcalInputError
        The axes have the other tilting axis and not this pair's (``cb`` planned on a
        machine with A).
    """
    given = {a.name.lower(): a for a in axes or []}
    c, tilt = given.get("c"), given.get(pair[1].lower())
    other = "b" if pair[1].lower() == "a" else "a"
    if tilt is None and other in given:
        raise VolcalInputError(
            f"a sphere test of a C table on {'an A' if pair[1].lower() == 'a' else 'a B'} "
            f"cradle (:{pair.lower()}), but the machine's rotary axes (--rotary-axes, or "
            f"[[machine.rotary_axes]] of the session) have {other.upper()} and no "
            f"{pair[1].upper()}: plan probe_sphere:c{other} or r_test:c{other}, or declare "
            f"{pair[1].upper()}")
    out = TrunnionRanges()
    if c is not None and not c.modulo:
        lo, hi = (float(v) for v in c.range_deg)
        out = TrunnionRanges((lo, hi), hi - lo >= 360.0 - 1e-9, out.tilt)
    if tilt is not None and not tilt.modulo:
        out = TrunnionRanges(out.c, out.c_full, (float(tilt.range_deg[0]),
                                                  float(tilt.range_deg[1])))
    return out


def _envelope(tilt: str, drop: float, offset: NDArray[np.float64],
              ranges: TrunnionRanges) -> NDArray[np.float64]:
    """Lowest and highest sphere centre over the angles, the C pivot at 0 [mm], (3, 2).

    The sphere turned about the vertical C line through the pivot, then about the tilting
    axis' line (parallel to X for A, to Y for B) ``drop`` below it: a rigid rotation of a
    point; over a full turn of C and a tilt range symmetric about 0 the envelope does not
    depend on the direction the angles count (``docs/fiveaxis.md``), and on a table-table
    chain the configured kinematics put the tool point there (the programs' positions).
    Every angle of ``ranges`` (C and the tilt, and those between: the R-test's following
    moves), sampled every :data:`ENVELOPE_STEP_DEG`.
    """
    c = np.deg2rad(ranges.c_angles(ENVELOPE_STEP_DEG))
    t = np.deg2rad(ranges.tilt_angles(ENVELOPE_STEP_DEG))
    C, T = (v.ravel() for v in np.meshgrid(c, t))
    x = offset[0] * np.cos(C) - offset[1] * np.sin(C)
    y = offset[0] * np.sin(C) + offset[1] * np.cos(C)
    z = np.full_like(C, offset[2] + drop)
    if tilt == "A":
        x, y, z = x, y * np.cos(T) - z * np.sin(T), y * np.sin(T) + z * np.cos(T)
    else:
        x, y, z = x * np.cos(T) + z * np.sin(T), y, -x * np.sin(T) + z * np.cos(T)
    q = np.column_stack([x, y, z - drop])
    return np.column_stack([q.min(axis=0), q.max(axis=0)])


def default_trunnion(pair: str, chain: str, travel: ArrayLike,
                     ranges: TrunnionRanges | None = None) -> TrunnionLayout:
    """The default pivots and sphere of a trunnion in a travel (both sphere kinds' plans).

    Parameters
    ----------
    pair : str
        ``'ca'`` (C on an A cradle) or ``'cb'``.
    chain : str
        The plan's linear chain (``XYFZ`` ...).
    travel : array_like, shape (3, 2)
        The travel [mm].
    ranges : TrunnionRanges, optional
        The angles the tests command (:func:`trunnion_ranges`; default its default).

    Returns
    -------
    TrunnionLayout

    Raises
    ------
    VolcalInputError
        A travel too short for the layout shrunk to :data:`MIN_SCALE`.
    """
    from volcal.model.chain import parse_machine_chain

    ch = parse_machine_chain(pair.upper() + chain)
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    off = np.array(SPHERE_OFFSET_MM)
    if pair.lower() == "cb":
        off = off[[1, 0, 2]]
    env = _envelope(pair[1].upper(), PIVOT_DROP_MM, off, ranges or TrunnionRanges())
    room = (t[:, 1] - t[:, 0]) - 2.0 * TRAVEL_MARGIN_MM
    span = env[:, 1] - env[:, 0]
    scale = float(min(1.0, np.floor(1e3 * (room / span).min()) / 1e3))
    if scale < MIN_SCALE:
        need = MIN_SCALE * span + 2.0 * TRAVEL_MARGIN_MM
        cradle = "an A" if pair[1] == "a" else "a B"
        raise VolcalInputError(f"C table on {cradle} cradle: the travel "
                               f"{', '.join(f'{a:g}..{b:g}' for a, b in t)} mm is too short "
                               "for a sphere test's default layout (it needs "
                               f"{', '.join(f'{v:.0f}' for v in need)} mm of X, Y, Z travel at "
                               "least); plan with --travel of the machine")
    # the envelope's middle at the travel's middle (the envelope scales about the C pivot)
    pc = 0.5 * (t[:, 0] + t[:, 1]) - scale * 0.5 * (env[:, 0] + env[:, 1])
    pc = np.round(pc, 3)
    pt = np.round(pc - np.array([0.0, 0.0, scale * PIVOT_DROP_MM]), 6)
    sphere = np.round(pc + scale * off, 6)
    return TrunnionLayout(ch.code, {"c": [float(v) for v in pc],
                                    pair[1].lower(): [float(v) for v in pt]},
                          [float(v) for v in sphere], scale)

