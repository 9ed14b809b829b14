"""Results as tables: lists of plain row dicts, and pandas DataFrames when pandas is there.

Every result of the flow that is a table (the identified error functions, the ISO 230-2
per-target statistics, the ISO 230-6 diagonals, the indices of a session) has
``to_rows()`` (a list of dicts, one per row, column names with their unit:
``position_mm``, ``mean_um``...) and ``to_dataframe()``, built from the same rows.
pandas is optional (``pip install volcal[dataframe]``) and imported only inside
:func:`to_dataframe`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from volcal.errors import VolcalInputError

if TYPE_CHECKING:
    import pandas

    from volcal.identify.result import IdentificationResult
    from volcal.standards.iso230_2 import Iso2302Result
    from volcal.standards.iso230_6 import DiagonalResult
    from volcal.standards.session import SessionEvaluation

Row = dict[str, Any]

__all__ = ["diagonal_row", "identified_rows", "iso230_2_rows", "session_rows", "to_dataframe"]


def to_dataframe(rows: list[Row], what: str) -> pandas.DataFrame:
    """A pandas DataFrame of the rows (pandas imported here, on first use).

    Parameters
    ----------
    rows : list of dict
        One dict per row, the same keys in every row.
    what : str
        Name of the result, for the message when pandas is missing.

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    VolcalInputError
        pandas is not installed (``to_rows()`` gives the same table without it).
    """
    try:
        import pandas as pd
    except ImportError:
        raise VolcalInputError(f"{what}.to_dataframe() needs pandas (pip install pandas, or "
                               "volcal[dataframe]); to_rows() gives the same table as a list "
                               "of dicts") from None
    return pd.DataFrame(rows)


def _f(v: Any) -> float:
    return float("nan") if v is None else float(v)


def identified_rows(result: IdentificationResult) -> list[Row]:
    """The identified error functions, one row per function and node.

    Parameters
    ----------
    result : IdentificationResult

    Returns
    -------
    list of dict
        ``function`` (ISO 230-1 name, e.g. ``'EXX'``), ``axis`` (moving axis),
        ``position_mm`` [mm] (NaN for the three squareness errors), ``value`` and its
        standard uncertainty ``u`` in ``unit`` (``'um'`` for translations, ``'urad'``
        for rotations and squareness). Components in the order of
        :data:`volcal.model.names.COMPONENT_NAMES`, then EC0Y, EB0Z, EA0Z.
    """
    from volcal.model.names import AXES, COMPONENT_NAMES, SQUARENESS_NAMES

    rows: list[Row] = []
    for k in range(3):
        nodes = result.layout.nodes[k]
        for c in range(6):
            name = COMPONENT_NAMES[6 * k + c]
            unit = "um" if c < 3 else "urad"
            for i, q in enumerate(nodes):
                rows.append({"function": name, "axis": AXES[k], "position_mm": float(q),
                             "value": float(result.errors.values[k][i, c]),
                             "u": float(result.std[k][i, c]), "unit": unit})
    for j, name in enumerate(SQUARENESS_NAMES):
        rows.append({"function": name, "axis": "", "position_mm": math.nan,
                     "value": float(result.errors.squareness[j]),
                     "u": float(result.squareness_std[j]), "unit": "urad"})
    return rows


_TARGET_KEYS = (("target_mm", "target_mm"), ("mean_up", "mean_up_um"),
                ("mean_down", "mean_down_um"), ("mean", "mean_um"), ("s_up", "s_up_um"),
                ("s_down", "s_down_um"), ("B", "B_um"), ("R_up", "R_up_um"),
                ("R_down", "R_down_um"), ("R", "R_um"))


def iso230_2_rows(res: Iso2302Result) -> list[Row]:
    """ISO 230-2 per-target statistics, one row per target.

    Parameters
    ----------
    res : Iso2302Result

    Returns
    -------
    list of dict
        ``target_mm`` [mm]; ``n_up``, ``n_down`` (runs that reached the target: fewer
        than planned where a capture was missed); ``mean_up_um``, ``mean_down_um``,
        ``mean_um`` (mean unidirectional and bidirectional positional deviations),
        ``s_up_um``, ``s_down_um``, ``B_um`` (reversal), ``R_up_um``, ``R_down_um``,
        ``R_um`` (repeatability) [um]; NaN where a target has too few runs.
    """
    t = res.targets
    nu, nd = t.counts()
    rows = []
    for i in range(t.target_mm.size):
        row: Row = {"target_mm": float(t.target_mm[i]), "n_up": int(nu[i]),
                    "n_down": int(nd[i])}
        row.update({new: float(getattr(t, old)[i]) for old, new in _TARGET_KEYS[1:]})
        rows.append(row)
    return rows


_AXIS_PARAMS = ("A", "A_up", "A_down", "E", "E_up", "E_down", "M", "R", "R_up", "R_down",
                "B", "B_mean")


def _axis_row(res: Iso2302Result) -> Row:
    return {f"{k}_um": float(getattr(res, k)) for k in _AXIS_PARAMS}


def diagonal_row(res: DiagonalResult) -> Row:
    """One ISO 230-6 diagonal as a row.

    Parameters
    ----------
    res : DiagonalResult

    Returns
    -------
    dict
        ``id``, ``diagonal``, ``plane`` ('' for a body diagonal), ``length_mm`` [mm],
        ``points_measured``, ``points_planned``, ``complete`` (an incomplete diagonal is
        left out of the largest E_D), ``E_D_um``, ``max_abs_um`` and ``R_um`` (ISO 230-2
        repeatability along the diagonal, NaN without bidirectional runs) [um].
    """
    return {"id": res.id, "diagonal": res.diagonal, "plane": res.plane or "",
            "length_mm": float(res.length_mm), "points_measured": res.points_measured,
            "points_planned": res.points_planned, "complete": res.complete,
            "E_D_um": float(res.E_D), "max_abs_um": float(res.max_abs_um),
            "R_um": math.nan if res.iso230_2 is None else float(res.iso230_2.R)}


SESSION_TABLES = ("iso230-2", "iso230-6")
"""Tables of a :class:`~volcal.standards.session.SessionEvaluation`."""


def session_rows(ev: SessionEvaluation, table: str = "iso230-2") -> list[Row]:
    """The indices of a session evaluation, one row per measurement.

    Parameters
    ----------
    ev : SessionEvaluation
    table : str
        ``'iso230-2'``: one row per linear test, ``id``, ``axis``, ``complete`` (False
        when a capture was missed) and the axis parameters ``A_um`` ... ``B_mean_um``
        [um]; ``'iso230-6'``: one row per diagonal (:func:`diagonal_row`).

    Returns
    -------
    list of dict

    Raises
    ------
    VolcalInputError
        Unknown ``table``.
    """
    if table == "iso230-2":
        return [{"id": k, "axis": ev.axis.get(k, ""), "complete": r.complete, **_axis_row(r)}
                for k, r in ev.iso230_2.items()]
    if table == "iso230-6":
        return [diagonal_row(r) for r in ev.iso230_6.values()]
    raise VolcalInputError(f"table {table!r}: expected one of {', '.join(SESSION_TABLES)}")
