"""Step ``identify``: the machine's errors from a session (``volcal identify``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from volcal import defaults as D
from volcal.errors import ParameterError
from volcal.steps import _checks

if TYPE_CHECKING:
    from volcal.identify import EstimatorSettings, IdentifyOptions
    from volcal.identify.between_share import BetweenShare
    from volcal.identify.result import IdentificationResult
    from volcal.session.format import Session
    from volcal.uncertainty.budget import Budget

__all__ = ["Identified", "MonteCarloSummary", "SystematicSummary", "identify",
           "identify_options"]

MONTE_CARLO_NOTE = ("noise part only (readings redrawn, same hyperparameters); the "
                    "analytic uncertainty adds the prior part")
OPTICS_DEFAULTED_NOTE = ("no [optics] scale keys in the budget file: the direct optics' "
                         "scale errors are the data-sheet defaults (volcal budget --template)")


@dataclass(frozen=True)
class MonteCarloSummary:
    """The Monte Carlo (GUM S1) propagation of the noise to the volumetric error.

    Attributes
    ----------
    trials : int
    points : int
        Points of the measured grid.
    max_std_um, rms_std_um : float
        Largest and RMS standard deviation over the grid [um].
    max_95_half_width_um : float
        Largest half-width of the 95 % interval [um].
    note : str
    """

    trials: int
    points: int
    max_std_um: float
    rms_std_um: float
    max_95_half_width_um: float
    note: str = MONTE_CARLO_NOTE

    def to_dict(self) -> dict[str, object]:
        """The model file's ``fit.monte_carlo``."""
        return {"trials": self.trials, "points": self.points, "max_std_um": self.max_std_um,
                "rms_std_um": self.rms_std_um,
                "max_95_half_width_um": self.max_95_half_width_um, "note": self.note}


@dataclass(frozen=True)
class SystematicSummary:
    """Largest standard uncertainty of the volumetric error over the measured grid [um].

    Attributes
    ----------
    noise_um : float
        Noise and prior part.
    systematic_um : float
        Systematic part (the budget's inputs).
    total_um : float
        Both.
    n_inputs : int
        Systematic inputs of the budget.
    budget : str
        The budget file as given.
    """

    noise_um: float
    systematic_um: float
    total_um: float
    n_inputs: int
    budget: str


@dataclass(frozen=True)
class Identified:
    """What :func:`identify` found.

    Attributes
    ----------
    result : IdentificationResult
        The model (``fit.monte_carlo`` holds the Monte Carlo summary when computed).
    session : Session
        The session identified from (its ``notes`` and ``warnings``).
    monte_carlo : MonteCarloSummary or None
    systematic : SystematicSummary or None
        With a budget.
    notes : tuple of str
        What the user should know beyond the report's messages.
    """

    result: IdentificationResult
    session: Session
    monte_carlo: MonteCarloSummary | None = None
    systematic: SystematicSummary | None = None
    notes: tuple[str, ...] = ()

    @cached_property
    def between(self) -> BetweenShare | None:
        """The volumetric uncertainty with and without the part between the readings.

        :func:`volcal.identify.between_share.between_share` of the result, computed when
        asked (``volcal identify`` prints it; ``Calibration.identify`` does not need it);
        None without that part.
        """
        from volcal.identify.between_share import between_share

        return between_share(self.result)

    @property
    def messages(self) -> list[str]:
        """The identifiability report's messages, in plain words."""
        return list(self.result.report.messages)


def identify(session: Session | str | Path, *, prior: str = D.PRIOR,
             noise_um: float | None = None, roll: str = D.ROLL,
             known: str | Path | Mapping[str, Sequence[object]] | None = None,
             known_u: float | None = None, monte_carlo: int = D.MONTE_CARLO,
             drift: bool = False, measurements: str | Sequence[str] | None = None,
             max_nodes: int = D.MAX_NODES, robust: bool = False,
             budget: str | Path | Budget | None = None,
             settings: EstimatorSettings | str | Path | None = None,
             **options: Any) -> Identified:
    """Identify the machine's errors with their uncertainties.

    Parameters
    ----------
    session : Session, str or Path
        The measured session, or its folder.
    prior : str
        ``'smooth'`` (Bayesian) or ``'none'`` (minimum-norm least squares).
    noise_um : float, optional
        Stated repeatability [um]; default: estimated.
    roll : str
        ``'estimate'`` or ``'zero'`` (the rolls EAX, EBY, ECZ fixed to zero).
    known : str, Path or dict, optional
        Errors measured separately, held fixed: the path of a CSV (axis, position_mm and
        any of EX_um..EC_urad, or a full error table), or a dict name -> ``(positions
        [mm], values)`` or ``(positions, values, u)``.
    known_u : float, optional
        Standard uncertainty of the ``known`` file's functions [um or urad]: priors
        instead of fixed.
    monte_carlo : int
        Monte Carlo trials (GUM S1) of the noise propagation; 0 = off.
    drift : bool
        Estimate a linear drift per measurement.
    measurements : sequence of str, or str, optional
        Ids of the measurements to use (comma-separated text or a list).
    max_nodes : int
        Nodes per axis at most (3..2001).
    robust : bool
        Down-weight the readings the outlier check flags and fit again.
    budget : str, Path or Budget, optional
        Uncertainty budget: its systematic inputs propagated through the fit, kept apart.
    settings : EstimatorSettings, str or Path, optional
        The estimator's settings, or the path of an estimator settings file (TOML, as
        ``--estimator-settings``; :mod:`volcal.identify.settings_file`); default volcal's.
    **options
        Other fields of :class:`volcal.identify.IdentifyOptions` (``scales``, ``kappa``,
        ``zero``, ``tilts``...; ``measurement_ids`` is ``measurements``).

    Returns
    -------
    Identified

    Raises
    ------
    ParameterError
        A parameter of a wrong value, named.
    """
    from volcal.identify import identify as run

    opts, known_file = identify_options(("known_u", "monte_carlo", "budget"), prior=prior,
                                        noise_um=noise_um, roll=roll, known=known,
                                        known_u=known_u, drift=drift,
                                        measurements=measurements, max_nodes=max_nodes,
                                        robust=robust, settings=settings, **options)
    trials = _checks.whole("monte_carlo", monte_carlo)
    if trials < 0:
        raise ParameterError(f"{{monte_carlo=}}{monte_carlo}: expected 0 (off) or more "
                             "trials")
    b = None if budget is None else _checks.budget(budget)
    s = _session(session, require_deviation=True)
    ids = opts.measurement_ids
    if ids is not None:
        have = {m.id for m in s.measurements}
        missing = [i for i in ids if i not in have]
        if missing:
            raise ParameterError(f"{{measurements}}: no measurement {', '.join(missing)} in "
                                 f"the session (it has {', '.join(sorted(have))})",
                                 s.path / "session.toml" if s.path else None)
    if known_file is not None:
        opts = _read_known(opts, known_file, known_u)
    res = run(s, opts)
    mc = None if trials == 0 else _monte_carlo(res, trials)
    sys_summary, notes = None, []
    if b is not None:
        from volcal.identify.systematic import attach_systematic

        attach_systematic(res, b[0], b[1])
        sys_summary = _systematic(res, b[1])
        if (any(k.endswith("_scale_pct") for k in b[0].defaulted)
                and any(lab.startswith("optics scale") for lab in res.sys_labels)):
            notes.append(OPTICS_DEFAULTED_NOTE)
    return Identified(res, s, mc, sys_summary, tuple(notes))


def identify_options(also: Sequence[str] = ("known_u",), **values: Any
                     ) -> tuple[IdentifyOptions, str | Path | None]:
    """:class:`~volcal.identify.IdentifyOptions` from keywords, every one checked.

    Parameters
    ----------
    also : sequence of str
        The step's other keywords, listed with the valid options of an unknown one.
    **values
        Fields of IdentifyOptions; ``measurements`` (or ``measurement_ids``), ``known``
        as a dict or a path (read by :func:`identify`), ``known_u``; ``settings`` an
        :class:`~volcal.identify.EstimatorSettings` or the path of an estimator settings
        file (TOML, :func:`volcal.identify.settings_file.read_estimator_settings`).

    Returns
    -------
    options : IdentifyOptions
        Without the functions of a ``known`` file.
    known_file : str, Path or None
        The ``known`` file, read by :func:`identify` once the session is checked.
    """
    from volcal.identify import IdentifyOptions

    valid = [f.name for f in fields(IdentifyOptions)]
    given = {k: v for k, v in values.items() if not (k in ("known", "known_u", "measurements",
                                                            "settings") and v is None)}
    if "measurement_ids" in given and "measurements" in given:
        raise ParameterError("give {measurements} or measurement_ids, not both")
    if "measurements" in given:
        given["measurement_ids"] = given.pop("measurements")
    known_u = given.pop("known_u", None)
    if isinstance(given.get("settings"), str | Path):  # an estimator settings file (TOML)
        from volcal.identify.settings_file import read_estimator_settings

        given["settings"] = read_estimator_settings(cast(str | Path, given["settings"]))
    for key in given:
        if key not in valid:
            raise _checks.unknown(key, [*(v if v != "measurement_ids" else "measurements"
                                          for v in valid), *also])
    _checks.kinds(given, {f.name: f.default for f in fields(IdentifyOptions)})
    noise = given.get("noise_um")
    if noise is not None and not (isinstance(noise, int | float) and np.isfinite(noise)
                                  and noise > 0):
        raise ParameterError(f"{{noise_um=}}{noise}: expected a positive repeatability [um]")
    known = given.get("known")
    if known_u is not None and known is None:
        raise ParameterError("{known_u} needs {known} (the error table it applies to)")
    if known_u is not None and not (isinstance(known_u, int | float) and np.isfinite(known_u)
                                    and known_u > 0):
        raise ParameterError(f"{{known_u=}}{known_u}: expected a positive uncertainty")
    ids = given.get("measurement_ids")
    if ids is not None:
        raw = ids
        ids = _checks.names("measurements", ids)
        if not ids:
            raise ParameterError(f"{{measurements=}}{raw!r}: no measurement id given")
        given["measurement_ids"] = ids
    n = given.get("max_nodes", D.MAX_NODES)
    if not 3 <= int(n) <= 2001:
        raise ParameterError(f"{{max_nodes=}}{n}: expected 3..2001")
    if isinstance(known, Mapping):
        if known_u is not None:
            raise ParameterError("{known_u} applies to the error table of a {known} file; in "
                                 "a dict give (positions, values, u)")
        given["known"] = _known_dict(known)
    elif known is not None and not isinstance(known, str | Path):
        raise ParameterError(f"{{known=}}{known!r}: expected a dict name -> (positions [mm], "
                             "values) or the path of an error table")
    known_file = None
    if isinstance(known, str | Path):
        known_file = known
        del given["known"]
    try:
        return IdentifyOptions(**given), known_file
    except TypeError as exc:
        raise ParameterError(f"{exc}; valid options: {', '.join(valid)}") from None


def _read_known(opts: IdentifyOptions, path: str | Path, u: float | None) -> IdentifyOptions:
    """The options with the functions of a ``known`` file (axis, position_mm, EX_um...)."""
    from dataclasses import replace

    from volcal.session.errortable import read_known_functions

    out = {n: (p, v) if u is None else (p, v, u)
           for n, (p, v) in read_known_functions(path).items()}
    return replace(opts, known=out)


def _known_dict(known: Mapping[str, Sequence[object]]) -> dict[str, tuple[object, ...]]:
    """Check a ``known`` dict: ISO 230-1 names -> (positions, values[, u])."""
    from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

    error_names = (*COMPONENT_NAMES, *SQUARENESS_NAMES)
    out: dict[str, tuple[object, ...]] = {}
    for name, v in known.items():
        key = str(name).upper()
        if key not in error_names:
            raise ParameterError(f"{{known}}[{name!r}]: not an error name; expected one of "
                                 f"{', '.join(error_names)}")
        if not isinstance(v, tuple | list) or len(v) not in (2, 3):
            raise ParameterError(f"{{known}}[{name!r}]: expected (positions [mm], values [um "
                                 "or urad]) or (positions, values, u)")
        out[key] = tuple(v)
    return out


def _session(session: Session | str | Path, require_deviation: bool) -> Session:
    """The session, read from its folder when given a path."""
    if isinstance(session, str | Path):
        from volcal.session.format import read_session

        return read_session(session, require_deviation=require_deviation)
    return session


def _monte_carlo(res: IdentificationResult, trials: int) -> MonteCarloSummary:
    """The Monte Carlo summary over the measured grid, kept in ``res.fit``."""
    from volcal.identify import monte_carlo as mc
    from volcal.identify.identifiability import grid_points

    q = grid_points(res.design)
    _, sd, lo, hi = mc(res, q, trials)
    out = MonteCarloSummary(trials, int(q.shape[0]), float(sd.max()),
                            float(np.sqrt(np.mean(sd**2))), float(((hi - lo) / 2).max()))
    res.fit["monte_carlo"] = out.to_dict()
    return out


def _systematic(res: IdentificationResult, label: str) -> SystematicSummary:
    """The largest u of the volumetric error over the measured grid, by part."""
    from volcal.identify.identifiability import grid_points

    q = grid_points(res.design)
    un = res.predict(q, systematic=False)[1]
    ut = res.predict(q)[1]
    us = np.sqrt(np.maximum(ut**2 - un**2, 0.0))
    return SystematicSummary(float(un.max()), float(us.max()), float(ut.max()),
                             len(res.sys_labels), label)
