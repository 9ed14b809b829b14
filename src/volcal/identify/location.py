r"""Location errors of the rotary axes from sphere readings: identifiability and estimate.

**Identifiability.** The readings of a design (probe-on-sphere centres, R-test
displacements) depend on the location errors ``x`` and on nuisances ``n`` (each sphere's
centre, each R-test's sensor zero) through the Jacobian ``[J_x  J_n]`` taken at the
nominal machine. A location error whose column lies in the span of the nuisance columns
and of the errors kept before it is *redundant*: no reading separates it. The analysis
walks the errors in a preference order (positions, then orientations, then zeros of the
angle, axes nearest the frame first), keeps each one that adds a direction the readings
see (projection residual of its unit column above ``tol``) and fixes the others at zero.
That is a parametrisation identifiable by construction; the price is that each kept error
is determined only in combination with the fixed ones: ``J_g = J_kept k_g`` gives, for
each fixed ``g``, the coefficients ``k_g`` with which it shifts the kept errors
(``x_kept + sum_g k_g x_g`` is what the design determines) and the nuisances (a redundant
error wholly absorbed by a sphere's position is a redefinition of the workpiece zero).

**Estimate.** Gauss-Newton on the exact forward models (:mod:`volcal.measure.spheres`),
the Jacobian re-evaluated at each iterate (exact at any error state), weighted by the
probe noise; optional Gaussian priors on the kept errors (zero mean, stated standard
deviation), flat priors on the nuisances. The covariance is the linearised posterior
``(J^T W J + \Lambda)^{-1}`` at the solution, scaled by nothing (the stated noise is
used, and the residual's chi-square is reported beside it).

References: Ibaraki, Iritani, Matsushita (2012), section 3 (the eight location errors of
a tilting rotary table identifiable by probing); ISG measuring cycle documentation ("lack
of kinematic separation"); Golub & Van Loan, *Matrix Computations*, 4th ed., 5.4 (QR with
column pivoting).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.measure.spheres import (
    SphereReadings,
    probe_jacobian,
    rtest_jacobian,
    rtest_readings,
)
from volcal.model.fiveaxis import FiveAxisMachine, location_parameter_names
from volcal.model.names import describe, info

__all__ = [
    "LocationIdentifiability",
    "LocationResult",
    "analyse_location",
    "design_jacobian",
    "identify_location",
]

Array = NDArray[np.float64]
UM = 1e-3


def _predict(block: SphereReadings, machine: FiveAxisMachine, nuis: dict[str, float],
             components: bool = False):
    """Prediction [um or mm], its error Jacobian [um/unit] and nuisance Jacobian of a block."""
    s = np.array([nuis[f"{block.sphere}:s{a}"] for a in "xyz"])
    if block.kind == "probe":
        names, q, dE, dS = probe_jacobian(machine, block.angles, s, block.tool_offset_mm,
                                          components=components)
        return names, q / UM, dE, {f"{block.sphere}:s{a}": dS[:, :, i]
                                   for i, a in enumerate("xyz")}
    assert block.q_mm is not None
    zero = np.array([nuis[f"{block.id}:zero_{a}"] for a in "xyz"])
    r = rtest_readings(machine, block.q_mm, block.angles, s, block.tool_offset_mm) + zero
    names, dE, dS = rtest_jacobian(machine, block.q_mm, block.angles, s, block.tool_offset_mm,
                                   components=components)
    cols = {f"{block.sphere}:s{a}": dS[:, :, i] for i, a in enumerate("xyz")}
    for i, a in enumerate("xyz"):
        e = np.zeros((block.n_poses, 3))
        e[:, i] = 1.0
        cols[f"{block.id}:zero_{a}"] = e
    return names, r, dE, cols


def _nuisance_start(blocks: Sequence[SphereReadings]) -> dict[str, float]:
    out: dict[str, float] = {}
    for b in blocks:
        for i, a in enumerate("xyz"):
            out.setdefault(f"{b.sphere}:s{a}", float(b.sphere_mm[i]))
            if b.kind == "rtest":
                out.setdefault(f"{b.id}:zero_{a}", 0.0)
    return out


def design_jacobian(machine: FiveAxisMachine, blocks: Sequence[SphereReadings],
                    nuisances: dict[str, float] | None = None):
    """Stacked, noise-weighted Jacobian of a design on errors and nuisances.

    Parameters
    ----------
    machine : FiveAxisMachine
        Where to linearise (the nominal machine for the analysis).
    blocks : sequence of SphereReadings
        The design (only poses, spheres and tool offsets are used).
    nuisances : dict, optional
        Nuisance values (sphere centres [mm], sensor zeros [um]); default the nominal.

    Returns
    -------
    J_x : ndarray, shape (n, P)
        Weighted rows on the location errors [1 per um or urad].
    J_n : ndarray, shape (n, N)
        Weighted rows on the nuisances.
    nuisance_names : list of str
    prediction : ndarray, shape (n,)
        Predicted readings, unweighted [um].
    weights : ndarray, shape (n,)
        1 / noise [1/um].
    """
    nuis = dict(_nuisance_start(blocks)) if nuisances is None else nuisances
    nnames = list(nuis)
    rows_x, rows_n, pred, wts = [], [], [], []
    for b in blocks:
        _, r, dE, cols = _predict(b, machine, nuis)
        m = b.n_poses
        Jn = np.zeros((3 * m, len(nnames)))
        for k, v in cols.items():
            # sphere centre columns are per mm of centre; the reading is in um
            Jn[:, nnames.index(k)] = v.reshape(-1) * (1.0 / UM if ":s" in k else 1.0)
        w = np.full(3 * m, 1.0 / b.noise_um)
        rows_x.append(dE.reshape(3 * m, -1) * w[:, None])
        rows_n.append(Jn * w[:, None])
        pred.append(r.reshape(-1))
        wts.append(w)
    return (np.vstack(rows_x), np.vstack(rows_n), nnames, np.concatenate(pred),
            np.concatenate(wts))


def _preference(names: Sequence[str], chain) -> list[str]:
    """Order in which errors are kept: positions, orientations, zeros; frame-side axes first."""
    rot = list(chain.rotary)
    # the axis nearest the frame first: the last table axis, the first head axis
    dist = {r: abs(chain.letters.index(r) - (chain.frame_index - 0.5)) for r in rot}
    order = {"position": 0, "orientation": 1, "zero": 2}
    return sorted(names, key=lambda n: (order[info(n).kind], dist[n[-1]], names.index(n)))


@dataclass
class LocationIdentifiability:
    """What a design determines of the location errors.

    Attributes
    ----------
    names : tuple of str
        All location errors of the chain.
    free : tuple of str
        The errors kept (identifiable by construction).
    fixed : tuple of str
        The redundant errors, held at zero.
    combinations : dict of str to dict of str to float
        Fixed error -> {kept error or nuisance: coefficient}: a fixed ``g`` shifts the
        estimate of each kept ``i`` by ``k_i g`` (units: um/urad, um/um, ...).
    singular_values : ndarray
        Of the free errors' normalised columns after eliminating the nuisances (the smallest
        says how well the worst-separated combination is seen).
    messages : list of str
        The report in plain words.
    """

    names: tuple[str, ...]
    free: tuple[str, ...]
    fixed: tuple[str, ...]
    combinations: dict[str, dict[str, float]] = field(default_factory=dict)
    singular_values: Array = field(default_factory=lambda: np.zeros(0))
    messages: list[str] = field(default_factory=list)

    def gauge_truth(self, truth: dict[str, float]) -> dict[str, float]:
        """What the design determines of a true machine: ``x_kept + sum_g k_g x_g``.

        Parameters
        ----------
        truth : dict of str to float
            True location errors by name [um, urad].

        Returns
        -------
        dict of str to float
            Value of each free error the estimate converges to without noise.
        """
        out = {n: float(truth.get(n, 0.0)) for n in self.free}
        for g, ks in self.combinations.items():
            for n, k in ks.items():
                if n in out:
                    out[n] += k * float(truth.get(g, 0.0))
        return out


def _orth(A: Array, n: int, rtol: float = 1e-10) -> Array:
    """An orthonormal basis of the span of the columns of ``A`` (rank-revealing SVD).

    QR would give a spurious direction for each dependent column (nuisances one with
    another, such as a sphere's height and a sensor's zero when only C turns).
    """
    if A.shape[1] == 0:
        return np.zeros((n, 0))
    U, sv, _ = np.linalg.svd(A, full_matrices=False)
    return np.asarray(U[:, sv > rtol * max(sv.max(initial=0.0), 1e-300)])


def analyse_location(J_x: Array, J_n: Array, names: Sequence[str], nuisance_names: Sequence[str],
                     chain, tol: float = 1e-6) -> LocationIdentifiability:
    """Identifiability of the location errors in a design.

    Parameters
    ----------
    J_x : ndarray, shape (n, P)
        Weighted rows on the location errors.
    J_n : ndarray, shape (n, N)
        Weighted rows on the nuisances.
    names : sequence of str
        The location errors (columns of ``J_x``).
    nuisance_names : sequence of str
        Columns of ``J_n``.
    chain : MachineChain
        The chain (for the preference order).
    tol : float
        Relative residual of a unit column below which it is redundant.

    Returns
    -------
    LocationIdentifiability
    """
    names = list(names)
    nrm = lambda A: A / np.maximum(np.linalg.norm(A, axis=0), 1e-300)  # noqa: E731
    Xn, Nn = nrm(J_x), nrm(J_n)
    kept: list[str] = []
    fixed: list[str] = []
    basis = Nn.copy()
    for n in _preference(names, chain):
        col = Xn[:, names.index(n)]
        Q = _orth(basis, col.size)
        res = col - Q @ (Q.T @ col)
        if np.linalg.norm(col) > 0 and np.linalg.norm(res) > tol:
            kept.append(n)
            basis = np.column_stack([basis, col])
        else:
            fixed.append(n)
    kept_sorted = tuple(n for n in names if n in kept)
    fixed_sorted = tuple(n for n in names if n in fixed)
    A = np.column_stack([J_x[:, [names.index(n) for n in kept_sorted]], J_n])
    labels = list(kept_sorted) + list(nuisance_names)
    combos: dict[str, dict[str, float]] = {}
    for g in fixed_sorted:
        k, *_ = np.linalg.lstsq(A, J_x[:, names.index(g)], rcond=None)
        combos[g] = {labels[i]: float(k[i]) for i in range(len(labels)) if abs(k[i]) > 1e-9}
    # singular values of the kept errors with the nuisances eliminated
    Qn = _orth(Nn, Xn.shape[0])
    Xk = Xn[:, [names.index(n) for n in kept_sorted]]
    sv = np.linalg.svd(Xk - Qn @ (Qn.T @ Xk), compute_uv=False) if kept_sorted else np.zeros(0)
    rep = LocationIdentifiability(tuple(names), kept_sorted, fixed_sorted, combos, sv)
    rep.messages = _messages(rep, set(kept_sorted))
    return rep


def _fmt_combo(g: str, ks: dict[str, float], kept: set[str]) -> str:
    if not ks:
        return (f"{describe(g)} does not act on these readings: no reading depends on it at "
                "these poses (its axis does not turn away from its zero in them).")
    errs = {n: k for n, k in ks.items() if n in kept}
    nuis = [n for n in ks if n not in kept]
    unit_g = info(g).unit
    parts = []
    for n, k in errs.items():
        unit_n = info(n).unit
        per = "" if unit_n == unit_g else f" {unit_n}/{unit_g}"
        sign = "-" if k < 0 else "+"
        parts.append(f"{n} {sign} {abs(k):.4g}{per} x {g}")
    where = []
    if parts:
        where.append("the design determines " + "; ".join(parts))
    spheres = sorted({n.split(":")[0] for n in nuis if ":zero_" not in n})
    zeros = sorted({n.split(":")[0] for n in nuis if ":zero_" in n})
    if spheres:
        where.append("it moves the centre of " + ", ".join(spheres) +
                     (" (a new workpiece zero)" if not parts else ""))
    if zeros:
        where.append(("the " if spheres else "it moves the ") + "sensor zeros of "
                     + ", ".join(zeros))
    return f"{describe(g)} is not separated from the others: " + " and ".join(where) + "."


def _messages(rep: LocationIdentifiability, kept: set[str]) -> list[str]:
    msgs = [f"{len(rep.free)} of {len(rep.names)} location errors are determined: "
            + ", ".join(rep.free) + "."]
    if rep.fixed:
        msgs.append("Held at zero, since no reading separates them: " + ", ".join(rep.fixed)
                    + ". Each is absorbed as follows:")
        msgs += ["  " + _fmt_combo(g, rep.combinations[g], kept) for g in rep.fixed]
    if rep.singular_values.size:
        msgs.append(f"Worst-separated combination: relative singular value "
                    f"{rep.singular_values.min() / rep.singular_values.max():.2g} "
                    "(small: add poses with larger angle differences or move the sphere "
                    "farther from the axes).")
    return msgs


@dataclass
class LocationResult:
    """Identified location errors with their uncertainty.

    Attributes
    ----------
    names : tuple of str
        The free (identified) location errors.
    estimate : dict of str to float
        Their values [um, urad].
    u : dict of str to float
        Standard uncertainty [um, urad].
    covariance : ndarray
        Covariance of the free errors, in ``names`` order.
    nuisances : dict of str to float
        Estimated sphere centres [mm] and sensor zeros [um].
    identifiability : LocationIdentifiability
        The report of the design.
    machine : FiveAxisMachine
        The nominal machine with the estimate (fixed errors zero).
    rms_before_um, rms_after_um : float
        RMS residual of the readings with the nominal machine (sphere centres fitted) and
        after identification [um].
    chi2 : float
        Weighted residual sum of squares at the solution.
    dof : int
        Readings minus estimated parameters.
    iterations : int
        Gauss-Newton iterations.
    linear : LinearPrior or None
        The linear model's prior (:mod:`volcal.identify.location_linear`), when given.
    u_without_linear : dict of str to float or None
        With a linear prior carrying a covariance: the standard uncertainty the readings'
        noise alone would give [um, urad] (the linear model's share is ``u`` beside it).
    u_without_undetermined : dict of str to float or None
        With a linear prior whose model leaves functions undetermined
        (:attr:`LinearPrior.undetermined`): the standard uncertainty with those functions
        taken as known [um, urad]; the rest of ``u``'s variance is the identification's
        prior statement about them, not a measurement of this machine.
    """

    names: tuple[str, ...]
    estimate: dict[str, float]
    u: dict[str, float]
    covariance: Array
    nuisances: dict[str, float]
    identifiability: LocationIdentifiability
    machine: FiveAxisMachine
    rms_before_um: float
    rms_after_um: float
    chi2: float
    dof: int
    iterations: int
    linear: Any = None
    u_without_linear: dict[str, float] | None = None
    u_without_undetermined: dict[str, float] | None = None

    def to_rows(self) -> list[dict[str, object]]:
        """One row per location error of the chain: name, meaning, value, u, status."""
        rows: list[dict[str, object]] = []
        for n in self.identifiability.names:
            e = info(n)
            if n in self.estimate:
                rows.append({"name": n, "meaning": e.meaning, "unit": e.unit,
                             "value": self.estimate[n], "u": self.u[n], "status": "identified"})
            else:
                rows.append({"name": n, "meaning": e.meaning, "unit": e.unit, "value": 0.0,
                             "u": float("nan"), "status": "redundant (held at zero)"})
        return rows


def _structural(machine: FiveAxisMachine) -> FiveAxisMachine:
    """The machine with perfect linear axes (the design's analysis)."""
    return FiveAxisMachine(machine.chain_obj, machine.rotary, None, machine.name)


def _readings(blocks: Sequence[SphereReadings]) -> Array:
    return np.concatenate([(b.values / UM if b.kind == "probe" else b.values).reshape(-1)
                           for b in blocks])


def identify_location(nominal: FiveAxisMachine, blocks: Sequence[SphereReadings], *,
                      prior_u: dict[str, float] | float | None = None,
                      max_iter: int = 20, tol: float = 1e-6,
                      hold: Sequence[str] = (), linear: Any = None) -> LocationResult:
    """Identify the location errors of the rotary axes from sphere readings.

    Parameters
    ----------
    nominal : FiveAxisMachine
        The machine as configured: chain, nominal pivots, linear errors (the laser model
        of the same machine, taken as known); its location errors are ignored.
    blocks : sequence of SphereReadings
        The readings.
    prior_u : float or dict of str to float, optional
        Standard deviation of a zero-mean Gaussian prior on each free location error
        [um, urad]; None: no prior (least squares).
    max_iter : int
        Gauss-Newton iterations at most.
    tol : float
        Stop when the step changes no parameter by more than ``tol`` [um, urad].
    hold : sequence of str
        Errors held at zero besides the redundant ones (the best fit of a model without
        them, e.g. a control's kinematics without tilts).
    linear : LinearPrior, optional
        The linear model's uncertainty on the readings
        (:func:`volcal.identify.location_linear.linear_prior`): with a covariance, the fit
        is generalised least squares with the readings' covariance ``diag(noise^2) + C_lin``
        and the location errors' covariance includes the linear model's.

    Returns
    -------
    LocationResult
    """
    if not blocks:
        raise VolcalInputError("no sphere readings to identify the location errors from")
    names = location_parameter_names(nominal.chain_obj)
    base = nominal.with_location(np.zeros(len(names)))
    # what the design determines is a property of the poses, not of the linear axes' small
    # errors: analysed on the configured machine with perfect linear axes (the linear
    # errors would otherwise lift redundant errors just above the threshold, with huge U)
    Jx, Jn, nnames, _, _ = design_jacobian(_structural(base), blocks)
    ident = analyse_location(Jx, Jn, names, nnames, base.chain_obj)
    fitted = tuple(n for n in ident.free if n not in set(hold))
    free = [names.index(n) for n in fitted]
    y = _readings(blocks)
    w = np.concatenate([np.full(3 * b.n_poses, 1.0 / b.noise_um) for b in blocks])
    if prior_u is None:
        lam = np.zeros(len(free))
    else:
        pu = prior_u if isinstance(prior_u, dict) else {n: float(prior_u) for n in ident.free}
        lam = np.array([1.0 / pu[n] ** 2 for n in fitted])
    x = np.zeros(len(names))
    nuis = _nuisance_start(blocks)
    # nuisances scaled to um so the normal equations are well conditioned
    scale = np.array([1.0 / UM if ":s" in k else 1.0 for k in nnames])

    # the linear model's covariance: whiten the weighted readings by K = chol(C_w)^-1
    K = None
    if linear is not None and linear.has_uncertainty:
        K = _whitener(linear.covariance(y.size), w)

    def step(xv: Array, nv: dict[str, float], with_errors: bool, white: bool = True):
        m = base.with_location(xv)
        Jx_, Jn_, _, pred, _ = design_jacobian(m, blocks, nv)
        r = (y - pred) * w
        A = np.column_stack([Jx_[:, free], Jn_ / scale]) if with_errors else Jn_ / scale
        if K is not None and white:
            A = K @ A
            r = K @ r
        return A, r

    # the nominal machine with only the sphere centres fitted: the scatter before
    for _ in range(5):
        A, r = step(x, nuis, False)
        dn, *_ = np.linalg.lstsq(A, r, rcond=None)
        nuis = {k: v + dn[i] / scale[i] for i, (k, v) in enumerate(nuis.items())}
    _, r = step(x, nuis, False, white=False)
    rms_before = float(np.sqrt(np.mean((r / w) ** 2)))
    iterations = 0
    for it in range(1, max_iter + 1):
        iterations = it
        A, r = step(x, nuis, True)
        nf = len(free)
        L = np.zeros(A.shape[1])
        L[:nf] = lam
        xf = x[free]
        rhs = A.T @ r - L * np.concatenate([xf, np.zeros(A.shape[1] - nf)])
        d = np.linalg.lstsq(A.T @ A + np.diag(L), rhs, rcond=None)[0]
        x[free] += d[:nf]
        nuis = {k: v + d[nf + i] / scale[i] for i, (k, v) in enumerate(nuis.items())}
        if np.abs(d[:nf]).max(initial=0.0) < tol and np.abs(d[nf:]).max(initial=0.0) < tol:
            break
    A, r = step(x, nuis, True)
    nf = len(free)
    L = np.zeros(A.shape[1])
    L[:nf] = lam
    # pinv: nuisances one with another (an R-test turning C only: the sphere's height and
    # the z sensor's zero) leave the normal matrix singular in their directions only, and
    # the errors' block of the pseudo-inverse is then their covariance
    cov_all = np.linalg.pinv(A.T @ A + np.diag(L), hermitian=True)
    cov = cov_all[:nf, :nf]
    u = np.sqrt(np.diag(cov))
    est = {n: float(x[i]) for n, i in zip(fitted, free, strict=True)}
    A0, r0 = step(x, nuis, True, white=False)
    u_noise = u_det = None
    if K is not None:
        u_noise = dict(zip(fitted, _u(A0, L, nf), strict=True))
        Cd = linear.covariance_determined(y.size)
        if Cd is not None:
            u_det = dict(zip(fitted, _u(_whitener(Cd, w) @ A0, L, nf), strict=True))
    return LocationResult(
        names=fitted, estimate=est, u={n: float(u[k]) for k, n in enumerate(fitted)},
        covariance=cov, nuisances=nuis, identifiability=ident, machine=base.with_location(x),
        rms_before_um=rms_before, rms_after_um=float(np.sqrt(np.mean((r0 / w) ** 2))),
        chi2=float(r @ r), dof=int(r.size - A.shape[1]), iterations=iterations,
        linear=linear, u_without_linear=u_noise, u_without_undetermined=u_det)


def _whitener(C: Array, w: Array) -> Array:
    """The whitening ``K = chol(I + C w w^T)^-1`` of readings weighted by ``w``.

    ``C`` is the readings' covariance from the linear model [um^2].
    """
    from scipy.linalg import solve_triangular

    Cw = np.eye(w.size) + C * np.outer(w, w)
    return solve_triangular(np.linalg.cholesky(Cw), np.eye(w.size), lower=True)


def _u(A: Array, lam: Array, nf: int) -> list[float]:
    """Standard uncertainty of the first ``nf`` parameters of the whitened system ``A``.

    With the prior precisions ``lam``; a pseudo-inverse (nuisances one with another).
    """
    cov = np.linalg.pinv(A.T @ A + np.diag(lam), hermitian=True)[:nf, :nf]
    return [float(v) for v in np.sqrt(np.diag(cov))]


def identifiability_markdown(reports: dict[tuple[str, str], LocationIdentifiability]) -> str:
    """A table of what each design determines, as ``docs/fiveaxis.md`` shows it.

    Parameters
    ----------
    reports : dict of (str, str) to LocationIdentifiability
        ``(chain, readings)`` -> the report of that design.

    Returns
    -------
    str
        One row per design: chain, readings, the determined errors, the redundant ones
        and the combinations the determined ones stand for.
    """
    rows = ["| chain | readings | determined | held at zero (redundant) | what the determined "
            "errors stand for |", "|---|---|---|---|---|"]
    for (chain, kind), rep in reports.items():
        combos = []
        for g in rep.fixed:
            ks = {n: k for n, k in rep.combinations[g].items() if n in rep.free}
            if ks:
                combos += [f"{n} {'-' if k < 0 else '+'} {abs(k):.3g} {g}" for n, k in ks.items()]
            elif not rep.combinations[g]:
                combos.append(f"{g} not acting at these poses")
            else:
                what = ("the sphere centre and the sensor zeros"
                        if any(":zero_" in n for n in rep.combinations[g])
                        else "the sphere centre (a new workpiece zero)")
                combos.append(f"{g} absorbed by {what}")
        rows.append(f"| {chain} | {kind} | {', '.join(rep.free)} | {', '.join(rep.fixed)} | "
                    f"{'; '.join(combos)} |")
    return "\n".join(rows) + "\n"


def separation_advice(nominal: FiveAxisMachine, blocks: Sequence[SphereReadings],
                      candidates: Sequence[Sequence[SphereReadings]] | None = None,
                      labels: Sequence[str] | None = None) -> list[str]:
    """Which extra readings would separate what the design leaves redundant or weak.

    Each candidate (a list of extra blocks: another sphere position, probed centres in
    machine coordinates beside R-test readings...) is added to the design in turn; the
    advice names those that determine errors the design holds at zero, and the one that
    best raises the worst-separated combination (relative singular value).

    Parameters
    ----------
    nominal : FiveAxisMachine
        The configured machine.
    blocks : sequence of SphereReadings
        The design.
    candidates : sequence of lists of SphereReadings, optional
        Extra readings to try; default: a second sphere at each of 3 radii x 3 heights
        around the first sphere's axis (same poses and kind), and, for an R-test design,
        probed centres of its sphere.
    labels : sequence of str, optional
        A description of each candidate (default generated).

    Returns
    -------
    list of str
        The advice in plain words (empty when the design determines everything well).
    """
    names = location_parameter_names(nominal.chain_obj)
    base = _structural(nominal.with_location(np.zeros(len(names))))

    def report(bs: Sequence[SphereReadings]) -> LocationIdentifiability:
        Jx, Jn, nn, _, _ = design_jacobian(base, bs)
        return analyse_location(Jx, Jn, names, nn, base.chain_obj)

    rep0 = report(blocks)
    b0 = blocks[0]
    if candidates is None:
        candidates, labels = [], []
        for r_mm in (75.0, 150.0, 250.0):
            for h_mm in (0.0, 40.0, 150.0):
                s = np.array([b0.sphere_mm[0], b0.sphere_mm[1], 0.0])
                c = nominal.rotary[nominal.chain_obj.rotary[0]].pivot_mm
                d = s[:2] - c[:2]
                d = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-9 else np.array([1.0, 0.0])
                pos = np.array([c[0] + r_mm * d[0], c[1] + r_mm * d[1], c[2] + h_mm])
                q = None
                if b0.kind == "rtest":
                    from volcal.measure.spheres import probe_centres

                    q = probe_centres(base, b0.angles, pos, b0.tool_offset_mm)
                candidates.append([SphereReadings(
                    "extra", b0.kind, b0.angles, np.zeros_like(b0.values), "extra_sphere", pos,
                    b0.tool_offset_mm, q, b0.noise_um)])
                labels.append(f"a second sphere {r_mm:g} mm from the first axis, {h_mm:g} mm "
                              "above its pivot")
        if b0.kind == "rtest":
            candidates.append([SphereReadings("extra", "probe", b0.angles,
                                              np.zeros_like(b0.values), b0.sphere, b0.sphere_mm,
                                              b0.tool_offset_mm, None, b0.noise_um)])
            labels.append("probed centres of the same sphere in machine coordinates")
    labels = list(labels or [f"candidate {i + 1}" for i in range(len(candidates))])
    msgs: list[str] = []
    worst0 = (rep0.singular_values.min() / rep0.singular_values.max()
              if rep0.singular_values.size else 0.0)
    best, best_label = worst0, ""
    for extra, label in zip(candidates, labels, strict=True):
        rep = report(list(blocks) + list(extra))
        gained = [n for n in rep0.fixed if n in rep.free]
        if gained:
            msgs.append(f"Adding {label} would determine {', '.join(gained)}.")
        if set(rep.free) == set(rep0.free) and rep.singular_values.size:
            w = rep.singular_values.min() / rep.singular_values.max()
            if w > best * 1.1:
                best, best_label = w, label
    if rep0.fixed and not any(m.startswith("Adding") for m in msgs):
        # what other poses of the same sphere would separate (volcal advise ranks them)
        from volcal.measure.fiveaxis_virtual import pose_grid
        from volcal.measure.spheres import probe_centres as centres

        grid = pose_grid(base.chain_obj.code, counts={"A": 13, "B": 13, "C": 12})
        rich = report(list(blocks) + [SphereReadings(
            b0.id, b0.kind, grid, np.zeros((next(iter(grid.values())).size, 3)), b0.sphere,
            b0.sphere_mm, b0.tool_offset_mm,
            None if b0.kind != "rtest" else centres(base, grid, b0.sphere_mm,
                                                    b0.tool_offset_mm), b0.noise_um)])
        by_poses = [g for g in rep0.fixed if g in rich.free]
        if by_poses:
            msgs.append("Adding poses at other angles would determine " + ", ".join(by_poses)
                        + " (volcal advise ranks the candidate poses).")
        rest = [g for g in rep0.fixed if g not in by_poses]
        if rest:
            msgs.append("No candidate reading separates " + ", ".join(rest) + ": they are "
                        "redundant for this kind of reading (not a matter of poses or sphere "
                        "positions); they are held at zero and absorbed as the report says.")
    if best_label:
        msgs.append(f"The worst-separated combination would improve most with {best_label} "
                    f"(relative singular value {worst0:.2g} -> {best:.2g}).")
    return msgs
