"""Argument checks of the Python API (:class:`volcal.Calibration`).

Every mistake in a call becomes a :class:`~volcal.errors.VolcalInputError` that names the
valid choices, as on the command line: :func:`checked` wraps a method so that an unknown
keyword names the closest valid one and lists them all; the converters accept numbers,
arrays or the command line's text (``'0:800,0:600,0:500'``, ``'x,y,z'``).
"""

from __future__ import annotations

import difflib
import functools
import inspect
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, ParamSpec, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import ParameterError, VolcalInputError

if TYPE_CHECKING:
    from volcal.standards.tolerance import Tolerance
    from volcal.uncertainty.budget import Budget

__all__ = ["acceptance", "budget_file", "checked", "names", "python_names", "python_text",
           "tolerance_text", "travel_mm", "unknown_option", "vector_mm"]

P = ParamSpec("P")
R = TypeVar("R")


def names(valid: Sequence[str]) -> str:
    """The valid choices, comma-separated, for a message.

    Parameters
    ----------
    valid : sequence of str

    Returns
    -------
    str
    """
    return ", ".join(valid)


def unknown_option(where: str, key: str, valid: Sequence[str]) -> VolcalInputError:
    """The error of an unknown keyword: the closest valid name and all of them.

    Parameters
    ----------
    where : str
        The method (``'Calibration.simulate'``).
    key : str
        The keyword given.
    valid : sequence of str
        The keywords the method takes.

    Returns
    -------
    VolcalInputError
    """
    close = difflib.get_close_matches(key, valid, n=1, cutoff=0.5)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return VolcalInputError(f"{where}: unknown option {key!r}{hint}; valid options: "
                            f"{names(valid)}")


def checked(func: Callable[P, R]) -> Callable[P, R]:
    """Turn a call that does not fit ``func``'s signature into a VolcalInputError.

    An unknown keyword, a missing required argument or one given twice names the
    method and lists its valid options (with the closest name), instead of Python's
    ``TypeError``; a value of another kind than its default (:func:`check_kinds`: text
    for a number, a fraction for a whole number...) is refused the same way. A step's
    :class:`~volcal.errors.ParameterError` (:mod:`volcal.steps`) names the keyword after
    the method.

    Parameters
    ----------
    func : callable
        A method of :class:`volcal.Calibration`; its signature is kept
        (``inspect.signature`` of the wrapper is the method's).

    Returns
    -------
    callable
    """
    sig = inspect.signature(func)
    params = [p for p in sig.parameters.values()
              if p.name not in ("self", "cls") and p.kind not in (p.VAR_KEYWORD,
                                                                   p.VAR_POSITIONAL)]
    valid = [p.name for p in params]
    takes_var = any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values())
    where = f"Calibration.{func.__name__}"
    defaults = {p.name: p.default for p in params if p.default is not p.empty}

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        if not takes_var:
            for key in kwargs:
                if key not in valid:
                    raise unknown_option(where, key, valid)
        try:
            bound = sig.bind(*args, **kwargs)
        except TypeError as exc:
            need = [p.name for p in params if p.default is p.empty]
            raise VolcalInputError(f"{where}: {exc}; required: {names(need) or 'none'}; "
                                   f"valid options: {names(valid)}") from None
        check_kinds(where, {k: v for k, v in bound.arguments.items() if k in defaults},
                    defaults)
        try:
            return func(*args, **kwargs)
        except ParameterError as exc:  # a step's parameter: the keyword, with the method
            raise exc.spelled({}, f"{where}: ") from None

    return wrapper


def travel_mm(travel: ArrayLike | str) -> NDArray[np.float64]:
    """Travel limits [mm] as a (3, 2) array.

    Parameters
    ----------
    travel : array_like, shape (3, 2), or str
        ``[[xmin, xmax], [ymin, ymax], [zmin, zmax]]`` [mm] or the command line's text
        ``'0:800,0:600,0:500'``.

    Returns
    -------
    ndarray, shape (3, 2)

    Raises
    ------
    VolcalInputError
        Not numbers, another shape, or a range without finite max > min.
    """
    try:
        if isinstance(travel, str):  # the command line's text
            travel = [[float(v) for v in p.split(":")] for p in travel.split(",")]
        t = np.asarray(travel, dtype=float)
    except (TypeError, ValueError):
        raise VolcalInputError(f"travel {travel!r}: expected [[xmin, xmax], [ymin, ymax], "
                               "[zmin, zmax]] in mm") from None
    if t.shape != (3, 2):
        raise VolcalInputError(f"travel of shape {t.shape}: expected [[xmin, xmax], [ymin, "
                               "ymax], [zmin, zmax]] in mm (shape (3, 2))")
    if not np.all(np.isfinite(t)) or np.any(t[:, 1] <= t[:, 0]):
        raise VolcalInputError(f"travel {t.tolist()}: every range needs finite max > min [mm]")
    return t


def vector_mm(v: ArrayLike | str, what: str) -> tuple[float, float, float]:
    """Three finite numbers x, y, z [mm].

    Parameters
    ----------
    v : array_like, shape (3,), or str
        The vector or the command line's text ``'x,y,z'``.
    what : str
        The keyword, for the message.

    Returns
    -------
    tuple of 3 float
    """
    try:
        a = np.asarray(v.split(",") if isinstance(v, str) else v, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        a = np.array([])
    if a.size != 3 or not np.all(np.isfinite(a)):
        raise VolcalInputError(f"{what} {v!r}: expected three finite numbers x, y, z [mm]")
    return float(a[0]), float(a[1]), float(a[2])


def tolerance_text(tolerance_um: float | str | Mapping[str, float]) -> str:
    """A tolerance [um] as the command line's ``--tolerance-um`` text.

    Parameters
    ----------
    tolerance_um : float, str or dict
        ``15``, ``'X=10,Y=10,Z=8'`` or ``{'X': 10, 'V': 15}`` [um].

    Returns
    -------
    str
    """
    if isinstance(tolerance_um, Mapping):
        return ",".join(f"{k}={v}" for k, v in tolerance_um.items())
    return str(tolerance_um)


def check_kinds(where: str, values: Mapping[str, object],
                defaults: Mapping[str, object]) -> None:
    """Check that every value is of its default's kind (bool, whole number, number).

    Parameters
    ----------
    where : str
        The method, for the message.
    values : mapping of str to object
        The keywords given.
    defaults : mapping of str to object
        The defaults of the option class; a value whose default is None or of another
        kind (text, tuples, dicts) is left to the option class to check.

    Raises
    ------
    VolcalInputError
        A bool option given something else than True/False, a whole-number option a
        fraction or text, a number option text or a non-finite number.
    """
    for key, v in values.items():
        d = defaults.get(key)
        if isinstance(d, bool):
            if not isinstance(v, bool | np.bool_):
                raise VolcalInputError(f"{where}: {key}={v!r}: expected True or False")
        elif isinstance(d, int):
            if isinstance(v, bool) or not isinstance(v, int | np.integer):
                raise VolcalInputError(f"{where}: {key}={v!r}: expected a whole number")
        elif isinstance(d, float):
            if isinstance(v, bool) or not isinstance(v, int | float | np.number) or \
                    not np.isfinite(v):
                raise VolcalInputError(f"{where}: {key}={v!r}: expected a finite number")


def budget_file(budget: str | Path | Budget, where: str) -> tuple[Budget, str]:
    """An uncertainty budget and the name recorded for it (the ``--budget`` option).

    :func:`volcal.steps._checks.budget`, the check behind both faces, its message
    naming the method.

    Parameters
    ----------
    budget : str, Path or Budget
        The budget file (TOML, ``volcal budget --template``), read and checked by
        :func:`volcal.uncertainty.budget.read_budget`, or a budget already read
        (:func:`volcal.uncertainty.budget.parse_budget`).
    where : str
        The method, for the message.

    Returns
    -------
    budget : Budget
    label : str
        The file as given (recorded in the model file and in ``truth/systematic.toml``,
        as by the command line), or the budget's own ``file``.
    """
    from volcal.steps._checks import budget as checked

    try:
        return checked(budget)
    except ParameterError as exc:
        raise exc.spelled({}, f"{where}: ") from None


def acceptance(where: str, tolerance: Tolerance | None, decision_rule: str,
               guard_band_um: float | None, budget: str | Path | Budget | None
               ) -> Tolerance | None:
    """The tolerance with its decision rule, guard band and budget, checked.

    :func:`volcal.steps._checks.acceptance`, the one check behind both faces; its
    :class:`~volcal.errors.ParameterError` names the keywords after the method.

    Parameters
    ----------
    where : str
        The method, for the messages.
    tolerance : Tolerance or None
        :func:`volcal.standards.tolerance.parse_tolerance` of ``tolerance_um``.
    decision_rule : str
        ``'simple'`` or ``'guarded'`` (:data:`volcal.standards.decision.RULES`).
    guard_band_um : float or None
        Guard band w of the guarded rule [um] (default: U of each parameter).
    budget : str, Path, Budget or None
        Uncertainty budget: U of the ISO 230-2 parameters, the guarded rule's guard band.

    Returns
    -------
    Tolerance or None
        None without a tolerance (then the rule must be ``'simple'``).
    """
    from volcal.steps._checks import acceptance as checked

    try:
        return checked(tolerance, decision_rule, guard_band_um, budget)
    except ParameterError as exc:
        raise exc.spelled({}, f"{where}: ") from None


#: The command line's option spellings in the library's messages, and their keywords.
_CLI_SPELLING: tuple[tuple[str, str], ...] = (
    ("--tables names", "tables= names"),
    ("give --as-left SESSION2 too", "give as_left= (the second session) too"),
    ("--strict applies", "strict=True applies"),
    ("(or give --certificate)", "(or give certificate=True)"),
    ("--as-left: the sessions", "as_left=: the sessions"),
    ("--decision-rule guarded", "decision_rule='guarded'"),
    ("--decision-rule", "decision_rule"),
    ("--guard-band-um W", "guard_band_um=W"),
    ("--guard-band-um", "guard_band_um"),
    ("--budget FILE", "budget=FILE"),
    ("--budget", "budget"),
    ("--tolerance-um", "tolerance_um"),
    ("--model MODEL.json", "the model (identify() or load_model())"),
    ("--compensation", "compensation"),
    ("--as-left", "as_left"),
    ("--tables", "tables"),
    ("--strict", "strict"),
    ("--force", "force=True"),
)


def python_text(text: str) -> str:
    """A library message or warning with the command line's options as Python keywords.

    Parameters
    ----------
    text : str
        E.g. ``'--force: the compensation tables ... were written for another machine'``.

    Returns
    -------
    str
        E.g. ``'force=True: the compensation tables ...'``.
    """
    for cli, py in _CLI_SPELLING:
        text = text.replace(cli, py)
    return text


@contextmanager
def python_names(where: str) -> Iterator[None]:
    """Re-raise a library's :class:`VolcalInputError` with the Python keywords.

    The library names the command line's options in some messages (``--budget FILE``);
    inside this context they become the keywords of the method (``budget=FILE``), and
    the message starts with the method's name.

    Parameters
    ----------
    where : str
        The method (``'Calibration.verdict'``).
    """
    try:
        yield
    except VolcalInputError as exc:
        msg, column = exc.message, exc.column
        if not any(cli in msg or cli == column for cli, _ in _CLI_SPELLING):
            raise
        column = dict(_CLI_SPELLING).get(column, column) if column else column
        raise VolcalInputError(f"{where}: {python_text(msg)}", exc.file, exc.row,
                               column) from None
