"""The change test between two calibrations of one machine.

Two kinds of entries (``docs/history.md``):

* **Results with an uncertainty** (ISO 230-2 parameters, diagonal results, volumetric
  indices): ``difference = later - earlier``, ``U`` the expanded uncertainty of the
  difference, ``sqrt(U1^2 + U2^2)`` (the two calibrations' uncertainties taken as
  independent; terms common to both, such as one laser's wavelength error, would cancel
  in the difference, so this errs on the side of "not changed"); ``changed`` when
  ``|difference| > U``; ``None`` when either has no U.
* **Identified functions and squareness** (from the two model files): one joint test
  per function over the combinations of its nodes both calibrations determine
  (:func:`_determined_statistic`): ``C = C1 + C2`` the sum of the two posterior
  covariances (prior part included), ``Cn`` the sum of their parts due to the readings
  and set-ups (``C - C Q C`` each, :func:`noise_covariance`); the eigen-directions of
  ``Cn`` in the metric of ``C`` with a determined fraction of at least
  :data:`DETERMINED_FROM` are tested, ``chi2 = sum z^2`` of the difference in those
  directions over its posterior standard deviation, with as many degrees of freedom as
  directions, against ``r F(1 - level/m; r, nu)`` (:func:`_threshold`, ``nu`` the
  calibrations' residual degrees of freedom; the chi-square quantile when unknown); ``m``
  is the number of functions tested, those both calibrations determine (Bonferroni: the
  family-wise false-alarm rate is at most ``level``). The directions left out are the
  prior's shrinkage: it moves with the hyperparameters each calibration chooses from its
  own readings, so two calibrations of one machine differ there by more than ``Cn``
  says (issue 26). ``difference`` is the largest node difference, ``U`` twice its
  posterior standard uncertainty there. ``changed`` is ``None`` where either calibration
  leaves the function undetermined (less than half of its prior variance removed by the
  data), or no combination is determined.

Both models must be in one gauge (the same chain; volcal's gauge is fixed by the design
kind, not by the data); functions on other nodes are compared at the earlier model's
nodes inside the common travel, by the models' own linear interpolation.

References
----------
.. [1] JCGM 100:2008 (GUM), 5.1 (combined uncertainty of a difference).
.. [2] Bonferroni, C. E. (1936), family-wise error rate of m tests at level alpha/m.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from volcal.errors import VolcalInputError

#: Rebuild the prior with its short-wavelength (nugget) part (``fit.hyperparameters``).
NUGGET_IN_PRIOR = True
#: Eigenvalues of a function's difference covariance below this fraction of the largest
#: are directions the two estimates hardly spread in: left out of the test. ``C - CQC``
#: is a difference of two nearly equal matrices in the directions the prior alone holds,
#: and two calibrations' evidence-chosen hyperparameters differ a little; at 1e-10 those
#: directions counted and unchanged machines were flagged (4 of 6 pairs, study of
#: benchmarks/history_study.py), at 1e-6 none (0 of 6), with the same power.
RANK_RTOL = 1e-6

#: Determined fraction below which a function counts as undetermined.
UNDETERMINED_BELOW = 0.5

#: Combinations of a function's nodes tested: those whose determined fraction (share of
#: the posterior variance due to the readings, ``1 - posterior / prior``) in both
#: calibrations together is at least this. The rest is the prior's shrinkage, which moves
#: with the hyperparameters each calibration chooses from its own readings: tested with
#: ``C - CQC`` alone, unchanged machines were flagged in 6 of 20 pairs at 6 increments
#: and 2 runs (issue 26); over these combinations with the posterior covariances, 0 of 20
#: (at 0.5 and at 0.25: 0.25 keeps the straightness bows of the diagonals in the test).
DETERMINED_FROM = 0.25


@dataclass
class Entry:
    """One entry of the change test.

    Attributes
    ----------
    name : str
        Parameter (``X.A``, ``linear-x1.R``, ``V.E_VXYZ``) or function (``EXX``, ``EC0Y``).
    difference : float
        Later minus earlier [um or urad] (for a function: at its node of largest change).
    U : float or None
        Expanded uncertainty of the difference (k = 2) [um or urad].
    changed : bool or None
        The test's decision; ``None`` when it cannot be made.
    unit : str
        ``um`` or ``urad``.
    test : str
        ``|d| > U`` or ``chi-square``.
    statistic, threshold : float or None
        The chi-square statistic and its critical value (functions).
    dof : int or None
        Degrees of freedom of the chi-square test.
    position_mm : float or None
        Node of the largest difference (functions).
    reason : str
        Why ``changed`` is ``None``.
    """

    name: str
    difference: float
    U: float | None
    changed: bool | None
    unit: str
    test: str
    statistic: float | None = None
    threshold: float | None = None
    dof: int | None = None
    position_mm: float | None = None
    reason: str = ""

    @property
    def verdict(self) -> str:
        """``CHANGED``, ``unchanged`` or ``undecided`` (``changed`` true, false, None)."""
        return "undecided" if self.changed is None else (
            "CHANGED" if self.changed else "unchanged")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (with ``verdict``)."""
        return {**{k: getattr(self, k) for k in ("name", "difference", "U", "changed",
                                                 "unit", "test", "statistic", "threshold",
                                                 "dof", "position_mm", "reason")},
                "verdict": self.verdict}


def load_record_model(store: Any, rid: str, record: Any = None) -> Any:
    """The model file of a calibration record, loaded from the store's copy.

    Parameters
    ----------
    store : Store
        The history.
    rid : str
        Calibration record id.
    record : Record, optional
        The record ``rid``, when already read (checked against its hash as it was read).
    """
    from volcal.identify.modelfile import load_model

    rec = record if record is not None and record.id == rid else store.record(rid)
    if rec.damage is not None:  # its list of files may be altered: nothing of it unpacked
        raise VolcalInputError(f"record {rec.id}: {rec.damage}; its model is not used "
                               "(volcal history verify)", store.where)
    names = [f for f in rec.files if f["role"] in ("model", "model-part")]
    if not any(f["role"] == "model" for f in names):
        return None
    with tempfile.TemporaryDirectory(prefix="volcal-history-") as tmp:
        for f in names:
            (Path(tmp) / f["name"]).write_bytes(store.file(rid, f["role"], f["name"], rec))
        main = [f["name"] for f in names if f["role"] == "model"][-1]
        return load_model(Path(tmp) / main)


def prior_precision(model: Any) -> Any:
    """Prior precision of a model's free parameters, rebuilt from its hyperparameters.

    With the estimator settings the model records
    (:func:`volcal.identify.settings_file.recorded_settings`: a prior's ``group_kappa`` or
    ``boundary`` other than the defaults changes its precision).

    ``None`` when the model file does not record them (then the posterior covariance
    is used as it is).

    Parameters
    ----------
    model : IdentificationResult
        A model whose fit records its hyperparameters.
    """
    from volcal.identify.prior import PriorStructure, function_scales
    from volcal.identify.settings_file import recorded_settings

    hyp = model.fit.hyperparameters or {}
    keys = ("positioning_um", "straightness_um", "roll_urad", "tilt_urad", "kappa")
    if not all(isinstance(hyp.get(k), int | float) for k in keys):
        return None
    per_metre = isinstance(hyp.get("positioning_trend_um_per_m"), int | float)
    settings = replace(recorded_settings(model), trend_per_metre=per_metre)
    prior = PriorStructure.build(model.layout, model.free, float(hyp["kappa"]),
                                 settings=settings)
    # a model of volcal <= issue 29 records one trend at the end of every travel [um]
    prior = prior.with_trend(hyp["positioning_trend_um_per_m"] if per_metre
                             else hyp.get("positioning_trend_um") or 0.0)
    # the tilts' linear part and each axis' curvature factor (issue 30; absent before)
    prior = prior.with_tilt_trend(hyp.get("tilt_trend_urad") or 0.0)
    axis_kappa = hyp.get("kappa_axis")
    if isinstance(axis_kappa, list) and len(axis_kappa) == 3:
        prior = prior.with_axis_kappa([float(v) for v in axis_kappa])
    if NUGGET_IN_PRIOR:
        prior = prior.with_nugget(hyp.get("positioning_nugget_um") or 0.0)
    scales = function_scales(np.array([hyp[k] for k in keys[:4]], dtype=float))
    # each axis' amplitude grown with its travel (issue 30; absent before)
    exponents = hyp.get("travel_exponent")
    if isinstance(exponents, list) and exponents:
        groups = hyp.get("travel_exponent_groups") or settings.travel_exponent_groups
        if len(groups) == len(exponents):
            scales = scales * np.exp(prior.travel_columns(groups)
                                     @ np.array(exponents, dtype=float))
    n = int(model.free.size)
    return prior.precision(scales, 100.0, n, np.zeros(0))


def noise_covariance(model: Any) -> np.ndarray:
    """Covariance of the estimate of a *given* machine: ``C - C Q C`` [free x free].

    The posterior covariance ``C`` of a Bayesian estimate holds the prior's spread of
    machines (``C Q C``) besides the spread of the readings and set-ups. Two
    calibrations of one machine with one prior share that part: the spread of their
    difference is that of the readings and set-ups alone, ``C - C Q C`` each
    (Rasmussen & Williams 2006, 2.2; the set-up tilts stay random: they differ from one
    set-up to the next).

    Parameters
    ----------
    model : IdentificationResult
        A model with its covariance factor and hyperparameters.
    """
    L = np.asarray(model.cov_factor)
    C = L @ L.T
    Q = prior_precision(model)
    if Q is None:
        return C
    QC = np.asarray(Q @ C)  # sparse prior precision times dense C
    Cn = C - QC.T @ C
    return (Cn + Cn.T) / 2  # negative eigenvalues (rounding) are dropped by the test


def _full_cov(model: Any, idx: np.ndarray, cov: np.ndarray | None = None) -> np.ndarray:
    """Covariance of the layout parameters ``idx`` (gauge zeros: 0).

    ``cov`` is a covariance of the free parameters; default the posterior's.
    """
    pos = -np.ones(model.layout.size, dtype=np.intp)
    pos[model.free] = np.arange(model.free.size)
    p = pos[idx]
    ok = p >= 0
    if cov is None:
        L = np.zeros((idx.size, model.cov_factor.shape[1]))
        L[ok] = np.asarray(model.cov_factor)[p[ok]]
        return L @ L.T
    out = np.zeros((idx.size, idx.size))
    out[np.ix_(ok, ok)] = cov[np.ix_(p[ok], p[ok])]
    return out


def _interp_matrix(nodes: np.ndarray, q: np.ndarray) -> np.ndarray:
    from volcal.model.errorfunctions import interp_weights

    i0, i1, w = interp_weights(nodes, q)
    P = np.zeros((q.size, nodes.size))
    P[np.arange(q.size), i0] += 1 - w
    P[np.arange(q.size), i1] += w
    return P


def _determined(model: Any, name: str) -> float | None:
    rep = model.report
    frac = rep.get("determined_fraction") if isinstance(rep, dict) else \
        getattr(rep, "determined_fraction", None)
    if not frac:
        return None
    v = frac.get(name)
    return None if v is None else float(v)


def _determined_statistic(d: np.ndarray, C: np.ndarray, Cn: np.ndarray | None
                          ) -> tuple[int, float]:
    """:func:`_split_statistic`'s tested part: ``(dof, statistic)``."""
    r, stat, _, _ = _split_statistic(d, C, Cn)
    return r, stat


def _split_statistic(d: np.ndarray, C: np.ndarray, Cn: np.ndarray | None
                     ) -> tuple[int, float, int, float]:
    """Chi-square of a difference over the combinations the data determine.

    ``C`` is the sum of the two posterior covariances, ``Cn`` the sum of their parts due
    to the readings and set-ups (``C - C Q C`` each). In the metric of ``C``, the
    eigen-directions of ``Cn`` with eigenvalue ``mu`` (the determined fraction of that
    combination: ``1 - posterior / prior`` variance) at or above
    :data:`DETERMINED_FROM` are tested, each with its posterior variance; the others (the
    prior's shrinkage, which moves with the hyperparameters chosen per calibration) are
    left out. ``Cn = None`` (no hyperparameters recorded): every direction of ``C``.

    Returns
    -------
    dof : int
        Combinations tested.
    statistic : float
        ``sum z_i^2``, ``z`` the difference in those combinations over its posterior
        standard deviation.
    rest_dof : int
        Combinations left out (not determined by the data).
    rest_statistic : float
        The same sum over them: large when the difference lies where the design cannot
        tell a change from the prior's shrinkage (the verdict is then undecided, never
        ``unchanged``; :func:`_function_entries`).
    """
    w, U = np.linalg.eigh((C + C.T) / 2)
    ok = w > max(w.max(), 0.0) * RANK_RTOL
    if not ok.any():
        return 0, 0.0, 0, 0.0
    T = U[:, ok] / np.sqrt(w[ok])
    z = T.T @ d
    if Cn is None:
        return int(ok.sum()), float(z @ z), 0, 0.0
    M = T.T @ Cn @ T
    mu, V = np.linalg.eigh((M + M.T) / 2)
    keep = mu >= DETERMINED_FROM
    zk = V[:, keep].T @ z
    zr = V[:, ~keep].T @ z
    return int(keep.sum()), float(zk @ zk), int((~keep).sum()), float(zr @ zr)


def _residual_dof(model: Any) -> float:
    """Residual degrees of freedom of a model's noise estimate (``fit.dof``; inf if none)."""
    fit = model.fit
    v = fit.get("dof") if isinstance(fit, dict) else getattr(fit, "dof", None)
    return float(v) if isinstance(v, int | float) and v > 0 else float("inf")


def _threshold(p: float, r: int, nu: float) -> float:
    """Critical value of ``chi2`` over ``r`` combinations at probability ``p``.

    The covariances scale with the reading noise each calibration estimates from its own
    residuals (``nu`` degrees of freedom, the smaller of the two): ``chi2 / r`` then
    follows an F distribution with ``(r, nu)`` degrees of freedom (Hotelling), not
    ``chi2(r) / r``; at 4 increments and 1 run (``nu`` about 70) the chi-square quantile
    flagged unchanged machines in 3 of 12 pairs (three generators), F 1 of 28. ``nu``
    infinite: the chi-square quantile.
    """
    from scipy.stats import chi2, f

    if not np.isfinite(nu):
        return float(chi2.ppf(p, r))
    return float(r * f.ppf(p, r, nu))


def _function_entries(m1: Any, m2: Any, level: float, common_prior: bool = True
                      ) -> list[Entry]:
    from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

    if str(m1.errors.chain) != str(m2.errors.chain):
        raise VolcalInputError(f"the two models have other chains ({m1.errors.chain}, "
                               f"{m2.errors.chain}): not one machine")
    tests: list[tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]] = []
    th1, th2 = m1.theta, m2.theta
    c1 = noise_covariance(m1) if common_prior else None
    c2 = noise_covariance(m2) if common_prior else None
    for k in range(3):
        n1, n2 = m1.layout.nodes[k], m2.layout.nodes[k]
        lo, hi = max(n1[0], n2[0]), min(n1[-1], n2[-1])
        q = n1[(n1 >= lo - 1e-9) & (n1 <= hi + 1e-9)]
        P1, P2 = _interp_matrix(n1, q), _interp_matrix(n2, q)
        for c in range(6):
            i1, i2 = m1.layout.indices(k, c), m2.layout.indices(k, c)
            d = P2 @ th2[i2] - P1 @ th1[i1]
            C = P1 @ _full_cov(m1, i1) @ P1.T + P2 @ _full_cov(m2, i2) @ P2.T
            Cn = P1 @ _full_cov(m1, i1, c1) @ P1.T + P2 @ _full_cov(m2, i2, c2) @ P2.T
            tests.append((COMPONENT_NAMES[6 * k + c], d, C, q,
                          Cn if common_prior and c1 is not None else None))
    s1, s2 = m1.layout.squareness_indices(), m2.layout.squareness_indices()
    for j, name in enumerate(SQUARENESS_NAMES):
        d = np.array([th2[s2[j]] - th1[s1[j]]])
        C = _full_cov(m1, s1[j:j + 1]) + _full_cov(m2, s2[j:j + 1])
        Cn = _full_cov(m1, s1[j:j + 1], c1) + _full_cov(m2, s2[j:j + 1], c2)
        tests.append((name, d, C, np.array([np.nan]),
                      Cn if common_prior and c1 is not None else None))
    # the family: the functions both calibrations determine (Bonferroni over the tests made)
    decided = [t for t in tests if not any(
        f is not None and f < UNDETERMINED_BELOW for f in (_determined(m1, t[0]),
                                                           _determined(m2, t[0])))]
    m = max(1, len(decided))
    nu = min(_residual_dof(m1), _residual_dof(m2))
    out = []
    for name, d, C, q, Cn in tests:
        unit = "um" if name[1] in "XYZ" and name not in SQUARENESS_NAMES else "urad"
        i = int(np.argmax(np.abs(d)))
        u = float(np.sqrt(max(C[i, i], 0.0)))
        pos = None if np.isnan(q[i]) else float(q[i])
        e = Entry(name, float(d[i]), 2.0 * u, None, unit, "chi-square", position_mm=pos)
        fr = [_determined(mm, name) for mm in (m1, m2)]
        if any(f is not None and f < UNDETERMINED_BELOW for f in fr):
            e.reason = "undetermined by " + " and ".join(
                w for w, f in zip(("the earlier", "the later"), fr, strict=True)
                if f is not None and f < UNDETERMINED_BELOW) + " calibration"
            out.append(e)
            continue
        r, stat, r_rest, stat_rest = _split_statistic(d, C, Cn)
        if r == 0:
            e.reason = ("fixed by the gauge in both calibrations" if not np.any(C)
                        else "no combination determined by both calibrations")
            out.append(e)
            continue
        thr = _threshold(1.0 - level / m, r, nu)
        e.statistic, e.threshold, e.dof = stat, thr, r
        e.changed = bool(stat > thr)
        if not e.changed and r_rest and stat_rest > (thr_rest := _threshold(
                1.0 - level / m, r_rest, nu)):
            # not "unchanged": the difference lies where the design cannot tell
            e.changed = None
            e.reason = (f"no change in the {r} combinations of its nodes the data "
                        f"determine (chi2 {stat:.1f} <= {thr:.1f}), but the difference in "
                        f"the {r_rest} they do not determine is beyond their spread (chi2 "
                        f"{stat_rest:.1f} > {thr_rest:.1f}): this design cannot tell")
        out.append(e)
    return out


def compare_models(m1: Any, m2: Any, level: float = 0.05) -> list[Entry]:
    """The change test of the identified functions and squareness of two models.

    The function part of :func:`compare`, for two models not stored (the history
    study's pairs).

    Parameters
    ----------
    m1, m2 : IdentificationResult
        Earlier and later model of one machine.
    level : float
        Family-wise false-alarm level (default 5 %).

    Returns
    -------
    list of Entry
    """
    if not 0.0 < level < 1.0:
        raise VolcalInputError(f"--level {level}: expected a fraction between 0 and 1")
    return _function_entries(m1, m2, level)


def _result_entries(r1: Any, r2: Any, models: bool) -> list[Entry]:
    from volcal.history.record import DESCRIPTOR_UNITS
    from volcal.model.names import SQUARENESS_NAMES

    out = []
    for name in sorted(set(r1.results) & set(r2.results)):
        if models and name in SQUARENESS_NAMES:
            continue  # tested with the functions, from the two models' covariances
        if name.rpartition(".")[2] in DESCRIPTOR_UNITS:
            continue  # a diagonal's length or point count: the test, not the machine
        a, b = r1.results[name], r2.results[name]
        if a["value"] is None or b["value"] is None:
            continue
        d = float(b["value"]) - float(a["value"])
        if a["U"] is None or b["U"] is None:
            out.append(Entry(name, d, None, None, a["unit"], "|d| > U",
                             reason="no uncertainty stored for "
                             + ("either" if a["U"] is None and b["U"] is None else
                                "the earlier" if a["U"] is None else "the later")))
            continue
        U = float(np.hypot(a["U"], b["U"]))
        out.append(Entry(name, d, U, bool(abs(d) > U), a["unit"], "|d| > U"))
    return out


def compare(store: Any, id1: str, id2: str, level: float = 0.05) -> list[Entry]:
    """The change test between two calibration records.

    Parameters
    ----------
    store : Store
        The history.
    id1, id2 : str
        Earlier and later calibration (the newest correction of each is used).
    level : float
        Family-wise false-alarm level of the function tests (default 5 %).

    Returns
    -------
    list of Entry

    Raises
    ------
    VolcalInputError
        Not calibrations, or of two machines.
    """
    if not 0.0 < level < 1.0:
        raise VolcalInputError(f"--level {level}: expected a fraction between 0 and 1")
    with store.reading():  # one connection for the records and their files
        r1, r2 = store.current(id1), store.current(id2)
        for r in (r1, r2):
            if r.kind != "calibration":
                raise VolcalInputError(f"{r.id} is a {r.kind} record, not a calibration")
        if r1.machine_id != r2.machine_id:
            raise VolcalInputError(f"{r1.id} and {r2.id} are calibrations of two machines "
                                   f"({r1.machine_name}, {r2.machine_name})")
        m1, m2 = load_record_model(store, r1.id, r1), load_record_model(store, r2.id, r2)
    both = m1 is not None and m2 is not None
    out = _result_entries(r1, r2, both)
    if both:
        out.extend(_function_entries(m1, m2, level))
    return out


def pair_notes(store: Any, id1: str, id2: str) -> list[str]:
    """What the two calibrations compared are to each other, for the reader of the test.

    Parameters
    ----------
    store : Store
        The history.
    id1, id2 : str
        The calibrations given as earlier and later.

    Returns
    -------
    list of str
        An as-found / as-left pair: its differences are the compensation's as much as the
        machine's (the machine's change is the next as-found against the as-left); the
        two given in the reverse order of their dates: the differences are then earlier
        minus later.
    """
    with store.reading():
        r1, r2 = store.current(id1), store.current(id2)
    out = []
    ids1, ids2 = {id1, r1.id}, {id2, r2.id}
    if r2.as_left_of in ids1 or r1.as_left_of in ids2:
        found, left = (r1, r2) if r2.as_left_of in ids1 else (r2, r1)
        out.append(f"{left.id} is the as-left of {found.id} (measured with the compensation "
                   "tables active): the differences are what the tables corrected as much "
                   f"as the machine's change; the machine's change since is the next "
                   f"as-found against {left.id}")
    d1, d2 = str(r1.date or "")[:19], str(r2.date or "")[:19]
    if d1 and d2 and d1 > d2:
        n = 10 if d1[:10] != d2[:10] else 19  # the day, or the time on one day
        out.append(f"{r1.id} was measured after {r2.id} ({d1[:n]}, {d2[:n]}): the "
                   "differences are the earlier minus the later (give the earlier first)")
    return out


@dataclass
class _Results:
    """Results of a calibration not (yet) stored, shaped as a record's ``results``."""

    results: dict[str, dict[str, Any]]


def session_digest(session: Any) -> str:
    """The hash a calibration record keeps of its session's files (``session_sha256``).

    Parameters
    ----------
    session : Session
        A session read from its folder.
    """
    import hashlib

    from volcal.history.record import session_files

    digest = hashlib.sha256()
    for role, name, content in session_files(Path(session.path)):
        if role == "session":
            digest.update(name.encode() + b"\0" + hashlib.sha256(content).digest())
    return digest.hexdigest()


def previous_calibration(store: Any, session: Any) -> Any:
    """The stored calibration of the session's machine that precedes the session.

    The machine is matched as ``history add`` matches it (serial, else name, chain and
    travel); among its current (not superseded) calibrations, the record of this very
    session (same files) is left out, and the newest one measured on or before the
    session's date (``[calibration] date``, else ``[provenance] date``; any date when it
    has none) is returned.

    Parameters
    ----------
    store : Store
        The history.
    session : Session
        The calibration being reported (read from its folder).

    Returns
    -------
    Record or None
        ``None`` when the machine or an earlier calibration is not in the history.

    Raises
    ------
    VolcalInputError
        The session matches several machines of the history.
    """
    return previous_and_own(store, session)[0]


def previous_and_own(store: Any, session: Any) -> tuple[Any, Any]:
    """The previous calibration (:func:`previous_calibration`) and the session's own record.

    One match of the machine, one digest of the session's files and one read of its
    calibrations for both (the report's "Previous calibration" needs both: an as-left
    stored with ``history add --as-left-of`` is said to be one).

    Parameters
    ----------
    store : Store
        The history.
    session : Session
        The calibration being reported (read from its folder).

    Returns
    -------
    (Record or None, Record or None)
        The previous calibration, and the current record holding the session's files
        (``None`` when it is not stored, or the session has no folder).

    Raises
    ------
    VolcalInputError
        The session matches several machines of the history.
    """
    from volcal.history.machines import match
    from volcal.session.identity import parse_date

    machine = match(store.records("machine"), session.identity)
    if machine is None:
        return None, None
    recs = [r for r in store.records("calibration", machine_id=machine.id)  # indexed
            if r.kind == "calibration" and r.machine_id == machine.id
            and r.superseded_by is None]
    own = session_digest(session) if session.path is not None else None
    mine = [r for r in recs if own is not None and r.payload.get("session_sha256") == own]
    when = session.calibration.get("date") or session.provenance.get("date")
    day = None if when is None else str(parse_date(when))[:10]
    cands = [r for r in recs if r.payload.get("session_sha256") != own
             and (day is None or r.date is None or str(r.date)[:10] <= day)]
    prev = max(cands, key=lambda r: (str(r.date or ""), r.id)) if cands else None
    return prev, (mine[0] if mine else None)


def compare_with_model(store: Any, earlier: str, session: Any, model: Any,
                       level: float = 0.05, evaluation: Any = None) -> list[Entry]:
    """The change test between a stored calibration and one not stored (yet).

    As :func:`compare`, with the later calibration given by its session and model
    instead of a record id: its results are computed as ``history add`` would store
    them (:func:`volcal.history.record.results_of`).

    Parameters
    ----------
    store : Store
        The history.
    earlier : str
        Id of the earlier calibration record.
    session : Session
        The later calibration's session (with readings).
    model : IdentificationResult or None
        Its model; ``None`` compares the results only.
    level : float
        Family-wise false-alarm level of the function tests (default 5 %).
    evaluation : SessionEvaluation, optional
        The session's evaluation already made (the report's, with its budget): its results
        and U are used as they are.

    Returns
    -------
    list of Entry
    """
    from volcal.history.record import results_of

    if not 0.0 < level < 1.0:
        raise VolcalInputError(f"--level {level}: expected a fraction between 0 and 1")
    r1 = store.current(earlier)
    if r1.kind != "calibration":
        raise VolcalInputError(f"{r1.id} is a {r1.kind} record, not a calibration")
    r2 = _Results({n: {"value": v, "U": u, "unit": unit}
                   for n, v, u, unit in results_of(session, model, evaluation=evaluation)})
    m1 = load_record_model(store, r1.id)
    both = m1 is not None and model is not None
    out = _result_entries(r1, r2, both)
    if both:
        out.extend(_function_entries(m1, model, level))
    return out
