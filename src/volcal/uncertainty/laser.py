"""Contributors of a laser length reading: the measurement model of one set-up.

A laser deviation at signed distance ``L`` from the datum (where the reading was zeroed),
compensated for the air and referred to 20 degC as the session records it (by the laser
software, or by volcal on reading: :func:`volcal.environment.apply.prepare_readings`),
differs from the measurand by::

    Delta(L) = L [ dlambda/lambda - (dn/dt dt + dn/dp dp + dn/dRH dRH) / n ]   (laser, air)
             - L [ alpha (t_m - 20) ]  (material, ISO 1: the referral's uncertainty)
             + L (1 - cos theta)       (cosine error, one-sided: L theta^2 / 2)
             + d0 Delta_n              (dead path: the air's change during the test)

The budget never corrects a value: every term enters the uncertainty only, so that every
parameter has the same value with and without a budget.

* The wavelength, air and material inputs are **systematic**: one uncertain number per
  measurement, shared by every reading, so that their effect is proportional to ``L``
  (a scale error) and cancels in differences at the same target (reversal, repeatability).
* The material term is the product ``alpha (t_m - 20)``: first order ``L alpha u(t_m)`` and
  ``L |t_m - 20| u(alpha)``, plus its second-order part ``L u(alpha) u(t_m)`` (GUM H.1),
  which does not vanish at ``t_m = 20 degC``.
* The cosine error has zero first-order sensitivity to the misalignment ``theta`` (zero
  mean, standard uncertainty ``u_theta``); it is a one-sided bias of expectation
  ``L u_theta^2 / 2`` and standard deviation ``L u_theta^2 / sqrt(2)`` (for a normal
  ``theta``, ``theta^2 / u_theta^2`` is chi-square with one degree of freedom: mean 1,
  variance 2). It is not corrected: it enters the uncertainty as an uncorrected bias,
  with the root mean square of the error about zero as its standard uncertainty,
  ``sqrt(b^2 + u_b^2) = L sqrt(3) u_theta^2 / 2`` (GUM F.2.4.5; ``docs/uncertainty.md``).
* The dead path ``d0`` (laser to the reflector at the datum) is not compensated for the
  change of the air after zeroing: ``d0 Delta_n`` with ``u(Delta_n)`` from the change of
  the air during the test (``[air] change_*``). It varies with time, so every use
  (each mean of a target and direction) gets an independent term.

References
----------
.. [1] JCGM 100:2008 (GUM), H.1 (end-gauge calibration: the material product terms).
.. [2] ISO 230-2:2014, annex A (laser positioning measurement: wavelength, air,
   material temperature and expansion, misalignment, dead path).
.. [3] J. A. Stone and J. H. Zimmerman, "Index of Refraction of Air", NIST EMToolbox.
"""

from __future__ import annotations

import math
from typing import Any

from volcal.uncertainty.budget import Budget
from volcal.uncertainty.propagation import Propagator
from volcal.uncertainty.sensitivity import AirSensitivity, air_sensitivity

__all__ = ["COSINE_RMS_FACTOR", "LaserModel"]

COSINE_RMS_FACTOR = math.sqrt(3.0) / 2.0
"""Root mean square of ``theta^2 / 2`` in units of ``u_theta^2`` for a normal ``theta``:
``sqrt(E[theta^4]) / 2 = sqrt(3) u_theta^2 / 2``."""


class LaserModel:
    """The uncertain inputs of one laser set-up, shared by all its readings.

    Parameters
    ----------
    budget : Budget
        Validated budget.
    prop : Propagator
        The propagator the inputs are created on.
    """

    def __init__(self, budget: Budget, prop: Propagator) -> None:
        self.budget = budget
        self.prop = prop
        v, i = budget.values, budget.inputs
        self.air: AirSensitivity = air_sensitivity(
            v["air.temperature_c"], v["air.pressure_pa"], v["air.humidity_pct"],
            v["laser.wavelength_nm"], v["air.formula"], v["air.co2_ppm"])
        a = self.air

        def inp(label: str, key: str, value: float, unit: str) -> Any:
            q = i[key]
            return prop.input(label, value, q.u, q.dof, q.distribution, unit)

        # relative length errors [-] (zero-mean), one per measurement
        wl = inp("laser wavelength", "laser.u_wavelength_ppm", 0.0, "ppm")
        dt = inp("air temperature", "air.u_temperature_k", 0.0, "K")
        dp = inp("air pressure", "air.u_pressure_pa", 0.0, "Pa")
        dh = inp("air humidity", "air.u_humidity_pct", 0.0, "%RH")
        self.relative = 1e-6 * wl - (a.dn_dt * dt + a.dn_dp * dp + a.dn_dh * dh) / a.n
        alpha = inp("expansion coefficient", "material.u_expansion_ppm_per_k",
                    v["material.expansion_ppm_per_k"], "ppm/K")
        tm = inp("material temperature", "material.u_temperature_k",
                 v["material.temperature_c"] - 20.0, "K")
        mat = prop.product("expansion coefficient × material temperature", 1e-6, alpha, tm)
        self.material = mat - float(getattr(mat, "x", mat))  # the correction is applied
        th = i["setup.u_misalignment_urad"]
        u2 = (th.u * 1e-6) ** 2
        # an uncorrected one-sided bias: zero-valued, u = its root mean square about zero
        self.cosine = prop.input("misalignment (cosine error)", 0.0, COSINE_RMS_FACTOR * u2,
                                 th.dof, "chi-square (1)", "-")
        d0 = v["setup.dead_path_mm"] * 1e3
        ct, cp, ch = (i[f"air.change_{k}"].u for k in
                      ("temperature_k", "pressure_pa", "humidity_pct"))
        self.u_dead_path_um = d0 * math.hypot(a.dn_dt * ct, a.dn_dp * cp, a.dn_dh * ch) / a.n
        self._handles = {"wavelength": wl, "air_t": dt, "air_p": dp, "air_h": dh,
                         "alpha": alpha, "t_m": tm}

    def length_term(self, length_mm: float) -> Any:
        """Zero-valued uncertain correction of a deviation at ``L`` from the datum [um].

        Parameters
        ----------
        length_mm : float
            Signed distance from the datum [mm].

        Returns
        -------
        GTC.lib.UncertainReal or float
            ``L (relative - material + cosine)`` with ``L`` in um: the systematic part,
            correlated between all readings of the measurement.
        """
        Lum = float(length_mm) * 1e3
        return Lum * self.relative - Lum * self.material + Lum * self.cosine

    def dead_path(self) -> Any:
        """An independent dead-path term (zero mean) [um].

        Returns
        -------
        GTC.lib.UncertainReal or float
        """
        return self.prop.input("dead path (air change)", 0.0, self.u_dead_path_um,
                               distribution="normal", unit="um")
