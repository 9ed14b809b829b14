"""Gather what the report shows: evaluate a session to the standards around its model.

This is the thin glue between the analysis modules and the report document: ISO 230-2
for every linear test with runs and directions, ISO 230-6 for every diagonal, the
volumetric indices and seed 002's ELv of the identified machine, and the simulated truth
when the session has one.
"""

from __future__ import annotations

from typing import Any

from volcal.model.errorfunctions import MachineErrors
from volcal.report.sections import ReportInputs
from volcal.session.errortable import read_error_table
from volcal.session.format import Session

__all__ = ["collect_inputs", "read_truth"]


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
                   edition: str = "2014") -> ReportInputs:
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

    Returns
    -------
    ReportInputs
    """
    from volcal.standards.iso230_2 import evaluate
    from volcal.standards.iso230_6 import evaluate_diagonal
    from volcal.standards.positioning_data import from_measurement
    from volcal.standards.volumetric import elv_from_model, volumetric_indices

    iso2: dict[str, Any] = {}
    iso6: dict[str, Any] = {}
    for m in session.measurements:
        if m.deviation is None:
            continue
        if m.kind == "linear" and "run" in m.columns and "direction" in m.columns:
            d = from_measurement(m, session.path)
            iso2[m.id] = evaluate(d.targets_mm, d.run, d.direction, d.deviation_um, edition,
                                  file=d.file, rows=d.rows)
        elif m.kind == "diagonal":
            iso6[m.id] = evaluate_diagonal(m, edition)
    vol = elv = None
    if result is not None:
        vol = volumetric_indices(result.errors)
        elv = elv_from_model(result.errors)
    if truth is None:
        truth = read_truth(session)
    return ReportInputs(session, result, truth, iso2 or None, iso6 or None, vol, elv=elv)
