"""Resampling the error model onto a controller's uniform compensation grid.

A controller table holds one value per compensation point on a uniform grid: the start
(or a reference point) and the spacing are parameters of the controller, the values are
the error of the axis at the points (``sign='error'``) or their negative, the amount
the controller must add to the command (``sign='correction'``). Between points the
controllers interpolate linearly (Siemens, Heidenhain) or step (Fanuc), so the spacing
decides how much of a curved error function survives.

Every value is rounded to the table's resolution; the readers of each format return
:class:`AxisTable` objects so a round trip can be checked against the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from volcal.errors import ParameterError, VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.kinematics import volumetric_error
from volcal.model.names import AXES, SQUARENESS_NAMES

SIGNS: tuple[str, str] = ("error", "correction")

# squareness -> (input axis, output axis, factor on  urad * mm -> um) (docs/conventions.md)
SQUARENESS_TERMS: dict[str, tuple[int, int, float]] = {
    "EC0Y": (1, 0, -1e-3),  # e_x gets -EC0Y * y
    "EB0Z": (2, 0, +1e-3),  # e_x gets +EB0Z * z
    "EA0Z": (2, 1, -1e-3),  # e_y gets -EA0Z * z
}


def sign_factor(sign: str) -> float:
    """Factor applied to the model errors: +1 for ``'error'``, -1 for ``'correction'``.

    Parameters
    ----------
    sign : str
        ``'error'`` (table = actual minus commanded position [um]) or ``'correction'``
        (table = the amount to add to the command, the negative error).

    Returns
    -------
    float
    """
    if sign not in SIGNS:
        raise ParameterError(f"{{sign=}}{sign!r}: expected 'error' or 'correction'")
    return 1.0 if sign == "error" else -1.0


@dataclass
class AxisTable:
    """One compensation table: an output error as a function of one input axis.

    Attributes
    ----------
    input_axis : int
        Axis whose position indexes the table (0, 1, 2 = X, Y, Z).
    output_axis : int
        Axis whose position is compensated; equal to ``input_axis`` for pitch tables.
    positions : ndarray, shape (n,)
        Uniform grid of the compensation points [mm].
    values : ndarray, shape (n,)
        Table values [um] in the table's sign convention.
    sign : str
        ``'error'`` or ``'correction'``.
    resolution_um : float
        Rounding step of the values [um].
    """

    input_axis: int
    output_axis: int
    positions: NDArray[np.float64]
    values: NDArray[np.float64]
    sign: str
    resolution_um: float

    @property
    def spacing(self) -> float:
        """Distance between compensation points [mm]."""
        return float(self.positions[1] - self.positions[0]) if self.positions.size > 1 else 0.0

    @property
    def name(self) -> str:
        """ISO 230-1 name of the tabulated error (``'EXX'``, ``'EYX'``...)."""
        return "E" + AXES[self.output_axis] + AXES[self.input_axis]


def axis_grid(lo: float, hi: float, spacing: float, anchor: float | None = None,
              max_points: int | None = None, what: str = "axis") -> NDArray[np.float64]:
    """Uniform compensation grid covering ``[lo, hi]`` with a node at ``anchor``.

    Parameters
    ----------
    lo, hi : float
        Travel to cover [mm].
    spacing : float
        Distance between points [mm], > 0.
    anchor : float, optional
        A point the grid must contain (reference point); default ``lo``.
    max_points : int, optional
        Controller limit of points; exceeding it raises.
    what : str
        Name used in messages.

    Returns
    -------
    ndarray
        Grid positions [mm]; the first ``<= lo``, the last ``>= hi``.

    Raises
    ------
    ParameterError
        A spacing that is not positive, or longer than the travel ``hi - lo``.
    VolcalInputError
        More points than ``max_points``.
    """
    if not math.isfinite(spacing) or spacing <= 0:
        raise ParameterError(f"{{spacing=}}{spacing}: expected a positive distance [mm]")
    if hi > lo and spacing > hi - lo + 1e-9:
        tenth = float(f"{(hi - lo) / 10:.2g}")
        raise ParameterError(
            f"{{spacing=}}{spacing:g}: longer than the travel of {what} ({hi - lo:g} mm): the "
            "table would hold one point inside the travel and take the error for a straight "
            f"line through a value beyond it; use a fraction of the travel (e.g. {tenth:g})")
    a = lo if anchor is None else float(anchor)
    j0 = math.floor((lo - a) / spacing + 1e-9)
    j1 = math.ceil((hi - a) / spacing - 1e-9)
    n = j1 - j0 + 1
    if max_points is not None and n > max_points:
        need = (hi - lo) / (max_points - 1) if max_points > 1 else float("inf")
        raise VolcalInputError(
            f"{what}: {n} compensation points at {spacing:g} mm spacing exceed the "
            f"controller's limit of {max_points}; use --spacing {math.ceil(need * 1000) / 1000:g}"
            " mm or more (or raise --max-points if your control allows)")
    if n > 1_000_000:
        raise VolcalInputError(f"{what}: {n} points; the spacing is too small")
    return a + spacing * np.arange(j0, j1 + 1, dtype=np.float64)


def require_finite(values: NDArray[np.float64], positions: NDArray[np.float64] | None,
                   what: str) -> NDArray[np.float64]:
    """The last guard of every writer: refuse a table holding a value that is not a number.

    A controller loads ``nan`` or ``inf`` as whatever its parser makes of it; no table is
    written from a model that gives one (a damaged model file, an error table or a
    :class:`~volcal.model.errorfunctions.MachineErrors` built with NaN).

    Parameters
    ----------
    values : array_like
        The table's values [um, or the unit of the table].
    positions : array_like or None
        Position of each value (first axis of ``values``) [mm], named in the message; a
        2-D array (the points of a 3-D grid) names the point.
    what : str
        The table, named in the message (``"LinuxCNC X.comp, forward"``).

    Returns
    -------
    ndarray
        ``values``, unchanged.

    Raises
    ------
    VolcalInputError
        At the first value that is not a finite number.
    """
    v = np.asarray(values, dtype=float)
    bad = np.flatnonzero(~np.isfinite(v).reshape(v.shape[0], -1).all(axis=1)) if v.ndim \
        else np.flatnonzero(~np.isfinite(v.reshape(1)))
    if bad.size:
        i = int(bad[0])
        at = ""
        if positions is not None:
            p = np.asarray(positions, dtype=float)
            at = (f" at {p[i]:g} mm" if p.ndim == 1 else
                  " at (" + ", ".join(f"{x:g}" for x in p[i]) + ") mm")
        raise VolcalInputError(f"{what}: the model gives a value that is not a finite number"
                               f"{at}; no table is written (is the model damaged? identify "
                               "again)")
    return values


def quantize(values_um: NDArray[np.float64], resolution_um: float) -> NDArray[np.float64]:
    """Round values to a table resolution [um] (the nearest multiple).

    Parameters
    ----------
    values_um : array_like
        Table values [um].
    resolution_um : float
        Rounding step of the table [um], > 0.

    Returns
    -------
    ndarray
        ``values_um`` rounded to the nearest multiple of ``resolution_um`` [um]
        (negative zeros turned into ``0.0``).
    """
    return np.round(np.asarray(values_um, dtype=float) / resolution_um) * resolution_um + 0.0


def pitch_table(errors: MachineErrors, axis: int, positions: NDArray[np.float64], sign: str,
                resolution_um: float) -> AxisTable:
    """Positioning error (EXX, EYY or EZZ) of one axis resampled onto a grid.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    axis : int
        0, 1, 2.
    positions : ndarray
        Grid [mm] (see :func:`axis_grid`).
    sign : str
        ``'error'`` or ``'correction'``.
    resolution_um : float
        Rounding step [um].

    Returns
    -------
    AxisTable
    """
    v = sign_factor(sign) * errors.component(axis, positions)[:, axis]
    require_finite(v, positions, f"{'E' + AXES[axis] * 2} table")
    return AxisTable(axis, axis, positions, quantize(v, resolution_um), sign, resolution_um)


def cross_values(errors: MachineErrors, input_axis: int, output_axis: int,
                 positions: NDArray[np.float64], include_squareness: bool = True
                 ) -> NDArray[np.float64]:
    """Straightness of ``input_axis`` in ``output_axis`` direction [um] (error sign).

    With ``include_squareness`` the linear squareness term whose lever is the input
    axis is added (``-EC0Y*y`` on X, ``+EB0Z*z`` on X, ``-EA0Z*z`` on Y), so the table
    carries the whole error of the output axis caused by moving the input axis on its
    reference line.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    input_axis : int
        Axis whose position indexes the table (0, 1, 2 = X, Y, Z).
    output_axis : int
        Direction of the straightness error (0, 1, 2), different from ``input_axis``.
    positions : ndarray, shape (n,)
        Positions of the input axis [mm].
    include_squareness : bool
        Add the squareness term whose lever is ``input_axis`` (default True).

    Returns
    -------
    ndarray, shape (n,)
        Error of the output axis [um], in the error sign (actual minus commanded).
    """
    v = errors.component(input_axis, positions)[:, output_axis].copy()
    if include_squareness:
        for name, (i_in, i_out, f) in SQUARENESS_TERMS.items():
            if (i_in, i_out) == (input_axis, output_axis):
                v += f * errors.squareness[SQUARENESS_NAMES.index(name)] * positions
    return v


def cross_table(errors: MachineErrors, input_axis: int, output_axis: int,
                positions: NDArray[np.float64], sign: str, resolution_um: float,
                include_squareness: bool = True) -> AxisTable:
    """Straightness (and squareness) table of one axis pair; see :func:`cross_values`.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    input_axis : int
        Axis whose position indexes the table (0, 1, 2 = X, Y, Z).
    output_axis : int
        Axis whose position is compensated (0, 1, 2), different from ``input_axis``.
    positions : ndarray, shape (n,)
        Grid of the input axis [mm] (see :func:`axis_grid`).
    sign : str
        ``'error'`` or ``'correction'``.
    resolution_um : float
        Rounding step of the values [um].
    include_squareness : bool
        Add the squareness term whose lever is ``input_axis`` (default True).

    Returns
    -------
    AxisTable
    """
    v = sign_factor(sign) * cross_values(errors, input_axis, output_axis, positions,
                                         include_squareness)
    require_finite(v, positions, f"E{AXES[output_axis]}{AXES[input_axis]} table")
    return AxisTable(input_axis, output_axis, positions, quantize(v, resolution_um), sign,
                     resolution_um)


def volumetric_grid(errors: MachineErrors, spacing: float, tool_offset=None,
                    max_points: int = 1_000_000):
    """Volumetric error on a 3-D grid covering the model's travel.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Grid spacing in X, Y and Z [mm].
    tool_offset : array_like, shape (3,), optional
        Target point on the tool [mm].
    max_points : int
        Largest grid accepted.

    Returns
    -------
    axes : list of 3 ndarrays
        Grid positions per axis [mm].
    points : ndarray, shape (m, 3)
        All grid points, X varying slowest [mm].
    e : ndarray, shape (m, 3)
        First-order volumetric error at the points [um] (Soons 2005, eq. 1).
    """
    t = errors.travel
    axes = [axis_grid(t[k, 0], t[k, 1], spacing, what=f"{AXES[k]} grid") for k in range(3)]
    n = math.prod(a.size for a in axes)
    if n > max_points:
        raise VolcalInputError(f"the 3-D grid would have {n} points (limit {max_points}); "
                               "use a larger --spacing")
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    e = volumetric_error(errors, g, tool_offset)
    return axes, g, require_finite(e, g, "3-D grid")
