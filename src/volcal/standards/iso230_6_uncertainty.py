"""Expanded uncertainty of an ISO 230-6 diagonal displacement result.

The diagonal is a positioning test along the beam, so the laser budget applies along it
with the distance from the start point as ``L`` (:mod:`volcal.uncertainty.laser`):

* with bidirectional runs the ISO 230-2 evaluation along the diagonal carries the
  uncertainty of every parameter (:mod:`volcal.standards.iso230_2_uncertainty`), and
  ``U(E_D) = U(E)``;
* with one run (the usual quick check) ``E_D`` is the range of the deviations: the
  systematic terms enter by the difference of the lengths of the highest and the lowest
  reading, plus the dead-path terms; one run gives no repeatability, and the output says
  so.

The readings are evaluated as the session records them (referred to 20 degC where it is
read, :func:`volcal.environment.apply.prepare_readings`): the budget corrects no value,
its ``[material]`` serves the sensitivities where the measurement records none.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from volcal.standards.iso230_2_uncertainty import Iso2302Uncertainty, iso230_2_uncertainty
from volcal.uncertainty.budget import Budget
from volcal.uncertainty.propagation import Estimate

__all__ = ["DiagonalUncertainty", "evaluate_diagonal_with_budget"]


@dataclass
class DiagonalUncertainty:
    """Uncertainty of one diagonal's result.

    Attributes
    ----------
    E_D : Estimate
        Diagonal displacement error with its U [um].
    iso230_2 : Iso2302Uncertainty or None
        Uncertainty of the ISO 230-2 parameters along the diagonal (bidirectional runs).
    notes : list of str
        What was assumed.
    """

    E_D: Estimate
    iso230_2: Iso2302Uncertainty | None = None
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """``U_E_D``, ``k_E_D`` and notes (JSON-friendly)."""
        return {"U_E_D": self.E_D.U, "k_E_D": self.E_D.k, "u_E_D": self.E_D.u,
                "uncertainty_notes": list(self.notes)}


def evaluate_diagonal_with_budget(meas: Any, budget: Budget, edition: str = "2014"
                                  ) -> tuple[Any, DiagonalUncertainty]:
    """Refer a diagonal's readings to 20 degC, evaluate it (ISO 230-6) with its U.

    Parameters
    ----------
    meas : Measurement
        A ``diagonal`` measurement with deviations [um].
    budget : Budget
        The budget (``[setup] datum_mm`` is not used: the datum is the start point).
    edition : str
        ISO 230-2 edition of bidirectional runs.

    Returns
    -------
    result : DiagonalResult
        Of the readings (the same as without a budget).
    unc : DiagonalUncertainty
    """
    from volcal.standards.iso230_2_uncertainty import budget_for
    from volcal.standards.iso230_6 import evaluate_diagonal
    from volcal.uncertainty.laser import LaserModel
    from volcal.uncertainty.propagation import Propagator

    if meas.deviation is None or meas.kind != "diagonal":
        evaluate_diagonal(meas, edition)  # raises the reader's error (kind, no readings)
    budget = budget_for(meas, budget)  # the session's operating point; no value corrected
    s = (meas.positions - meas.positions[0]) @ meas.beam_direction
    m = meas
    res = evaluate_diagonal(m, edition)
    notes = list(budget.notes) + ["datum: the start point of the diagonal"]
    if res.iso230_2 is not None:
        u = iso230_2_uncertainty(res.iso230_2, budget, 0.0)
        return res, DiagonalUncertainty(u.parameters["E"], u, notes)
    prop = Propagator()
    laser = LaserModel(budget, prop)
    d = np.asarray(m.deviation)
    hi, lo = int(np.argmax(d)), int(np.argmin(d))
    expr = ((float(d[hi]) + laser.length_term(s[hi]) + laser.dead_path())
            - (float(d[lo]) + laser.length_term(s[lo]) + laser.dead_path()))
    notes.append("one run: no repeatability in U(E_D) (ISO 230-6 with bidirectional runs "
                 "gives it)")
    return res, DiagonalUncertainty(prop.estimate(expr), None, notes)
