r"""The location errors of a session, the sphere-centre scatter and its test per path.

One evaluation of a session's ``probe_sphere`` and ``r_test`` tests, shared by the report, the
certificate and the history (they format or store what it gives):

* the location errors per chain (:func:`volcal.identify.location.identify_location`),
  with the linear axes' errors of the session's model when there is one;
* the **scatter of the sphere centre before and after**: at each pose, the sphere centre
  the reported probe centre gives in workpiece coordinates (the probe tip through the
  inverse of the chain's pose) with the configured kinematics, minus the mean of the
  test's poses (its length is the dispersion a control's own cycle reports, HEIDENHAIN
  cycle 451, Siemens CYCLE996) -- *before*; and with the identified location errors
  applied, minus the identified sphere centre -- *after* (the residual the identified
  kinematics leave, what a control holding them would leave);
* an **ISO 10791-6-style test** of each path: the poses of a test along which one rotary
  axis turns while the others stand (``C at A = 45 deg``). At each pose of the path the
  deviation in machine coordinates X, Y, Z: the reported centre minus where the
  kinematics put the sphere as the path's first pose located it (an R-test's sensors
  zeroed at the start of the path); its range (max - min) in X, in Y and in Z over the
  path, as the kinematic tests of ISO 10791-6:2014 evaluate the sphere centre's
  deviation during a rotary motion with the linear axes following (Weikert 2004;
  Ibaraki et al. 2011), compared with a tolerance by the decision rules of the linear axes
  (:func:`volcal.standards.decision.decide`). The expanded uncertainty of a range (the
  difference of two readings) is ``U = k sqrt(2) sigma`` with the test's probe noise
  ``sigma`` (``noise_um``), k = 2.

References
----------
.. [1] ISO 10791-6:2014, Test conditions for machining centres -- Part 6: Accuracy of
   speeds and interpolations (kinematic tests of paths of simultaneous linear and rotary
   motion; the clauses and tolerances of its 5-axis tests are not publicly available,
   hence "ISO 10791-6-style").
.. [2] Weikert, S., "R-Test, a new device for accuracy measurements on five axis machine
   tools", CIRP Annals 53(1) (2004) 429-432.
.. [3] Ibaraki, S., Oyama, C., Otsubo, H., "Construction of an error map of rotary axes on
   a five-axis machining center by static R-test", Int. J. Machine Tools and Manufacture
   51 (2011) 190-200.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["COVERAGE_K", "LocatedChain", "LocationTolerance", "PathRange", "locate_session",
           "location_results", "location_tolerance", "path_decisions"]

Array = NDArray[np.float64]
COVERAGE_K = 2.0
"""Coverage factor of every U of this module."""


@dataclass(frozen=True)
class LocationTolerance:
    """The tolerance of the per-path sphere-centre test and its decision rule.

    Attributes
    ----------
    tolerance_um : float
        Tolerance T of the largest range (X, Y or Z) of a path [um].
    rule : str
        ``'simple'`` or ``'guarded'`` (:mod:`volcal.standards.decision`).
    guard_band_um : float, optional
        Guard band w of the guarded rule [um] (default U).
    """

    tolerance_um: float
    rule: str = "simple"
    guard_band_um: float | None = None


def location_tolerance(tolerance_um: float | None, rule: str = "simple",
                       guard_band_um: float | None = None) -> LocationTolerance | None:
    """The checked tolerance (None when ``tolerance_um`` is None).

    Parameters
    ----------
    tolerance_um : float or None
        Tolerance [um], finite and positive.
    rule : str
        Decision rule.
    guard_band_um : float, optional
        Guard band [um].

    Raises
    ------
    ParameterError
        A tolerance that is not a positive number, an unknown rule.
    """
    from volcal.errors import ParameterError
    from volcal.standards.decision import check_rule

    if tolerance_um is None:
        return None
    t = float(tolerance_um)
    if not (math.isfinite(t) and t > 0):
        raise ParameterError(f"{{location_tolerance_um=}}{tolerance_um}: expected a positive "
                             "tolerance [um]")
    return LocationTolerance(t, check_rule(rule), guard_band_um)


@dataclass(frozen=True)
class PathRange:
    """The sphere centre's deviation over one path of a test.

    Attributes
    ----------
    measurement : str
        The probe_sphere test.
    path : str
        In words: ``'C at A = 45°'`` (the turning axis, the others' fixed angles), or
        ``'all poses'`` when the poses form no path.
    moving : str
        The turning axis (``''`` for ``'all poses'``).
    n_poses : int
        Poses on the path.
    range_before_um : ndarray, shape (3,)
        Range of the deviation in X, Y, Z with the configured kinematics, zeroed at the
        path's first pose, machine coordinates [um].
    range_after_um : ndarray, shape (3,)
        The same with the identified location errors applied [um].
    U_um : float
        Expanded uncertainty of a range from the probe noise, ``k sqrt(2) sigma`` [um].
    """

    measurement: str
    path: str
    moving: str
    n_poses: int
    range_before_um: Array
    range_after_um: Array
    U_um: float

    @property
    def before_um(self) -> float:
        """The largest of the three ranges before [um]."""
        return float(np.max(self.range_before_um))

    @property
    def after_um(self) -> float:
        """The largest of the three ranges after [um]."""
        return float(np.max(self.range_after_um))


@dataclass(frozen=True)
class LocatedChain:
    """The location errors of one chain and the scatter of its tests.

    Attributes
    ----------
    chain : str
        Chain code.
    measurements : tuple of str
        The probe_sphere tests.
    result : LocationResult
        The identification.
    angles : dict of str to ndarray
        Angles of every pose of the tests, in their order [deg].
    pose_measurement : tuple of str
        The test of each pose.
    before_um : ndarray, shape (n, 3)
        Sphere centre per pose with the configured kinematics minus the test's mean,
        workpiece coordinates [um].
    after_um : ndarray, shape (n, 3)
        Sphere centre per pose with the identified errors minus the identified centre [um].
    paths : tuple of PathRange
        The ranges per path.
    linear : bool
        Whether the linear axes' errors of a model were applied.
    """

    chain: str
    measurements: tuple[str, ...]
    result: Any
    angles: dict[str, Array]
    pose_measurement: tuple[str, ...]
    before_um: Array
    after_um: Array
    paths: tuple[PathRange, ...] = field(default_factory=tuple)
    linear: bool = False

    def location_rows(self) -> list[dict[str, Any]]:
        """Every location error of the chain: name, meaning, unit, value, U, status.

        ``value`` and ``U`` (k = 2) are None for an error held at zero (redundant).
        """
        rows = []
        for r in self.result.to_rows():
            u = float(r["u"])
            ok = not math.isnan(u)
            rows.append({"name": r["name"], "meaning": r["meaning"], "unit": r["unit"],
                         "value": float(r["value"]) if ok else None,
                         "U": COVERAGE_K * u if ok else None, "status": r["status"]})
        return rows


def _path_range(kin: tuple[Any, Array], angles: dict[str, Array], idx: list[int],
                pos: Array, tool: Array) -> Array:
    """Range in X, Y, Z of a path's deviation, zeroed at its first pose [um].

    The deviation at each pose of the path: the reported centre minus where the
    kinematics put the sphere as the first pose of the path located it (an R-test's
    sensors zeroed at the start of the path), in machine coordinates.
    """
    from volcal.measure.spheres import probe_centres

    machine, p = kin
    ang = {r: v[idx] for r, v in angles.items()}
    d = pos[idx] - probe_centres(machine, ang, p[idx[0]], tool)
    return np.asarray(np.ptp(d, axis=0) * 1e3, dtype=float)


def _paths(mid: str, angles: dict[str, Array], before: tuple[Any, Array],
           after: tuple[Any, Array], pos: Array, tool: Array, U: float) -> list[PathRange]:
    """The poses along which one axis turns while the others stand (>= 3 poses)."""
    return _path_ranges(mid, angles, pos.shape[0], U, lambda idx: (
        _path_range(before, angles, idx, pos, tool), _path_range(after, angles, idx, pos, tool)))


def _rtest_paths(mid: str, angles: dict[str, Array], before: Array, after: Array,
                 U: float) -> list[PathRange]:
    """An r_test's paths: the range of its displacements (before) and residuals (after)."""
    return _path_ranges(mid, angles, before.shape[0], U, lambda idx: (
        np.asarray(np.ptp(before[idx], axis=0), dtype=float),
        np.asarray(np.ptp(after[idx], axis=0), dtype=float)))


def _path_ranges(mid: str, angles: dict[str, Array], n: int, U: float,
                 ranges: Callable[[list[int]], tuple[Array, Array]]) -> list[PathRange]:
    """The paths of a test, ``ranges(idx)`` giving the ranges before and after [um]."""
    letters = list(angles)
    out: list[PathRange] = []
    for r in letters:
        others = [o for o in letters if o != r]
        keys = [tuple(round(float(angles[o][i]), 6) for o in others) for i in range(n)]
        for key in dict.fromkeys(keys):
            idx = [i for i, k in enumerate(keys) if k == key]
            if len(idx) < 3 or np.ptp(angles[r][idx]) == 0.0:
                continue
            where = ", ".join(f"{o} = {v:g}°" for o, v in zip(others, key, strict=True))
            before, after = ranges(idx)
            out.append(PathRange(mid, f"{r} at {where}" if where else f"{r}", r, len(idx),
                                 before, after, U))
    if not out and n >= 2:
        before, after = ranges(list(range(n)))
        out.append(PathRange(mid, "all poses", "", n, before, after, U))
    return out


def locate_session(session: Any, model: Any = None) -> list[LocatedChain]:
    """The location errors and the sphere-centre scatter of a session, chain by chain.

    Identified as ``volcal locate SESSION --model MODEL`` identifies them
    (:func:`volcal.steps.locate.locate`): the model's linear errors in the forward model
    and, for a model with its covariance, its uncertainty in the readings' covariance
    (:func:`volcal.identify.location_linear.linear_prior`).

    Parameters
    ----------
    session : Session
        A session; its measured ``probe_sphere`` and ``r_test`` tests are used (none: an
        empty list). An r_test's scatter is the sphere's displacement in the nest [um]:
        before, the readings minus their mean; after, the residual of the identification
        (the readings minus those the identified errors, sphere and nest predict) minus its
        mean; its paths' ranges are those of the readings and of the residual.
    model : IdentificationResult or MachineErrors, optional
        The linear axes' model (``volcal identify``'s, with its covariance) or bare
        errors; None: perfect linear axes.

    Returns
    -------
    list of LocatedChain
    """
    from volcal.identify.location import identify_location
    from volcal.measure.spheres import rtest_readings
    from volcal.model.fiveaxis import exact_pose5
    from volcal.session.probe_sphere import _angles, _keys, five_axis_machine

    linear = getattr(model, "errors", model)
    ms = [m for m in session.measurements
          if m.kind in ("probe_sphere", "r_test") and m.deviation is not None]
    out: list[LocatedChain] = []
    for chain in dict.fromkeys(m.meta["chain"] for m in ms):
        group = [m for m in ms if m.meta["chain"] == chain]
        nominal = five_axis_machine(group[0], linear)
        blocks = [_block(m) if m.kind == "probe_sphere" else _rtest_block(m) for m in group]
        prior = None
        if model is not None and nominal.linear is not None:  # as volcal locate --model
            from volcal.identify.location_linear import linear_prior

            prior = linear_prior(model, nominal, blocks)
        res = identify_location(nominal, blocks, linear=prior)
        before, after, poses = [], [], []
        paths: list[PathRange] = []
        angles: dict[str, list[Array]] = {}
        for m, b in zip(group, blocks, strict=True):
            if m.kind == "r_test":
                s = np.array([res.nuisances[f"{b.sphere}:s{a}"] for a in "xyz"])
                pred = rtest_readings(res.machine, b.q_mm, b.angles, s, b.tool_offset_mm)
                v = np.asarray(b.values, dtype=float)
                resid = v - pred
                before.append(v - v.mean(axis=0))
                after.append(resid - resid.mean(axis=0))
                poses += [m.id] * m.n
                for r, a in b.angles.items():
                    angles.setdefault(r, []).append(a)
                paths += _rtest_paths(m.id, b.angles, v, resid,
                                      COVERAGE_K * math.sqrt(2.0) * float(b.noise_um))
                continue
            k = _keys(m)
            ang = _angles(m)
            pos = np.asarray(m.positions, dtype=float)
            tool = np.asarray(m.tool_offset, dtype=float)
            nom = five_axis_machine(m, linear)
            p0, _ = exact_pose5(nom, pos, ang, tool)
            p1, _ = exact_pose5(res.machine, pos, ang, tool)
            s = np.array([res.nuisances[f"{k['sphere']}:s{a}"] for a in "xyz"])
            before.append((p0 - p0.mean(axis=0)) * 1e3)
            after.append((p1 - s) * 1e3)
            poses += [m.id] * m.n
            for r, v in ang.items():
                angles.setdefault(r, []).append(v)
            U = COVERAGE_K * math.sqrt(2.0) * float(k["noise_um"])
            paths += _paths(m.id, ang, (nom, p0), (res.machine, p1), pos, tool, U)
        out.append(LocatedChain(
            nominal.chain_obj.code, tuple(m.id for m in group), res,
            {r: np.concatenate(v) for r, v in angles.items()}, tuple(poses),
            np.vstack(before), np.vstack(after), tuple(paths), nominal.linear is not None))
    return out


def _block(m: Any) -> Any:
    """A measured probe_sphere test as the estimator's block."""
    from volcal.measure.spheres import SphereReadings
    from volcal.session.probe_sphere import _angles, _keys

    k = _keys(m)
    return SphereReadings(m.id, "probe", _angles(m), np.asarray(m.positions, dtype=float),
                          k["sphere"], k["sphere_mm"], np.asarray(m.tool_offset, dtype=float),
                          None, k["noise_um"])


def _rtest_block(m: Any) -> Any:
    """A measured r_test test as the estimator's block, in the nest's frame.

    As ``volcal locate`` builds it (:func:`volcal.kinds.r_test.rtest_readings_block`).
    """
    from volcal.measure.spheres import SphereReadings
    from volcal.session.r_test import head_rotation, rtest_angles, rtest_keys

    k = rtest_keys(m)
    ang = rtest_angles(m)
    d = np.column_stack([np.asarray(m.columns[c], dtype=float)
                         for c in ("dx_um", "dy_um", "dz_um")])
    v = np.einsum("mji,mj->mi", head_rotation(k["chain"], ang), d)
    return SphereReadings(m.id, "rtest", ang, v, k["sphere"], k["sphere_mm"],
                          np.asarray(m.tool_offset, dtype=float),
                          np.asarray(m.positions, dtype=float), k["noise_um"])


def path_decisions(located: list[LocatedChain], tolerance_um: float, rule: str = "simple",
                   guard_band_um: float | None = None) -> list[dict[str, Any]]:
    """The ISO 10791-6-style test of every path: ranges before and after vs a tolerance.

    Parameters
    ----------
    located : list of LocatedChain
        :func:`locate_session`'s result.
    tolerance_um : float
        Tolerance T of the largest range (X, Y or Z) of a path [um].
    rule : {'simple', 'guarded'}
        Decision rule (:mod:`volcal.standards.decision`), as for the linear axes.
    guard_band_um : float, optional
        Guard band of the guarded rule (default U).

    Returns
    -------
    list of dict
        Per path: ``chain``, ``measurement``, ``path``, ``n_poses``, ``range_before_um``
        and ``range_after_um`` (X, Y, Z), ``U_um``, ``verdict_before`` and
        ``verdict_after`` (``'pass'``, ``'conditional'``, ``'fail'``) with their notes.
    """
    from volcal.standards.decision import conformity_verdict

    rows = []
    for lc in located:
        for p in lc.paths:
            vb, nb = conformity_verdict(p.before_um, tolerance_um, rule, p.U_um, guard_band_um)
            va, na = conformity_verdict(p.after_um, tolerance_um, rule, p.U_um, guard_band_um)
            rows.append({"chain": lc.chain, "measurement": p.measurement, "path": p.path,
                         "n_poses": p.n_poses,
                         "range_before_um": [float(v) for v in p.range_before_um],
                         "range_after_um": [float(v) for v in p.range_after_um],
                         "U_um": p.U_um, "tolerance_um": float(tolerance_um), "rule": rule,
                         "verdict_before": vb, "note_before": nb,
                         "verdict_after": va, "note_after": na})
    return rows


def location_results(located: list[LocatedChain]
                     ) -> list[tuple[str, float | None, float | None, str]]:
    """The determined location errors as named results ``name, value, U, unit``.

    The names are ISO 230-1's (``EX0C``; :mod:`volcal.model.names`); a second chain of
    the session prefixes its own (``FXYZCA.EX0C``). Errors held at zero (redundant) are
    not results. The RMS scatter before and after is stored as ``<chain>.scatter_before``
    and ``<chain>.scatter_after`` [um] (no U).

    Parameters
    ----------
    located : list of LocatedChain
        :func:`locate_session`'s result.
    """
    rows: list[tuple[str, float | None, float | None, str]] = []
    for i, lc in enumerate(located):
        prefix = "" if i == 0 else f"{lc.chain}."
        for r in lc.location_rows():
            if r["value"] is not None:
                rows.append((prefix + r["name"], float(r["value"]) + 0.0, float(r["U"]),
                             str(r["unit"])))
        rows.append((f"{lc.chain}.scatter_before", float(lc.result.rms_before_um), None, "um"))
        rows.append((f"{lc.chain}.scatter_after", float(lc.result.rms_after_um), None, "um"))
    return rows
