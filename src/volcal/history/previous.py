"""Report section "Previous calibration": the change since the machine's last calibration.

The history builds the section and hands it to the report (``ReportInputs.extra_sections``):
the report never imports the history (docs/architecture.md). Only with
``volcal report S --history DB`` or ``Calibration.report(history=...)``: the report command
and the facade import this module (and with it SQLAlchemy) only then.
The previous calibration is the newest stored calibration of the same machine measured
before this session (:func:`volcal.history.compare.previous_calibration`); the change
test is the history's (:func:`volcal.history.compare.compare_with_model`,
``docs/history.md``): results ``|difference| > U``, identified functions and squareness
one joint chi-square test each at a family-wise level of 5 %.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError
from volcal.history.compare import compare_with_model, previous_and_own
from volcal.history.store import Store
from volcal.history.url import resolve_url
from volcal.report.document import Section, Table

#: ISO 230-2 parameters shown per axis (the directional ones and the per-test duplicates
#: are left to ``volcal history compare``).
_AXIS_KEYS = ("A", "B", "E", "M", "R")


def _shown(name: str) -> bool:
    """Results of the results table: per-axis A, B, E, M, R (also a rotary axis'); V; diagonals."""
    prefix, _, key = name.partition(".")
    if prefix in ("X", "Y", "Z", "A", "B", "C"):  # A, B, C: a rotary axis' first test
        return key in _AXIS_KEYS
    return prefix == "V" or (prefix.startswith("diag") and not key.endswith("_mm"))


def _num(v: float | None, digits: int = 2) -> str:
    return "-" if v is None else f"{v:.{digits}f}"


def _changed(v: bool | None) -> str:
    return {True: "CHANGED", False: "no", None: "not tested"}[v]


def check_history(db: str) -> None:
    """Refuse a ``--history`` SQLite file that does not exist (before any work).

    Parameters
    ----------
    db : str
        URL or SQLite file.

    Raises
    ------
    VolcalInputError
        The file does not exist (a report never creates a history).
    """
    url = resolve_url(db)
    if url.startswith("sqlite:///") and not Path(url[len("sqlite:///"):]).is_file():
        raise VolcalInputError(f"--history {db}: no such history file (volcal history add "
                               "creates one)")


def previous_section(inp: Any, db: str, level: float = 0.05) -> Section:
    """The "Previous calibration" section of a report.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs: ``session`` and ``result`` (the model of this calibration,
        which need not be stored).
    db : str
        The history: URL or SQLite file (as ``volcal history --db``).
    level : float
        Family-wise false-alarm level of the function tests.

    Returns
    -------
    Section
        Id ``previous``.

    Raises
    ------
    VolcalInputError
        The store cannot be opened, or the session matches several machines.
    """
    check_history(db)
    sec = Section("previous", "Previous calibration")
    store = Store(db, create=False)
    try:
        prev, own = previous_and_own(store, inp.session)
        if prev is None:
            sec.paragraphs.append(f"The history ({store.where}) holds no earlier calibration "
                                  f"of {inp.session.name}: nothing to compare with.")
            return sec
        entries = compare_with_model(store, prev.id, inp.session, inp.result, level,
                                     getattr(inp, "evaluation", None))
    finally:
        store.close()
    sec.paragraphs.append(
        f"Previous calibration of this machine in the history ({store.where}): record "
        f"{prev.id}, measured {prev.date}. Change since then (this calibration minus "
        f"{prev.id}): a result has changed when its difference exceeds the expanded "
        f"uncertainty U of the difference (k = 2); each identified error function and "
        f"squareness is tested once over its nodes (chi-square with the covariance of "
        f"the difference) at a family-wise false-alarm level of {level:.0%}.")
    if own is not None and own.as_left_of == prev.id:
        sec.paragraphs.append(
            f"This calibration is stored as the as-left of {prev.id} (measured with the "
            "compensation tables active): the changes below are what the tables corrected "
            "as much as the machine's change; the machine's own change is the next "
            "as-found against this one.")
    funcs = [e for e in entries if e.test == "chi-square"]
    results = [e for e in entries if e.test != "chi-square" and _shown(e.name)]
    changed = [e for e in entries if e.changed]
    if changed:
        sec.warnings.append("changed since " + prev.id + ": "
                            + ", ".join(e.name for e in changed))
    flagged = [e for e in funcs if e.changed]
    if funcs and not flagged:
        sec.paragraphs.append(f"No identified error function or squareness changed "
                              f"({len(funcs)} tested).")
    elif not funcs:
        sec.paragraphs.append(f"Error functions not compared: {prev.id} or this "
                              "calibration has no identified model.")
    if flagged:
        sec.tables.append(Table(
            ["Error", "Largest difference", "U (k=2)", "Unit", "At [mm]", "chi2 / limit"],
            [[e.name, _num(e.difference), _num(e.U), e.unit,
              "-" if e.position_mm is None else f"{e.position_mm:.0f}",
              f"{e.statistic:.1f} / {e.threshold:.1f}"] for e in flagged],
            title=f"Error functions changed since {prev.id}",
            note="Largest difference: at the node of largest change; U: twice its "
                 "standard uncertainty there."))
    undetermined = [e.name for e in funcs if e.changed is None]
    if undetermined:
        sec.paragraphs.append("Not tested (undetermined by either calibration, or no "
                              "covariance): " + ", ".join(undetermined) + ".")
    if results:
        from volcal.standards.iso230_2_rotary import UNITS

        units = getattr(inp, "angle_units", None) or "urad"  # angles in the report's unit
        f = {e.name: UNITS[units] if e.unit == "urad" else 1.0 for e in results}
        sec.tables.append(Table(
            ["Result", "Difference", "U (k=2)", "Unit", "Changed"],
            [[e.name, _num(e.difference * f[e.name]),
              _num(None if e.U is None else e.U * f[e.name]),
              units if e.unit == "urad" else e.unit, _changed(e.changed)]
             for e in results],
            title=f"Results: this calibration minus {prev.id}",
            note="U: expanded uncertainty of the difference, sqrt(U1^2 + U2^2); "
                 "'not tested' where either calibration has no U. Every test's results: "
                 f"store this calibration (volcal history add) and run volcal history "
                 f"compare {prev.id} ID."))
    return sec
