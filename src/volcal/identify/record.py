"""Typed records of an identification: fit statistics, convergence, session identity.

:class:`FitRecord` replaces the untyped ``fit`` dictionary of the model file (it still
answers ``fit["sigma_um"]`` for older code); :class:`SessionIdentity` ties a model to
the session it was identified from (machine name, chain, travel and a SHA-256 hash of
the readings), so that ``report``, ``predict`` and ``compensate`` can refuse a model of
another machine (:func:`volcal.identify.modelfile.check_model_session`).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from volcal.errors import VolcalInputError

__all__ = ["Convergence", "FitRecord", "SessionIdentity", "readings_sha256", "session_identity"]


@dataclass
class Convergence:
    """How the optimiser of the hyperparameters ended.

    Attributes
    ----------
    optimiser : str
        Name of the optimiser (empty if none was run or it is not recorded).
    iterations, evaluations : int or None
        Iterations and objective evaluations.
    converged : bool or None
        Whether the optimiser reported success (``None``: not recorded).
    message : str
        The optimiser's own message.
    """

    optimiser: str = ""
    iterations: int | None = None
    evaluations: int | None = None
    converged: bool | None = None
    message: str = ""

    def __getitem__(self, key: str) -> Any:
        """``fit["convergence"]["converged"]``: dictionary-style access to a field."""
        if key not in ("optimiser", "iterations", "evaluations", "converged", "message"):
            raise KeyError(key)
        return getattr(self, key)

    def describe(self) -> str:
        """One plain line about the convergence."""
        if not self.optimiser and self.converged is None:
            return "optimiser convergence not recorded"
        state = {True: "converged", False: "did NOT converge", None: "ended"}[self.converged]
        n = "" if self.iterations is None else f" after {self.iterations} iterations"
        msg = f" ({self.message})" if self.message else ""
        return f"optimiser {self.optimiser or '?'} {state}{n}{msg}"

    @classmethod
    def from_dict(cls, d: Any) -> Convergence:
        """Build from a dictionary (unknown keys are ignored).

        Parameters
        ----------
        d : dict or None
            ``optimiser``, ``iterations``, ``evaluations``, ``converged``, ``message``.
        """
        if not isinstance(d, dict):
            return cls()
        it, ev, cv = d.get("iterations"), d.get("evaluations"), d.get("converged")
        return cls(str(d.get("optimiser", "") or ""),
                   int(it) if isinstance(it, (int, float)) and math.isfinite(it) else None,
                   int(ev) if isinstance(ev, (int, float)) and math.isfinite(ev) else None,
                   bool(cv) if cv is not None else None, str(d.get("message", "") or ""))


_NUM = ("sigma_um", "sigma_residual_um", "dof", "log_evidence")
_INT = ("n_readings", "n_parameters", "n_nuisance")


@dataclass
class FitRecord:
    """Fit statistics of an identification.

    Attributes
    ----------
    method : str
        ``'bayes'`` or ``'lsq'``...
    sigma_um : float or None
        Reading noise used by the estimator [um].
    sigma_residual_um : float or None
        RMS residual [um].
    dof : float or None
        Degrees of freedom of the residual.
    n_readings, n_parameters, n_nuisance : int
        Readings used, estimated error parameters, set-up (nuisance) parameters.
    log_evidence : float or None
        Log marginal likelihood of the hyperparameters.
    hyperparameters : dict
        Prior scales (positioning [um], straightness [um], angular [urad], kappa...).
    convergence : Convergence
        How the optimiser of the hyperparameters ended.
    measurements, known : list of str
        Measurement ids used; functions held fixed.
    gauge : str
        The gauge (which values are zero by convention).
    outliers : list of dict
        Readings whose standardised residual exceeds the threshold.
    notes : list of str
        Plain-word notes (e.g. what an older model file lacked).
    extra : dict
        Any other entry of the file's ``fit`` table (Monte Carlo summary...), kept as is.
    """

    method: str = ""
    sigma_um: float | None = None
    sigma_residual_um: float | None = None
    dof: float | None = None
    n_readings: int = 0
    n_parameters: int = 0
    n_nuisance: int = 0
    log_evidence: float | None = None
    hyperparameters: dict[str, Any] = field(default_factory=dict)
    convergence: Convergence = field(default_factory=Convergence)
    measurements: list[str] = field(default_factory=list)
    known: list[str] = field(default_factory=list)
    gauge: str = ""
    outliers: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)

    # dictionary-style access for code written against the old ``fit`` dict
    def __getitem__(self, key: str) -> Any:
        """``fit["sigma_um"]``: a field, or an entry of :attr:`extra`."""
        if key in self._names():
            return getattr(self, key)
        if key == "prior_scales":
            return self.hyperparameters
        return self.extra[key]

    def __setitem__(self, key: str, value: Any) -> None:
        """Set a field, or an entry of :attr:`extra`."""
        if key in self._names():
            setattr(self, key, value)
        else:
            self.extra[key] = value

    def __contains__(self, key: object) -> bool:
        """Whether a field or extra entry of that name exists."""
        return key in self._names() or key in self.extra

    def get(self, key: str, default: Any = None) -> Any:
        """Like :meth:`dict.get`.

        Parameters
        ----------
        key : str
            Field or extra entry.
        default : object
            Returned when absent.
        """
        try:
            return self[key]
        except KeyError:
            return default

    @classmethod
    def _names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (``outliers`` live at the top of the model file)."""
        d = asdict(self)
        d.pop("outliers")
        extra = d.pop("extra")
        for k in _NUM:
            v = d[k]
            d[k] = None if v is None or not math.isfinite(float(v)) else float(v)
        return {**extra, **d}

    @classmethod
    def from_dict(cls, d: dict[str, Any], source: str = "model") -> FitRecord:
        """Build from a model file's ``fit`` table or the estimator's dictionary.

        Parameters
        ----------
        d : dict
            ``method``, ``sigma_um`` [um], ``sigma_residual_um`` [um], ``dof``,
            ``n_readings``, ... ; ``prior_scales`` (format 1) is read as the
            hyperparameters. Missing entries take their defaults.
        source : str
            File name for error messages.

        Raises
        ------
        VolcalInputError
            If a number is not a number.
        """
        d = dict(d)
        kw: dict[str, Any] = {}
        try:
            for k in _NUM:
                v = d.pop(k, None)
                kw[k] = None if v is None else float(v)
            for k in _INT:
                v = d.pop(k, None)
                kw[k] = 0 if v is None else int(v)
        except (TypeError, ValueError):
            raise VolcalInputError(f"fit.{k}: expected a number, found {v!r}", source, None,
                                   f"fit.{k}") from None
        hyp = d.pop("hyperparameters", None)
        scales = d.pop("prior_scales", None)
        kw["hyperparameters"] = dict(hyp if isinstance(hyp, dict)
                                     else scales if isinstance(scales, dict) else {})
        kw["convergence"] = Convergence.from_dict(d.pop("convergence", None))
        kw["method"] = str(d.pop("method", "") or "")
        kw["gauge"] = str(d.pop("gauge", "") or "")
        for k in ("measurements", "known", "notes", "outliers"):
            v = d.pop(k, None)
            kw[k] = list(v) if isinstance(v, list) else []
        return cls(**kw, extra=d)


def readings_sha256(session: Any, legacy: bool = False) -> tuple[str, int]:
    """SHA-256 of a session's readings in a canonical order.

    Each measured reading contributes one line ``id,i,x,y,z,deviation`` (positions [mm]
    and deviation [um] as ``%.9g``), measurements sorted by id; ``i`` counts the
    measurement's readings from 0. Unmeasured readings (NaN: a missed capture kept by a
    reader that does not drop it) are left out and not counted, so a session gives the
    same hash whether its missed captures were dropped (``read_session``) or kept as NaN
    (``read_session(require_deviation=False)``). The hash is independent of CSV
    formatting, column order and measurement order in ``session.toml``, and changes with
    any reading.

    Parameters
    ----------
    session : Session
        The session.
    legacy : bool
        Number the readings by their index in the measurement, NaN included (what volcal
        before 2026-11 wrote for a session holding NaN readings; the same hash for a
        session without any). Only to recognise the models of those versions.

    Returns
    -------
    digest : str
        Hexadecimal SHA-256.
    n : int
        Readings hashed.
    """
    h = hashlib.sha256()
    n = 0
    for m in sorted(session.measurements, key=lambda m: m.id):
        if m.deviation is None:
            continue
        pos = np.asarray(m.positions, dtype=float).reshape(-1, 3)
        dev = np.asarray(m.deviation, dtype=float).reshape(-1)
        ok = np.flatnonzero(np.isfinite(dev))
        rows = np.column_stack([pos[ok], dev[ok]]).tolist()
        number = ok.tolist() if legacy else range(len(rows))
        line = m.id.replace("%", "%%") + ",%d,%.9g,%.9g,%.9g,%.9g\n"  # as f"{v:.9g}"
        h.update("".join([line % (i, *r) for i, r in zip(number, rows,
                                                          strict=True)]).encode())
        n += int(ok.size)
    return h.hexdigest(), n


@dataclass(frozen=True)
class SessionIdentity:
    """Identity of the session a model was identified from.

    Attributes
    ----------
    name : str
        Machine name.
    chain : str
        Kinematic chain code.
    travel_mm : tuple of 3 (min, max)
        Travel [mm].
    readings_sha256 : str
        :func:`readings_sha256` of the readings used.
    n_readings : int
        Readings hashed.
    measurements : tuple of str
        Measurement ids of the session.
    """

    name: str
    chain: str
    travel_mm: tuple[tuple[float, float], ...]
    readings_sha256: str
    n_readings: int = 0
    measurements: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {"name": self.name, "chain": self.chain,
                "travel_mm": [list(t) for t in self.travel_mm],
                "readings_sha256": self.readings_sha256, "n_readings": self.n_readings,
                "measurements": list(self.measurements)}

    @classmethod
    def from_dict(cls, d: Any, source: str = "model") -> SessionIdentity | None:
        """Read the ``session`` table of a model file (``None`` if absent).

        Parameters
        ----------
        d : dict or None
            ``name``, ``chain``, ``travel_mm`` [mm], ``readings_sha256``...
        source : str
            File name for error messages.
        """
        if d is None:
            return None
        try:
            tr = tuple((float(a), float(b)) for a, b in d["travel_mm"])
            if len(tr) != 3:
                raise ValueError("travel_mm")
            return cls(str(d["name"]), str(d["chain"]), tr, str(d["readings_sha256"]),
                       int(d.get("n_readings", 0)),
                       tuple(str(x) for x in d.get("measurements", [])))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise VolcalInputError(f"invalid 'session' section of the model ({exc})", source,
                                   None, "session") from None


def session_identity(session: Any) -> SessionIdentity:
    """The identity of a session: name, chain, travel and hash of its readings.

    Parameters
    ----------
    session : Session
        The session.

    Returns
    -------
    SessionIdentity
    """
    digest, n = readings_sha256(session)
    tr = np.asarray(session.travel, dtype=float).reshape(3, 2)
    return SessionIdentity(str(session.name), str(session.chain),
                           tuple((float(a), float(b)) for a, b in tr), digest, n,
                           tuple(m.id for m in session.measurements))
