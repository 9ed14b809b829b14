r"""Body diagonals: the quick volumetric check and Soons' combinations of the four diagonals.

The four body diagonals ``ppp, npp, pnp, ppn`` (ASME B5.54, ISO 230-6; seed 000 section
3) are measured with a retroreflector along the diagonal. Their largest deviation and
their range are the shop floor's quick check of the volumetric accuracy (seed 002): small
values make large errors unlikely, large values prove large errors, but four curves cannot
say which of the 21 errors is large.

Soons (2005, eq. 5-10) combines the deviations over the whole diagonals. From the
first-order model (:func:`volcal.model.kinematics.first_order_pose`), the deviation of
diagonal ``s`` (travel signs ``s_x, s_y, s_z``, direction cosines ``n = dq/D``) between its
end points is, without angular errors,

.. math::

    dD_s = \sum_k n_k \Delta E_{KK} + \sum_{c \ne k} s_c s_k n_c \Delta E_{CK}
           + D\,(-s_x s_y n_x n_y\,EC0Y + s_x s_z n_x n_z\,EB0Z - s_y s_z n_y n_z\,EA0Z)
           \cdot 10^{-3}

(``Delta E`` the change of a function over the full travel [um], squareness [urad],
``D`` [mm]). The sign products are orthogonal over the four diagonals, so

* the mean ``(ppp + npp + pnp + ppn)/4 = n_x dEXX + n_y dEYY + n_z dEZZ``: one positioning
  combination (Soons eq. 7);
* ``EC0Y = -1000 (ppp - npp - pnp + ppn) / (4 D n_x n_y)``,
  ``EB0Z = +1000 (ppp - npp + pnp - ppn) / (4 D n_x n_z)``,
  ``EA0Z = -1000 (ppp + npp - pnp - ppn) / (4 D n_y n_z)``
  (Soons eq. 8-10 with our sign convention; the straightness terms ``dEYX/dX + dEXY/dY``...
  vanish because straightness is zero at both travel ends).

Angular errors add Abbe terms ``n . [eps_k x L_k]`` that depend on the chain and the tool
offset (Soons eq. 7-10 list them for his machine); they bias both estimates
(``docs/classic.md``).

References
----------
.. [1] ISO 230-6:2002, Test code for machine tools -- Part 6: Determination of positioning
   accuracy on body and face diagonals.
.. [2] Wang, C. and Liotto, G., Proc. Lamdamap 2003, section 3 (seed 000).
.. [3] Soons, J.A., "Analysis of the step-diagonal test", Proc. Lamdamap 2005, section 3.
.. [4] Chapman, M.A.V., "Limitations of laser diagonal measurements", Precision
   Engineering 27(4), 2003, 401-406.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.model.kinematics import UM, URAD
from volcal.plan.geometry import BODY_DIAGONALS
from volcal.session.format import Measurement

__all__ = ["DiagonalCheck", "SoonsCombinations", "body_diagonal_code", "diagonal_check",
           "soons_combinations", "soons_from_measurements"]

_SIGNS = {c: np.array([1.0 if ch == "p" else -1.0 for ch in c]) for c in BODY_DIAGONALS}


@dataclass(frozen=True)
class DiagonalCheck:
    """Quick-check figures of one diagonal measurement.

    Attributes
    ----------
    id : str
        Measurement id.
    max_abs_um : float
        Largest absolute deviation from the first reading [um].
    range_um : float
        Largest minus smallest deviation [um].
    end_um : float
        Deviation at the last reading [um].
    length_mm : float
        Length of the diagonal [mm].
    """

    id: str
    max_abs_um: float
    range_um: float
    end_um: float
    length_mm: float


@dataclass(frozen=True)
class SoonsCombinations:
    """What the four body diagonals determine (small-angle assumption).

    Attributes
    ----------
    positioning_um : float
        ``n_x dEXX + n_y dEYY + n_z dEZZ``: the mean end deviation of the 4 diagonals [um].
    squareness_urad : ndarray, shape (3,)
        EC0Y, EB0Z, EA0Z [urad].
    direction_cosines : ndarray, shape (3,)
        ``|dX|, |dY|, |dZ|`` over the diagonal length.
    length_mm : float
        Diagonal length ``D`` [mm].
    """

    positioning_um: float
    squareness_urad: NDArray[np.float64]
    direction_cosines: NDArray[np.float64]
    length_mm: float


def diagonal_check(measurements: Sequence[Measurement]) -> list[DiagonalCheck]:
    """Largest deviation and range of each diagonal: the quick volumetric check.

    Parameters
    ----------
    measurements : sequence of Measurement
        Diagonal measurements (other kinds are skipped).

    Returns
    -------
    list of DiagonalCheck
    """
    out = []
    for m in measurements:
        if m.kind != "diagonal":
            continue
        if m.deviation is None:
            raise VolcalInputError("diagonal has no deviations", m.file, None, "deviation_um")
        d = m.deviation - m.deviation[0]
        out.append(DiagonalCheck(m.id, float(np.abs(d).max()), float(np.ptp(d)), float(d[-1]),
                                 float(np.linalg.norm(m.positions[-1] - m.positions[0]))))
    return out


def body_diagonal_code(meas: Measurement) -> tuple[str, float]:
    """Which body diagonal a measurement runs along, and in which sense.

    Parameters
    ----------
    meas : Measurement
        A diagonal measurement whose first and last readings are opposite corners.

    Returns
    -------
    code : str
        ``'ppp'``, ``'npp'``, ``'pnp'`` or ``'ppn'``.
    sense : float
        +1 if measured in the code's direction, -1 if measured backwards (``'nnn'`` is
        ``'ppp'`` backwards).

    Raises
    ------
    VolcalInputError
        If the measurement is not a body diagonal (an axis does not move).
    """
    d = meas.positions[-1] - meas.positions[0]
    if np.any(np.abs(d) < 1e-6):
        raise VolcalInputError("not a body diagonal: every axis must move from the first to "
                               "the last reading", meas.file)
    s = np.sign(d)
    for code, sg in _SIGNS.items():
        if np.array_equal(s, sg):
            return code, 1.0
        if np.array_equal(s, -sg):
            return code, -1.0
    raise AssertionError("unreachable: every sign pattern is one of the 4 diagonals")


def soons_combinations(end_deviation_um: dict[str, float], span_mm: ArrayLike
                       ) -> SoonsCombinations:
    """Positioning combination and squareness from the end deviations of 4 body diagonals.

    Parameters
    ----------
    end_deviation_um : dict of str to float
        Deviation between the start and end corner of each diagonal ``ppp, npp, pnp,
        ppn``, each measured in its code's direction [um].
    span_mm : array_like, shape (3,)
        Travel covered by the diagonals in X, Y, Z [mm] (the same box for all four).

    Returns
    -------
    SoonsCombinations

    Raises
    ------
    ValueError
        If a diagonal is missing or the span is not positive.
    """
    missing = [c for c in BODY_DIAGONALS if c not in end_deviation_um]
    if missing:
        raise ValueError(f"missing body diagonal(s) {', '.join(missing)}: all four are needed")
    span = np.abs(np.asarray(span_mm, dtype=float).reshape(3))
    if np.any(span <= 0):
        raise ValueError("the diagonals must span every axis")
    D = float(np.linalg.norm(span))
    n = span / D
    d = np.array([end_deviation_um[c] for c in BODY_DIAGONALS])
    S = np.array([_SIGNS[c] for c in BODY_DIAGONALS])
    w_xy, w_xz, w_yz = S[:, 0] * S[:, 1], S[:, 0] * S[:, 2], S[:, 1] * S[:, 2]
    c = UM / URAD  # um/mm -> urad
    sq = np.array([-(w_xy @ d) / (4 * D * n[0] * n[1]),
                   (w_xz @ d) / (4 * D * n[0] * n[2]),
                   -(w_yz @ d) / (4 * D * n[1] * n[2])]) * c
    return SoonsCombinations(float(d.mean()), sq, n, D)


def soons_from_measurements(measurements: Sequence[Measurement]) -> SoonsCombinations:
    """Soons' combinations from the body-diagonal measurements of a session.

    Parameters
    ----------
    measurements : sequence of Measurement
        Measurements; the diagonal ones running corner to corner are used.

    Returns
    -------
    SoonsCombinations

    Raises
    ------
    VolcalInputError
        If one of the four diagonals is missing, measured twice, misses its end point (a
        missed capture), or the four do not span the same box.
    """
    ends: dict[str, float] = {}
    span = None
    for m in measurements:
        if m.kind != "diagonal" or m.meta.get("plane"):
            continue
        if m.deviation is None:
            raise VolcalInputError("diagonal has no deviations", m.file, None, "deviation_um")
        code, sense = body_diagonal_code(m)
        late = [r for r in m.missed if m.rows is None or r["row"] > int(np.max(m.rows))]
        if late:
            raise VolcalInputError(
                f"body diagonal {code} ({m.id}) misses its end point (row {late[-1]['row']}, "
                "a missed capture): the combinations need the end deviation of complete "
                "diagonals", m.file, late[-1]["row"], "deviation_um")
        if code in ends:
            raise VolcalInputError(f"body diagonal {code} appears twice", m.file)
        ends[code] = sense * float(m.deviation[-1] - m.deviation[0])
        sp = np.abs(m.positions[-1] - m.positions[0])
        if span is None:
            span = sp
        elif np.abs(sp - span).max() > 1e-6:
            raise VolcalInputError("the body diagonals must run between the corners of one "
                                   "box", m.file)
    missing = [c for c in BODY_DIAGONALS if c not in ends]
    if missing:
        raise VolcalInputError(f"missing body diagonal(s) {', '.join(missing)}: the "
                               "combinations need all four")
    assert span is not None
    return soons_combinations(ends, span)
