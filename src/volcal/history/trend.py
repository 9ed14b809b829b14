"""A parameter over the calibrations of one machine: values with their U.

Parameter names (``docs/history.md``): a stored result (``X.A`` for the first linear
test of X, ``linear-x1.R``, ``diag-ppp.range`` ..., ``V.E_VXYZ`` for a volumetric index,
``EC0Y`` for a squareness) or an identified function at a position, ``EXX@400``
(value and U = 2 u from the model's covariance at 400 mm of X).
"""

from __future__ import annotations

import re
from typing import Any

from volcal.errors import VolcalInputError

_AT = re.compile(r"^(E[XYZABC][XYZ])@(-?[0-9.]+)$", re.IGNORECASE)


def trend(history: Any, machine: str, parameter: str) -> list[dict[str, Any]]:
    """Rows ``id, date, value, U, unit`` of one parameter, oldest first.

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
        Unknown parameter (the valid names of the latest calibration are listed).
    """
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
            model = load_record_model(history.store, r.id)
            if model is None:
                rows.append({"id": r.id, "date": r.date, "value": None, "U": None, "unit": unit})
                continue
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


def plot_trend(rows: list[dict[str, Any]], parameter: str, machine: str, path: Any) -> None:
    """Write the trend as a figure (value with its U as error bars), atomically.

    Parameters
    ----------
    rows : list of dict
        What :func:`trend` returns.
    parameter : str
        Parameter name (axis label).
    machine : str
        Machine (title).
    path : str or Path
        Figure file; the format from its suffix.
    """
    import matplotlib

    matplotlib.use("Agg")
    import datetime as _dt

    import matplotlib.pyplot as plt

    from volcal.io.atomic import atomic_path

    pts = [r for r in rows if r["value"] is not None]
    fig, ax = plt.subplots(figsize=(6.5, 3.2))
    x = [_dt.date.fromisoformat(r["date"][:10]) for r in pts]
    y = [r["value"] for r in pts]
    e = [0.0 if r["U"] is None else r["U"] for r in pts]
    ax.errorbar(x, y, yerr=e, marker="o", capsize=3)
    unit = pts[0]["unit"].replace("um", "µm").replace("urad", "µrad") if pts else ""
    ax.set_ylabel(f"{parameter} [{unit}]")
    ax.set_title(f"{machine}: {parameter} (bars: U, k = 2)")
    fig.autofmt_xdate()
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=str(path).rsplit(".", 1)[-1].lower())
    plt.close(fig)
