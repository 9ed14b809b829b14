"""Gather what the report shows: evaluate a session to the standards around its model.

This is the thin glue between the analysis modules and the report document: ISO 230-2
for every linear test with runs and directions, ISO 230-6 for every diagonal, the
volumetric indices and seed 002's ELv of the identified machine, and the simulated truth
when the session has one.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.report.sections import ReportInputs
from volcal.session.errortable import read_error_table
from volcal.session.format import Session

__all__ = ["CompensationSummary", "collect_inputs", "compensation_summary", "read_truth"]


@dataclass(frozen=True)
class CompensationSummary:
    """What compensation tables were written and what they can achieve.

    Attributes
    ----------
    folder : Path or None
        Folder of the tables (with ``volcal-compensation.toml``), if written.
    manifest : dict
        The folder's manifest: controller format, sign, spacing, files.
    model_max_um : float
        Largest length of the modelled volumetric error over the work zone [um].
    residual_u2_max_um : float
        Largest expanded uncertainty (k = 2) of the modelled volumetric error [um]: what a
        perfect application of the tables leaves, at 95 %.
    truth_max_um, truth_residual_max_um, truth_residual_rms_um : float or None
        Simulated sessions only: largest true volumetric error, and the largest and RMS
        length of true minus modelled error (the error left after compensation) [um].
    n : int
        Grid points per axis of the evaluation.
    """

    folder: Path | None
    manifest: dict[str, Any]
    model_max_um: float
    residual_u2_max_um: float
    truth_max_um: float | None
    truth_residual_max_um: float | None
    truth_residual_rms_um: float | None
    n: int


def compensation_summary(result: Any, travel: Any, truth: MachineErrors | None = None,
                         folder: str | Path | None = None, n: int = 11) -> CompensationSummary:
    """Summarise the compensation of a model: files written and the error it leaves.

    Parameters
    ----------
    result : IdentificationResult
        The identified model (``predict`` gives the volumetric error and its uncertainty).
    travel : array_like, shape (3, 2)
        Work zone [mm].
    truth : MachineErrors, optional
        Simulated truth.
    folder : str or Path, optional
        Compensation folder written by ``volcal compensate`` (its manifest is read).
    n : int
        Grid points per axis.

    Returns
    -------
    CompensationSummary

    Raises
    ------
    VolcalInputError
        If ``folder`` has no readable ``volcal-compensation.toml``.
    """
    import tomllib

    from volcal.compensate.formats import MANIFEST
    from volcal.model.kinematics import volumetric_error

    manifest: dict[str, Any] = {}
    if folder is not None:
        folder = Path(folder)
        path = folder / MANIFEST
        if not path.is_file():
            raise VolcalInputError(f"no {MANIFEST} here (is it a volcal compensation folder?)",
                                   folder)
        try:
            manifest = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise VolcalInputError(f"invalid TOML: {exc}", path) from None
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    g = np.meshgrid(*[np.linspace(lo, hi, n) for lo, hi in t], indexing="ij")
    q = np.stack([a.ravel() for a in g], axis=1)
    e, u = result.predict(q)
    tmax = tres = trms = None
    if truth is not None:
        et = volumetric_error(truth, q)
        r = np.linalg.norm(et - e, axis=1)
        tmax = float(np.linalg.norm(et, axis=1).max())
        tres = float(r.max())
        trms = float(np.sqrt(np.mean(r**2)))
    return CompensationSummary(None if folder is None else Path(folder), manifest,
                               float(np.linalg.norm(e, axis=1).max()),
                               float(2.0 * np.linalg.norm(u, axis=1).max()), tmax, tres, trms,
                               n)


def read_truth(session: Session) -> MachineErrors | None:
    """Read the simulated truth ``SESSION/truth/machine.csv`` if there is one.

    Parameters
    ----------
    session : Session
        A session read from disk.

    Returns
    -------
    MachineErrors or None
    """
    if session.path is None:
        return None
    path = session.path / "truth" / "machine.csv"
    return read_error_table(path, chain=session.chain) if path.is_file() else None


def collect_inputs(session: Session, result: Any = None, truth: MachineErrors | None = None,
                   edition: str = "2014", compensation: str | Path | None = None
                   ) -> ReportInputs:
    """Evaluate the session and its model for the report.

    Parameters
    ----------
    session : Session
        Measured session.
    result : IdentificationResult, optional
        Identified model (from ``volcal.identify`` or a model file).
    truth : MachineErrors, optional
        Simulated truth; read from the session folder when omitted.
    edition : str
        ISO 230-2 edition.
    compensation : str or Path, optional
        Folder of compensation tables written from ``result``.

    Returns
    -------
    ReportInputs
    """
    from volcal.standards.session import evaluate_session

    ev = evaluate_session(session, result, edition)
    if truth is None:
        truth = read_truth(session)
    comp = None
    if result is not None:
        comp = compensation_summary(result, session.travel, truth, compensation)
    return ReportInputs(session, result, truth, ev.iso230_2 or None, ev.iso230_6 or None,
                        ev.volumetric, comp, elv=ev.elv)
