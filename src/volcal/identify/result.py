"""The identified model: error functions with uncertainties, predictions, JSON file.

Schema ``volcal-model/2`` (``docs/identification.md``); ``volcal-model/1`` files (no
``session`` identity, untyped ``fit``) still load::

    {"format": "volcal-model/2", "name", "chain", "travel_mm": [[x0,x1],[y0,y1],[z0,z1]],
     "session": {"name", "chain", "travel_mm", "readings_sha256", "n_readings",
                 "measurements"},
     "functions": {"X": {"position_mm": [...], "EXX_um": [...], "u_EXX_um": [...], ...,
                         "EAX_urad": [...], "u_EAX_urad": [...], ...}, "Y": ..., "Z": ...},
     "squareness_urad": {"EC0Y": v, ...}, "u_squareness_urad": {...},
     "covariance": {"free_index": [...], "factor": [[...], ...]},
     "systematic": {"inputs": [...], "factor": [[...], ...], "budget": "..."},  (optional)
     "identifiability": {...}, "fit": {...}, "nuisances": {...}, "outliers": [...],
     "readings": {"<measurement id>": {"fitted_um": [...], "residual_um": [...]}}}
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.identify.record import Convergence, FitRecord, SessionIdentity
from volcal.io.atomic import write_text
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import pose_jacobian
from volcal.model.names import AXES, COMPONENTS, SQUARENESS_NAMES
from volcal.model.parameters import ParameterLayout

if TYPE_CHECKING:
    import pandas

MODEL_FORMAT = "volcal-model/2"
MODEL_FORMATS_READ = ("volcal-model/1", "volcal-model/2")
"""Model formats :meth:`IdentificationResult.from_dict` reads."""
UNITS = ("um", "um", "um", "urad", "urad", "urad")

__all__ = ["MODEL_FORMAT", "MODEL_FORMATS_READ", "Convergence", "FitRecord",
           "IdentificationResult", "SessionIdentity"]


@dataclass
class IdentificationResult:
    """Result of :func:`volcal.identify.identify`.

    Attributes
    ----------
    errors : MachineErrors
        Estimated error functions on the estimation nodes.
    layout : ParameterLayout
        Parameter layout of ``errors``.
    free : ndarray of int
        Layout indices of the estimated parameters (the others are gauge zeros or known).
    cov_factor : ndarray, shape (len(free), r)
        Factor ``L`` of the posterior covariance of the estimated parameters, ``L L^T``.
    std : list of 3 ndarray, shape (n_k, 6)
        Standard uncertainty of each node value [um, urad].
    squareness_std : ndarray, shape (3,)
        Standard uncertainty of EC0Y, EB0Z, EA0Z [urad].
    report : IdentifiabilityReport or dict
        Identifiability in plain words.
    fit : FitRecord
        Fit statistics: method, sigma_um, sigma_residual_um, dof, n_readings,
        hyperparameters, convergence of the optimiser, notes (a dict given here is
        converted; ``fit["sigma_um"]`` still works).
    residuals, fitted : dict of str to ndarray
        Per measurement [um].
    nuisances : dict of str to (value, std)
        Set-up parameters (offsets [um], tilts [urad], reversal [um], drift [um/h]).
    outliers : list of dict
        Readings whose standardised residual exceeds the threshold.
    session : SessionIdentity or None
        Identity of the session the model was identified from (machine name, chain,
        travel, hash of the readings); ``None`` for models of format ``volcal-model/1``.
    format : str
        Model format the result was read from (or will be written as).
    sys_factor : ndarray, shape (len(free), k) or None
        Covariance factor of the systematic inputs of an uncertainty budget, propagated
        through the fit's linear gain (:mod:`volcal.identify.systematic`); kept apart from
        the noise factor ``cov_factor``. ``predict`` and ``function_std`` combine both.
    sys_labels : list of str
        Input of each column of ``sys_factor``.
    sys_source : str
        The budget file the systematic part came from.
    """

    name: str
    errors: MachineErrors
    layout: ParameterLayout
    free: NDArray[np.intp]
    cov_factor: NDArray[np.float64]
    std: list[NDArray[np.float64]]
    squareness_std: NDArray[np.float64]
    report: Any
    fit: FitRecord
    residuals: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    fitted: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    nuisances: dict[str, tuple[float, float]] = field(default_factory=dict)
    outliers: list[dict[str, Any]] = field(default_factory=list)
    design: Any = field(default=None, repr=False)
    solution: Any = field(default=None, repr=False)
    session: SessionIdentity | None = None
    format: str = MODEL_FORMAT
    sys_factor: NDArray[np.float64] | None = None
    sys_labels: list[str] = field(default_factory=list)
    sys_source: str = ""

    def _factor(self, systematic: bool = True) -> NDArray[np.float64]:
        """Covariance factor: noise, with the systematic columns appended if any."""
        if not systematic or self.sys_factor is None or self.sys_factor.shape[1] == 0:
            return self.cov_factor
        return np.hstack([np.asarray(self.cov_factor), self.sys_factor])

    def __post_init__(self) -> None:
        """Convert an untyped fit dictionary into a :class:`FitRecord`."""
        if not isinstance(self.fit, FitRecord):
            self.fit = FitRecord.from_dict(dict(self.fit or {}))
        if not self.fit.outliers and self.outliers:
            self.fit.outliers = self.outliers

    def __repr__(self) -> str:
        """Short one-line description (the arrays are left out)."""
        f = self.fit
        sig = "?" if f.sigma_um is None else f"{f.sigma_um:.3g}"
        return (f"IdentificationResult(name={self.name!r}, chain={str(self.errors.chain)!r}, "
                f"parameters={int(self.free.size)}, readings={f.n_readings}, "
                f"sigma_um={sig}, method={f.method!r}, format={self.format!r})")

    def summary(self) -> str:
        """A few plain lines: machine, data, fit and convergence.

        Returns
        -------
        str
            Lines separated by newlines.
        """
        f = self.fit
        t = self.errors.travel
        lines = [f"model of {self.name} (chain {self.errors.chain}, travel "
                 + " x ".join(f"{lo:g}..{hi:g}" for lo, hi in t) + " mm)"]
        lines.append(f"{f.n_readings} readings, {int(self.free.size)} estimated parameters, "
                     f"method {f.method or '?'}")
        if f.sigma_um is not None:
            res = ("" if f.sigma_residual_um is None
                   else f", residual {f.sigma_residual_um:.3f} um")
            lines.append(f"reading noise {f.sigma_um:.3f} um{res}")
        lines.append(f.convergence.describe())
        if self.outliers:
            lines.append(f"{len(self.outliers)} outlier reading(s)")
        if self.session is not None:
            lines.append(f"session readings sha256 {self.session.readings_sha256[:12]}...")
        lines.extend(f.notes)
        return "\n".join(lines)

    @property
    def sigma_um(self) -> float | None:
        """Reading noise used by the estimator [um] (``None`` if the file lacks it)."""
        return self.fit.sigma_um

    @property
    def theta(self) -> NDArray[np.float64]:
        """Full parameter vector of the estimate."""
        return self.layout.pack(self.errors)

    def predict(self, q: ArrayLike, tool_offset: ArrayLike | None = None, chunk: int = 20000,
                rigid_removed: bool = False, systematic: bool = True
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Volumetric error and its standard uncertainty at points.

        Parameters
        ----------
        q : array_like, shape (m, 3)
            Commanded positions [mm].
        tool_offset : array_like, shape (3,), optional
            Tool offset [mm].
        chunk : int
            Points per block (memory bound).
        rigid_removed : bool
            Remove the best-fit rigid-body motion over the points ``q`` from the error field
            and from its uncertainty (ISO 230-1 volumetric comparisons; relative laser
            readings cannot see a rigid motion of the work zone). Dense in ``3m``: for at
            most a few thousand points.
        systematic : bool
            Include the systematic part (``sys_factor``) when there is one (default).

        Returns
        -------
        e : ndarray, shape (m, 3)
            Actual minus commanded tool point position, machine axes [um].
        u : ndarray, shape (m, 3)
            Standard uncertainties [um].

        Raises
        ------
        VolcalInputError
            ``q`` is not numbers of shape (m, 3) (or one point of shape (3,)).
        """
        try:
            q = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            q = np.full((1, 2), np.nan)
        if q.size == 0 or q.size % 3 or (q.ndim > 1 and q.shape[-1] != 3) or q.ndim > 2:
            raise VolcalInputError(f"predict: an array of shape {q.shape}: expected points x, "
                                   "y, z [mm], shape (m, 3)")
        q = q.reshape(-1, 3)
        theta = self.theta
        factor = self._factor(systematic)
        order = self.errors.chain_obj.order
        if rigid_removed:
            from volcal.identify.identifiability import rigid_projector

            Je, _ = pose_jacobian(order, self.layout.nodes, q, tool_offset)
            R = rigid_projector(q)
            e = (R @ (Je @ theta)).reshape(-1, 3)
            GL = R @ np.asarray(Je[:, self.free] @ factor)
            return e, np.sqrt(np.sum(GL**2, axis=1)).reshape(-1, 3)
        es, us = [], []
        for i in range(0, q.shape[0], chunk):
            qq = q[i:i + chunk]
            Je, _ = pose_jacobian(order, self.layout.nodes, qq, tool_offset)
            es.append((Je @ theta).reshape(-1, 3))
            GL = Je[:, self.free] @ factor
            us.append(np.sqrt(np.sum(np.asarray(GL) ** 2, axis=1)).reshape(-1, 3))
        return np.concatenate(es), np.concatenate(us)

    def function_std(self, name: str, q: ArrayLike, systematic: bool = True
                     ) -> NDArray[np.float64]:
        """Standard uncertainty of one named function at positions [um or urad].

        Parameters
        ----------
        name : str
            ISO name (``'EXX'``...) or squareness name.
        q : array_like
            Positions of that axis [mm].
        systematic : bool
            Include the systematic part (``sys_factor``) when there is one (default).
        """
        factor = self._factor(systematic)
        from volcal.model.errorfunctions import interp_weights
        from volcal.model.names import COMPONENT_NAMES

        name = name.upper()
        q = np.asarray(q, dtype=float).reshape(-1)
        pos = -np.ones(self.layout.size, dtype=np.intp)
        pos[self.free] = np.arange(self.free.size)
        if name in SQUARENESS_NAMES:
            i = pos[self.layout.squareness_indices()[SQUARENESS_NAMES.index(name)]]
            return np.full(q.shape, 0.0 if i < 0 else float(np.linalg.norm(factor[i])))
        k, c = divmod(COMPONENT_NAMES.index(name), 6)
        idx = self.layout.indices(k, c)
        i0, i1, w = interp_weights(self.layout.nodes[k], q)
        L = np.zeros((q.size, factor.shape[1]))
        for ii, ww in ((i0, 1 - w), (i1, w)):
            p = pos[idx[ii]]
            ok = p >= 0
            L[ok] += ww[ok, None] * factor[p[ok]]
        return np.linalg.norm(L, axis=1)

    # ------------------------------------------------------------------ tables
    def to_rows(self) -> list[dict[str, Any]]:
        """The identified functions as a table, one row per function and node.

        Returns
        -------
        list of dict
            ``function`` (``'EXX'``...), ``axis``, ``position_mm`` [mm] (NaN for the
            squareness errors), ``value`` and ``u`` (standard uncertainty) in ``unit``
            (``'um'`` or ``'urad'``); see :func:`volcal.io.frames.identified_rows`.
        """
        from volcal.io.frames import identified_rows

        return identified_rows(self)

    def to_dataframe(self) -> pandas.DataFrame:
        """:meth:`to_rows` as a pandas DataFrame (needs pandas).

        Returns
        -------
        pandas.DataFrame
        """
        from volcal.io.frames import to_dataframe

        return to_dataframe(self.to_rows(), "IdentificationResult")

    # ------------------------------------------------------------------ file
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (schema ``volcal-model/2``)."""
        funcs = {}
        for k in range(3):
            d: dict[str, Any] = {"position_mm": _r(self.layout.nodes[k])}
            for c in range(6):
                nm = f"{COMPONENTS[c]}{AXES[k]}_{UNITS[c]}"
                d[nm] = _r(self.errors.values[k][:, c])
                d["u_" + nm] = _r(self.std[k][:, c])
            funcs[AXES[k]] = d
        rep = self.report.to_dict() if hasattr(self.report, "to_dict") else self.report
        out = {
            "format": MODEL_FORMAT,
            "name": self.name,
            "session": None if self.session is None else self.session.to_dict(),
            "chain": str(self.errors.chain),
            "travel_mm": [_r(self.errors.travel[k]) for k in range(3)],
            "functions": funcs,
            "squareness_urad": dict(zip(SQUARENESS_NAMES, _r(self.errors.squareness), strict=True)),
            "u_squareness_urad": dict(zip(SQUARENESS_NAMES, _r(self.squareness_std), strict=True)),
            "covariance": {"free_index": [int(i) for i in self.free],
                           "factor": [_r(row) for row in self.cov_factor]},
            "identifiability": rep,
            "fit": self.fit.to_dict(),
            "nuisances": {k: {"value": _f(v[0]), "u": _f(v[1])} for k, v in self.nuisances.items()},
            "outliers": self.outliers,
            "readings": {mid: {"fitted_um": _r(self.fitted[mid]),
                               "residual_um": _r(self.residuals[mid])}
                         for mid in self.fitted if mid in self.residuals},
        }
        if self.sys_factor is not None:
            out["systematic"] = {"inputs": list(self.sys_labels), "budget": self.sys_source,
                                 "factor": [_r(row) for row in self.sys_factor]}
        return out

    def to_json(self, path: str | Path) -> Path:
        """Write the model file atomically.

        Parameters
        ----------
        path : str or Path
            Output file (``MODEL.json``).
        """
        path = Path(path)
        write_text(path, json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n")
        return path

    @classmethod
    def from_dict(cls, doc: dict[str, Any], source: str = "model") -> IdentificationResult:
        """Rebuild a result from its JSON dictionary (no residuals or design).

        Parameters
        ----------
        doc : dict
            Parsed model file as written by :meth:`to_dict` (format ``volcal-model/2``,
            or the older ``volcal-model/1``): positions [mm], translations [um], rotations
            and squareness [urad].
        source : str
            Name of the file the dictionary came from, used in error messages.

        Returns
        -------
        IdentificationResult
        """
        try:
            fmt = doc.get("format")
            if fmt not in MODEL_FORMATS_READ:
                raise VolcalInputError(f"unknown model format {fmt!r}: this volcal reads "
                                       + ", ".join(f'"{x}"' for x in MODEL_FORMATS_READ)
                                       + " (write the model again with `volcal identify`)",
                                       source, None, "format")
            nodes, values, std = [], [], []
            for k in range(3):
                f = doc["functions"][AXES[k]]
                nodes.append(np.array(f["position_mm"], dtype=float))
                values.append(np.stack([np.array(f[f"{COMPONENTS[c]}{AXES[k]}_{UNITS[c]}"],
                                                 dtype=float) for c in range(6)], 1))
                std.append(np.stack([np.array(f[f"u_{COMPONENTS[c]}{AXES[k]}_{UNITS[c]}"],
                                              dtype=float) for c in range(6)], 1))
            sq = np.array([doc["squareness_urad"][n] for n in SQUARENESS_NAMES], dtype=float)
            usq = np.array([doc["u_squareness_urad"][n] for n in SQUARENESS_NAMES], dtype=float)
            errors = MachineErrors(doc["chain"], nodes, values, sq, name=doc.get("name", "model"))
            layout = ParameterLayout(tuple(nodes))
            free = np.array(doc["covariance"]["free_index"], dtype=np.intp)
            fac = np.array(doc["covariance"]["factor"], dtype=float).reshape(free.size, -1)
        except VolcalInputError:
            raise
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise VolcalInputError(f"not a valid volcal model file ({exc.__class__.__name__}: "
                                   f"{exc})", source) from None
        try:
            nuis = {k: (v["value"], v["u"]) for k, v in doc.get("nuisances", {}).items()}
        except (KeyError, TypeError, AttributeError):
            raise VolcalInputError("invalid 'nuisances' section", source, None,
                                   "nuisances") from None
        readings = doc.get("readings", {})
        try:
            fitted = {k: np.array(v["fitted_um"], dtype=float) for k, v in readings.items()}
            resid = {k: np.array(v["residual_um"], dtype=float) for k, v in readings.items()}
        except (KeyError, TypeError, ValueError, AttributeError):
            raise VolcalInputError("invalid 'readings' section", source, None,
                                   "readings") from None
        fit_doc = doc.get("fit", {})
        if not isinstance(fit_doc, dict):
            raise VolcalInputError("invalid 'fit' section (expected a table)", source, None,
                                   "fit")
        fit = FitRecord.from_dict(fit_doc, source)
        if fit.sigma_um is None:
            fit.notes.append("the model file gives no reading noise (fit.sigma_um)")
        ident = SessionIdentity.from_dict(doc.get("session"), source)
        outliers = doc.get("outliers", [])
        if not isinstance(outliers, list):
            raise VolcalInputError("invalid 'outliers' section (expected a list)", source,
                                   None, "outliers")
        sys_f, sys_l, sys_src = None, [], ""
        if doc.get("systematic") is not None:
            try:
                sd = doc["systematic"]
                sys_l = [str(x) for x in sd["inputs"]]
                sys_f = np.array(sd["factor"], dtype=float).reshape(free.size, len(sys_l))
                sys_src = str(sd.get("budget", ""))
            except (KeyError, TypeError, ValueError):
                raise VolcalInputError("invalid 'systematic' section", source, None,
                                       "systematic") from None
        return cls(doc.get("name", "model"), errors, layout, free, fac, std, usq,
                   doc.get("identifiability", {}), fit, resid, fitted,
                   nuisances=nuis, outliers=outliers, session=ident, format=str(fmt),
                   sys_factor=sys_f, sys_labels=sys_l, sys_source=sys_src)


def _f(v: float) -> float | None:
    v = float(v)
    return float(f"{v:.7g}") if math.isfinite(v) else None


def _r(a: ArrayLike) -> list[float]:
    return [float(f"{float(v):.7g}") for v in np.asarray(a).reshape(-1)]
