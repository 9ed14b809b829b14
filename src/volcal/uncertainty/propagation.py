"""GUM propagation on the GUM Tree Calculator (GTC).

An uncertain number carries its components, so a budget is a query of the result, never
a table kept by hand. This module adds what GTC leaves to its user:

* **product terms** ``c x y`` of two uncertain inputs: their first-order part is GTC's;
  the second-order part ``c^2 u(x)^2 u(y)^2`` (GUM 5.1.2, note; the end-gauge example H.1)
  enters as a zero-mean component of its own, labelled ``x × y (2nd order)``, so that a
  product whose first-order sensitivity is zero (``x = 0``) is never silently dropped;
* **one-sided terms** (a bias with zero first-order sensitivity, e.g. the cosine error
  ``L (1 - cos θ)``): entered as a correction equal to the expectation with its standard
  uncertainty (GUM 6.3.1 note, F.2.4.5: correct a known bias, count its uncertainty);
* the **coverage factor** from the Welch-Satterthwaite effective degrees of freedom
  (GUM G.4.1) and Student's t at 95.45 % coverage, which is k = 2 exactly for infinite
  degrees of freedom (EA-4/02 M: 2022, table E.1; "k = 2 when the degrees of freedom
  are large").

References
----------
.. [1] JCGM 100:2008, Evaluation of measurement data - Guide to the expression of
   uncertainty in measurement (GUM), 5.1.2, G.4, H.1.
.. [2] B. D. Hall, "The GUM Tree Calculator", Measurement Standards Laboratory of New
   Zealand, https://gtc.readthedocs.io
.. [3] EA-4/02 M: 2022, Evaluation of the uncertainty of measurement in calibration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

__all__ = ["COVERAGE_PCT", "Component", "Estimate", "Propagator", "coverage_factor"]

#: Coverage probability [%] of the expanded uncertainty: the probability of a normal
#: distribution within +-2 sigma, so that k = 2 exactly for infinite degrees of freedom.
COVERAGE_PCT = 100.0 * math.erf(2.0 / math.sqrt(2.0))


def coverage_factor(dof: float, p_pct: float = COVERAGE_PCT) -> float:
    """Coverage factor k from Student's t distribution.

    Parameters
    ----------
    dof : float
        Effective degrees of freedom (``inf`` allowed; below 1 is taken as 1).
    p_pct : float
        Coverage probability [%].

    Returns
    -------
    float
        ``t_p(dof)``; 2.0 for infinite dof at the default coverage.
    """
    from GTC import reporting

    if not math.isfinite(dof):
        return 2.0 if p_pct == COVERAGE_PCT else float(reporting.k_factor(math.inf, p_pct))
    return float(reporting.k_factor(max(float(dof), 1.0), p_pct))


@dataclass(frozen=True)
class Component:
    """One line of a budget: an input's contribution to a result.

    Attributes
    ----------
    label : str
        The input (e.g. ``'air temperature'``).
    u : float
        Component of uncertainty ``|c| u(x)`` in the result's unit.
    share : float
        Fraction of the combined variance, ``u_i^2 / u_c^2`` [-].
    dof : float
        Degrees of freedom of the input.
    distribution : str
        Distribution of the input.
    sensitivity : float or None
        Sensitivity coefficient ``c`` (result unit per input unit), when defined.
    u_input : float or None
        Standard uncertainty of the input, in its own unit.
    unit : str
        Unit of the input.
    """

    label: str
    u: float
    share: float
    dof: float
    distribution: str = "normal"
    sensitivity: float | None = None
    u_input: float | None = None
    unit: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict (infinite dof written as ``null``)."""
        return {"label": self.label, "u": self.u, "share": self.share,
                "dof": None if not math.isfinite(self.dof) else self.dof,
                "distribution": self.distribution, "sensitivity": self.sensitivity,
                "u_input": self.u_input, "unit": self.unit}


@dataclass
class Estimate:
    """A result with its standard and expanded uncertainty.

    Attributes
    ----------
    value : float
        Estimate.
    u : float
        Combined standard uncertainty.
    dof : float
        Welch-Satterthwaite effective degrees of freedom.
    k : float
        Coverage factor (95.45 %, Student's t).
    U : float
        Expanded uncertainty ``k u``.
    components : list of Component
        Budget, largest first.
    """

    value: float
    u: float
    dof: float
    k: float
    U: float
    components: list[Component] = field(default_factory=list)


class Propagator:
    """Build a measurement model on GTC uncertain numbers and evaluate its budget.

    Parameters
    ----------
    second_order : bool
        Add the second-order part of product terms (default True).

    Examples
    --------
    >>> p = Propagator()
    >>> x = p.input("x", 1.0, 0.1)
    >>> y = p.input("y", 2.0, 0.2, dof=9)
    >>> round(p.estimate(x + y).u, 4)
    0.2236
    """

    def __init__(self, second_order: bool = True) -> None:
        self.second_order = second_order
        self._meta: dict[Any, tuple[str, float, str, float, str]] = {}
        self._inputs: dict[Any, Any] = {}

    def input(self, label: str, value: float, u: float, dof: float = math.inf,
              distribution: str = "normal", unit: str = "") -> Any:
        """An input quantity (a GTC ``ureal``).

        Parameters
        ----------
        label : str
            Name in the budget (inputs sharing a label are summed in the budget).
        value : float
            Estimate.
        u : float
            Standard uncertainty (>= 0).
        dof : float
            Degrees of freedom (``inf`` by default; GTC needs >= 1).
        distribution : str
            Recorded in the budget.
        unit : str
            Unit of ``value`` and ``u``.

        Returns
        -------
        GTC.lib.UncertainReal
        """
        from GTC import constant, ureal

        if u == 0.0:
            return constant(float(value), label=label)
        x = ureal(float(value), float(u), max(float(dof), 1.0), label=label)
        self._meta[x.uid] = (label, float(dof), distribution, float(u), unit)
        self._inputs[x.uid] = x
        return x

    def product(self, label: str, c: float, x: Any, y: Any) -> Any:
        """``c x y`` with its second-order part.

        Parameters
        ----------
        label : str
            Name of the second-order component.
        c : float
            Constant factor.
        x, y : uncertain or float
            Independent factors.

        Returns
        -------
        GTC.lib.UncertainReal
            ``c x y`` (first order by GTC) plus a zero-mean input of standard uncertainty
            ``|c| u(x) u(y)`` (when both are uncertain and ``second_order``).
        """
        out = c * x * y
        ux, uy = getattr(x, "u", 0.0), getattr(y, "u", 0.0)
        if self.second_order and ux > 0 and uy > 0:
            dx = self._meta.get(getattr(x, "uid", None), (None, math.inf))[1]
            dy = self._meta.get(getattr(y, "uid", None), (None, math.inf))[1]
            out = out + self.input(f"{label} (2nd order)", 0.0, abs(c) * ux * uy,
                                   min(dx, dy), unit="-")
        return out

    def bias(self, label: str, expectation: float, u: float, dof: float = math.inf,
             distribution: str = "normal", unit: str = "") -> Any:
        """A one-sided term: a correction equal to its expectation, with its uncertainty.

        Parameters
        ----------
        label : str
            Name in the budget.
        expectation : float
            Expected value of the term (the correction applied).
        u : float
            Standard deviation of the term.
        dof : float
            Degrees of freedom.
        distribution : str
            Recorded in the budget.
        unit : str
            Unit of the term.

        Returns
        -------
        GTC.lib.UncertainReal
        """
        return self.input(label, expectation, u, dof, distribution, unit)

    def estimate(self, y: Any) -> Estimate:
        """Value, u, effective dof, k, U and the budget of a result.

        Parameters
        ----------
        y : uncertain or float
            The result.

        Returns
        -------
        Estimate
            Components of the same label are combined (root sum of squares; their
            sensitivity and input u are then omitted).
        """
        from GTC import dof as gtc_dof
        from GTC import reporting

        if not hasattr(y, "u"):
            return Estimate(float(y), 0.0, math.inf, 2.0, 0.0, [])
        u = float(y.u)
        nu = float(gtc_dof(y)) if u > 0 else math.inf
        if nu > 1e12:
            nu = math.inf
        k = coverage_factor(nu)
        grouped: dict[str, list[Any]] = {}
        for inf in reporting.budget(y, trim=0):
            if inf.u == 0.0:
                continue
            grouped.setdefault(inf.label, []).append(inf)
        comps: list[Component] = []
        for label, items in grouped.items():
            ui = math.sqrt(sum(i.u**2 for i in items))
            meta = self._meta.get(items[0].uid, (label, math.inf, "normal", None, ""))
            sens = u_in = None
            if len(items) == 1 and meta[3] and items[0].uid in self._inputs:
                u_in = meta[3]
                sens = float(reporting.u_component(y, self._inputs[items[0].uid])) / u_in
            comps.append(Component(label, ui, ui**2 / u**2 if u > 0 else 0.0,
                                   min(self._meta.get(i.uid, meta)[1] for i in items),
                                   meta[2], sens, u_in, meta[4]))
        comps.sort(key=lambda c: -c.u)
        return Estimate(float(y.x), u, nu, k, k * u, comps)

