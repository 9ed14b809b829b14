"""Systematic contributors of the budget carried into the identified model.

The identification's own uncertainty is the noise and prior part. The systematic inputs of
the laser budget (:mod:`volcal.uncertainty`) are not re-estimated as nuisances under the
evidence-tuned prior: they are propagated after the fit through the estimator's linear
gain. For a systematic input with standard uncertainty ``u`` that changes the readings by
``dy`` per unit, the estimate changes by ``dx = H^-1 A^T W dy / sigma^2`` (``H`` the
posterior precision, ``W`` the robust weights): one column ``dx u`` of a covariance factor
per input, kept apart from the noise factor.

Inputs (one column each):

* ``laser wavelength``: common to all measurements, ``dy = L u_rel`` with ``L`` the
  distance of the reading from the measurement's first reading along the beam;
* ``air, <measurement id>``: per set-up, the air sensors' relative uncertainty
  ``u_rel = |grad n . u| / n`` (temperature, pressure and humidity combined);
* ``material, <axis>``: per axis, ``u_rel = sqrt((alpha u_t)^2 + ((t - 20) u_alpha)^2 +
  (u_alpha u_t)^2)`` on the displacement component along that axis, projected on the beam.

* ``optics scale, <target>``: direct optics (``straightness``, ``angular``), the scale
  (calibration) error of the optic, ``dy = y u_rel`` with ``y`` the line's readings and
  ``u_rel`` the ``[optics] u_<kind>_scale_pct`` of its target: one column per optic
  (target), common to every line read with it (``[optics] scale_correlation =
  "instrument"``, the default: one kit in the case, and in an optical-square group the
  same interferometer and reflector read both lines), or one per line
  (``optics scale, <measurement id>`` with ``"measurement"``). The part of ``y u_rel`` that
  is the reference optic's slope or rotation goes to those nuisances, as a scale error of
  the set-up does.

The cosine and dead-path terms, and the optics' per-reading terms (``[optics]
u_straightness_um`` ...), vary from reading to reading and are left to the noise; the
optical square's certificate (``[references.NAME] u_square_urad``) is already a prior of
the fit (its u is in the noise and prior part, not counted again here); multilateration
readings (tracking interferometer) are not included.

References
----------
.. [1] JCGM 100:2008 (GUM), 5.2 (correlated input quantities: a common systematic input).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.model.names import AXES
from volcal.session.kinds import kind_of

__all__ = ["LENGTH_KINDS", "OPTIC_KINDS", "attach_systematic", "optic_scale_inputs",
           "systematic_factor", "systematic_inputs"]

#: Measurement kinds whose readings are lengths along the beam (``Kind.systematic``).
LENGTH_KINDS: tuple[str, ...] = ("linear", "diagonal", "step_diagonal")
#: Direct-optics kinds (a scale error of the optic: one column per optic or per line).
OPTIC_KINDS: tuple[str, ...] = ("straightness", "angular")


def _systematic(m) -> str | None:
    """The measurement's systematic errors: ``'length'``, ``'optic'`` or None (its kind)."""
    return kind_of(m.kind).systematic


def optic_scale_inputs(design: Any, budget: Any) -> list[tuple[str, NDArray[np.float64]]]:
    """The reading changes of the optics' scale errors at one standard uncertainty.

    Parameters
    ----------
    design : Design
        The identification's observation system.
    budget : Budget
        The uncertainty budget (its ``[optics]`` section, or its defaults).

    Returns
    -------
    list of (str, ndarray)
        ``('optics scale, <target>', dy)`` per optic (``scale_correlation = "instrument"``)
        or ``('optics scale, <id>', dy)`` per line (``"measurement"``); ``dy`` in the
        design's weighted rows (the optic's reading [um or urad] times its
        :func:`volcal.measure.optics.row_weight`), zero elsewhere; zero uncertainties left
        out.
    """
    from volcal.measure.optics import row_weight
    from volcal.uncertainty.budget import OPTIC_KEYS

    per_line = budget.values.get("optics.scale_correlation", "instrument") == "measurement"
    n_rows = design.A.shape[0]
    cols: dict[str, NDArray[np.float64]] = {}
    for m in design.measurements:
        if _systematic(m) != "optic" or m.deviation is None or m.target not in OPTIC_KEYS:
            continue
        inp = budget.inputs.get(OPTIC_KEYS[m.target][0])
        if inp is None or inp.u == 0:
            continue
        key = f"optics scale, {m.id if per_line else m.target}"
        col = cols.setdefault(key, np.zeros(n_rows))
        col[design.rows[m.id]] = (np.asarray(m.deviation, dtype=float) * row_weight(m)
                                  * inp.u * 1e-2)
    return [(k, c) for k, c in cols.items() if np.any(c)]


def systematic_inputs(design: Any, budget: Any) -> list[tuple[str, NDArray[np.float64]]]:
    """The reading changes of each systematic input at one standard uncertainty.

    Parameters
    ----------
    design : Design
        The identification's observation system (rows of every measurement).
    budget : Budget
        The uncertainty budget (:func:`volcal.uncertainty.budget.read_budget`).

    Returns
    -------
    list of (str, ndarray)
        Label and ``dy`` [um] for every row of ``design.A`` (zero outside the readings of
        length measurements), then the optics' scale errors
        (:func:`optic_scale_inputs`); inputs with zero uncertainty are left out.
    """
    i = budget.inputs
    u_wl = i["laser.u_wavelength_ppm"].u * 1e-6
    n_rows = design.A.shape[0]
    wl = np.zeros(n_rows)
    mat = np.zeros((3, n_rows))
    out: list[tuple[str, NDArray[np.float64]]] = []
    for m in design.measurements:
        if _systematic(m) != "length":
            continue
        # the sensitivities at the environment the session records (the budget's where none)
        u_air, u_mat = _relative_u(budget, m)
        rows = design.rows[m.id]
        disp = np.asarray(m.positions, dtype=float) - np.asarray(m.positions[0], dtype=float)
        beam = np.asarray(m.beam_direction, dtype=float)
        L = disp @ beam * 1e3                                   # [um]
        wl[rows] = L * u_wl
        for k in range(3):
            mat[k, rows] = disp[:, k] * beam[k] * 1e3 * u_mat
        if u_air > 0:
            col = np.zeros(n_rows)
            col[rows] = L * u_air
            out.append((f"air, {m.id}", col))
    if u_wl > 0:
        out.insert(0, ("laser wavelength", wl))
    out.extend((f"material, {AXES[k]}", mat[k]) for k in range(3) if np.any(mat[k]))
    return out + optic_scale_inputs(design, budget)


def _relative_u(budget: Any, m: Any) -> tuple[float, float]:
    """Relative u of the air and of the material term of one length measurement [-].

    The budget's operating point serves only where the measurement's session records no
    environment (:meth:`volcal.uncertainty.budget.Budget.at`).
    """
    from volcal.environment.apply import thermal_record
    from volcal.uncertainty.sensitivity import air_sensitivity

    b = budget.at(thermal_record(m)["operating_point"]) if hasattr(budget, "at") else budget
    v, i = b.values, b.inputs
    a = air_sensitivity(v["air.temperature_c"], v["air.pressure_pa"], v["air.humidity_pct"],
                        v["laser.wavelength_nm"], v["air.formula"], v["air.co2_ppm"])
    u_air = math.hypot(a.dn_dt * i["air.u_temperature_k"].u, a.dn_dp * i["air.u_pressure_pa"].u,
                       a.dn_dh * i["air.u_humidity_pct"].u) / a.n
    alpha, ua = v["material.expansion_ppm_per_k"], i["material.u_expansion_ppm_per_k"].u
    ut, dt = i["material.u_temperature_k"].u, v["material.temperature_c"] - 20.0
    u_mat = math.sqrt((alpha * ut) ** 2 + (dt * ua) ** 2 + (ua * ut) ** 2) * 1e-6
    return u_air, u_mat


def systematic_factor(design: Any, solution: Any, budget: Any
                      ) -> tuple[NDArray[np.float64], list[str]]:
    """Covariance factor of the estimated parameters from the systematic inputs.

    Parameters
    ----------
    design : Design
        Observation system of the fit.
    solution : Solution
        The fit (its ``solve`` applies the inverse posterior precision, or its dense
        ``covariance``), with ``sigma_um``.
    budget : Budget
        The uncertainty budget.

    Returns
    -------
    factor : ndarray, shape (n_free, k)
        ``dx u`` of each input for the free parameters [um, urad]; ``factor factor^T`` is
        the systematic covariance.
    labels : list of str
        Input of each column.

    Raises
    ------
    VolcalInputError
        When the fit keeps neither a solver nor a covariance (very large designs).
    """
    inputs = systematic_inputs(design, budget)
    nf = design.n_free
    if not inputs:
        return np.zeros((nf, 0)), []
    w = np.ones(design.A.shape[0]) if design.row_scale is None else np.asarray(
        design.row_scale, dtype=float)
    if design.row_scale is not None and design.row_scale.size < design.A.shape[0]:
        w = np.concatenate([w, np.ones(design.A.shape[0] - w.size)])
    rhs = np.stack([design.A.T @ (w * dy) for _, dy in inputs], axis=1) / solution.sigma_um**2
    if getattr(solution, "solve", None) is not None:
        dx = np.stack([solution.solve(rhs[:, j]) for j in range(rhs.shape[1])], axis=1)
    elif getattr(solution, "covariance", None) is not None:
        dx = solution.covariance @ rhs
    else:
        raise VolcalInputError("this fit keeps neither its solver nor its covariance: the "
                               "systematic part cannot be propagated")
    return np.asarray(dx[:nf]), [lab for lab, _ in inputs]


def attach_systematic(result: Any, budget: Any, source: str = "") -> Any:
    """Give an identification result the systematic part of a budget.

    Parameters
    ----------
    result : IdentificationResult
        A fresh result of :func:`volcal.identify.identify` (with its design and solution).
    budget : Budget
        The uncertainty budget.
    source : str
        Name of the budget file, recorded in the model file.

    Returns
    -------
    IdentificationResult
        The same object, with ``sys_factor``, ``sys_labels`` and ``sys_source`` set.

    Raises
    ------
    VolcalInputError
        A result read from a model file (no design): identify the session again.
    """
    if getattr(result, "design", None) is None or getattr(result, "solution", None) is None:
        raise VolcalInputError("the systematic part is propagated through the fit: identify "
                               "the session with --budget (a model file has no design)")
    result.sys_factor, result.sys_labels = systematic_factor(result.design, result.solution,
                                                             budget)
    result.sys_source = str(source)
    return result
