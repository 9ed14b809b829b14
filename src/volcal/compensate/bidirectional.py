"""Direction-dependent positioning errors from the ISO 230-2 linear tests of a session.

An axis with reversal (backlash, lost motion) reaches a target with a different error
when it approaches from below (forward, ``+``) than from above (reverse, ``-``).
ISO 230-2 gives, per target, the mean unidirectional deviations ``x_up`` and
``x_down``; their difference is the reversal ``B = x_up - x_down``. Controllers with two
tables (LinuxCNC ``COMP_FILE_TYPE`` 0/1, Fanuc bidirectional pitch compensation,
HEIDENHAIN's ``BACKLASH`` column) take the forward and reverse errors; volcal builds them
as the identified positioning error ``EXX(p)`` plus and minus half the measured reversal,
interpolated linearly between the targets and held constant beyond them:

``forward(p) = EXX(p) + B(p)/2``, ``reverse(p) = EXX(p) - B(p)/2``.

References
----------
ISO 230-2:2014, 3.3 (mean unidirectional positional deviation, reversal value B_i).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["DirectionalErrors", "directional_from_session"]


@dataclass
class DirectionalErrors:
    """Measured reversal of each axis along its travel.

    Attributes
    ----------
    targets : list of 3 (ndarray or None)
        Target positions of each axis' linear test [mm]; None for an axis without a
        bidirectional test.
    reversal_um : list of 3 (ndarray or None)
        Reversal ``B = x_up - x_down`` at the targets [um].
    source : str
        Measurement ids the values come from.
    """

    targets: list[NDArray[np.float64] | None]
    reversal_um: list[NDArray[np.float64] | None]
    source: str = ""

    def has(self, axis: int) -> bool:
        """True if ``axis`` (0, 1, 2) has bidirectional data.

        Parameters
        ----------
        axis : int
            0, 1, 2 = X, Y, Z.

        Returns
        -------
        bool
        """
        return self.targets[axis] is not None

    def half_reversal(self, axis: int, positions) -> NDArray[np.float64]:
        """``B(p)/2`` at positions of ``axis`` [um] (zero without data).

        Parameters
        ----------
        axis : int
            0, 1, 2.
        positions : array_like
            Positions of the axis [mm].

        Returns
        -------
        ndarray
        """
        p = np.asarray(positions, dtype=float)
        t, b = self.targets[axis], self.reversal_um[axis]
        if t is None or b is None:
            return np.zeros_like(p)
        return 0.5 * np.interp(p, t, b)


def directional_from_session(session) -> DirectionalErrors:
    """Reversal per axis from the bidirectional linear tests of a session.

    Uses, per axis, the linear test on the axis' reference line (the one with the
    smallest Abbe offsets) that has runs in both directions, evaluated with ISO 230-2.

    Parameters
    ----------
    session : volcal.session.format.Session
        A measured session.

    Returns
    -------
    DirectionalErrors
    """
    from volcal.errors import VolcalInputError
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.positioning_data import from_measurement

    targets: list[NDArray[np.float64] | None] = [None, None, None]
    rev: list[NDArray[np.float64] | None] = [None, None, None]
    used = []
    best: dict[int, float] = {}
    for m in session.measurements:
        if m.kind != "linear" or m.deviation is None or m.axis is None:
            continue
        if m.direction is None or len(set(m.direction.tolist())) < 2:
            continue
        k = m.axis
        lever = float(np.abs(np.delete(m.positions[0], k)).sum()
                      + np.abs(m.tool_offset).sum())
        if k in best and best[k] <= lever:
            continue
        try:
            d = from_measurement(m)
            res = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, file=d.file,
                           rows=d.rows)
        except VolcalInputError:  # a test ISO 230-2 cannot read gives no reversal
            continue
        best[k] = lever
        targets[k] = np.asarray(res.targets.target_mm, dtype=float)
        rev[k] = np.asarray(res.targets.B, dtype=float)
        used.append(m.id)
    return DirectionalErrors(targets, rev, ", ".join(used))
