"""What the data can and cannot determine, in plain words.

The analysis uses the design's data information matrix on the free function parameters,
with the set-up nuisances eliminated (Schur complement),

.. math:: F = A_f^T A_f - A_f^T A_n (A_n^T A_n)^+ A_n^T A_f,

and its null space (eigenvectors of ``F``, scaled by the prior precision ``Q`` to make the
units comparable, with eigenvalues ~ 0): directions no reading sees; the prior restricted
to them, ``N (N^T Q N)^-1 N^T``, is what remains uncertain without noise. For
each function the report gives the share of its prior variance that the data remove,
names the functions that undetermined combinations mix, quantifies the volumetric error
they can cause (the *volumetric ambiguity* of the design: the posterior standard deviation
of the volumetric error, after removing rigid-body motion, in the noise-free limit) and
tries candidate extra measurements to say which one would help most. The analysis is
done on the nodes at the measured positions (interpolation between readings is the job
of the prior, not a design weakness).

References: Soons (seed 004) sections 3-5 for the known weaknesses of the diagonal and
step-diagonal tests; Golub & Van Loan, *Matrix Computations*, 4th ed., 8.1 (symmetric
eigenproblem).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from volcal.identify.design import Design, read_functions, untouched_parameters
from volcal.identify.prior import PriorStructure
from volcal.identify.settings import EstimatorSettings
from volcal.model.kinematics import pose_jacobian
from volcal.model.names import COMPONENT_NAMES, ROLL_NAMES, SQUARENESS_NAMES, describe, kind

if TYPE_CHECKING:
    from volcal.identify.between_share import BetweenForecast

__all__ = ["IdentifiabilityReport", "analyse", "describe", "parameter_names", "rigid_projector"]

@dataclass
class IdentifiabilityReport:
    """Identifiability of a design.

    Attributes
    ----------
    n_parameters : int
        Free function and squareness parameters (at the measured positions).
    rank : int
        Number of combinations the readings determine.
    null_dimension : int
        Combinations no reading sees.
    determined_fraction : dict of str to float
        Per function: share of its prior variance removed by the data (1 = fully
        determined by the readings, 0 = the estimate is the prior's).
    ambiguity_um : float
        Volumetric ambiguity: largest posterior standard deviation (noise-free limit) of
        a volumetric error component over the measured grid, rigid-body motion removed [um].
    ambiguity_rms_um : float
        RMS of the same over the grid [um].
    messages : list of str
        The report in plain words.
    suggestions : list of str
        Extra measurements that would determine more, best first.
    null_groups : list of list of str
        For each group of undetermined combinations, the functions they mix.
    between : BetweenForecast or None
        Before measuring (:func:`volcal.identify.api.advise`): the part between the
        readings the plan would leave on a typical machine
        (:func:`volcal.identify.between_share.forecast_between`); not in :meth:`to_dict`
        (the advice's document carries it as ``between_readings``).
    """

    n_parameters: int
    rank: int
    null_dimension: int
    determined_fraction: dict[str, float]
    ambiguity_um: float
    ambiguity_rms_um: float
    messages: list[str] = field(default_factory=list)
    suggestions: list[str] = field(default_factory=list)
    null_groups: list[list[str]] = field(default_factory=list)
    between: BetweenForecast | None = None

    def to_dict(self) -> dict:
        """JSON-ready dictionary."""
        return {
            "n_parameters": self.n_parameters,
            "rank": self.rank,
            "null_dimension": self.null_dimension,
            "determined_fraction": self.determined_fraction,
            "ambiguity_um": self.ambiguity_um,
            "ambiguity_rms_um": self.ambiguity_rms_um,
            "messages": self.messages,
            "suggestions": self.suggestions,
            "null_groups": self.null_groups,
        }


def parameter_names(design: Design) -> NDArray[np.str_]:
    """Function name of every free parameter (``'EXX'``..., or a squareness name).

    Parameters
    ----------
    design : Design
        Assembled observation system (:func:`volcal.identify.design.build_design`).

    Returns
    -------
    ndarray of str, shape (p_free,)
        ISO 230-1 name of the function each free parameter belongs to.
    """
    names = []
    starts = design.layout.starts
    for fi in design.free:
        if fi >= starts[3]:
            names.append(SQUARENESS_NAMES[fi - starts[3]])
        else:
            k = int(np.searchsorted(starts, fi, side="right") - 1)
            names.append(COMPONENT_NAMES[6 * k + (fi - starts[k]) % 6])
    return np.array(names)


def rigid_projector(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Projector (3m x 3m) removing rigid-body displacement fields on points ``q`` [mm].

    Parameters
    ----------
    q : ndarray, shape (m, 3)
        Points of the work zone [mm]; the rotations act about their centroid.

    Returns
    -------
    ndarray, shape (3m, 3m)
        Orthogonal projector onto the complement of the rigid-body (translation and small
        rotation) displacement fields, acting on vectors stacked point by point.
    """
    from volcal.model.rigid import _design

    G = _design(q - q.mean(axis=0))
    Qm, _ = np.linalg.qr(G)
    return np.eye(3 * q.shape[0]) - Qm @ Qm.T


def information(design: Design, ata: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Data information matrix of the free parameters, nuisances eliminated.

    Sparse products only: ``A_f^T A_f - (A_f^T A_n) (A_n^T A_n)^+ (A_n^T A_f)``.

    Parameters
    ----------
    design : Design
        Assembled observation system; ``A`` holds the free columns first, then the
        nuisance columns.
    ata : ndarray, optional
        ``A^T A`` of this design if already formed (dense; the solver's), saving the pass
        over the readings.

    Returns
    -------
    ndarray, shape (p_free, p_free)
        Symmetric information matrix of the free parameters for unit reading variance:
        the Schur complement of the nuisance block of ``A^T A`` (plus the nuisances'
        own prior precision where the design has one, ``Design.extra_precision``: an
        optical square's certificate, scaled to a 0.5 um reading noise).
    """
    nf = design.n_free
    if ata is not None:
        F, C, G = ata[:nf, :nf], ata[:nf, nf:], ata[nf:, nf:]
    else:
        A = design.A.tocsc()
        Af, An = A[:, :nf], A[:, nf:]
        F = (Af.T @ Af).toarray()
        C = (Af.T @ An).toarray()
        G = (An.T @ An).toarray()
    if G.shape[1]:
        ex = design.extra_precision
        if ex is not None and np.any(ex[nf:]):
            # nuisances known from outside the readings (an optical square's certificate,
            # a tracker station): their prior precision [1/unit^2] in units of the reading
            # variance of a displacement reading (volcal.measure.optics.REFERENCE_NOISE_UM)
            from volcal.measure.optics import REFERENCE_NOISE_UM

            G = G + np.diag(ex[nf:] * REFERENCE_NOISE_UM**2)
        F = F - C @ np.linalg.pinv(G, hermitian=True) @ C.T
    return (F + F.T) / 2


def projected_information(design: Design, P: NDArray[np.float64]) -> NDArray[np.float64]:
    """``P^T F P`` for the information ``F`` of :func:`information`, without forming ``F``.

    With ``B = A_f P`` (sparse times a few columns) ``P^T F P = B^T B - (A_n^T B)^T G^+
    (A_n^T B)``, ``G = A_n^T A_n`` (plus the nuisances' own precision): the candidate
    designs of the identifiability report are projected on the null space of the main
    design this way, a few dozen columns instead of the full parameter count.

    Parameters
    ----------
    design : Design
        Assembled observation system (free columns first, then nuisances).
    P : ndarray, shape (p_free, m)
        Directions in the free parameters.

    Returns
    -------
    ndarray, shape (m, m)
        Symmetric.
    """
    nf = design.n_free
    A = design.A.tocsc()
    Af, An = A[:, :nf], A[:, nf:]
    B = Af @ P
    out = B.T @ B
    if An.shape[1]:
        G = (An.T @ An).toarray()
        ex = design.extra_precision
        if ex is not None and np.any(ex[nf:]):
            from volcal.measure.optics import REFERENCE_NOISE_UM

            G = G + np.diag(ex[nf:] * REFERENCE_NOISE_UM**2)
        CB = An.T @ B
        out = out - CB.T @ np.linalg.pinv(G, hermitian=True) @ CB
    return (out + out.T) / 2


def grid_points(design: Design, per_axis: int = 5) -> NDArray[np.float64]:
    """Grid over the measured positions (subsampled to ``per_axis`` per axis) [mm].

    Parameters
    ----------
    design : Design
        Assembled observation system; its layout nodes are the measured positions.
    per_axis : int
        Largest number of positions taken per axis, evenly spread over the nodes.

    Returns
    -------
    ndarray, shape (m, 3)
        All combinations of the chosen X, Y, Z positions [mm], X varying slowest.
    """
    ax = []
    for k in range(3):
        n = design.layout.nodes[k]
        idx = np.unique(np.round(np.linspace(0, n.size - 1, min(per_axis, n.size))).astype(int))
        ax.append(n[idx])
    return np.stack(np.meshgrid(*ax, indexing="ij"), -1).reshape(-1, 3)


def null_space_covariance(F: NDArray[np.float64], Qp: NDArray[np.float64], tol: float = 1e-9):
    """Prior covariance restricted to the data null space (noise-free posterior).

    Parameters
    ----------
    F : ndarray
        Data information matrix.
    Qp : ndarray
        Prior precision (same size).
    tol : float
        Relative eigenvalue threshold of the null space.

    Returns
    -------
    cov : ndarray
        ``N (N^T Qp N)^-1 N^T`` with ``N`` a basis of the null space of ``F``.
    N : ndarray
        The basis.
    """
    N, _ = _null_basis(F, tol)
    if N.shape[1] == 0:
        return np.zeros_like(F), N
    M = N.T @ Qp @ N
    return N @ np.linalg.solve(M, N.T), N


def _null_basis(F: NDArray[np.float64], tol: float = 1e-9
                ) -> tuple[NDArray[np.float64], float]:
    """Orthonormal basis of the null space of ``F`` and its eigenvalue threshold.

    The null space is spanned by the eigenvectors whose eigenvalues are below ``tol``
    times the largest.
    """
    w, V = np.linalg.eigh(F)
    thr = tol * max(float(w.max()), 1e-300)
    return V[:, w < thr], thr


def _reference_scales(settings: EstimatorSettings | None = None) -> NDArray[np.float64]:
    """The typical machining centre's group scales (:attr:`EstimatorSettings.typical_scales`)."""
    st = settings if settings is not None else EstimatorSettings()
    return np.array(st.typical_scales)


def _reference_prior(design: Design, settings: EstimatorSettings | None = None
                     ) -> PriorStructure:
    """The prior of :func:`volcal.identify.api.advise` (hyperprior centres) on ``design``.

    The identifiability report finds its null space in this prior's scaling, so that a
    plan and the identification of its data name the same undetermined combinations.
    """
    st = settings if settings is not None else EstimatorSettings()
    return PriorStructure.build(design.layout, design.free, st.kappa_centre,
                                settings=st).with_trend(
        st.trend_centre_um_per_m if st.trend_per_metre else st.trend_centre_um)


def analyse(design: Design, prior: PriorStructure, scales: NDArray[np.float64],
            squareness_std: float, candidates: dict[str, Design] | None = None,
            tool_offset: NDArray[np.float64] | None = None,
            ata: NDArray[np.float64] | None = None,
            settings: EstimatorSettings | None = None) -> IdentifiabilityReport:
    """Identifiability report of a design (nodes at the measured positions).

    Parameters
    ----------
    design : Design
        Observation system, nodes at the measured positions only (``refine=1``).
    prior : PriorStructure
        Prior for the same design.
    scales : ndarray, shape (4,)
        Prior amplitude scales [um, um, urad, urad] (positioning, straightness, roll, tilt).
    squareness_std : float
        Prior standard deviation of the squareness [urad].
    candidates : dict of str to Design, optional
        Extra measurements to try (each a design on the same nodes, its own readings only);
        the key is the plain-word description.
    tool_offset : ndarray, optional
        Tool offset for the volumetric ambiguity [mm].
    ata : ndarray, optional
        ``A^T A`` of ``design`` if already formed (:func:`information`).
    settings : EstimatorSettings, optional
        The reference prior's settings (``typical_scales``, ``kappa_centre``,
        ``trend_centre_um``); default ``EstimatorSettings()``.

    Returns
    -------
    IdentifiabilityReport
    """
    nf = design.n_free
    Qp = prior.precision(scales, squareness_std, nf, np.zeros(0)).toarray()
    F = information(design, ata)
    scale = np.sqrt(np.diag(Qp))
    Fs = F / np.outer(scale, scale)
    Qs = Qp / np.outer(scale, scale)
    # the null space is a property of the design: found on the information scaled by the
    # prior's diagonal at the *reference* hyperparameters (those of advise before
    # measuring), not the fitted ones, which moved a direction at 1e-9 of the largest
    # eigenvalue across the threshold between a plan and its data (ranks 166 and 167)
    ref = np.sqrt(np.diag(_reference_prior(design, settings).precision(
        _reference_scales(settings), squareness_std, nf, np.zeros(0)).toarray()))
    N_ref, _ = _null_basis(F / np.outer(ref, ref))
    N = np.linalg.qr((scale / ref)[:, None] * N_ref)[0] if N_ref.shape[1] else N_ref
    # the candidates' threshold on the information in this prior's scaling
    import scipy.linalg as sla

    top = sla.eigh(Fs, eigvals_only=True, subset_by_index=[nf - 1, nf - 1])
    thr = 1e-9 * max(float(top[0]), 1e-300)
    NQN = N.T @ Qs @ N  # the prior metric of the null space
    rank = nf - N.shape[1]  # the same null space the ambiguity is computed from
    var_inf = _null_variance(np.eye(nf), N, NQN) / scale**2
    prior_var = np.diag(np.linalg.inv(Qp))
    names = parameter_names(design)
    frac = {}
    for n in dict.fromkeys(names):
        sel = names == n
        frac[str(n)] = float(np.clip(1.0 - var_inf[sel].sum() / prior_var[sel].sum(), 0.0, 1.0))
    # volumetric ambiguity on the measured grid
    q = grid_points(design)
    Je, _ = pose_jacobian(_order(design), design.layout.nodes, q, tool_offset)
    G = Je[:, design.free].toarray()
    R = rigid_projector(q)
    GN = (R @ G / scale) @ N  # the volumetric effect of each null direction
    # diag(GP cov GP^T) through the null-space basis: cov is N M^-1 N^T in the scaled
    # parameters, so only (points x null dimension) products are needed
    var = _null_variance(GN, np.eye(N.shape[1]), NQN)
    amb = np.sqrt(np.clip(var, 0, None))
    unmoved = _unmoved_axes(design)
    for k in unmoved:  # a function of an axis no test moves may have no free node on these
        for n in COMPONENT_NAMES[6 * k:6 * k + 6]:  # nodes (a straightness held at both
            frac.setdefault(n, 0.0)  # ends): it is still undetermined
    frac = {n: frac[n] for n in (*COMPONENT_NAMES, *SQUARENESS_NAMES) if n in frac}
    report = IdentifiabilityReport(nf, rank, nf - rank, frac, float(amb.max()),
                                   float(np.sqrt(np.mean(amb**2))))
    # groups of undetermined combinations
    if N.shape[1]:
        keys = list(frac)
        share = _null_shares(N, names, keys)
        total = share.sum(axis=0)
        mixed = [keys[i] for i in np.argsort(-total) if total[i] > 0.05 * total.max()]
        report.null_groups.append(mixed)
    _messages(report, design, unmoved)
    if candidates:
        _suggest(report, scale, thr, candidates, N, GN, NQN)
    return report


def _null_shares(N: NDArray[np.float64], names: NDArray[np.str_], keys: list[str]
                 ) -> NDArray[np.float64]:
    """Each function's share of each null direction: ``N[:, j]^2`` summed over its parameters.

    Returns shape (null dimension, len(keys)); a function per column, each direction's sum
    over a contiguous row (the sum of ``(N[:, j]^2)[names == key]``, in its order).
    """
    share = np.zeros((N.shape[1], len(keys)))
    for i, key in enumerate(keys):
        share[:, i] = np.ascontiguousarray((N[names == key] ** 2).T).sum(axis=1)
    return share


def _order(design: Design):
    from volcal.model.chain import parse_chain

    return parse_chain(design.chain).order


def _unmoved_axes(design: Design) -> set[int]:
    """The axes (0, 1, 2 = X, Y, Z) with free nodes but no function a reading moves."""
    if not design.measurements:
        return set()
    free = np.asarray(design.free)
    read = read_functions(design.layout, free, untouched_parameters(design))
    out = set()
    for k in range(3):
        m = np.isin(free, np.concatenate([design.layout.indices(k, c) for c in range(6)]))
        if m.any() and not read[m].any():
            out.add(k)
    return out


#: Why a kind of error no reading sees is unseen, for the one line that lists them all.
_UNSEEN_WHY = {
    "straightness": "no reading here moves across an axis' direction of travel (a linear "
                    "test reads along it); diagonals, step diagonals or a straightness optic "
                    "would.",
    "roll": "roll acts only through lever arms across the beam, and no test here has them. "
            "Their estimates lean on the prior (zero); measure them with an electronic level "
            "or give them as known errors.",
    "squareness": "no test here relates the directions of two axes; body or face "
                  "diagonals, or an optical square, would.",
}


def _messages(rep: IdentifiabilityReport, design: Design,
              unmoved: set[int] | None = None) -> None:
    kinds = sorted({m.kind for m in design.measurements})
    rep.messages.append(
        f"{len(design.measurements)} measurements ({', '.join(kinds)}) determine {rep.rank} of "
        f"{rep.n_parameters} combinations of the error values at the measured positions; "
        f"{rep.null_dimension} combinations are seen by no reading.")
    poor = [n for n, f in rep.determined_fraction.items() if f < 0.5]
    weak = [n for n, f in rep.determined_fraction.items() if 0.5 <= f < 0.95]
    if unmoved is None:
        unmoved = _unmoved_axes(design)
    of_unmoved = {n for n in poor
                  if n in COMPONENT_NAMES and COMPONENT_NAMES.index(n) // 6 in unmoved}
    for k in sorted(unmoved):  # one line per axis no test moves, not one per function
        names = [n for n in poor if n in of_unmoved and COMPONENT_NAMES.index(n) // 6 == k]
        if names:
            rep.messages.append(
                f"No test here moves the {'XYZ'[k]} axis, so no reading depends on its "
                f"errors: {', '.join(names)} are not determined by the data (none of their "
                "prior uncertainty removed); their estimates are the prior's (zero), with its "
                "uncertainty carried into the predictions.")
    poor = [n for n in poor if n not in of_unmoved]
    rolls = [n for n in poor if n in ROLL_NAMES]
    for what, why in _UNSEEN_WHY.items():  # one line per kind no reading sees at all
        unseen = [n for n in poor if kind(n) == what and rep.determined_fraction[n] < 0.005]
        if len(unseen) > 1:
            rep.messages.append(f"The {what} errors {', '.join(unseen)} are not determined by "
                                f"the data (none of their prior uncertainty removed): {why}")
            poor = [n for n in poor if n not in unseen]
    for n in poor:
        f = rep.determined_fraction[n]
        why = ""
        if n in ROLL_NAMES:
            why = (" Roll acts only through lever arms across the beam; linear tests along the "
                   "axis cannot see it. Its estimate leans on the prior (zero); measure it with "
                   "an electronic level or give it as a known error.")
        elif kind(n) == "tilt":
            why = (" This rotation has (almost) no lever arm to the target in these set-ups, so "
                   "it changes the tool orientation only; a flat mirror sees that weakly.")
        share = (f"only {100 * f:.0f}% of its prior uncertainty is removed" if f >= 0.005
                 else "none of its prior uncertainty is removed")
        rep.messages.append(f"{describe(n)} is not determined by the data: {share}.{why}")
    if weak:
        rep.messages.append("Weakly determined (50-95% of the prior uncertainty removed): "
                            + ", ".join(describe(n) for n in weak) + ".")
    if rep.null_groups:
        rep.messages.append("The undetermined combinations mix " + ", ".join(
            describe(n) for n in rep.null_groups[0][:6]) + ".")
    if rolls:
        rep.messages.append("Roll: " + ", ".join(rolls) + " not measured; taken from the prior "
                            "(zero mean), with its uncertainty carried into the predictions.")
    rep.messages.append(
        f"Volumetric ambiguity of this design: up to {rep.ambiguity_um:.2f} um (one standard "
        f"deviation, RMS {rep.ambiguity_rms_um:.2f} um over the measured grid, rigid-body motion "
        "removed) of the volumetric error cannot be determined by these tests, even without noise.")
    step_flat = [m for m in design.measurements
                 if m.kind == "step_diagonal" and m.target != "retroreflector"]
    linears = {m.axis for m in design.measurements if m.kind == "linear"}
    if step_flat and len(linears) < 2:
        rep.messages.append(
            "The slopes of the positioning errors are confounded with the mirror tilts of the "
            "step diagonals (Soons, section 4): only the assumption that the set-ups' tilts "
            "are independent and small separates them, weakly, and their uncertainty is "
            "carried into the predictions; "
            + ("add linear measurements of two axes (X and Y, say)." if not linears else
               "add a linear measurement of a second axis ("
               + " or ".join("XYZ"[k] for k in range(3) if k not in linears) + ")."))


def _null_variance(GPs: NDArray[np.float64], N: NDArray[np.float64],
                   M: NDArray[np.float64]) -> NDArray[np.float64]:
    """``diag(GPs N M^-1 N^T GPs^T)``: the variance the null space leaves per row.

    ``N`` is the null-space basis, ``M = N^T Q N`` its prior metric; zero when ``N`` is
    empty.
    """
    if N.shape[1] == 0:
        return np.zeros(GPs.shape[0])
    B = GPs @ N
    return np.sum(np.linalg.solve(M, B.T).T * B, axis=1)


def _suggest(rep: IdentifiabilityReport, scale, thr, candidates, N, GN, NQN) -> None:
    # The null space of F + Fc (both positive semi-definite) is the part of the null space
    # N of F that Fc does not see either: an eigenproblem of the size of N per candidate,
    # not of the full parameter count. scale, thr, N, GN (volumetric effect of each null
    # direction) and NQN (their prior metric) are the design's, from analyse.
    base = rep.ambiguity_rms_um
    scores = []
    for label, cd in candidates.items():
        if N.shape[1] == 0:
            break
        # N^T (F_c / scale scale^T) N, projected without the full matrix
        wc, Vc = np.linalg.eigh(projected_information(cd, N / scale[:, None]))
        Vn = Vc[:, wc < thr]  # what the candidate does not see either: N @ Vn
        var = _null_variance(GN, Vn, Vn.T @ NQN @ Vn)
        rms = float(np.sqrt(np.mean(np.clip(var, 0, None))))
        scores.append((rms, label))
    scores.sort()
    for rms, label in scores[:3]:
        if rms < 0.9 * base:
            rep.suggestions.append(f"{label}: volumetric ambiguity {base:.2f} -> {rms:.2f} um RMS")
    if rep.suggestions:
        rep.messages.append("Best extra measurement: " + rep.suggestions[0] + ".")
    from volcal.plan.optics import OPTIC_LABEL  # the best direct optic, also when not top 3

    optic = [(r, lb) for r, lb in scores if lb.startswith(OPTIC_LABEL)]
    if optic and optic[0][0] < 0.9 * base and optic[0] != scores[0]:
        # named whenever it is not the best extra measurement already (most users own a
        # level before a second set of diagonal optics)
        rms, label = optic[0]
        if optic[0] not in scores[:3]:
            rep.suggestions.append(f"{label}: volumetric ambiguity {base:.2f} -> {rms:.2f} "
                                   "um RMS")
        rep.messages.append(f"Best direct optic: {label[len(OPTIC_LABEL):]}: volumetric "
                            f"ambiguity {base:.2f} -> {rms:.2f} um RMS.")

