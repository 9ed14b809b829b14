"""ISO 230-2 for rotary axes: the positioning parameters of one rotary axis [urad].

ISO 230-2 "applies equally to linear and rotary axes" (ISO 230-2:2014, scope): the
definitions of :mod:`volcal.standards.iso230_2` (A, A per direction, E, M, R, B, B mean,
the per-target statistics) are applied to the angular deviations ``x_ij`` = actual -
commanded angle [urad] at the commanded angles [deg]. Every parameter is an angle
[urad]; ``units='arcsec'`` gives them in arcseconds (1 arcsec = pi/648000 rad =
4.8481368 urad). The sign: positive counter-clockwise looking from the positive end of
the axis towards the origin (ISO 841, ``docs/conventions.md``).

**Full-circle closure.** On a full-circle (modulo 360) axis 0 and 360 deg are one
physical position. The standard test cycle reads it at both ends of each pass (0 at the
start of the up pass and the end of the down pass, 360 at the end of the up pass and the
start of the down pass), so both stay targets of the evaluation, each with its own
statistics, exactly as commanded. Their difference, per direction, is the *closure*
(``closure_urad``: mean deviation at 360 minus at 0): the axis is back where it started,
so a closure beyond the repeatability says the readings drifted or the calibrator lost
count during the run, and a warning says so. Any pair of targets equal modulo 360 is
treated the same way.

**Uncertainty** (``--budget``, section ``[angular]``, ``docs/uncertainty.md``): each
per-target mean carries its type A (``s / sqrt(n)``), the calibrator's accuracy
(``u_calibrator_urad``, Renishaw XR20: +-1 arcsec, data sheet / white paper TE327; or, for
the target ``index_table``, ``u_index_table_urad``, Keysight 5530 360-tooth precision index
table: +-0.5 arcsec, Measurements Reference Guide chapter 4) and the eccentric mounting
(``u_eccentricity_urad_per_mm`` times the test's ``eccentricity_mm``: TE327, a 1 mm
eccentric mounting adds under +-0.5 arcsec). Those two are independent between targets
(they depend on the angle) and zero at the datum (the first target, where the
calibrator was zeroed); targets equal modulo 360 share them. The repeatability
parameters use the statistics of ``s`` (GUM E.4.3), as for linear axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.session.rotary import ARCSEC_URAD
from volcal.standards.iso230_2 import AXIS_KEYS, EDITIONS, Iso2302Result, evaluate
from volcal.standards.iso230_2_uncertainty import parameter_expressions

__all__ = ["UNITS", "RotaryIso2302Result", "RotaryUncertainty", "evaluate_rotary",
           "evaluate_rotary_measurement", "is_rotary_csv", "read_rotary_file",
           "rotary_uncertainty"]

UNITS: dict[str, float] = {"urad": 1.0, "arcsec": 1.0 / ARCSEC_URAD}
"""Output units of the rotary parameters and the factor from urad."""


@dataclass
class RotaryUncertainty:
    """Expanded uncertainty of a rotary ISO 230-2 evaluation [urad].

    Attributes
    ----------
    parameters : dict of str to Estimate
        ``A, A_up, ..., B_mean`` [urad].
    targets : list of Estimate
        Mean bidirectional deviation of each target [urad].
    notes : list of str
        What was assumed (budget defaults, instrument).
    """

    parameters: dict[str, Any]
    targets: list[Any]
    notes: list[str] = field(default_factory=list)


@dataclass
class RotaryIso2302Result:
    """ISO 230-2 evaluation of one rotary axis.

    Attributes
    ----------
    iso : Iso2302Result
        The parameters in urad; its per-target ``target_mm`` holds the commanded angles
        [deg].
    axis : str
        ``'A'``, ``'B'``, ``'C'`` or ``'?'``.
    modulo : bool
        A full-circle axis (closure evaluated).
    closure_urad : dict
        ``{'up': .., 'down': .., 'targets_deg': [a, b]}``: mean deviation at the later of
        two targets equal modulo 360 minus at the earlier, per direction [urad]; empty
        when the test has no such pair.
    warnings : list of str
        Test-cycle remarks (runs, targets, spacing, closure).
    uncertainty : RotaryUncertainty or None
        With a budget.
    file : str
        Source, for the output.
    """

    iso: Iso2302Result
    axis: str = "?"
    modulo: bool = True
    closure_urad: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    uncertainty: RotaryUncertainty | None = None
    file: str = ""

    def __getattr__(self, name: str) -> Any:
        """The parameters of :attr:`iso` (``res.A`` [urad])."""
        if name in AXIS_KEYS or name in ("targets", "edition", "missing", "notes",
                                         "complete"):
            return getattr(self.__dict__["iso"], name)
        raise AttributeError(name)

    def value(self, key: str, units: str = "urad") -> float:
        """A parameter in ``units`` (``'urad'`` or ``'arcsec'``).

        Parameters
        ----------
        key : str
            One of ``A, A_up, ..., B_mean``.
        units : str
            Output unit.
        """
        return float(getattr(self.iso, key)) * UNITS[units]

    def to_dict(self, units: str = "urad") -> dict[str, Any]:
        """JSON-friendly: the keys of the linear evaluation plus ``unit`` and the axis.

        Parameters
        ----------
        units : str
            ``'urad'`` (default) or ``'arcsec'``: every angle of the output.

        Returns
        -------
        dict
            ``A ... B_mean``, ``targets`` (rows with ``target_deg``; ``target_mm`` is
            null: a rotary target is an angle), ``n_runs_up``, ``n_runs_down``,
            ``edition``, ``warnings``, ``complete``, ``missing``, ``notes``, ``unit``,
            ``kind`` (``'rotary'``), ``axis``, ``modulo``, ``closure``; with a budget
            ``U_<key>``, ``k``, ``uncertainty`` and per target ``U_<unit>``, ``u_<unit>``.
        """
        f = UNITS[check_units(units)]
        d = self.iso.to_dict()
        for k in AXIS_KEYS:
            d[k] = d[k] * f
        rows = []
        for row in d["targets"]:
            new: dict[str, Any] = {"target_deg": row["target_mm"], "target_mm": None}
            for k, v in row.items():
                if k in ("target_mm",):
                    continue
                new[k] = v * f if isinstance(v, float) and not k.startswith("n") else v
            rows.append(new)
        d["targets"] = rows
        d["missing"] = [{"run": m.run, "target_deg": m.target_mm, "direction": m.direction}
                        for m in self.iso.missing]
        d["warnings"] = list(self.warnings)
        d["unit"] = units
        d["kind"] = "rotary"
        d["axis"] = self.axis
        d["modulo"] = self.modulo
        d["closure"] = ({} if not self.closure_urad else
                        {"targets_deg": self.closure_urad["targets_deg"],
                         "up": _scaled(self.closure_urad["up"], f),
                         "down": _scaled(self.closure_urad["down"], f)})
        if self.uncertainty is not None:
            u = self.uncertainty
            for k, e in u.parameters.items():
                d[f"U_{k}"] = e.U * f
            d["k"] = u.parameters["A"].k
            d["uncertainty"] = {
                "coverage_pct": 95.45,
                "parameters": {k: {"u": e.u * f, "U": e.U * f, "k": e.k,
                                   "dof": None if not math.isfinite(e.dof) else e.dof,
                                   "components": [c.to_dict() for c in e.components]}
                               for k, e in u.parameters.items()},
                "notes": list(u.notes)}
            for row, e in zip(d["targets"], u.targets, strict=True):
                row[f"U_{units}"] = e.U * f
                row[f"u_{units}"] = e.u * f
                row["k"] = e.k
        return d


def _scaled(v: Any, f: float) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v) * f


def check_units(units: str) -> str:
    """Check an output unit of angles (``'urad'`` or ``'arcsec'``).

    Parameters
    ----------
    units : str
        The unit asked for.

    Returns
    -------
    str
    """
    if units not in UNITS:
        raise VolcalInputError(f"--units {units!r}: expected urad or arcsec", column="units")
    return units


def _closure(targets: NDArray[np.float64], mu: NDArray[np.float64], md: NDArray[np.float64],
             modulo: bool) -> dict[str, Any]:
    if not modulo:
        return {}
    for i in range(targets.size):
        for j in range(i + 1, targets.size):
            if abs(((targets[j] - targets[i]) + 180.0) % 360.0 - 180.0) < 1e-6:
                return {"targets_deg": [float(targets[i]), float(targets[j])],
                        "up": float(mu[j] - mu[i]), "down": float(md[j] - md[i])}
    return {}


def _cycle_warnings(targets: NDArray[np.float64], n_up: int, n_down: int) -> list[str]:
    """ISO 230-2 test-cycle remarks for a rotary axis."""
    w: list[str] = []
    if min(n_up, n_down) < 5:
        w.append(f"only {n_up} run(s) up and {n_down} down: ISO 230-2 asks for 5 runs in "
                 "each direction")
    if targets.size < 5:
        w.append(f"{targets.size} target angles: ISO 230-2 asks for at least five")
    inner = targets[1:-1]
    if inner.size >= 2 and np.all(np.abs(inner / 5.0 - np.round(inner / 5.0)) < 1e-9):
        w.append("every target is a multiple of 5 deg: a periodic error of the encoder or "
                 "worm gear whose period divides the step is sampled at one phase only; "
                 "ISO 230-2 recommends unequal spacing")
    elif targets.size >= 3 and np.ptp(np.diff(targets)) <= 1e-6 * float(np.mean(np.diff(targets))):
        w.append("targets are equally spaced: ISO 230-2 recommends unequal spacing so that "
                 "periodic errors are sampled at different phases")
    return w


def evaluate_rotary(target_deg: ArrayLike, run: ArrayLike, direction: ArrayLike,
                    deviation_urad: ArrayLike, edition: str = "2014", *, axis: str = "?",
                    modulo: bool = True, file: str | None = None,
                    rows: ArrayLike | None = None, allow_incomplete: bool = False
                    ) -> RotaryIso2302Result:
    """Evaluate a bidirectional positioning test of a rotary axis to ISO 230-2.

    Parameters
    ----------
    target_deg : array_like, shape (n,)
        Commanded angle of each reading [deg].
    run : array_like of int, shape (n,)
        Run number of each reading.
    direction : array_like of str, shape (n,)
        ``'+'`` approached turning positive, ``'-'`` negative.
    deviation_urad : array_like, shape (n,)
        Actual - commanded angle [urad].
    edition : str
        ISO 230-2 edition.
    axis : str
        ``'A'``, ``'B'``, ``'C'`` (for the output).
    modulo : bool
        Full-circle axis: targets equal modulo 360 are one position (closure).
    file : str, optional
        Source file named in errors.
    rows : array_like of int, optional
        Row of each reading in ``file``.
    allow_incomplete : bool
        Evaluate runs with missed captures per target (see :mod:`volcal.standards.iso230_2`).

    Returns
    -------
    RotaryIso2302Result
        Parameters A ... B_mean [urad], the per-target table, the closure.

    References
    ----------
    ISO 230-2:2014, clause 3 (definitions, "linear and rotary axes"), 5.3 (test cycle).
    """
    res = evaluate(target_deg, run, direction, deviation_urad, edition, file=file, rows=rows,
                   allow_incomplete=allow_incomplete, target_column="target_deg")
    res.notes = [n.replace(" mm ", " deg ") for n in res.notes]
    t = res.targets
    closure = _closure(t.target_mm, t.mean_up, t.mean_down, modulo)
    warn = _cycle_warnings(t.target_mm, t.n_up, t.n_down)
    if closure:
        big = max(abs(closure["up"]), abs(closure["down"]))
        if np.isfinite(big) and big > max(float(res.R), 1e-9):
            warn.append(f"closure {big:.3g} urad between {closure['targets_deg'][0]:g} and "
                        f"{closure['targets_deg'][1]:g} deg (one physical position) exceeds "
                        f"the repeatability R = {res.R:.3g} urad: drift or a lost count "
                        "during the test?")
    return RotaryIso2302Result(res, axis.upper(), modulo, closure, warn, None, file or "")


def rotary_uncertainty(res: RotaryIso2302Result, budget: Any, target: str = "rotary_calibrator",
                       eccentricity_mm: float = 0.0) -> RotaryUncertainty:
    """Expanded uncertainty of every rotary ISO 230-2 parameter (module docstring).

    Parameters
    ----------
    res : RotaryIso2302Result
        The evaluation.
    budget : Budget
        With the ``[angular]`` section (defaults: the data sheets).
    target : str
        ``'rotary_calibrator'`` or ``'index_table'``: which instrument term applies.
    eccentricity_mm : float
        Eccentricity of an off-axis mounting [mm] (0: on axis).

    Returns
    -------
    RotaryUncertainty
    """
    from volcal.uncertainty.propagation import Propagator

    t = res.iso.targets
    m = t.target_mm.size
    ke = EDITIONS[res.iso.edition]
    prop = Propagator()
    nu, nd = t.counts()
    inst_key = ("angular.u_index_table_urad" if target == "index_table"
                else "angular.u_calibrator_urad")
    inst = budget.inputs[inst_key]
    ecc = budget.inputs["angular.u_eccentricity_urad_per_mm"]
    notes = [n for n in budget.notes]
    used = [k for k in (inst_key, "angular.u_eccentricity_urad_per_mm")
            if k in budget.defaulted]
    if used:
        notes.append(f"[angular] {', '.join(k.split('.')[1] for k in used)} not in the budget: "
                     "the data-sheet defaults are used (docs/uncertainty.md)")
    datum = float(t.target_mm[0])
    systematic: dict[float, Any] = {}

    def angle_terms(a: float) -> Any:
        key = round(a % 360.0, 6) if res.modulo else round(a, 6)
        same = (abs(((a - datum) + 180.0) % 360.0 - 180.0) < 1e-9 if res.modulo
                else abs(a - datum) < 1e-9)
        if same:
            return 0.0  # the calibrator was zeroed there
        if key not in systematic:
            x = prop.input(f"{inst_key.split('.')[1]} at {a:g} deg", 0.0, inst.u, inst.dof,
                           inst.distribution, unit="urad")
            if eccentricity_mm > 0:
                x = x + prop.input(f"eccentric mounting at {a:g} deg", 0.0,
                                   ecc.u * eccentricity_mm, ecc.dof, ecc.distribution,
                                   unit="urad")
            systematic[key] = x
        return systematic[key]

    def mean(label: str, x: float, s: float, n: int) -> Any:
        if not (math.isfinite(s) and n >= 2):
            return prop.input(f"repeatability ({label})", x, 0.0)
        return prop.input(f"repeatability ({label})", x, s / math.sqrt(n), n - 1.0,
                          unit="urad")

    def sdev(label: str, s: float, n: int) -> Any:
        if not (math.isfinite(s) and n >= 2):
            return prop.input(f"standard deviation s ({label})", 0.0, 0.0)
        return prop.input(f"standard deviation s ({label})", s,
                          s / math.sqrt(2.0 * (n - 1.0)), n - 1.0, unit="urad")

    mu, md, su, sd = [], [], [], []
    for i in range(m):
        sys_i = angle_terms(float(t.target_mm[i]))
        mu.append(mean("+", t.mean_up[i], t.s_up[i], int(nu[i])) + sys_i)
        md.append(mean("-", t.mean_down[i], t.s_down[i], int(nd[i])) + sys_i)
        su.append(sdev("+", t.s_up[i], int(nu[i])))
        sd.append(sdev("-", t.s_down[i], int(nd[i])))
    mid = [(a + b) / 2 for a, b in zip(mu, md, strict=True)]

    expr = parameter_expressions(mu, md, su, sd, ke, np.nanargmax, np.nanargmin)
    params = {k: prop.estimate(expr[k]) for k in AXIS_KEYS}
    notes.append(f"datum (calibrator zeroed) at {datum:g} deg; instrument term "
                 f"{inst_key.split('.')[1]} = {inst.u:.3g} urad"
                 + (f", eccentric mounting {eccentricity_mm:g} mm" if eccentricity_mm else ""))
    return RotaryUncertainty(params, [prop.estimate(v) for v in mid], notes)


# ----------------------------------------------------------------------------- files

def is_rotary_csv(path: str | Path) -> bool:
    """Whether a CSV is a rotary test: its header has ``target_deg``.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    bool
    """
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as fh:
            for line in fh:
                if line.strip() and not line.lstrip().startswith("#"):
                    cells = [c.strip().strip('"').lower()
                             for c in line.replace(";", ",").replace("\t", ",").split(",")]
                    return "target_deg" in cells
    except OSError:
        return False
    return False


def read_rotary_file(path: str | Path) -> tuple[Any, list[str]]:
    """A rotary CSV (``target_deg, run, direction, deviation_urad|deviation_arcsec``).

    Parameters
    ----------
    path : str or Path
        The file (a session's rotary CSV or a bare one).

    Returns
    -------
    rows : RotaryRows
        Missed captures dropped.
    notes : list of str
        The missed captures skipped.
    """
    from volcal.session.rotary import read_rotary_csv

    r = read_rotary_csv(path)
    if r.deviation_urad is None:
        raise VolcalInputError("no readings: the deviation column is empty", path, None,
                               "deviation_urad")
    for c in ("run", "direction"):
        if c not in r.columns:
            raise VolcalInputError(f"missing column {c}: ISO 230-2 needs the run and the "
                                   "approach direction of every reading", path, None, c)
    notes = []
    if r.missed.any():
        rows = ", ".join(str(int(v)) for v in r.rows[r.missed])
        notes.append(f"{Path(path).name}: missed captures skipped (rows {rows})")
    return r, notes


PLAUSIBLE_URAD = 2000.0
"""Largest plausible angular positioning error of a rotary axis [urad] (about 410 arcsec):
a larger reading is more likely an angle in another unit (mrad, arcsec typed as urad)."""


def rotary_plausibility(deviation_urad: ArrayLike, file: str = "") -> list[str]:
    """Warnings about implausible rotary readings (``plausibility`` of the JSON output).

    Parameters
    ----------
    deviation_urad : array_like
        The readings [urad].
    file : str
        Their file, named in the warnings.

    Returns
    -------
    list of str
    """
    d = np.asarray(deviation_urad, dtype=float)
    d = d[np.isfinite(d)]
    name = Path(file).name if file else "the readings"
    out = []
    if d.size and float(np.max(np.abs(d))) > PLAUSIBLE_URAD:
        out.append(f"{name}: a deviation of {float(np.max(np.abs(d))):.4g} urad "
                   f"(> {PLAUSIBLE_URAD:g} urad, {PLAUSIBLE_URAD / ARCSEC_URAD:.0f} arcsec): "
                   "readings in another unit (mrad, or arcsec written as urad)?")
    return out


def evaluate_rotary_file(path: str | Path, edition: str = "2014", budget: Any = None,
                         axis: str = "?", modulo: bool | None = None
                         ) -> tuple[RotaryIso2302Result, list[str]]:
    """Evaluate a rotary CSV file (``volcal evaluate iso230-2 FILE``).

    Parameters
    ----------
    path : str or Path
        The CSV.
    edition : str
        ISO 230-2 edition.
    budget : Budget, optional
        For U (the ``[angular]`` section).
    axis : str
        Axis name for the output.
    modulo : bool, optional
        Full circle; default: the targets span 360 deg.

    Returns
    -------
    result : RotaryIso2302Result
    notes : list of str
    """
    r, notes = read_rotary_file(path)
    keep = ~r.missed
    t = r.target_deg[keep]
    if modulo is None:
        modulo = bool(np.ptp(t) >= 360.0 - 1e-9)
    res = evaluate_rotary(t, r.columns["run"][keep], r.columns["direction"][keep],
                          r.deviation_urad[keep], edition, axis=axis, modulo=modulo,
                          file=str(path), rows=r.rows[keep],
                          allow_incomplete=bool(r.missed.any()))
    if budget is not None:
        res.uncertainty = rotary_uncertainty(res, budget)
    return res, notes


def evaluate_rotary_measurement(m: Any, edition: str = "2014", budget: Any = None,
                                file: str | None = None) -> RotaryIso2302Result:
    """Evaluate a session's ``rotary`` measurement.

    Parameters
    ----------
    m : Measurement
        With readings, ``target_deg``, ``run``, ``direction``.
    edition : str
        ISO 230-2 edition.
    budget : Budget, optional
        For U.
    file : str, optional
        Its CSV, for messages.

    Returns
    -------
    RotaryIso2302Result
    """
    if m.deviation is None:
        raise VolcalInputError(f"{m.id}: no readings yet", file or m.file)
    for c in ("run", "direction"):
        if c not in m.columns:
            raise VolcalInputError(f"missing column {c}: ISO 230-2 needs the run and the "
                                   "approach direction of every reading", file or m.file,
                                   None, c)
    res = evaluate_rotary(m.columns["target_deg"], m.columns["run"], m.columns["direction"],
                          m.deviation, edition, axis=m.meta.get("axis", "?"),
                          modulo=bool(m.meta.get("modulo", True)), file=file or m.file,
                          rows=m.rows, allow_incomplete=bool(m.meta.get("_missed")))
    if budget is not None:
        res.uncertainty = rotary_uncertainty(res, budget, m.target,
                                             float(m.meta.get("eccentricity_mm", 0.0)))
    return res
