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

A test with missed captures is evaluated as ``volcal evaluate session`` does (each target
over the runs that reached it); a target left without a reading in one direction gives
no reversal and is bridged from its neighbours. An axis without a usable bidirectional
test keeps forward = reverse, and :meth:`DirectionalErrors.notes` says so (and why): the
writers put that in their notes, never a silent copy of the forward table.

References
----------
ISO 230-2:2014, 3.3 (mean unidirectional positional deviation, reversal value B_i).
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
    why_missing : list of 3 str
        Per axis without reversal: why (no bidirectional linear test of the axis, or the
        reason its tests could not be evaluated); empty for the axes that have one.
    remarks : list of str
        What else the tables should say about the reversal: a test set aside for another
        of the same axis, targets without a reading in one direction.
    """

    targets: list[NDArray[np.float64] | None]
    reversal_um: list[NDArray[np.float64] | None]
    source: str = ""
    why_missing: list[str] = field(default_factory=lambda: ["", "", ""])
    remarks: list[str] = field(default_factory=list)

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

    def notes(self) -> list[str]:
        """Plain lines for the tables' notes: each axis without reversal and why, remarks.

        Returns
        -------
        list of str
            ``"Y: forward = reverse (no reverse table): ..."`` per axis without reversal,
            then :attr:`remarks`.
        """
        out = [f"{'XYZ'[k]}: forward = reverse (no reverse table): "
               f"{self.why_missing[k] or 'no bidirectional ISO 230-2 linear test of this axis'}"
               for k in range(3) if not self.has(k)]
        return out + list(self.remarks)


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

    out = DirectionalErrors([None, None, None], [None, None, None])
    used: list[str] = []
    refused: list[list[str]] = [[], [], []]
    candidates = []
    for m in session.measurements:
        if m.kind != "linear" or m.deviation is None or m.axis is None:
            continue
        if m.direction is None:
            continue
        dev = np.asarray(m.deviation, dtype=float)
        if len(set(np.asarray(m.direction)[np.isfinite(dev)].tolist())) < 2:
            continue
        lever = float(np.abs(np.delete(m.positions[0], m.axis)).sum()
                      + np.abs(m.tool_offset).sum())
        candidates.append((lever, m))
    # per axis, the test on the reference line first (smallest Abbe offsets)
    for _lever, m in sorted(candidates, key=lambda c: c[0]):
        k = m.axis
        if out.has(k):
            continue
        try:
            d = from_measurement(_without_missed(m), getattr(session, "path", None))
            res = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um,
                           **d.evaluate_kwargs())
        except VolcalInputError as exc:  # too many missed captures: say so, try the next
            refused[k].append(f"{m.id} ({exc.message})")
            continue
        t = np.asarray(res.targets.target_mm, dtype=float)
        b = np.asarray(res.targets.B, dtype=float)
        ok = np.isfinite(b)
        if not ok.any():
            refused[k].append(f"{m.id} (no target reached in both directions)")
            continue
        if not ok.all():
            gone = ", ".join(f"{v:g}" for v in t[~ok])
            out.remarks.append(f"{'XYZ'[k]}: {m.id} has no reading in one direction at "
                               f"{gone} mm (missed captures): the reversal there is "
                               "interpolated from the neighbouring targets")
        if refused[k]:
            out.remarks.append(f"{'XYZ'[k]}: reversal from {m.id}, not from "
                               f"{'; '.join(refused[k])}")
        out.targets[k], out.reversal_um[k] = t[ok], b[ok]
        used.append(m.id)
    for k in range(3):
        if not out.has(k) and refused[k]:
            out.why_missing[k] = ("its bidirectional tests could not be evaluated: "
                                  + "; ".join(refused[k]))
    out.source = ", ".join(used)
    return out


def _without_missed(m):
    """The measurement without its NaN readings (missed captures a reader kept)."""
    import dataclasses

    dev = np.asarray(m.deviation, dtype=float)
    keep = np.isfinite(dev)
    if keep.all():
        return m
    rows = None if m.rows is None else np.asarray(m.rows)[keep]
    cols = {c: np.asarray(v)[keep] for c, v in m.columns.items()}
    return dataclasses.replace(m, positions=np.asarray(m.positions)[keep], deviation=dev[keep],
                               columns=cols, rows=rows)
