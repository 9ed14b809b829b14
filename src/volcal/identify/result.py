"""The identified model: error functions with uncertainties, predictions, model file.

The model file (``docs/formats.md``, "Model file") is written and read by
:mod:`volcal.identify.modelfile`: format ``volcal-model/3`` is a small readable JSON
(this module's :meth:`IdentificationResult.to_dict`) and a binary sidecar ``.npz`` with the
large arrays (the covariance factor, the fitted values and residuals of every reading),
bound to the JSON by its sha256. ``volcal-model/2`` and ``/1`` files (the factor as JSON
text, and the systematic part's as ``systematic.factor``; ``/1`` without ``session``
identity and with an untyped ``fit``) still load. ``volcal identify -o -`` writes format
2 (one file: all standard output can carry). Format 3::

    {"format": "volcal-model/3", "name", "chain", "travel_mm": [[x0,x1],[y0,y1],[z0,z1]],
     "session": {"name", "chain", "travel_mm", "readings_sha256", "n_readings",
                 "measurements"},
     "functions": {"X": {"position_mm": [...], "EXX_um": [...], "u_EXX_um": [...], ...,
                         "EAX_urad": [...], "u_EAX_urad": [...], ...}, "Y": ..., "Z": ...},
     "squareness_urad": {"EC0Y": v, ...}, "u_squareness_urad": {...},
     "covariance": {"free_index": [...], "parts": {"noise": "noise_factor",
                    "between_readings": "between_readings_variance",  (1-D: one per parameter)
                    "systematic": "systematic_factor"}},  (with a budget only)
     "systematic": {"inputs": [...], "budget": "..."},  (with a budget only)
     "identifiability": {...}, "fit": {...}, "nuisances": {...}, "outliers": [...],
     "readings": {"arrays": ["fitted_um", "residual_um"],
                  "measurements": {"<measurement id>": [first, count], ...}},
     "arrays": {"file": "MODEL.npz", "sha256", "bytes",
                "members": {"noise_factor": {"shape": [n, r], "dtype": "<f8"}, ...}}}
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError
from volcal.identify.record import Convergence, FitRecord, SessionIdentity
from volcal.model.errorfunctions import MachineErrors, interp_weights
from volcal.model.kinematics import UM, URAD, pose_jacobian, volumetric_error
from volcal.model.names import AXES, COMPONENTS, SQUARENESS_NAMES
from volcal.model.parameters import ParameterLayout

if TYPE_CHECKING:
    import pandas

MODEL_FORMAT = "volcal-model/3"
MODEL_FORMATS_READ = ("volcal-model/1", "volcal-model/2", "volcal-model/3")
"""Model formats :meth:`IdentificationResult.from_dict` reads."""
UNITS = ("um", "um", "um", "urad", "urad", "urad")
MAX_TRANSLATION_UM = 10_000.0
"""Largest plausible positioning or straightness error (and its u) in a model file [um]:
10 mm, the bound of the readings' ``deviation_um`` column."""
MAX_ROTATION_URAD = 10_000.0
"""Largest plausible angular or squareness error (and its u) in a model file [urad]:
10 mrad (0.57 degree)."""
MAX_POSITION_MM = 1e6
"""Largest plausible node position in a model file [mm] (1 km, as the readers' targets)."""

__all__ = ["MODEL_FORMAT", "MODEL_FORMATS_READ", "Convergence", "FitRecord",
           "IdentificationResult", "SessionIdentity"]


DIAGONAL_PARTS: tuple[str, ...] = ("between_readings",)
"""Covariance parts stored as one variance per parameter (``<part>_variance``, 1-D) in the
model file's binary part; the others as a factor (``<part>_factor``)."""


def _member(part: str) -> str:
    """The binary part's member of a covariance part."""
    return f"{part}_variance" if part in DIAGONAL_PARTS else f"{part}_factor"


def diagonal_factor(variance: ArrayLike) -> NDArray[np.float64]:
    """Factor of a diagonal covariance: one column per non-zero variance.

    Parameters
    ----------
    variance : array_like, shape (n,)
        Variance of each parameter [um^2 or urad^2].

    Returns
    -------
    ndarray, shape (n, k)
        ``F`` with ``F F^T = diag(variance)``, ``k`` the non-zero variances.
    """
    v = np.asarray(variance, dtype=float)
    rows = np.flatnonzero(v > 0)
    out = np.zeros((v.size, rows.size))
    out[rows, np.arange(rows.size)] = np.sqrt(v[rows])
    return out


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
    cov_factor : ndarray, shape (len(free), r), or None
        Factor ``L`` of the posterior covariance of the estimated parameters, ``L L^T``
        (reading noise and prior: the ``noise`` part). ``None`` for a model file whose
        binary part is missing or does not match: see :attr:`uncertainty_missing`.
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
    between_factor : ndarray, shape (len(free), k) or None
        Covariance factor of the variance between the readings (nodes no reading
        touches: :mod:`volcal.identify.between`), one column per node; kept apart from
        ``cov_factor`` (the history's change test leaves it out), combined with it by
        ``predict``, ``function_std`` and the U of the model's indices; in ``std``.
    sys_source : str
        The budget file the systematic part came from.
    uncertainty_missing : str or None
        Why the model has no uncertainty (its binary part missing or not matching), or
        ``None``. :meth:`predict`, :meth:`function_std` and
        :meth:`require_uncertainty` then raise :class:`~volcal.errors.VolcalInputError`
        with this reason.
    uncertainty_file : str or None
        The file at fault when :attr:`uncertainty_missing` is set (the binary part
        ``MODEL.npz``, or the JSON when it names none), named by
        :meth:`require_uncertainty`.
    """

    name: str
    errors: MachineErrors
    layout: ParameterLayout
    free: NDArray[np.intp]
    cov_factor: NDArray[np.float64] | None
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
    between_factor: NDArray[np.float64] | None = None
    uncertainty_missing: str | None = None
    uncertainty_file: str | None = None

    def statistical_factor(self) -> NDArray[np.float64] | None:
        """Covariance factor of the fit: the noise part and the part between the readings.

        Returns
        -------
        ndarray, shape (len(free), r) or None
            ``cov_factor`` with the columns of ``between_factor`` appended when there
            are any; None without uncertainty.
        """
        if self.cov_factor is None:
            return None
        if self.between_factor is None or self.between_factor.shape[1] == 0:
            return self.cov_factor
        return np.hstack([np.asarray(self.cov_factor), self.between_factor])

    def _factor(self, systematic: bool = True) -> NDArray[np.float64] | None:
        """Covariance factor: :meth:`statistical_factor`, the systematic columns appended."""
        stat = self.statistical_factor()
        if (stat is None or not systematic or self.sys_factor is None
                or self.sys_factor.shape[1] == 0):
            return stat
        return np.hstack([stat, self.sys_factor])

    def nugget_variance(self, k: int, x: ArrayLike) -> NDArray[np.float64]:
        """Variance of the positioning error of axis ``k`` between its nodes [um^2].

        The short-wavelength ("nugget") part of the positioning prior
        (``fit.hyperparameters['positioning_nugget_um']``, ``n``; a lead screw's cyclic
        error) is independent at every point: the node values carry it, and their linear
        interpolation carries ``((1 - w)^2 + w^2) n^2`` of it at the weight ``w`` between
        two nodes; the rest, ``2 w (1 - w) n^2``, is added to the predicted variance (zero
        at the nodes, ``n^2 / 2`` half way). Zero without a nugget or where the function
        is held (gauge, known).

        Parameters
        ----------
        k : int
            Axis (0, 1, 2 = X, Y, Z).
        x : array_like
            Positions of that axis [mm].

        Returns
        -------
        ndarray
            Variance [um^2], the shape of ``x``.
        """
        x = np.asarray(x, dtype=float)
        n = self.fit.hyperparameters.get("positioning_nugget_um") if isinstance(
            self.fit.hyperparameters, dict) else None
        if not n or not np.isfinite(n):
            return np.zeros(x.shape)
        if not np.isin(self.layout.indices(k, k), self.free).any():
            return np.zeros(x.shape)
        _, _, w = interp_weights(self.layout.nodes[k], x.reshape(-1))
        w = np.clip(w, 0.0, 1.0)
        return (2.0 * float(n) ** 2 * w * (1.0 - w)).reshape(x.shape)

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

    @property
    def has_uncertainty(self) -> bool:
        """True when the covariance factor is there (see :attr:`uncertainty_missing`)."""
        return self.cov_factor is not None

    def require_uncertainty(self, what: str = "this", source: str | Path | None = None
                            ) -> None:
        """Refuse a model without its uncertainty.

        Parameters
        ----------
        what : str
            What needs the uncertainty, named in the message (``"predict"``, ``"the
            report's uncertainty bands"``).
        source : str or Path, optional
            Model file named in the message when the result does not know the file at
            fault (:attr:`uncertainty_file`).

        Raises
        ------
        VolcalInputError
            If the model has no covariance factor (:attr:`uncertainty_missing` says why).
        """
        if self.cov_factor is None:
            why = self.uncertainty_missing or "the model carries no covariance"
            raise VolcalInputError(f"{what} needs the model's uncertainty, and {why}",
                                   self.uncertainty_file or source)

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
            Points per block at most (memory bound; smaller blocks are taken when the
            covariance factor is wide, and about 256 kB of the factor's rows at a time for
            the uncertainty).
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
            Standard uncertainties [um], with the short-wavelength part of the positioning
            errors between their nodes (:meth:`nugget_variance`).

        Raises
        ------
        VolcalInputError
            ``q`` is not numbers of shape (m, 3) (or one point of shape (3,)), the
            model has no uncertainty (:attr:`uncertainty_missing`), or a value at a point
            is not a finite number (NaN or infinite points or model values).
        """
        self.require_uncertainty("predict")
        try:
            q = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            q = np.full((1, 2), np.nan)
        if q.size == 0 or q.size % 3 or (q.ndim > 1 and q.shape[-1] != 3) or q.ndim > 2:
            raise VolcalInputError(f"predict: an array of shape {q.shape}: expected points x, "
                                   "y, z [mm], shape (m, 3)")
        q = q.reshape(-1, 3)
        factor = self._factor(systematic)
        assert factor is not None
        if rigid_removed:
            from volcal.identify.identifiability import rigid_projector

            theta = self.theta
            order = self.errors.chain_obj.order
            Je, _ = pose_jacobian(order, self.layout.nodes, q, tool_offset)
            R = rigid_projector(q)
            e = (R @ (Je @ theta)).reshape(-1, 3)
            GL = R @ np.asarray(Je[:, self.free] @ factor)
            v = np.stack([self.nugget_variance(k, q[:, k]) for k in range(3)], axis=1)
            var = np.sum(GL**2, axis=1) + (R**2) @ v.ravel()
            return _finite_prediction(e, np.sqrt(var).reshape(-1, 3), q)
        t = np.zeros(3) if tool_offset is None else np.asarray(tool_offset, dtype=float)
        t = np.broadcast_to(t, q.shape) if t.ndim == 1 else t.reshape(-1, 3)
        e = volumetric_error(self.errors, q, t)
        L = self._full_factor(factor)
        # blocks of about 256 kB of rows: they stay in the cache while their terms are
        # summed (the same floats for any block: each point's row is its own sum)
        width = max(L.shape[1], 1)
        step = max(1, min(int(chunk), 2_000_000 // width, max(16, 32_768 // width)))
        u = np.empty_like(e)
        for i in range(0, q.shape[0], step):
            for c, terms in enumerate(self._error_rows(q[i:i + step], t[i:i + step])):
                G = np.zeros((terms[0][1].size, L.shape[1]))
                term = np.empty_like(G)  # one buffer for every term: no new pages each time
                for cols, vals in terms:  # G += vals[:, None] * L[cols], the same floats
                    np.take(L, cols, axis=0, out=term)
                    np.multiply(vals[:, None], term, out=term)
                    G += term
                u[i:i + step, c] = np.sqrt(np.einsum("mr,mr->m", G, G)
                                           + self.nugget_variance(c, q[i:i + step, c]))
        return _finite_prediction(e, u, q)

    def _full_factor(self, factor: NDArray[np.float64]) -> NDArray[np.float64]:
        """A covariance factor on every layout parameter (zero rows where not free)."""
        L = np.zeros((self.layout.size, factor.shape[1]))
        L[self.free] = factor
        return L

    def _error_rows(self, q: NDArray[np.float64], t: NDArray[np.float64]
                    ) -> list[list[tuple[NDArray[np.intp], NDArray[np.float64]]]]:
        """The first-order Jacobian of the volumetric error, row by row, as (column, value).

        For each error component x, y, z: a list of ``(cols, vals)`` pairs, each one entry
        per point, whose sum over the list is that component's row of the Jacobian
        :func:`volcal.model.kinematics.pose_jacobian` (2 nodes x (1 translation + 2
        rotations) per axis, plus the squareness): ``J L`` is then a sum of scaled rows of
        the factor ``L``, without scipy (``volcal predict`` does not import it) and without
        forming ``J``.
        """
        m = q.shape[0]
        starts = self.layout.starts
        order = self.errors.chain_obj.order
        s = URAD / UM
        rows: list[list[tuple[NDArray[np.intp], NDArray[np.float64]]]] = [[], [], []]
        for i, k in enumerate(order):
            down = order[i + 1:]
            lev = [(t[:, a] + q[:, a] if a in down else t[:, a]) * s for a in range(3)]
            i0, i1, w = interp_weights(self.layout.nodes[k], q[:, k])
            for idx, wt in ((i0, 1.0 - w), (i1, w)):
                b = starts[k] + 6 * idx
                for c in range(3):
                    rows[c].append((b + c, wt))
                # eps x L: e_x += eb L_z - ec L_y, e_y += ec L_x - ea L_z, e_z += ea L_y - eb L_x
                rows[0] += [(b + 4, wt * lev[2]), (b + 5, -wt * lev[1])]
                rows[1] += [(b + 5, wt * lev[0]), (b + 3, -wt * lev[2])]
                rows[2] += [(b + 3, wt * lev[1]), (b + 4, -wt * lev[0])]
        sq = self.layout.squareness_indices()
        rows[0] += [(np.full(m, sq[0]), -q[:, 1] * s), (np.full(m, sq[1]), q[:, 2] * s)]
        rows[1] += [(np.full(m, sq[2]), -q[:, 2] * s)]
        return rows

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

        Returns
        -------
        ndarray
            Standard uncertainty at ``q``; for a positioning error (EXX, EYY, EZZ) with
            its short-wavelength part between the nodes (:meth:`nugget_variance`).
        """
        from volcal.model.names import COMPONENT_NAMES

        self.require_uncertainty(f"the uncertainty of {name}")
        factor = self._factor(systematic)
        assert factor is not None

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
        if c == k:  # positioning: its short-wavelength part between the nodes
            return np.sqrt(np.sum(L**2, axis=1) + self.nugget_variance(k, q))
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
    def binary_arrays(self) -> tuple[dict[str, NDArray[np.float64]], dict[str, list[int]]]:
        """The arrays of the model file's binary part and the readings' index.

        Returns
        -------
        arrays : dict of str to ndarray
            ``<part>_factor`` for each covariance part (``noise_factor``: shape
            (len(free), r)), ``<part>_variance`` (shape (len(free),)) for a part of
            :data:`DIAGONAL_PARTS`, ``fitted_um`` and ``residual_um``: the readings of every
            measurement one after another [um].
        index : dict of str to [first, count]
            Where each measurement's readings are in ``fitted_um`` and ``residual_um``.

        Raises
        ------
        VolcalInputError
            If the model has no covariance (loaded without its binary part).
        """
        self.require_uncertainty("writing the model file")
        arrays: dict[str, NDArray[np.float64]] = {
            _member(name): np.ascontiguousarray(
                np.sum(f**2, axis=1) if name in DIAGONAL_PARTS else f, dtype=np.float64)
            for name, f in self._parts().items()}
        index: dict[str, list[int]] = {}
        fitted, resid = [], []
        first = 0
        for mid in self.fitted:
            if mid not in self.residuals:
                continue
            n = int(np.asarray(self.fitted[mid]).size)
            index[mid] = [first, n]
            fitted.append(np.asarray(self.fitted[mid], dtype=np.float64).reshape(-1))
            resid.append(np.asarray(self.residuals[mid], dtype=np.float64).reshape(-1))
            first += n
        arrays["fitted_um"] = np.concatenate(fitted) if fitted else np.zeros(0)
        arrays["residual_um"] = np.concatenate(resid) if resid else np.zeros(0)
        return arrays, index

    def _part_names(self) -> list[str]:
        """The covariance parts: ``noise``, ``between_readings`` and ``systematic``."""
        return (["noise"] + (["between_readings"] if self.between_factor is not None else [])
                + (["systematic"] if self.sys_factor is not None else []))

    def _parts(self) -> dict[str, NDArray[np.float64]]:
        """The covariance factor by part (of a model with uncertainty)."""
        assert self.cov_factor is not None  # the callers check require_uncertainty
        parts = {"noise": self.cov_factor}
        if self.between_factor is not None:
            parts["between_readings"] = self.between_factor
        if self.sys_factor is not None:
            parts["systematic"] = self.sys_factor
        return parts

    def to_dict(self, arrays: dict[str, Any] | None = None,
                readings: dict[str, list[int]] | None = None) -> dict[str, Any]:
        """The JSON part of the model file (schema ``volcal-model/3``).

        Parameters
        ----------
        arrays : dict, optional
            The ``arrays`` block naming the binary part (file, sha256, bytes, members),
            as :func:`volcal.identify.modelfile.write_model` makes it; left out if None
            (a dictionary without it loads without uncertainty).
        readings : dict of str to [first, count], optional
            Index of the readings in the binary part (:meth:`binary_arrays`).

        Returns
        -------
        dict
            JSON-ready: positions [mm], translations [um], rotations and squareness
            [urad], rounded to 7 significant digits.
        """
        funcs = {}
        for k in range(3):
            d: dict[str, Any] = {"position_mm": _r(self.layout.nodes[k])}
            for c in range(6):
                nm = f"{COMPONENTS[c]}{AXES[k]}_{UNITS[c]}"
                d[nm] = _r(self.errors.values[k][:, c])
                d["u_" + nm] = _r(self.std[k][:, c])
            funcs[AXES[k]] = d
        rep = self.report.to_dict() if hasattr(self.report, "to_dict") else self.report
        doc: dict[str, Any] = {
            "format": MODEL_FORMAT,
            "name": self.name,
            "session": None if self.session is None else self.session.to_dict(),
            "chain": str(self.errors.chain),
            "travel_mm": [_r(self.errors.travel[k]) for k in range(3)],
            "functions": funcs,
            "squareness_urad": dict(zip(SQUARENESS_NAMES, _r(self.errors.squareness), strict=True)),
            "u_squareness_urad": dict(zip(SQUARENESS_NAMES, _r(self.squareness_std), strict=True)),
            "covariance": {"free_index": [int(i) for i in self.free],
                           "parts": {name: _member(name) for name in self._part_names()}},
            "identifiability": rep,
            "fit": self.fit.to_dict(),
            "nuisances": {k: {"value": _f(v[0]), "u": _f(v[1])} for k, v in self.nuisances.items()},
            "outliers": self.outliers,
            "readings": {"arrays": ["fitted_um", "residual_um"],
                         "measurements": dict(readings or {})},
        }
        if self.sys_factor is not None:  # the labels here, the factor in the binary part
            doc["systematic"] = {"inputs": list(self.sys_labels), "budget": self.sys_source}
        if arrays is not None:
            doc["arrays"] = arrays
        return doc

    def to_single_file_dict(self) -> dict[str, Any]:
        """The whole model as one JSON document (format ``volcal-model/2``).

        For ``volcal identify -o -``: standard output carries one file, so the factors
        and the readings go in as text (slow for large models; the files of
        :meth:`to_json` are the normal form).

        Returns
        -------
        dict
            JSON-ready, schema ``volcal-model/2``.
        """
        self.require_uncertainty("writing the model")
        assert self.cov_factor is not None
        doc = self.to_dict()
        doc["format"] = "volcal-model/2"
        stat = self.statistical_factor()  # one factor in this format: both parts in it,
        assert stat is not None          # the part between the readings its last columns
        doc["covariance"] = {"free_index": [int(i) for i in self.free],
                             "factor": [_r(row) for row in stat]}
        if self.between_factor is not None and self.between_factor.shape[1]:
            doc["covariance"]["between_readings_columns"] = int(self.between_factor.shape[1])
        doc["readings"] = {mid: {"fitted_um": _r(self.fitted[mid]),
                                 "residual_um": _r(self.residuals[mid])}
                           for mid in self.fitted if mid in self.residuals}
        if self.sys_factor is not None:
            doc["systematic"]["factor"] = [_r(row) for row in self.sys_factor]
        return doc

    def to_json(self, path: str | Path) -> Path:
        """Write the model file atomically: ``MODEL.npz`` first, then ``MODEL.json``.

        Parameters
        ----------
        path : str or Path
            Output file (``MODEL.json``); the binary part is written beside it with the
            suffix ``.npz`` (:func:`volcal.identify.modelwrite.write_model`).

        Returns
        -------
        Path
            The JSON file.
        """
        from volcal.identify.modelwrite import write_model

        return write_model(self, path)

    @classmethod
    def from_dict(cls, doc: dict[str, Any], source: str = "model",
                  arrays: dict[str, NDArray[np.float64]] | None = None,
                  missing: str | None = None) -> IdentificationResult:
        """Rebuild a result from its JSON dictionary (no design).

        Parameters
        ----------
        doc : dict
            Parsed model file as written by :meth:`to_dict` (format ``volcal-model/3``,
            or the older ``volcal-model/2`` and ``/1`` with the factor in the JSON):
            positions [mm], translations [um], rotations and squareness [urad].
        source : str
            Name of the file the dictionary came from, used in error messages.
        arrays : dict of str to ndarray, optional
            Format 3: the arrays of the binary part, checked against its digest
            (:func:`volcal.identify.modelfile.load_model`). Without them the result has no
            uncertainty, no fitted values and no residuals.
        missing : str, optional
            Format 3 without ``arrays``: why they are missing (kept as
            :attr:`uncertainty_missing`).

        Returns
        -------
        IdentificationResult
        """
        fac: NDArray[np.float64] | None  # the covariance factor, when the model has one
        btw_f: NDArray[np.float64] | None = None  # the part between the readings
        try:
            fmt = doc.get("format")
            if fmt not in MODEL_FORMATS_READ:
                raise VolcalInputError(f"unknown model format {fmt!r}: this volcal reads "
                                       + ", ".join(f'"{x}"' for x in MODEL_FORMATS_READ)
                                       + " (write the model again with `volcal identify`)",
                                       source, None, "format")
            for key in ("chain", "name"):
                if not isinstance(doc.get(key, ""), str):
                    raise VolcalInputError(f"expected text, found {doc[key]!r}"[:200], source,
                                           None, key)
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
            check_model_values(nodes, values, std, sq, usq, source)
            errors = MachineErrors(doc["chain"], nodes, values, sq, name=doc.get("name", "model"))
            layout = ParameterLayout((nodes[0], nodes[1], nodes[2]))
            free = _free_index(doc["covariance"]["free_index"], layout.size, source)
            if fmt == MODEL_FORMAT:
                part_names = dict(doc["covariance"]["parts"])
                if not part_names or not all(isinstance(v, str) for v in part_names.values()):
                    raise ValueError("covariance.parts: expected part names -> array names")
            else:
                part_names = {}
                fac = np.array(doc["covariance"]["factor"], dtype=float).reshape(free.size, -1)
                nb = doc["covariance"].get("between_readings_columns", 0)
                if not isinstance(nb, int) or isinstance(nb, bool) or not 0 <= nb < fac.shape[1]:
                    raise ValueError(f"covariance.between_readings_columns: expected a count "
                                     f"of the factor's last columns (0-{fac.shape[1] - 1}), "
                                     f"got {nb!r}")
                if nb:
                    btw_f, fac = fac[:, -nb:], fac[:, :-nb]
        except VolcalInputError:
            raise
        except (KeyError, TypeError, ValueError, IndexError, OverflowError) as exc:
            raise VolcalInputError(f"not a valid volcal model file ({exc.__class__.__name__}: "
                                   f"{exc})", source) from None
        try:
            nuis = {k: (v["value"], v["u"]) for k, v in doc.get("nuisances", {}).items()}
        except (KeyError, TypeError, AttributeError):
            raise VolcalInputError("invalid 'nuisances' section", source, None,
                                   "nuisances") from None
        readings = doc.get("readings", {})
        fitted: dict[str, NDArray[np.float64]] = {}
        resid: dict[str, NDArray[np.float64]] = {}
        parts: dict[str, NDArray[np.float64]] = {}
        try:
            if fmt != MODEL_FORMAT:
                fitted = {k: np.array(v["fitted_um"], dtype=float) for k, v in readings.items()}
                resid = {k: np.array(v["residual_um"], dtype=float) for k, v in readings.items()}
            elif arrays is not None:
                fa, ra = arrays["fitted_um"], arrays["residual_um"]
                for mid, (first, count) in readings["measurements"].items():
                    if first < 0 or count < 0 or first + count > fa.size:
                        raise ValueError(f"{mid}: [{first}, {count}] outside the arrays")
                    fitted[mid] = fa[first:first + count]
                    resid[mid] = ra[first:first + count]
        except (KeyError, TypeError, ValueError, AttributeError):
            raise VolcalInputError("invalid 'readings' section", source, None,
                                   "readings") from None
        sys_f, sys_l, sys_src = None, [], ""
        if doc.get("systematic") is not None:
            try:
                sd = doc["systematic"]
                sys_l = [str(x) for x in sd["inputs"]]
                sys_src = str(sd.get("budget", ""))
                if fmt != MODEL_FORMAT:
                    sys_f = np.array(sd["factor"], dtype=float).reshape(free.size, len(sys_l))
            except (KeyError, TypeError, ValueError):
                raise VolcalInputError("invalid 'systematic' section", source, None,
                                       "systematic") from None
        if fmt == MODEL_FORMAT:
            fac = None
            if arrays is not None:
                for name, member in part_names.items():
                    f = arrays.get(member)
                    if f is None or f.ndim not in (1, 2) or f.shape[0] != free.size:
                        raise VolcalInputError(
                            f"covariance part {name!r}: array {member!r} missing or not of "
                            f"{free.size} rows", source, None, "covariance")
                    if f.ndim == 1:  # a diagonal part: the variance of each parameter
                        if not np.all(np.isfinite(f) & (f >= 0)):
                            raise VolcalInputError(
                                f"covariance part {name!r}: array {member!r} holds "
                                "variances: expected finite values >= 0", source, None,
                                "covariance")
                        f = diagonal_factor(f)
                    parts[name] = f
                if "noise" not in parts:
                    raise VolcalInputError("covariance: no 'noise' part", source, None,
                                           "covariance")
                sys_f = parts.pop("systematic", None)
                btw_f = parts.pop("between_readings", None)
                if sys_f is not None and sys_f.shape[1] != len(sys_l):
                    raise VolcalInputError(f"systematic: {len(sys_l)} inputs named, the "
                                           f"factor has {sys_f.shape[1]} columns", source,
                                           None, "systematic")
                # the noise part, and any part this version does not know, side by side
                noise = parts.pop("noise")
                fac = np.hstack([noise, *parts.values()]) if parts else noise
            else:
                missing = missing or "the model carries no binary part"
                std = [np.full_like(s, np.nan) for s in std]
                usq = np.full_like(usq, np.nan)
        fit_doc = doc.get("fit", {})
        if not isinstance(fit_doc, dict):
            raise VolcalInputError("invalid 'fit' section (expected a table)", source, None,
                                   "fit")
        fit = FitRecord.from_dict(fit_doc, source)
        if fit.sigma_um is None:
            fit.notes.append("the model file gives no reading noise (fit.sigma_um)")
        if fac is None:
            fit.notes.append(f"no uncertainty: {missing}")
        ident = SessionIdentity.from_dict(doc.get("session"), source)
        outliers = doc.get("outliers", [])
        if not isinstance(outliers, list):
            raise VolcalInputError("invalid 'outliers' section (expected a list)", source,
                                   None, "outliers")
        return cls(doc.get("name", "model"), errors, layout, free, fac, std, usq,
                   doc.get("identifiability", {}), fit, resid, fitted,
                   nuisances=nuis, outliers=outliers, session=ident, format=str(fmt),
                   sys_factor=sys_f, sys_labels=sys_l, sys_source=sys_src,
                   between_factor=btw_f,
                   uncertainty_missing=None if fac is not None else missing)


def _free_index(value: Any, size: int, source: str) -> NDArray[np.intp]:
    """``covariance.free_index``: distinct whole numbers within the layout of ``size``."""
    ok = isinstance(value, list) and all(isinstance(v, int) and not isinstance(v, bool)
                                         and 0 <= v < size for v in value)
    if not ok or len(set(value)) != len(value):
        raise VolcalInputError(f"expected distinct whole numbers from 0 to {size - 1} (the "
                               "estimated parameters)", source, None, "covariance.free_index")
    return np.array(value, dtype=np.intp)


def _finite_prediction(e: NDArray[np.float64], u: NDArray[np.float64],
                       q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(e, u)`` if every value is a finite number; else refuse, naming the first point."""
    bad = np.flatnonzero(~(np.isfinite(e).all(axis=1) & np.isfinite(u).all(axis=1)))
    if bad.size:
        p = ", ".join(f"{v:g}" for v in q[int(bad[0])])
        raise VolcalInputError(f"predict: the model gives a value that is not a finite number "
                               f"at ({p}) mm (point {int(bad[0]) + 1}); nothing is written "
                               "(is the model damaged? identify again)")
    return e, u


def _first_bad(a: NDArray[np.float64], bound: float, signed: bool = True) -> int | None:
    """Index of the first value not finite, beyond ``bound``, or negative when unsigned."""
    bad = ~np.isfinite(a) | (np.abs(np.where(np.isfinite(a), a, 0.0)) > bound)
    if not signed:
        bad |= a < 0
    idx = np.flatnonzero(bad.reshape(-1))
    return int(idx[0]) if idx.size else None


def check_model_values(nodes: list[NDArray[np.float64]], values: list[NDArray[np.float64]],
                       std: list[NDArray[np.float64]], squareness: NDArray[np.float64],
                       squareness_std: NDArray[np.float64], source: str = "model") -> None:
    """Refuse a model whose numbers are not finite or not plausible.

    Positions within :data:`MAX_POSITION_MM`; translations (positioning, straightness)
    and their standard uncertainties within :data:`MAX_TRANSLATION_UM`, rotations and
    squareness within :data:`MAX_ROTATION_URAD`; uncertainties not negative.

    Parameters
    ----------
    nodes : list of 3 ndarray
        Node positions per axis [mm].
    values, std : list of 3 ndarray, shape (n_k, 6)
        Function values and their standard uncertainties at the nodes [um, urad].
    squareness, squareness_std : ndarray, shape (3,)
        EC0Y, EB0Z, EA0Z and their standard uncertainties [urad].
    source : str
        The model file, named in the message.

    Raises
    ------
    VolcalInputError
        Naming the file and the key (``functions.X.EXX_um[3]``) of the first bad value.
    """
    def refuse(key: str, v: float, what: str, unit: str, bound: float) -> None:
        text = ("not a finite number" if not math.isfinite(v) else
                f"{v:g} {unit} is negative" if v < 0 and what == "u" else
                f"{v:g} {unit} is not a plausible {what} (at most {bound:g} {unit}; see "
                "docs/formats.md, 'Model file')")
        raise VolcalInputError(f"{text}: the model file is damaged (identify again)", source,
                               None, key)

    for k in range(3):
        i = _first_bad(np.asarray(nodes[k], dtype=float), MAX_POSITION_MM)
        if i is not None:
            refuse(f"functions.{AXES[k]}.position_mm[{i}]", float(nodes[k][i]), "position",
                   "mm", MAX_POSITION_MM)
        for c in range(6):
            unit, bound = UNITS[c], MAX_TRANSLATION_UM if c < 3 else MAX_ROTATION_URAD
            name = f"{COMPONENTS[c]}{AXES[k]}_{unit}"
            for arr, key, signed, what in ((values[k][:, c], name, True, "error"),
                                           (std[k][:, c], "u_" + name, False, "u")):
                i = _first_bad(np.asarray(arr, dtype=float), bound, signed)
                if i is not None:
                    refuse(f"functions.{AXES[k]}.{key}[{i}]", float(arr[i]), what, unit, bound)
    for arr, key, signed, what in ((squareness, "squareness_urad", True, "error"),
                                   (squareness_std, "u_squareness_urad", False, "u")):
        i = _first_bad(np.asarray(arr, dtype=float), MAX_ROTATION_URAD, signed)
        if i is not None:
            refuse(f"{key}.{SQUARENESS_NAMES[i]}", float(arr[i]), what, "urad",
                   MAX_ROTATION_URAD)


def _f(v: float) -> float | None:
    v = float(v)
    return float(f"{v:.7g}") if math.isfinite(v) else None


def _r(a: ArrayLike) -> list[float]:
    return [float(f"{float(v):.7g}") for v in np.asarray(a).reshape(-1)]
