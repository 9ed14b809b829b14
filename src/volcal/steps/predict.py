"""Step ``predict``: the volumetric error and its uncertainty at points (``volcal predict``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from volcal import defaults as D
from volcal.errors import ParameterError, VolcalInputError
from volcal.steps import _checks

if TYPE_CHECKING:
    from volcal.identify.result import IdentificationResult

__all__ = ["Prediction", "predict", "read_points"]

COLUMNS = ("x_mm", "y_mm", "z_mm", "ex_um", "ey_um", "ez_um", "ux_um", "uy_um", "uz_um")
"""The columns of ``volcal predict``'s CSV."""


@dataclass(frozen=True)
class Prediction:
    """What :func:`predict` computed.

    Attributes
    ----------
    points : ndarray, shape (n, 3)
        The points [mm].
    error_um : ndarray, shape (n, 3)
        Volumetric error ex, ey, ez [um].
    u_um : ndarray, shape (n, 3)
        Its standard uncertainty ux, uy, uz [um].
    warnings : tuple of str
        The differences between the model's session and ``session`` (``force=True``).
    """

    points: np.ndarray
    error_um: np.ndarray
    u_um: np.ndarray
    warnings: tuple[str, ...] = ()

    def to_csv(self) -> str:
        """The CSV of ``volcal predict``.

        Returns
        -------
        str
            :data:`COLUMNS`; 6 significant digits for the points [mm], 4 decimals for the
            errors and uncertainties [um].
        """
        import csv
        import io

        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(COLUMNS)
        for i in range(self.points.shape[0]):
            w.writerow([f"{v:.6g}" for v in self.points[i]]
                       + [f"{v:.4f}" for v in self.error_um[i]]
                       + [f"{v:.4f}" for v in self.u_um[i]])
        return buf.getvalue()


def read_points(path: str | Path) -> np.ndarray:
    """The points CSV ``x_mm,y_mm,z_mm`` [mm] (:func:`volcal.io.table.read_table`).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    ndarray, shape (n, 3)
    """
    from volcal.io.table import Column, TableSpec, read_table

    spec = TableSpec(tuple(Column(c, abs_max=1e7) for c in ("x_mm", "y_mm", "z_mm")),
                     min_rows=0, what="points file")
    t = read_table(path, spec)
    if len(t) == 0:
        raise VolcalInputError("no points", path, 2)
    return np.stack([t[c].astype(float) for c in ("x_mm", "y_mm", "z_mm")], axis=1)


def predict(model: str | Path | IdentificationResult, points: str | Path | ArrayLike, *,
            tool_offset: ArrayLike = D.TOOL_OFFSET_MM, session: str | Path | None = None,
            force: bool = False) -> Prediction:
    """Predict the volumetric error and its uncertainty at points inside the travel.

    Parameters
    ----------
    model : str, Path or IdentificationResult
        The model file (``MODEL.json``) or a model.
    points : str, Path or array_like, shape (n, 3)
        A CSV with ``x_mm,y_mm,z_mm`` or the points [mm]; every point inside the model's
        travel (no extrapolation).
    tool_offset : array_like, shape (3,)
        Tool offset x, y, z [mm].
    session : str or Path, optional
        Session folder the model should belong to: refused if name, chain, travel or
        readings differ.
    force : bool
        With ``session``: use the model even if it was identified from another session.

    Returns
    -------
    Prediction
    """
    from volcal.identify import load_model
    from volcal.identify.modelfile import check_model_file_session, check_model_session

    offset = _checks.vector("tool_offset", tool_offset)
    m = load_model(model) if isinstance(model, str | Path) else model
    m.require_uncertainty("volcal predict (its columns ux_um, uy_um, uz_um)",
                          model if isinstance(model, str | Path) else None)
    if isinstance(model, str | Path):
        warnings = check_model_file_session(model, session, force)
    elif session is not None:
        from volcal.session.format import read_session

        warnings = check_model_session(m, read_session(session, require_deviation=False),
                                       force)
    else:
        warnings = []
    file = points if isinstance(points, str | Path) else None
    q = read_points(points) if isinstance(points, str | Path) else _points(points)
    travel = m.errors.travel
    for j, col in enumerate(("x_mm", "y_mm", "z_mm")):
        out = np.flatnonzero((q[:, j] < travel[j, 0] - 1e-9) | (q[:, j] > travel[j, 1] + 1e-9))
        if out.size:
            raise VolcalInputError(f"{q[out[0], j]:g} mm is outside the model's travel "
                                   f"{travel[j, 0]:g}..{travel[j, 1]:g} mm (no extrapolation)",
                                   file, int(out[0]) + 2 if file is not None else None,
                                   col if file is not None else None)
    e, u = m.predict(q, offset)
    return Prediction(q, np.asarray(e), np.asarray(u), tuple(warnings))


def _points(points: ArrayLike) -> np.ndarray:
    """Points given as an array, checked: (n, 3) finite [mm]."""
    try:
        q = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        q = np.empty((0, 0))
    if q.ndim == 1 and q.size == 3:
        q = q.reshape(1, 3)
    if q.ndim != 2 or q.shape[1] != 3 or q.shape[0] == 0 or not np.all(np.isfinite(q)):
        raise ParameterError(f"{{points}} of shape {q.shape}: expected finite points x, y, z "
                             "[mm], shape (n, 3)")
    return q
