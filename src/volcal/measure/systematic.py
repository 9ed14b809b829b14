"""Systematic errors of a simulated laser measurement, drawn from an uncertainty budget.

So that the honesty of the reported uncertainty can be tested, ``volcal simulate
--budget`` draws, once per simulation, the errors the budget describes and applies them
to the readings as scale errors of the length readings (``linear``, ``diagonal``,
``step_diagonal``):

* the laser's vacuum wavelength: one relative error ``e_lambda`` for all measurements;
* the air sensors: per measurement (set-up), errors ``dt, dp, dRH`` of the sensors give
  the relative error ``-(dn/dt dt + dn/dp dp + dn/dRH dRH) / n`` of the compensation;
* the material: per machine axis, errors of the scale temperature ``dt_m`` and of the
  expansion coefficient ``dalpha`` give ``-(alpha dt_m + (t_m - 20) dalpha + dalpha dt_m)``
  on the displacement component along that axis.

The sensitivities (the air's ``dn/dt, dn/dp, dn/dRH, n``, the material's ``alpha`` and
``t_m - 20``) are taken at the operating point each measurement records, the budget's
where it records none (:meth:`volcal.uncertainty.budget.Budget.at`), as the
identification's systematic part takes them (:mod:`volcal.identify.systematic`); the
draws themselves (one per input, in the same order) do not depend on it, so that a
session recording no environment draws exactly what it drew before.

A reading at displacement ``d`` from the measurement's first reading along the beam ``n``
gains ``(e_lambda + e_air) (d . n) + sum_k e_k d_k n_k`` [um for d in um]. Each input is
drawn from its distribution with its standard uncertainty.

Direct optics (``straightness``, ``angular``): a scale error ``g`` of the optic, drawn
from ``[optics] u_<kind>_scale_pct`` once per optic (target: ``straightness_optics``,
``angular_optics``, ``level``, ``roll_optics``) and shared by every line read with it, or
once per line with ``scale_correlation = "measurement"``; the readings become
``y (1 + g)`` (the reference optic's slope included, as a real optic scales all it reads).
These draws come after the laser's, so that a session without optics draws what it drew
before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from volcal.model.names import AXES

__all__ = ["SystematicDraw", "apply_systematic", "draw_systematic"]



def _systematic(m: Any) -> str | None:
    """The measurement's systematic errors: ``'length'``, ``'optic'`` or None (its kind)."""
    from volcal.session.kinds import kind_of

    return kind_of(m.kind).systematic


@dataclass
class SystematicDraw:
    """Drawn systematic errors (relative, [-]).

    Attributes
    ----------
    wavelength : float
        Relative error of the vacuum wavelength.
    air : dict of str to float
        Relative compensation error per measurement id.
    material : dict of str to float
        Relative scale error per axis (``'X'``, ``'Y'``, ``'Z'``), at the budget's
        operating point.
    material_by_measurement : dict of str to dict
        Measurement id -> its relative scale error per axis, for the measurements that
        record another operating point (material temperature, expansion coefficient):
        the same draws of ``dt_m`` and ``dalpha`` at their ``alpha`` and ``t_m - 20``.
    optics : dict of str to float
        Relative scale error per direct optic (by target) or per line (by measurement id,
        ``scale_correlation = "measurement"``).
    """

    wavelength: float = 0.0
    air: dict[str, float] = field(default_factory=dict)
    material: dict[str, float] = field(default_factory=dict)
    optics: dict[str, float] = field(default_factory=dict)
    material_by_measurement: dict[str, dict[str, float]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """TOML-friendly dict in ppm (the optics' scale errors in percent)."""
        out = {"wavelength_ppm": self.wavelength * 1e6,
               "air_ppm": {k: v * 1e6 for k, v in self.air.items()},
               "material_ppm": {k: v * 1e6 for k, v in self.material.items()}}
        if self.optics:
            out["optics_scale_pct"] = {k: v * 1e2 for k, v in self.optics.items()}
        if self.material_by_measurement:
            out["material_by_measurement_ppm"] = {
                mid: {k: v * 1e6 for k, v in e.items()}
                for mid, e in self.material_by_measurement.items()}
        return out

    def material_of(self, meas_id: str) -> dict[str, float]:
        """The relative scale error per axis on one measurement's readings [-].

        Parameters
        ----------
        meas_id : str
            Measurement id.

        Returns
        -------
        dict of str to float
            Its own (at the operating point it records) or the budget's.
        """
        return self.material_by_measurement.get(meas_id, self.material)

    def optic_scale(self, meas: Any) -> float:
        """The drawn scale error of a direct-optics measurement.

        Parameters
        ----------
        meas : Measurement
            A straightness or angular measurement.

        Returns
        -------
        float
            Relative scale error [-]: the line's own (by id) or its optic's (by target),
            0 when none was drawn.
        """
        return self.optics.get(meas.id, self.optics.get(meas.target, 0.0))


def _draw(rng: np.random.Generator, inp: Any) -> float:
    u = inp.u
    if u == 0:
        return 0.0
    if inp.distribution == "rectangular":
        return float(rng.uniform(-math.sqrt(3) * u, math.sqrt(3) * u))
    if inp.distribution == "triangular":
        return float(rng.triangular(-math.sqrt(6) * u, 0.0, math.sqrt(6) * u))
    if inp.distribution == "arcsine":
        return float(math.sqrt(2) * u * math.sin(rng.uniform(0, 2 * math.pi)))
    return float(rng.normal(0.0, u))


def draw_systematic(session: Any, budget: Any, rng: np.random.Generator) -> SystematicDraw:
    """Draw the systematic errors of one simulated calibration.

    Parameters
    ----------
    session : Session
        The session (one air draw per length measurement, one scale draw per direct optic
        or per direct-optics line).
    budget : Budget
        The uncertainty budget (:mod:`volcal.uncertainty.budget`): its uncertainties, and
        its operating point where a measurement records none (the sensitivities at the
        operating point each measurement records, as the identification takes them).
    rng : numpy.random.Generator
        Random source (the draws do not depend on the operating point).

    Returns
    -------
    SystematicDraw
    """
    i = budget.inputs
    out = SystematicDraw(_draw(rng, i["laser.u_wavelength_ppm"]) * 1e-6)
    length = [m for m in session.measurements if _systematic(m) == "length"]
    at = {m.id: _at(budget, m) for m in length}  # the operating point each records
    airs: dict[int, Any] = {}
    for m in length:
        b = at[m.id]
        if id(b) not in airs:
            airs[id(b)] = _air(b)
        a = airs[id(b)]
        out.air[m.id] = -(a.dn_dt * _draw(rng, i["air.u_temperature_k"])
                          + a.dn_dp * _draw(rng, i["air.u_pressure_pa"])
                          + a.dn_dh * _draw(rng, i["air.u_humidity_pct"])) / a.n
    drawn: dict[str, tuple[float, float]] = {}
    for k in AXES:
        drawn[k] = (_draw(rng, i["material.u_temperature_k"]),
                    _draw(rng, i["material.u_expansion_ppm_per_k"]))
    out.material = _material(budget, drawn)
    for m in length:
        if at[m.id] is not budget:
            out.material_by_measurement[m.id] = _material(at[m.id], drawn)
    from volcal.uncertainty.budget import OPTIC_KEYS

    per_line = budget.values.get("optics.scale_correlation", "instrument") == "measurement"
    for m in session.measurements:
        if _systematic(m) == "optic" and m.target in OPTIC_KEYS:
            key = m.id if per_line else m.target
            inp = i.get(OPTIC_KEYS[m.target][0])
            if key not in out.optics and inp is not None:
                out.optics[key] = _draw(rng, inp) * 1e-2
    return out


def _at(budget: Any, m: Any) -> Any:
    """The budget at the operating point ``m`` records (``budget`` itself where none)."""
    if not hasattr(budget, "at"):
        return budget
    from volcal.environment.apply import thermal_record

    return budget.at(thermal_record(m)["operating_point"])


def _air(b: Any) -> Any:
    """The air's refractive index and its sensitivities at ``b``'s operating point."""
    from volcal.uncertainty.sensitivity import air_sensitivity

    v = b.values
    return air_sensitivity(v["air.temperature_c"], v["air.pressure_pa"], v["air.humidity_pct"],
                           v["laser.wavelength_nm"], v["air.formula"], v["air.co2_ppm"])


def _material(b: Any, drawn: dict[str, tuple[float, float]]) -> dict[str, float]:
    """Relative scale error per axis of the drawn ``(dt_m, dalpha)`` [-].

    At ``b``'s ``alpha`` and ``t_m - 20``.
    """
    v = b.values
    alpha, dt20 = v["material.expansion_ppm_per_k"], v["material.temperature_c"] - 20.0
    return {k: -(alpha * dt + dt20 * da + da * dt) * 1e-6 for k, (dt, da) in drawn.items()}


def apply_systematic(session: Any, draw: SystematicDraw) -> None:
    """Add the drawn systematic errors to the session's deviations, in place.

    Parameters
    ----------
    session : Session
        Session with simulated deviations [um].
    draw : SystematicDraw
        The errors (the direct optics' readings scaled by ``1 + g``).
    """
    for m in session.measurements:
        if _systematic(m) == "optic" and m.deviation is not None:
            m.deviation = np.asarray(m.deviation, dtype=float) * (1.0 + draw.optic_scale(m))
            continue
        if _systematic(m) != "length" or m.deviation is None:
            continue
        d = (np.asarray(m.positions, dtype=float) - np.asarray(m.positions[0], dtype=float))
        n = np.asarray(m.beam_direction, dtype=float)
        change = (draw.wavelength + draw.air.get(m.id, 0.0)) * (d @ n)
        material = draw.material_of(m.id)
        for k, ax in enumerate(AXES):
            change = change + material[ax] * d[:, k] * n[k]
        m.deviation = np.asarray(m.deviation, dtype=float) + change * 1e3
