"""A parameter over the calibrations of one machine: values with their U.

Parameter names (``docs/history.md``): a stored result (``X.A`` for the first linear
test of X, ``linear-x1.R``, ``diag-ppp.range`` ..., ``V.E_VXYZ`` for a volumetric index,
``EC0Y`` for a squareness) or an identified function at a position, ``EXX@400``
(value and U = 2 u from the model's covariance at 400 mm of X). The figure of a trend is
:func:`volcal.plot.trend.trend_plot`'s.
"""

from __future__ import annotations

import re
from typing import Any

from volcal.errors import VolcalInputError

_AT = re.compile(r"^(E[XYZABC][XYZ])@(-?[0-9.]+)$", re.IGNORECASE)


def trend(history: Any, machine: str, parameter: str) -> list[dict[str, Any]]:
    """Rows ``id, date, value, U, unit`` of one parameter, by date of measurement.

    Parameters
    ----------
    history : History
        The store.
    machine : str
        Machine record id or name.
    parameter : str
        See the module docstring.

    Raises
    ------
    VolcalInputError
        Unknown parameter (the valid names of the latest calibration are listed), or a
        position outside the travel of a calibration's model.
    """
    with history.store.reading():  # one connection for the records and their files
        return _trend(history, machine, parameter)


def _trend(history: Any, machine: str, parameter: str) -> list[dict[str, Any]]:
    """:func:`trend` inside one reading connection."""
    from volcal.history.compare import load_record_model

    cals = history.calibrations(machine)
    if not cals:
        raise VolcalInputError(f"no calibration of {machine!r} in the history")
    m = _AT.match(parameter.strip())
    rows = []
    if m:
        import numpy as np

        from volcal.model.names import COMPONENT_NAMES

        name, pos = m.group(1).upper(), float(m.group(2))
        if name not in COMPONENT_NAMES:
            raise VolcalInputError(f"--parameter {parameter}: {name} is not one of "
                                   f"{', '.join(COMPONENT_NAMES)}")
        unit = "urad" if name[1] in "ABC" else "um"
        for r in cals:
            model = load_record_model(history.store, r.id, r)
            if model is None:
                rows.append({"id": r.id, "date": r.date, "value": None, "U": None, "unit": unit})
                continue
            _within_travel(model, name, pos, parameter, r.id)
            v = float(model.errors.function(name, np.array([pos]))[0])
            u = float(model.function_std(name, np.array([pos]))[0])
            rows.append({"id": r.id, "date": r.date, "value": v, "U": 2.0 * u, "unit": unit})
        return rows
    names = set().union(*(r.results for r in cals))
    if parameter not in names:
        known = sorted(cals[-1].results)
        raise VolcalInputError(f"--parameter {parameter!r} is no stored result of {machine}; "
                               f"valid: {', '.join(known[:60])}"
                               f"{' ...' if len(known) > 60 else ''}, or a function at a "
                               "position such as EXX@400")
    for r in cals:
        v = r.results.get(parameter)
        rows.append({"id": r.id, "date": r.date, "value": None if v is None else v["value"],
                     "U": None if v is None else v["U"],
                     "unit": "" if v is None else v["unit"]})
    return rows


def axis_lines_note(history: Any, rows: list[dict[str, Any]], parameter: str) -> str | None:
    """Which test an axis' result is (``X.A``: the first X line's), when there are others.

    Parameters
    ----------
    history : History
        The store.
    rows : list of dict
        The trend's rows (:func:`trend`); the newest record is read.
    parameter : str
        The parameter trended.

    Returns
    -------
    str or None
        ``"X.A is the first X line's (linear-x1); C000004 has 3 X lines: --parameter
        linear-x2.A, linear-x3.A for the others"`` (the newest calibration of the rows),
        or None (not an axis' result, or one line only).
    """
    m = re.fullmatch(r"([XYZABC])\.(\w+)", parameter)
    if m is None or not rows:
        return None
    axis, p = m.group(1), m.group(2)
    results = history.store.current(rows[-1]["id"]).results
    pat = re.compile(rf"((?:linear|rotary)-{axis.lower()}\d+)\.{re.escape(p)}")
    lines = sorted(n for n in results if pat.fullmatch(n))
    if len(lines) < 2:
        return None
    mine = next((n for n in lines if results[n].get("value") == results[parameter]["value"]),
                lines[0]) if parameter in results else lines[0]
    others = [n for n in lines if n != mine]
    return (f"{parameter} is the first {axis} line's ({mine.split('.')[0]}); "
            f"{rows[-1]['id']} has {len(lines)} {axis} lines: --parameter "
            + ", ".join(others) + " for the others")


def _within_travel(model: Any, name: str, pos: float, parameter: str, rid: str) -> None:
    """Refuse a position outside the identified travel of the function's axis [mm].

    The functions are identified between the first and last node of their axis; beyond,
    the value would be the end value held constant, not a measurement.
    """
    axis = "XYZ".index(name[2])
    nodes = model.errors.nodes[axis]
    lo, hi = float(nodes[0]), float(nodes[-1])
    if not lo - 1e-9 <= pos <= hi + 1e-9:
        raise VolcalInputError(f"--parameter {parameter}: {pos:g} mm is outside the travel "
                               f"of {name[2]} in {rid} ({lo:g} to {hi:g} mm)")
