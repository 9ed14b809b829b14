"""Checks of step parameters: each raises a :class:`~volcal.errors.ParameterError`."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from volcal.errors import ParameterError

if TYPE_CHECKING:
    from volcal.model.errorfunctions import MachineErrors
    from volcal.session.format import Session
    from volcal.standards.tolerance import Tolerance
    from volcal.uncertainty.budget import Budget


def whole(name: str, value: object) -> int:
    """``value`` as a whole number (not a bool, not a fraction).

    Parameters
    ----------
    name : str
        The parameter.
    value : object

    Returns
    -------
    int
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ParameterError(f"{{{name}=}}{value!r}: expected a whole number")
    return int(value)


def names(name: str, value: str | Sequence[str]) -> list[str]:
    """A list of names from a sequence or comma-separated text.

    Parameters
    ----------
    name : str
        The parameter.
    value : sequence of str, or str

    Returns
    -------
    list of str
    """
    if isinstance(value, str):
        return [s.strip() for s in value.split(",") if s.strip()]
    if not all(isinstance(s, str) for s in value):
        raise ParameterError(f"{{{name}}} {value!r}: expected names (strings)")
    return list(value)


def vector(name: str, value: object) -> np.ndarray:
    """Three finite numbers x, y, z [mm].

    Parameters
    ----------
    name : str
        The parameter.
    value : array_like, shape (3,)

    Returns
    -------
    ndarray, shape (3,)
    """
    try:
        a = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        a = np.array([])
    if a.size != 3 or not np.all(np.isfinite(a)):
        raise ParameterError(f"{{{name}}} {value!r}: expected three finite numbers x, y, z "
                             "[mm]")
    return a


def number(name: str, value: object, low: float | None = None, *, strict: bool = False,
           unit: str = "mm") -> float:
    """A finite number, at least (``strict``: above) ``low``.

    Parameters
    ----------
    name : str
        The parameter.
    value : object
    low : float, optional
        Smallest value allowed.
    strict : bool
        ``low`` itself is not allowed.
    unit : str
        Unit of the value, for the message.

    Returns
    -------
    float
    """
    ok = (not isinstance(value, bool) and isinstance(value, int | float | np.floating | np.integer)
          and bool(np.isfinite(value)))
    if ok and low is not None:
        ok = float(value) > low if strict else float(value) >= low  # type: ignore[arg-type]
    if not ok:
        bound = "" if low is None else f" {'>' if strict else '>='} {low:g}"
        raise ParameterError(f"{{{name}=}}{value!r}: expected a finite number{bound} [{unit}]")
    return float(value)  # type: ignore[arg-type]


def table_machine(errors: MachineErrors, session: Session) -> str | None:
    """How an error table's machine differs from the session's (None: the same).

    Its chain and travel must be the session's; the name may differ (a simulated truth
    is "virtual ...").

    Parameters
    ----------
    errors : MachineErrors
        Read from an error table (``.csv`` with its ``.toml``).
    session : Session

    Returns
    -------
    str or None
        The difference in words (:func:`volcal.session.identity.same_machine`).
    """
    from volcal.compensate.manifest import identity_of_errors
    from volcal.session.identity import MachineIdentity, same_machine

    me = MachineIdentity.of(session)
    mine = identity_of_errors(errors)
    same, why = same_machine(MachineIdentity(me.name, mine.chain, mine.travel_mm), me)
    return None if same else why


def travel(value: object) -> np.ndarray:
    """Travel limits [mm] as a (3, 2) array with finite max > min.

    Parameters
    ----------
    value : array_like, shape (3, 2)

    Returns
    -------
    ndarray, shape (3, 2)
    """
    try:
        t = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{{travel}} {value!r}: expected [[xmin, xmax], [ymin, ymax], "
                             "[zmin, zmax]] in mm") from None
    if t.shape != (3, 2):
        raise ParameterError(f"{{travel}} of shape {t.shape}: expected [[xmin, xmax], [ymin, "
                             "ymax], [zmin, zmax]] in mm (shape (3, 2))")
    if not np.all(np.isfinite(t)) or np.any(t[:, 1] <= t[:, 0]):
        raise ParameterError(f"{{travel}} {t.tolist()}: every range needs finite max > min "
                             "[mm]")
    return t


def unknown(key: str, valid: Sequence[str]) -> ParameterError:
    """The error of an unknown keyword: the closest valid name and all of them.

    Parameters
    ----------
    key : str
        The keyword given.
    valid : sequence of str
        The keywords taken.

    Returns
    -------
    ParameterError
    """
    import difflib

    close = difflib.get_close_matches(key, valid, n=1, cutoff=0.5)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return ParameterError(f"unknown option {key!r}{hint}; valid options: {', '.join(valid)}")


def kinds(values: dict[str, object], defaults: dict[str, object]) -> None:
    """Check that every value is of its default's kind (bool, whole number, number).

    Parameters
    ----------
    values : dict
        Parameter -> value given.
    defaults : dict
        Parameter -> default; a default None or of another kind is not checked here.
    """
    for key, v in values.items():
        d = defaults.get(key)
        if isinstance(d, bool):
            if not isinstance(v, bool | np.bool_):
                raise ParameterError(f"{{{key}=}}{v!r}: expected True or False")
        elif isinstance(d, int):
            if isinstance(v, bool) or not isinstance(v, int | np.integer):
                raise ParameterError(f"{{{key}=}}{v!r}: expected a whole number")
        elif isinstance(d, float):
            if isinstance(v, bool) or not isinstance(v, int | float | np.number) or \
                    not np.isfinite(v):
                raise ParameterError(f"{{{key}=}}{v!r}: expected a finite number")


def budget(value: object) -> tuple[Budget, str]:
    """An uncertainty budget and the name recorded for it.

    Parameters
    ----------
    value : str, Path or Budget
        The budget file (TOML, ``volcal budget --template``) or a budget already read.

    Returns
    -------
    budget : Budget
    label : str
        The file as given, or the budget's own ``file``.
    """
    from pathlib import Path

    from volcal.uncertainty.budget import Budget, read_budget

    if isinstance(value, Budget):
        return value, value.file or "budget"
    if not isinstance(value, str | Path):
        raise ParameterError(f"{{budget=}}{value!r}: expected the path of a budget file "
                             "(TOML, `volcal budget --template`) or a Budget")
    return read_budget(value), str(value)


def acceptance(tolerance: Tolerance | None, decision_rule: str, guard_band_um: float | None,
               budget_value: str | Path | Budget | None) -> Tolerance | None:
    """The tolerance with its decision rule, guard band and budget, checked once.

    Behind both faces: the command line's ``--decision-rule``, ``--guard-band-um``,
    ``--tolerance-um`` and ``--budget`` and :class:`volcal.Calibration`'s keywords; the
    messages name the parameters (:class:`~volcal.errors.ParameterError`), each face
    spells them.

    Parameters
    ----------
    tolerance : Tolerance or None
        :func:`volcal.standards.tolerance.parse_tolerance` of ``tolerance_um``.
    decision_rule : str
        ``'simple'`` or ``'guarded'`` (:data:`volcal.standards.decision.RULES`;
        case-insensitive).
    guard_band_um : float or None
        Guard band w of the guarded rule [um] (default: U of each parameter).
    budget_value : str, Path, Budget or None
        Uncertainty budget: U of the ISO 230-2 parameters, the guarded rule's guard band.

    Returns
    -------
    Tolerance or None
        None without a tolerance (then the rule must be ``'simple'``).

    Raises
    ------
    ParameterError
        An unknown rule, a guard band that is not a finite number >= 0 or given with the
        simple rule, the guarded rule without a tolerance.

    References
    ----------
    ISO 14253-1:2017, decision rules for proving conformity with specifications.
    """
    import math
    from dataclasses import replace

    from volcal.standards.decision import RULES

    valid = ", ".join(RULES)
    if not isinstance(decision_rule, str) or decision_rule.strip().lower() not in RULES:
        raise ParameterError(f"{{decision_rule=}}{decision_rule!r}: expected one of {valid}")
    rule = decision_rule.strip().lower()
    w = guard_band_um
    if w is not None:
        if isinstance(w, bool) or not isinstance(w, int | float) or not math.isfinite(w) \
                or w < 0:
            raise ParameterError(f"{{guard_band_um=}}{w!r}: expected a finite number >= 0 "
                                 "[um]")
        if rule != "guarded":
            raise ParameterError(f"{{guard_band_um}} applies to {{decision_rule=}}'guarded' "
                                 f"(valid rules: {valid})")
    if tolerance is None:
        if rule != "simple":
            raise ParameterError(f"{{decision_rule=}}{rule!r} judges a tolerance: give "
                                 "{tolerance_um} too")
        return None
    b = None if budget_value is None else budget(budget_value)[0]
    return replace(tolerance, rule=rule, guard_band_um=None if w is None else float(w),
                   budget=b)


def output_folder(path: str | Path, what: str, own: Callable[[Path], bool] | None,
                  written: Callable[[Path], Iterable[str]] | None,
                  replace: bool) -> str | None:
    """:func:`volcal.io.paths.prepare_output_folder`, its refusal naming ``replace``.

    Parameters
    ----------
    path : str or Path
        The output folder.
    what : str
        Its kind, for the message (``'program'``).
    own : callable
        True for a folder this step wrote before.
    written : callable
        The files volcal wrote in such a folder.
    replace : bool
        Move the other files into ``backup/<UTC time>/`` instead of refusing.

    Returns
    -------
    str or None
        Where the files were moved, relative to ``path``.
    """
    from volcal.errors import VolcalInputError
    from volcal.io.paths import prepare_output_folder

    try:
        return prepare_output_folder(path, what, own, written=written,
                                     replace=replace, option="{replace=True}")
    except VolcalInputError as exc:
        if "{replace=True}" not in exc.message:
            raise
        raise ParameterError(exc.message, exc.file, exc.row, exc.column) from None
