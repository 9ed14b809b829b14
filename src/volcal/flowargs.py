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
from collections.abc import Callable, Mapping, Sequence
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import VolcalInputError

__all__ = ["checked", "known_functions", "names", "name_list", "tolerance_text", "travel_mm",
           "unknown_option", "vector_mm"]

F = TypeVar("F", bound=Callable[..., object])


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


def checked(func: F) -> F:
    """Turn a call that does not fit ``func``'s signature into a VolcalInputError.

    An unknown keyword, a missing required argument or one given twice names the
    method and lists its valid options (with the closest name), instead of Python's
    ``TypeError``; a value of another kind than its default (:func:`check_kinds`: text
    for a number, a fraction for a whole number...) is refused the same way.

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
    def wrapper(*args: object, **kwargs: object) -> object:
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
        return func(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


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


def name_list(v: str | Sequence[str], what: str) -> list[str]:
    """A list of names.

    Parameters
    ----------
    v : sequence of str, or str
        The names or the command line's comma-separated text.
    what : str
        The keyword, for the message.

    Returns
    -------
    list of str
    """
    if isinstance(v, str):
        return [s.strip() for s in v.split(",") if s.strip()]
    if not all(isinstance(s, str) for s in v):
        raise VolcalInputError(f"{what} {v!r}: expected names (strings)")
    return list(v)


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


def known_functions(known: object, where: str) -> dict[str, tuple[object, ...]]:
    """Check the ``known`` option of :class:`volcal.identify.IdentifyOptions`.

    Parameters
    ----------
    known : dict
        ISO 230-1 name -> ``(positions [mm], values [um or urad])`` or ``(positions,
        values, u)``.
    where : str
        The method, for the message.

    Returns
    -------
    dict
        Upper-case names to tuples.
    """
    from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

    error_names = (*COMPONENT_NAMES, *SQUARENESS_NAMES)
    if not isinstance(known, Mapping):
        raise VolcalInputError(f"{where}: known={known!r}: expected a dict name -> "
                               "(positions [mm], values) or the path of an error table")
    out: dict[str, tuple[object, ...]] = {}
    for name, v in known.items():
        key = str(name).upper()
        if key not in error_names:
            raise VolcalInputError(f"{where}: known[{name!r}]: not an error name; expected "
                                   f"one of {names(error_names)}")
        if not isinstance(v, tuple | list) or len(v) not in (2, 3):
            raise VolcalInputError(f"{where}: known[{name!r}]: expected (positions [mm], "
                                   "values [um or urad]) or (positions, values, u)")
        out[key] = tuple(v)
    return out


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
