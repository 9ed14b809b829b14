r"""The linear axes' model as a prior of the location errors' identification.

The sphere readings of a 5-axis machine (probe-on-sphere centres, R-test displacements)
depend on the linear axes' errors at the poses' linear positions as much as on the rotary
axes' location errors: the linear axes move by the pivot-to-sphere distance between poses.
``volcal locate --model MODEL.json`` takes the laser model of the same machine
(``volcal identify``) as known **with its uncertainty**: its estimate enters the forward
model, and its posterior covariance ``Sigma = L L^T`` (the model's covariance factor, noise
and systematic parts) enters the readings' covariance

.. math:: C = \operatorname{diag}(\sigma^2) + G L L^T G^T + \operatorname{diag}(v_\mathrm{nug}),

with ``G = d(reading)/d(theta_lin)`` the readings' sensitivity to the model's parameters
(central differences of the exact forward model of :mod:`volcal.measure.spheres`, one per
parameter the poses touch) and ``v_nug`` the model's variance of the positioning errors
between its nodes (:meth:`IdentificationResult.nugget_variance`). Generalised least squares
with ``C`` is the joint estimate of the location errors and the linear parameters under the
model's Gaussian posterior as prior, the linear parameters marginalised (Kaipio &
Somersalo, *Statistical and Computational Inverse Problems*, 2005, 3.3; the "approximation
error" treatment of uncertain model parameters); the location errors' covariance then
includes the linear model's uncertainty.

An error table (``machine.csv``, a simulation's truth) or a model without its binary part
carries no covariance: its errors are taken as known, and the report says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.measure.spheres import SphereReadings, probe_centres, rtest_readings
from volcal.model.fiveaxis import FiveAxisMachine

__all__ = ["LinearPrior", "linear_prior", "linear_prior_note", "undetermined"]

Array = NDArray[np.float64]
UM = 1e-3


@dataclass
class LinearPrior:
    """The linear model's uncertainty as it acts on the sphere readings.

    Attributes
    ----------
    source : str
        What the linear errors are: ``'model with covariance'``, ``'model without
        uncertainty'`` or ``'error table'``.
    factor_rows : ndarray, shape (n, r)
        ``G L``: the readings' response to each column of the model's covariance factor
        [um per standard deviation], in the order of the blocks' readings.
    nugget_var : ndarray, shape (n,)
        Variance of the readings from the model's positioning errors between its nodes
        [um^2].
    parameters : int
        Layout parameters the poses' linear positions touch.
    notes : list of str
        What is left out (positions outside the model's travel).
    undetermined : list of str
        The model's functions its readings hardly determine (``determined_fraction``
        below :data:`UNDETERMINED_FRACTION`): their covariance is the identification's
        prior, not a measurement of this machine.
    determined_rows : ndarray, shape (n, r), or None
        ``factor_rows`` with the undetermined functions' parameters left out (taken as
        known); None when none is undetermined.
    """

    source: str
    factor_rows: Array = field(default_factory=lambda: np.zeros((0, 0)))
    nugget_var: Array = field(default_factory=lambda: np.zeros(0))
    parameters: int = 0
    notes: list[str] = field(default_factory=list)
    undetermined: list[str] = field(default_factory=list)
    determined_rows: Array | None = None

    @property
    def has_uncertainty(self) -> bool:
        """Whether the prior carries a covariance."""
        return self.factor_rows.size > 0

    def reading_std_um(self) -> Array:
        """Standard deviation of each reading from the linear model's uncertainty [um]."""
        if not self.has_uncertainty:
            return np.zeros(self.nugget_var.size)
        return np.asarray(np.sqrt(np.sum(self.factor_rows**2, axis=1) + self.nugget_var))

    def covariance(self, n: int) -> Array:
        """The readings' covariance from the linear model [um^2].

        Parameters
        ----------
        n : int
            Number of readings (the shape of the zero matrix without a covariance).

        Returns
        -------
        ndarray, shape (n, n)
        """
        if not self.has_uncertainty:
            return np.zeros((n, n))
        return self._from(self.factor_rows)

    def _from(self, F: Array) -> Array:
        """``F F^T`` plus the nugget's diagonal [um^2]."""
        return np.asarray(F @ F.T + np.diag(self.nugget_var))

    def covariance_determined(self, n: int) -> Array | None:
        """The readings' covariance from the model's determined functions alone [um^2].

        The part of :meth:`covariance` left when the functions the model's readings hardly
        determine (:attr:`undetermined`) are taken as known: what the location errors' U
        would be without the identification's prior statement about them.

        Parameters
        ----------
        n : int
            Number of readings.

        Returns
        -------
        ndarray, shape (n, n), or None
            None when no function is undetermined.
        """
        if self.determined_rows is None:
            return None
        return self._from(self.determined_rows)

    def to_json(self) -> dict[str, Any]:
        """The ``linear_model`` entry of ``volcal locate --json``."""
        s = self.reading_std_um()
        return {"source": self.source, "with_uncertainty": self.has_uncertainty,
                "parameters": self.parameters,
                "reading_u_um_max": float(s.max()) if s.size else 0.0,
                "reading_u_um_rms": float(np.sqrt(np.mean(s**2))) if s.size else 0.0,
                "notes": list(self.notes), "undetermined": list(self.undetermined)}


def _predict_um(machine: FiveAxisMachine, blocks: Sequence[SphereReadings]) -> Array:
    """Every reading of the blocks on a machine [um], nominal spheres."""
    out = []
    for b in blocks:
        if b.kind == "probe":
            v = probe_centres(machine, b.angles, b.sphere_mm, b.tool_offset_mm,
                              q0=b.values) / UM
        else:
            assert b.q_mm is not None
            v = rtest_readings(machine, b.q_mm, b.angles, b.sphere_mm, b.tool_offset_mm)
        out.append(np.asarray(v, dtype=float).reshape(-1))
    return np.concatenate(out)


def _positions(blocks: Sequence[SphereReadings]) -> Array:
    return np.vstack([np.asarray(b.values if b.kind == "probe" else b.q_mm, dtype=float)
                      for b in blocks])


def linear_prior(model: Any, nominal: FiveAxisMachine, blocks: Sequence[SphereReadings]
                 ) -> LinearPrior:
    """The linear model's covariance on the sphere readings.

    Parameters
    ----------
    model : IdentificationResult or MachineErrors
        The linear model (``volcal identify``'s, with its covariance) or bare errors.
    nominal : FiveAxisMachine
        The configured machine with the model's errors as its linear errors.
    blocks : sequence of SphereReadings
        The readings.

    Returns
    -------
    LinearPrior
    """
    q = _positions(blocks)
    n = sum(3 * b.n_poses for b in blocks)
    layout = getattr(model, "layout", None)
    cov = getattr(model, "cov_factor", None)
    if layout is None:
        return LinearPrior("error table", nugget_var=np.zeros(n))
    if cov is None:
        return LinearPrior("model without uncertainty", nugget_var=np.zeros(n))
    factor = model._factor(True)
    L = np.zeros((layout.size, factor.shape[1]))
    L[model.free] = factor
    # the parameters the poses touch: the two nodes around each position, the squareness
    from volcal.model.errorfunctions import interp_weights

    touched: set[int] = set(int(i) for i in layout.squareness_indices())
    notes: list[str] = []
    travel = model.errors.travel
    for k in range(3):
        i0, i1, _ = interp_weights(layout.nodes[k], q[:, k])
        for i in np.unique(np.concatenate([i0, i1])):
            touched.update(int(j) for j in layout.starts[k] + 6 * int(i) + np.arange(6))
        out = (q[:, k] < travel[k, 0] - 1e-6) | (q[:, k] > travel[k, 1] + 1e-6)
        if out.any():
            notes.append(f"{int(out.sum())} pose(s) put {'XYZ'[k]} outside the model's travel "
                         f"{travel[k, 0]:g}..{travel[k, 1]:g} mm: its errors there are the "
                         "end node's (no extrapolation)")
    idx = sorted(j for j in touched if np.any(L[j] != 0.0))
    col = {j: c for c, j in enumerate(idx)}

    def machine(lin: Any) -> FiveAxisMachine:
        return FiveAxisMachine(nominal.chain_obj, nominal.rotary, lin, nominal.name)

    h = 1.0  # [um or urad]: the readings are linear in it to far below a nanometre
    G = np.zeros((n, len(idx)))
    # each pose's readings depend on the component errors at its own positions only: a
    # uniform step of one component function gives its derivative at every pose at once,
    # spread onto the two nodes around each pose by the interpolation weights
    for k in range(3):
        i0, i1, wt = interp_weights(layout.nodes[k], q[:, k])
        for c in range(6):
            up, down = model.errors.copy(), model.errors.copy()
            up.values[k][:, c] += h
            down.values[k][:, c] -= h
            d = ((_predict_um(machine(up), blocks) - _predict_um(machine(down), blocks))
                 / (2 * h)).reshape(-1, 3)
            for nodes, weight in ((i0, 1.0 - wt), (i1, wt)):
                for pose in range(q.shape[0]):
                    j = int(layout.starts[k] + 6 * nodes[pose] + c)
                    if j in col:
                        G[3 * pose:3 * pose + 3, col[j]] += weight[pose] * d[pose]
    for a, j in enumerate(layout.squareness_indices()):
        if int(j) not in col:
            continue
        up, down = model.errors.copy(), model.errors.copy()
        up.squareness[a] += h
        down.squareness[a] -= h
        G[:, col[int(j)]] = ((_predict_um(machine(up), blocks)
                              - _predict_um(machine(down), blocks)) / (2 * h))
    F = G @ L[idx]
    under = undetermined(model)
    determined_rows = None
    if under:
        from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

        owner = np.empty(layout.size, dtype=object)
        for k in range(3):
            for c in range(6):
                owner[layout.indices(k, c)] = COMPONENT_NAMES[6 * k + c]
        owner[layout.squareness_indices()] = SQUARENESS_NAMES
        keep = np.array([owner[j] not in under for j in idx], dtype=bool)
        determined_rows = G[:, keep] @ L[idx][keep]
    # positioning errors between the nodes: uncorrelated, along the machine axes
    nug = np.zeros(n)
    from volcal.session.r_test import head_rotation

    row = 0
    for b in blocks:
        qb = np.asarray(b.values if b.kind == "probe" else b.q_mm, dtype=float)
        v = np.column_stack([model.nugget_variance(k, qb[:, k]) for k in range(3)])
        if b.kind == "rtest":
            R = head_rotation(nominal.chain_obj, b.angles)
            v = np.einsum("mki,mk->mi", R**2, v)  # diagonal of R^T diag(v) R
        nug[row:row + 3 * b.n_poses] = v.reshape(-1)
        row += 3 * b.n_poses
    return LinearPrior("model with covariance", F, nug, len(idx), notes, under,
                       determined_rows)


def linear_prior_note(prior: LinearPrior, model: Any) -> str:
    """The report's sentence on the linear model, in plain words.

    Parameters
    ----------
    prior : LinearPrior
        The prior.
    model : IdentificationResult or MachineErrors
        The linear model as loaded: the functions its readings hardly determine
        (``report.determined_fraction`` below :data:`UNDETERMINED_FRACTION`) are named.
    """
    name = "the error table given" if prior.source == "error table" else "the model given"
    if not prior.has_uncertainty:
        why = ("an error table carries no uncertainty" if prior.source == "error table"
               else "the model was loaded without its uncertainty (its binary part)")
        return (f"The linear axes' errors are those of {name}, taken as known ({why}): the "
                "location errors' U does not include them.")
    s = prior.reading_std_um()
    text = (f"The linear axes' errors are those of {name}, with its uncertainty: the model's "
            f"covariance on the {prior.parameters} parameters the poses' linear positions "
            f"touch moves the readings by up to {s.max():.2f} um (1 standard deviation, RMS "
            f"{np.sqrt(np.mean(s**2)):.2f} um), and the location errors' U includes it.")
    return " ".join([text, *_undetermined_note(prior.undetermined), *prior.notes])


#: Share of a function's prior variance its readings remove below which the linear model is
#: said not to measure it (``IdentifiabilityReport.determined_fraction``).
UNDETERMINED_FRACTION = 0.5


def undetermined(model: Any) -> list[str]:
    """The functions a model's readings hardly determine.

    Parameters
    ----------
    model : IdentificationResult or object
        A model with ``report.determined_fraction`` (a dict report, as loaded, or the
        report object); anything else has none.

    Returns
    -------
    list of str
        Function names whose determined fraction is below :data:`UNDETERMINED_FRACTION`.
    """
    report = getattr(model, "report", None)
    frac = (report.get("determined_fraction") if isinstance(report, dict)
            else getattr(report, "determined_fraction", None)) or {}
    return [n for n, f in frac.items() if float(f) < UNDETERMINED_FRACTION]


def _undetermined_note(under: list[str]) -> list[str]:
    """The sentence on the functions whose share of U is the prior's."""
    if not under:
        return []
    return [f"The model's readings determine less than half of the prior variance of "
            f"{', '.join(under)}: their share of that U is the identification's prior for a "
            "typical machine, not a measurement of this one, and where this machine's errors "
            "are larger the location errors are covered less (on virtual machines, of the "
            "R-test's location errors within 2u: 0.89 with a laser model without its rolls "
            "measured, 0.49 with a model of X's lines alone; benchmarks/README.md, \"fused "
            "with the laser model\"). Measuring them (volcal advise on the laser session) "
            "makes U this machine's."]
